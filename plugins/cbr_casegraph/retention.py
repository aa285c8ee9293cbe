"""Retaining a traversed path in the case graph, with the similarity test of eq. (12), and
counting the uses of the segments a solution reused.

A segment is never stored twice over the same cells: where a retained path runs along a stored
edge it reuses that edge, where it crosses or leaves one the edge is split there, and the path's
own new stretches are cut at their turns (eq. 7 of the papers). A new segment is skipped when a
stored one is similar to it by eq. (12): the stored segments similar to a new one have an end in
a small square around the new one's first end, so retaining a path costs in proportion to the
path, not to the graph.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from cbr_casegraph import writes
from cbr_casegraph.index import ID_LIMIT, SegmentIndex, slot
from cbr_casegraph.tiles import OWNER, VERTEX
from cbr_grid.distances import distance as distance_function
from cbr_grid.query import without_loops

if TYPE_CHECKING:
    from cbr_casegraph.graph import CaseGraph

Cell = tuple[int, int]


def add_path(graph: CaseGraph, path: ArrayLike, *, similarity_delta: int = 0,
             distance: str = "chebyshev") -> list[int]:
    """Retain a traversed path: store its new straight stretches as edges.

    Where the path runs along stored edges nothing is added; where a new stretch starts,
    ends or crosses the graph, the edge there is split so that segments meet only at
    their end points; new stretches are cut at their turns. A new segment is skipped
    when a stored one is similar to it by eq. (12) with ``similarity_delta`` under the
    named distance. A diagonal step that crosses a stored diagonal step between cells (an X
    in a 2x2 block: the paths intersect without sharing a cell) is cut there too and joined
    to the stored segment by a one-step edge. The path must be a valid path on the map.
    Returns the ids of the new edges.
    """
    if similarity_delta > 0:
        distance_function(distance)  # an unknown name is refused before anything changes
    cells = without_loops(path)
    if len(cells) < 2:
        return []
    index = graph.index
    new_steps = _new_steps(index, cells)
    crossings = _crossings(index, cells, new_steps)
    joins = np.array([(*cells[i], *beside) for i, beside in crossings],
                     dtype=np.int64).reshape(-1, 4)
    # eq. (12) compares with the cases stored before this path: its own segments (the
    # steps of a staircase are within one cell of each other) are one new case, not
    # duplicates, and skipping them would cut the path into unconnected pieces. At
    # similarity_delta 0 no comparison is needed: a stored segment with the same two ends
    # would be the same straight run of cells, whose steps are then not new
    return writes.retain(graph, candidates(index, cells, new_steps, crossings), joins,
                         similarity_delta, distance)


def candidates(index: SegmentIndex, cells: np.ndarray, new_steps: np.ndarray | None = None,
               crossings: list[tuple[int, Cell]] | None = None) -> np.ndarray:
    """The new segments of the loop-free path ``cells`` before eq. (12) is asked about them:
    rows (ax, ay, bx, by) in path order.

    Each maximal stretch of new steps is cut at its turns, at the cells the graph already
    holds and where a new diagonal step crosses a stored one between cells. The graph's
    cells are read once for the whole path: the path's own segments cover only its own
    cells, each visited once, so they never change what a later stretch finds.
    """
    if new_steps is None:
        new_steps = _new_steps(index, cells)
    if crossings is None:
        crossings = _crossings(index, cells, new_steps)
    cuts = index.taken(cells)
    cuts[[i for i, _ in crossings]] = True
    cuts[0] = cuts[-1] = True
    steps = np.diff(cells, axis=0)
    cuts[1:-1] |= np.any(steps[1:] != steps[:-1], axis=1) | (new_steps[1:] != new_steps[:-1])
    points = np.flatnonzero(cuts)
    first, last = points[:-1], points[1:]
    # a stretch of new steps begins and ends at a cut, so the pair of cuts around a new step
    # is a segment of it and the pair around a stored step is not
    first, last = first[new_steps[first]], last[new_steps[first]]
    return np.concatenate([cells[first], cells[last]], axis=1)


def record_use(index: SegmentIndex, edges: Iterable[int]) -> None:
    """Count one more use of each edge still in the graph (the store counts its own)."""
    for edge in edges:
        if index.has(edge):
            index.uses[edge] += 1


def similar(index: SegmentIndex, a: Cell, b: Cell, delta: int, distance: str = "chebyshev"
            ) -> bool:
    """Eq. (12): whether a stored segment has its ends within ``delta`` of a and b (either
    way round) under the named distance. Costs in proportion to the square N(a, delta),
    not to the graph."""
    distance_function(distance)
    # compiled: imported here so that loading the plugin does not load numba
    from cbr_casegraph.retention_kernel import MEASURES
    from cbr_casegraph.retention_kernel import similar as similar_kernel

    return bool(similar_kernel(index.cells.directory, index.cells.tiles, index.vx, index.vy,
                               index.leaving, index.ea, index.eb, int(a[0]), int(a[1]),
                               int(b[0]), int(b[1]), delta, MEASURES[distance], ID_LIMIT,
                               np.zeros((0, 4), dtype=np.int64), 0))


def _new_steps(index: SegmentIndex, cells: np.ndarray) -> np.ndarray:
    """For each step of the path: True unless it runs along a stored edge."""
    x, y = cells[:, 0], cells[:, 1]
    inside = index.cells.get(OWNER, x, y)
    vertex = index.cells.get(VERTEX, x, y)
    new = np.ones(len(cells) - 1, dtype=bool)
    both = (inside[:-1] >= 0) & (inside[1:] >= 0)
    new[both] = inside[:-1][both] != inside[1:][both]
    # a vertex and a cell inside an edge: along that edge when the vertex is one of its ends
    for at_vertex, at_edge in ((vertex[:-1], inside[1:]), (vertex[1:], inside[:-1])):
        mixed = (at_vertex >= 0) & (at_edge >= 0)
        edge, ends_at = at_edge[mixed], at_vertex[mixed]
        new[mixed] = (index.ea[edge] != ends_at) & (index.eb[edge] != ends_at)
    # two vertices side by side: along the edge leaving the first towards the second, which
    # can only be a one-step edge between them
    pairs = (vertex[:-1] >= 0) & (vertex[1:] >= 0)
    step = np.diff(cells[pairs.nonzero()[0][:, None] + [0, 1]], axis=1)[:, 0]
    new[pairs] = index.leaving[vertex[:-1][pairs], slot(step[:, 0], step[:, 1])] < 0
    return new


def _crossings(index: SegmentIndex, cells: np.ndarray, new_steps: np.ndarray
               ) -> list[tuple[int, Cell]]:
    """The new diagonal steps i -> i+1 that cross a stored diagonal step between cells.

    Returns (i, cell): the step's first cell and the stored cell beside it (same row) that
    a one-step edge joins it to.
    """
    steps = np.diff(cells, axis=0)
    diagonal = new_steps & (np.abs(steps).sum(axis=1) == 2)
    found_at = np.flatnonzero(diagonal)
    if len(found_at) == 0:
        return []
    # the two cells beside a diagonal step p -> q: (q.x, p.y) and (p.x, q.y)
    side = np.stack([cells[found_at + 1, 0], cells[found_at, 1]], axis=1)
    other = np.stack([cells[found_at, 0], cells[found_at + 1, 1]], axis=1)
    both = index.taken(side) & index.taken(other)
    found: list[tuple[int, Cell]] = []
    for k in np.flatnonzero(both).tolist():
        r = (int(side[k, 0]), int(side[k, 1]))
        t = (int(other[k, 0]), int(other[k, 1]))
        if set(index.edges_at(r)) & set(index.edges_at(t)):  # one stored step r -> t
            found.append((int(found_at[k]), r))
    return found
