"""A short-term memory of landmarks: what the camera saw a moment ago stays in the situation.

002's Vision agent identifies the landmarks "in the view field of the cameras" and recognises
those it identified before; the robot's view of the landmarks is not limited to one camera
frame. A camera narrower than the layout it faces (or one that pans, see
:class:`~cbr_world2d.sensors.Camera`) never shows every landmark of the layout at once; the
memory keeps each landmark's last sighting for ``seconds`` and carries it into the robot's
current frame by odometry, so a situation holds the landmarks seen within that time.

**The rule.** A landmark the camera sees now is given by its current sighting. A landmark last
seen ``age`` seconds ago (``0 < age <= seconds``), after which the robot drove ``driven`` metres
by its odometry, is placed where it was seen (the peaks of its distance and bearing, in the
odometry's frame of that time) and given the distance and bearing of that place from the robot's
current odometry pose (the peaks). Its uncertainty grows by

    w = per_metre * driven + per_second * age

metres: the distance triangle's half-width is the wider side of the one seen plus ``w``, and the
bearing triangle's half-width is the angle that the arc of the one seen (its wider side times
the distance seen) plus ``w`` spans at the current distance (at most pi). A landmark unseen for
longer than ``seconds`` is dropped. With no motion and no time the remembered sighting is the
one seen (its triangles made symmetric).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import attrs

from cbr_world2d.fuzzy import unchecked, wrap_angle
from cbrcore.options import option

if TYPE_CHECKING:
    from cbr_world2d.robot import Pose
    from cbr_world2d.sensors import Observation, Sighting

_NON_NEGATIVE = attrs.validators.ge(0.0)


@attrs.frozen
class MemoryOptions:
    """How long the robot remembers the landmarks it saw, and how fast their places blur."""

    seconds: float = option(
        0.0, "How long, in seconds, a landmark out of view stays in the situation's sightings, "
        "carried by odometry into the robot's current frame (0: no memory, the camera's "
        "current view only).", validator=attrs.validators.and_(_NON_NEGATIVE,
                                                               attrs.validators.le(3600.0)))
    per_metre: float = option(
        0.05, "How much a remembered landmark's place blurs, in metres per metre driven since "
        "it was seen (added to both sides of its distance, and its arc across).",
        validator=attrs.validators.and_(_NON_NEGATIVE, attrs.validators.le(10.0)))
    per_second: float = option(
        0.01, "How much a remembered landmark's place blurs, in metres per second since it "
        "was seen.", validator=attrs.validators.and_(_NON_NEGATIVE, attrs.validators.le(10.0)))


@attrs.frozen
class _Seen:
    sighting: Sighting
    x: float  # the place at the peaks, in the odometry's frame of that time
    y: float
    distance_half: float
    arc_half: float
    t: float
    driven: float


class LandmarkMemory:
    """The landmarks of one trial seen within the last ``options.seconds``.

    :meth:`update` with every observation, in order; :meth:`sightings` gives the camera's
    current sightings followed by the remembered ones (see the module docstring).
    """

    def __init__(self, options: MemoryOptions) -> None:
        self.options = options
        self._seen: dict[str, _Seen] = {}
        self._driven = 0.0
        self._pose: Pose | None = None

    @property
    def driven(self) -> float:
        """Metres driven by the odometry since the first observation."""
        return self._driven

    def update(self, obs: Observation) -> None:
        """Take the observation ``obs``: its sightings become the latest of their landmarks."""
        pose = obs.pose
        if self._pose is not None:
            self._driven += math.hypot(pose.x - self._pose.x, pose.y - self._pose.y)
        self._pose = pose
        for s in obs.sightings:
            d, b = s.distance.peak, s.bearing.peak
            heading = pose.theta + b
            self._seen[s.id] = _Seen(
                s, pose.x + d * math.cos(heading), pose.y + d * math.sin(heading),
                max(d - s.distance.low, s.distance.high - d),
                d * min(max(b - s.bearing.low, s.bearing.high - b), math.pi),
                obs.t, self._driven)
        horizon = obs.t - self.options.seconds - 1e-9
        for gone in [i for i, seen in self._seen.items() if seen.t < horizon]:
            del self._seen[gone]

    def sightings(self, obs: Observation) -> tuple[tuple[Sighting, ...], tuple[str, ...]]:
        """The sightings of the situation at ``obs`` (the last observation :meth:`update`
        took): those of the camera now, then the remembered ones; and the remembered ids."""
        now = {s.id for s in obs.sightings}
        remembered = [self._carried(seen, obs) for i, seen in self._seen.items()
                      if i not in now and obs.t - seen.t <= self.options.seconds + 1e-9]
        return (tuple(obs.sightings) + tuple(remembered),
                tuple(s.id for s in remembered))

    def _carried(self, seen: _Seen, obs: Observation) -> Sighting:
        from cbr_world2d.sensors import Sighting

        pose = obs.pose
        dx, dy = seen.x - pose.x, seen.y - pose.y
        d = math.hypot(dx, dy)
        b = wrap_angle(math.atan2(dy, dx) - pose.theta)
        o = self.options
        w = o.per_metre * (self._driven - seen.driven) + o.per_second * (obs.t - seen.t)
        distance_half = seen.distance_half + w
        bearing_half = math.pi if d <= 0.0 else min((seen.arc_half + w) / d, math.pi)
        return Sighting(seen.sighting.id,
                        unchecked(max(d - distance_half, 0.0), d, d + distance_half),
                        unchecked(b - bearing_half, b, b + bearing_half))
