"""Changing the case graph and its case base together: edges added, split, removed, repriced.

The graph writes through to a case base (:class:`cbrcore.casebase.store.CaseStore`) when it has
one: every edge is a case of kind ``segment`` (:mod:`cbr_casegraph.cases`) whose id is the
edge's id, so the graph survives across runs and commits with the engine's learn transaction.
Without a store (experiments that build graphs in bulk) edges are numbered by the index itself.

A segment is never stored twice over the same cells: an edge whose end falls inside a stored
edge splits that edge there, its two parts keeping its use count and creation stamp. A retained
path's segments are connected by one compiled call (:func:`retain`); forgetting and following
another writer connect theirs one at a time (:func:`connect`, :func:`vertex`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import attrs
import numpy as np

from cbr_casegraph.cases import segment_case
from cbr_casegraph.costs import segment_costs
from cbr_casegraph.geometry import segments_cells

if TYPE_CHECKING:
    from cbr_casegraph.graph import CaseGraph
    from cbrcore.casebase.store import CaseStore

Cell = tuple[int, int]


def connect(graph: CaseGraph, a: Cell, b: Cell, *, uses: int = 0, created: int | None = None
            ) -> int | None:
    """Add the straight edge a-b (splitting edges at its ends); None if it exists."""
    index = graph.index
    va, vb = vertex(graph, a), vertex(graph, b)
    joined = index.leaving_towards(va, b[0] - a[0], b[1] - a[1])
    if joined >= 0 and index.other(joined, va) == vb:
        return None
    return _insert(graph, a, b, va, vb, uses=uses,
                   created=graph.stamp() if created is None else created)


def vertex(graph: CaseGraph, cell: Cell) -> int:
    """The vertex on ``cell``, made if needed (splitting the edge through the cell)."""
    made, through = graph.index.add_vertex(cell)
    if through >= 0:
        _split(graph, through, made)
    return made


def remove(graph: CaseGraph, edges: list[int]) -> None:
    """Take ``edges`` (live ones) out of the store and the index."""
    if graph.store is not None and edges:
        graph.store.remove(edges)
    for edge in edges:
        graph.index.drop(edge)


def retain(graph: CaseGraph, segments: np.ndarray, crossings: np.ndarray, delta: int,
           distance: str) -> list[int]:
    """Connect the candidate ``segments`` of a retained path (rows ax, ay, bx, by, in path
    order) but those similar by eq. (12) at ``delta`` under ``distance`` to a segment stored
    before the path, then the one-step ``crossings``; the ids of the new edges.

    The compiled kernel (:func:`cbr_casegraph.retention_kernel.retain`) changes the index and
    logs what it did; the log is then written to the case base in the same order as
    :func:`connect` writes one segment at a time, so the store sees the same cases, ids and
    creation stamps, and the new edges move to the ids the store gave their cases.
    """
    # compiled: imported here so that loading the plugin does not load numba
    from cbr_casegraph import retention_kernel as kernel

    index = graph.index
    count = len(segments) + len(crossings)
    if count == 0:
        return []
    first = index.next_id
    # each segment makes at most two vertices and, with the edges split at its ends, five
    # edge ids, seven log entries and fourteen changed vertices
    index.reserve(vertices=2 * count, edges=5 * count)
    index.cells.allocate(*segments_cells(segments[:, :2], segments[:, 2:])[0].T)
    free = np.asarray(index.free, dtype=np.int64)
    counters = np.array([index.slots, first, len(free), 0], dtype=np.int64)
    log = np.empty((7 * count, 2), dtype=np.int64)
    changed = np.empty(14 * count, dtype=np.int64)
    added = np.empty(count, dtype=np.int64)
    grid = graph.grid
    logged, touched, made = kernel.retain(
        index.cells.directory, index.cells.tiles, index.vx, index.vy, index.leaving, index.ea,
        index.eb, index.cost, index.risk, index.uses, index.created, index.alive, free, counters,
        grid.factor, grid.passable, grid.corner_cutting, grid.risk, segments, crossings,
        delta, kernel.MEASURES.get(distance, 0), log, changed, added)
    index.free = free[:counters[kernel.FREE]].tolist()
    index.slots = int(counters[kernel.SLOTS])
    index.next_id = int(counters[kernel.NEXT_ID])
    index.changed.update(changed[:touched].tolist())
    index.touched()
    log, added = log[:logged], added[:made]
    # the kernel numbers its connections 1, 2, ...; each takes the stamp graph.stamp() gives
    # when its case is written, and the parts of a split edge keep that edge's stamp
    ordinal = index.created[first:index.next_id]
    fresh = ordinal < 0
    stamps = np.zeros(made + 1, dtype=np.int64)
    if graph.store is None:
        for k in range(1, made + 1):
            stamps[k] = graph.stamp()
        ordinal[fresh] = stamps[-ordinal[fresh]]
        return added.tolist()
    ids = _store_log(graph, graph.store, log, stamps)
    ordinal[fresh] = stamps[-ordinal[fresh]]
    index.renumber(ids)
    return [ids[edge] for edge in added.tolist()]


def _store_log(graph: CaseGraph, store: CaseStore, log: np.ndarray, stamps: np.ndarray
               ) -> dict[int, int]:
    """Write the kernel's ``log`` to ``store`` in order, filling ``stamps`` for the
    connections as they are written; the store's id for each edge made."""
    from cbr_casegraph.retention_kernel import CONNECTED, DROPPED

    index = graph.index
    ids: dict[int, int] = {}
    connections = 0
    for kind, edge in log.tolist():
        if kind == DROPPED:
            store.remove([ids.get(edge, edge)])
            continue
        if kind == CONNECTED:
            connections += 1
            stamps[connections] = graph.stamp()
        a, b = index.cell(int(index.ea[edge])), index.cell(int(index.eb[edge]))
        case = segment_case(a, b, float(index.cost[edge]), float(index.risk[edge]),
                            int(index.uses[edge]))
        ids[edge] = store.add(case).id
    return ids


