"""The robot's own map of linear obstacles between landmarks, learned from what it senses.

002 section 2: the navigation system keeps a map of the landmarks it has seen and of the linear
obstacles between them, which it "identifies when the robot bumps against them". An
:class:`ObstacleMap` is that map. It places each landmark the camera has seen, in the frame of
the odometry, at the mean of its sightings weighted by their precision; it takes every pair of
known landmarks as a hypothesis (a linear obstacle along the segment between them) and keeps,
stretch by stretch along the segment, what the sonar ring and the bumper said about it (the
rule is :mod:`cbr_world2d.obstacle_evidence`'s). The robot perceives an obstacle between two
landmarks when the stretches the evidence holds occupied outnumber those it holds free by at
least ``coverage`` of the stretches: it must have sensed the obstacle along a good part of its
length, not at one point where something else crosses the line.

Evidence does not fade with time; a stretch's score is turned only by newer votes against it,
so a robot that never comes back keeps what it learned, and one that senses a gap where it
believed an obstacle forgets it. The map is kept by whoever holds it (the ``trials`` workload
keeps one for the whole run, across its trials); a world's ``between`` declarations never
enter it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import attrs
import numpy as np

from cbrcore.options import option

if TYPE_CHECKING:
    from cbr_world2d.sensors import Observation, Sighting, SonarRing

BINS = 16
"""Stretches each hypothetical obstacle's interior is cut into."""

OPEN_SHARE = 0.75
"""The share of a pair's stretches that must be free, none occupied, for the way between its
landmarks to be seen open: in 002's scenario 2 a robot that passes the V's apex gets free votes
on half the stretches of the V's arm beside it (the map places the arm a little off), and a
room's door seen from inside and out gets them on 15 of 16."""

SCAN_STEP = 0.1
"""Metres the robot must have moved since the last scan the map took before it takes another
(or turned :data:`SCAN_TURN`, or bumped): consecutive readings of a slow robot say the same."""

SCAN_TURN = math.radians(10.0)
"""Radians the robot must have turned since the last scan the map took before it takes
another."""

_POSITIVE = attrs.validators.gt(0.0)


@attrs.frozen
class PerceptionOptions:
    """How the robot learns linear obstacles between landmarks from its sonar and bumper."""

    near: float = option(
        0.2, "How well, in metres, a reading must agree with what an obstacle between two "
        "landmarks would give (and how near a bump or a third landmark must lie to it).",
        validator=_POSITIVE)
    margin: float = option(
        0.35, "Metres left out at each end of the segment between two landmarks, where the "
        "landmarks' own discs answer the sonar.", validator=attrs.validators.ge(0.0))
    coverage: float = option(
        0.5, "The share of the segment that must be sensed occupied (less what was sensed "
        "free) for the robot to perceive an obstacle there.",
        validator=attrs.validators.and_(_POSITIVE, attrs.validators.le(1.0)))
    longest: float = option(
        8.0, "The longest linear obstacle between two landmarks, in metres; farther pairs are "
        "never joined.", validator=_POSITIVE)
    reach: float = option(
        3.0, "The farthest sonar reading, in metres, taken as a sign of an obstacle (farther, "
        "a beam's cone is too wide to say where the return came from; it still shows what is "
        "free).", validator=_POSITIVE)


