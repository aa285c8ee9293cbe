"""When the ``trials`` workload consults the engine: the triggers of one trial.

Four triggers, looked at before each step in this order (the first that fires names the
consultation):

- ``blocked``: the progress monitor reported the robot blocked or oscillating in the last step;
- ``landmarks``: a landmark came into view. The camera's view of a landmark at the edge of its
  field or range flickers as the robot swerves, so a landmark counts as *come into view* only
  with hysteresis: it must have been in view for ``settle`` seconds without a break, and it
  stays *in view* until it has been out of view for ``absence`` seconds; returning sooner, it
  has not come into view again. The landmarks in view at a trial's start count at once (002's
  agent looks at point A);
- ``heading``: the heading has turned ``turn`` degrees or more from where it pointed at the
  last consultation (or at the start): the problem case is measured against the heading, so
  after such a turn it is another situation, and a case that did not match before may now;
- ``period``: ``period`` seconds have passed since the last consultation (or the start), so
  that a retrieval missed (the measurement noise of one step kept a case under the threshold)
  is tried again, also when no landmark comes into view.

The state updates at every step, also while the workload may not consult (an action under
way, a diverting target set): a landmark that comes into view meanwhile does not fire later,
whereas the heading and the period, measured from the last consultation, fire at the first
step the workload may consult again.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Literal

from cbr_world2d.fuzzy import wrap_angle
from cbr_world2d.pilots.monitor import STUCK

if TYPE_CHECKING:
    from cbr_world2d.sensors import Observation
    from cbr_world2d.simulation import Event

Trigger = Literal["blocked", "landmarks", "heading", "period"]

TRIGGERS: tuple[Trigger, ...] = ("blocked", "landmarks", "heading", "period")
"""Every trigger, in the order they are looked at."""


class LandmarksInView:
    """Which landmarks come into view, with hysteresis (see the module docstring).

    ``settle`` and ``absence`` are in seconds; with both 0 a landmark comes into view whenever
    it is in view and was not at the step before.
    """

    def __init__(self, settle: float, absence: float) -> None:
        self.settle = settle
        self.absence = absence
        self._run_since: dict[str, float] = {}  # in view without a break since
        self._last_seen: dict[str, float] = {}
        self._in_view: set[str] = set()
        self._started = False

    def update(self, t: float, ids: Iterable[str]) -> frozenset[str]:
        """The landmarks that come into view at time ``t``, given those the camera sees."""
        now = frozenset(ids)
        for gone in [i for i in self._run_since if i not in now]:
            del self._run_since[gone]
        for i in [i for i in self._in_view if i not in now]:
            # counted from the last step it was seen: with absence 0, one step out is enough
            if t - self._last_seen[i] >= self.absence - 1e-9:
                self._in_view.discard(i)
        come: set[str] = set()
        for i in now:
            since = self._run_since.setdefault(i, t)
            self._last_seen[i] = t
            if i not in self._in_view and (not self._started
                                           or t - since >= self.settle - 1e-9):
                self._in_view.add(i)
                come.add(i)
        self._started = True
        return frozenset(come)


class Triggers:
    """The triggers of one trial: :meth:`update` at every step, :meth:`consulted` when the
    workload consulted."""

    def __init__(self, on: Sequence[Trigger], obs: Observation, *, period: float, turn: float,
                 settle: float, absence: float) -> None:
        self.on = frozenset(on)
        self.period = period
        self.turn = math.radians(turn)
        self.landmarks = LandmarksInView(settle, absence)
        self._asked_at = obs.t
        self._asked_facing = obs.pose.theta

    def update(self, obs: Observation, events: Sequence[Event]) -> Trigger | None:
        """The trigger that fires before the step after ``obs`` (whose ``events`` are the last
        step's), or None."""
        come = self.landmarks.update(obs.t, (s.id for s in obs.sightings))
        if "blocked" in self.on and any(e.name in STUCK for e in events):
            return "blocked"
        if "landmarks" in self.on and come:
            return "landmarks"
        if ("heading" in self.on
                and abs(wrap_angle(obs.pose.theta - self._asked_facing)) >= self.turn - 1e-12):
            return "heading"
        if "period" in self.on and obs.t - self._asked_at >= self.period - 1e-9:
            return "period"
        return None

    def consulted(self, obs: Observation) -> None:
        """The workload consulted the engine on ``obs``: the heading and the period count from
        here."""
        self._asked_at = obs.t
        self._asked_facing = obs.pose.theta
