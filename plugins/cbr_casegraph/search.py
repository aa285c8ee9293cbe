"""Compiled searches of the planner: the best path in the extended case graph, and the descent
of a local cost map back to its source.

The extended graph G' of the planning algorithm is the stored graph (its cached CSR arrays,
never modified by a query) plus a small overlay of virtual vertices and temporary edges made for
one query: the start, the goal, the points where they attach to stored edges, and the parts of
those edges on either side. The kernel walks both edge lists, so building G' costs in proportion
to the overlay and removing it costs nothing.
"""

from __future__ import annotations

import numpy as np

from cbr_grid.costs import SQRT2
from cbr_grid.search_base import DX, DY, move, pop, push, push_grown
from cbr_kernels import njit


@njit
def graph_search(indptr: np.ndarray, target: np.ndarray, weight: np.ndarray, edge: np.ndarray,
                 o_ptr: np.ndarray, o_target: np.ndarray, o_weight: np.ndarray,
                 xy: np.ndarray, source: int, goal: int, informed: bool, scale: float,
                 potential: np.ndarray, virtual: np.ndarray, low: np.ndarray, high: np.ndarray
                 ) -> tuple[bool, float, np.ndarray, np.ndarray, int]:
    """Dijkstra (or A* when ``informed``) from ``source`` to ``goal`` over base + overlay edges.

    Base edges leave vertex v < len(indptr) - 1 in ``indptr[v]:indptr[v+1]``; overlay edges
    leave any vertex v in ``o_ptr[v]:o_ptr[v+1]``. A*'s bound of the cost left is the larger of
    the octile distance from ``xy`` (every vertex's cell), scaled by ``scale`` (the least cost
    factor), and the landmark bound: for each landmark column k of the table rows
    (``potential`` for base vertices, ``virtual`` for the others, :mod:`cbr_casegraph.potentials`)
    the distance of the vertex's entry D outside [``low[k]``, ``high[k]``], the goal's interval
    (inf/-inf when it has none). Both are consistent on every edge not leaving the source, which
    is settled first, so the first path to settle the goal is the cheapest.
    Returns (found, cost, vertices, codes, settled): the path's vertices from source to goal and,
    for each of its edges, the base edge id (>= 0) or -(overlay index + 1).
    """
    n = o_ptr.shape[0] - 1
    n_base = indptr.shape[0] - 1
    dist = np.full(n, np.inf)
    came = np.full(n, -1, dtype=np.int64)
    code = np.zeros(n, dtype=np.int64)
    closed = np.zeros(n, dtype=np.bool_)
    keys = np.empty(64, dtype=np.float64)
    items = np.empty(64, dtype=np.int64)
    gx, gy = xy[goal, 0], xy[goal, 1]
    dist[source] = 0.0
    # int64 sizes, not literals: numba would compile the heap's kernels for each literal too
    size = np.int64(0)
    push(keys, items, size, 0.0, source)
    size += 1
    settled = 0
    while size > 0:
        v = pop(keys, items, size)
        size -= 1
        if closed[v]:
            continue
        closed[v] = True
        settled += 1
        if v == goal:
            break
        here = dist[v]
        for part in range(2):
            if part == 0:
                if v >= n_base:
                    continue
                lo, hi = indptr[v], indptr[v + 1]
            else:
                lo, hi = o_ptr[v], o_ptr[v + 1]
            for k in range(lo, hi):
                if part == 0:
                    u, w, c = target[k], weight[k], edge[k]
                else:
                    u, w, c = o_target[k], o_weight[k], -(k + 1)
                if closed[u] or not w < np.inf:
                    continue
                g = here + w
                if g >= dist[u]:
                    continue
                dist[u] = g
                came[u] = v
                code[u] = c
                key = g
                if informed and u != goal:
                    dx = abs(xy[u, 0] - gx)
                    dy = abs(xy[u, 1] - gy)
                    bound = (max(dx, dy) + (SQRT2 - 1.0) * min(dx, dy)) * scale
                    for k in range(low.shape[0]):
                        d = potential[u, k] if u < n_base else virtual[u - n_base, k]
                        if d < np.inf and low[k] < np.inf:
                            bound = max(bound, d - high[k], low[k] - d)
                    key = g + bound
                keys, items = push_grown(keys, items, size, key, u)
                size += 1
    if not closed[goal]:
        return False, np.inf, np.zeros(0, np.int64), np.zeros(0, np.int64), settled
    count = 1
    v = goal
    while v != source:
        v = came[v]
        count += 1
    vertices = np.empty(count, dtype=np.int64)
    codes = np.empty(count - 1, dtype=np.int64)
    v = goal
    for i in range(count - 1, 0, -1):
        vertices[i] = v
        codes[i - 1] = code[v]
        v = came[v]
    vertices[0] = source
    return True, dist[goal], vertices, codes, settled


