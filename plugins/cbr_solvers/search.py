"""Compiled shortest-path searches on an 8-connected grid: Dijkstra and A*.

A grid reaches the search as numpy arrays indexed ``[y, x]``: ``factor`` (float64, the cost
factor of each cell), ``passable`` (bool) and the ``corner_cutting`` flag. One step between
8-neighbours ``a`` and ``b`` costs ``step_length * (factor[a] + factor[b]) / 2``, the step length
being 1 orthogonally and sqrt(2) diagonally. A diagonal step passes the two orthogonal cells
beside it: without corner cutting both must be passable, with corner cutting one (never squeezing
between two obstacles, the rule of ``cbr_grid.grid.Grid``). With every factor 1 the costs are
octile lengths.

Both searches share one numba kernel (compiled once per process, cached on disk) over flat cell
indices, built on :mod:`cbr_grid.search_base`: its 4-ary heap with lazy deletion (an improved
cell is pushed again and its stale entries are skipped when popped), its moves, corner rule and
move masks, its argument checks and its per-thread working arrays, where a generation stamp, not
a fill, marks what one search has seen, so a call costs in proportion to the cells it touches
rather than to the grid. The search may be limited to a window, an inclusive bounding box of
cells. Both stay exact and save work four ways:

- the eight moves of a cell are one byte of the grid's move masks, built once for read-only
  arrays (those of ``cbr_grid.grid.Grid``) and clipped by the window on its border;
- when every passable factor in the window is equal, a cell's cost is counted in orthogonal and
  diagonal steps (integers) and no factor is read, so equal costs are equal floats; a factor
  held once for a whole large grid (:func:`cbr_grid.costs.broadcast_factor`) is read as its one
  value, never copied cell by cell;
- A* breaks ties in f toward the cell nearer the goal, by a bias too small to reorder different
  costs (see :func:`_search`);
- a successor that would be the next cell popped skips the heap.

The least and greatest passable factor of the window (A*'s heuristic scale, and whether costs
are uniform) are remembered for whole read-only grids.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Sequence

import attrs
import numpy as np

from cbr_grid.costs import SQRT2, uniform_factor
from cbr_grid.search_base import (
    DX,
    DY,
    INITIAL_HEAP,
    LEAVING,
    CellWorkspace,
    cell_moves,
    checked_arguments,
    move_masks,
    pop,
    pop4,
    push,
    push4,
    push4_grown,
)
from cbr_kernels import njit


@attrs.frozen
class SearchResult:
    """A path found by a search.

    ``path`` is an (n, 2) int64 array of (x, y) rows from the start to the goal reached, ``cost``
    its cost under the grid's cost contract and ``expanded`` the number of cells settled.
    """

    path: np.ndarray = attrs.field(eq=attrs.cmp_using(eq=np.array_equal))
    cost: float
    expanded: int


@njit(inline="always")
def _heuristic(x: int, y: int, goals: np.ndarray, scale: float) -> float:
    """The octile distance from (x, y) to the nearest of ``goals``, times ``scale``."""
    best = np.inf
    for k in range(goals.shape[0]):
        dx = abs(goals[k, 0] - x)
        dy = abs(goals[k, 1] - y)
        octile = max(dx, dy) + (SQRT2 - 1.0) * min(dx, dy)
        best = min(best, octile)
    return best * scale


@njit
def factor_range(factor: np.ndarray, passable: np.ndarray, x0: int, y0: int, x1: int, y1: int
                 ) -> tuple[float, float]:
    """The least and the greatest factor of a passable cell in the window (inf, -inf if none);
    ValueError for one that is not finite and positive."""
    least, most = np.inf, -np.inf
    for y in range(y0, y1 + 1):
        for x in range(x0, x1 + 1):
            if passable[y, x]:
                f = factor[y, x]
                if not (f > 0.0 and f < np.inf):
                    raise ValueError("factor must be finite and positive on passable cells")
                least = min(least, f)
                most = max(most, f)
    return least, most


@njit
def window_min_factor(factor: np.ndarray, passable: np.ndarray, x0: int, y0: int, x1: int,
                      y1: int) -> float:
    """The least factor of a passable cell in the window (inf if none); ValueError for one that
    is not finite and positive. Left to the kernels on small windows, where numpy's call
    overhead would dominate."""
    return factor_range(factor, passable, x0, y0, x1, y1)[0]


_LOW = (1 << 32) - 1
# A uniform search counts a cell's steps in one int64: orthogonal ones above bit 32, diagonal
# ones below, so its cost a + b·sqrt(2) is computed afresh from integers wherever it is needed.
_ORTHOGONAL_STEP = 1 << 32


@njit(inline="always")
def _octile_steps(x: int, y: int, targets: np.ndarray) -> tuple[int, int]:
    """The octile distance from (x, y) to the nearest target as (orthogonal, diagonal) steps."""
    best, straight, slanted = np.inf, 0, 0
    for k in range(targets.shape[0]):
        dx = abs(targets[k, 0] - x)
        dy = abs(targets[k, 1] - y)
        low, high = min(dx, dy), max(dx, dy)
        length = (high - low) + low * SQRT2
        if length < best:
            best, straight, slanted = length, high - low, low
    return straight, slanted


@njit(inline="always")
def _length(steps: int) -> float:
    """The length a + b·sqrt(2) of a uniform search's step count (see ``_ORTHOGONAL_STEP``)."""
    return (steps >> 32) + (steps & _LOW) * SQRT2


