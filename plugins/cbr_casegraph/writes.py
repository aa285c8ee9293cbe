"""Changing the case graph and its case base together: edges added, split, removed, repriced.

The graph writes through to a case base (:class:`cbrcore.casebase.store.CaseStore`) when it has
one: every edge is a case of kind ``segment`` (:mod:`cbr_casegraph.cases`) whose id is the
edge's id, so the graph survives across runs and commits with the engine's learn transaction.
Without a store (experiments that build graphs in bulk) edges are numbered by the index itself.

A segment is never stored twice over the same cells: an edge whose end falls inside a stored
edge splits that edge there, its two parts keeping its use count and creation stamp.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import attrs
import numpy as np

from cbr_casegraph.cases import segment_case
from cbr_casegraph.costs import segment_costs

if TYPE_CHECKING:
    from cbr_casegraph.graph import CaseGraph

Cell = tuple[int, int]


@attrs.define
class Journal:
    """What one retained path has written so far, for eq. (12) to compare it with the segments
    stored before it: the edges it inserted, and the ends of the earlier edges it split away."""

    fresh: set[int] = attrs.field(factory=set)
    replaced: list[tuple[Cell, Cell]] = attrs.field(factory=list)


def connect(graph: CaseGraph, a: Cell, b: Cell, *, uses: int = 0, created: int | None = None,
            journal: Journal | None = None) -> int | None:
    """Add the straight edge a-b (splitting edges at its ends); None if it exists."""
    index = graph.index
    va, vb = vertex(graph, a, journal), vertex(graph, b, journal)
    joined = index.leaving_towards(va, b[0] - a[0], b[1] - a[1])
    if joined >= 0 and index.other(joined, va) == vb:
        return None
    return _insert(graph, a, b, va, vb, uses=uses,
                   created=graph.stamp() if created is None else created, journal=journal)


def vertex(graph: CaseGraph, cell: Cell, journal: Journal | None = None) -> int:
    """The vertex on ``cell``, made if needed (splitting the edge through the cell)."""
    made, through = graph.index.add_vertex(cell)
    if through >= 0:
        _split(graph, through, made, journal)
    return made


def remove(graph: CaseGraph, edges: list[int]) -> None:
    """Take ``edges`` (live ones) out of the store and the index."""
    if graph.store is not None and edges:
        graph.store.remove(edges)
    for edge in edges:
        graph.index.drop(edge)


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


def _split(graph: CaseGraph, edge: int, here: int, journal: Journal | None) -> None:
    """Replace ``edge`` by its two parts on either side of the vertex ``here``."""
    index = graph.index
    va, vb = int(index.ea[edge]), int(index.eb[edge])
    uses, created = int(index.uses[edge]), int(index.created[edge])
    if graph.store is not None:
        graph.store.remove([edge])
    # the ends stay vertices even when this was their only edge: its parts come back now
    a, b = index.drop(edge, keep_vertices=True)
    if journal is not None and edge not in journal.fresh:
        journal.replaced.append((a, b))
    middle = index.cell(here)
    for p, q, vp, vq in ((a, middle, va, here), (middle, b, here, vb)):
        _insert(graph, p, q, vp, vq, uses=uses, created=created, journal=journal)


def _insert(graph: CaseGraph, a: Cell, b: Cell, va: int, vb: int, *, uses: int, created: int,
            journal: Journal | None) -> int:
    """Price the edge a-b between vertices va and vb, store its case and index it."""
    cost, risk = (float(v[0]) for v in segment_costs(graph.grid, [a], [b]))
    stored = (None if graph.store is None
              else graph.store.add(segment_case(a, b, cost, risk, uses)).id)
    edge = graph.index.next_id if stored is None else stored
    graph.index.insert(edge, va, vb, uses=uses, created=created, cost=cost, risk=risk)
    if journal is not None:
        journal.fresh.add(edge)
    return edge
