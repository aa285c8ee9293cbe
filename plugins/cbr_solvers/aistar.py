"""Ai*: A* guided by an integer distance map propagated from the goals.

Before searching, Ai* propagates a wavefront from the goal cells over the passable cells of the
search window in 8 directions, under the same corner rule as the search
(:func:`cbr_grid.search_base.move`). The map counts integer steps: an orthogonal step adds 3 and a
diagonal step 4, the 3-4 chamfer distance. This is our reading of "an integer approximation of the
distance ... constructed using 8-direction propagation" with "a maximum error of distance estimation
of about 8 percent": on an open map a diagonal run of n cells measures 4n/3 instead of n·sqrt(2),
short by (sqrt(2) - 4/3)·n = 0.0809·n, about 8 percent of the run's side (5.7 percent of its
length); orthogonal runs are exact.

A* then uses ``h(c) = D(c) / 3 · fmin``, ``D`` the integer map and ``fmin`` the smallest cost
factor of a passable cell in the window. Both maps are shortest paths over the same moves, and no
step of the integer map (1 or 4/3 after dividing by 3) is longer than the step's length (1 or
sqrt(2)), whose cost is at least its length times ``fmin``. So the heuristic never overestimates
and is consistent: with this scaling Ai* is admissible and returns an optimal path, the same cost
as Dijkstra. On a risk-free map the heuristic is at least 4/(3·sqrt(2)) of the true cost, a
relative error of at most 1 - 4/(3·sqrt(2)) = 5.72 percent (:data:`RISK_FREE_ERROR_BOUND`).
With factors between ``fmin`` and ``fmax`` in the window the true cost is at most ``fmax`` times
the path's length, so the error is at most 1 - 4/(3·sqrt(2))·fmin/fmax (:func:`error_bound`).
:func:`heuristic_error` measures the error on a given map.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from cbr_grid.costs import SQRT2, uniform_factor
from cbr_grid.search_base import DX, DY, INITIAL_HEAP, move, pop, push_grown
from cbr_kernels import njit
from cbr_solvers.search import SearchResult, _profile, _run

# Integer step lengths of the distance map: orthogonal and diagonal.
ORTHOGONAL_STEPS = 3
DIAGONAL_STEPS = 4

# The largest relative error of the heuristic on a risk-free map: a diagonal step's 4/3 against
# its sqrt(2).
RISK_FREE_ERROR_BOUND = 1.0 - DIAGONAL_STEPS / (ORTHOGONAL_STEPS * math.sqrt(2.0))

_ALL = np.zeros(0, dtype=np.int64)
"""No wanted cells: propagate over the whole window."""

# What a step adds in the wavefront of ``wavefront``.
INTEGER_STEPS = 0
"""The integer ``ORTHOGONAL_STEPS`` or ``DIAGONAL_STEPS``: Ai*'s distance map."""
COST_STEPS = 1
"""The step's cost under the cost contract, from the cell factors."""
LENGTH_STEPS = 2
"""The step's length, 1 or sqrt(2): a step's cost with every factor 1, without a map of ones."""

_NO_FACTOR = np.ones((1, 1))
"""The factor argument of the wavefronts that do not read factors (integer or length steps)."""
# read-only like a Grid's factor, so that both share one compiled variant of the wavefront
_NO_FACTOR.setflags(write=False)