@njit
def _search(factor: np.ndarray, passable: np.ndarray, moves: np.ndarray, corner_cutting: bool,
            sx: int, sy: int, goals: np.ndarray, x0: int, y0: int, x1: int, y1: int,
            informed: bool, least: float, most: float, table: np.ndarray, stamp: np.ndarray,
            dist: np.ndarray, steps: np.ndarray, parent: np.ndarray, generation: int
            ) -> tuple[bool, np.ndarray, float, int]:
    """Search from (sx, sy) to the nearest goal inside the window [x0, x1] x [y0, y1].

    Returns (found, path, cost, expanded). ``factor`` is the grid's factor array raveled,
    ``passable`` the (h, w) mask and ``moves`` the grid's move masks
    (:func:`cbr_grid.search_base.move_masks`), or empty to work them out per cell. ``least``
    and ``most`` are the least and greatest passable factor in the window, both negative to
    find them here (which also refuses a factor that is not finite and positive). When they are
    equal every step costs its length times that factor: the search then counts steps in
    integers (``steps``) instead of summing costs (``dist``), so equal costs are equal floats and
    A*'s tie rule works on them. ``informed`` selects A* over Dijkstra; its heuristic is
    ``table`` when not empty (one value per window cell in row-major order), else the octile
    distance to the nearest goal times ``least``; with uniform costs, among cells of equal f the
    one of lower heuristic pops first (see ``tie`` below). The caller guarantees that the window
    lies inside the grid, the start inside the window and the goals on the grid.

    ``stamp``, ``dist`` and ``parent`` are reused working arrays of at least the window's size,
    indexed like ``table``; ``steps`` is ``dist`` viewed as int64. Nothing is cleared between
    searches: a cell has been reached in this search iff ``stamp == generation`` (then its
    ``dist`` or ``steps`` and ``parent``, the move that reached it, are its own), settled iff
    ``stamp == generation + 1``; older stamps are below ``generation``.
    """
    w = passable.shape[1]
    ww = x1 - x0 + 1
    settled = generation + 1
    empty = np.empty((0, 2), dtype=np.int64)

    if least < 0.0:
        least, most = factor_range(factor.reshape(passable.shape), passable, x0, y0, x1, y1)
    uniform = least == most

    inside = np.zeros(goals.shape[0], dtype=np.bool_)
    for k in range(goals.shape[0]):
        x, y = goals[k, 0], goals[k, 1]
        inside[k] = x0 <= x <= x1 and y0 <= y <= y1 and passable[y, x]
    targets = goals[inside]
    if targets.shape[0] == 0 or not passable[sy, sx]:
        return False, empty, np.inf, 0
    # The goals as sorted window cells: one comparison for one goal, a bisection for several.
    # They are sorted through the binary heap: numba's sort would be compiled for this alone.
    count = targets.shape[0]
    order_keys = np.empty(count, dtype=np.float64)
    order_items = np.empty(count, dtype=np.int64)
    for k in range(count):
        end = (targets[k, 1] - y0) * ww + (targets[k, 0] - x0)
        push(order_keys, order_items, k, float(end), end)
    ends = np.empty(count, dtype=np.int64)
    for k in range(count):
        ends[k] = pop(order_keys, order_items, count - k)
    single = ends.shape[0] == 1
    gx, gy = targets[0, 0], targets[0, 1]
    # A uniform A* breaks ties in f toward the cell nearer the goal (larger g) by adding
    # tie·h to f. Two different f = a + b·sqrt(2) of the window's cells differ by more than
    # 0.26 / |b - b'| > 0.26 / (cells + span), and tie·h stays below 0.1 / (cells + span):
    # the bias orders equal f only, so the search stays exact (as long as the floats resolve
    # that gap, i.e. for any f below about 10^7 on such a window).
    span = ww + (y1 - y0 + 1)
    tie = 0.1 / ((ww * (y1 - y0 + 1) + span) * span)

    window_step = DY * ww + DX
    grid_step = DY * w + DX
    tabled = table.shape[0] > 0
    masked = moves.shape[0] > 0

    keys = np.empty(INITIAL_HEAP, dtype=np.float64)
    items = np.empty(INITIAL_HEAP, dtype=np.int64)
    start = (sy - y0) * ww + (sx - x0)
    stamp[start] = generation
    steps[start] = 0  # also dist 0.0: both are all-zero bits
    keys[0] = 0.0
    items[0] = start
    size = 1
    expanded = 0
    reached = -1

    # A successor whose key is at most that of the cell being expanded would be the next pop:
    # it is held aside instead of pushed (a straight run toward the goal keeps f, so most of a
    # path's cells on open ground never enter the heap).
    held = -1
    held_key = 0.0
    while size > 0 or held >= 0:
        if held >= 0:
            cell, current = held, held_key
            held = -1
        else:
            cell, current = items[0], keys[0]
            pop4(keys, items, size)
            size -= 1
        if stamp[cell] == settled:
            continue  # a stale entry of a cell settled through a cheaper push
        stamp[cell] = settled
        expanded += 1
        if single:
            if cell == ends[0]:
                reached = cell
                break
        else:
            lo, hi = 0, ends.shape[0]
            while lo < hi:
                middle = (lo + hi) >> 1
                if ends[middle] < cell:
                    lo = middle + 1
                else:
                    hi = middle
            if lo < ends.shape[0] and ends[lo] == cell:
                reached = cell
                break

        row = cell // ww
        cx = x0 + cell - row * ww
        cy = y0 + row
        here = cy * w + cx
        mask = np.int64(moves[here]) if masked else cell_moves(passable, corner_cutting, cx, cy)
        if cx == x0:
            mask &= ~LEAVING[0]
        if cx == x1:
            mask &= ~LEAVING[1]
        if cy == y0:
            mask &= ~LEAVING[2]
        if cy == y1:
            mask &= ~LEAVING[3]
        counted = steps[cell]
        cost = dist[cell]
        fc = 0.0 if uniform else factor[here]  # a uniform search reads no factor
        for d in range(8):
            if not (mask >> d) & 1:
                continue
            other = cell + window_step[d]
            mark = stamp[other]
            if mark == settled:
                continue
            diagonal = d >= 4
            count = counted + (1 if diagonal else _ORTHOGONAL_STEP)
            if uniform:
                g = _length(count)
                if mark == generation and g >= _length(steps[other]):
                    continue
                steps[other] = count
            else:
                length = SQRT2 if diagonal else 1.0
                g = cost + length * (fc + factor[here + grid_step[d]]) * 0.5
                if mark == generation and g >= dist[other]:
                    continue
                dist[other] = g
            stamp[other] = generation
            parent[other] = d
            key = g
            if tabled:
                estimate = table[other]
                if estimate == np.inf:
                    continue  # no goal can be reached from there
                key = (g * least if uniform else g) + estimate
            elif informed:
                if single:
                    dx = abs(gx - cx - DX[d])
                    dy = abs(gy - cy - DY[d])
                    straight, slanted = max(dx, dy) - min(dx, dy), min(dx, dy)
                else:
                    straight, slanted = _octile_steps(cx + DX[d], cy + DY[d], targets)
                estimate = straight + slanted * SQRT2
                if uniform:
                    key = _length(count + (straight << 32) + slanted) + tie * estimate
                else:
                    key = g + estimate * least
            if key <= current and (held < 0 or key < held_key):
                held, held_key, key, other = other, key, held_key, held
                if other < 0:
                    continue
            if size < keys.shape[0]:
                push4(keys, items, size, key, other)  # inlined, no arrays returned
            else:
                keys, items = push4_grown(keys, items, size, key, other)
            size += 1

    if reached < 0:
        return False, empty, np.inf, expanded

    n = 1
    cell = reached
    while cell != start:
        cell -= window_step[parent[cell]]
        n += 1
    path = np.empty((n, 2), dtype=np.int64)
    cell = reached
    for i in range(n - 1, -1, -1):
        row = cell // ww
        path[i, 0] = x0 + cell - row * ww
        path[i, 1] = y0 + row
        if i:
            cell -= window_step[parent[cell]]
    total = _length(steps[reached]) * least if uniform else dist[reached]
    return True, path, total, expanded


