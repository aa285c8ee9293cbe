"""Hausdorff distances between one new path and many stored paths, in one compiled call.

A path is an ordered (n, 2) integer array of (x, y) grid cells. Whole-path case bases (Kruusmaa
& Svensson; Šeda & Dvořák, eq. 8) compare a path about to be retained with every stored path by
the directed Hausdorff distance ``D(P1, P2) = max over c1 in P1 of min over c2 in P2 of d(c1, c2)``
or its symmetric form ``max(D(P1, P2), D(P2, P1))``, with ``d`` the euclidean, manhattan, octile
or chebyshev cell distance.

Hand-written because ``scipy.spatial.distance.directed_hausdorff`` takes one pair per call and
measures euclidean distance only, while the case base needs four metrics against thousands of
stored paths per retained one: a Python loop over the pairs would dominate the retain step.
The stored paths are spans of one cell array: :func:`hausdorff` takes them back to back
(offsets), :func:`hausdorff_spans` anywhere in it (the case base's store of cells, which keeps
the paths it forgot until it compacts, and compares only the paths its index finds near).

The kernel is the early-break algorithm of Taha & Hanbury (2015): for each cell of A it scans B and
stops as soon as a cell no farther than the running maximum turns up, since that cell of A can no
longer raise the maximum. Two orderings make early breaks come soon on paths: the cells of A are
visited coarse first (every s-th cell, s = floor(sqrt(n)), then the rest), so the running maximum
grows large early, and each scan of B starts where the previous one stopped and works outwards on
both sides of it in turn, since consecutive cells of a path have nearby nearest neighbours, after
or before the previous one as B runs along A or against it (a stored path between the same ends as
a new one is as likely to have been driven the other way). Distances above ``limit`` are not needed
by the caller, so a pair stops as soon as its running maximum exceeds ``limit``, and a pair whose
bounding boxes are already farther apart than ``limit`` is not scanned at all.

The kernel runs serially (no ``parallel=True``): the engine may call it from several threads,
and numba's default threading layer does not allow concurrent parallel launches.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from cbr_kernels import njit

SQRT2 = math.sqrt(2.0)

# Metric codes for the kernel, by the names the public function takes.
_EUCLIDEAN, _MANHATTAN, _OCTILE, _CHEBYSHEV = 1, 2, 3, 9
METRICS = {"euclidean": _EUCLIDEAN, "manhattan": _MANHATTAN, "octile": _OCTILE,
           "chebyshev": _CHEBYSHEV}


@njit(inline="always")
def _key(dx: int, dy: int, metric: int) -> float:
    """A key of the distance between cells ``|dx|, |dy|`` apart, increasing with the distance.

    The key is the distance itself except for euclidean, where it is the squared distance (an
    exact integer), so the inner loop takes no square root.
    """
    if metric == _EUCLIDEAN:
        return float(dx * dx + dy * dy)
    if metric == _MANHATTAN:
        return float(dx + dy)
    if metric == _OCTILE:
        return (SQRT2 - 1.0) * min(dx, dy) + max(dx, dy)
    return float(max(dx, dy))


@njit(inline="always")
def _value(key: float, metric: int) -> float:
    """The distance of a :func:`_key`."""
    return math.sqrt(key) if metric == _EUCLIDEAN else key


@njit
def _directed(a: np.ndarray, a0: int, a1: int, b: np.ndarray, b0: int, b1: int, metric: int,
              limit: float) -> float:
    """D(a[a0:a1], b[b0:b1]) by early break; inf as soon as it is known to exceed ``limit``."""
    n, m = a1 - a0, b1 - b0
    stride = max(1, int(math.sqrt(n)))
    worst = 0.0  # the running maximum, as a key
    start = b0  # where the next scan of b begins: where the previous one stopped
    for coarse in (True, False):
        for i in range(a0, a1):
            if ((i - a0) % stride == 0) != coarse:
                continue
            ax, ay = a[i, 0], a[i, 1]
            nearest, at = math.inf, start
            # outwards from start, one cell after it and one before it in turn (wrapping
            # round): b may run either way along a, so the next nearest cell lies on either side
            after, before = start, start - 1 if start > b0 else b1 - 1
            for step in range(m):
                if step % 2 == 0:
                    j = after
                    after = after + 1 if after + 1 < b1 else b0
                else:
                    j = before
                    before = before - 1 if before > b0 else b1 - 1
                key = _key(abs(ax - b[j, 0]), abs(ay - b[j, 1]), metric)
                if key < nearest:
                    nearest, at = key, j
                if key <= worst:
                    break  # this cell of a cannot raise the maximum
            start = at
            if nearest > worst:
                worst = nearest
                if _value(worst, metric) > limit:
                    return math.inf
    return _value(worst, metric)


@njit
def _box(cells: np.ndarray, s: int, e: int) -> tuple[int, int, int, int]:
    """The inclusive bounding box (x0, y0, x1, y1) of ``cells[s:e]``, which is not empty."""
    x0 = x1 = cells[s, 0]
    y0 = y1 = cells[s, 1]
    for i in range(s + 1, e):
        x, y = cells[i, 0], cells[i, 1]
        x0, x1 = min(x0, x), max(x1, x)
        y0, y1 = min(y0, y), max(y1, y)
    return x0, y0, x1, y1


@njit
def _all(path: np.ndarray, cells: np.ndarray, begins: np.ndarray, ends: np.ndarray,
         metric: int, limit: float, symmetric: bool, forward: np.ndarray,
         backward: np.ndarray) -> None:
    """Fill ``forward[i] = D(path, P_i)`` and ``backward[i] = D(P_i, path)`` for each stored path
    P_i = ``cells[begins[i]:ends[i]]``; with ``symmetric``, both are inf as soon as one is.

    Any two cells of two paths are at least the gaps between the paths' bounding boxes apart on
    each axis, and all four metrics grow with ``|dx|`` and with ``|dy|``: the metric of the gaps
    bounds both directed distances from below. A pair whose bound exceeds ``limit`` is skipped.
    """
    n = path.shape[0]
    px0, py0, px1, py1 = _box(path, 0, n)
    for i in range(begins.shape[0]):
        s, e = begins[i], ends[i]
        x0, y0, x1, y1 = _box(cells, s, e)
        gx = max(0, x0 - px1, px0 - x1)
        gy = max(0, y0 - py1, py0 - y1)
        if _value(_key(gx, gy, metric), metric) > limit:
            forward[i] = backward[i] = math.inf
            continue
        backward[i] = _directed(cells, s, e, path, 0, n, metric, limit)
        if symmetric and backward[i] == math.inf:
            # a stored path running on past the new one's ends, along it: the way back
            # finds that at the first cell beyond, the way out would scan every cell
            forward[i] = math.inf
            continue
        forward[i] = _directed(path, 0, n, cells, s, e, metric, limit)


def _cells(array: npt.ArrayLike, name: str, at_least: int) -> np.ndarray:
    """``array`` as a contiguous (n, 2) int64 array with n >= ``at_least``; ValueError if not."""
    cells = np.asarray(array)
    if cells.ndim != 2 or cells.shape[1] != 2 or cells.shape[0] < at_least:
        raise ValueError(f"{name} must be an (n, 2) array of (x, y) cells with n >= {at_least};"
                         f" got shape {cells.shape}")
    if cells.size and not np.issubdtype(cells.dtype, np.integer):
        raise ValueError(f"{name} must hold integer cells; got dtype {cells.dtype}")
    return np.ascontiguousarray(cells, dtype=np.int64)


def _metric(distance: str, limit: float) -> tuple[int, float]:
    """The kernel's metric code and the limit as a float; ValueError naming a bad one."""
    metric = METRICS.get(distance)
    if metric is None:
        raise ValueError(f"distance must be one of {', '.join(map(repr, METRICS))};"
                         f" got {distance!r}")
    limit = float(limit)
    if math.isnan(limit):
        raise ValueError("limit must be a number or inf; got nan")
    return metric, limit


