"""The situation features of the index (:data:`cbr_behaviors.index.SITUATION`), computed from
what the robot senses.

Figure 5's raw features cannot tell an office floor's situations apart: one walker passing
changes every sonar range at once, and the ``map`` set flips from "empty hallway" to "object
near" whenever any cell within 3 m is occupied. The features here name what a behavior set is
chosen for, each scaled into [0, 1]:

- the sonar as sector minima (:func:`sectors`): the nearest reading ahead (within 15 degrees of
  the heading), to the left and right (15 to 150 degrees) and behind, and the free width
  across the robot (:func:`free_width`);
- the nearest person in view (:func:`people_in_view`): the robot's person tracker, as a camera
  or laser leg detector gives one on a real robot, reports the people within
  :data:`PERSON_REACH` that no wall or shut door hides, with their distance (to their rim),
  bearing and closing speed;
- the doorway ahead (:func:`door_ahead`): the next doorway the planned route passes within
  :data:`DOOR_REACH`, and whether its door is shut (seen, as the camera sees it, once it is in
  line of sight);
- the progress along the route to the goal (:func:`progress`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import attrs
import numpy as np

from cbr_behaviors.index import SONAR_MAX

if TYPE_CHECKING:
    from cbr_world2d.crowd import Crowd
    from cbr_world2d.robot import Pose
    from cbr_world2d.world import Door, Point, World

FRONT_ARC = math.radians(15.0)
"""The beams within this of the heading are ``front`` (on a Pioneer the two at 10 degrees,
whose cones reach 25 degrees: in a hallway 2 m wide the walls stand 2.4 m off along them, so
that ``front`` tells an open way from one blocked ahead)."""
REAR_ARC = math.radians(150.0)
"""The beams more than this off the heading are ``rear``; those between the arcs are ``left``
(counter-clockwise) and ``right``."""
SIDE_ARC = math.radians(20.0)
"""The beams within this of straight left or right measure the free width."""
WIDTH_SCALE = 4.0
"""Metres of free width at which ``width`` reaches 1: wider than any hallway, a room."""
PERSON_REACH = 5.0
"""Metres: the person tracker reports people this near (their rim)."""
CLOSING_SCALE = 1.5
"""m/s at which ``closing`` reaches 1: a walker at 1.1 m/s meeting the robot at 0.4 m/s."""
DOOR_REACH = 5.0
"""Metres: the doorway ahead counts within this, straight-line to its centre."""


def sectors(sonar: Sequence[float] | np.ndarray, angles: Sequence[float] | np.ndarray
            ) -> tuple[float, float, float, float]:
    """``(front, left, right, rear)``: the nearest reading in each sector, metres, at most
    :data:`~cbr_behaviors.index.SONAR_MAX` (a sector with no beam reads that)."""
    ranges = np.minimum(np.asarray(sonar, dtype=float), SONAR_MAX)
    wrapped = (np.asarray(angles, dtype=float) + math.pi) % (2.0 * math.pi) - math.pi
    off = np.abs(wrapped)
    side = (off > FRONT_ARC) & (off <= REAR_ARC)

    def nearest(mask: np.ndarray) -> float:
        return float(ranges[mask].min()) if mask.any() else SONAR_MAX

    return (nearest(off <= FRONT_ARC), nearest(side & (wrapped > 0)),
            nearest(side & (wrapped < 0)), nearest(off > REAR_ARC))


def free_width(sonar: Sequence[float] | np.ndarray, angles: Sequence[float] | np.ndarray,
               diameter: float) -> float:
    """Metres free across the robot: the nearest readings within :data:`SIDE_ARC` of straight
    left and right, as followWall reads them (:func:`cbr_world2d.pilots.kernels.sides`),
    each at most :data:`~cbr_behaviors.index.SONAR_MAX`, and its ``diameter``."""
    from cbr_world2d.pilots.kernels import sides

    left, right = sides(np.asarray(sonar, dtype=np.float64),
                        np.asarray(angles, dtype=np.float64), SIDE_ARC)
    return min(left, SONAR_MAX) + min(right, SONAR_MAX) + diameter


@attrs.frozen
class PersonSeen:
    """A person the tracker reports: ``distance`` to their rim (metres), ``bearing`` off the
    robot's heading (radians, left positive), ``closing`` how fast the gap shrinks (m/s,
    negative when parting) and where they stand in the robot's own frame of the map (``x``,
    ``y``: the robot's believed pose plus the measured offset)."""

    distance: float
    bearing: float
    closing: float
    x: float
    y: float


