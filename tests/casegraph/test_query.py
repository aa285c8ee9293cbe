"""The compiled CBR query of the case graph planner, against brute force built from the graph's
edge list and the map alone.

The brute force builds the extended graph G' of the planning algorithm in Python: the cases
meeting N(., delta) found by enumerating every edge's cells; the temporary edges from exact
local costs (``cbr_solvers.aistar.cost_map`` over the window); every stored edge cut at the
virtual vertices inside it; and the cheapest path by scipy's Dijkstra. The compiled planner
must find a path exactly when G' connects start and goal, costing no more than G''s cheapest
path (the planner cuts loops out of it) and no less than the map's optimum.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra as csgraph_dijkstra

from cbr_casegraph.geometry import segment_cells
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.planner import Failure, Plan, Settings, neighbourhoods, plan
from cbr_casegraph.query import cut_loops
from cbr_grid.costs import path_cost
from cbr_grid.grid import Grid
from cbr_grid.query import without_loops
from cbr_solvers.aistar import cost_map
from cbr_solvers.search import dijkstra

Cell = tuple[int, int]


@st.composite
def worlds(draw: st.DrawFn) -> tuple[CaseGraph, list[tuple[Cell, Cell]]]:
    """A random map with risk, a case graph of a few Dijkstra paths on it, and queries."""
    width, height = draw(st.integers(10, 24)), draw(st.integers(10, 24))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    density = draw(st.sampled_from([0.0, 0.1, 0.25]))
    hazard = np.where(rng.random((height, width)) < 0.3, 0.6, 0.0)
    risk = np.where(rng.random((height, width)) < density, 1.0, hazard)
    free_cells = np.argwhere(risk < 1)
    if len(free_cells) < 2:
        risk[:] = 0.0
        free_cells = np.argwhere(risk < 1)
    grid = Grid(risk, corner_cutting=draw(st.booleans()))

    def pairs(count: int) -> list[tuple[Cell, Cell]]:
        picks = rng.integers(0, len(free_cells), (count, 2))
        return [((int(free_cells[i][1]), int(free_cells[i][0])),
                 (int(free_cells[j][1]), int(free_cells[j][0]))) for i, j in picks.tolist()]

    graph = CaseGraph(grid)

    def retain(count: int) -> None:
        for start, goal in pairs(count):
            found = dijkstra(grid.factor, grid.passable, grid.corner_cutting, start, [goal])
            if found is not None and len(found.path) > 1:
                graph.add_path(found.path)

    retain(draw(st.integers(1, 6)))
    if draw(st.booleans()):
        # the landmark table made now is repaired through what follows (rebuilt only when
        # the graph has doubled)
        graph.potentials()
        retain(draw(st.integers(0, 2)))
        ids = graph.edge_ids()
        graph.remove(ids[rng.random(len(ids)) < draw(st.sampled_from([0.0, 0.3]))].tolist())
    return graph, pairs(6)


def edge_cells(graph: CaseGraph) -> dict[int, np.ndarray]:
    ids = graph.edge_ids()
    a, b = graph.ends(ids)
    return {int(e): segment_cells(p, q) for e, p, q in zip(ids, a, b, strict=True)}


def brute_cases(graph: CaseGraph, cells_of: dict[int, np.ndarray], cell: Cell, delta: int,
                selective: bool) -> list[int]:
    """E(cell): the edges of finite cost with a cell within delta of ``cell`` (eq. 11)."""
    found = []
    for edge, cells in cells_of.items():
        if not np.isfinite(graph.costs([edge])[0]):
            continue
        if np.abs(cells - cell).max(axis=1).min() > delta:
            continue
        if selective and min(np.abs(cells[[0, -1]] - cell).max(axis=1)) > 3 * delta:
            continue
        found.append(edge)
    return sorted(found)


def brute_links(graph: CaseGraph, cells_of: dict[int, np.ndarray], cell: Cell,
                cases: list[int], settings: Settings) -> dict[Cell, float]:
    """The temporary edges of ``cell``: each case's cheapest cells within delta, by exact local
    costs over the window N(cell, delta + margin)."""
    grid, radius = graph.grid, settings.window_radius
    x0, y0 = max(cell[0] - radius, 0), max(cell[1] - radius, 0)
    x1, y1 = min(cell[0] + radius, grid.width - 1), min(cell[1] + radius, grid.height - 1)
    local = cost_map(grid.factor, grid.passable, grid.corner_cutting, [cell], (x0, y0, x1, y1))
    links: dict[Cell, float] = {}
    for edge in cases:
        cells = cells_of[edge]
        near = cells[np.abs(cells - cell).max(axis=1) <= settings.delta]
        costs = local[near[:, 1] - y0, near[:, 0] - x0]
        if not np.isfinite(costs.min()):
            continue
        for x, y in near[costs == costs.min()].tolist():
            if (x, y) != cell:
                links[x, y] = float(local[y - y0, x - x0])
    return links


def brute_extended_cost(graph: CaseGraph, cells_of: dict[int, np.ndarray], start: Cell,
                        goal: Cell, settings: Settings) -> float:
    """The cheapest start-goal path in G', built from the edge list (inf when none)."""
    links = {side: brute_links(graph, cells_of, cell, brute_cases(
        graph, cells_of, cell, settings.delta, settings.selective), settings)
             for side, cell in (("start", start), ("goal", goal))}
    nodes: dict[Cell, int] = {}
    for y, x in np.argwhere(graph.vertex_at >= 0).tolist():
        nodes.setdefault((x, y), len(nodes))
    for cell in (start, goal, *links["start"], *links["goal"]):
        nodes.setdefault(cell, len(nodes))
    rows, cols, weights = [], [], []

    def add(p: Cell, q: Cell, cost: float) -> None:
        if np.isfinite(cost):
            # a tiny floor keeps a zero-cost entry from vanishing from the sparse matrix
            rows.append(nodes[p])
            cols.append(nodes[q])
            weights.append(max(cost, 1e-12))

    for cells in cells_of.values():
        cut = [i for i, c in enumerate(cells.tolist()) if tuple(c) in nodes]
        for i, j in itertools.pairwise(cut):
            add(tuple(cells[i]), tuple(cells[j]), path_cost(graph.grid, cells[i:j + 1]))
    for side, cell in (("start", start), ("goal", goal)):
        for target, cost in links[side].items():
            add(cell, target, cost)
    matrix = coo_matrix((weights, (rows, cols)), shape=(len(nodes), len(nodes))).tocsr()
    return float(csgraph_dijkstra(matrix, directed=False, indices=nodes[start])[nodes[goal]])


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(worlds(), st.integers(1, 5), st.booleans(), st.sampled_from(["astar", "dijkstra"]))
def test_the_compiled_query_finds_the_cheapest_path_of_the_extended_graph(
        world: Any, delta: int, selective: bool, graph_search: str) -> None:
    graph, queries = world
    settings_ = Settings(delta=delta, selective=selective, graph_search=graph_search)
    grid = graph.grid
    cells_of = edge_cells(graph)
    for start, goal in queries:
        found = neighbourhoods(graph, start, goal, settings_)
        if isinstance(found, Failure):
            event(found.reason)
            continue
        assert found.start.tolist() == brute_cases(graph, cells_of, start, delta, selective)
        assert found.goal.tolist() == brute_cases(graph, cells_of, goal, delta, selective)
        result = plan(graph, start, goal, settings_)
        expected = brute_extended_cost(graph, cells_of, start, goal, settings_)
        event(type(result).__name__)
        assert isinstance(result, Plan) == np.isfinite(expected), (start, goal, result)
        if isinstance(result, Plan):
            assert grid.path_problems(result.path) == []
            assert tuple(result.path[0]) == start and tuple(result.path[-1]) == goal
            assert result.cost == pytest.approx(path_cost(grid, result.path))
            assert result.cost <= expected + 1e-9
            optimum = dijkstra(grid.factor, grid.passable, grid.corner_cutting, start, [goal])
            assert optimum is not None and result.cost >= optimum.cost - 1e-9


@given(st.lists(st.tuples(st.integers(0, 4), st.integers(0, 4)), min_size=1, max_size=40))
def test_the_compiled_loop_cut_is_the_python_one(cells: list[Cell]) -> None:
    path = np.array(cells, dtype=np.int64)
    assert np.array_equal(cut_loops(path), without_loops(path))
