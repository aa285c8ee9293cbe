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

Steps 3-6 and the path are compiled (:mod:`cbr_casegraph.query`): a query is a constant number
of kernel calls, whatever the number of cases, links and vertices it meets. A connector that
searches once per case (``astar``, ``jps``, ``genetic`` or any other registered grid planner)
makes its temporary edges here, one search per case, and hands them to the same kernel. The
overlay classes below serve the planner for a robot with kinematic constraints
(:mod:`cbr_casegraph.kinematic`).
"""

from __future__ import annotations

import itertools
import weakref
from collections.abc import Callable
from typing import Any, Literal

import attrs
import numpy as np

from cbr_casegraph import query
from cbr_casegraph.geometry import segments_cells
from cbr_casegraph.graph import Adjacency, CaseGraph
from cbr_casegraph.search import run_costs
from cbr_grid.grid import Grid
from cbr_grid.planning import Window

Cell = tuple[int, int]
Connect = Callable[[Grid, Cell, np.ndarray, Window], Any]
"""A connector's local search: ``connect(grid, start, goals, window)``, a path to one of
``goals`` inside ``window`` with its ``path`` and ``cost``, or None (see :func:`searched`)."""
Trace = Callable[[], np.ndarray]


@attrs.frozen
class Settings:
    """How the planner adapts: neighbourhood radius, which cases, which searches."""

    delta: int = 10
    selective: bool = False
    connector: str = "dijkstra"
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
class EdgeTables:
    """The stored graph as the compiled query reads it: the CSR adjacency and, by edge id, the
    vertices at the edge's ends a and b and its cost (infinite for an id not in use)."""

    adjacency: Adjacency
    a: np.ndarray
    b: np.ndarray
    cost: np.ndarray


_TABLES: weakref.WeakKeyDictionary[CaseGraph, EdgeTables] = weakref.WeakKeyDictionary()
"""Each graph's tables, kept while its adjacency is the one they were made from."""


def edge_tables(graph: CaseGraph) -> EdgeTables:
    """The graph's tables for the compiled query, made again only when its adjacency changed."""
    adjacency = graph.adjacency()
    known = _TABLES.get(graph)
    if known is not None and known.adjacency is adjacency:
        return known
    ids = graph.edge_ids()
    size = int(ids[-1]) + 1 if len(ids) else 0
    ends = [np.full(size, -1, dtype=np.int64) for _ in range(2)]
    for table, cells in zip(ends, graph.ends(ids), strict=True):
        table[ids] = graph.vertex_at[cells[:, 1], cells[:, 0]]
    cost = np.full(size, np.inf)
    cost[ids] = graph.costs(ids)
    made = EdgeTables(adjacency, ends[0], ends[1], cost)
    _TABLES[graph] = made
    return made


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
    tables = edge_tables(graph)
    adjacency = tables.adjacency
    found: list[np.ndarray] = []
    on_graph: list[bool] = []
    for name, cell in (("start", start), ("goal", goal)):
        cases, on = query.cases_near(graph.vertex_at, graph.owner, adjacency.indptr,
                                     adjacency.edge, tables.a, tables.b, tables.cost,
                                     adjacency.xy, int(cell[0]), int(cell[1]), delta,
                                     settings.selective)
        if len(cases) == 0:
            return Failure(f"no case meets the {name}'s neighbourhood")
        found.append(cases)
        on_graph.append(bool(on))
    return Neighbourhoods(found[0], found[1], on_graph[0], on_graph[1])


_FAILURES = {query.NO_START_LINK: "no local path from the start to a case",
             query.NO_GOAL_LINK: "no local path from the goal to a case",
             query.NOT_CONNECTED: "the extended case graph does not connect start and goal"}


def searched(search: Callable[..., Any]) -> Connect:
    """The connector of a compiled search with the signature of ``cbr_solvers.search.astar``."""

    def connect(grid: Grid, start: Cell, goals: np.ndarray, window: Window) -> Any:
        return search(grid.factor, grid.passable, grid.corner_cutting, start, goals, window)

    return connect


