"""What the case graph records (see :mod:`cbr_recording`): the segments a query reused (taken
down at the next query), and the whole graph now and then.

Every edge of the graph is a straight segment between its two vertices, so the graph is drawn
as one line list in the map frame, each segment coloured by its mean risk (green 0 to red 1);
the segments a path was adapted from are drawn again, wider and yellow, on their own topic.
"""

from __future__ import annotations

import numpy as np

from cbr_casegraph.graph import CaseGraph
from cbr_grid.recording import frame_of, in_metres, risk_colors
from cbr_recording import cdr
from cbr_recording.keys import RECORDER
from cbr_recording.markers import Clear, Marker
from cbrcore.context import Context
from cbrcore.stash import StashKey

GRAPH_PERIOD = 5000.0
"""The least simulated seconds between two drawings of the whole graph (some forty trips of the
main job): the graph is large, the segments each query reused are drawn every time."""

REUSED = (1.0, 0.85, 0.0, 1.0)

MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"

_CLEAR = cdr.Template(cdr.marker_array(0, [Clear()]), [8], [])
"""A marker array that clears its topic, its stamp filled in (at offset 8, the one marker's)."""

_DRAWN = StashKey[bool]()
"""Whether ``/casegraph/reused`` shows the segments of the last query."""


def _lines(graph: CaseGraph, edges: np.ndarray) -> np.ndarray:
    """The map-frame points of ``edges``' ends, two a segment, as a line list draws them."""
    a, b = graph.ends(edges)
    return in_metres(graph.grid, np.stack((a, b), axis=1).reshape(-1, 2))


def record_reuse(ctx: Context, graph: CaseGraph, edges: list[int]) -> None:
    """Draw the segments ``edges`` a query reused (``/casegraph/reused``) and, when it is due,
    the whole graph (``/casegraph``), when the run is recorded."""
    recorder = ctx.stash.get(RECORDER, None)
    if recorder is None:
        return
    side = frame_of(graph.grid).resolution
    if recorder.due("/casegraph", GRAPH_PERIOD):
        ids = graph.edge_ids()
        colors = np.repeat(risk_colors(graph.risks(ids)), 2, axis=0)
        recorder.markers("/casegraph", [Marker(
            "segments", 0, "line_list", _lines(graph, ids), scale=(0.15 * side, 0, 0),
            colors=colors)])
    # every query draws it anew: laid out once, its points filled in
    reused = Marker("reused", 0, "line_list", scale=(0.4 * side, 0, 0), color=REUSED)
    recorder.moving("/casegraph/reused", reused,
                    _lines(graph, np.asarray(edges, dtype=np.int64)))
    ctx.stash[_DRAWN] = True


def clear_reuse(ctx: Context) -> None:
    """At a new query, take down the segments the last one reused, if it reused any: an
    answer from the fallback solver reuses none."""
    recorder = ctx.stash.get(RECORDER, None)
    if recorder is None or not ctx.stash.get(_DRAWN, False):
        return
    recorder.channel("/casegraph/reused", MARKER_ARRAY).write(
        _CLEAR.fill(recorder.stamp))
    ctx.stash[_DRAWN] = False
