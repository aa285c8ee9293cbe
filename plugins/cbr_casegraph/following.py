"""The case graph following its case base: the stored segments taken in, and other writers'
commits caught up with (:class:`cbrcore.casebase.mirror.FollowsChanges`)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

from cbr_casegraph.cases import SEGMENT, same_ends, segment_ends
from cbr_casegraph.costs import segment_costs
from cbr_casegraph.geometry import segment_cells
from cbr_casegraph.tiles import OWNER, VERTEX
from cbr_casegraph.writes import vertex
from cbrcore.casebase.store import Changes
from cbrcore.errors import CbrError
from cbrcore.model import Case

if TYPE_CHECKING:
    from cbr_casegraph.graph import CaseGraph


def take(graph: CaseGraph, cases: Iterable[Case]) -> list[int]:
    """Insert stored segment cases, unpriced; return their edges. CbrError naming the case
    when one does not fit the map or overlaps another segment."""
    index = graph.index
    edges = []
    for case in cases:
        a, b = segment_ends(case, graph.grid, index.source)
        cells = segment_cells(a, b)
        taken = index.cells.get(OWNER, cells[:, 0], cells[:, 1]) >= 0
        taken[1:-1] |= index.cells.get(VERTEX, cells[1:-1, 0], cells[1:-1, 1]) >= 0
        if taken.any():
            x, y = cells[np.flatnonzero(taken)[0]]
            raise CbrError(f"case base {index.source}: segment case {case.id} overlaps "
                           f"another segment at cell ({x}, {y}); the case graph is "
                           "inconsistent")
        edges.append(index.insert(case.id, vertex(graph, a), vertex(graph, b),
                                  uses=case.uses, created=case.created or 0, cost=0.0,
                                  risk=0.0))
    return edges


def catch_up(graph: CaseGraph, changes: Changes) -> bool:
    """Follow another writer's commits: drop the removed segments, then take the new ones and
    the new use counts, priced on the graph's map. The store's segments meet only at vertices,
    so a segment removed by a split is among the removed ones before its parts are taken.
    False, with nothing changed, when a changed segment moved its ends (no learn step does
    that)."""
    index = graph.index
    removed = [edge for edge in changes.removed if index.has(edge)]
    written = [case for case in changes.cases if case.kind == SEGMENT]
    kept = [case for case in written if index.has(case.id or 0)]
    for case in kept:
        # a use counted or a cost written: the ends, checked when the edge was taken, stay
        edge = case.id or 0
        if not same_ends(case, {index.cell(index.ea[edge]), index.cell(index.eb[edge])}):
            return False
    for edge in removed:
        index.drop(edge)
    for case in kept:
        index.uses[case.id or 0] = case.uses
    new = take(graph, (case for case in written if not index.has(case.id or 0)))
    if new:
        ids = np.asarray(new, dtype=np.int64)
        index.price(ids, *segment_costs(graph.grid, *index.ends(ids)))
    return True
