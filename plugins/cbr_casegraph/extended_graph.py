"""The extended graph G' for a robot with kinematic constraints, and the cells it drives.

G' is searched by the modified Dijkstra or A* (:mod:`cbr_solvers.graph_search`) over its
directed edges. A stored segment is straight, so each of its two directed edges has one
direction δ; a manoeuvre at a vertex may use the first step of any segment leaving it, out and
back. Temporary edges (:func:`cbr_casegraph.links.swept`) carry the directions the robot
arrives and leaves with; their cells come from the sweep that made them.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from cbr_casegraph.geometry import segment_cells
from cbr_casegraph.index import Adjacency
from cbr_casegraph.overlay import Overlay
from cbr_grid.directions import STEPS, between
from cbr_grid.grid import Grid
from cbr_solvers.graph_search import DirectedGraph
from cbr_solvers.manoeuvres import manoeuvre_cells

Cell = tuple[int, int]
Temporary = tuple[int, int, float, int, int, Callable[[], np.ndarray]]
"""A temporary edge: (tail, head, cost, departure, arrival, the cells from tail to head); -1 for
a direction leaves the condition at that end to the search."""

_LENGTH = np.where(np.arange(8) % 2 == 1, np.sqrt(2.0), 1.0)
"""The length of a step in each direction: the odd directions are the diagonals."""


class Extended:
    """G' as a :class:`DirectedGraph`, with what each of its edges is: the stored edge it is
    (or is a part of), or -1, and the cells of each temporary edge on demand."""

    def __init__(self, graph: DirectedGraph, stored: np.ndarray,
                 traces: dict[int, Callable[[], np.ndarray]]) -> None:
        self.graph = graph
        self.stored = stored.tolist()
        self.traces = traces


def build(grid: Grid, adjacency: Adjacency, overlay: Overlay, links: list[Temporary],
          scale: float) -> Extended:
    """G' from the stored graph's ``adjacency``, the parts of the split edges in ``overlay``
    and the temporary ``links``; ``scale`` is the A* heuristic's least cost factor."""
    base = overlay.base
    xy = overlay.xy(adjacency.xy)
    # the stored edges, both ways, and the parts of the split ones, both ways: straight runs
    parts = [(u, v, w, edge) for u, v, w, _, edge in overlay.edges]
    tails = np.concatenate([np.repeat(np.arange(base), np.diff(adjacency.indptr)),
                            [p[0] for p in parts], [p[1] for p in parts]]).astype(np.int64)
    heads = np.concatenate([adjacency.target, [p[1] for p in parts],
                            [p[0] for p in parts]]).astype(np.int64)
    weights = np.concatenate([adjacency.weight, [p[2] for p in parts] * 2]).astype(np.float64)
    stored = np.concatenate([adjacency.edge, [p[3] for p in parts] * 2]).astype(np.int64)
    directions = between(xy[tails], xy[heads]) if len(tails) else np.zeros(0, dtype=np.int64)
    # a manoeuvre drives the first step of the edge out and back
    nx, ny = (xy[tails] + STEPS[directions]).T
    first = grid.factor[xy[tails, 1], xy[tails, 0]] + grid.factor[ny, nx]
    out_and_back = _LENGTH[directions] * first
    count = len(tails)
    traces = {count + k: link[5] for k, link in enumerate(links)}
    extended = DirectedGraph(
        np.concatenate([tails, [link[0] for link in links]]).astype(np.int64),
        np.concatenate([heads, [link[1] for link in links]]).astype(np.int64),
        np.concatenate([weights, [link[2] for link in links]]).astype(np.float64),
        np.concatenate([directions, [link[3] for link in links]]).astype(np.int64),
        np.concatenate([directions, [link[4] for link in links]]).astype(np.int64),
        np.concatenate([out_and_back, np.full(len(links), np.inf)]),
        xy, scale)
    return Extended(extended, np.concatenate([stored, np.full(len(links), -1)]), traces)


def driven_cells(extended: Extended, edges: tuple[int, ...], manoeuvres: tuple[int, ...],
                 final: int, goal: Cell) -> np.ndarray:
    """The cells the robot drives along ``edges``, each manoeuvre's out-and-back included."""
    xy = extended.graph.xy
    tails, heads = extended.graph.tails, extended.graph.heads
    # a manoeuvre drives out to a neighbour and back, at most twice: four cells
    out = np.empty((4, 2), dtype=np.int64)
    pieces: list[np.ndarray] = [xy[tails[edges[0]]][None]] if edges else []
    for at, code, edge in zip(xy[tails[list(edges)]], manoeuvres, edges, strict=True):
        pieces.append(out[:manoeuvre_cells(int(at[0]), int(at[1]), code, out, 0)].copy())
        trace = extended.traces.get(edge)
        cells = trace() if trace is not None else segment_cells(at, xy[heads[edge]])
        pieces.append(cells[1:])
    pieces.append(out[:manoeuvre_cells(int(goal[0]), int(goal[1]), final, out, 0)].copy())
    return np.concatenate(pieces).astype(np.int64)
