"""The experience-graph reuser (``reuse: experience_graph``) and the reviser's guarantee branch.

The bound is checked against Dijkstra's optimum on random grids with random risk and retained
paths, some of them crossed afterwards by new obstacles; a ride along a stored segment is worked
out by hand (drawn: x to the right, y downwards).
"""

from __future__ import annotations

import csv
import heapq
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cbr_casegraph.experience import plan
from cbr_casegraph.graph import CaseGraph
from cbr_grid.costs import path_cost
from cbr_grid.grid import Grid
from cbr_grid.query import GridQuery, without_loops
from cbr_pathquality.reviser import QualityOptions, QualityTest
from cbr_solvers.search import dijkstra
from cbrcore.casebase.memory import MemoryStore
from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.errors import CbrError
from cbrcore.model import Solution
from cbrcore.registry import Registry
from cbrcore.run import run_workload
from repo_paths import ROOT

CONFIG = ROOT / "configs" / "hybrid_grid_egraph.yaml"
FACTORS = st.sampled_from([1.0, 1.1, 1.25, 1.5, 2.0, 3.0])


def optimum(grid: Grid, start: tuple[int, int], goal: tuple[int, int]) -> float | None:
    found = dijkstra(grid.factor, grid.passable, grid.corner_cutting, start, [goal])
    return None if found is None else found.cost


@st.composite
def worlds(draw: st.DrawFn) -> tuple[CaseGraph, tuple[int, int], tuple[int, int]]:
    """A random grid with risk and obstacles, a case graph of a few retained optimal paths
    (then, sometimes, obstacles dropped on them), and a query between two free cells."""
    width, height = draw(st.integers(6, 18)), draw(st.integers(6, 18))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    risk = np.where(rng.random((height, width)) < 0.25, 1.0,
                    rng.random((height, width)) * draw(st.sampled_from([0.0, 0.9])))
    grid = Grid(risk, corner_cutting=draw(st.booleans()))
    free = np.argwhere(grid.passable)[:, ::-1]
    if len(free) < 2:
        risk[0, 0] = risk[0, 1] = 0.0
        grid = Grid(risk, corner_cutting=grid.corner_cutting)
        free = np.argwhere(grid.passable)[:, ::-1]
    graph = CaseGraph(grid)
    for _ in range(draw(st.integers(0, 4))):
        a, b = rng.choice(len(free), 2)
        found = dijkstra(grid.factor, grid.passable, grid.corner_cutting, free[a], [free[b]])
        if found is not None and len(found.path) > 1:
            graph.add_path(found.path)
    if draw(st.booleans()):
        # the map changes under the stored segments: some now cross an obstacle
        changed = risk.copy()
        changed[rng.random(risk.shape) < 0.1] = 1.0
        s, g = free[rng.choice(len(free), 2)]
        changed[s[1], s[0]] = changed[g[1], g[0]] = 0.0
        grid = Grid(changed, corner_cutting=grid.corner_cutting)
        graph.set_grid(grid)
        return graph, (int(s[0]), int(s[1])), (int(g[0]), int(g[1]))
    s, g = free[rng.choice(len(free), 2)]
    return graph, (int(s[0]), int(s[1])), (int(g[0]), int(g[1]))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(worlds(), FACTORS, FACTORS)
def test_every_path_is_valid_and_within_the_bound(
        world: tuple[CaseGraph, tuple[int, int], tuple[int, int]], epsilon: float,
        experience: float) -> None:
    graph, start, goal = world
    grid = graph.grid
    best = optimum(grid, start, goal)
    found = plan(graph, start, goal, epsilon, experience)
    if best is None:
        assert found is None
        return
    assert found is not None
    path = found.path
    assert grid.path_problems(path) == []
    assert tuple(path[0]) == start and tuple(path[-1]) == goal
    assert len({tuple(c) for c in path.tolist()}) == len(path)  # no loops
    assert found.cost == pytest.approx(path_cost(grid, path))
    assert found.bound == epsilon * experience
    assert found.cost <= epsilon * experience * best + 1e-9
    assert set(found.edges) <= set(graph.edge_ids().tolist())
    if epsilon == experience == 1.0:
        assert found.cost == pytest.approx(best)


STEPS = [(dx, dy) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if (dx, dy) != (0, 0)]


def allowed(grid: Grid, x: int, y: int, dx: int, dy: int) -> bool:
    """The corner rule, written out: a step onto a passable cell; a diagonal one passes the two
    cells beside it, both passable (one with corner cutting)."""
    nx, ny = x + dx, y + dy
    if not (0 <= nx < grid.width and 0 <= ny < grid.height and grid.passable[ny, nx]):
        return False
    if dx == 0 or dy == 0:
        return True
    beside = (bool(grid.passable[y, nx]), bool(grid.passable[ny, x]))
    return any(beside) if grid.corner_cutting else all(beside)