_WORKSPACE = CellWorkspace()

# The least and greatest passable factor of whole read-only grids: (id(factor), id(passable))
# -> (weak references to both, least, greatest). The references tell a live array from a new
# one at a reused id.
_SCALES: dict[tuple[int, int], tuple[weakref.ref, weakref.ref, float, float]] = {}
_SCALES_KEPT = 8
# The move masks of read-only grids: (id(passable), corner_cutting) -> (weak reference, masks).
# One byte a cell, so few are kept.
_MASKS: dict[tuple[int, bool], tuple[weakref.ref, np.ndarray]] = {}
_MASKS_KEPT = 2
# Windows of at most this many cells that cannot be remembered are scanned by the kernel.
_SMALL_WINDOW = 4096
# A search builds a grid's move masks when its window covers at least this share of the grid;
# smaller windows use masks already built or work each cell's moves out. Grids of more cells
# than _MASKED_MAX keep no masks: a byte a cell is then worth more than the time it saves.
_MASKED_SHARE = 0.25
_MASKED_MAX = 1 << 24

_NO_MOVES = np.empty(0, dtype=np.uint8)
_ONE_FACTOR = np.ones(1)
"""What the kernel receives for a factor holding one value for every cell, which it never reads
(read-only like a Grid's factor, so that both share one compiled variant)."""
_ONE_FACTOR.setflags(write=False)
_NO_GOALS = np.empty((0, 2), dtype=np.int64)


