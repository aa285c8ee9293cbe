"""Jump point search (Harabor and Grastien, AAAI 2011) on uniform-cost 8-connected grids without
corner cutting.

:func:`jps` takes the arguments of :func:`cbr_solvers.search.astar` and returns the same
cheapest path, every cell of it, by A* over jump points only: from each point it expands, the
search jumps along straight and diagonal lines over the cells that some other path of no greater
cost reaches without passing through them, and stops at the cells where a path may have to turn
(jump points) and at goals.

**The rules without corner cutting.** A diagonal step from ``p`` to ``x`` needs both orthogonal
cells beside it passable, so the paper's rules (written for maps that allow corner cutting) change.
Let ``x`` be reached from ``p``, the move being ``(dx, dy)``:

- *Diagonal move.* Both cells beside the step, ``(x - dx, y)`` and ``(x, y - dy)``, are passable,
  so every neighbour of ``x`` behind it is reached from ``p`` through them at no greater cost:
  a diagonal move has **no forced neighbours**. Its natural neighbours are ``(x + dx, y)``,
  ``(x, y + dy)`` and ``(x + dx, y + dy)``; a diagonal jump stops at ``x`` when ``x`` is a goal
  or when the straight jump from ``x`` along ``dx`` or along ``dy`` finds a jump point.
- *Straight move* ``(dx, 0)`` (columns alike, with the axes swapped). The natural neighbour is
  ``(x + dx, y)``. For each side ``s`` (+1 and -1): when ``(x, y + s)`` is passable and
  ``(x - dx, y + s)``, the cell beside ``p``, is blocked, ``p`` cannot step diagonally to
  ``(x, y + s)``, so ``(x, y + s)`` and ``(x + dx, y + s)`` are **forced**: the cheapest way to
  them from ``p`` passes ``x``. When ``(x - dx, y + s)`` is passable, ``p`` reaches
  ``(x, y + s)`` in one diagonal step (√2 < 2) and ``(x + dx, y + s)`` diagonally first at the
  same cost as through ``x`` (1 + √2), so neither is needed. A straight jump stops at the first
  cell that is a goal or has a forced neighbour; it fails at a blocked cell or the window's edge.
  (With corner cutting the forced neighbours appear one cell earlier, when the cell beside ``x``
  is blocked and the next one open; without it the jump reaches that open cell and stops there.)
- The start expands all eight moves.

Tests check these rules by brute force: on random small grids, with windows and several goals,
:func:`jps` returns A*'s cost on every query, unreachable goals included.

**Diagonal cells are not queued.** As in Harabor and Grastien's later refinement (ICAPS 2014),
a diagonal jump does not stop at the cell whose straight jumps find points: it offers those
points at once, through the point it started from, and goes on to the diagonal's end or a goal.
The path to such a point runs diagonally first, then straight, so the cell where it turns
follows from its two ends and the direction it arrived in is the straight one. Of two points
of equal f the one nearer a goal is expanded first, by a tilt of the heuristic too small to
reorder different f (see :func:`_search`).

**Cells are scanned 64 at a time.** The window's passable cells are packed into bit rows and bit
columns (a border of blocked cells around the window), with two more layers of each marking the
cells where a straight jump towards higher or lower positions must stop: blocked, or with a
forced neighbour. A jump finds its first stop from one word and a count of trailing (leading,
going back) zeros per 64 cells; goals are bits of their own. The bits of a whole grid given as
read-only arrays (those of :class:`cbr_grid.grid.Grid`) are kept between calls, 6 bits a cell;
other grids and windows are packed per call, at a cost in proportion to the window.

**Non-uniform costs hand over to A*.** Jump point search prices every step by its length alone.
When the factors of the passable cells in the window are not all equal (a risk map, a learned
cost after a collision) or when ``corner_cutting`` is true, :func:`jps` returns
:func:`cbr_solvers.search.astar`'s answer instead, which is still the cheapest path; the result's
``search`` says which search planned. Refusing instead would make ``jps`` unusable as the
fallback solver of a case base whose map learns risk.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence

import attrs
import numpy as np
from numba.cpython.unsafe.numbers import leading_zeros, trailing_zeros

from cbr_grid.costs import SQRT2
from cbr_grid.search_base import INITIAL_HEAP, Workspace, checked_arguments, pop, push
from cbr_kernels import njit
from cbr_solvers.search import SearchResult, _frozen, _heuristic, astar


@attrs.frozen
class JumpResult(SearchResult):
    """A path found by :func:`jps`: ``search`` is ``"jps"`` when jump point search planned it
    (``expanded`` counts the jump points settled) and ``"astar"`` when the grid's costs or corner
    rule handed the query over to A* (``expanded`` counts cells)."""

    search: str = "jps"


_ONE = np.uint64(1)
_ALL = np.uint64(0xFFFFFFFFFFFFFFFF)
_TOP = np.uint64(63)


@njit
def _stops(bits: np.ndarray) -> None:
    """Fill layers 1 and 2 of ``bits`` (:func:`_pack`) from layer 0, the passable cells: where a
    straight jump along a line towards higher (layer 1) or lower (layer 2) positions stops,
    because the cell is blocked or has a forced neighbour on the line before or after."""
    last = bits.shape[2] - 1
    for line in range(1, bits.shape[1] - 1):
        for k in range(last + 1):
            a = bits[0, line - 1, k]
            b = bits[0, line + 1, k]
            # the cell before position q going up is q - 1: bit 63 of the previous word for bit 0
            a_before = a << _ONE
            b_before = b << _ONE
            if k > 0:
                a_before |= bits[0, line - 1, k - 1] >> _TOP
                b_before |= bits[0, line + 1, k - 1] >> _TOP
            blocked = ~bits[0, line, k]
            bits[1, line, k] = blocked | (a & ~a_before) | (b & ~b_before)
            a_before = a >> _ONE
            b_before = b >> _ONE
            if k < last:
                a_before |= bits[0, line - 1, k + 1] << _TOP
                b_before |= bits[0, line + 1, k + 1] << _TOP
            bits[2, line, k] = blocked | (a & ~a_before) | (b & ~b_before)


@njit
def _pack(factor: np.ndarray, passable: np.ndarray, x0: int, y0: int, x1: int, y1: int
          ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The window's passable cells as bits, and the least and greatest factor among them.

    Returns (rows, cols, least, greatest). ``rows[0, r, c >> 6]`` holds bit ``c & 63`` for the
    cell of window column ``c - 1`` and row ``r - 1``; line and position 0 and one past the
    window are blocked borders, so every scan ends inside. ``rows[1]`` and ``rows[2]`` mark where
    jumps along the rows stop (:func:`_stops`). ``cols`` holds the
    same by column. ``least`` is NaN when a passable factor is NaN.
    """
    ww, wh = x1 - x0 + 1, y1 - y0 + 1
    rows = np.zeros((3, wh + 2, (ww + 2 + 63) >> 6), dtype=np.uint64)
    cols = np.zeros((3, ww + 2, (wh + 2 + 63) >> 6), dtype=np.uint64)
    least, greatest = np.inf, -np.inf
    for r in range(1, wh + 1):
        y = y0 + r - 1
        for c in range(1, ww + 1):
            x = x0 + c - 1
            if passable[y, x]:
                rows[0, r, c >> 6] |= _ONE << np.uint64(c & 63)
                cols[0, c, r >> 6] |= _ONE << np.uint64(r & 63)
                f = factor[y, x]
                if f != f:
                    least = np.nan
                elif least == least:
                    least = min(least, f)
                greatest = max(greatest, f)
    _stops(rows)
    _stops(cols)
    return rows, cols, least, greatest