def reference_optimum(grid: Grid, start: tuple[int, int], goal: tuple[int, int]
                      ) -> float | None:
    """Dijkstra's algorithm in plain Python over the grid's step costs, sharing no code with
    the compiled searches: the cheapest cost from start to goal, None when unreachable."""
    best = {start: 0.0}
    frontier = [(0.0, start)]
    while frontier:
        cost, (x, y) = heapq.heappop(frontier)
        if (x, y) == goal:
            return cost
        if cost > best[(x, y)]:
            continue
        for dx, dy in STEPS:
            if not allowed(grid, x, y, dx, dy):
                continue
            step = math.hypot(dx, dy) * (grid.factor[y, x] + grid.factor[y + dy, x + dx]) / 2
            other = (x + dx, y + dy)
            if cost + step < best.get(other, math.inf):
                best[other] = cost + step
                heapq.heappush(frontier, (cost + step, other))
    return None


@st.composite
def walked_worlds(draw: st.DrawFn) -> tuple[CaseGraph, tuple[int, int], tuple[int, int]]:
    """A random grid, uniform (every passable cell of one factor, where the search counts
    steps) or with risk, and a case graph of random walks: experience that is valid but far
    from optimal, crossing itself and other walks."""
    width, height = draw(st.integers(5, 16)), draw(st.integers(5, 16))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    blocked = rng.random((height, width)) < draw(st.sampled_from([0.0, 0.15, 0.3]))
    spread = draw(st.sampled_from([0.0, 0.0, 0.5, 0.9]))
    risk = np.where(blocked, 1.0, rng.random((height, width)) * spread)
    risk[0, 0] = risk[height - 1, width - 1] = 0.0
    grid = Grid(risk, corner_cutting=draw(st.booleans()))
    graph = CaseGraph(grid)
    free = np.argwhere(grid.passable)[:, ::-1]
    for _ in range(draw(st.integers(0, 5))):
        x, y = (int(v) for v in free[rng.integers(len(free))])
        walk = [(x, y)]
        for _ in range(int(rng.integers(1, 3 * (width + height)))):
            moves = [(dx, dy) for dx, dy in STEPS if allowed(grid, x, y, dx, dy)]
            if not moves:
                break
            dx, dy = moves[rng.integers(len(moves))]
            x, y = x + dx, y + dy
            walk.append((x, y))
        walk = without_loops(walk)
        if len(walk) > 1:
            graph.add_path(walk)
    s, g = free[rng.choice(len(free), 2)] if len(free) > 1 else (free[0], free[0])
    return graph, (int(s[0]), int(s[1])), (int(g[0]), int(g[1]))


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(walked_worlds(), st.sampled_from([1.0, 1.0, 1.1, 1.35, 2.0]),
       st.sampled_from([1.0, 1.0, 1.1, 1.5, 3.0]))
def test_the_bound_holds_against_an_independent_dijkstra_with_random_experience(
        world: tuple[CaseGraph, tuple[int, int], tuple[int, int]], epsilon: float,
        experience: float) -> None:
    # the tie rule and the uniform step counts only choose among cells of equal f, so the
    # bound holds, and at epsilon = eps_E = 1 the path is optimal
    graph, start, goal = world
    best = reference_optimum(graph.grid, start, goal)
    found = plan(graph, start, goal, epsilon, experience)
    if best is None:
        assert found is None
        return
    assert found is not None
    assert graph.grid.path_problems(found.path) == []
    assert tuple(found.path[0]) == start and tuple(found.path[-1]) == goal
    assert found.cost == pytest.approx(path_cost(graph.grid, found.path))
    assert found.cost <= epsilon * experience * best * (1 + 1e-12) + 1e-9
    if epsilon == experience == 1.0:
        assert found.cost == pytest.approx(best, rel=1e-12)


@pytest.mark.parametrize(("epsilon", "experience"), [(1.0, 1.0), (1.35, 1.1), (1.0, 1.5)])
def test_open_ground_is_crossed_without_expanding_a_plateau(epsilon: float,
                                                            experience: float) -> None:
    # on a free uniform map every cell of the rectangle between start and goal lies on a
    # cheapest path, a plateau of equal f at epsilon = eps_E = 1; the tie rule takes the cell
    # nearest the goal, so only the path's own cells are expanded (no case: no ride)
    graph = CaseGraph(Grid(np.zeros((40, 60))))
    found = plan(graph, (2, 3), (57, 36), epsilon, experience)
    assert found is not None
    assert found.detail["expanded"] == len(found.path)
    if epsilon == experience == 1.0:
        assert found.cost == pytest.approx(22 + 33 * np.sqrt(2))


def corridor() -> tuple[CaseGraph, int]:
    """A free 20x7 grid with one stored segment along row 3, from (1, 3) to (18, 3)."""
    graph = CaseGraph(Grid(np.zeros((7, 20))))
    graph.add_path([(x, 3) for x in range(1, 19)])
    (edge,) = graph.edge_ids().tolist()
    return graph, edge


