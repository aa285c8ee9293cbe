"""What every pilot is: the :class:`Pilot` protocol, the stash key of the run's pilot, and the
angle helpers pilots share.

A pilot turns one observation and the target it is told to head for into a motion command
``(v, w)``: forward speed in m/s and turn rate in rad/s, counter-clockwise positive. It sees the
world only through the observation (odometry pose, sonar ranges, sightings), never the world
itself, and the robot's own limits are applied afterwards by :func:`cbr_world2d.robot.step`, so a
pilot may ask for more than the robot can do.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Protocol, runtime_checkable

if TYPE_CHECKING:
    from cbr_world2d.sensors import Observation

Point = tuple[float, float]
Command = tuple[float, float]
"""``(v, w)``: forward speed (m/s) and turn rate (rad/s, counter-clockwise positive)."""


@runtime_checkable
class Pilot(Protocol):
    """Drives the robot toward a target, avoiding what its sensors report."""

    def command(self, obs: Observation, target: Point) -> Command:
        """The command ``(v, w)`` for this step, heading for ``target`` (metres, world frame)."""
        ...

    def reset(self) -> None:
        """Forget whatever the pilot kept from earlier steps (a new trial begins)."""
        ...




def wrap_angle(angle: float) -> float:
    """``angle`` in radians brought into ``[-pi, pi)``."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def bearing_error(x: float, y: float, theta: float, target: Point) -> tuple[float, float]:
    """``(distance, error)`` from the pose ``(x, y, theta)`` to ``target``: the straight-line
    distance and the heading error, the angle to turn (counter-clockwise positive, in
    ``[-pi, pi)``) to face it."""
    dx, dy = target[0] - x, target[1] - y
    return math.hypot(dx, dy), wrap_angle(math.atan2(dy, dx) - theta)
