"""The potential-field pilot of 002 section 2: attraction to the target, repulsion from what the
sonar senses.

Each step the pilot sums two kinds of force on the robot, in the world frame:

* **attraction**: a vector of constant magnitude ``attraction`` pointing at the target. A
  constant pull (rather than one growing with distance) keeps the balance with the obstacles
  the same wherever the target is, so a trap is a trap whether the target is 2 m or 20 m away.
* **repulsion**: for every sonar reading ``d`` (measured from the robot's rim) closer than the
  influence distance ``d0``, Khatib's term ``repulsion * (1/d - 1/d0) / d**2`` along the beam,
  pointing away from the echo. Readings below ``min_range`` count as ``min_range`` so that the
  force stays finite when the robot touches something. A bump counts as one more reading of
  ``min_range`` at the contact's bearing: a thin obstacle that falls between the sonar's rays
  (a wall's end pointing straight at the robot) still pushes once the robot touches it, as
  002's robot learns of obstacles by bumping into them.

The resulting force's direction is the heading the pilot wants; the heading error ``e`` sets the
turn rate ``w = clip(turn_gain * e, +-max_turn_rate)`` and the speed is
``max_speed * max(cos e, 0) * min(1, front / slow_distance) * min(1, distance / approach)``,
where ``front`` is the nearest reading in the front half (beams within 90 degrees of the
heading): the robot turns on the spot when the force points sideways or behind, slows down as
something comes close in front, and as it nears the target.

The pilot is deliberately the classic method with nothing added to escape local minima: where
the repulsion of a U-shaped obstacle balances the pull toward a target behind it, the force
flips from side to side and the robot stays there until the trial times out (002 section 4,
scenario 2). Getting out is the Rescuer's and the CBR agent's job, not the pilot's.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import attrs
import numpy as np

from cbr_world2d.pilots.base import Command, Point
from cbrcore.options import option

if TYPE_CHECKING:
    from cbr_world2d.sensors import Observation

_POSITIVE = attrs.validators.gt(0.0)
_NON_NEGATIVE = attrs.validators.ge(0.0)


@attrs.frozen
class PotentialFieldOptions:
    """The options of the ``potential_field`` pilot (lengths in metres, angles in radians)."""

    max_speed: float = option(
        0.4, "The forward speed in m/s with the way clear and the target ahead; the robot's "
        "own limit caps it (0.4 m/s is an indoor cruising speed for a Pioneer 2 DX, well under "
        "its top speed).", validator=_POSITIVE)
    max_turn_rate: float = option(
        1.0, "The largest turn rate the pilot asks for, in rad/s.", validator=_POSITIVE)
    turn_gain: float = option(
        1.5, "Turn rate per radian of heading error, in 1/s.", validator=_POSITIVE)
    attraction: float = option(
        1.0, "The magnitude of the pull toward the target (a unit vector times this).",
        validator=_POSITIVE)
    repulsion: float = option(
        0.05, "Khatib's gain k: a reading d closer than the influence distance d0 pushes with "
        "k * (1/d - 1/d0) / d**2 (0.05 balances the default pull at about 0.32 m from a "
        "single echo).", validator=_NON_NEGATIVE)
    influence: float = option(
        1.0, "d0: readings farther than this (in metres from the robot's rim) do not push.",
        validator=_POSITIVE)
    min_range: float = option(
        0.02, "Readings below this count as this, so that the push stays finite on contact.",
        validator=_POSITIVE)
    slow_distance: float = option(
        1.0, "The speed scales with the nearest reading in the front half divided by this "
        "(up to 1): the robot slows as something comes close ahead.", validator=_POSITIVE)
    approach: float = option(
        0.5, "Within this distance of the target the speed scales down in proportion.",
        validator=_POSITIVE)


class PotentialField:
    """The potential-field pilot (see the module docstring); it keeps no state between steps."""

    def __init__(self, options: PotentialFieldOptions | None = None) -> None:
        # numba loads with a pilot built to drive, not with the registration at every start
        # of cbr; bound here so that a step looks up no module
        from cbr_world2d.pilots.kernels import field_command, field_force

        self.options = options if options is not None else PotentialFieldOptions()
        self._force = field_force
        self._command = field_command

    def force(self, obs: Observation, target: Point) -> tuple[float, float]:
        """The total force ``(fx, fy)`` in the world frame for this observation."""
        o, pose = self.options, obs.pose
        ranges, angles = self._readings(obs)
        return self._force(pose.x, pose.y, pose.theta, float(target[0]), float(target[1]),
                           ranges, angles, o.attraction, o.repulsion, o.influence, o.min_range)

    def command(self, obs: Observation, target: Point) -> Command:
        o, pose = self.options, obs.pose
        ranges, angles = self._readings(obs)
        return self._command(pose.x, pose.y, pose.theta, float(target[0]), float(target[1]),
                             ranges, angles, o.attraction,
                             o.repulsion, o.influence, o.min_range, o.turn_gain,
                             o.max_turn_rate, o.max_speed, o.slow_distance, o.approach)

    def _readings(self, obs: Observation) -> tuple[np.ndarray, np.ndarray]:
        """The sonar's ranges and bearings, with a bump as one more reading at contact."""
        ranges, angles = _floats(obs.sonar), _floats(obs.sonar_angles)
        if obs.bumped and math.isfinite(obs.bump_bearing):
            ranges = np.append(ranges, self.options.min_range)
            angles = np.append(angles, obs.bump_bearing)
        return ranges, angles

    def reset(self) -> None:
        """Nothing to forget: the field depends on the current observation alone."""


def _floats(values: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(values, dtype=np.float64)
