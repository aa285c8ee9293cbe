"""Forgetting in the case graph: edges removed, and vertices in the middle of a straight edge
merged away, in the index and the case base together.

The strategies (:mod:`cbr_casegraph.components`) choose what to forget.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

from cbr_casegraph.geometry import direction
from cbr_casegraph.writes import connect
from cbr_casegraph.writes import remove as remove_edges

if TYPE_CHECKING:
    from cbr_casegraph.graph import CaseGraph

def remove(graph: CaseGraph, edges: Iterable[int]) -> None:
    """Forget these edges; vertices left without edges disappear. KeyError for an edge that
    is not in the graph, with nothing forgotten."""
    ids = sorted(set(int(e) for e in edges))
    for edge in ids:
        if not graph.index.has(edge):
            raise KeyError(edge)
    remove_edges(graph, ids)


def merge_redundant(graph: CaseGraph) -> int:
    """Delete the vertices in the middle of a straight edge: degree 2, both edges collinear.
    Only the vertices whose edges changed since the last merge are looked at.

    Returns how many vertices were removed.
    """
    index = graph.index
    merged = 0
    for vertex in sorted(index.take_changed()):
        edges = index.incident(vertex).tolist()
        if len(edges) != 2:
            continue
        e1, e2 = edges
        far1, far2 = index.other(e1, vertex), index.other(e2, vertex)
        here, p1, p2 = index.cell(vertex), index.cell(far1), index.cell(far2)
        if not np.array_equal(direction(p1, here), direction(here, p2)):
            continue
        if far1 == far2:
            continue
        uses = int(max(index.uses[e1], index.uses[e2]))
        created = int(min(index.created[e1], index.created[e2]))
        remove(graph, [e1, e2])
        connect(graph, p1, p2, uses=uses, created=created)
        merged += 1
    return merged