@njit
def descend(cost: np.ndarray, factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
            x0: int, y0: int, x1: int, y1: int, px: int, py: int) -> np.ndarray:
    """The cheapest path from the source of a cost map to cell (px, py), source first.

    ``cost`` is the exact cost from the source to each cell of the window [x0, x1] x [y0, y1]
    (row-major over the window, as ``cbr_solvers.aistar.cost_map`` gives it). From (px, py) the
    walk steps to the neighbour through which the cell was reached, the one minimising the
    neighbour's cost plus the step, until it reaches cost 0.
    """
    ww = x1 - x0 + 1
    limit = cost.shape[0] * cost.shape[1] if cost.ndim == 2 else cost.shape[0]
    flat = cost.ravel()
    xs = np.empty(limit + 1, dtype=np.int64)
    ys = np.empty(limit + 1, dtype=np.int64)
    xs[0], ys[0] = px, py
    count = 1
    cx, cy = px, py
    while flat[(cy - y0) * ww + (cx - x0)] > 0.0 and count <= limit:
        best = np.inf
        bx, by = -1, -1
        for d in range(8):
            if not move(passable, corner_cutting, cx, cy, d, x0, y0, x1, y1):
                continue
            nx, ny = cx + DX[d], cy + DY[d]
            step = (SQRT2 if d >= 4 else 1.0) * (factor[cy, cx] + factor[ny, nx]) * 0.5
            value = flat[(ny - y0) * ww + (nx - x0)] + step
            if value < best:
                best, bx, by = value, nx, ny
        if bx < 0:
            break
        cx, cy = bx, by
        xs[count], ys[count] = cx, cy
        count += 1
    path = np.empty((count, 2), dtype=np.int64)
    for i in range(count):
        path[i, 0] = xs[count - 1 - i]
        path[i, 1] = ys[count - 1 - i]
    return path


@njit(inline="always")
def run_cost(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, x: int, y: int,
             ex: int, ey: int) -> float:
    """The cost of the straight run (x, y) -> (ex, ey); inf when a step is not allowed."""
    h, w = passable.shape
    dx, dy = np.sign(ex - x), np.sign(ey - y)
    d = 0
    for j in range(8):
        if DX[j] == dx and DY[j] == dy:
            d = j
    steps = max(abs(ex - x), abs(ey - y))
    if steps > 0 and not passable[y, x]:
        return np.inf
    total = 0.0
    for _ in range(steps):
        if not move(passable, corner_cutting, x, y, d, 0, 0, w - 1, h - 1):
            return np.inf
        nx, ny = x + dx, y + dy
        total += (SQRT2 if d >= 4 else 1.0) * (factor[y, x] + factor[ny, nx]) * 0.5
        x, y = nx, ny
    return total


@njit(inline="always")
def run_risk(risk: np.ndarray, x: int, y: int, ex: int, ey: int) -> float:
    """The mean risk of the cells of the straight run (x, y) -> (ex, ey), both ends included."""
    dx, dy = np.sign(ex - x), np.sign(ey - y)
    steps = max(abs(ex - x), abs(ey - y))
    total = 0.0
    for _ in range(steps + 1):
        total += risk[y, x]
        x, y = x + dx, y + dy
    return total / (steps + 1)


@njit
def run_costs(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
              starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """The cost of each straight run starts[k] -> ends[k]; inf when a step is not allowed."""
    costs = np.zeros(starts.shape[0])
    for k in range(starts.shape[0]):
        costs[k] = run_cost(factor, passable, corner_cutting, starts[k, 0], starts[k, 1],
                            ends[k, 0], ends[k, 1])
    return costs


@njit
def run_risks(risk: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """The mean risk of the cells of each straight run starts[k] -> ends[k], both ends
    included."""
    means = np.zeros(starts.shape[0])
    for k in range(starts.shape[0]):
        means[k] = run_risk(risk, starts[k, 0], starts[k, 1], ends[k, 0], ends[k, 1])
    return means


@njit
def path_cost(factor: np.ndarray, path: np.ndarray) -> float:
    """The cost of a path of 8-neighbour steps under the step cost contract."""
    total = 0.0
    for k in range(path.shape[0] - 1):
        x, y, nx, ny = path[k, 0], path[k, 1], path[k + 1, 0], path[k + 1, 1]
        length = SQRT2 if x != nx and y != ny else 1.0
        total += length * (factor[y, x] + factor[ny, nx]) * 0.5
    return total