def _frozen(array: np.ndarray) -> bool:
    """Whether no one can write ``array``'s data through numpy: it and every base read-only."""
    while isinstance(array, np.ndarray):
        if array.flags.writeable:
            return False
        array = array.base
    return array is None


def _remember(cache: dict, kept: int, key: object, entry: tuple) -> None:
    """Keep ``entry`` (weak references first) in ``cache``, dropping the entries of arrays that
    are gone, then the oldest beyond ``kept``."""
    for old in [k for k, value in cache.items() if value[0]() is None]:
        del cache[old]
    if len(cache) >= kept:
        cache.pop(next(iter(cache)))
    cache[key] = entry


def _profile(factor: np.ndarray, passable: np.ndarray, window: tuple[int, int, int, int],
             whole: bool) -> tuple[float, float]:
    """The least and greatest factor of a passable cell in the window (inf, -inf if none);
    ValueError for one that is not finite and positive.

    For the whole grid of read-only arrays (a :class:`cbr_grid.grid.Grid`'s) the values are
    remembered per pair of arrays. Returns (-1, -1) for a small window that is not remembered:
    the kernel then finds the values itself.
    """
    # Read-only now, the arrays may be made writable again later: check at every call.
    whole = whole and _frozen(factor) and _frozen(passable)
    key = (id(factor), id(passable))
    if whole:
        known = _SCALES.get(key)
        if known is not None and known[0]() is factor and known[1]() is passable:
            return known[2], known[3]
    x0, y0, x1, y1 = window
    value = uniform_factor(factor)
    if value is not None:
        # one factor for every cell: whether the window has a passable cell is all to find
        if not passable[y0:y1 + 1, x0:x1 + 1].any():
            least, most = np.inf, -np.inf
        elif 0.0 < value < np.inf:
            least = most = value
        else:
            raise ValueError("factor must be finite and positive on passable cells")
        if whole:
            _remember(_SCALES, _SCALES_KEPT, key,
                      (weakref.ref(factor), weakref.ref(passable), least, most))
        return least, most
    if not whole and (x1 - x0 + 1) * (y1 - y0 + 1) <= _SMALL_WINDOW:
        return -1.0, -1.0
    # Fast path for arrays that cannot be remembered: numpy's vectorised reductions over all the
    # window's cells settle the common case of one factor everywhere (NaN fails the test).
    region = factor[y0:y1 + 1, x0:x1 + 1]
    least = float(region.min()) if region.size else np.inf
    if not (least > 0.0 and least < np.inf and least == float(region.max())):
        least, most = factor_range(factor, passable, x0, y0, x1, y1)
    else:
        most = least
    if whole:
        _remember(_SCALES, _SCALES_KEPT, key,
                  (weakref.ref(factor), weakref.ref(passable), least, most))
    return least, most


