"""Kernels of the perceived-obstacle map (:mod:`cbr_world2d.obstacle_map`): which readings of
the sonar ring and the bumper a linear obstacle between two landmarks would explain.

A pair of known landmarks is a hypothesis: a linear obstacle along the segment between their
estimated places. Its *interior*, the segment less ``margin`` metres at each end (where the
landmarks' own discs answer the sonar), is cut into ``bins`` equal stretches, and ``marks``
``(K, K, bins)`` (``int8``, only ``[i, j]`` with ``i < j`` used) holds each stretch's latest
verdict: 1 seen occupied, -1 seen free, 0 never sensed. A scan gives, for every pair in reach:

- **occupied**, the stretch where the segment comes nearest the robot inside a beam's cone,
  when the beam's reading is within ``near`` metres of what the segment would give there (the
  sonar reads the nearest obstacle anywhere in its cone, so that is where the return came
  from if the obstacle is there);
- **occupied**, the stretch within ``near`` of the contact point when the robot bumped;
- **free**, the stretch the beam's axis crosses, when the beam reads more than ``near``
  metres past the crossing (the axis passed through where the obstacle would be), the
  crossing is nearer than the range less ``near`` and the axis meets the segment at 30
  degrees or more (a grazing axis crosses far along the segment for a small error in the
  landmarks' places).

A pair is no hypothesis when its landmarks lie more than ``longest`` apart, less than two
margins apart, or when another known landmark lies within ``near`` of its interior: an
obstacle along three landmarks is two obstacles, each between neighbours.
"""

from __future__ import annotations

import math

import numpy as np

from cbrcore.compiled import njit

FREE_INCIDENCE = 0.5
"""The least sine of the angle at which a beam's axis must meet a segment to see it free
(30 degrees)."""


@njit
def is_candidate(places: np.ndarray, count: int, i: int, j: int, near: float, margin: float,
                 longest: float) -> bool:
    """Whether landmarks ``i`` and ``j`` of the ``count`` known ``places`` ``(K, 2)`` may be
    joined by a linear obstacle (see the module's docstring)."""
    ax, ay = places[i, 0], places[i, 1]
    ex, ey = places[j, 0] - ax, places[j, 1] - ay
    length = math.sqrt(ex * ex + ey * ey)
    if length > longest or length <= 2.0 * margin:
        return False
    for k in range(count):
        if k in (i, j):
            continue
        s = ((places[k, 0] - ax) * ex + (places[k, 1] - ay) * ey) / (length * length)
        if s * length < margin or s * length > length - margin:
            continue
        qx, qy = ax + s * ex - places[k, 0], ay + s * ey - places[k, 1]
        if qx * qx + qy * qy <= near * near:
            return False
    return True


@njit(inline="always")
def _bin(s: float, lo: float, hi: float, bins: int) -> int:
    return min(max(int((s - lo) / (hi - lo) * bins), 0), bins - 1)


@njit
def nearest_in_cone(x: float, y: float, ux: float, uy: float, cos_half: float,
                     half: float, ax: float, ay: float, ex: float, ey: float
                     ) -> tuple[float, float]:
    """``(distance, s)``: the point ``a + s e`` of the segment nearest ``(x, y)`` inside the
    cone of axis ``u`` and half-width ``half`` (inf when none lies in it)."""
    best = np.inf
    best_s = -1.0
    length2 = ex * ex + ey * ey
    foot = min(max(((x - ax) * ex + (y - ay) * ey) / length2, 0.0), 1.0)
    candidates = [0.0, 1.0, foot]
    # where the cone's two edges cross the segment bound its part inside the cone
    for sign in (-1.0, 1.0):
        c, s_ = math.cos(sign * half), math.sin(sign * half)
        dx, dy = c * ux - s_ * uy, s_ * ux + c * uy
        denom = dx * ey - dy * ex
        if denom != 0.0:
            wx, wy = ax - x, ay - y
            t = (wx * ey - wy * ex) / denom
            s = (wx * dy - wy * dx) / denom
            if t >= 0.0 and 0.0 <= s <= 1.0:
                candidates.append(s)
    for s in candidates:
        px, py = ax + s * ex - x, ay + s * ey - y
        d = math.sqrt(px * px + py * py)
        if d < best and px * ux + py * uy >= d * cos_half - 1e-12:
            best = d
            best_s = s
    return best, best_s


@njit
def record_scan(x: float, y: float, theta: float, directions: np.ndarray, half: float,
                max_range: float, radius: float, ranges: np.ndarray, bump_bearing: float,
                places: np.ndarray, count: int, marks: np.ndarray, near: float, margin: float,
                longest: float) -> None:
    """Write one scan's verdicts into ``marks`` (see the module's docstring).

    ``(x, y, theta)`` is the robot's estimated pose; the ring's beams point at ``directions``
    relative to the heading, ``half`` wide each side, read from the rim of ``radius`` up to
    ``max_range``, and read ``ranges``. ``bump_bearing`` is where the robot touched something,
    relative to the heading (nan: no bump).
    """
    bins = marks.shape[2]
    cos_half = math.cos(half)
    reach = max_range + radius + near
    for i in range(count):
        for j in range(i + 1, count):
            ax, ay = places[i, 0], places[i, 1]
            ex, ey = places[j, 0] - ax, places[j, 1] - ay
            length2 = ex * ex + ey * ey
            length = math.sqrt(length2)
            if length > longest or length <= 2.0 * margin:
                continue
            foot = min(max(((x - ax) * ex + (y - ay) * ey) / length2, 0.0), 1.0)
            fx, fy = ax + foot * ex - x, ay + foot * ey - y
            if fx * fx + fy * fy > reach * reach:
                continue
            if not is_candidate(places, count, i, j, near, margin, longest):
                continue
            lo = margin / length
            hi = 1.0 - lo
            if not math.isnan(bump_bearing):
                cx = x + radius * math.cos(theta + bump_bearing)
                cy = y + radius * math.sin(theta + bump_bearing)
                s = ((cx - ax) * ex + (cy - ay) * ey) / length2
                qx, qy = ax + s * ex - cx, ay + s * ey - cy
                if lo <= s <= hi and qx * qx + qy * qy <= near * near:
                    marks[i, j, _bin(s, lo, hi, bins)] = 1
            for b in range(directions.shape[0]):
                ux = math.cos(theta + directions[b])
                uy = math.sin(theta + directions[b])
                d, s = nearest_in_cone(x, y, ux, uy, cos_half, half, ax, ay, ex, ey)
                expected = d - radius
                if (expected < max_range - near and abs(ranges[b] - expected) <= near
                        and lo <= s <= hi):
                    marks[i, j, _bin(s, lo, hi, bins)] = 1
            for b in range(directions.shape[0]):
                ux = math.cos(theta + directions[b])
                uy = math.sin(theta + directions[b])
                denom = ux * ey - uy * ex
                if abs(denom) < FREE_INCIDENCE * length:
                    continue
                wx, wy = ax - x, ay - y
                t = (wx * ey - wy * ex) / denom
                s = (wx * uy - wy * ux) / denom
                crossing = t - radius
                if (lo <= s <= hi and 0.0 <= crossing < max_range - near
                        and ranges[b] > crossing + near):
                    marks[i, j, _bin(s, lo, hi, bins)] = -1
