"""Planning with the case graph: the algorithm of section 4.5 of the case graph paper.

For a start s and goal g on the current map:

0. When g lies in N(s, delta), the case graph is not used (step 1 of the survey's algorithm).
1-2. s and g join the graph as vertices; one lying inside a stored edge splits it (virtually).
3-4. Each connects by temporary edges to the nearest cells, within N(., delta), of every case
     meeting its neighbourhood (E_s, E_g of eq. 11), found by a local search in the window
     N(., delta + margin); a cell inside a stored edge splits it virtually. The paper does this
     only for a terminal off the graph; here a terminal on a segment is linked too, since that
     segment may lead nowhere.
5.   No case near s or g, or (for a terminal off the graph) no local path to one: CBR fails.
6.   The best path in the extended graph G' by Dijkstra or A*.
8.   No path in G': CBR fails.
9.   G' exists only for the query: the stored graph is never modified by planning.

The quality test of step 7 is the reviser's (``cbr_pathquality.reviser.QualityTest``). The
virtual split keeps the stored edge in the search as well: its parts cost exactly what it
costs, since a step's cost depends only on its two cells.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import Any, Literal

import attrs
import numpy as np

from cbr_casegraph.geometry import segments_cells
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.search import descend, graph_search, path_cost, run_costs
from cbr_grid.grid import Grid
from cbr_grid.query import without_loops
from cbr_solvers.aistar import cost_map

Cell = tuple[int, int]
Connector = Literal["dijkstra", "astar", "genetic"]
Trace = Callable[[], np.ndarray]


@attrs.frozen
class Settings:
    """How the planner adapts: neighbourhood radius, which cases, which searches."""

    delta: int = 10
    selective: bool = False
    connector: Connector = "dijkstra"
    margin: int | None = None
    graph_search: Literal["dijkstra", "astar"] = "astar"

    @property
    def window_radius(self) -> int:
        """The local search's reach: N(., delta) widened by the margin (delta / 2 by default)."""
        return self.delta + (self.delta // 2 if self.margin is None else self.margin)


@attrs.frozen
class Plan:
    """A path planned on the case graph.

    ``path`` is the (n, 2) cell path from start to goal, loops cut out; ``cost`` its cost on the
    map; ``edges`` the ids of the stored edges it uses; ``detail`` the sizes of what was built.
    """

    path: np.ndarray
    cost: float
    edges: tuple[int, ...]
    detail: dict[str, Any]


@attrs.frozen
class Failure:
    """Why the case graph gave no path."""

    reason: str
    detail: dict[str, Any] = attrs.field(factory=dict)


def _box(cell: Cell, radius: int, grid: Grid) -> tuple[int, int, int, int]:
    x, y = cell
    return (max(x - radius, 0), max(y - radius, 0), min(x + radius, grid.width - 1),
            min(y + radius, grid.height - 1))


@attrs.define
class _Overlay:
    """The virtual vertices and temporary edges of one query."""

    base: int
    cells: list[Cell] = attrs.field(factory=list)
    index: dict[Cell, int] = attrs.field(factory=dict)
    # temporary edges: (u, v, cost, the cells from u to v on demand (None for the part of a
    # split stored edge: a straight run), the stored edge it is a part of or -1)
    edges: list[tuple[int, int, float, Trace | None, int]] = attrs.field(factory=list)
    # stored edge -> cells inside it that became virtual vertices
    splits: dict[int, set[Cell]] = attrs.field(factory=dict)

    def vertex(self, graph: CaseGraph, cell: Cell) -> int:
        """The vertex of ``cell`` in G': a stored vertex, or a virtual one (split if inside)."""
        stored = graph.vertex_index(cell)
        if stored >= 0:
            return stored
        if cell not in self.index:
            self.index[cell] = self.base + len(self.cells)
            self.cells.append(cell)
            inside = int(graph.owner[cell[1], cell[0]])
            if inside >= 0:
                self.splits.setdefault(inside, set()).add(cell)
        return self.index[cell]


@attrs.frozen
class Neighbourhoods:
    """Retrieval: the cases meeting N(start, delta) and N(goal, delta) (eq. 11).

    ``*_on_graph`` says whether the terminal lies on a stored segment (it then joins the
    graph there, and is linked to the other cases near it as well).
    """

    start: np.ndarray
    goal: np.ndarray
    start_on_graph: bool
    goal_on_graph: bool


def neighbourhoods(graph: CaseGraph, start: Cell, goal: Cell, settings: Settings
                   ) -> Neighbourhoods | Failure:
    """E_s and E_g, or why the case graph cannot be used for this query."""
    delta = settings.delta
    if max(abs(start[0] - goal[0]), abs(start[1] - goal[1])) <= delta:
        return Failure("start and goal within delta: plan directly")
    found: list[np.ndarray] = []
    on_graph: list[bool] = []
    for name, cell in (("start", start), ("goal", goal)):
        through = graph.edges_at(cell)
        cases = graph.meeting(cell, delta, selective=settings.selective)
        cases = cases[np.isfinite(graph.costs(cases))]
        if len(cases) == 0:
            return Failure(f"no case meets the {name}'s neighbourhood")
        found.append(cases)
        on_graph.append(bool(through))
    return Neighbourhoods(found[0], found[1], on_graph[0], on_graph[1])


def adapt(graph: CaseGraph, start: Cell, goal: Cell, cases: Neighbourhoods, settings: Settings,
          search: Callable[..., Any] | None = None) -> Plan | Failure:
    """Reuse: extend the graph by start, goal and temporary edges; the best path in it.

    ``search`` is the local search for temporary edges when the connector is not Dijkstra (a
    function with the signature of ``cbr_solvers.search.astar``).
    """
    adjacency = graph.adjacency()
    overlay = _Overlay(base=len(adjacency.indptr) - 1)
    detail: dict[str, Any] = {"start_cases": len(cases.start), "goal_cases": len(cases.goal)}
    ends = {}
    for name, cell, near, on_graph in (("start", start, cases.start, cases.start_on_graph),
                                       ("goal", goal, cases.goal, cases.goal_on_graph)):
        ends[name] = overlay.vertex(graph, cell)
        # A terminal on the graph is linked to the other cases near it too: the segment
        # through it may be a fragment that leads nowhere (a similar segment was not stored,
        # or a part was forgotten).
        links = [link for link in _connect(graph, cell, near, settings, search)
                 if link[0] != cell]
        if not links and not on_graph:
            return Failure(f"no local path from the {name} to a case", detail)
        for target, path, cost in links:
            overlay.edges.append((ends[name], overlay.vertex(graph, target), cost, path, -1))
    _split_edges(graph, overlay)
    found = _search(graph, adjacency, overlay, ends["start"], ends["goal"], settings)
    if found is None:
        return Failure("the extended case graph does not connect start and goal", detail)
    vertices, codes, settled = found
    path, edges = _expand(graph, adjacency, overlay, vertices, codes)
    path = without_loops(path)
    cost = path_cost(graph.grid.factor, path)
    detail.update(temporary_edges=len(overlay.edges), settled=settled)
    return Plan(path, cost, edges, detail)


def plan(graph: CaseGraph, start: Cell, goal: Cell, settings: Settings,
         search: Callable[..., Any] | None = None) -> Plan | Failure:
    """Retrieve and reuse in one call: plan from ``start`` to ``goal`` on ``graph``."""
    cases = neighbourhoods(graph, start, goal, settings)
    if isinstance(cases, Failure):
        return cases
    return adapt(graph, start, goal, cases, settings, search)


def _connect(graph: CaseGraph, cell: Cell, cases: np.ndarray, settings: Settings,
             search: Callable[..., Any] | None) -> list[tuple[Cell, Trace, float]]:
    """Temporary edges from ``cell`` to the nearest cell of each case inside N(cell, delta).

    Returns (case cell reached, a function giving the path from ``cell`` to it, cost) per case
    that can be reached; cases sharing their nearest cell share one edge.
    """
    grid = graph.grid
    a, b = graph.ends(cases)
    cells, offsets = segments_cells(a, b)
    delta = settings.delta
    near = np.abs(cells - np.asarray(cell)).max(axis=1) <= delta
    box = _box(cell, settings.window_radius, grid)
    x0, y0, x1, y1 = box
    links: list[tuple[Cell, Trace, float]] = []
    if settings.connector == "dijkstra":
        width = x1 - x0 + 1
        # one sweep from the cell, stopped once every case cell in N(cell, delta) is settled
        costs = cost_map(grid.factor, grid.passable, grid.corner_cutting, [cell], box,
                         wanted=cells[near])
        reach = np.full(len(cells), np.inf)
        reach[near] = costs[cells[near, 1] - y0, cells[near, 0] - x0]
        # the cheapest cells of each case; ties all get an edge, since which of them the best
        # path should use depends on where it goes next
        best = np.minimum.reduceat(reach, offsets[:-1])
        chosen = np.flatnonzero((reach == np.repeat(best, np.diff(offsets))) & np.isfinite(reach))
        # distinct cells, by flat index (np.unique along an axis is far slower)
        flat_chosen = np.unique((cells[chosen, 1] - y0) * width + (cells[chosen, 0] - x0))
        for y, x in zip((flat_chosen // width + y0).tolist(), (flat_chosen % width + x0).tolist(),
                        strict=True):
            # the path is traced only if the search uses this edge
            def trace(x: int = x, y: int = y) -> np.ndarray:
                return descend(costs, grid.factor, grid.passable, grid.corner_cutting,
                               x0, y0, x1, y1, x, y)
            links.append(((x, y), trace, float(costs[y - y0, x - x0])))
        return links
    if search is None:
        raise ValueError(f"connector {settings.connector!r} needs a search function")
    for k in range(len(cases)):
        goals = cells[offsets[k]:offsets[k + 1]][near[offsets[k]:offsets[k + 1]]]
        result = search(grid.factor, grid.passable, grid.corner_cutting, cell, goals, box)
        if result is None:
            continue
        target = (int(result.path[-1, 0]), int(result.path[-1, 1]))
        links.append((target, lambda path=result.path: path, float(result.cost)))
    return links


def _split_edges(graph: CaseGraph, overlay: _Overlay) -> None:
    """Temporary parts of every stored edge with virtual vertices inside it, end to end."""
    if not overlay.splits:
        return
    split = list(overlay.splits)
    starts, ends = graph.ends(split)
    parts_from: list[Cell] = []
    parts_to: list[Cell] = []
    chains: list[tuple[int, int, int]] = []
    for edge, a, b in zip(split, starts.tolist(), ends.tolist(), strict=True):
        points = sorted(overlay.splits[edge],
                        key=lambda c: max(abs(c[0] - a[0]), abs(c[1] - a[1])))
        chain = [(a[0], a[1]), *points, (b[0], b[1])]
        for p, q in itertools.pairwise(chain):
            parts_from.append(p)
            parts_to.append(q)
            chains.append((overlay.vertex(graph, p), overlay.vertex(graph, q), edge))
    grid = graph.grid
    costs = run_costs(grid.factor, grid.passable, grid.corner_cutting,
                      np.asarray(parts_from, dtype=np.int64).reshape(-1, 2),
                      np.asarray(parts_to, dtype=np.int64).reshape(-1, 2))
    for (u, v, edge), cost in zip(chains, costs.tolist(), strict=True):
        overlay.edges.append((u, v, cost, None, edge))


def _search(graph: CaseGraph, adjacency: Any, overlay: _Overlay, source: int, goal: int,
            settings: Settings) -> tuple[np.ndarray, np.ndarray, int] | None:
    n = overlay.base + len(overlay.cells)
    if overlay.edges:
        u = np.array([e[0] for e in overlay.edges] + [e[1] for e in overlay.edges])
        v = np.array([e[1] for e in overlay.edges] + [e[0] for e in overlay.edges])
        w = np.array([e[2] for e in overlay.edges] * 2)
        order = np.argsort(u, kind="stable")
        o_ptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(u, minlength=n), out=o_ptr[1:])
        o_target, o_weight = v[order].astype(np.int64), w[order].astype(np.float64)
        # overlay index k of a CSR entry: which temporary edge it came from
        o_edge = np.concatenate([np.arange(len(overlay.edges))] * 2)[order]
    else:
        o_ptr = np.zeros(n + 1, dtype=np.int64)
        o_target = np.zeros(0, dtype=np.int64)
        o_weight = np.zeros(0)
        o_edge = np.zeros(0, dtype=np.int64)
    xy = adjacency.xy
    if overlay.cells:
        xy = np.concatenate([xy, np.asarray(overlay.cells, dtype=np.int64).reshape(-1, 2)])
    informed = settings.graph_search == "astar"
    found, _, vertices, codes, settled = graph_search(
        adjacency.indptr, adjacency.target, adjacency.weight, adjacency.edge, o_ptr, o_target,
        o_weight, xy, source, goal, informed, graph.heuristic_scale() if informed else 0.0)
    if not found:
        return None
    # translate overlay CSR positions into temporary edge indices
    overlay_codes = codes < 0
    codes = codes.copy()
    codes[overlay_codes] = -(o_edge[-codes[overlay_codes] - 1] + 1)
    return vertices, codes, int(settled)


def _expand(graph: CaseGraph, adjacency: Any, overlay: _Overlay, vertices: np.ndarray,
            codes: np.ndarray) -> tuple[np.ndarray, tuple[int, ...]]:
    """The cell path along the found vertices, and the stored edges it uses."""
    base = overlay.base
    extra = np.asarray(overlay.cells, dtype=np.int64).reshape(-1, 2)
    xy = np.where((vertices < base)[:, None], adjacency.xy[np.minimum(vertices, base - 1)],
                  extra[np.maximum(vertices - base, 0)] if len(extra) else 0)
    edges = codes.copy()
    traced: dict[int, np.ndarray] = {}
    for i in np.flatnonzero(codes < 0).tolist():
        u, _, _, trace, edge = overlay.edges[-int(codes[i]) - 1]
        edges[i] = edge
        if trace is not None:
            cells = trace()
            traced[i] = cells if int(vertices[i]) == u else cells[::-1]
    # every other hop is a straight run between its two vertices: runs of them are cut in one
    # go, each hop's first cell dropped where the previous hop ended on it
    pieces: list[np.ndarray] = []
    bounds = [-1, *sorted(traced), len(codes)]
    for before, after in itertools.pairwise(bounds):
        if before >= 0:
            pieces.append(traced[before] if not pieces else traced[before][1:])
        hops = np.arange(before + 1, after)
        if len(hops) == 0:
            continue
        cells, offsets = segments_cells(xy[hops], xy[hops + 1])
        keep = np.ones(len(cells), dtype=bool)
        keep[offsets[1:-1]] = False
        if pieces:
            keep[0] = False
        pieces.append(cells[keep])
    used = edges[edges >= 0].tolist()
    return np.concatenate(pieces), tuple(dict.fromkeys(used))
