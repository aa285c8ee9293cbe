"""Kernels of the perceived-obstacle map (:mod:`cbr_world2d.obstacle_map`): what the sonar ring
and the bumper say about a linear obstacle between two landmarks.

A pair of known landmarks is a hypothesis: a linear obstacle along the segment between their
estimated places. Its *interior*, the segment less ``margin`` metres at each end (where the
landmarks' own discs answer the sonar), is cut into ``bins`` equal stretches, and ``scores``
``(K, K, bins)`` (``int8``, only ``[i, j]`` with ``i < j`` used) holds each stretch's evidence:
positive when it was sensed occupied more often than free (of late), negative the other way, 0
when never sensed or undecided. A sonar beam reads the nearest obstacle anywhere in its cone, so
for each stretch whose middle lies inside a beam's cone, at ``expected`` metres from the rim:

- the beam reads more than ``near`` past ``expected``: nothing was there, a vote **free**;
- the beam reads within ``near`` of ``expected``, at most ``reach`` metres, and no known
  landmark in its cone (a disc of radius up to ``margin``) may be what it read: what it read
  may be the obstacle, a vote **occupied** (a far reading's wide cone explains too much, and
  from afar the landmarks at the segment's ends lie about as far as its middle);
- the beam reads nearer: something else hides the stretch, no vote;
- ``expected`` is not less than the ring's range less ``near``: the sonar cannot tell.

A free vote of any beam outweighs the occupied votes of others in the same scan. A bump whose
contact point lies within ``near`` of a stretch is a vote occupied worth :data:`LIMIT` (002's
robot identifies obstacles by bumping into them). Each vote moves the score by one and the
score is clamped to ``[-LIMIT, LIMIT]``, so that older evidence is outweighed by at most
``LIMIT + 1`` newer votes against it, and never forgotten by time alone.

Only pairs whose segment passes within ``reach`` (plus the robot's radius and ``near``) of the
robot are voted on. A pair is no hypothesis when its landmarks lie more than ``longest``
apart, less than two margins apart, or when another known landmark lies within ``near`` of its
interior: an obstacle along three landmarks is two obstacles, each between neighbours.
"""

from __future__ import annotations

import math

import numpy as np

from cbr_kernels import njit

LIMIT = 8
"""The largest score a stretch holds either way: the most votes newer evidence needs (plus one)
to turn it."""


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


@njit
def _landmark_returns(x: float, y: float, ux: np.ndarray, uy: np.ndarray, half: float,
                      radius: float, ranges: np.ndarray, places: np.ndarray, count: int,
                      near: float, margin: float) -> np.ndarray:
    """For each beam, whether a known landmark (a disc of radius up to ``margin``) inside its
    cone may be what it read."""
    out = np.zeros(ux.shape[0], dtype=np.bool_)
    for k in range(count):
        px, py = places[k, 0] - x, places[k, 1] - y
        d = math.sqrt(px * px + py * py)
        if d <= margin:
            continue
        threshold = d * math.cos(min(half + math.asin(margin / d), math.pi))
        for b in range(ux.shape[0]):
            if (px * ux[b] + py * uy[b] >= threshold
                    and d - radius - margin - near <= ranges[b] <= d - radius + near):
                out[b] = True
    return out


@njit
def record_scan(x: float, y: float, theta: float, directions: np.ndarray, half: float,
                max_range: float, radius: float, ranges: np.ndarray, bump_bearing: float,
                places: np.ndarray, count: int, scores: np.ndarray, near: float, margin: float,
                longest: float, reach: float) -> None:
    """Add one scan's votes to ``scores`` (see the module's docstring).

    ``(x, y, theta)`` is the robot's estimated pose; the ring's beams point at ``directions``
    relative to the heading, ``half`` wide each side, read from the rim of ``radius`` up to
    ``max_range``, and read ``ranges``. ``bump_bearing`` is where the robot touched something,
    relative to the heading (nan: no bump).
    """
    bins = scores.shape[2]
    cos_half = math.cos(half)
    ux = np.cos(theta + directions)
    uy = np.sin(theta + directions)
    # an obstacle no nearer than reach gets no occupied vote; the free votes it could get
    # are not worth the time of every pair in the sonar's range
    within = reach + radius + near
    explained = _landmark_returns(x, y, ux, uy, half, radius, ranges, places, count, near,
                                  margin)
    bumped = not math.isnan(bump_bearing)
    cx = x + radius * math.cos(theta + bump_bearing) if bumped else 0.0
    cy = y + radius * math.sin(theta + bump_bearing) if bumped else 0.0
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
            if fx * fx + fy * fy > within * within:
                continue
            if not is_candidate(places, count, i, j, near, margin, longest):
                continue
            lo = margin / length
            step = (1.0 - 2.0 * lo) / bins
            for k in range(bins):
                s = lo + (k + 0.5) * step
                px, py = ax + s * ex - x, ay + s * ey - y
                d = math.sqrt(px * px + py * py)
                expected = d - radius
                vote = 0
                if bumped:
                    qx, qy = ax + s * ex - cx, ay + s * ey - cy
                    if qx * qx + qy * qy <= max(near, 0.5 * step * length) ** 2:
                        vote = LIMIT
                if vote == 0 and expected < max_range - near:
                    threshold = d * cos_half
                    for b in range(ux.shape[0]):
                        if px * ux[b] + py * uy[b] < threshold:
                            continue
                        if ranges[b] > expected + near:
                            vote = -1
                            break
                        if expected - near <= ranges[b] <= reach and not explained[b]:
                            vote = 1
                if vote != 0:
                    scores[i, j, k] = min(max(scores[i, j, k] + vote, -LIMIT), LIMIT)
