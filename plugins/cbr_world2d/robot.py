"""The robot: a disc with unicycle (differential-drive) kinematics, limits and collisions.

:class:`RobotSpec` holds the body and the limits, with two presets whose numbers are sourced
below; :class:`RobotState` is the pose and the current speeds; :func:`step` advances a state by
one time step under a ``(v, w)`` command. Limits apply in the order a motor controller applies
them: the change of speed is capped by the acceleration first, then the result by the speed
limits. Motion follows the exact arc of constant ``v`` and ``w``; the swept disc is checked
continuously against every segment and disc (:func:`cbr_world2d.geometry.advance`), so the
robot never passes through anything.

A blocked step stops the robot at the contact point with ``v = w = 0`` (as P2OS does with its
``BUMP_STALL`` option: stop and register a stall when the bump ring is touched, Pioneer 2
manual, command 44) but still applies the step's turn: a disc
turning on the spot cannot hit anything, and letting the turn through is what lets a pilot turn
away from the wall it touches instead of freezing against it. From contact the robot may drive
on only along a path that leaves the obstacle (or runs along it), forward or in reverse.
"""

from __future__ import annotations

import math

import attrs
import numpy as np

from cbr_world2d.checks import non_negative, positive
from cbr_world2d.geometry import advance


@attrs.frozen
class RobotSpec:
    """A disc robot's body and limits (metres, seconds, radians).

    ``max_speed`` forward and ``max_reverse`` backward (both >= 0) bound the speed,
    ``max_turn_rate`` the turn rate either way; ``max_accel`` and ``max_turn_accel`` bound how
    fast either changes (the same for speeding up and braking).
    """

    radius: float = attrs.field(converter=float, validator=positive)
    max_speed: float = attrs.field(converter=float, validator=positive)
    max_reverse: float = attrs.field(converter=float, validator=non_negative)
    max_turn_rate: float = attrs.field(converter=float, validator=positive)
    max_accel: float = attrs.field(converter=float, validator=positive)
    max_turn_accel: float = attrs.field(converter=float, validator=positive)
    name: str = ""


PIONEER_2DX = RobotSpec(
    radius=0.25,
    max_speed=0.75,
    max_reverse=0.75,
    max_turn_rate=math.radians(100.0),
    max_accel=0.3,
    max_turn_accel=math.radians(100.0),
    name="pioneer-2dx",
)
"""The Pioneer 2 DX of 004 (Fox, RUPART).

- ``radius`` 0.25 m: ``RobotRadius 250`` (mm) in ARIA's parameter file ``params/p2dx.p``,
  the radius ARIA itself gives the robot; the body is ``RobotWidth 425`` by
  ``RobotLength 511`` mm, centred 210 mm behind the nose (``RobotLengthFront 210``).
- ``max_speed`` 0.75 m/s and ``max_turn_rate`` 100 deg/s: the speed profile MobileRobots'
  own simulator gives its Pioneer 2 bases (MobileSim / AMRISim ``PioneerRobotModels.world.inc``,
  models ``p2de``, ``p2d8``, ``p2ce``: ``max_speed [0.75 0 1.74]``, m/s and rad/s). The
  absolute ceilings in ``p2dx.p`` are ``MaxVelocity 2200`` mm/s and ``MaxRVelocity 500``
  deg/s, which no Pioneer 2 drives at in practice. Reverse is as fast as forward (the drive is
  symmetric).
- ``max_accel`` 0.3 m/s^2 and ``max_turn_accel`` 100 deg/s^2: the same file's Pioneer
  defaults ``accel [0.3 0 1.74]`` (its braking, ``decel`` 0.6 m/s^2, is faster; one bound for
  both keeps the model simple and errs on the cautious side). ``p2dx.p`` leaves
  ``TransAccel`` and ``RotAccel`` at 0, meaning "use the robot's firmware values".
"""

ROS_2005 = RobotSpec(
    radius=0.2,
    max_speed=0.05,
    max_reverse=0.05,
    max_turn_rate=math.radians(45.0),
    max_accel=0.05,
    max_turn_accel=math.radians(90.0),
    name="ros-2005",
)
"""The simulated robot of 002 (Ros et al.).

- ``max_speed`` 0.05 m/s: "the robot's average velocity is 5 cm/sec" (002 section 4); their
  optimal times are the optimal distances at exactly that speed (539.82 cm in 107 s), so the
  robot cruises at 5 cm/s and 5 cm/s is its top speed. It backs up as slowly.
- The paper gives nothing else. ``radius`` 0.2 m is a small research platform of that time
  (a Pioneer-class body); ``max_turn_rate`` 45 deg/s turns it round in a few seconds, fast next
  to its 5 cm/s so that avoiding stays a matter of steering; ``max_accel`` 0.05 m/s^2 reaches
  cruising speed in one second and ``max_turn_accel`` 90 deg/s^2 the full turn rate in half a
  second, so the pilot's commands are followed almost at once, as in the paper's simulator.
"""

PRESETS: dict[str, RobotSpec] = {"pioneer2dx": PIONEER_2DX, "ros2005": ROS_2005}
"""The presets by the names configurations and the command line use."""


@attrs.frozen
class Pose:
    """Where the robot is and where it faces (``theta``, radians from +x)."""

    x: float
    y: float
    theta: float


@attrs.frozen
class RobotState:
    """The robot's pose and its current speed ``v`` (m/s) and turn rate ``w`` (rad/s)."""

    x: float
    y: float
    theta: float
    v: float = 0.0
    w: float = 0.0

    @property
    def pose(self) -> Pose:
        return Pose(self.x, self.y, self.theta)


def limit(current: float, command: float, accel: float, top: float, bottom: float,
          dt: float) -> float:
    """The speed reached from ``current`` toward ``command`` in ``dt``: the change capped by
    ``accel``, then the result kept within ``[bottom, top]``."""
    change = max(-accel * dt, min(accel * dt, command - current))
    return max(bottom, min(top, current + change))


def step(state: RobotState, command: tuple[float, float], spec: RobotSpec, dt: float,
         segments: np.ndarray, discs: np.ndarray) -> tuple[RobotState, bool]:
    """Advance ``state`` by ``dt`` seconds under ``command = (v, w)``.

    Returns the new state and whether a collision cut the move short; a blocked state has
    ``v = w = 0`` and sits at the contact point, a hair (``geometry.GAP``) short of touching,
    with the step's turn applied. The flag is True on every step that pushes into an
    obstacle, so a caller counting contacts counts the steps where it turns True.
    """
    if not dt > 0.0:
        raise ValueError(f"a time step must be > 0 seconds, not {dt!r}")
    v_cmd, w_cmd = command
    v = limit(state.v, float(v_cmd), spec.max_accel, spec.max_speed, -spec.max_reverse, dt)
    w = limit(state.w, float(w_cmd), spec.max_turn_accel, spec.max_turn_rate,
              -spec.max_turn_rate, dt)
    x, y, theta, blocked = advance(state.x, state.y, state.theta, v, w, dt, spec.radius,
                                   segments, discs)
    if blocked:
        return RobotState(x, y, theta, 0.0, 0.0), True
    return RobotState(x, y, theta, v, w), False
