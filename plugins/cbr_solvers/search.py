"""Compiled shortest-path searches on an 8-connected grid: Dijkstra and A*.

A grid reaches the search as numpy arrays indexed ``[y, x]``: ``factor`` (float64, the cost
factor of each cell), ``passable`` (bool) and the ``corner_cutting`` flag. One step between
8-neighbours ``a`` and ``b`` costs ``step_length * (factor[a] + factor[b]) / 2``, the step length
being 1 orthogonally and sqrt(2) diagonally. A diagonal step passes the two orthogonal cells
beside it: without corner cutting both must be passable, with corner cutting one (never squeezing
between two obstacles, the rule of ``cbr_grid.grid.Grid``). With every factor 1 the costs are
octile lengths.

Both searches share one numba kernel (compiled once per process, cached on disk) over flat cell
indices, built on :mod:`cbr_grid.search_base`: its binary heap with lazy deletion (an improved
cell is pushed again and its stale entries are skipped when popped), its moves and corner rule,
its argument checks and its per-thread working arrays, where a generation stamp, not a fill,
marks what one search has seen, so a call costs in proportion to the cells it touches rather than
to the grid. The search may be limited to a window, an inclusive bounding box of cells. A*'s
heuristic scale (the least passable factor) is a vectorised reduction over the window,
remembered for whole grids given as read-only arrays (those of ``cbr_grid.grid.Grid``);
Dijkstra needs none.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Sequence

import attrs
import numpy as np

from cbr_grid.costs import SQRT2
from cbr_grid.search_base import (
    DX,
    DY,
    INITIAL_HEAP,
    Workspace,
    checked_arguments,
    move,
    pop,
    push_grown,
)
from cbrcore.compiled import njit


@attrs.frozen
class SearchResult:
    """A path found by a search.

    ``path`` is an (n, 2) int64 array of (x, y) rows from the start to the goal reached, ``cost``
    its cost under the grid's cost contract and ``expanded`` the number of cells settled.
    """

    path: np.ndarray = attrs.field(eq=attrs.cmp_using(eq=np.array_equal))
    cost: float
    expanded: int


@njit
def _heuristic(x: int, y: int, goals: np.ndarray, scale: float) -> float:
    best = np.inf
    for k in range(goals.shape[0]):
        dx = abs(goals[k, 0] - x)
        dy = abs(goals[k, 1] - y)
        octile = max(dx, dy) + (SQRT2 - 1.0) * min(dx, dy)
        best = min(best, octile)
    return best * scale


@njit
def window_min_factor(factor: np.ndarray, passable: np.ndarray, x0: int, y0: int, x1: int,
                      y1: int) -> float:
    """The least factor of a passable cell in the window (inf if none); ValueError for one that
    is not finite and positive. Left to the kernels on small windows, where numpy's call
    overhead would dominate."""
    least = np.inf
    for y in range(y0, y1 + 1):
        for x in range(x0, x1 + 1):
            if passable[y, x]:
                f = factor[y, x]
                if not (f > 0.0 and f < np.inf):
                    raise ValueError("factor must be finite and positive on passable cells")
                least = min(least, f)
    return least


@njit
def _search(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, sx: int, sy: int,
            goals: np.ndarray, x0: int, y0: int, x1: int, y1: int, informed: bool, scale: float,
            table: np.ndarray, stamp: np.ndarray, dist: np.ndarray, parent: np.ndarray,
            goal_mark: np.ndarray, generation: int) -> tuple[bool, np.ndarray, float, int]:
    """Search from (sx, sy) to the nearest goal inside the window [x0, x1] x [y0, y1].

    Returns (found, path, cost, expanded). ``informed`` selects A* (octile heuristic times
    ``scale``, at most the smallest passable factor in the window, or that factor found here
    when ``scale`` is negative) over Dijkstra; a non-empty
    ``table`` gives A* its heuristic instead, one value per window cell in the window's
    row-major order. The caller guarantees that the window lies inside the grid, the start inside
    the window and the goals on the grid. The cells a diagonal step passes beside it are judged
    on the whole grid, window or not. A factor that is not finite and positive raises ValueError
    when the search meets its cell.

    ``stamp``, ``dist``, ``parent`` and ``goal_mark`` are reused working arrays of at least the
    window's size, indexed like ``table``. Nothing is cleared between searches: a cell has been
    reached in this search iff ``stamp == generation`` (then ``dist`` and ``parent`` are its
    own), settled iff ``stamp == generation + 1``, and is a goal iff ``goal_mark == generation``;
    older stamps are below ``generation``.
    """
    ww = x1 - x0 + 1
    settled = generation + 1

    if informed and scale < 0.0:
        scale = window_min_factor(factor, passable, x0, y0, x1, y1)

    inside = np.zeros(goals.shape[0], dtype=np.bool_)
    for k in range(goals.shape[0]):
        gx, gy = goals[k, 0], goals[k, 1]
        if x0 <= gx <= x1 and y0 <= gy <= y1 and passable[gy, gx]:
            goal_mark[(gy - y0) * ww + (gx - x0)] = generation
            inside[k] = True
    targets = goals[inside]
    empty = np.empty((0, 2), dtype=np.int64)
    if targets.shape[0] == 0 or not passable[sy, sx]:
        return False, empty, np.inf, 0
    fs = factor[sy, sx]
    if not (fs > 0.0 and fs < np.inf):
        raise ValueError("factor must be finite and positive on passable cells")

    keys = np.empty(INITIAL_HEAP, dtype=np.float64)
    items = np.empty(INITIAL_HEAP, dtype=np.int64)

    start = (sy - y0) * ww + (sx - x0)
    stamp[start] = generation
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
        cell = pop(keys, items, size)
        size -= 1
        if stamp[cell] == settled:
            continue  # a stale entry of a cell settled through a cheaper push
        stamp[cell] = settled
        expanded += 1
        if goal_mark[cell] == generation:
            reached = cell
            break

        cx = x0 + cell % ww
        cy = y0 + cell // ww
        here = dist[cell]
        fc = factor[cy, cx]
        for d in range(8):
            if not move(passable, corner_cutting, cx, cy, d, x0, y0, x1, y1):
                continue
            nx, ny = cx + DX[d], cy + DY[d]
            diagonal = d >= 4
            other = (ny - y0) * ww + (nx - x0)
            mark = stamp[other]
            if mark == settled:
                continue
            fn = factor[ny, nx]
            if not (fn > 0.0 and fn < np.inf):
                raise ValueError("factor must be finite and positive on passable cells")
            length = SQRT2 if diagonal else 1.0
            g = here + length * (fc + fn) * 0.5
            if mark == generation and g >= dist[other]:
                continue
            stamp[other] = generation
            dist[other] = g
            parent[other] = cell
            key = g
            if tabled:
                key += table[other]
            elif informed:
                key += _heuristic(nx, ny, targets, scale)
            keys, items = push_grown(keys, items, size, key, other)
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


_WORKSPACE = Workspace()

# The smallest passable factor of whole read-only grids: (id(factor), id(passable)) -> (weak
# references to both, value). The references tell a live array from a new one at a reused id.
_SCALES: dict[tuple[int, int], tuple[weakref.ref, weakref.ref, float]] = {}
_SCALES_KEPT = 8
# Windows of at most this many cells that cannot be remembered are scanned by the kernel.
_SMALL_WINDOW = 4096


def _frozen(array: np.ndarray) -> bool:
    """Whether no one can write ``array``'s data through numpy: it and every base read-only."""
    while isinstance(array, np.ndarray):
        if array.flags.writeable:
            return False
        array = array.base
    return array is None


