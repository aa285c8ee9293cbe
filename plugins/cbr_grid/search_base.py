"""The ground floor every compiled grid search stands on: the binary heap, the eight moves and
their corner rule, the argument checks and the reusable working arrays.

The solvers' Dijkstra, A*, Ai*, genetic algorithm and edge-based searches and the case graph's
kernels all step between 8-neighbours under one rule and order their frontier in one heap, so
these pieces live once, here, at the bottom of the grid family where every package that
searches can reach them. Nothing here is a search itself: each search writes its own loop over
its own graph, because one loop specialised per graph measures well slower
(``benchmarks/search_loop.py``, docs/benchmarks.md, "One search loop or one per graph").

**The heap** is a binary min-heap of (float64 key, int64 item) pairs kept in two arrays, the
caller holding its size: :func:`push` into arrays with room, :func:`push_grown` doubling them
when full, :func:`pop`. A search pushes a cell again when it improves and skips the stale entries
it pops (lazy deletion).

**The 4-ary heap** (:func:`push4`, :func:`pop4`, :func:`push4_grown`) holds the same pairs with
four children to a node: half the levels, and a node's children side by side in memory. The
first two are inlined into the kernel that calls them. The cell searches use it; on their
frontiers it takes 10-25% less time than the binary heap.

**The moves** are numbered 0-7 in the order the searches try them: the four orthogonal ones
(E, W, S, N), then the diagonals (SE, NE, SW, NW), so ``d >= 4`` is a diagonal move. The
order decides which of two equally cheap paths a search returns, so every search shares it.
:data:`MOVE_DIRECTIONS` gives each move's direction in :mod:`cbr_grid.directions`, whose table
of steps :data:`DX` and :data:`DY` are read from; :data:`MOVE_OF_DIRECTION` goes back.

**The corner rule** (:func:`move`): a diagonal step passes the two orthogonal cells beside it.
Without corner cutting both must be passable, with corner cutting one, so a path never squeezes
between two obstacles (the rule of :class:`cbr_grid.grid.Grid`). Each kernel is compiled with
numba, cached on disk.

**The working arrays** are kept per thread and reused: :class:`Workspace` for searches over
states (the edge-based searches: an int32 stamp, a float64 cost, an int64 parent state and an
int32 goal mark per state) and :class:`CellWorkspace` for searches over cells (a uint8 stamp,
a float64 cost and the uint8 move that reached the cell: 10 bytes a cell).

**Move masks** (:func:`move_masks`, :func:`cell_moves`) hold the corner rule's verdict for all
eight moves of a cell in one byte, bit ``d`` set when move ``d`` is allowed on the whole grid:
a search reads one byte per expansion instead of up to sixteen cells, and a window clips the
byte with :data:`LEAVING` on its border.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence

import numpy as np

from cbr_grid.costs import uniform_factor
from cbr_grid.directions import STEPS
from cbr_kernels import njit

MOVE_DIRECTIONS = np.array([0, 4, 6, 2, 7, 1, 5, 3], dtype=np.int64)
"""The direction (:mod:`cbr_grid.directions`) of each move 0-7: orthogonal first, then diagonal."""

MOVE_OF_DIRECTION = np.argsort(MOVE_DIRECTIONS).astype(np.int64)
"""The move of each direction 0-7: the inverse of :data:`MOVE_DIRECTIONS`."""

DX = STEPS[MOVE_DIRECTIONS, 0]
"""The x offset of each move."""

DY = STEPS[MOVE_DIRECTIONS, 1]
"""The y offset of each move."""

INITIAL_HEAP = 1024
"""The capacity a grid search's heap starts with; :func:`push_grown` doubles it when full."""


@njit
def push(keys: np.ndarray, items: np.ndarray, size: int, key: float, item: int) -> None:
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


@njit
def pop(keys: np.ndarray, items: np.ndarray, size: int) -> int:
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


@njit
def push_grown(keys: np.ndarray, items: np.ndarray, size: int, key: float, item: int
               ) -> tuple[np.ndarray, np.ndarray]:
    """Add (key, item) to the heap of ``size`` entries, doubling its arrays when they are full;
    the arrays, new or not."""
    if size == keys.shape[0]:
        keys = np.concatenate((keys, np.empty_like(keys)))
        items = np.concatenate((items, np.empty_like(items)))
    push(keys, items, size, key, item)
    return keys, items