def _moves(passable: np.ndarray, corner_cutting: bool, window: tuple[int, int, int, int]
           ) -> np.ndarray:
    """The grid's move masks for a search of ``window``: remembered for read-only grids, built
    when the window is a large share of the grid; empty (each cell worked out) otherwise."""
    if passable.size > _MASKED_MAX or not _frozen(passable):
        return _NO_MOVES
    key = (id(passable), corner_cutting)
    known = _MASKS.get(key)
    if known is not None and known[0]() is passable:
        return known[1]
    x0, y0, x1, y1 = window
    if (x1 - x0 + 1) * (y1 - y0 + 1) < _MASKED_SHARE * passable.size:
        return _NO_MOVES
    masks = move_masks(passable, corner_cutting)
    _remember(_MASKS, _MASKS_KEPT, key, (weakref.ref(passable), masks))
    return masks


def least_factor(factor: np.ndarray, passable: np.ndarray,
                 window: Sequence[int] | None = None) -> float:
    """The least factor of a passable cell of the grid, or of the inclusive window (x0, y0, x1,
    y1) clipped to it; inf if there is none. No step costs less per unit of length, so it
    scales admissible heuristics. Remembered for a whole grid of read-only arrays (a
    :class:`cbr_grid.grid.Grid`'s) and found without temporary arrays the size of the map.
    ValueError for a factor that is not finite and positive on a passable cell."""
    factor, passable, _, _, box = checked_arguments(factor, passable, (0, 0), np.empty((0, 2)),
                                                    window, uniform=True)
    h, w = passable.shape
    least = _profile(factor, passable, box, box == (0, 0, w - 1, h - 1))[0]
    return window_min_factor(factor, passable, *box) if least < 0.0 else least


