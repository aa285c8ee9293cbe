"""Planning on the case graph for a robot with kinematic constraints (section 5 of the paper).

The extended graph G' of :mod:`cbr_casegraph.planner` is searched by the modified Dijkstra or A*
(:mod:`cbr_solvers.graph_search`) over its directed edges. A stored segment is straight, so
each of its two directed edges has one direction δ; a manoeuvre at a vertex may use the first
step of any segment leaving it, out and back. The temporary edges come from sweeps of the
edge-based grid search (:func:`cbr_solvers.kinematic_search.sweep`): forward from the start with
the robot's heading, and backwards from the goal with the final heading. Each case near the
start gets one temporary edge per direction in which the robot can arrive at one of its cells,
to the cheapest such cell; each case near the goal one per direction in which the robot can
leave one of its cells for the goal. The condition P at the joins is then the graph search's,
and the whole path, manoeuvres included, is one the robot can drive. Loops are not cut from it:
a manoeuvre drives out and back over the same cells on purpose.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from cbr_casegraph.geometry import segment_cells, segments_cells
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.planner import (
    Cell,
    Failure,
    Neighbourhoods,
    Plan,
    Settings,
    _box,
    _Overlay,
    _split_edges,
)
from cbr_casegraph.search import path_cost
from cbr_grid.directions import STEPS, between, facing
from cbr_grid.directions import of_steps as step_directions
from cbr_grid.directions import reversing as reversing_steps
from cbr_kinematics.models import Kinematics
from cbr_solvers.graph_search import DirectedGraph, graph_search
from cbr_solvers.kinematic_search import Sweep, sweep
from cbr_solvers.manoeuvres import decode

_LENGTH = np.where(np.arange(8) % 2 == 1, np.sqrt(2.0), 1.0)
"""The length of a step in each direction: the odd directions are the diagonals."""


def _links(graph: CaseGraph, cell: Cell, cases: np.ndarray, settings: Settings,
           found: Sweep) -> list[tuple[Cell, int, float]]:
    """The temporary edges of one terminal: (case cell, direction, cost) for each case and
    each direction, to (or from) the case's cheapest cell within N(cell, delta)."""
    a, b = graph.ends(cases)
    cells, offsets = segments_cells(a, b)
    x0, y0, x1, y1 = found.window
    near = (np.abs(cells - np.asarray(cell)).max(axis=1) <= settings.delta) & (
        (cells >= (x0, y0)) & (cells <= (x1, y1))).all(axis=1)
    near &= (cells != np.asarray(cell)).any(axis=1)
    costs = np.full((len(cells), 8), np.inf)
    costs[near] = found.cost[cells[near, 1] - y0, cells[near, 0] - x0]
    links: dict[tuple[Cell, int], float] = {}
    for lo, hi in zip(offsets[:-1].tolist(), offsets[1:].tolist(), strict=True):
        if hi == lo:
            continue
        best = np.argmin(costs[lo:hi], axis=0) + lo
        for direction in np.flatnonzero(np.isfinite(costs[best, np.arange(8)])).tolist():
            k = int(best[direction])
            links[(int(cells[k, 0]), int(cells[k, 1])), direction] = float(costs[k, direction])
    return [(target, direction, cost) for (target, direction), cost in links.items()]


