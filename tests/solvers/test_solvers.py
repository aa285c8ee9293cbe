"""The grid searches of cbr_solvers: optimal on Moving AI benchmarks, exact on small grids."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra as reference_dijkstra

from cbr_grid import grid as grid_module
from cbr_grid.costs import CostModel, broadcast_factor, path_cost, uniform_factor
from cbr_grid.grid import Grid
from cbr_grid.movingai import Scenario, load_map, load_scen
from cbr_grid.query import GridQuery
from cbr_solvers import AStar, Dijkstra, GridSolver
from cbr_solvers import search as search_module
from cbr_solvers.aistar import aistar, cost_map
from cbr_solvers.jps import jps
from cbr_solvers.search import SearchResult, astar, dijkstra
from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.errors import CbrError
from cbrcore.plugins import Plugins
from cbrcore.registry import NoOptions, Registry
from repo_paths import DATA

MOVINGAI = DATA / "movingai"
SEARCHES = {"dijkstra": dijkstra, "astar": astar}
SAMPLES_PER_FILE = 10
EIGHT = [(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if (dx, dy) != (0, 0)]

Search = Callable[..., SearchResult | None]


SCENARIO_FILES = sorted(MOVINGAI.glob("scenarios/*/*.scen"))


def sample_scenarios(path: Path) -> list[Scenario]:
    """Scenarios spread over the buckets: the last of each of up to 10 evenly spaced buckets."""
    last_of_bucket = {s.bucket: s for s in load_scen(path)}
    buckets = sorted(last_of_bucket)
    chosen = np.unique(np.linspace(0, len(buckets) - 1, SAMPLES_PER_FILE).round().astype(int))
    return [last_of_bucket[buckets[i]] for i in chosen]


def scenario_grid(scen: Path, scenarios: list[Scenario]) -> Grid:
    """The map of a scenario file; the scenarios' map column gives its name, not its folder."""
    return load_map(MOVINGAI / "maps" / scen.parent.name / Path(scenarios[0].map_name).name)


