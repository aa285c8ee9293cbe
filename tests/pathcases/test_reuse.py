"""Whole-path cases (``cbr_pathcases``): reuse, and the family in the engine.

Reuse is worked by hand on a free grid (the extension to the new ends, a loop cut, a reversed
path) and checked as a property on small random grids: whatever the connector, a reused path
starts at the query's start, ends at its goal and is valid on the map, and the genetic
improvement never returns a costlier path than the extended case. The engine test runs trips
between a few places on a small map with a capacity forgetter.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from cbr_grid.costs import path_cost
from cbr_grid.generate import generate
from cbr_grid.grid import Grid
from cbr_grid.query import GridQuery
from cbr_pathcases.base import PATH, base_of
from cbr_pathcases.components import PathReuser, ReuseOptions
from cbr_solvers.search import astar
from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.errors import CbrError
from cbrcore.model import Case, Match, Retrieval, Solution
from cbrcore.plugins import Plugins

from .test_pathcases import SQRT2, Cell, context, free, keep, retrieve, run, stored_ids

CONNECTORS = ("astar", "dijkstra", "randomized", "genetic")


def reuse(ctx: Context, retrieval: Retrieval, start: Cell, goal: Cell,
          **options: Any) -> Solution | None:
    reuser = PathReuser(ReuseOptions(**options), ctx)
    return reuser.cbr_reuse(problem=GridQuery(start, goal), retrieval=retrieval, ctx=ctx)


def match(path: np.ndarray, case_id: int) -> Match:
    """A retrieval's match of the stored ``path``, as offered (already turned if reversed)."""
    case = Case({"start": path[0].tolist(), "goal": path[-1].tolist()}, path.tolist(),
                kind=PATH, id=case_id)
    return Match(case, 1.0, {"probability": 1.0, "reversed": 0.0})


def assert_valid(grid: Grid, value: Any, start: Cell, goal: Cell) -> None:
    path = np.asarray(value)
    assert tuple(path[0]) == start and tuple(path[-1]) == goal
    assert (np.abs(np.diff(path, axis=0)).max(axis=1) == 1).all()
    assert grid.path_problems(value) == []


# --- worked by hand ---------------------------------------------------------------------------


@pytest.mark.parametrize("connector", CONNECTORS)
def test_the_case_is_extended_to_the_new_start_and_goal(connector: str) -> None:
    # . . . . . . . . . . . .
    # . s . . . . . . . . . .
    # . . a - - - - - b . . .
    # . . . . . . . . . g . .
    # the only shortest extensions are the two diagonal steps: F = 6 + 2 sqrt 2
    ctx = context(free(12, 6))
    case = keep(ctx, run((2, 2), (8, 2)), 1.0)
    found = retrieve(ctx, (1, 1), (9, 3), delta=2.0)
    # noise 0.2 keeps a noisy diagonal step (at most 1.2 sqrt 2) cheaper than two straight ones
    solution = reuse(ctx, found, (1, 1), (9, 3), connector=connector, generations=500, noise=0.2)
    assert solution is not None
    assert solution.value == run((1, 1), (2, 2), (8, 2), (9, 3)).tolist()
    assert solution.cost == pytest.approx(6 + 2 * SQRT2)
    assert solution.cases == (case,)
    assert solution.detail == {"case": case, "probability": 1.0, "reversed": False}


def test_a_reversed_case_is_driven_the_other_way() -> None:
    ctx = context(free(12, 6))
    case = keep(ctx, run((2, 2), (8, 2)), 1.0)
    found = retrieve(ctx, (9, 3), (1, 1), delta=2.0)
    solution = reuse(ctx, found, (9, 3), (1, 1))
    assert solution is not None
    assert solution.value == run((9, 3), (8, 2), (2, 2), (1, 1)).tolist()
    assert solution.cases == (case,) and solution.detail["reversed"] is True


def test_an_extension_back_along_the_case_is_cut_out() -> None:
    # a - - s - - - - b       the start lies on the case, 3 cells in: the extension runs back
    # . . . . . . . . g       to a and the case forward over s again; the loop is cut
    ctx = context(free(10, 4))
    keep(ctx, run((0, 1), (8, 1)), 1.0)
    found = retrieve(ctx, (3, 1), (8, 2), delta=5.0)
    solution = reuse(ctx, found, (3, 1), (8, 2))
    assert solution is not None
    assert solution.value == run((3, 1), (8, 1), (8, 2)).tolist()
    assert solution.cost == pytest.approx(6.0)