@njit(inline="always")
def _bit(bits: np.ndarray, line: int, pos: int) -> bool:
    """Whether the cell at ``pos`` of ``line`` is passable (bits of :func:`_pack`)."""
    return (bits[0, line, pos >> 6] >> np.uint64(pos & 63)) & _ONE != 0


@njit(inline="always")
def _goal(goals: np.ndarray, line: int, pos: int) -> bool:
    return (goals[line, pos >> 6] >> np.uint64(pos & 63)) & _ONE != 0


@njit(inline="always")
def _set(goals: np.ndarray, line: int, pos: int) -> None:
    goals[line, pos >> 6] |= _ONE << np.uint64(pos & 63)


@njit(inline="always")
def _scan(bits: np.ndarray, goals: np.ndarray, line: int, pos: int, step: int) -> int:
    """The jump point of a straight jump from ``pos`` along ``line`` (a row or column of the
    bits of :func:`_pack`) towards higher positions (``step`` 1) or lower ones (-1), or -1 when
    it meets a blocked cell first."""
    if step > 0:
        p = pos + 1
        k = p >> 6
        stop = (bits[1, line, k] | goals[line, k]) & (_ALL << np.uint64(p & 63))
        while stop == 0:
            k += 1
            stop = bits[1, line, k] | goals[line, k]
        q = (k << 6) + np.int64(trailing_zeros(stop))
    else:
        p = pos - 1
        k = p >> 6
        stop = (bits[2, line, k] | goals[line, k]) & (_ALL >> np.uint64(63 - (p & 63)))
        while stop == 0:
            k -= 1
            stop = bits[2, line, k] | goals[line, k]
        q = (k << 6) + 63 - np.int64(leading_zeros(stop))
    return q if (bits[0, line, k] >> np.uint64(q & 63)) & _ONE != 0 else -1