def _min_factor(factor: np.ndarray, passable: np.ndarray, window: tuple[int, int, int, int],
                whole: bool) -> float:
    """The smallest factor of a passable cell in the window (inf if none); ValueError if not > 0.

    For the whole grid of read-only arrays (a :class:`cbr_grid.grid.Grid`'s) the value is
    remembered per pair of arrays. Returns -1 for a small window that is not remembered: the
    kernel then finds the value itself.
    """
    # Read-only now, the arrays may be made writable again later: check at every call.
    whole = whole and _frozen(factor) and _frozen(passable)
    key = (id(factor), id(passable))
    if whole:
        known = _SCALES.get(key)
        if known is not None and known[0]() is factor and known[1]() is passable:
            return known[2]
    x0, y0, x1, y1 = window
    if not whole and (x1 - x0 + 1) * (y1 - y0 + 1) <= _SMALL_WINDOW:
        return -1.0
    region, open_ = factor[y0:y1 + 1, x0:x1 + 1], passable[y0:y1 + 1, x0:x1 + 1]
    value = np.inf
    if region.size:
        # Fast path: the least factor of the window, if a passable cell has it (NaN fails here).
        value = float(region.min())
        attained = region == value
        attained &= open_
        if not (value > 0.0 and attained.any()):
            value = float(np.where(open_, region, np.inf).min())
    # Also NaN, and only infinite factors; other infinite ones are refused when the search meets
    # them.
    if not value > 0.0 or (value == np.inf and open_.any()):
        raise ValueError("factor must be finite and positive on passable cells")
    if whole:
        if len(_SCALES) >= _SCALES_KEPT:
            _SCALES.pop(next(iter(_SCALES)))
        _SCALES[key] = (weakref.ref(factor), weakref.ref(passable), value)
    return value