@njit
def wavefront(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
               goals: np.ndarray, x0: int, y0: int, x1: int, y1: int, steps: int,
               wanted: np.ndarray) -> np.ndarray:
    """Distances from the goals to every cell of the window [x0, x1] x [y0, y1], row-major.

    ``steps`` says what a step adds: ``COST_STEPS`` its cost under the cost contract,
    ``LENGTH_STEPS`` its length (``factor`` is then not read), ``INTEGER_STEPS`` the integer
    ``ORTHOGONAL_STEPS`` or ``DIAGONAL_STEPS`` (nor is ``factor`` read then). Goals off the
    window or blocked are ignored; cells that no goal reaches inside the window stay infinite.
    Step costs are symmetric, so the distance from the goals is the cost to reach them. A
    non-empty ``wanted`` (row-major window indices) stops the wavefront once all of them are
    settled; the cells not settled by then are left infinite.
    """
    ww = x1 - x0 + 1
    n = ww * (y1 - y0 + 1)
    dist = np.full(n, np.inf)
    closed = np.zeros(n, dtype=np.bool_)
    # a byte per cell only when there are wanted cells to look up
    want = np.zeros(n if wanted.shape[0] else 0, dtype=np.bool_)
    left = 0
    for k in range(wanted.shape[0]):
        if not want[wanted[k]]:
            want[wanted[k]] = True
            left += 1
    stop_early = left > 0
    keys = np.empty(INITIAL_HEAP, dtype=np.float64)
    items = np.empty(INITIAL_HEAP, dtype=np.int64)
    # an int64, not the literal 0: numba would compile the heap's kernels for the literal too
    size = np.int64(0)
    for k in range(goals.shape[0]):
        gx, gy = goals[k, 0], goals[k, 1]
        if not (x0 <= gx <= x1 and y0 <= gy <= y1 and passable[gy, gx]):
            continue
        cell = (gy - y0) * ww + (gx - x0)
        if dist[cell] == 0.0:
            continue
        dist[cell] = 0.0
        keys, items = push_grown(keys, items, size, 0.0, cell)
        size += 1

    # The wavefront advances in order of distance; integer distances are exact in float64.
    while size > 0:
        cell = pop(keys, items, size)
        size -= 1
        if closed[cell]:
            continue  # a stale entry of a cell reached again more cheaply
        closed[cell] = True
        if stop_early and want[cell]:
            left -= 1
            if left == 0:
                break
        cx = x0 + cell % ww
        cy = y0 + cell // ww
        here = dist[cell]
        for d in range(8):
            if not move(passable, corner_cutting, cx, cy, d, x0, y0, x1, y1):
                continue
            nx, ny = cx + DX[d], cy + DY[d]
            diagonal = d >= 4
            other = (ny - y0) * ww + (nx - x0)
            if closed[other]:
                continue
            if steps == COST_STEPS:
                step = (SQRT2 if diagonal else 1.0) * (factor[cy, cx] + factor[ny, nx]) * 0.5
            elif steps == LENGTH_STEPS:
                step = SQRT2 if diagonal else 1.0
            else:
                step = float(DIAGONAL_STEPS if diagonal else ORTHOGONAL_STEPS)
            g = here + step
            if g >= dist[other]:
                continue
            dist[other] = g
            keys, items = push_grown(keys, items, size, g, other)
            size += 1
    if stop_early:
        for cell in range(n):
            if not closed[cell]:
                dist[cell] = np.inf
    return dist


def _window(passable: np.ndarray, window: Sequence[int] | None) -> tuple[int, int, int, int]:
    """The inclusive window (x0, y0, x1, y1) clipped to the grid; the whole grid by default."""
    h, w = passable.shape
    if window is None:
        return 0, 0, w - 1, h - 1
    wx0, wy0, wx1, wy1 = (int(v) for v in window)
    return max(wx0, 0), max(wy0, 0), min(wx1, w - 1), min(wy1, h - 1)


def _goal_array(goals: object) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(goals, dtype=np.int64).reshape(-1, 2))


def heuristic_table(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
                    goals: np.ndarray, window: tuple[int, int, int, int]) -> np.ndarray:
    """Ai*'s heuristic over the window, row-major: the integer map / 3 times the least factor."""
    x0, y0, x1, y1 = window
    h, w = passable.shape
    # Refuses a factor <= 0 or NaN; an empty window has no start to search from, so any finite
    # scale serves.
    fmin = _profile(factor, passable, window, window == (0, 0, w - 1, h - 1))[0]
    if fmin < 0.0:  # a small window, left to scan
        inside = factor[y0:y1 + 1, x0:x1 + 1][passable[y0:y1 + 1, x0:x1 + 1]]
        fmin = float(inside.min()) if inside.size else np.inf
        if not fmin > 0.0:
            raise ValueError("factor must be finite and positive on passable cells")
    if fmin == np.inf:
        fmin = 1.0
    steps = wavefront(_NO_FACTOR, passable, corner_cutting, goals, x0, y0, x1, y1,
                       INTEGER_STEPS, _ALL)
    steps *= fmin / ORTHOGONAL_STEPS
    return steps


def distance_map(passable: np.ndarray, corner_cutting: bool, goals: object,
                 window: Sequence[int] | None = None) -> np.ndarray:
    """Ai*'s integer distance map from ``goals``: 3 per orthogonal step, 4 per diagonal step.

    Returns an int64 array over the window (the whole grid by default), indexed ``[y, x]`` from
    the window's corner, with -1 where no goal can be reached inside the window.
    """
    passable = np.ascontiguousarray(passable, dtype=np.bool_)
    x0, y0, x1, y1 = _window(passable, window)
    dist = wavefront(_NO_FACTOR, passable, bool(corner_cutting), _goal_array(goals),
                      x0, y0, x1, y1, INTEGER_STEPS, _ALL)
    steps = np.where(np.isinf(dist), -1, dist).astype(np.int64)
    return steps.reshape(y1 - y0 + 1, x1 - x0 + 1)