def adapt(graph: CaseGraph, start: Cell, goal: Cell, cases: Neighbourhoods, settings: Settings,
          kinematics: Kinematics, heading: int | None, final_heading: int | None
          ) -> Plan | Failure:
    """Reuse for a robot of ``kinematics``: the cheapest path in G' it can drive from ``start``
    facing ``heading`` to ``goal``, able to drive on in ``final_heading`` (None: any)."""
    grid = graph.grid
    adjacency = graph.adjacency()
    overlay = _Overlay(base=len(adjacency.indptr) - 1)
    detail: dict[str, Any] = {"start_cases": len(cases.start), "goal_cases": len(cases.goal)}
    ends = {"start": overlay.vertex(graph, start), "goal": overlay.vertex(graph, goal)}
    # temporary edges: (tail, head, cost, departure, arrival, the cells from tail to head)
    links: list[tuple[int, int, float, int, int, Callable[[], np.ndarray]]] = []
    for name, cell, near, on_graph, direction, reverse in (
            ("start", start, cases.start, cases.start_on_graph, heading, False),
            ("goal", goal, cases.goal, cases.goal_on_graph, final_heading, True)):
        found = sweep(grid.factor, grid.passable, grid.corner_cutting, cell,
                      _box(cell, settings.window_radius, grid), kinematics=kinematics,
                      heading=direction, reverse=reverse)
        made = _links(graph, cell, near, settings, found)
        if not made and not on_graph:
            return Failure(f"no local path from the {name} to a case", detail)
        for target, way, cost in made:
            other = overlay.vertex(graph, target)

            def trace(found: Sweep = found, target: Cell = target, way: int = way) -> np.ndarray:
                return found.path(target, way)
            # the sweep already turned from the heading: no condition where the edge begins;
            # the goal's edges end under the final heading: none where they end
            links.append((ends["start"], other, cost, -1, way, trace) if not reverse else
                         (other, ends["goal"], cost, way, -1, trace))
    _split_edges(graph, overlay)
    extended = _extended(graph, adjacency, overlay, links)
    path_found = graph_search(extended.graph, ends["start"], ends["goal"], kinematics,
                              heading=heading, final_heading=final_heading,
                              informed=settings.graph_search == "astar")
    if path_found is None:
        return Failure("the extended case graph has no path this robot can drive", detail)
    path = _cells(extended, path_found.edges, path_found.manoeuvres, path_found.final, goal)
    used = [extended.stored[e] for e in path_found.edges if extended.stored[e] >= 0]
    directions = step_directions(path)
    detail.update(temporary_edges=len(overlay.edges) + len(links),
                  settled=path_found.expanded, headings=facing(directions).tolist(),
                  reversing=reversing_steps(directions).tolist())
    return Plan(path, path_cost(grid.factor, path), tuple(dict.fromkeys(used)), detail)


class _Extended:
    """G' as a :class:`DirectedGraph`, with what each of its edges is: the stored edge it is
    (or is a part of), or -1, and the cells of each temporary edge on demand."""

    def __init__(self, graph: DirectedGraph, stored: np.ndarray,
                 traces: dict[int, Callable[[], np.ndarray]]) -> None:
        self.graph = graph
        self.stored = stored.tolist()
        self.traces = traces


def _extended(graph: CaseGraph, adjacency: Any, overlay: _Overlay,
              links: list[tuple[int, int, float, int, int, Callable[[], np.ndarray]]]
              ) -> _Extended:
    grid = graph.grid
    base = overlay.base
    xy = adjacency.xy
    if overlay.cells:
        xy = np.concatenate([xy, np.asarray(overlay.cells, dtype=np.int64).reshape(-1, 2)])
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
        xy, graph.heuristic_scale())
    return _Extended(extended, np.concatenate([stored, np.full(len(links), -1)]), traces)


def _cells(extended: _Extended, edges: tuple[int, ...], manoeuvres: tuple[int, ...], final: int,
           goal: Cell) -> np.ndarray:
    """The cells the robot drives along ``edges``, each manoeuvre's out-and-back included."""
    xy = extended.graph.xy
    tails, heads = extended.graph.tails, extended.graph.heads
    pieces: list[np.ndarray] = []
    for edge, code in zip(edges, manoeuvres, strict=True):
        at = xy[tails[edge]]
        pieces.append(_manoeuvre(at, code) if pieces else np.concatenate(
            [at[None], _manoeuvre(at, code)]))
        trace = extended.traces.get(edge)
        cells = trace() if trace is not None else segment_cells(at, xy[heads[edge]])
        pieces.append(cells[1:])
    pieces.append(_manoeuvre(np.asarray(goal), final))
    return np.concatenate(pieces).astype(np.int64)


def _manoeuvre(at: np.ndarray, code: int) -> np.ndarray:
    """The cells of manoeuvre ``code`` at cell ``at``: out to each neighbour and back."""
    cells = [(at + STEPS[d], at) for d in decode(code) if d >= 0]
    return np.asarray([c for pair in cells for c in pair], dtype=np.int64).reshape(-1, 2)
