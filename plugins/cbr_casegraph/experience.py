"""The experience-graph planner: weighted A* on the grid, drawn along the case graph's segments.

Phillips, Cohen, Chitta and Likhachev, "E-Graphs: Bootstrapping Planning with Experience
Graphs" (RSS 2012). The search is A* on the 8-connected grid with

    f(s) = g(s) + epsilon · h^E(s)

where h^G(s, t) is the octile distance times the least passable cost factor (no path from s to
t costs less) and the experience heuristic is

    h^E(s) = min( eps_E · h^G(s, goal),  min over v in K of  eps_E · h^G(s, v) + H(v) ).

H(v) is the E-graph heuristic of case graph vertex v: the cheapest way from v to the goal that
rides stored segments at their real cost and jumps, at eps_E times h^G, from the last vertex to
the goal (one A* from the goal over the case graph, towards the start). K is a thinned copy of
the best experience route from the start (the vertex v* minimising eps_E · h^G(start, v) + H(v),
then its ride to the goal). A cell that is a case graph vertex also has the other ends of its stored
segments as successors, at the segments' real cost (infinite, so left out, for a segment that
crosses an obstacle of the current map), so a ride along a stored segment is one expansion.

**The bound.** Every term of h^E is eps_E-Lipschitz in h^G and h^G(s, s') never exceeds the
cost of a step (or of a shortcut, a straight run of steps) from s to s', so h^E / eps_E is
consistent, whatever K and whatever constants H >= 0; and h^E(goal) = 0. So h^E / eps_E is
admissible (h^E(s) <= eps_E · h^G(s, goal) <= eps_E · h*(s)) and the search is weighted A* with
weight epsilon · eps_E on a consistent admissible heuristic. Without re-expansions such a search
returns a path of cost at most epsilon · eps_E times the optimum (Likhachev, Gordon and Thrun,
"ARA*: Anytime A* with Provable Bounds on Sub-Optimality", NIPS 2003); a shortcut's cost is that
of the grid path it stands for, so the optimum over the grid with shortcuts is the grid's own.
Phillips et al. state the same bound for their planner (the solution cost is no more than
epsilon · eps_E times the optimal cost), from the eps_E-consistency of their h^E.

Both passes, the search of H over the case graph and the grid search, are one compiled kernel on
the ground floor of :mod:`cbr_grid.search_base`.
"""

from __future__ import annotations

from typing import Any

import attrs
import numpy as np

from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.search import path_cost
from cbr_casegraph.tile_kernels import cell_value
from cbr_casegraph.tiles import VERTEX
from cbr_grid.costs import SQRT2
from cbr_grid.query import Cell, without_loops
from cbr_grid.search_base import (
    DX,
    DY,
    INITIAL_HEAP,
    Workspace,
    move,
    pop,
    push_grown,
)
from cbr_kernels import njit
from cbrcore.errors import CbrError

ROUTE_VERTICES = 16
"""Into how many equal parts of its H the start's experience route is thinned for K, which keeps
a vertex per part and the route's two ends: every vertex of K costs one octile distance at each
cell the search reaches, and a route of staircase steps has hundreds."""


@attrs.frozen
class ExperiencePath:
    """A path found by the experience-graph search.

    ``path`` is the (n, 2) cell path from start to goal, loops cut out; ``cost`` its cost on the
    map; ``edges`` the ids of the stored segments ridden as shortcuts; ``bound`` the guaranteed
    factor (epsilon · eps_E) over the cheapest path's cost; ``detail`` the work done.
    """

    path: np.ndarray
    cost: float
    edges: tuple[int, ...]
    bound: float
    detail: dict[str, Any]


@njit(inline="always")
def _octile(ax: int, ay: int, bx: int, by: int) -> float:
    dx = abs(ax - bx)
    dy = abs(ay - by)
    return max(dx, dy) + (SQRT2 - 1.0) * min(dx, dy)