def hausdorff_spans(path: np.ndarray, cells: np.ndarray, begins: np.ndarray, ends: np.ndarray,
                    *, distance: str = "euclidean", limit: float = math.inf,
                    symmetric: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """:func:`hausdorff` for the stored paths ``cells[begins[i]:ends[i]]``, anywhere in
    ``cells``: contiguous int64 arrays, ``path`` (n, 2) with n >= 1, ``cells`` (M, 2), and
    ``0 <= begins[i] < ends[i] <= M`` (the caller's own layout, which is not checked).

    ``symmetric``: only the symmetric distance is wanted, so a pair found beyond ``limit`` one
    way is reported inf both ways without scanning the other way.
    """
    metric, limit = _metric(distance, limit)
    forward = np.empty(len(begins), dtype=np.float64)
    backward = np.empty(len(begins), dtype=np.float64)
    _all(path, cells, begins, ends, metric, limit, symmetric, forward, backward)
    return forward, backward


def hausdorff(path: npt.ArrayLike, cells: npt.ArrayLike, offsets: npt.ArrayLike, *,
              distance: str = "euclidean", limit: float = math.inf
              ) -> tuple[np.ndarray, np.ndarray]:
    """Directed Hausdorff distances between ``path`` and each of k stored paths, both ways.

    ``path`` is the (n, 2) integer array of the new path's (x, y) cells, n >= 1. The stored paths
    are concatenated in the (M, 2) integer array ``cells``; ``offsets`` is the (k + 1,) integer
    array with stored path i = ``cells[offsets[i]:offsets[i + 1]]``, starting at 0, ending at M
    and increasing (no stored path is empty); k may be 0. ``distance`` names the cell metric:
    "euclidean", "manhattan", "octile" or "chebyshev".

    Returns ``(forward, backward)``, float64 arrays of length k with ``forward[i] = D(path, P_i)``
    and ``backward[i] = D(P_i, path)``; the symmetric Hausdorff distance is
    ``np.maximum(forward, backward)``. Every entry whose true value exceeds ``limit`` is reported
    as inf (that lets the computation stop early); entries up to ``limit`` are exact. Raises
    ValueError for malformed arguments, naming what was expected.
    """
    _metric(distance, limit)  # a bad distance or limit is named before the arrays
    path = _cells(path, "path", 1)
    cells = _cells(cells, "cells", 0)
    bounds = np.asarray(offsets)
    if bounds.ndim != 1 or bounds.shape[0] < 1 or not np.issubdtype(bounds.dtype, np.integer):
        raise ValueError("offsets must be a 1-d integer array of k + 1 path bounds; got"
                         f" shape {bounds.shape}, dtype {bounds.dtype}")
    if bounds[0] != 0 or bounds[-1] != cells.shape[0]:
        raise ValueError(f"offsets must start at 0 and end at len(cells) = {cells.shape[0]};"
                         f" got {bounds[0]} and {bounds[-1]}")
    steps = np.diff(bounds)
    if (steps < 0).any():
        raise ValueError("offsets must be non-decreasing; they decrease after index"
                         f" {int(np.argmax(steps < 0))}")
    if (steps == 0).any():
        raise ValueError(f"stored path {int(np.argmax(steps == 0))} is empty"
                         " (offsets repeat a value)")
    bounds = np.ascontiguousarray(bounds, dtype=np.int64)
    return hausdorff_spans(path, cells, bounds[:-1], bounds[1:], distance=distance, limit=limit)
