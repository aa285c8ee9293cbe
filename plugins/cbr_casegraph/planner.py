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
makes its temporary edges one search per case (:func:`cbr_casegraph.links.searched`) and hands
them to the same kernel. A robot with kinematic constraints has a planner of its own
(:mod:`cbr_casegraph.kinematic`) on the same retrieval.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Literal

import attrs
import numpy as np

from cbr_casegraph import links, query
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.links import Connect
from cbr_casegraph.potentials import LANDMARKS
from cbr_grid.grid import Grid
from cbr_grid.planning import Window

Cell = tuple[int, int]


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
    tables = graph.tables()
    adjacency = tables.adjacency
    found: list[np.ndarray] = []
    on_graph: list[bool] = []
    for name, cell in (("start", start), ("goal", goal)):
        cases, on = query.cases_near(*graph.cell_tiles(), adjacency.indptr,
                                     adjacency.edge, tables.a, tables.b, tables.cost,
                                     adjacency.xy, int(cell[0]), int(cell[1]), delta,
                                     settings.selective)
        if len(cases) == 0:
            return Failure(f"no case meets the {name}'s neighbourhood")
        found.append(cases)
        on_graph.append(bool(on))
    return Neighbourhoods(found[0], found[1], on_graph[0], on_graph[1])


_NO_POTENTIAL = np.zeros((0, LANDMARKS))
"""The landmark table Dijkstra's graph search is given: none."""

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
    tables = graph.tables()
    adj = tables.adjacency
    informed = settings.graph_search == "astar"
    scale = graph.heuristic_scale() if informed else 0.0
    potential = graph.potentials() if informed else _NO_POTENTIAL
    (sx, sy), (gx, gy) = (int(v) for v in start), (int(v) for v in goal)
    if settings.connector == "dijkstra":
        status, path, cost, hops, temporary, settled = query.adapt_swept(
            grid.factor, grid.passable, grid.corner_cutting, *graph.cell_tiles(),
            adj.indptr, adj.target, adj.weight, adj.edge, adj.xy, tables.a, tables.b,
            cases.start, cases.goal, cases.start_on_graph, cases.goal_on_graph, sx, sy, gx, gy,
            settings.delta, settings.window_radius, informed, scale, potential)
    else:
        if search is None:
            raise ValueError(f"connector {settings.connector!r} needs a search function")
        s_links = links.searched(grid, start, tables.ends(cases.start), settings.delta,
                                 settings.window_radius, search)
        g_links = links.searched(grid, goal, tables.ends(cases.goal), settings.delta,
                                 settings.window_radius, search)
        no_box, no_dist = np.zeros(4, dtype=np.int64), np.zeros(0)
        status, path, cost, hops, temporary, settled = query.extend(
            grid.factor, grid.passable, grid.corner_cutting, *graph.cell_tiles(),
            adj.indptr, adj.target, adj.weight, adj.edge, adj.xy, tables.a, tables.b,
            cases.start_on_graph, cases.goal_on_graph, sx, sy, gx, gy,
            *s_links[:2], no_box, no_dist, *s_links[2:],
            *g_links[:2], no_box, no_dist, *g_links[2:], informed, scale, potential)
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