@njit
def _experience_heuristic(indptr: np.ndarray, target: np.ndarray, weight: np.ndarray,
                          xy: np.ndarray, sx: int, sy: int, gx: int, gy: int, scale: float,
                          experience: float, route_max: int) -> tuple[np.ndarray, np.ndarray, int]:
    """K and its constants H: the thinned experience route of the start, and vertices settled.

    A jump between cells a and b costs ``experience · scale · octile(a, b)``. The route is the
    cheapest way from the start to the goal that jumps once to a vertex v, rides stored segments
    and jumps to the goal: H(v) is its cost from v, found by A* from the goal (every vertex
    seeded with its jump to the goal) towards the start, guided by ``scale · octile(v, start)``,
    which no ride or jump undercuts, so the heuristic is consistent and the H of every settled
    vertex, the route's among them, is exact. It stops once no vertex left can beat the best
    route seen (at worst the start's own jump to the goal).
    """
    n = indptr.shape[0] - 1
    jump = experience * scale
    best = jump * _octile(sx, sy, gx, gy)
    value = np.full(n, np.inf)
    towards = np.full(n, -1, dtype=np.int64)
    done = np.zeros(n, dtype=np.bool_)
    keys = np.empty(64, dtype=np.float64)
    items = np.empty(64, dtype=np.int64)
    size = 0
    for v in range(n):
        if indptr[v + 1] == indptr[v]:
            continue  # a free vertex slot has no segment
        seed = jump * _octile(xy[v, 0], xy[v, 1], gx, gy)
        key = seed + scale * _octile(xy[v, 0], xy[v, 1], sx, sy)
        if key < best:  # else no route through v beats the start's own jump
            value[v] = seed
            keys, items = push_grown(keys, items, size, key, v)
            size += 1
    entry = -1
    settled = 0
    while size > 0:
        v = pop(keys, items, size)
        size -= 1
        if done[v]:
            continue
        done[v] = True
        settled += 1
        here = value[v]
        vx, vy = xy[v, 0], xy[v, 1]
        if here + scale * _octile(vx, vy, sx, sy) >= best:
            break
        through = jump * _octile(sx, sy, vx, vy) + here
        if through < best:
            best, entry = through, v
        for k in range(indptr[v], indptr[v + 1]):
            u = target[k]
            g = here + weight[k]
            if done[u] or not g < value[u]:
                continue
            value[u] = g
            towards[u] = v
            key = g + scale * _octile(xy[u, 0], xy[u, 1], sx, sy)
            keys, items = push_grown(keys, items, size, key, u)
            size += 1
    if entry < 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0), settled
    count = 0
    last = entry
    v = entry
    while v >= 0:
        count += 1
        last = v
        v = towards[v]
    # keep the entry, the last vertex (which jumps to the goal) and vertices spaced evenly
    # along the route's H in between
    spacing = (value[entry] - value[last]) / route_max
    kept = np.empty(min(count, route_max + 2), dtype=np.int64)
    size = 0
    v = entry
    while towards[v] >= 0:
        if size == 0 or (value[kept[size - 1]] - value[v] >= spacing
                         and size < kept.shape[0] - 1):
            kept[size] = v
            size += 1
        v = towards[v]
    kept[size] = v
    size += 1
    return kept[:size], value[kept[:size]], settled


