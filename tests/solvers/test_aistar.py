"""Ai*: its integer distance map, its heuristic's error and its paths against Dijkstra's."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_grid.grid import Grid
from cbr_grid.movingai import load_map, load_scen
from cbr_grid.query import GridQuery
from cbr_solvers import AiStar
from cbr_solvers.aistar import (
    RISK_FREE_ERROR_BOUND,
    aistar,
    cost_map,
    distance_map,
    error_bound,
    heuristic_error,
    heuristic_map,
)
from cbr_solvers.search import dijkstra
from cbrcore.context import Context
from cbrcore.registry import NoOptions, Registry
from repo_paths import DATA

from .test_solvers import check_path, grid_problems

MOVINGAI = DATA / "movingai"
ARENA_SCENARIOS = 12


def test_distance_map_by_hand() -> None:
    # 3 x 3 with an obstacle in the middle, goal in the top left corner.
    passable = np.ones((3, 3), dtype=bool)
    passable[1, 1] = False

    # Without corner cutting no diagonal step passes the obstacle: only the border is walked.
    assert distance_map(passable, False, [(0, 0)]).tolist() == [
        [0, 3, 6],
        [3, -1, 9],
        [6, 9, 12],
    ]
    # With it (1, 0) -> (2, 1) passes (2, 0) and the obstacle: 3 + 4.
    assert distance_map(passable, True, [(0, 0)]).tolist() == [
        [0, 3, 6],
        [3, -1, 7],
        [6, 7, 10],
    ]
    # An open map: 3 per orthogonal step, 4 per diagonal step, from the nearer of two goals.
    assert distance_map(np.ones((2, 4), dtype=bool), False, [(0, 0), (3, 1)]).tolist() == [
        [0, 3, 4, 3],
        [3, 4, 3, 0],
    ]
    # A window: the map covers only it, and a goal outside it reaches nothing.
    assert distance_map(np.ones((3, 3), dtype=bool), False, [(2, 2)],
                        window=(1, 1, 5, 5)).tolist() == [[4, 3], [3, 0]]
    assert distance_map(np.ones((3, 3), dtype=bool), False, [(0, 0)],
                        window=(1, 1, 2, 2)).tolist() == [[-1, -1], [-1, -1]]


def test_heuristic_error_by_hand() -> None:
    # One open row and a 2 x 2 square, risk-free. Along the row the heuristic is exact; across
    # the square the diagonal is estimated 4/3 against sqrt(2).
    row = np.ones((1, 5))
    assert heuristic_error(row, row > 0, False, [(0, 0)]) == 0.0
    square = np.ones((2, 2))
    expected = (math.sqrt(2) - 4 / 3) / math.sqrt(2)
    assert heuristic_error(square, square > 0, False, [(0, 0)]) == pytest.approx(expected)
    assert expected == pytest.approx(RISK_FREE_ERROR_BOUND)

    # Risk widens it: factors 1 and 3 on a row. The heuristic takes 1 per step; the cell next
    # to the goal costs (1 + 3) / 2 = 2 to leave, the next 2 + 3 = 5.
    factor = np.array([[1.0, 3.0, 3.0]])
    assert heuristic_map(factor, factor > 0, False, [(0, 0)]).tolist() == [[0.0, 1.0, 2.0]]
    assert cost_map(factor, factor > 0, False, [(0, 0)]).tolist() == [[0.0, 2.0, 5.0]]
    assert heuristic_error(factor, factor > 0, False, [(0, 0)]) == pytest.approx(3 / 5)
    # The bound: 1 - 4 / (3 sqrt(2)) * fmin / fmax.
    assert error_bound(factor, factor > 0) == pytest.approx(1 - 4 / (3 * math.sqrt(2)) / 3)

    # Nothing else reaches the goal: no error to report.
    assert heuristic_error(np.ones((1, 1)), np.ones((1, 1), dtype=bool), False, [(0, 0)]) == 0.0


@settings(max_examples=150, deadline=None)
@given(grid_problems(), st.booleans())
def test_random_grids_match_dijkstra(problem: tuple, risk_free: bool) -> None:
    factor, passable, corner_cutting, start, goals, window = problem
    if risk_free:
        factor = np.ones_like(factor)

    found = dijkstra(factor, passable, corner_cutting, start, goals, window)
    informed = aistar(factor, passable, corner_cutting, start, goals, window)

    if found is None:
        assert informed is None
        return
    assert informed is not None
    check_path(informed, factor, passable, corner_cutting, start, goals, window)
    # The heuristic is admissible on every map, so Ai* is optimal: never cheaper than Dijkstra
    # (which is exact) and, up to rounding, never dearer.
    assert informed.cost >= found.cost * (1 - 1e-12)
    assert math.isclose(informed.cost, found.cost, rel_tol=1e-9)
    truth = cost_map(factor, passable, corner_cutting, goals, window)
    estimate = heuristic_map(factor, passable, corner_cutting, goals, window)
    reached = np.isfinite(truth)
    assert (estimate[reached] <= truth[reached] * (1 + 1e-12)).all()
    error = heuristic_error(factor, passable, corner_cutting, goals, window)
    bound = RISK_FREE_ERROR_BOUND if risk_free else error_bound(factor, passable, window)
    assert 0.0 <= error <= bound + 1e-12


def test_movingai_arena_optimal() -> None:
    grid = load_map(MOVINGAI / "maps" / "dao" / "arena.map")
    scenarios = load_scen(MOVINGAI / "scenarios" / "dao" / "arena.map.scen")
    chosen = np.linspace(0, len(scenarios) - 1, ARENA_SCENARIOS).round().astype(int)
    for scenario in (scenarios[i] for i in chosen):
        result = aistar(grid.factor, grid.passable, False, scenario.start, [scenario.goal])
        assert result is not None, scenario
        assert scenario.agrees(result.cost), (scenario, result.cost)
        check_path(result, grid.factor, grid.passable, False, scenario.start, [scenario.goal])
        assert grid.path_problems(result.path) == []
    error = heuristic_error(grid.factor, grid.passable, False, [scenarios[-1].goal])
    assert 0.0 <= error <= RISK_FREE_ERROR_BOUND + 1e-12


def test_aistar_component() -> None:
    # A wall at x = 2 with a gap in row 2; the component plans around it like Dijkstra.
    risk = np.zeros((3, 5))
    risk[0:2, 2] = 1.0
    grid = Grid(risk)
    ctx = Context(registry=Registry(), seed=0, world=grid)
    solver = AiStar(NoOptions(), ctx)

    solution = solver.cbr_solve(GridQuery((0, 0), (4, 0)), ctx)

    assert solution is not None
    assert solution.cost == pytest.approx(4 + 2 * math.sqrt(2))
    assert solution.detail["solver"] == "aistar"
    assert grid.path_problems(solution.value) == []