def test_the_next_candidate_is_tried_when_one_cannot_be_extended() -> None:
    #  # # # . . . . .
    #  # a - - - b . .     case 1, the cheaper: its start a is open only to the right, beyond
    #  # # # . . . . .     the margin of 1 around s and a, so no extension reaches it
    #  . a'- - - b'. .     case 2
    #  s . . . . . g .
    risk = np.zeros((5, 8))
    risk[2, :3] = 1
    risk[0:2, 0] = 1
    risk[0, 1:3] = 1
    ctx = context(Grid(risk))
    walled = keep(ctx, run((1, 1), (5, 1)), 1.0)
    other = keep(ctx, run((1, 3), (5, 3)), 1.25)
    found = retrieve(ctx, (0, 4), (6, 4), delta=4.0, selection="greedy")
    assert [m.case.id for m in found.matches] == [walled, other]
    solution = reuse(ctx, found, (0, 4), (6, 4), margin=1)
    assert solution is not None and solution.cases == (other,)
    assert_valid(ctx.world, solution.value, (0, 4), (6, 4))
    # nothing to extend: no solution
    assert reuse(ctx, Retrieval((found.matches[0],)), (0, 4), (6, 4), margin=1) is None


# --- properties on random grids ---------------------------------------------------------------


@st.composite
def scenes(draw: st.DrawFn) -> tuple[Grid, np.ndarray, Cell, Cell]:
    """A random grid, a stored path planned on it, and a query whose ends lie near the path's
    ends (within 3 cells each way) and can reach them."""
    width, height = draw(st.integers(6, 13)), draw(st.integers(6, 13))
    grid = generate("random", width, height, draw(st.integers(0, 2**16)),
                    density=draw(st.sampled_from([0.0, 0.1, 0.25])),
                    corner_cutting=draw(st.booleans()))
    free_cells = [(int(x), int(y)) for y, x in np.argwhere(grid.passable)]
    assume(len(free_cells) >= 2)
    a = draw(st.sampled_from(free_cells))
    b = draw(st.sampled_from(free_cells).filter(lambda c: c != a))
    stored = astar(grid.factor, grid.passable, grid.corner_cutting, a, [b])
    assume(stored is not None)
    near = st.tuples(st.integers(-3, 3), st.integers(-3, 3))
    (dx, dy), (ex, ey) = draw(near), draw(near)
    start, goal = (a[0] + dx, a[1] + dy), (b[0] + ex, b[1] + ey)
    assume(start in free_cells and goal in free_cells and start != goal)
    assume(astar(grid.factor, grid.passable, grid.corner_cutting, start, [goal]) is not None)
    return grid, stored.path, start, goal


@pytest.mark.parametrize("connector", CONNECTORS)
@settings(max_examples=25, deadline=None)
@given(scene=scenes(), reverse=st.booleans())
def test_every_reused_path_is_valid(connector: str, scene: tuple[Grid, np.ndarray, Cell, Cell],
                                    reverse: bool) -> None:
    grid, stored, start, goal = scene
    ctx = context(grid, seed=5)
    keep(ctx, stored[::-1] if reverse else stored, 1.0)
    found = retrieve(ctx, start, goal, delta=6.0)
    assert found.matches
    # the margin spans the grid, so a search that always finds a path (all but the genetic
    # algorithm's) always extends the case
    solution = reuse(ctx, found, start, goal, connector=connector, margin=20, generations=300)
    if connector != "genetic":
        assert solution is not None
    if solution is not None:
        assert_valid(grid, solution.value, start, goal)
        assert solution.cost == pytest.approx(path_cost(grid, solution.value))


