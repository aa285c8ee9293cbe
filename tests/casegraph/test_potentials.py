"""The landmark table of the case graph search: exact distances when built, and a table whose
entries change across no edge by more than its cost however the graph grows and shrinks."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra as csgraph_dijkstra

from cbr_casegraph.graph import CaseGraph
from cbr_grid.grid import Grid
from cbr_solvers.search import dijkstra


def random_graph(seed: int, paths: int) -> tuple[CaseGraph, np.random.Generator]:
    rng = np.random.default_rng(seed)
    risk = np.where(rng.random((18, 20)) < 0.2, 1.0, np.where(rng.random((18, 20)) < 0.3, 0.5,
                                                                0.0))
    graph = CaseGraph(Grid(risk, corner_cutting=False))
    grow(graph, rng, paths)
    return graph, rng


def grow(graph: CaseGraph, rng: np.random.Generator, paths: int) -> None:
    grid = graph.grid
    free = np.argwhere(grid.passable)
    for _ in range(paths):
        (y0, x0), (y1, x1) = free[rng.integers(0, len(free), 2)]
        found = dijkstra(grid.factor, grid.passable, grid.corner_cutting, (int(x0), int(y0)),
                         [(int(x1), int(y1))])
        if found is not None and len(found.path) > 1:
            graph.add_path(found.path)


def exact(graph: CaseGraph, source: int) -> np.ndarray:
    adjacency = graph.index.adjacency()
    n = len(adjacency.indptr) - 1
    rows = np.repeat(np.arange(n), np.diff(adjacency.indptr))
    finite = np.isfinite(adjacency.weight)
    matrix = coo_matrix((np.maximum(adjacency.weight[finite], 1e-12),
                         (rows[finite], adjacency.target[finite])), shape=(n, n)).tocsr()
    return csgraph_dijkstra(matrix, indices=source)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1), st.integers(1, 8))
def test_a_built_table_holds_the_exact_distances_from_its_landmarks(seed: int,
                                                                      paths: int) -> None:
    graph, _ = random_graph(seed, paths)
    table = graph.potentials()
    live = np.flatnonzero(np.diff(graph.index.adjacency().indptr))
    if len(live) == 0:
        assert np.all(np.isinf(table))
        return
    for column in table.T:
        landmark = int(np.flatnonzero(column == 0.0)[0])
        np.testing.assert_allclose(column[live], exact(graph, landmark)[live], rtol=1e-12)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1), st.integers(1, 6),
       st.lists(st.tuples(st.integers(0, 3), st.sampled_from([0.0, 0.2, 0.5])), max_size=4))
def test_the_table_stays_within_each_edge_cost_as_the_graph_changes(
        seed: int, paths: int, changes: list[tuple[int, float]]) -> None:
    graph, rng = random_graph(seed, paths)
    graph.potentials()
    for added, dropped in changes:
        grow(graph, rng, added)
        ids = graph.edge_ids()
        graph.remove(ids[rng.random(len(ids)) < dropped].tolist())
        graph.merge_redundant()
        table = graph.potentials()
        adjacency = graph.index.adjacency()
        tails = np.repeat(np.arange(len(adjacency.indptr) - 1), np.diff(adjacency.indptr))
        finite = np.isfinite(adjacency.weight)
        tail, head = table[tails[finite]], table[adjacency.target[finite]]
        # a vertex a landmark reaches across an edge is reached too: no inf beside a number
        assert np.array_equal(np.isinf(tail), np.isinf(head))
        both = np.isfinite(tail)
        gap = np.abs(np.subtract(tail, head, out=np.zeros_like(tail), where=both))
        assert np.all(gap <= adjacency.weight[finite][:, None] * (1 + 1e-12) + 1e-12)