# Builds an A* heuristic table for (factor, passable, corner_cutting, goals, (x0, y0, x1, y1)).
HeuristicTable = Callable[[np.ndarray, np.ndarray, bool, np.ndarray, tuple[int, int, int, int]],
                          np.ndarray]

_NO_TABLE = np.empty(0, dtype=np.float64)


def guidance(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
             targets: np.ndarray, box: tuple[int, int, int, int], informed: bool,
             heuristic: HeuristicTable | None) -> tuple[np.ndarray, float] | None:
    """A*'s heuristic for a search of the window ``box`` of checked arrays: (per-cell table,
    octile scale). The table is ``heuristic``'s when one is given, else empty; the scale is the
    least passable factor (-1 for a small window, which the kernel scans itself) when
    ``informed``, else 1. None when the window has no passable cell, so no path."""
    if heuristic is not None:
        table = np.ascontiguousarray(
            heuristic(factor, passable, bool(corner_cutting), targets, box),
            dtype=np.float64).reshape(-1)
        return table, 1.0
    if not informed:
        return _NO_TABLE, 1.0
    h, w = passable.shape
    scale = _min_factor(factor, passable, box, box == (0, 0, w - 1, h - 1))
    return None if scale == np.inf else (_NO_TABLE, scale)


def _run(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, start: Sequence[int],
         goals: object, window: Sequence[int] | None, informed: bool,
         heuristic: HeuristicTable | None = None) -> SearchResult | None:
    """Check and convert the arguments of :func:`dijkstra` and :func:`astar`, then search.

    ``heuristic``, given, builds the A* heuristic table from the checked arrays, the goals and
    the clipped window (see :func:`_search`).
    """
    factor, passable, (sx, sy), targets, (x0, y0, x1, y1) = checked_arguments(
        factor, passable, start, goals, window)
    if not (x0 <= sx <= x1 and y0 <= sy <= y1):
        return None
    box = (x0, y0, x1, y1)
    guide = guidance(factor, passable, corner_cutting, targets, box, informed, heuristic)
    if guide is None:
        return None
    table, scale = guide
    stamp, dist, parent, goal_mark, generation = _WORKSPACE.take((x1 - x0 + 1) * (y1 - y0 + 1))
    found, path, cost, expanded = _search(factor, passable, bool(corner_cutting), sx, sy, targets,
                                          x0, y0, x1, y1, informed, scale, table, stamp, dist,
                                          parent, goal_mark, generation)
    return SearchResult(path, float(cost), int(expanded)) if found else None


def dijkstra(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, start: Sequence[int],
             goals: object, window: Sequence[int] | None = None) -> SearchResult | None:
    """The cheapest path from ``start`` to the nearest of ``goals`` by Dijkstra's algorithm.

    ``start`` is an (x, y) cell, ``goals`` a (k, 2) array of (x, y) rows (the search stops at the
    first goal it settles, the cheapest to reach), ``window`` an optional inclusive bounding box
    (x0, y0, x1, y1), clipped to the grid, that the path must stay in. Returns None when no goal
    can be reached (also when the start is blocked or outside the window). Raises ValueError for
    cells outside the grid and for a factor that is not finite and positive on a passable cell
    the search meets.
    """
    return _run(factor, passable, corner_cutting, start, goals, window, informed=False)


def astar(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, start: Sequence[int],
          goals: object, window: Sequence[int] | None = None) -> SearchResult | None:
    """The cheapest path from ``start`` to the nearest of ``goals`` by A*.

    Arguments and result as for :func:`dijkstra`. The heuristic is the octile distance to the
    nearest goal times the smallest factor of a passable cell in the window, which no step can
    undercut, so it is admissible and consistent and the cost is optimal. Besides the cells it
    meets, a factor that is NaN or not positive on any passable cell of the window is refused.
    """
    return _run(factor, passable, corner_cutting, start, goals, window, informed=True)