def write_costs(graph: CaseGraph, edges: np.ndarray) -> None:
    """Write the current cost and risk of ``edges`` to their cases."""
    if graph.store is None:
        return
    for edge in edges.tolist():
        case = graph.store.get(edge)
        solution = dict(case.solution)
        cost = float(graph.index.cost[edge])
        solution["cost"] = cost if math.isfinite(cost) else None
        solution["risk"] = float(graph.index.risk[edge])
        graph.store.replace(attrs.evolve(case, solution=solution))


def _split(graph: CaseGraph, edge: int, here: int) -> None:
    """Replace ``edge`` by its two parts on either side of the vertex ``here``."""
    index = graph.index
    va, vb = int(index.ea[edge]), int(index.eb[edge])
    uses, created = int(index.uses[edge]), int(index.created[edge])
    if graph.store is not None:
        graph.store.remove([edge])
    # the ends stay vertices even when this was their only edge: its parts come back now
    a, b = index.drop(edge, keep_vertices=True)
    middle = index.cell(here)
    for p, q, vp, vq in ((a, middle, va, here), (middle, b, here, vb)):
        _insert(graph, p, q, vp, vq, uses=uses, created=created)


def _insert(graph: CaseGraph, a: Cell, b: Cell, va: int, vb: int, *, uses: int, created: int
            ) -> int:
    """Price the edge a-b between vertices va and vb, store its case and index it."""
    cost, risk = (float(v[0]) for v in segment_costs(graph.grid, [a], [b]))
    stored = (None if graph.store is None
              else graph.store.add(segment_case(a, b, cost, risk, uses)).id)
    edge = graph.index.next_id if stored is None else stored
    graph.index.insert(edge, va, vb, uses=uses, created=created, cost=cost, risk=risk)
    return edge