class ObstacleMap:
    """The linear obstacles between landmarks a robot with ``sonar`` (its ring, mounted on its
    rim) has perceived, by ``options``' rule. Feed it every observation (:meth:`sense`); ask it
    which pairs of landmarks it knows an obstacle between (:meth:`between`)."""

    def __init__(self, options: PerceptionOptions, sonar: SonarRing) -> None:
        # the kernels load numba: imported when a map is made, not with the workload's options
        from cbr_world2d import obstacle_evidence

        self.options = options
        self.sonar = sonar
        self._kernels = obstacle_evidence
        self._index: dict[str, int] = {}
        self._ids: list[str] = []
        self._sums = np.zeros((8, 2))
        self._weights = np.zeros(8)
        self.places = np.zeros((8, 2))
        self.scores = np.zeros((8, 8, BINS), dtype=np.int8)
        self._last: tuple[float, float, float] | None = None
        self._directions = np.asarray(sonar.directions, dtype=float)
        self._half = 0.5 * sonar.beam_width if sonar.rays_per_beam > 1 else 0.0

    @property
    def landmarks(self) -> tuple[str, ...]:
        """The landmarks seen so far, in the order they were first seen."""
        return tuple(self._ids)

    def place(self, id: str) -> tuple[float, float] | None:
        """Where the robot believes landmark ``id`` is (None: never seen)."""
        k = self._index.get(id)
        return None if k is None else (float(self.places[k, 0]), float(self.places[k, 1]))

    def _grow(self) -> None:
        size = 2 * self.places.shape[0]
        n = self.places.shape[0]
        sums, weights, places = np.zeros((size, 2)), np.zeros(size), np.zeros((size, 2))
        scores = np.zeros((size, size, BINS), dtype=np.int8)
        sums[:n], weights[:n], places[:n], scores[:n, :n] = (
            self._sums, self._weights, self.places, self.scores)
        self._sums, self._weights, self.places, self.scores = sums, weights, places, scores

    def sense(self, obs: Observation) -> None:
        """Take what ``obs`` saw into the map: once the robot has moved :data:`SCAN_STEP` or
        turned :data:`SCAN_TURN` since the last scan taken (or bumped), its sightings refine
        the landmarks' places and its sonar and bump the evidence on every pair in reach."""
        pose = obs.pose
        if self._last is not None and not obs.bumped:
            lx, ly, lt = self._last
            turned = abs(math.remainder(pose.theta - lt, math.tau))
            if math.hypot(pose.x - lx, pose.y - ly) < SCAN_STEP and turned < SCAN_TURN:
                return
        self._last = (pose.x, pose.y, pose.theta)
        if obs.sightings:
            self._see(obs.sightings, pose.x, pose.y, pose.theta)
        count = len(self._ids)
        if count < 2:
            return
        o = self.options
        bearing = obs.bump_bearing if obs.bumped else math.nan
        self._kernels.record_scan(
            pose.x, pose.y, pose.theta, self._directions, self._half, self.sonar.max_range,
            self.sonar.mount_radius, np.asarray(obs.sonar, dtype=float), bearing, self.places,
            count, self.scores, o.near, o.margin, o.longest, o.reach)

    def _see(self, sightings: Sequence[Sighting], x: float, y: float, theta: float) -> None:
        rows = []
        for sighting in sightings:
            k = self._index.get(sighting.id)
            if k is None:
                k = len(self._ids)
                if k == self.places.shape[0]:
                    self._grow()
                self._index[sighting.id] = k
                self._ids.append(sighting.id)
            rows.append(k)
        from cbr_world2d.sensors import sighted_points

        local, spread = sighted_points(sightings)
        # each place weighted by the inverse square of how far off it may be
        weight = 1.0 / np.maximum(spread, 1e-3) ** 2
        c, s = math.cos(theta), math.sin(theta)
        world = np.column_stack((x + c * local[:, 0] - s * local[:, 1],
                                 y + s * local[:, 0] + c * local[:, 1]))
        # a landmark is sighted once per observation, so the rows are distinct
        self._sums[rows] += weight[:, None] * world
        self._weights[rows] += weight
        self.places[rows] = self._sums[rows] / self._weights[rows, None]

    def evidence(self, first: str, second: str) -> tuple[int, int]:
        """How many of the stretches between two landmarks the evidence holds occupied and how
        many free (0, 0 when either landmark was never seen)."""
        i, j = self._index.get(first), self._index.get(second)
        if i is None or j is None or i == j:
            return 0, 0
        row = self.scores[min(i, j), max(i, j)]
        return int(np.count_nonzero(row > 0)), int(np.count_nonzero(row < 0))

    def perceives(self, first: str, second: str) -> bool:
        """Whether the robot perceives a linear obstacle between two landmarks."""
        i, j = self._index.get(first), self._index.get(second)
        if i is None or j is None or i == j:
            return False
        o = self.options
        if not self._kernels.is_candidate(self.places, len(self._ids), min(i, j), max(i, j),
                                          o.near, o.margin, o.longest):
            return False
        hits, frees = self.evidence(first, second)
        return hits - frees >= o.coverage * BINS - 1e-9

    def sees_open(self, first: str, second: str) -> bool:
        """Whether the robot has seen the way between two landmarks open: the evidence holds
        no stretch occupied and at least :data:`OPEN_SHARE` of them free. Not the mirror of
        :meth:`perceives`: a free vote needs no more than a reading past where the map places
        a stretch, and a wall whose landmarks the map places some way off gets such votes on
        the stretches it misses; a wall is nowhere along an open way."""
        hits, frees = self.evidence(first, second)
        return hits == 0 and frees >= OPEN_SHARE * BINS

    def open_between(self, ids: Sequence[str]) -> tuple[tuple[str, str], ...]:
        """The pairs of the landmarks ``ids`` the robot has seen open between, in the order of
        ``ids``."""
        known = [id for id in ids if id in self._index]
        return tuple((a, b) for k, a in enumerate(known) for b in known[k + 1:]
                     if self.sees_open(a, b))

    def between(self, ids: Sequence[str]) -> tuple[tuple[str, str], ...]:
        """The perceived obstacles joining two of the landmarks ``ids``, as pairs of ids in the
        order of ``ids``."""
        known = [id for id in ids if id in self._index]
        return tuple((a, b) for k, a in enumerate(known) for b in known[k + 1:]
                     if self.perceives(a, b))

    def perceived(self) -> tuple[tuple[str, str], ...]:
        """Every perceived obstacle, as pairs of ids in the order the landmarks were first
        seen."""
        return self.between(self._ids)

    def walls(self) -> tuple[tuple[tuple[float, float], tuple[float, float]], ...]:
        """Every perceived obstacle as the segment between the places the robot believes its
        two landmarks at, in the order of :meth:`perceived`."""
        def at(id: str) -> tuple[float, float]:
            x, y = self.places[self._index[id]]
            return float(x), float(y)

        return tuple((at(a), at(b)) for a, b in self.perceived())