@njit
def _search(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, sx: int, sy: int,
            gx: int, gy: int, directory: np.ndarray, tiles: np.ndarray, indptr: np.ndarray,
            target: np.ndarray, weight: np.ndarray, edge: np.ndarray, xy: np.ndarray,
            epsilon: float,
            experience: float, scale: float, route_max: int, stamp: np.ndarray,
            dist: np.ndarray, parent: np.ndarray, estimate: np.ndarray, via: np.ndarray,
            generation: int) -> tuple[bool, np.ndarray, np.ndarray, float, int, int, int]:
    """The experience-graph search from (sx, sy) to (gx, gy) on the whole grid.

    Returns (found, path, shortcut edges, cost, cells expanded, vertices settled by H, size of
    K). ``stamp``, ``dist`` and ``parent`` are a :class:`~cbr_grid.search_base.Workspace`'s
    (a cell reached iff ``stamp == generation``, settled iff ``generation + 1``); ``estimate``
    (h^E of a reached cell, computed once) and ``via`` (the stored edge a cell was reached by,
    or -1) are read only for reached cells, so they are never cleared either.
    """
    h, w = passable.shape
    jump = experience * scale
    route, constant, settled_vertices = _experience_heuristic(
        indptr, target, weight, xy, sx, sy, gx, gy, scale, experience, route_max)
    kx = np.empty(route.shape[0], dtype=np.int64)
    ky = np.empty(route.shape[0], dtype=np.int64)
    for j in range(route.shape[0]):
        kx[j], ky[j] = xy[route[j], 0], xy[route[j], 1]
    empty = np.empty((0, 2), dtype=np.int64)
    none = np.empty(0, dtype=np.int64)
    if not (passable[sy, sx] and passable[gy, gx]):
        return False, empty, none, np.inf, 0, settled_vertices, route.shape[0]
    settled = generation + 1
    start = sy * w + sx
    goal = gy * w + gx
    keys = np.empty(INITIAL_HEAP, dtype=np.float64)
    items = np.empty(INITIAL_HEAP, dtype=np.int64)
    stamp[start] = generation
    dist[start] = 0.0
    via[start] = -1
    estimate[start] = _estimate(sx, sy, gx, gy, kx, ky, constant, jump)
    keys[0] = epsilon * estimate[start]
    items[0] = start
    size = 1
    expanded = 0
    while size > 0:
        cell = pop(keys, items, size)
        size -= 1
        if stamp[cell] == settled:
            continue  # no re-expansions: the bound's proof needs none
        stamp[cell] = settled
        expanded += 1
        if cell == goal:
            break
        cx = cell % w
        cy = cell // w
        here = dist[cell]
        fc = factor[cy, cx]
        for d in range(8):
            if not move(passable, corner_cutting, cx, cy, d, 0, 0, w - 1, h - 1):
                continue
            nx, ny = cx + DX[d], cy + DY[d]
            other = ny * w + nx
            mark = stamp[other]
            if mark == settled:
                continue
            g = here + (SQRT2 if d >= 4 else 1.0) * (fc + factor[ny, nx]) * 0.5
            if mark == generation and g >= dist[other]:
                continue
            if mark != generation:
                estimate[other] = _estimate(nx, ny, gx, gy, kx, ky, constant, jump)
            stamp[other] = generation
            dist[other] = g
            parent[other] = cell
            via[other] = -1
            keys, items = push_grown(keys, items, size, g + epsilon * estimate[other], other)
            size += 1
        v = cell_value(directory, tiles, VERTEX, cx, cy)
        if v < 0:
            continue
        for k in range(indptr[v], indptr[v + 1]):
            if not weight[k] < np.inf:
                continue  # the segment crosses an obstacle of the current map
            u = target[k]
            nx, ny = xy[u, 0], xy[u, 1]
            other = ny * w + nx
            mark = stamp[other]
            if mark == settled:
                continue
            g = here + weight[k]
            if mark == generation and g >= dist[other]:
                continue
            if mark != generation:
                estimate[other] = _estimate(nx, ny, gx, gy, kx, ky, constant, jump)
            stamp[other] = generation
            dist[other] = g
            parent[other] = cell
            via[other] = edge[k]
            keys, items = push_grown(keys, items, size, g + epsilon * estimate[other], other)
            size += 1
    if stamp[goal] != settled:
        return False, empty, none, np.inf, expanded, settled_vertices, route.shape[0]
    path, edges = _unwound(parent, via, start, goal, w)
    return True, path, edges, dist[goal], expanded, settled_vertices, route.shape[0]


@njit(inline="always")
def _estimate(x: int, y: int, gx: int, gy: int, kx: np.ndarray, ky: np.ndarray,
              constant: np.ndarray, jump: float) -> float:
    """h^E of cell (x, y): the jump to the goal, or to a vertex of K and on from there."""
    best = jump * _octile(x, y, gx, gy)
    for j in range(kx.shape[0]):
        value = jump * _octile(x, y, kx[j], ky[j]) + constant[j]
        if value < best:
            best = value
    return best