@njit(inline="always")
def move(passable: np.ndarray, corner_cutting: bool, cx: int, cy: int, d: int, x0: int, y0: int,
         x1: int, y1: int) -> bool:
    """Whether move ``d`` from (cx, cy) stays in the window [x0, x1] x [y0, y1] on passable
    cells and passes the corner rule. The cells beside a diagonal step are judged on the whole
    grid, window or not."""
    nx, ny = cx + DX[d], cy + DY[d]
    if nx < x0 or nx > x1 or ny < y0 or ny > y1 or not passable[ny, nx]:
        return False
    if d < 4:
        return True
    beside_x, beside_y = passable[cy, nx], passable[ny, cx]
    return (beside_x or beside_y) if corner_cutting else (beside_x and beside_y)


@njit(inline="always")
def push4(keys: np.ndarray, items: np.ndarray, size: int, key: float, item: int) -> None:
    """Add (key, item) to the 4-ary heap of ``size`` entries; the arrays have room for it."""
    i = size
    while i > 0:
        parent = (i - 1) >> 2
        if keys[parent] <= key:
            break
        keys[i] = keys[parent]
        items[i] = items[parent]
        i = parent
    keys[i] = key
    items[i] = item


@njit(inline="always")
def pop4(keys: np.ndarray, items: np.ndarray, size: int) -> int:
    """Remove the entry with the smallest key from the 4-ary heap of ``size`` entries; its item."""
    top = items[0]
    size -= 1
    key, item = keys[size], items[size]
    i = 0
    while True:
        first = 4 * i + 1
        if first >= size:
            break
        child, least = first, keys[first]
        for other in range(first + 1, min(first + 4, size)):
            if keys[other] < least:
                child, least = other, keys[other]
        if key <= least:
            break
        keys[i] = least
        items[i] = items[child]
        i = child
    keys[i] = key
    items[i] = item
    return top


