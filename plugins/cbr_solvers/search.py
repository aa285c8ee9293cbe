"""Compiled shortest-path searches on an 8-connected grid: Dijkstra and A*.

A grid reaches the search as numpy arrays indexed ``[y, x]``: ``factor`` (float64, the cost
factor of each cell), ``passable`` (bool) and the ``corner_cutting`` flag. One step between
8-neighbours ``a`` and ``b`` costs ``step_length * (factor[a] + factor[b]) / 2``, the step length
being 1 orthogonally and sqrt(2) diagonally. A diagonal step passes the two orthogonal cells
beside it: without corner cutting both must be passable, with corner cutting one (never squeezing
between two obstacles, the rule of ``cbr_grid.grid.Grid``). With every factor 1 the costs are
octile lengths.

Both searches share one numba kernel (compiled once per process, cached on disk) with a binary
heap over flat cell indices and lazy deletion: an improved cell is pushed again and its stale
entries are skipped when popped. The search may be limited to a window, an inclusive bounding
box of cells; its working arrays then cover only the window.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import attrs
import numba
import numpy as np

SQRT2 = math.sqrt(2.0)

# The 8 neighbour offsets (dx, dy): the orthogonal ones first, then the diagonals.
_DX = np.array([1, -1, 0, 0, 1, 1, -1, -1], dtype=np.int64)
_DY = np.array([0, 0, 1, -1, 1, -1, 1, -1], dtype=np.int64)

_INITIAL_HEAP = 1024


@attrs.frozen
class SearchResult:
    """A path found by a search.

    ``path`` is an (n, 2) int64 array of (x, y) rows from the start to the goal reached, ``cost``
    its cost under the grid's cost contract and ``expanded`` the number of cells settled.
    """

    path: np.ndarray = attrs.field(eq=attrs.cmp_using(eq=np.array_equal))
    cost: float
    expanded: int


@numba.njit(cache=True)
def _push(keys: np.ndarray, items: np.ndarray, size: int, key: float, item: int) -> None:
    """Add (key, item) to the heap of ``size`` entries; the arrays have room for it."""
    # Move the hole up rather than swapping: one write per level instead of two.
    i = size
    while i > 0:
        parent = (i - 1) >> 1
        if keys[parent] <= key:
            break
        keys[i] = keys[parent]
        items[i] = items[parent]
        i = parent
    keys[i] = key
    items[i] = item


@numba.njit(cache=True)
def _pop(keys: np.ndarray, items: np.ndarray, size: int) -> int:
    """Remove the entry with the smallest key from the heap of ``size`` entries; its item."""
    top = items[0]
    size -= 1
    key, item = keys[size], items[size]
    i = 0
    while True:
        child = 2 * i + 1
        if child >= size:
            break
        if child + 1 < size and keys[child + 1] < keys[child]:
            child += 1
        if key <= keys[child]:
            break
        keys[i] = keys[child]
        items[i] = items[child]
        i = child
    keys[i] = key
    items[i] = item
    return top


@numba.njit(cache=True)
def _heuristic(x: int, y: int, goals: np.ndarray, scale: float) -> float:
    best = np.inf
    for k in range(goals.shape[0]):
        dx = abs(goals[k, 0] - x)
        dy = abs(goals[k, 1] - y)
        octile = max(dx, dy) + (SQRT2 - 1.0) * min(dx, dy)
        best = min(best, octile)
    return best * scale


@numba.njit(cache=True)
def _search(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, sx: int, sy: int,
            goals: np.ndarray, x0: int, y0: int, x1: int, y1: int, informed: bool,
            table: np.ndarray) -> tuple[bool, np.ndarray, float, int]:
    """Search from (sx, sy) to the nearest goal inside the window [x0, x1] x [y0, y1].

    Returns (found, path, cost, expanded). ``informed`` selects A* (octile heuristic scaled by
    the smallest passable factor in the window) over Dijkstra; a non-empty ``table`` gives A* its
    heuristic instead, one value per window cell in the window's row-major order. The caller
    guarantees that the window lies inside the grid, the start inside the window and the goals
    on the grid. The cells a diagonal step passes beside it are judged on the whole grid, window
    or not.
    """
    ww = x1 - x0 + 1
    n = ww * (y1 - y0 + 1)

    # The smallest factor keeps the heuristic admissible: no step is cheaper than its length
    # times it. Reading the window also checks the factors the search can meet.
    scale = np.inf
    for y in range(y0, y1 + 1):
        for x in range(x0, x1 + 1):
            if passable[y, x]:
                f = factor[y, x]
                if not (f > 0.0 and f < np.inf):
                    raise ValueError("factor must be finite and positive on passable cells")
                scale = min(scale, f)

    is_goal = np.zeros(n, dtype=np.bool_)
    inside = np.zeros(goals.shape[0], dtype=np.bool_)
    for k in range(goals.shape[0]):
        gx, gy = goals[k, 0], goals[k, 1]
        if x0 <= gx <= x1 and y0 <= gy <= y1 and passable[gy, gx]:
            is_goal[(gy - y0) * ww + (gx - x0)] = True
            inside[k] = True
    targets = goals[inside]
    empty = np.empty((0, 2), dtype=np.int64)
    if targets.shape[0] == 0 or not passable[sy, sx]:
        return False, empty, np.inf, 0

    dist = np.full(n, np.inf)
    parent = np.full(n, -1, dtype=np.int64)
    closed = np.zeros(n, dtype=np.bool_)
    keys = np.empty(_INITIAL_HEAP, dtype=np.float64)
    items = np.empty(_INITIAL_HEAP, dtype=np.int64)

    start = (sy - y0) * ww + (sx - x0)
    dist[start] = 0.0
    tabled = table.shape[0] > 0
    if not informed:
        keys[0] = 0.0
    elif tabled:
        keys[0] = table[start]
    else:
        keys[0] = _heuristic(sx, sy, targets, scale)
    items[0] = start
    size = 1
    expanded = 0
    reached = -1

    while size > 0:
        cell = _pop(keys, items, size)
        size -= 1
        if closed[cell]:
            continue  # a stale entry of a cell settled through a cheaper push
        closed[cell] = True
        expanded += 1
        if is_goal[cell]:
            reached = cell
            break

        cx = x0 + cell % ww
        cy = y0 + cell // ww
        here = dist[cell]
        fc = factor[cy, cx]
        for d in range(8):
            dx, dy = _DX[d], _DY[d]
            nx, ny = cx + dx, cy + dy
            if nx < x0 or nx > x1 or ny < y0 or ny > y1 or not passable[ny, nx]:
                continue
            diagonal = d >= 4
            if diagonal:
                beside_x, beside_y = passable[cy, nx], passable[ny, cx]
                if not ((beside_x or beside_y) if corner_cutting else (beside_x and beside_y)):
                    continue
            other = (ny - y0) * ww + (nx - x0)
            if closed[other]:
                continue
            length = SQRT2 if diagonal else 1.0
            g = here + length * (fc + factor[ny, nx]) * 0.5
            if g >= dist[other]:
                continue
            dist[other] = g
            parent[other] = cell
            if size == keys.shape[0]:
                keys = np.concatenate((keys, np.empty_like(keys)))
                items = np.concatenate((items, np.empty_like(items)))
            key = g
            if tabled:
                key += table[other]
            elif informed:
                key += _heuristic(nx, ny, targets, scale)
            _push(keys, items, size, key, other)
            size += 1

    if reached < 0:
        return False, empty, np.inf, expanded

    steps = 1
    cell = reached
    while cell != start:
        cell = parent[cell]
        steps += 1
    path = np.empty((steps, 2), dtype=np.int64)
    cell = reached
    for i in range(steps - 1, -1, -1):
        path[i, 0] = x0 + cell % ww
        path[i, 1] = y0 + cell // ww
        cell = parent[cell]
    return True, path, dist[reached], expanded


# Builds an A* heuristic table for (factor, passable, corner_cutting, goals, (x0, y0, x1, y1)).
HeuristicTable = Callable[[np.ndarray, np.ndarray, bool, np.ndarray, tuple[int, int, int, int]],
                          np.ndarray]

_NO_TABLE = np.empty(0, dtype=np.float64)


def _run(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, start: Sequence[int],
         goals: object, window: Sequence[int] | None, informed: bool,
         heuristic: HeuristicTable | None = None) -> SearchResult | None:
    """Check and convert the arguments of :func:`dijkstra` and :func:`astar`, then search.

    ``heuristic``, given, builds the A* heuristic table from the checked arrays, the goals and
    the clipped window (see :func:`_search`).
    """
    factor = np.ascontiguousarray(factor, dtype=np.float64)
    passable = np.ascontiguousarray(passable, dtype=np.bool_)
    if factor.ndim != 2 or factor.shape != passable.shape:
        raise ValueError(f"factor {factor.shape} and passable {passable.shape} must be one (h, w)"
                         " shape")
    h, w = passable.shape
    sx, sy = (int(v) for v in start)
    if not (0 <= sx < w and 0 <= sy < h):
        raise ValueError(f"start {(sx, sy)} is outside the {w}x{h} grid")
    targets = np.ascontiguousarray(np.asarray(goals, dtype=np.int64).reshape(-1, 2))
    outside = ~((targets >= 0) & (targets < (w, h))).all(axis=1)
    if outside.any():
        raise ValueError(f"goal {tuple(targets[outside][0])} is outside the {w}x{h} grid")
    if window is None:
        x0, y0, x1, y1 = 0, 0, w - 1, h - 1
    else:
        wx0, wy0, wx1, wy1 = (int(v) for v in window)
        x0, y0, x1, y1 = max(wx0, 0), max(wy0, 0), min(wx1, w - 1), min(wy1, h - 1)
    if not (x0 <= sx <= x1 and y0 <= sy <= y1):
        return None
    table = _NO_TABLE
    if heuristic is not None:
        table = np.ascontiguousarray(
            heuristic(factor, passable, bool(corner_cutting), targets, (x0, y0, x1, y1)),
            dtype=np.float64).reshape(-1)
    found, path, cost, expanded = _search(factor, passable, bool(corner_cutting), sx, sy, targets,
                                          x0, y0, x1, y1, informed, table)
    return SearchResult(path, float(cost), int(expanded)) if found else None


def dijkstra(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, start: Sequence[int],
             goals: object, window: Sequence[int] | None = None) -> SearchResult | None:
    """The cheapest path from ``start`` to the nearest of ``goals`` by Dijkstra's algorithm.

    ``start`` is an (x, y) cell, ``goals`` a (k, 2) array of (x, y) rows (the search stops at the
    first goal it settles, the cheapest to reach), ``window`` an optional inclusive bounding box
    (x0, y0, x1, y1), clipped to the grid, that the path must stay in. Returns None when no goal
    can be reached (also when the start is blocked or outside the window). Raises ValueError for
    cells outside the grid and for factors that are not finite and positive on passable cells.
    """
    return _run(factor, passable, corner_cutting, start, goals, window, informed=False)


def astar(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, start: Sequence[int],
          goals: object, window: Sequence[int] | None = None) -> SearchResult | None:
    """The cheapest path from ``start`` to the nearest of ``goals`` by A*.

    Arguments and result as for :func:`dijkstra`. The heuristic is the octile distance to the
    nearest goal times the smallest factor of a passable cell in the window, which no step can
    undercut, so it is admissible and consistent and the cost is optimal.
    """
    return _run(factor, passable, corner_cutting, start, goals, window, informed=True)
