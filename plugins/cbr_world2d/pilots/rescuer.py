"""The Rescuer of 002 section 2: diverting targets, and the original target restored after.

The Rescuer holds the target the robot was sent to (the *original* target) and, while it
diverts the robot, a *diverting* target; :attr:`Rescuer.current_target` is the one the pilot
heads for. A diverting target comes from outside (:meth:`Rescuer.divert`, as the CBR agent asks
in 002 section 3.3) or from the Rescuer itself (:meth:`Rescuer.rescue`, when the robot is
blocked). The original target is restored when the robot comes within ``tolerance`` of the
diverting target (``reached``) or when ``give_up`` seconds pass first (``given_up``); whoever
sets a diverting target may give it a ``give_up`` of its own (one that follows its distance).

The Rescuer's own diverting target uses the sonar alone (it knows no map). It looks at the
beams pointing at least ``min_turn`` away from the blocked heading (the bearing of the current
target, where the pilot was trying to go) and turns as little as it can: it takes the open beam
nearest the blocked heading, open meaning that its reading leaves room for a diverting target
the full ``distance`` away with ``clearance`` to spare; ties go to the lower beam index. When no
beam is open it takes the longest reading instead. The diverting target lies along the chosen
beam at ``min(reading - clearance, distance)`` from the robot's centre (readings start at the
rim, so the target stays ``clearance`` plus the robot's radius short of the echo). When that is
not farther than ``tolerance``, there is no way out worth taking and nothing is diverted.

Like a wall follower's turn at a wall's end, this gets a robot past a single linear obstacle
(002 scenario 1, where the navigation system without CBR reaches the target); inside a dead end
the only open beams point back out of its mouth, and once the original target is restored the
pilot drives straight back in (002 scenario 2, where only the CBR agent's diverting target
helps).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import attrs
import numpy as np

from cbr_world2d.pilots.base import Point, wrap_angle
from cbrcore.options import option

if TYPE_CHECKING:
    from cbr_world2d.sensors import Observation

REACHED = "reached"
"""Why a diverting target ended: the robot reached it."""
GIVEN_UP = "given_up"
"""Why a diverting target ended: ``give_up`` seconds passed first."""

_POSITIVE = attrs.validators.gt(0.0)


@attrs.frozen
class RescuerOptions:
    """How the Rescuer diverts (metres, seconds, radians)."""

    tolerance: float = option(
        0.3, "A diverting target is reached within this distance (the trials' default "
        "tolerance for the final target).", validator=_POSITIVE)
    give_up: float = option(
        120.0, "Seconds after which an unreached diverting target is given up (002's robot "
        "drives 6 m in 120 s at its 5 cm/s, more than any diverting target of its scenarios "
        "is away).", validator=_POSITIVE)
    distance: float = option(
        1.5, "How far from the robot its own diverting target lies at most.",
        validator=_POSITIVE)
    clearance: float = option(
        0.4, "How far short of the echo along the chosen beam the diverting target stays.",
        validator=attrs.validators.ge(0.0))
    min_turn: float = option(
        math.pi / 3, "The chosen beam points at least this far (radians) from the blocked "
        "heading.", validator=attrs.validators.and_(attrs.validators.ge(0.0),
                                                    attrs.validators.le(math.pi)))


@attrs.frozen
class Restored:
    """The original target came back: why (:data:`REACHED` or :data:`GIVEN_UP`) and when."""

    reason: str
    t: float
    diverting: Point


class Rescuer:
    """Holds the original target and, for a while, a diverting one."""

    def __init__(self, options: RescuerOptions | None = None,
                 target: Point | None = None) -> None:
        self.options = options if options is not None else RescuerOptions()
        self.target: Point | None = target
        self.diverting_target: Point | None = None
        self.diverted_at = 0.0
        self.give_up = self.options.give_up
        """Seconds after which the current diverting target is given up."""

    @property
    def diverting(self) -> bool:
        """Whether a diverting target is set."""
        return self.diverting_target is not None

    @property
    def current_target(self) -> Point:
        """The target to head for: the diverting one while set, else the original."""
        if self.diverting_target is not None:
            return self.diverting_target
        if self.target is None:
            raise ValueError("the Rescuer has no target; set one with set_target")
        return self.target

    def set_target(self, target: Point) -> None:
        """A new original target; any diverting target is dropped."""
        self.target = (float(target[0]), float(target[1]))
        self.diverting_target = None

    def divert(self, point: Point, t: float, give_up: float | None = None) -> None:
        """Head for ``point`` from time ``t`` until it is reached or given up, after
        ``give_up`` seconds (None: the options' ``give_up``)."""
        self.diverting_target = (float(point[0]), float(point[1]))
        self.diverted_at = t
        self.give_up = self.options.give_up if give_up is None else float(give_up)

    def drop(self) -> None:
        """Drop the diverting target, if any: the original target is the one to head for."""
        self.diverting_target = None

    def update(self, x: float, y: float, t: float) -> Restored | None:
        """Check the diverting target against the pose ``(x, y)`` at time ``t``; when it is
        reached or given up, restore the original target and say so."""
        point = self.diverting_target
        if point is None:
            return None
        o = self.options
        if math.hypot(point[0] - x, point[1] - y) <= o.tolerance:
            reason = REACHED
        elif t - self.diverted_at >= self.give_up:
            reason = GIVEN_UP
        else:
            return None
        self.diverting_target = None
        return Restored(reason, t, point)

    def escape(self, obs: Observation) -> Point | None:
        """The diverting target the sonar suggests (see the module docstring), or None."""
        o, pose = self.options, obs.pose
        target = self.current_target
        blocked = math.atan2(target[1] - pose.y, target[0] - pose.x)
        ranges = np.asarray(obs.sonar, dtype=float)
        directions = pose.theta + np.asarray(obs.sonar_angles, dtype=float)
        away = np.abs((directions - blocked + math.pi) % (2.0 * math.pi) - math.pi)
        candidates = np.flatnonzero(away >= o.min_turn - 1e-9)
        if candidates.size == 0:
            return None
        open_ = candidates[ranges[candidates] >= o.distance + o.clearance]
        if open_.size:
            # argmin keeps the first of equal angles: the lower beam index
            best = open_[np.argmin(away[open_])]
        else:
            best = candidates[np.argmax(ranges[candidates])]
        reach = min(float(ranges[best]) - o.clearance, o.distance)
        if reach <= o.tolerance:
            return None
        angle = wrap_angle(float(directions[best]))
        return pose.x + reach * math.cos(angle), pose.y + reach * math.sin(angle)

    def rescue(self, obs: Observation) -> Point | None:
        """Divert to the sonar's way out (:meth:`escape`) unless already diverting; the point
        diverted to, or None."""
        if self.diverting:
            return None
        point = self.escape(obs)
        if point is not None:
            self.divert(point, obs.t)
        return point