@pytest.mark.parametrize("scen", SCENARIO_FILES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_movingai_optimal_lengths(scen: Path) -> None:
    # Scenario.agrees allows one unit in the last printed digit and 1e-9 relative: the files
    # printing 8 decimals are up to about 1e-7 off the exact lengths, more than half a unit.
    # Distinct octile lengths below 1000 differ by more than 1e-4, so it still tells an optimal
    # path from any other.
    scenarios = sample_scenarios(scen)
    grid = scenario_grid(scen, scenarios)
    assert grid.corner_cutting is False
    for scenario in scenarios:
        for name, search in SEARCHES.items():
            result = search(grid.factor, grid.passable, False, scenario.start, [scenario.goal])
            assert result is not None, (name, scenario)
            assert scenario.agrees(result.cost), (name, scenario, result.cost)
            check_path(result, grid.factor, grid.passable, False, scenario.start,
                       [scenario.goal])
            assert grid.path_problems(result.path) == []


@pytest.mark.parametrize("scen", SCENARIO_FILES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_movingai_optimal_lengths_with_the_factor_held_once(
        scen: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # Large grids hold a factor shared by every passable cell once; lowered here to every grid,
    # the searches find what they find on a full array of it: the same optimal paths.
    monkeypatch.setattr(grid_module, "UNIFORM_FACTOR_CELLS", 0)
    scenarios = sample_scenarios(scen)[::2]
    grid = scenario_grid(scen, scenarios)
    assert uniform_factor(grid.factor) == 1.0
    full = np.array(grid.factor)
    for scenario in scenarios:
        for search in (dijkstra, astar, aistar, jps):
            held = search(grid.factor, grid.passable, False, scenario.start, [scenario.goal])
            plain = search(full, grid.passable, False, scenario.start, [scenario.goal])
            assert held is not None and plain is not None
            assert scenario.agrees(held.cost), (search.__name__, scenario, held.cost)
            assert (held.cost, held.expanded) == (plain.cost, plain.expanded)
            assert np.array_equal(held.path, plain.path)
    goal = [scenarios[-1].goal]
    assert np.array_equal(cost_map(grid.factor, grid.passable, False, goal),
                          cost_map(full, grid.passable, False, goal))


def corner_allowed(passable: np.ndarray, corner_cutting: bool, ax: int, ay: int, bx: int,
                   by: int) -> bool:
    """Whether the diagonal step a -> b may pass the two cells beside it.

    Without corner cutting both must be passable, with it at least one.
    """
    beside = (bool(passable[ay, bx]), bool(passable[by, ax]))
    return any(beside) if corner_cutting else all(beside)


def contract_cost(path: np.ndarray, factor: np.ndarray) -> float:
    """A path's cost recomputed from the cost contract."""
    total = 0.0
    for (ax, ay), (bx, by) in itertools.pairwise(path):
        length = math.sqrt(2.0) if ax != bx and ay != by else 1.0
        total += length * (factor[ay, ax] + factor[by, bx]) / 2
    return total


def check_path(result: SearchResult, factor: np.ndarray, passable: np.ndarray,
               corner_cutting: bool, start: tuple[int, int], goals: list[tuple[int, int]],
               window: tuple[int, int, int, int] | None = None) -> None:
    """Assert the path is a legal walk from the start to a goal costing what was reported."""
    path = result.path
    assert path.ndim == 2 and path.shape[1] == 2 and path.dtype.kind == "i"
    assert tuple(path[0]) == tuple(start)
    assert tuple(path[-1]) in {tuple(g) for g in goals}
    assert all(passable[y, x] for x, y in path)
    if window is not None:
        x0, y0, x1, y1 = window
        assert all(x0 <= x <= x1 and y0 <= y <= y1 for x, y in path)
    for (ax, ay), (bx, by) in itertools.pairwise(path):
        assert (bx - ax, by - ay) in EIGHT
        if ax != bx and ay != by:
            assert corner_allowed(passable, corner_cutting, ax, ay, bx, by), ((ax, ay), (bx, by))
    assert math.isclose(contract_cost(path, factor), result.cost, rel_tol=1e-12, abs_tol=1e-12)
    assert result.expanded >= 1


def reference_cost(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
                   start: tuple[int, int], goals: list[tuple[int, int]],
                   window: tuple[int, int, int, int] | None) -> float:
    """The cheapest cost by scipy's Dijkstra on the explicitly built graph of the contract."""
    h, w = passable.shape
    x0, y0, x1, y1 = window if window is not None else (0, 0, w - 1, h - 1)

    def usable(x: int, y: int) -> bool:
        return x0 <= x <= x1 and y0 <= y <= y1 and 0 <= x < w and 0 <= y < h and passable[y, x]

    rows, cols, weights = [], [], []
    for y in range(h):
        for x in range(w):
            if not usable(x, y):
                continue
            for dx, dy in EIGHT:
                nx, ny = x + dx, y + dy
                if not usable(nx, ny):
                    continue
                diagonal = dx != 0 and dy != 0
                if diagonal and not corner_allowed(passable, corner_cutting, x, y, nx, ny):
                    continue
                length = math.sqrt(2.0) if diagonal else 1.0
                rows.append(y * w + x)
                cols.append(ny * w + nx)
                weights.append(length * (factor[y, x] + factor[ny, nx]) / 2)
    if not usable(*start):
        return math.inf
    graph = coo_matrix((weights, (rows, cols)), shape=(h * w, h * w)).tocsr()
    dist = reference_dijkstra(graph, directed=True, indices=start[1] * w + start[0])
    return min((dist[gy * w + gx] for gx, gy in goals if usable(gx, gy)), default=math.inf)


@st.composite
def grid_problems(draw: st.DrawFn) -> tuple:
    """A small grid with obstacles and factors in [1, 3], a start, 1-3 goals and maybe a window."""
    h = draw(st.integers(1, 8))
    w = draw(st.integers(1, 8))
    blocked = draw(st.floats(0.0, 0.5))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    passable = rng.random((h, w)) >= blocked
    factor = rng.uniform(1.0, 3.0, (h, w))
    corner_cutting = draw(st.booleans())
    cell = st.tuples(st.integers(0, w - 1), st.integers(0, h - 1))
    start = draw(cell)
    goals = draw(st.lists(cell, min_size=1, max_size=3))
    window = None
    if draw(st.booleans()):
        xs = sorted(draw(st.tuples(st.integers(-1, w), st.integers(-1, w))))
        ys = sorted(draw(st.tuples(st.integers(-1, h), st.integers(-1, h))))
        window = (xs[0], ys[0], xs[1], ys[1])
    return factor, passable, corner_cutting, start, goals, window


@settings(max_examples=200, deadline=None)
@given(grid_problems())
def test_random_grids_match_the_reference(problem: tuple) -> None:
    factor, passable, corner_cutting, start, goals, window = problem
    expected = reference_cost(factor, passable, corner_cutting, start, goals, window)

    found = dijkstra(factor, passable, corner_cutting, start, goals, window)
    informed = astar(factor, passable, corner_cutting, start, goals, window)

    if math.isinf(expected):
        assert found is None and informed is None
        return
    assert found is not None and informed is not None
    assert math.isclose(found.cost, expected, rel_tol=1e-9)
    assert math.isclose(informed.cost, found.cost, rel_tol=1e-9)
    for result in (found, informed):
        check_path(result, factor, passable, corner_cutting, start, goals, window)


def wall_grid() -> tuple[np.ndarray, np.ndarray]:
    """5 wide, 3 high, a wall at x = 2 on rows 0 and 1: the only gap is (2, 2)."""
    passable = np.ones((3, 5), dtype=bool)
    passable[0:2, 2] = False
    return np.ones(passable.shape), passable


@pytest.mark.parametrize("search", SEARCHES.values(), ids=SEARCHES.keys())
def test_through_the_gap(search: Search) -> None:
    factor, passable = wall_grid()

    # Without corner cutting, (1, 1) -> (2, 2) would cut the wall's corner at (2, 1).
    result = search(factor, passable, False, (0, 0), [(4, 0)])
    assert result is not None
    assert result.cost == pytest.approx(4 + 2 * math.sqrt(2))
    check_path(result, factor, passable, False, (0, 0), [(4, 0)])

    cutting = search(factor, passable, True, (0, 0), [(4, 0)])
    assert cutting is not None
    assert cutting.path.tolist() == [[0, 0], [1, 1], [2, 2], [3, 1], [4, 0]]
    assert cutting.cost == pytest.approx(4 * math.sqrt(2))

    # Corner cutting never squeezes between two obstacles.
    diagonal = np.array([[True, False], [False, True]])
    assert search(np.ones((2, 2)), diagonal, True, (0, 0), [(1, 1)]) is None


@pytest.mark.parametrize("search", SEARCHES.values(), ids=SEARCHES.keys())
def test_windows(search: Search) -> None:
    factor, passable = wall_grid()

    # The window without row 2 has no gap; a window covering the grid, or beyond it, changes
    # nothing; a start outside the window has no path in it.
    assert search(factor, passable, False, (0, 0), [(4, 0)], window=(0, 0, 4, 1)) is None
    full = search(factor, passable, False, (0, 0), [(4, 0)])
    assert full is not None
    for window in [(0, 0, 4, 2), (-3, -3, 9, 9)]:
        inside = search(factor, passable, False, (0, 0), [(4, 0)], window=window)
        assert inside is not None
        assert inside.cost == full.cost
    assert search(factor, passable, False, (0, 0), [(4, 0)], window=(1, 0, 4, 2)) is None

    # A window that excludes the nearer goal leads to the farther one.
    corridor = np.ones((1, 5))
    open_row = np.ones((1, 5), dtype=bool)
    near = search(corridor, open_row, False, (1, 0), [(0, 0), (4, 0)])
    assert near is not None and near.path.tolist() == [[1, 0], [0, 0]] and near.cost == 1
    far = search(corridor, open_row, False, (1, 0), [(0, 0), (4, 0)], window=(1, 0, 4, 0))
    assert far is not None
    assert far.path.tolist() == [[1, 0], [2, 0], [3, 0], [4, 0]] and far.cost == 3


@pytest.mark.parametrize("search", SEARCHES.values(), ids=SEARCHES.keys())
def test_multiple_goals(search: Search) -> None:
    # Factors 1 1 1 5 1: the left goal costs 2, the right one 3 + 3 = 6.
    factor = np.array([[1.0, 1.0, 1.0, 5.0, 1.0]])
    passable = np.ones(factor.shape, dtype=bool)
    result = search(factor, passable, False, (2, 0), np.array([[4, 0], [0, 0]]))
    assert result is not None
    assert result.path.tolist() == [[2, 0], [1, 0], [0, 0]]
    assert result.cost == 2

    # A blocked goal is ignored; the start itself may be a goal.
    passable[0, 0] = False
    right = search(factor, passable, False, (2, 0), [(0, 0), (4, 0)])
    assert right is not None and right.cost == 6 and right.path[-1].tolist() == [4, 0]
    here = search(factor, passable, False, (2, 0), [(4, 0), (2, 0)])
    assert here is not None
    assert here.path.tolist() == [[2, 0]] and here.cost == 0 and here.expanded == 1
    assert search(factor, passable, False, (2, 0), [(0, 0)]) is None
    assert search(factor, passable, False, (0, 0), [(4, 0)]) is None


def test_bad_input_is_refused() -> None:
    factor, passable = wall_grid()
    with pytest.raises(ValueError, match="start"):
        dijkstra(factor, passable, False, (5, 0), [(0, 0)])
    with pytest.raises(ValueError, match="goal"):
        astar(factor, passable, False, (0, 0), [(0, 3)])
    with pytest.raises(ValueError, match="shape"):
        astar(factor[:, :4], passable, False, (0, 0), [(1, 0)])
    factor[1, 1] = 0.0
    with pytest.raises(ValueError, match="finite and positive"):
        dijkstra(factor, passable, False, (0, 0), [(1, 0)])


@pytest.mark.parametrize("name", SEARCHES)
def test_solver_components_answer_through_the_engine(
        name: str, solver_plugins: Plugins, cbr_engine: Callable[..., Engine]) -> None:
    map_path = MOVINGAI / "maps" / "dao" / "arena.map"
    scenario = load_scen(MOVINGAI / "scenarios" / "dao" / "arena.map.scen")[-1]
    engine = cbr_engine({"world": {"use": "movingai", "map": str(map_path)}, "solver": name})

    proposal = engine.solve(GridQuery(scenario.start, scenario.goal))

    assert proposal.source == f"solver:{name}"
    solution = proposal.solution
    assert solution is not None
    assert scenario.agrees(solution.cost)
    assert solution.value[0] == list(scenario.start) and solution.value[-1] == list(scenario.goal)
    assert all(type(cell) is list and len(cell) == 2 and all(type(v) is int for v in cell)
               for cell in solution.value)
    assert engine.world.path_problems(solution.value) == []
    assert solution.detail["solver"] == name and solution.detail["expanded"] > 0


@pytest.mark.parametrize("factory", [Dijkstra, AStar], ids=["dijkstra", "astar"])
def test_solver_components_avoid_risk(factory: type[GridSolver]) -> None:
    # Row 1 is the straight way from (0, 1) to (4, 1); its middle cell is risky, so the
    # cheapest path steps around it through row 0 or row 2. Column 6 is walled off.
    risk = np.zeros((3, 7))
    risk[1, 2] = 0.9
    risk[:, 5] = 1.0
    grid = Grid(risk, cost_model=CostModel(risk_weight=10.0))
    ctx = Context(registry=Registry(), seed=0, world=grid)
    solver = factory(NoOptions(), ctx)

    solution = solver.cbr_solve(GridQuery((0, 1), (4, 1)), ctx)

    assert solution is not None
    assert [2, 1] not in solution.value
    assert solution.cost == pytest.approx(2 + 2 * math.sqrt(2))
    assert solution.cost == pytest.approx(path_cost(grid, solution.value))
    assert solver.cbr_solve(GridQuery((0, 1), (6, 1)), ctx) is None
    with pytest.raises(CbrError, match="on an obstacle"):
        solver.cbr_solve(GridQuery((5, 1), (0, 0)), ctx)
    with pytest.raises(CbrError, match="grid world"):
        factory(NoOptions(), Context(registry=Registry(), seed=0, world=None))


def frozen(array: np.ndarray) -> np.ndarray:
    array = np.array(array)
    array.setflags(write=False)
    return array


def test_the_heuristic_scale_is_remembered_only_for_read_only_grids() -> None:
    rng = np.random.default_rng(5)
    passable = rng.random((30, 40)) > 0.2
    passable[0, 0] = passable[29, 39] = True
    factor = 1.0 + 4.0 * rng.random((30, 40))
    factor[~passable] = 0.01  # smaller than any passable factor: must not set the scale
    writable_base = factor.copy()
    read_only_view = writable_base[:, :]
    read_only_view.setflags(write=False)  # its data can still change through the base
    for array_factor, array_passable, kept in ((factor, passable, False),
                                               (read_only_view, frozen(passable), False),
                                               (frozen(factor), frozen(passable), True)):
        search_module._SCALES.clear()
        expected = dijkstra(array_factor, array_passable, False, (0, 0), [(39, 29)])
        for _ in range(2):
            found = astar(array_factor, array_passable, False, (0, 0), [(39, 29)])
            assert found is not None and expected is not None
            assert math.isclose(found.cost, expected.cost, rel_tol=1e-12)
        assert bool(search_module._SCALES) is kept
        if kept:
            (scale,) = [entry[2] for entry in search_module._SCALES.values()]
            assert scale == array_factor[array_passable].min()


def test_a_remembered_scale_does_not_outlive_its_grid() -> None:
    search_module._SCALES.clear()
    passable = frozen(np.ones((8, 8), dtype=bool))
    for value in (3.0, 1.0, 0.5, 2.0):
        factor = frozen(np.full((8, 8), value))
        found = astar(factor, passable, False, (0, 0), [(7, 3)])
        assert found is not None and math.isclose(found.cost, value * (4 + 3 * math.sqrt(2)))
        del factor, found
    assert len(search_module._SCALES) <= search_module._SCALES_KEPT


def test_working_arrays_survive_interleaved_searches_and_wraparound() -> None:
    rng = np.random.default_rng(11)
    grids = []
    for h, w in ((12, 17), (40, 9), (25, 25)):
        passable = rng.random((h, w)) > 0.25
        factor = 1.0 + rng.random((h, w))
        grids.append((factor, passable))
    workspace = search_module._WORKSPACE
    for round_ in range(3):
        if round_ == 2:
            # wraps within this round; only ever forward, since stamps of later generations
            # may be left by earlier searches of this thread
            workspace.generation = max(workspace.generation, np.iinfo(np.uint8).max - 7)
        for factor, passable in grids * 2:
            h, w = passable.shape
            start = tuple(int(v) for v in rng.integers(0, (w, h)))
            goals = rng.integers(0, (w, h), size=(2, 2))
            window = (1, 1, w - 2, h - 2) if rng.random() < 0.5 else None
            expected = reference_cost(factor, passable, False, start, goals, window)
            for search in (dijkstra, astar):
                result = search(factor, passable, False, start, goals, window)
                if math.isinf(expected):
                    assert result is None
                else:
                    assert result is not None
                    assert math.isclose(result.cost, expected, rel_tol=1e-9)
                    check_path(result, factor, passable, False, start, goals, window)
    assert 0 < workspace.generation < np.iinfo(np.uint8).max - 7


@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf])
def test_bad_factors_are_refused_on_large_grids(bad: float) -> None:
    passable = np.ones((80, 80), dtype=bool)  # above the kernel's small-window scan
    factor = np.full((80, 80), bad)
    held = broadcast_factor(bad, (80, 80))  # the one value of a large grid, read as it is
    for arrays in ((factor, passable), (frozen(factor), frozen(passable)),
                   (held, frozen(passable)), (held, passable)):
        for search in (dijkstra, astar, aistar, jps):
            with pytest.raises(ValueError, match="finite and positive"):
                search(*arrays, False, (0, 0), [(79, 79)])