@njit(inline="always")
def _reach(stamp: np.ndarray, dist: np.ndarray, parent: np.ndarray, keys: np.ndarray,
           items: np.ndarray, size: int, generation: int, cell: int, c: int, r: int, ww: int,
           g: float, targets: np.ndarray, tilt: float) -> int:
    """Offer the point (c, r) at length ``g`` through the point ``cell``: recorded and pushed
    with the key g + ``tilt`` · h when it is new or shorter than before; the heap's new size.
    The heap has room."""
    other = (r - 1) * ww + (c - 1)
    mark = stamp[other]
    if mark == generation + 1 or (mark == generation and g >= dist[other]):
        return size
    stamp[other] = generation
    dist[other] = g
    parent[other] = cell
    push(keys, items, size, g + tilt * _heuristic(c, r, targets, 1.0), other)
    return size + 1


@njit
def _grown(keys: np.ndarray, items: np.ndarray, least: int) -> tuple[np.ndarray, np.ndarray]:
    """The heap's arrays copied into arrays of at least ``least`` entries, and at least twice
    as many as before."""
    n = max(least, 2 * keys.shape[0])
    more_keys = np.empty(n, dtype=keys.dtype)
    more_items = np.empty(n, dtype=items.dtype)
    more_keys[:keys.shape[0]] = keys
    more_items[:items.shape[0]] = items
    return more_keys, more_items