def test_a_stored_segment_is_ridden_in_one_step() -> None:
    # H(start vertex) = 17 (ride to the goal's vertex); every neighbour of the start has
    # h^E >= 2 + 17 - ... > 17 / epsilon, so the goal, reached by the ride at g = 17, is the
    # second cell expanded
    graph, edge = corridor()
    found = plan(graph, (1, 3), (18, 3), 1.5, 2.0)
    assert found is not None
    assert found.edges == (edge,)
    assert found.path.tolist() == [[x, 3] for x in range(1, 19)]
    assert found.cost == pytest.approx(17.0)
    assert found.detail["expanded"] == 2
    assert found.detail["shortcuts"] == 1
    # the route's vertex at the goal is left out of K: its term is the jump to the goal itself
    assert found.detail["route_vertices"] == 1


def test_a_segment_crossing_a_new_obstacle_is_not_ridden() -> None:
    graph, _ = corridor()
    risk = np.zeros((7, 20))
    risk[3, 10] = 1.0
    graph.set_grid(Grid(risk))
    found = plan(graph, (1, 3), (18, 3), 1.5, 2.0)
    assert found is not None
    assert found.edges == ()
    assert [10, 3] not in found.path.tolist()
    # around the obstacle: 16 straight steps and two diagonals
    assert found.cost <= 3.0 * (15 + 2 * np.sqrt(2)) + 1e-9
    assert Grid(risk).path_problems(found.path) == []


def test_factors_below_one_are_refused() -> None:
    graph, _ = corridor()
    with pytest.raises(CbrError, match=r"epsilon 0\.5"):
        plan(graph, (1, 3), (18, 3), 0.5, 2.0)


# --- the quality test's guarantee branch --------------------------------------------------------


def review(solution: Solution, max_ratio: float = 1.5) -> tuple[bool, str]:
    grid = Grid(np.zeros((10, 10)))
    ctx = Context(registry=Registry(), seed=0, world=grid, casebase=MemoryStore())
    test = QualityTest(QualityOptions(max_ratio=max_ratio, ideal="octile"), ctx)
    verdict = test.cbr_revise(problem=GridQuery((0, 0), (2, 0)), solution=solution, ctx=ctx)
    return verdict.accepted, verdict.reason


DETOUR = [(0, 0), (0, 1), (0, 2), (1, 3), (2, 2), (2, 1), (2, 0)]
"""A valid path from (0, 0) to (2, 0) of length 4 + 2·sqrt(2), 3.4 times the octile distance."""


def test_a_guaranteed_bound_within_max_ratio_is_accepted_without_the_length_test() -> None:
    assert review(Solution(DETOUR)) == (False, "length ratio above 1.5")
    assert review(Solution(DETOUR, bound=1.5)) == (True, "")
    assert review(Solution(DETOUR, bound=1.2), max_ratio=1.2) == (True, "")


def test_a_bound_above_max_ratio_is_tested_like_any_path() -> None:
    assert review(Solution(DETOUR, bound=2.0)) == (False, "length ratio above 1.5")


def test_a_bound_below_one_or_only_in_the_detail_is_no_guarantee() -> None:
    # below 1 the claim is impossible (cheaper than the cheapest path); the detail is for people
    assert review(Solution(DETOUR, bound=0.5)) == (False, "length ratio above 1.5")
    assert review(Solution(DETOUR, detail={"bound": 1.5})) == (False, "length ratio above 1.5")


def test_a_guaranteed_path_must_still_be_valid_and_join_start_and_goal() -> None:
    assert review(Solution([(0, 0), (2, 0)], bound=1.0)) == (
        False, "invalid on the current map")
    assert review(Solution([(0, 0), (1, 0)], bound=1.0)) == (
        False, "does not connect start and goal")


# --- the engine ----------------------------------------------------------------------------------

SMALL = ["world.width=60", "world.height=60", "workload.count=40"]


def test_the_engine_runs_the_experience_graph_config(tmp_path: Path) -> None:
    with Engine.from_yaml(CONFIG, overrides=SMALL, out_dir=tmp_path) as engine:
        bound = engine.components["reuse"].options.bound
        run_workload(engine, tmp_path)
    with (tmp_path / "results.csv").open(newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    reused = [row for row in rows if row["source"] == "casebase"]
    assert len(reused) > len(rows) // 3
    # the bound is on the map the robot planned on, which the deviation is measured on
    assert bound <= 1.5
    assert max(float(row["deviation"]) for row in reused) <= bound - 1 + 1e-9


def test_a_constrained_robot_is_refused_at_configuration_time(tmp_path: Path) -> None:
    with pytest.raises(CbrError, match="experience-graph search plans for robots"):
        Engine.from_yaml(CONFIG, overrides=[*SMALL, "kinematics=forward"], out_dir=tmp_path)