@njit
def _unwound(parent: np.ndarray, via: np.ndarray, start: int, goal: int, w: int
             ) -> tuple[np.ndarray, np.ndarray]:
    """The cells from start to goal, each shortcut laid out as its straight run of cells, and
    the stored edges ridden."""
    cells = 1
    rides = 0
    cell = goal
    while cell != start:
        before = parent[cell]
        cells += max(abs(cell % w - before % w), abs(cell // w - before // w))
        if via[cell] >= 0:
            rides += 1
        cell = before
    path = np.empty((cells, 2), dtype=np.int64)
    edges = np.empty(rides, dtype=np.int64)
    i = cells - 1
    cell = goal
    path[i, 0], path[i, 1] = cell % w, cell // w
    while cell != start:
        before = parent[cell]
        bx, by = before % w, before // w
        x, y = cell % w, cell // w
        dx, dy = np.sign(bx - x), np.sign(by - y)
        for _ in range(max(abs(bx - x), abs(by - y))):
            x += dx
            y += dy
            i -= 1
            path[i, 0], path[i, 1] = x, y
        if via[cell] >= 0:
            rides -= 1
            edges[rides] = via[cell]
        cell = before
    return path, edges


class _Workspace(Workspace):
    """The search's working arrays, with h^E and the shortcut of each reached cell besides."""

    def __init__(self) -> None:
        super().__init__()
        self.estimate = np.empty(0, dtype=np.float64)
        self.via = np.empty(0, dtype=np.int64)

    def extra(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        if self.estimate.shape[0] < n:
            self.estimate = np.empty(n, dtype=np.float64)
            self.via = np.empty(n, dtype=np.int64)
        return self.estimate, self.via


_WORKSPACE = _Workspace()


def plan(graph: CaseGraph, start: Cell, goal: Cell, epsilon: float, experience_factor: float,
         *, route_vertices: int = ROUTE_VERTICES) -> ExperiencePath | None:
    """The experience-graph path from ``start`` to ``goal`` on ``graph``'s map, or None when
    the map does not connect them. Its cost is at most ``epsilon · experience_factor`` times the
    cheapest path's. CbrError for a factor below 1, ValueError for cells off the grid."""
    if not (epsilon >= 1.0 and experience_factor >= 1.0):
        raise CbrError(f"the experience-graph search: epsilon {epsilon!r} and "
                       f"experience_factor {experience_factor!r} must both be at least 1")
    grid = graph.grid
    for name, (x, y) in (("start", start), ("goal", goal)):
        if not (0 <= x < grid.width and 0 <= y < grid.height):
            raise CbrError(f"the experience-graph search: {name} {(x, y)} is outside the "
                           f"{grid.width}x{grid.height} grid")
    adjacency = graph.adjacency()
    n = grid.passable.size
    stamp, dist, parent, _, generation = _WORKSPACE.take(n)
    estimate, via = _WORKSPACE.extra(n)
    found, path, edges, cost, expanded, settled, route = _search(
        grid.factor, grid.passable, grid.corner_cutting, int(start[0]), int(start[1]),
        int(goal[0]), int(goal[1]), *graph.cell_tiles(), adjacency.indptr, adjacency.target,
        adjacency.weight, adjacency.edge, adjacency.xy, float(epsilon), float(experience_factor),
        graph.heuristic_scale(), int(route_vertices), stamp, dist, parent, estimate, via,
        generation)
    if not found:
        return None
    if len(edges):  # a ride may pass cells the path also reaches otherwise
        path = without_loops(path)
    detail = {"expanded": int(expanded), "vertices_settled": int(settled),
              "route_vertices": int(route), "shortcuts": len(edges), "search_cost": float(cost)}
    return ExperiencePath(path, float(path_cost(grid.factor, path)),
                          tuple(dict.fromkeys(edges.tolist())),
                          float(epsilon * experience_factor), detail)
