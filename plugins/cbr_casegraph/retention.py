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

import itertools
from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from cbr_casegraph.index import SegmentIndex, slot
from cbr_casegraph.writes import Journal, connect
from cbr_grid.distances import Distance
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
    cells = without_loops(path)
    if len(cells) < 2:
        return []
    index = graph.index
    new_steps = _new_steps(index, cells)
    crossings = _crossings(index, cells, new_steps)
    forced = np.zeros(len(cells), dtype=bool)
    forced[[i for i, _ in crossings]] = True
    # eq. (12) compares with the cases stored before this path: its own segments (the
    # steps of a staircase are within one cell of each other) are one new case, not
    # duplicates, and skipping them would cut the path into unconnected pieces. At
    # similarity_delta 0 no comparison is needed: a stored segment with the same two ends
    # would be the same straight run of cells, whose steps are then not new
    measure = distance_function(distance) if similarity_delta > 0 else None
    journal = Journal() if measure is not None else None
    added: list[int] = []
    for first, last in _runs(new_steps):
        # the stretch of cells first..last (inclusive) consists of new steps only
        stretch = cells[first:last + 1]
        cuts = _turns(stretch) | forced[first:last + 1]
        cuts[index.taken(stretch)] = True
        points = np.flatnonzero(cuts)
        for i, j in itertools.pairwise(points):
            a = (int(stretch[i, 0]), int(stretch[i, 1]))
            b = (int(stretch[j, 0]), int(stretch[j, 1]))
            if (measure is not None and journal is not None
                    and similar_before(index, journal, a, b, similarity_delta, measure)):
                continue
            edge = connect(graph, a, b, journal=journal)
            if edge is not None:
                added.append(edge)
    for i, beside in crossings:
        here = (int(cells[i, 0]), int(cells[i, 1]))
        if index.vertex_at[here[1], here[0]] >= 0:  # not when its segment was skipped
            edge = connect(graph, here, beside, journal=journal)
            if edge is not None:
                added.append(edge)
    return added


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
    return similar_before(index, Journal(), a, b, delta, distance_function(distance))


def similar_before(index: SegmentIndex, journal: Journal, a: Cell, b: Cell, delta: int,
                   measure: Distance) -> bool:
    """Eq. (12): a segment stored before the path of ``journal`` has its ends within ``delta``
    of a and b (either way round) under ``measure``.

    Every distance of :mod:`cbr_grid.distances` is at least the Chebyshev distance, so one
    end of such a segment is a vertex in the square N(a, delta): the vertices there and
    their edges are every candidate. The edges the path inserted are left out and the
    earlier edges it split away are compared as they were.
    """
    x0, y0, x1, y1 = index.square(a, delta)
    near = index.vertex_at[y0:y1 + 1, x0:x1 + 1]
    vertices = near[near >= 0]
    if len(vertices) and _similar_at(index, journal, vertices, a, b, delta, measure):
        return True
    for p, q in journal.replaced:
        if ((measure(p, a) <= delta and measure(q, b) <= delta)
                or (measure(q, a) <= delta and measure(p, b) <= delta)):
            return True
    return False


def _similar_at(index: SegmentIndex, journal: Journal, vertices: np.ndarray, a: Cell, b: Cell,
                delta: int, measure: Distance) -> bool:
    """Whether a segment leaving one of ``vertices`` within ``delta`` of a, stored before
    the path of ``journal``, ends within ``delta`` of b."""
    vertices = vertices[measure(index.cells(vertices), a) <= delta]
    leaving = index.leaving[vertices]
    mine = leaving >= 0
    edges, here = leaving[mine], np.repeat(vertices, mine.sum(axis=1))
    if journal.fresh:
        old = ~np.isin(edges, list(journal.fresh))
        edges, here = edges[old], here[old]
    others = np.where(index.ea[edges] == here, index.eb[edges], index.ea[edges])
    return bool((measure(index.cells(others), b) <= delta).any())


def _new_steps(index: SegmentIndex, cells: np.ndarray) -> np.ndarray:
    """For each step of the path: True unless it runs along a stored edge."""
    x, y = cells[:, 0], cells[:, 1]
    inside = index.owner[y, x]
    vertex = index.vertex_at[y, x]
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


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """Maximal runs of True steps as (first cell, last cell) index pairs of the path."""
    padded = np.concatenate([[False], flags, [False]])
    change = np.flatnonzero(padded[1:] != padded[:-1])
    return [(int(s), int(e)) for s, e in zip(change[::2], change[1::2], strict=True)]


def _turns(stretch: np.ndarray) -> np.ndarray:
    """Flags over the cells of a stretch: its ends and the cells where the direction changes."""
    cuts = np.zeros(len(stretch), dtype=bool)
    cuts[0] = cuts[-1] = True
    steps = np.diff(stretch, axis=0)
    cuts[1:-1] = np.any(steps[1:] != steps[:-1], axis=1)
    return cuts