@settings(max_examples=25, deadline=None)
@given(scene=scenes(), extra=st.integers(0, 2))
def test_the_genetic_improvement_is_never_costlier_than_the_extended_case(
        scene: tuple[Grid, np.ndarray, Cell, Cell], extra: int) -> None:
    grid, stored, start, goal = scene
    ctx = context(grid, seed=11)
    keep(ctx, stored, 1.0)
    # more candidates seed the population besides the chosen one
    for i in range(extra):
        keep(ctx, stored[: max(2, len(stored) - 1 - i)], 1.0 + i)
    found = retrieve(ctx, start, goal, delta=6.0, selection="greedy")
    extended = reuse(ctx, found, start, goal, margin=20)
    improved = reuse(ctx, found, start, goal, margin=20, improve="genetic", generations=400)
    assert extended is not None and improved is not None
    assert_valid(grid, improved.value, start, goal)
    assert improved.cost <= extended.cost + 1e-9
    assert improved.cases == extended.cases
    if improved.detail.get("improved"):
        assert improved.cost < extended.cost
    else:
        assert improved.value == extended.value


# --- in the engine ----------------------------------------------------------------------------

# A 20x12 floor with two rooms; trips go between five places.
FLOOR = """\
....................
....................
...#####....#####...
...#...#....#...#...
...#...#....#...#...
.......#........#...
...#...#....#.......
...#...#....#...#...
...#####....#####...
....................
....................
....................
"""
PLACES = [[0, 0], [19, 0], [5, 5], [14, 4], [10, 11]]
CAPACITY = 4


@pytest.fixture
def path_plugins(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    return cbr_plugins(entry_points=True,
                       environ={"CBR_PLUGINS": "core,grid,solvers,pathcases,pathquality"})


def floor_config(tmp_path: Path, forget: str = "worst_paths") -> dict[str, Any]:
    path = tmp_path / "floor.grid"
    path.write_text(FLOOR, encoding="utf-8")
    return {
        "seed": 3,
        "world": {"use": "map_file", "path": str(path)},
        "workload": {"use": "trips", "count": 60, "places": PLACES, "unknown_dynamic": 4,
                     "appear": 0.3},
        "retrieve": {"use": "path_cases", "delta": 2.0},
        "reuse": {"use": "path_cases"},
        "revise": {"use": "path_quality", "max_ratio": 1.5},
        "solver": "astar",
        "retain": ["risk_map", "path_cases"],
        "forget": [{"use": forget, "capacity": CAPACITY}],
    }


@pytest.mark.parametrize("forget", ["worst_paths", "least_used_paths"])
def test_trips_between_places_learn_within_the_capacity(
        path_plugins: Plugins, cbr_engine: Callable[..., Engine], tmp_path: Path,
        forget: str) -> None:
    engine = cbr_engine(floor_config(tmp_path, forget))
    store = engine.casebase
    sources = []
    for problem in engine.workload.queries(engine.ctx):
        planned_on = engine.ctx.world  # the robot's map, as it learns
        proposal = engine.solve(problem)
        assert proposal.solution is not None
        assert_valid(planned_on, proposal.solution.value, problem.start, problem.goal)
        outcome = engine.workload.execute(problem, proposal, engine.ctx)
        engine.learn(problem, proposal, outcome)
        count = store.count(PATH)
        assert 0 < count <= CAPACITY
        assert base_of(engine.ctx).ids.tolist() == stored_ids(store)
        sources.append(proposal.source)
    assert sources[0] == "solver:astar"
    assert engine.stats.queries == 60
    assert engine.stats.from_casebase == sources.count("casebase") > 0
    assert store.check() == []
    for case in store.cases(PATH):
        # driven on the true world, which only adds obstacles to the map
        assert engine.world.path_problems(case.solution) == []
        assert case.meta["cost"] >= 1.0 - 1e-9  # by the ratio, no path beats the ideal


def test_a_constrained_robot_is_refused_with_what_plans_for_it(
        cbr_engine: Callable[..., Engine], cbr_plugins: Callable[..., Plugins]) -> None:
    cbr_plugins(entry_points=True)
    with pytest.raises(CbrError, match=r"reuse 'path_cases'.*Forward.*reuse: casegraph"):
        cbr_engine({"world": {"use": "generated", "kind": "office", "width": 20,
                              "height": 20}, "kinematics": "forward",
                    "retrieve": "path_cases", "reuse": "path_cases"})