@njit
def _search(rows: np.ndarray, cols: np.ndarray, scale: float, sx: int, sy: int,
            goals: np.ndarray, x0: int, y0: int, x1: int, y1: int, stamp: np.ndarray,
            dist: np.ndarray, parent: np.ndarray, generation: int
            ) -> tuple[bool, np.ndarray, float, int]:
    """Jump point search from (sx, sy) to the nearest goal inside the window [x0, x1] x [y0, y1],
    every step costing its length times ``scale``; (found, path, cost, expanded).

    ``rows`` and ``cols`` are the window's bits (:func:`_pack`). ``stamp``, ``dist`` and
    ``parent`` are working arrays of at least the window's size, indexed by window cell in
    row-major order and never cleared: a cell has been reached in this search iff
    ``stamp == generation`` and settled iff ``stamp == generation + 1``; then ``dist`` is its
    length in cells (times ``scale`` only at the end) and ``parent`` the point it was reached
    through (itself for the start). The caller guarantees the start inside the window and the
    goals on the grid.
    """
    ww = x1 - x0 + 1
    settled = generation + 1
    empty = np.empty((0, 2), dtype=np.int64)
    # the goals inside the window and passable, in window coordinates (border included)
    goal_rows = np.zeros_like(rows[0])
    goal_cols = np.zeros_like(cols[0])
    local = np.empty_like(goals)
    count = 0
    for k in range(goals.shape[0]):
        c, r = goals[k, 0] - x0 + 1, goals[k, 1] - y0 + 1
        if 1 <= c <= ww and 1 <= r <= y1 - y0 + 1 and _bit(rows, r, c):
            _set(goal_rows, r, c)
            _set(goal_cols, c, r)
            local[count, 0] = c
            local[count, 1] = r
            count += 1
    targets = local[:count]
    sc, sr = sx - x0 + 1, sy - y0 + 1
    if count == 0 or not _bit(rows, sr, sc):
        return False, empty, np.inf, 0

    # The most points one expansion can push: two per diagonal step, four diagonals and four
    # straight jumps. The heap is grown to hold them before the expansion, so that pushing never
    # hands arrays back (which would count references at every push).
    room = 8 * min(ww, y1 - y0 + 1) + 4
    keys = np.empty(max(INITIAL_HEAP, room + 1), dtype=np.float64)
    items = np.empty(keys.shape[0], dtype=np.int64)
    start = (sr - 1) * ww + (sc - 1)
    stamp[start] = generation
    dist[start] = 0.0
    parent[start] = start
    # Lengths are counted in cells and the key of a point is g + tilt · h: ties in f go to the
    # point nearer a goal, which spares expanding a whole tie on open ground. Two different
    # lengths a + b·√2 of paths in the window differ by more than 0.26 / (cells + span), and
    # (tilt - 1) · h stays below 0.1 / (cells + span), so the tilt orders equal f only and the
    # search stays exact.
    span = ww + y1 - y0 + 1
    tilt = 1.0 + 0.1 / ((ww * (y1 - y0 + 1) + span) * span)
    keys[0] = tilt * _heuristic(sc, sr, targets, 1.0)
    items[0] = start
    size = 1
    expanded = 0
    reached = -1

    while size > 0:
        cell = pop(keys, items, size)
        size -= 1
        if stamp[cell] == settled:
            continue  # a stale entry of a point settled through a cheaper push
        stamp[cell] = settled
        expanded += 1
        c = cell % ww + 1
        r = cell // ww + 1
        if _goal(goal_rows, r, c):
            reached = cell
            break
        here = dist[cell]
        if keys.shape[0] - size < room:
            keys, items = _grown(keys, items, size + room)

        # the moves to jump along, as a mask over the eight (dx, dy) of index 3 * (dy + 1) + dx + 1
        came = parent[cell]
        if came == cell:
            moves = 0b111101111
        else:
            # the last stretch from the point before: straight along the longer axis, diagonal
            # when both axes are equal
            ex, ey = c - (came % ww + 1), r - (came // ww + 1)
            dx = np.sign(ex) if abs(ex) >= abs(ey) else 0
            dy = np.sign(ey) if abs(ey) >= abs(ex) else 0
            moves = 1 << (3 * (dy + 1) + dx + 1)
            if dx != 0 and dy != 0:
                moves |= (1 << (4 + dx)) | (1 << (3 * (dy + 1) + 1))
            elif dy == 0:
                for s in (-1, 1):
                    if _bit(rows, r + s, c) and not _bit(rows, r + s, c - dx):
                        moves |= (1 << (3 * (s + 1) + 1)) | (1 << (3 * (s + 1) + dx + 1))
            else:
                for s in (-1, 1):
                    if _bit(cols, c + s, r) and not _bit(cols, c + s, r - dy):
                        moves |= (1 << (4 + s)) | (1 << (3 * (dy + 1) + s + 1))

        for index in range(9):
            if not (moves >> index) & 1:
                continue
            mx, my = index % 3 - 1, index // 3 - 1
            if my == 0:
                q = _scan(rows, goal_rows, r, c, mx)
                if q >= 0:
                    size = _reach(stamp, dist, parent, keys, items, size,
                                  generation, cell, q, r, ww,
                                  here + abs(q - c), targets, tilt)
                continue
            if mx == 0:
                q = _scan(cols, goal_cols, c, r, my)
                if q >= 0:
                    size = _reach(stamp, dist, parent, keys, items, size,
                                  generation, cell, c, q, ww,
                                  here + abs(q - r), targets, tilt)
                continue
            # Along the diagonal, the points the straight jumps find are offered at once through
            # this point (the path runs diagonally first, then straight); the diagonal cells
            # themselves are not pushed and the diagonal goes on to its end or a goal.
            dc, dr, g = c, r, here
            while (_bit(rows, dr + my, dc + mx) and _bit(rows, dr, dc + mx)
                   and _bit(rows, dr + my, dc)):
                dc += mx
                dr += my
                g += SQRT2
                if _goal(goal_rows, dr, dc):
                    size = _reach(stamp, dist, parent, keys, items, size,
                                  generation, cell, dc, dr, ww, g, targets, tilt)
                    break  # anything beyond is reached through this goal
                q = _scan(rows, goal_rows, dr, dc, mx)
                if q >= 0:
                    size = _reach(stamp, dist, parent, keys, items, size,
                                  generation, cell, q, dr, ww,
                                               g + abs(q - dc), targets, tilt)
                q = _scan(cols, goal_cols, dc, dr, my)
                if q >= 0:
                    size = _reach(stamp, dist, parent, keys, items, size,
                                  generation, cell, dc, q, ww,
                                               g + abs(q - dr), targets, tilt)

    if reached < 0:
        return False, empty, np.inf, expanded

    # every cell between consecutive points: diagonally from the earlier one, then straight
    cells = 1
    cell = reached
    while cell != start:
        before = parent[cell]
        cells += max(abs(cell % ww - before % ww), abs(cell // ww - before // ww))
        cell = before
    path = np.empty((cells, 2), dtype=np.int64)
    i = cells - 1
    cell = reached
    path[i, 0] = x0 + cell % ww
    path[i, 1] = y0 + cell // ww
    while cell != start:
        before = parent[cell]
        bx, by = before % ww, before // ww
        x, y = cell % ww, cell // ww
        while x != bx or y != by:
            ex, ey = bx - x, by - y
            if abs(ex) >= abs(ey):
                x += np.sign(ex)
            if abs(ey) >= abs(ex):
                y += np.sign(ey)
            i -= 1
            path[i, 0] = x0 + x
            path[i, 1] = y0 + y
        cell = before
    return True, path, dist[reached] * scale, expanded


_WORKSPACE = Workspace()

# The bits of whole read-only grids: (id(factor), id(passable)) -> (weak references to both,
# (rows, cols, least, greatest)). The references tell a live array from a new one at a reused id.
_PACKED: dict[tuple[int, int], tuple[weakref.ref, weakref.ref,
                                     tuple[np.ndarray, np.ndarray, float, float]]] = {}
_PACKED_KEPT = 8


def _packed(factor: np.ndarray, passable: np.ndarray, box: tuple[int, int, int, int]
            ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """:func:`_pack` of the window ``box``, remembered for the whole grid of read-only arrays."""
    h, w = passable.shape
    # Read-only now, the arrays may be made writable again later: check at every call.
    whole = box == (0, 0, w - 1, h - 1) and _frozen(factor) and _frozen(passable)
    key = (id(factor), id(passable))
    if whole:
        known = _PACKED.get(key)
        if known is not None and known[0]() is factor and known[1]() is passable:
            return known[2]
    packed = _pack(factor, passable, *box)
    if whole:
        if len(_PACKED) >= _PACKED_KEPT:
            _PACKED.pop(next(iter(_PACKED)))
        _PACKED[key] = (weakref.ref(factor), weakref.ref(passable), packed)
    return packed


def jps(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, start: Sequence[int],
        goals: object, window: Sequence[int] | None = None) -> JumpResult | None:
    """The cheapest path from ``start`` to the nearest of ``goals`` by jump point search.

    Arguments, checks and result as for :func:`cbr_solvers.search.astar`; the path holds every
    cell, not only the jump points. When the passable cells of the window do not all have one
    factor, or ``corner_cutting`` is true, A* answers instead (see the module's docstring) and
    the result's ``search`` is ``"astar"``.
    """
    # a factor held once is read as it is by the packing, not copied cell by cell
    factor, passable, (sx, sy), targets, box = checked_arguments(
        factor, passable, start, goals, window, uniform=True)
    x0, y0, x1, y1 = box
    if not (x0 <= sx <= x1 and y0 <= sy <= y1):
        return None
    rows, cols, least, greatest = (None, None, np.nan, np.nan) if corner_cutting else _packed(
        factor, passable, box)
    if rows is None or not (least == greatest and 0.0 < least < np.inf):
        found = astar(factor, passable, corner_cutting, start, targets, box)
        return None if found is None else JumpResult(found.path, found.cost, found.expanded,
                                                     "astar")
    stamp, dist, parent, _, generation = _WORKSPACE.take((x1 - x0 + 1) * (y1 - y0 + 1))
    found, path, cost, expanded = _search(rows, cols, least, sx, sy, targets, x0, y0, x1, y1,
                                          stamp, dist, parent, generation)
    return JumpResult(path, float(cost), int(expanded)) if found else None