def people_in_view(crowd: Crowd, true: Pose, believed: Pose, dt: float, robot_v: float,
                   reach: float = PERSON_REACH) -> list[PersonSeen]:
    """The people of ``crowd`` whose rim lies within ``reach`` of the robot's centre and whom no
    wall or shut door hides, nearest first. ``true`` is where the robot is (the tracker
    measures from it), ``believed`` where it thinks it is (the positions are reported in its
    frame), ``robot_v`` its speed: the closing speed is the robot's and the person's
    velocities (over the last step, ``dt``) along the line between them."""
    from cbr_world2d.geometry import visible

    world, t = crowd.world, crowd.t
    seen: list[PersonSeen] = []
    segments = None
    heading = (math.cos(true.theta), math.sin(true.theta))
    for mover, (px, py), (qx, qy) in zip(world.movers, crowd.now, crowd.before, strict=True):
        if mover.kind != "person" or not mover.present(t):
            continue
        dx, dy = px - true.x, py - true.y
        centre = math.hypot(dx, dy)
        gap = centre - mover.radius
        if gap > reach or centre == 0.0:
            continue
        if segments is None:
            segments = world.segments_at(t)
        if not visible(true.x, true.y, px, py, segments):
            continue
        ux, uy = dx / centre, dy / centre
        person_v = ((px - qx) * ux + (py - qy) * uy) / dt
        closing = robot_v * (heading[0] * ux + heading[1] * uy) - person_v
        bearing = math.atan2(dy, dx) - true.theta
        bearing = (bearing + math.pi) % (2.0 * math.pi) - math.pi
        direction = believed.theta + bearing
        seen.append(PersonSeen(gap, bearing, closing, believed.x + centre * math.cos(direction),
                               believed.y + centre * math.sin(direction)))
    return sorted(seen, key=lambda p: p.distance)


def _crosses(a: Point, b: Point, door: Door) -> bool:
    """Whether the leg ``a``-``b`` crosses the doorway ``door`` (proper intersection)."""
    (ax, ay), (bx, by) = a, b
    (cx, cy), (dx, dy) = door.a, door.b

    def side(px: float, py: float, qx: float, qy: float, rx: float, ry: float) -> float:
        return (qx - px) * (ry - py) - (qy - py) * (rx - px)

    return (side(ax, ay, bx, by, cx, cy) * side(ax, ay, bx, by, dx, dy) < 0
            and side(cx, cy, dx, dy, ax, ay) * side(cx, cy, dx, dy, bx, by) < 0)


def door_ahead(world: World, at: Point, route: Sequence[Point], t: float,
               reach: float = DOOR_REACH) -> tuple[float, bool] | None:
    """``(distance, shut)`` of the first doorway the route from ``at`` through ``route``
    crosses, or whose centre is a waypoint, within ``reach`` (straight-line from ``at`` to its
    centre); None when there is none. ``shut`` is whether its door is shut now, which the robot
    sees once the doorway's centre is in line of sight."""
    from cbr_world2d.geometry import visible

    for a, b in itertools.pairwise([at, *route]):
        if math.dist(at, a) > reach:
            return None
        # of the doorways this leg passes, the nearest its start
        passed = [door for door in world.doors
                  if _crosses(a, b, door) or math.dist(b, _centre(door)) < 0.05]
        if passed:
            door = min(passed, key=lambda d: math.dist(a, _centre(d)))
            centre = _centre(door)
            distance = math.dist(at, centre)
            if distance > reach:
                return None
            seen = visible(at[0], at[1], centre[0], centre[1], world.static_segments)
            return distance, bool(seen and not door.is_open(t))
    return None


def _centre(door: Door) -> Point:
    return ((door.a[0] + door.b[0]) / 2, (door.a[1] + door.b[1]) / 2)


def progress(remaining: float, total: float) -> float:
    """The part of a route already driven: ``1 - remaining / total`` in [0, 1] (1 with no
    route left to drive)."""
    if total <= 0.0:
        return 1.0
    return min(1.0, max(0.0, 1.0 - remaining / total))
