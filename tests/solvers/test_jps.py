"""Jump point search: A*'s costs by brute force, the Moving AI optimal lengths, hand-worked
forced neighbours, windows and several goals, the hand-over to A*, the solver and ``cbr plan``."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_grid.costs import CostModel
from cbr_grid.grid import Grid
from cbr_grid.movingai import Scenario, load_map, load_scen
from cbr_grid.query import GridQuery
from cbr_kinematics import KINEMATICS
from cbr_kinematics.models import Forward
from cbr_solvers import JumpPointSearch, JumpPointSearchOptions
from cbr_solvers.jps import JumpResult, jps
from cbr_solvers.search import astar
from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.errors import CbrError
from cbrcore.plugins import Plugins
from cbrcore.registry import NoOptions, Registry
from cbrcore.testing import CliResult
from repo_paths import DATA

MOVINGAI = DATA / "movingai"
ARENA = MOVINGAI / "maps" / "dao" / "arena.map"
ARENA_SCEN = MOVINGAI / "scenarios" / "dao" / "arena.map.scen"
# The 512 x 512 maps hold 17 000 scenarios between them: the test takes this many of each, spread
# evenly over its file, and benchmarks/solvers.py --jps-all checks every one.
LARGE_MAP_SAMPLE = 300


def check_path(result: JumpResult, factor: float, passable: np.ndarray,
               start: tuple[int, int], goals: np.ndarray,
               window: tuple[int, int, int, int] | None = None) -> None:
    """The path is a legal walk from the start to a goal, inside the window, without cutting a
    corner, and costs what the result says."""
    path = result.path
    assert tuple(path[0]) == start
    assert any((path[-1] == goal).all() for goal in goals)
    steps = np.diff(path, axis=0)
    assert (np.abs(steps).max(axis=1, initial=1) == 1).all()
    assert passable[path[:, 1], path[:, 0]].all()
    if window is not None:
        x0, y0, x1, y1 = window
        assert ((path >= (x0, y0)) & (path <= (x1, y1))).all()
    diagonal = (np.abs(steps) == 1).all(axis=1)
    before, after = path[:-1][diagonal], path[1:][diagonal]
    assert passable[before[:, 1], after[:, 0]].all() and passable[after[:, 1], before[:, 0]].all()
    length = diagonal.sum() * math.sqrt(2) + (~diagonal).sum()
    assert result.cost == pytest.approx(length * factor, rel=1e-12, abs=1e-12)


@st.composite
def problems(draw: st.DrawFn) -> tuple:
    """A small grid of one cost factor, a start, one to three goals and maybe a window."""
    width = draw(st.integers(1, 12))
    height = draw(st.integers(1, 12))
    density = draw(st.sampled_from([0.0, 0.15, 0.3, 0.45]))
    seed = draw(st.integers(0, 2**32 - 1))
    passable = np.random.default_rng(seed).random((height, width)) >= density
    cell = st.tuples(st.integers(0, width - 1), st.integers(0, height - 1))
    start = draw(cell)
    goals = np.array(draw(st.lists(cell, min_size=1, max_size=3)))
    window = draw(st.none() | st.tuples(st.integers(-1, width - 1), st.integers(-1, height - 1),
                                        st.integers(0, width), st.integers(0, height)))
    factor = draw(st.sampled_from([1.0, 0.5, 3.0]))
    return passable, factor, start, goals, window


@settings(max_examples=300, deadline=None)
@given(problems())
def test_costs_equal_astar_on_random_grids(problem: tuple) -> None:
    passable, factor, start, goals, window = problem
    factors = np.full(passable.shape, factor)
    expected = astar(factors, passable, False, start, goals, window)
    found = jps(factors, passable, False, start, goals, window)
    if expected is None:
        assert found is None
        return
    assert found is not None and found.search == "jps"
    assert found.cost == pytest.approx(expected.cost, rel=1e-12, abs=1e-12)
    clipped = None if window is None else (max(window[0], 0), max(window[1], 0), window[2],
                                           window[3])
    check_path(found, factor, passable, start, goals, clipped)


def test_wide_grids_cross_the_words_of_the_bit_rows() -> None:
    # 64 cells a word: rows and columns of 150 cells span three words, and the scans cross them
    rng = np.random.default_rng(11)
    for density in (0.05, 0.2, 0.35):
        passable = rng.random((150, 140)) >= density
        factor = np.ones(passable.shape)
        free = np.argwhere(passable)[:, ::-1]
        for _ in range(15):
            start, goal = (tuple(int(v) for v in free[i]) for i in rng.integers(len(free), size=2))
            expected = astar(factor, passable, False, start, [goal])
            found = jps(factor, passable, False, start, [goal])
            assert (found is None) == (expected is None)
            if found is not None:
                assert found.cost == pytest.approx(expected.cost, rel=1e-12)
                check_path(found, 1.0, passable, start, np.array([goal]))


def grid_of(rows: list[str]) -> np.ndarray:
    return np.array([[c == "." for c in row] for row in rows])


def test_a_straight_jump_stops_where_the_wall_beside_it_ends() -> None:
    # Going east along row 1 from (0, 1): (1, 0) is open and (0, 0), beside the cell before, is
    # blocked, so (1, 0) is a forced neighbour of (1, 1), a jump point. The start, (1, 1) and the
    # goal are the only points settled. With corner cutting the path would step diagonally.
    passable = grid_of(["#...",
                        "...."])
    found = jps(np.ones(passable.shape), passable, False, (0, 1), [(1, 0)])
    assert found is not None
    assert found.path.tolist() == [[0, 1], [1, 1], [1, 0]]
    assert found.cost == 2.0 and found.expanded == 3


def test_a_straight_jump_passes_a_wall_that_goes_on() -> None:
    # Row 0 is blocked from column 0 to 2 and open from column 3: going east along row 1, (3, 1)
    # is the first cell whose upper neighbour is open behind a blocked one; the goal (5, 0) is
    # reached diagonally first from there, (3, 1) -> (4, 0) -> (5, 0).
    passable = grid_of(["###...",
                        "......"])
    found = jps(np.ones(passable.shape), passable, False, (0, 1), [(5, 0)])
    assert found is not None
    assert found.path.tolist() == [[0, 1], [1, 1], [2, 1], [3, 1], [4, 0], [5, 0]]
    assert found.cost == pytest.approx(4 + math.sqrt(2))
    assert found.expanded == 3


def test_a_diagonal_never_squeezes_past_a_blocked_corner() -> None:
    # (1, 1) -> (2, 0) would pass the blocked (2, 1); the path goes round by (1, 0).
    passable = grid_of(["...",
                        "..#",
                        "..."])
    found = jps(np.ones(passable.shape), passable, False, (0, 2), [(2, 0)])
    assert found is not None
    assert found.cost == pytest.approx(2 + math.sqrt(2))
    check_path(found, 1.0, passable, (0, 2), np.array([(2, 0)]))
    assert jps(np.ones(passable.shape), passable, False, (0, 0), [(2, 2)]).cost == (
        pytest.approx(2 + math.sqrt(2)))


def test_start_on_a_goal_blocked_and_unreachable_goals() -> None:
    passable = grid_of(["..#..",
                        "..#.."])
    factor = np.ones(passable.shape)
    found = jps(factor, passable, False, (1, 1), [(1, 1), (4, 0)])
    assert found is not None and found.path.tolist() == [[1, 1]] and found.cost == 0.0
    assert jps(factor, passable, False, (0, 0), [(4, 0)]) is None
    assert jps(factor, passable, False, (0, 0), [(2, 0)]) is None  # the goal is blocked
    assert jps(factor, passable, False, (2, 0), [(0, 0)]) is None  # so is the start
    assert jps(factor, passable, False, (0, 0), [(1, 0)], window=(3, 0, 4, 1)) is None


def movingai_cases() -> list[tuple[Path, Path]]:
    cases = []
    for scen in sorted(MOVINGAI.glob("scenarios/*/*.scen")):
        name = scen.name.removesuffix(".scen")
        if not name.endswith(".map"):
            name = name.rsplit("-random-", 1)[0] + ".map"  # the MAPF scenario naming
        cases.append((MOVINGAI / "maps" / scen.parent.name / name, scen))
    return cases


@pytest.mark.parametrize(("map_path", "scen"), movingai_cases(), ids=lambda p: p.name)
def test_movingai_optimal_lengths(map_path: Path, scen: Path) -> None:
    # Every scenario of the maps below 512 x 512, an evenly spread sample of the larger ones.
    grid = load_map(map_path)
    scenarios: list[Scenario] = load_scen(scen, grid)
    if grid.width * grid.height >= 512 * 512:
        picks = np.linspace(0, len(scenarios) - 1, LARGE_MAP_SAMPLE).round().astype(int)
        scenarios = [scenarios[i] for i in np.unique(picks)]
    wrong = []
    for scenario in scenarios:
        found = jps(grid.factor, grid.passable, grid.corner_cutting, scenario.start,
                    [scenario.goal])
        if found is None or not scenario.agrees(found.cost) or found.search != "jps":
            wrong.append((scenario.line, None if found is None else found.cost,
                          scenario.optimal))
    assert wrong == []
    check_path(found, 1.0, grid.passable, scenario.start, np.array([scenario.goal]))


def test_a_window_and_several_goals_as_a_local_search() -> None:
    # The case graph's connector: from a cell to the nearest of several cells inside a box.
    grid = load_map(MOVINGAI / "maps" / "dao" / "den312d.map")
    rng = np.random.default_rng(3)
    free = np.argwhere(grid.passable)[:, ::-1]
    searched = 0
    for _ in range(60):
        start = tuple(int(v) for v in free[rng.integers(len(free))])
        window = (start[0] - 12, start[1] - 9, start[0] + 10, start[1] + 13)
        goals = free[rng.integers(len(free), size=8)]
        goals = np.vstack([goals, np.clip(np.array(start) + rng.integers(-10, 11, size=(4, 2)),
                                          0, (grid.width - 1, grid.height - 1))])
        expected = astar(grid.factor, grid.passable, False, start, goals, window)
        found = jps(grid.factor, grid.passable, False, start, goals, window)
        assert (found is None) == (expected is None)
        if found is not None:
            searched += 1
            assert found.cost == pytest.approx(expected.cost, rel=1e-12)
            clipped = (max(window[0], 0), max(window[1], 0), min(window[2], grid.width - 1),
                       min(window[3], grid.height - 1))
            check_path(found, 1.0, grid.passable, start, goals, clipped)
    assert searched > 20


def test_unequal_costs_and_corner_cutting_hand_over_to_astar() -> None:
    rng = np.random.default_rng(8)
    passable = rng.random((20, 25)) >= 0.25
    passable[0, 0] = passable[19, 24] = True
    risky = 1.0 + rng.random(passable.shape)
    for factor, cutting in ((risky, False), (np.ones(passable.shape), True)):
        expected = astar(factor, passable, cutting, (0, 0), [(24, 19)])
        found = jps(factor, passable, cutting, (0, 0), [(24, 19)])
        assert (found is None) == (expected is None)
        if found is not None:
            assert found.search == "astar"
            assert found.cost == expected.cost and found.expanded == expected.expanded
            assert np.array_equal(found.path, expected.path)
    # a blocked cell's factor does not count, and one passable factor everywhere is uniform
    factor = np.where(passable, 2.0, 7.0)
    found = jps(factor, passable, False, (0, 0), [(24, 19)])
    expected = astar(factor, passable, False, (0, 0), [(24, 19)])
    assert (found is None) == (expected is None)
    if found is not None:
        assert found.search == "jps" and found.cost == pytest.approx(expected.cost)


def test_bad_input_is_refused_as_astar_refuses_it() -> None:
    passable = np.ones((3, 4), dtype=bool)
    factor = np.ones((3, 4))
    with pytest.raises(ValueError, match=r"start \(4, 0\) is outside the 4x3 grid"):
        jps(factor, passable, False, (4, 0), [(0, 0)])
    with pytest.raises(ValueError, match=r"goal \(.*0.*, .*3.*\) is outside the 4x3 grid"):
        jps(factor, passable, False, (0, 0), [(0, 3)])
    with pytest.raises(ValueError, match="shape"):
        jps(factor[:, :3], passable, False, (0, 0), [(1, 0)])
    for bad in (np.nan, 0.0, -1.0, np.inf):
        with pytest.raises(ValueError, match="finite and positive"):
            jps(np.full((3, 4), bad), passable, False, (0, 0), [(3, 2)])


def test_read_only_grids_are_packed_once_and_follow_changes() -> None:
    # A Grid's arrays are read-only, so their bits are kept; writable arrays are packed anew
    passable = np.ones((6, 6), dtype=bool)
    factor = np.ones((6, 6))
    assert jps(factor, passable, False, (0, 0), [(5, 5)]).cost == pytest.approx(5 * math.sqrt(2))
    passable[1:, 2] = False
    passable[:5, 4] = False
    assert jps(factor, passable, False, (0, 0), [(5, 5)]).cost == pytest.approx(
        astar(factor, passable, False, (0, 0), [(5, 5)]).cost)
    grid = Grid(np.where(passable, 0.0, 1.0))
    first = jps(grid.factor, grid.passable, False, (0, 0), [(5, 5)])
    again = jps(grid.factor, grid.passable, False, (0, 0), [(5, 5)])
    # round both walls: east along row 0, down column 3, east along row 5, no diagonal allowed
    assert first == again and first.cost == 10.0


def test_the_jps_solver_answers_through_the_engine(
        solver_plugins: Plugins, cbr_engine: Callable[..., Engine]) -> None:
    scenario = max(load_scen(ARENA_SCEN), key=lambda s: s.optimal)
    engine = cbr_engine({"world": {"use": "movingai", "map": str(ARENA)}, "solver": "jps"})

    proposal = engine.solve(GridQuery(scenario.start, scenario.goal))

    assert proposal.source == "solver:jps"
    solution = proposal.solution
    assert solution is not None and scenario.agrees(solution.cost)
    assert solution.value[0] == list(scenario.start) and solution.value[-1] == list(scenario.goal)
    assert engine.world.path_problems(solution.value) == []
    assert solution.detail["solver"] == "jps" and solution.detail["search"] == "jps"
    assert 0 < solution.detail["expanded"] < len(solution.value)


def test_on_a_risky_grid_the_solver_says_astar_planned() -> None:
    risk = np.zeros((3, 7))
    risk[1, 2] = 0.9
    grid = Grid(risk, cost_model=CostModel(risk_weight=10.0))
    ctx = Context(registry=Registry(), seed=0, world=grid)
    solver = JumpPointSearch(NoOptions(), ctx)
    solution = solver.cbr_solve(GridQuery((0, 1), (4, 1)), ctx)
    assert solution is not None and [2, 1] not in solution.value
    assert solution.cost == pytest.approx(2 + 2 * math.sqrt(2))
    assert solution.detail["search"] == "astar"
    free = Grid(np.zeros((3, 7)))
    ctx = Context(registry=Registry(), seed=0, world=free)
    assert JumpPointSearch(NoOptions(), ctx).cbr_solve(GridQuery((0, 1), (4, 1)), ctx).detail[
        "search"] == "jps"


def test_the_solver_refuses_constrained_kinematics(
        cbr_plugins: Callable[..., Plugins], cbr_engine: Callable[..., Engine]) -> None:
    cbr_plugins(entry_points=True)
    with pytest.raises(CbrError, match="jump point search plans for robots that may make any "
                       "move, not for kinematics 'forward'"):
        cbr_engine({"world": {"use": "movingai", "map": str(ARENA)}, "solver": "jps",
                    "kinematics": "forward"})
    # a context built in code has no configuration reading to check it
    grid = Grid(np.zeros((3, 7)))
    ctx = Context(registry=Registry(), seed=0, world=grid)
    ctx.stash[KINEMATICS] = Forward()
    with pytest.raises(CbrError, match="'jps' plans for robots that may make any move"):
        JumpPointSearch(JumpPointSearchOptions(), ctx)


def test_cbr_plan_with_jps(cbr_plugins: Callable[..., Plugins],
                           invoke_cbr: Callable[..., CliResult]) -> None:
    cbr_plugins(entry_points=True)
    scenario = max(load_scen(ARENA_SCEN), key=lambda s: s.optimal)
    result = invoke_cbr("plan", str(ARENA), "--start", f"{scenario.start[0]},{scenario.start[1]}",
                     "--goal", f"{scenario.goal[0]},{scenario.goal[1]}", "--solver", "jps",
                     "--json")
    assert result.exit_code == 0, result.stderr
    record = json.loads(result.stdout)
    assert record["solver"] == "jps" and record["search"] == "jps"
    assert scenario.agrees(record["length"]) and record["cost"] == pytest.approx(record["length"])
    result = invoke_cbr("plan", str(ARENA), "--scen", str(ARENA_SCEN), "--solver", "jps", "--json")
    assert result.exit_code == 0, result.stderr
    summary = json.loads(result.stdout.splitlines()[-1])
    assert summary["matched"] == summary["total"] == 160
