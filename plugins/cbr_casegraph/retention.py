"""Retaining a traversed path in the case graph, with the similarity test of eq. (12), and
counting the uses of the segments a solution reused.

A segment is never stored twice over the same cells: where a retained path runs along a stored
edge it reuses that edge, where it crosses or leaves one the edge is split there, and the path's
own new stretches are cut at their turns (eq. 7 of the papers). A new segment is skipped when a
stored one is similar to it by eq. (12): the stored segments similar to a new one have an end in
a small square around the new one's first end, so retaining a path costs in proportion to the
path, not to the graph. The cutting, the test and the writes run compiled
(:mod:`cbr_casegraph.retention_kernel`): two kernel calls per path, none per segment.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from cbr_casegraph import writes
from cbr_casegraph.index import ID_LIMIT, SegmentIndex
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
    segments, crossings = candidates(graph.index, cells)
    # eq. (12) compares with the cases stored before this path: its own segments (the
    # steps of a staircase are within one cell of each other) are one new case, not
    # duplicates, and skipping them would cut the path into unconnected pieces. At
    # similarity_delta 0 no comparison is needed: a stored segment with the same two ends
    # would be the same straight run of cells, whose steps are then not new
    return writes.retain(graph, segments, crossings, similarity_delta, distance)


def candidates(index: SegmentIndex, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The new segments of the loop-free path ``cells`` before eq. (12) is asked about them,
    rows (ax, ay, bx, by) in path order, and its crossings of stored diagonal steps, rows (the
    crossing step's first cell, the stored cell beside it)
    (:func:`cbr_casegraph.retention_kernel.candidates`).

    The graph's cells are read once for the whole path: the path's own segments cover only
    its own cells, each visited once, so they never change what a later stretch finds. A
    crossing's one-step edge is not compared by eq. (12): it is made whenever the path's cell
    is a vertex once the segments are retained, and may join the same two cells as a segment
    that eq. (12) skipped.
    """
    # compiled: imported here so that loading the plugin does not load numba
    from cbr_casegraph.retention_kernel import candidates as cut

    return cut(index.cells.directory, index.cells.tiles, index.leaving, index.ea, index.eb,
               np.ascontiguousarray(cells, dtype=np.int64))


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
