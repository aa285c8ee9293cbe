"""Growing a case graph to a given size, as the papers' experiments imply.

The papers never say how their test graphs were made; they only say that every traversed path is
retained (section 4.3 of the case graph paper) and that the alternative method (Dijkstra or A*)
plans whatever the case graph cannot. A graph of a chosen size is therefore grown the way a
robot starting with an empty case base would grow it: plan a random task between two free cells
with the alternative method and retain its path (cut into segments, similar segments skipped
by eq. 12), until the graph has the requested number of vertices. Each path adds a whole batch
of vertices, so the final count overshoots the target by at most one path's worth.

Tasks are drawn among the cells reachable from one another (the largest connected region of
free cells), so that no draw is wasted on an unreachable pair and the graph covers the region
the experiments query.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Literal

import numpy as np

from cbr_casegraph.graph import CaseGraph
from cbr_grid.grid import Grid
from cbr_solvers.aistar import aistar, cost_map
from cbr_solvers.search import astar, dijkstra

Solver = Literal["dijkstra", "astar", "aistar"]

SOLVERS: dict[str, Callable[..., Any]] = {"dijkstra": dijkstra, "astar": astar,
                                          "aistar": aistar}
"""The alternative planning methods, by name: all take (factor, passable, corner_cutting, start,
goals) and return a ``SearchResult`` or None."""

STALL = 200
"""Retained paths in a row that add no vertex before growing gives up: the map is saturated."""


def connected_cells(grid: Grid, rng: np.random.Generator) -> np.ndarray:
    """The (x, y) cells of the largest region of mutually reachable free cells.

    A region holding more than half the free cells is necessarily the largest, so random free
    cells are tried until one lies in such a region; otherwise the largest region met is kept.
    """
    free = np.argwhere(grid.passable)[:, ::-1]
    if len(free) == 0:
        raise ValueError("the map has no free cell")
    best = np.zeros((0, 2), dtype=np.int64)
    for _ in range(20):
        seed = free[rng.integers(len(free))]
        reach = cost_map(grid.factor, grid.passable, grid.corner_cutting, [tuple(seed)])
        region = np.argwhere(np.isfinite(reach))[:, ::-1]
        if len(region) > len(best):
            best = region
        if 2 * len(best) > len(free):
            break
    return best.astype(np.int64)


def random_task(cells: np.ndarray, rng: np.random.Generator) -> tuple[tuple[int, int],
                                                                       tuple[int, int]]:
    """Two distinct cells drawn uniformly from ``cells``."""
    i, j = rng.choice(len(cells), size=2, replace=False)
    return (int(cells[i, 0]), int(cells[i, 1])), (int(cells[j, 0]), int(cells[j, 1]))


def grow(graph: CaseGraph, vertices: int, rng: np.random.Generator, *,
         solver: Solver = "dijkstra", similarity_delta: int = 0,
         cells: np.ndarray | None = None) -> int:
    """Retain the ``solver``'s paths for random tasks until ``graph`` has ``vertices`` vertices.

    ``cells`` are the cells tasks are drawn from (default: :func:`connected_cells`; pass them
    when growing one graph in several steps to avoid recomputing them). Returns how many paths
    were retained. Raises ValueError when the map cannot hold that many vertices.
    """
    grid = graph.grid
    search = SOLVERS[solver]
    pool = connected_cells(grid, rng) if cells is None else cells
    if len(pool) < 2:
        raise ValueError("fewer than two reachable free cells: nothing to plan")
    paths = stalled = 0
    while graph.vertex_count < vertices:
        start, goal = random_task(pool, rng)
        found = search(grid.factor, grid.passable, grid.corner_cutting, start, [goal])
        if found is None:
            continue
        before = graph.vertex_count
        graph.add_path(found.path, similarity_delta=similarity_delta)
        paths += 1
        stalled = stalled + 1 if graph.vertex_count == before else 0
        if stalled >= STALL:
            raise ValueError(f"the graph stopped growing at {graph.vertex_count} vertices, "
                             f"short of {vertices}")
    return paths