def grid_profile(factor: np.ndarray, passable: np.ndarray) -> tuple[float, float]:
    """The least and greatest factor of a passable cell of the whole grid (inf, -inf if none):
    when they are equal every step costs its length times one factor. Remembered, as for A*,
    for read-only arrays (a :class:`cbr_grid.grid.Grid`'s). ValueError for a factor that is not
    finite and positive on a passable cell."""
    factor, passable, _, _, box = checked_arguments(factor, passable, (0, 0), _NO_GOALS, None,
                                                    uniform=True)
    return _profile(factor, passable, box, True)


def grid_moves(passable: np.ndarray, corner_cutting: bool) -> np.ndarray:
    """The move masks (:func:`cbr_grid.search_base.move_masks`) A* uses for a search of the
    whole grid: built once and shared for a read-only grid of at most 2^24 cells, empty (work
    each cell's moves out) otherwise."""
    h, w = passable.shape
    return _moves(passable, bool(corner_cutting), (0, 0, w - 1, h - 1))


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
    scale = _profile(factor, passable, box, box == (0, 0, w - 1, h - 1))[0]
    return None if scale == np.inf else (_NO_TABLE, scale)


def _run(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, start: Sequence[int],
         goals: object, window: Sequence[int] | None, informed: bool,
         heuristic: HeuristicTable | None = None) -> SearchResult | None:
    """Check and convert the arguments of :func:`dijkstra` and :func:`astar`, then search.

    ``heuristic``, given, builds the A* heuristic table from the checked arrays, the goals and
    the clipped window (see :func:`_search`).
    """
    factor, passable, (sx, sy), targets, box = checked_arguments(
        factor, passable, start, goals, window, uniform=True)
    x0, y0, x1, y1 = box
    if not (x0 <= sx <= x1 and y0 <= sy <= y1):
        return None
    h, w = passable.shape
    least, most = _profile(factor, passable, box, box == (0, 0, w - 1, h - 1))
    if least == np.inf:
        return None
    cells = factor.reshape(-1)
    if uniform_factor(factor) is not None:
        # equal factors: the kernel reads none (least == most), so one stands for them all
        cells = _ONE_FACTOR
    table = _NO_TABLE
    if heuristic is not None:
        table = np.ascontiguousarray(heuristic(factor, passable, bool(corner_cutting), targets,
                                               box), dtype=np.float64).reshape(-1)
    moves = _moves(passable, bool(corner_cutting), box)
    stamp, dist, parent, generation = _WORKSPACE.take((x1 - x0 + 1) * (y1 - y0 + 1))
    found, path, cost, expanded = _search(
        cells, passable, moves, bool(corner_cutting), sx, sy, targets, x0, y0, x1,
        y1, informed or heuristic is not None, least, most, table, stamp, dist,
        dist.view(np.int64), parent, generation)
    return SearchResult(path, float(cost), int(expanded)) if found else None


def dijkstra(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, start: Sequence[int],
             goals: object, window: Sequence[int] | None = None) -> SearchResult | None:
    """The cheapest path from ``start`` to the nearest of ``goals`` by Dijkstra's algorithm.

    ``start`` is an (x, y) cell, ``goals`` a (k, 2) array of (x, y) rows (the search stops at the
    first goal it settles, the cheapest to reach), ``window`` an optional inclusive bounding box
    (x0, y0, x1, y1), clipped to the grid, that the path must stay in. Returns None when no goal
    can be reached (also when the start is blocked or outside the window). Raises ValueError for
    cells outside the grid and for a factor that is not finite and positive on a passable cell
    of the window (every one is read to tell whether the costs are uniform).
    """
    return _run(factor, passable, corner_cutting, start, goals, window, informed=False)


def astar(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, start: Sequence[int],
          goals: object, window: Sequence[int] | None = None) -> SearchResult | None:
    """The cheapest path from ``start`` to the nearest of ``goals`` by A*.

    Arguments and result as for :func:`dijkstra`. The heuristic is the octile distance to the
    nearest goal times the smallest factor of a passable cell in the window, which no step can
    undercut, so it is admissible and consistent and the cost is optimal. Among cells of equal
    f it expands the one nearer the goal first.
    """
    return _run(factor, passable, corner_cutting, start, goals, window, informed=True)