def adapt(graph: CaseGraph, start: Cell, goal: Cell, cases: Neighbourhoods, settings: Settings,
          search: Connect | None = None) -> Plan | Failure:
    """Reuse: extend the graph by start, goal and temporary edges; the best path in it.

    ``search`` is the local search for temporary edges when the connector is not Dijkstra:
    :func:`searched` of a compiled search, or :func:`cbr_grid.planning.plan_with` of a grid
    planner from the registry.
    """
    grid = graph.grid
    tables = edge_tables(graph)
    adj = tables.adjacency
    informed = settings.graph_search == "astar"
    scale = graph.heuristic_scale() if informed else 0.0
    (sx, sy), (gx, gy) = (int(v) for v in start), (int(v) for v in goal)
    if settings.connector == "dijkstra":
        status, path, cost, hops, temporary, settled = query.adapt_swept(
            grid.factor, grid.passable, grid.corner_cutting, graph.vertex_at, graph.owner,
            adj.indptr, adj.target, adj.weight, adj.edge, adj.xy, tables.a, tables.b,
            cases.start, cases.goal, cases.start_on_graph, cases.goal_on_graph, sx, sy, gx, gy,
            settings.delta, settings.window_radius, informed, scale)
    else:
        if search is None:
            raise ValueError(f"connector {settings.connector!r} needs a search function")
        s_links = _searched_links(graph, start, cases.start, settings, search)
        g_links = _searched_links(graph, goal, cases.goal, settings, search)
        no_box, no_dist = np.zeros(4, dtype=np.int64), np.zeros(0)
        status, path, cost, hops, temporary, settled = query.extend(
            grid.factor, grid.passable, grid.corner_cutting, graph.vertex_at, graph.owner,
            adj.indptr, adj.target, adj.weight, adj.edge, adj.xy, tables.a, tables.b,
            cases.start_on_graph, cases.goal_on_graph, sx, sy, gx, gy,
            *s_links[:2], no_box, no_dist, *s_links[2:],
            *g_links[:2], no_box, no_dist, *g_links[2:], informed, scale)
    detail: dict[str, Any] = {"start_cases": len(cases.start), "goal_cases": len(cases.goal)}
    if status != query.OK:
        return Failure(_FAILURES[status], detail)
    detail.update(temporary_edges=int(temporary), settled=int(settled))
    used = dict.fromkeys(hops[hops >= 0].tolist())
    return Plan(path, float(cost), tuple(used), detail)


def plan(graph: CaseGraph, start: Cell, goal: Cell, settings: Settings,
         search: Connect | None = None) -> Plan | Failure:
    """Retrieve and reuse in one call: plan from ``start`` to ``goal`` on ``graph``."""
    cases = neighbourhoods(graph, start, goal, settings)
    if isinstance(cases, Failure):
        return cases
    return adapt(graph, start, goal, cases, settings, search)


def _searched_links(graph: CaseGraph, cell: Cell, cases: np.ndarray, settings: Settings,
                    search: Connect
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Temporary edges by one search per case, from ``cell`` to the case's cells inside
    N(cell, delta): (target cells, costs, path offsets, the paths' cells from ``cell``)."""
    grid = graph.grid
    a, b = graph.ends(cases)
    cells, offsets = segments_cells(a, b)
    near = np.abs(cells - np.asarray(cell)).max(axis=1) <= settings.delta
    box = _box(cell, settings.window_radius, grid)
    paths: list[np.ndarray] = []
    costs: list[float] = []
    for k in range(len(cases)):
        goals = cells[offsets[k]:offsets[k + 1]][near[offsets[k]:offsets[k + 1]]]
        result = search(grid, cell, goals, box)
        if result is not None:
            paths.append(np.asarray(result.path, dtype=np.int64).reshape(-1, 2))
            costs.append(float(result.cost))
    bounds = np.zeros(len(paths) + 1, dtype=np.int64)
    np.cumsum([len(p) for p in paths], out=bounds[1:])
    joined = np.concatenate(paths) if paths else np.zeros((0, 2), dtype=np.int64)
    targets = np.array([p[-1] for p in paths], dtype=np.int64).reshape(-1, 2)
    return targets, np.array(costs, dtype=np.float64), bounds, joined


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