@njit
def push4_grown(keys: np.ndarray, items: np.ndarray, size: int, key: float, item: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """Add (key, item) to the 4-ary heap of ``size`` entries, doubling its arrays when they are
    full; the arrays, new or not."""
    if size == keys.shape[0]:
        keys = np.concatenate((keys, np.empty_like(keys)))
        items = np.concatenate((items, np.empty_like(items)))
    push4(keys, items, size, key, item)
    return keys, items


def _leaving(axis: np.ndarray, sign: int) -> int:
    return int(sum(1 << d for d in range(8) if axis[d] == sign))


LEAVING = np.array([_leaving(DX, -1), _leaving(DX, 1), _leaving(DY, -1), _leaving(DY, 1)],
                   dtype=np.int64)
"""The bits of the moves that step west, east, north and south (decreasing x, increasing x,
decreasing y, increasing y): cleared from a cell's move mask on a window's border."""


@njit(inline="always")
def cell_moves(passable: np.ndarray, corner_cutting: bool, x: int, y: int) -> int:
    """The move mask of (x, y) on the whole grid: bit ``d`` set when :func:`move` allows ``d``."""
    h, w = passable.shape
    mask = 0
    for d in range(8):
        if move(passable, corner_cutting, x, y, d, 0, 0, w - 1, h - 1):
            mask |= 1 << d
    return mask


@njit
def move_masks(passable: np.ndarray, corner_cutting: bool) -> np.ndarray:
    """The move mask (:func:`cell_moves`) of every cell, row-major, one uint8 each; 0 on blocked
    cells."""
    h, w = passable.shape
    masks = np.zeros(h * w, dtype=np.uint8)
    for y in range(h):
        for x in range(w):
            if passable[y, x]:
                masks[y * w + x] = cell_moves(passable, corner_cutting, x, y)
    return masks


def read_only(array: np.ndarray) -> np.ndarray:
    """``array`` itself when it is read-only, else a read-only view of it.

    numba compiles a kernel apart for a writable and for a read-only array argument; the
    searches hand their kernels read-only arrays only, so that a first run compiles each once
    (a few seconds each) whichever arrays its callers hold.
    """
    if not array.flags.writeable:
        return array
    view = array.view()
    view.flags.writeable = False
    return view


def checked_arguments(factor: np.ndarray, passable: np.ndarray, start: Sequence[int],
                      goals: object, window: Sequence[int] | None, *, uniform: bool = False
                      ) -> tuple[np.ndarray, np.ndarray, tuple[int, int], np.ndarray,
                                 tuple[int, int, int, int]]:
    """The grid searches' arguments checked and converted: contiguous float64 factor and bool
    passable arrays, read-only, the start, the goals as a (k, 2) int64 array and the window
    clipped to the grid (the whole grid when None). ValueError names what is wrong.

    With ``uniform`` a factor holding one value for every cell
    (:func:`cbr_grid.costs.broadcast_factor`) is passed on as it is, for a caller that reads
    the value (:func:`cbr_grid.costs.uniform_factor`) rather than copy it cell by cell.
    """
    if not (uniform and uniform_factor(factor) is not None):
        factor = read_only(np.ascontiguousarray(factor, dtype=np.float64))
    passable = read_only(np.ascontiguousarray(passable, dtype=np.bool_))
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
        box = (0, 0, w - 1, h - 1)
    else:
        wx0, wy0, wx1, wy1 = (int(v) for v in window)
        box = (max(wx0, 0), max(wy0, 0), min(wx1, w - 1), min(wy1, h - 1))
    return factor, passable, (sx, sy), targets, box


class Workspace(threading.local):
    """A search's working arrays, kept per thread and reused across its calls.

    ``stamp`` and ``goal_mark`` (int32), ``dist`` (float64) and ``parent`` (int64) grow to the
    largest number of states asked for and are never cleared: each call takes a new generation
    (two stamp values), so a search marks a state reached with the generation and settled with
    the generation + 1, and its work is proportional to the states it touches, not to the
    arrays. Kept per thread, a search may run in each thread; the kernels hold the GIL.
    """

    def __init__(self) -> None:
        self.stamp = np.zeros(0, dtype=np.int32)
        self.goal_mark = np.zeros(0, dtype=np.int32)
        self.dist = np.empty(0, dtype=np.float64)
        self.parent = np.empty(0, dtype=np.int64)
        self.generation = 0

    def take(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
        """(stamp, dist, parent, goal_mark, generation): arrays of at least ``n`` states and a
        fresh generation for one search."""
        if self.stamp.shape[0] < n:
            self.stamp = np.zeros(n, dtype=np.int32)
            self.goal_mark = np.zeros(n, dtype=np.int32)
            self.dist = np.empty(n, dtype=np.float64)
            self.parent = np.empty(n, dtype=np.int64)
            self.generation = 0
        self.generation += 2
        if self.generation >= np.iinfo(np.int32).max - 2:
            self.stamp[:] = 0
            self.goal_mark[:] = 0
            self.generation = 2
        return self.stamp, self.dist, self.parent, self.goal_mark, self.generation



class CellWorkspace(threading.local):
    """A cell search's working arrays, kept per thread and reused across its calls.

    ``stamp`` (uint8), ``dist`` (float64) and ``parent`` (uint8, the move that reached a cell)
    grow to the largest window asked for, 10 bytes a cell. As in :class:`Workspace` a search
    marks a cell reached with its generation and settled with the generation + 1; a byte holds
    126 generations, after which the stamps used since the last clearing are cleared (only as
    many as the largest window since, so small searches clear little).
    """

    def __init__(self) -> None:
        self.stamp = np.zeros(0, dtype=np.uint8)
        self.dist = np.empty(0, dtype=np.float64)
        self.parent = np.empty(0, dtype=np.uint8)
        self.generation = 0
        self.used = 0

    def take(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """(stamp, dist, parent, generation): arrays of at least ``n`` cells and a fresh
        generation for one search."""
        if self.stamp.shape[0] < n:
            # Drop the old arrays first, so the old and new ones are never held together.
            self.stamp = self.dist = self.parent = None  # type: ignore[assignment]
            self.stamp = np.zeros(n, dtype=np.uint8)
            self.dist = np.empty(n, dtype=np.float64)
            self.parent = np.empty(n, dtype=np.uint8)
            self.generation = self.used = 0
        self.generation += 2
        if self.generation >= np.iinfo(np.uint8).max - 1:
            self.stamp[:self.used] = 0
            self.generation, self.used = 2, 0
        self.used = max(self.used, n)
        return self.stamp, self.dist, self.parent, self.generation