def heuristic_map(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, goals: object,
                  window: Sequence[int] | None = None) -> np.ndarray:
    """The heuristic Ai* gives each cell of the window, in cost units (inf where unreachable)."""
    if uniform_factor(factor) is None:  # else read as one value, not copied cell by cell
        factor = np.ascontiguousarray(factor, dtype=np.float64)
    passable = np.ascontiguousarray(passable, dtype=np.bool_)
    box = _window(passable, window)
    table = heuristic_table(factor, passable, bool(corner_cutting), _goal_array(goals), box)
    return table.reshape(box[3] - box[1] + 1, box[2] - box[0] + 1)


def cost_map(factor: np.ndarray | None, passable: np.ndarray, corner_cutting: bool,
             goals: object, window: Sequence[int] | None = None,
             wanted: object = None) -> np.ndarray:
    """The exact cheapest cost from each cell of the window to the goals (Dijkstra from them).

    A ``factor`` of None stands for every factor 1: the costs are then the shortest path
    lengths, computed without a map of ones; a factor holding one value for every cell
    (:func:`cbr_grid.costs.broadcast_factor`) gives those lengths times the value. Besides the
    float64 result the wavefront holds a byte per cell of the window (two with ``wanted``) and
    its frontier.

    With ``wanted`` cells ((k, 2) of (x, y), inside the window) the wavefront stops once they
    are all settled: their costs and those of every cell cheaper than the dearest of them are
    exact, the rest is left infinite.
    """
    steps, scale = COST_STEPS, None if factor is None else uniform_factor(factor)
    if factor is None or scale is not None:
        factor, steps = _NO_FACTOR, LENGTH_STEPS
    factor = np.ascontiguousarray(factor, dtype=np.float64)
    passable = np.ascontiguousarray(passable, dtype=np.bool_)
    x0, y0, x1, y1 = _window(passable, window)
    cells = _ALL
    if wanted is not None:
        xy = _goal_array(wanted)
        cells = np.ascontiguousarray((xy[:, 1] - y0) * (x1 - x0 + 1) + (xy[:, 0] - x0))
    dist = wavefront(factor, passable, bool(corner_cutting), _goal_array(goals),
                      x0, y0, x1, y1, steps, cells)
    if scale is not None and scale != 1.0:
        dist *= scale
    return dist.reshape(y1 - y0 + 1, x1 - x0 + 1)


def heuristic_error(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
                    goals: object, window: Sequence[int] | None = None) -> float:
    """The largest relative error (true - h) / true of Ai*'s heuristic over the window.

    ``true`` is the exact cost to the goals (:func:`cost_map`), taken over the cells that reach
    a goal, goals excluded. A negative error at some cell would mean an overestimate there; the
    scaling of this module never gives one. Returns 0 when no other cell reaches a goal.
    """
    true = cost_map(factor, passable, corner_cutting, goals, window)
    estimate = heuristic_map(factor, passable, corner_cutting, goals, window)
    reached = np.isfinite(true) & (true > 0)
    if not reached.any():
        return 0.0
    return float(((true[reached] - estimate[reached]) / true[reached]).max())


def error_bound(factor: np.ndarray, passable: np.ndarray,
                window: Sequence[int] | None = None) -> float:
    """The largest relative error Ai*'s heuristic can have over the window, from its factors."""
    passable = np.asarray(passable, dtype=np.bool_)
    x0, y0, x1, y1 = _window(passable, window)
    inside = np.asarray(factor, dtype=np.float64)[y0:y1 + 1, x0:x1 + 1][
        passable[y0:y1 + 1, x0:x1 + 1]]
    if not inside.size:
        return 0.0
    return 1.0 - (1.0 - RISK_FREE_ERROR_BOUND) * float(inside.min() / inside.max())


def aistar(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, start: Sequence[int],
           goals: object, window: Sequence[int] | None = None) -> SearchResult | None:
    """The cheapest path from ``start`` to the nearest of ``goals`` by Ai*.

    Arguments and result as for :func:`cbr_solvers.search.astar`. The heuristic is the integer
    distance map to the goals divided by 3 and times the smallest passable factor in the window;
    it is admissible and consistent, so the cost is optimal.
    """
    return _run(factor, passable, corner_cutting, start, goals, window, informed=True,
                heuristic=heuristic_table)
