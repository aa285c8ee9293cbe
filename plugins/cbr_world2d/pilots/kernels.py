"""The pilots' numba kernels: the potential field of :mod:`.potential_field`, and the sonar
sector ahead and the readings beside the robot that the behaviors of :mod:`.primitives` read.

They live apart from the pilots' options, which the plugin registers at every start of ``cbr``:
this module loads numba, and only a pilot that is built to drive imports it.
"""

from __future__ import annotations

import math

import numpy as np

from cbr_kernels import njit


@njit
def field_force(x: float, y: float, theta: float, tx: float, ty: float, ranges: np.ndarray,
                angles: np.ndarray, attraction: float, repulsion: float, influence: float,
                min_range: float) -> tuple[float, float]:
    """The total force ``(fx, fy)`` in the world frame on a robot at ``(x, y, theta)`` heading
    for ``(tx, ty)`` with sonar ``ranges`` along ``angles`` (relative to the heading)."""
    dx, dy = tx - x, ty - y
    norm = math.hypot(dx, dy)
    fx = fy = 0.0
    if norm > 0.0:
        fx, fy = attraction * dx / norm, attraction * dy / norm
    for i in range(ranges.shape[0]):
        d = ranges[i]
        if d >= influence:
            continue
        d = max(d, min_range)
        push = repulsion * (1.0 / d - 1.0 / influence) / (d * d)
        phi = theta + angles[i]
        fx -= push * math.cos(phi)
        fy -= push * math.sin(phi)
    return fx, fy


@njit
def field_command(x: float, y: float, theta: float, tx: float, ty: float, ranges: np.ndarray,
                  angles: np.ndarray, attraction: float, repulsion: float, influence: float,
                  min_range: float, turn_gain: float, max_turn_rate: float, max_speed: float,
                  slow_distance: float, approach: float) -> tuple[float, float]:
    """The command ``(v, w)`` of the potential field (see
    :mod:`cbr_world2d.pilots.potential_field`)."""
    fx, fy = field_force(x, y, theta, tx, ty, ranges, angles, attraction, repulsion,
                         influence, min_range)
    if fx == 0.0 and fy == 0.0:
        return 0.0, 0.0
    error = math.atan2(fy, fx) - theta
    error = (error + math.pi) % (2.0 * math.pi) - math.pi
    w = min(max(turn_gain * error, -max_turn_rate), max_turn_rate)
    front = slow_distance
    for i in range(ranges.shape[0]):
        a = (angles[i] + math.pi) % (2.0 * math.pi) - math.pi
        if abs(a) < 0.5 * math.pi and ranges[i] < front:
            front = max(ranges[i], 0.0)
    v = max_speed * max(math.cos(error), 0.0) * (front / slow_distance)
    v *= min(1.0, math.hypot(tx - x, ty - y) / approach)
    return v, w


@njit
def sector(ranges: np.ndarray, angles: np.ndarray, arc: float,
           distance: float) -> tuple[float, float]:
    """``(nearest, side)`` over the beams within ``arc`` of the heading (``angles`` relative to
    it): the shortest reading (inf when no beam is in the arc) and the side to turn to, away
    from the readings closer than ``distance``: each such reading weighs
    ``(distance - d) * sin(angle)``, positive on the left; -1 (turn right) when the sum is
    positive, else +1 (turn left, counter-clockwise: a wall straight ahead, or nothing close,
    turns left)."""
    nearest = math.inf
    weight = 0.0
    for i in range(ranges.shape[0]):
        a = (angles[i] + math.pi) % (2.0 * math.pi) - math.pi
        if abs(a) > arc + 1e-9:
            continue
        d = ranges[i]
        nearest = min(nearest, d)
        if d < distance:
            weight += (distance - d) * math.sin(a)
    return nearest, (-1.0 if weight > 0.0 else 1.0)


@njit
def sides(ranges: np.ndarray, angles: np.ndarray, arc: float) -> tuple[float, float]:
    """``(left, right)``: the shortest reading among the beams within ``arc`` of straight left
    (+90 degrees from the heading, ``angles`` relative to it) and of straight right (-90); inf
    on a side with no beam in its arc."""
    left = right = math.inf
    half = 0.5 * math.pi
    for i in range(ranges.shape[0]):
        a = (angles[i] + math.pi) % (2.0 * math.pi) - math.pi
        if abs(a - half) <= arc + 1e-9:
            left = min(left, ranges[i])
        elif abs(a + half) <= arc + 1e-9:
            right = min(right, ranges[i])
    return left, right
