"""When RUPART re-plans: the triggers of action selection (004 Figure 3, "Selecting Actions").

004: "Any number of occurrences trigger re-planning, including: a sudden change to the raw sonar
readings, objects added or removed to the global map, a new, critical message goal,
installation of a new high-level plan, an impasse, or a drop in its confidence in its location.
The passage of time or distance with no other detected changes also triggers re-planning.
Because the robot continues its current behaviors while re-planning occurs, RUPART errs on the
side of retrieving too often, rather than too seldom."

:class:`ReplanMonitor` is shown a :class:`Snapshot` of the robot's situation every step
(:meth:`ReplanMonitor.check`) and told when a retrieval happened
(:meth:`ReplanMonitor.retrieved`, with the snapshot the retrieval used). Every trigger compares
the situation with the one at the last retrieval, so a trigger that fired keeps firing until
the next retrieval. The triggers, in the order :meth:`~ReplanMonitor.check` lists them:

- ``situation``: the situation moved: some feature of :data:`WATCHED` (the way ahead, the
  free width, the person in view, the doorway ahead) differs from its value at the last
  retrieval by more than ``change``, and has for ``settle`` seconds (004's "sudden change to
  the raw sonar readings", read as a change of what the readings mean: one walker passing
  changes every raw range, a sonar flicker none of these);
- ``person``: a person came into the way: within ``near`` metres (rim to rim) and
  ``ahead`` degrees of the heading, when none was at the last retrieval; a case chosen for a
  clear way is not kept driving at its speed into someone for the rest of its hold. It is
  critical once per ``hold``: people stepping in and out of the way in a crowd would
  otherwise retrieve every few seconds;
- ``map``: a snapshot since the last retrieval reported object cells added to or removed from
  the global map;
- ``message``: a snapshot since the last retrieval reported a new critical message;
- ``plan``: a snapshot since the last retrieval reported a newly installed high-level plan;
- ``impasse``: the distance to the current target has not shrunk by ``progress`` metres over
  the last ``window`` seconds (measured from the last target change or the last impasse on, at
  the snapshots checked; not from the last retrieval, since other triggers may retrieve every
  second while the robot stays stuck), or the progress monitor's status turned blocked or
  oscillating since the last retrieval. Once it fired the window starts again, so a robot that
  stays stuck is told once per window;
- ``location``: the location confidence fell below ``confidence`` since the last retrieval,
  or by ``confidence_drop`` or more;
- ``period``: ``period`` seconds passed or ``distance`` metres were driven since the last
  retrieval, and no other trigger fired. Before the first retrieval the period has always
  passed.

*Hysteresis*: within ``hold`` seconds of a retrieval only the critical triggers (``person``,
unless it fired within the last ``hold``; ``message``, ``impasse``) fire; the others are
remembered until the hold has passed, so that an installed case acts for a while before it is
judged again.

The events (``map``, ``message``, ``plan``) come as what happened since the previous snapshot;
the monitor remembers them until a retrieval. A retrieval's own snapshot sets the baselines
(time, sonar, confidence, distance, status, target) and clears the remembered events; its event
fields are ignored, so an event the caller reports after consulting (a plan the retrieval
installed) reaches the next check.
"""

from __future__ import annotations

import math
from collections import deque
from typing import TYPE_CHECKING

import attrs
import numpy as np

from cbr_behaviors.index import SITUATION
from cbr_behaviors.situation import PERSON_REACH
from cbr_world2d.pilots.monitor import STUCK
from cbrcore.options import option

if TYPE_CHECKING:
    from cbr_world2d.robot import Pose
    from cbr_world2d.world import Point

TRIGGERS: tuple[str, ...] = ("situation", "person", "map", "message", "plan", "impasse",
                             "location", "period")
"""The trigger names, in the order a check lists those that fired."""
WATCHED: tuple[str, ...] = ("front", "width", "person", "person-bearing", "closing", "door",
                            "door-shut")
"""The situation features whose change fires ``situation``: those that name what a case is
chosen for. The side and rear readings change with every piece of furniture passed, and the
progress with every metre driven."""
_WATCHED = np.array([SITUATION.index(f) for f in WATCHED])
_PERSON = SITUATION.index("person")
_BEARING = SITUATION.index("person-bearing")
CRITICAL: frozenset[str] = frozenset({"person", "message", "impasse"})
"""The triggers that fire within the hold after a retrieval."""

_POSITIVE = attrs.validators.gt(0.0)
_UNIT = attrs.validators.and_(attrs.validators.ge(0.0), attrs.validators.le(1.0))


@attrs.frozen
class TriggerOptions:
    """The thresholds of the re-planning triggers (metres and seconds)."""

    change: float = option(
        0.35, "A situation feature (docs/rupart.md) differing from its value at the last "
        "retrieval by more than this fires 'situation' (features are in [0, 1]: 0.35 is a "
        "person coming into view within 3 m, or the nearest reading ahead falling from "
        "nothing in range to 3 m).", validator=_POSITIVE)
    window: float = option(
        10.0, "Seconds without progress toward the target that fire 'impasse' (the progress "
        "monitor's window).", validator=_POSITIVE)
    progress: float = option(
        0.2, "Metres the distance to the target must shrink within the window to count as "
        "progress (the progress monitor's min_progress).", validator=_POSITIVE)
    confidence: float = option(
        0.5, "'location' fires when the location confidence falls below this since the last "
        "retrieval (0.5: the odometry's error has grown to its confidence scale).",
        validator=_UNIT)
    confidence_drop: float = option(
        0.2, "... or when it fell by this much or more since the last retrieval.",
        validator=_POSITIVE)
    settle: float = option(
        1.0, "Seconds the situation must stay moved before 'situation' fires: a person "
        "flickering at the edge of view, or a reading passing a doorframe, fires nothing.",
        validator=attrs.validators.ge(0.0))
    map_cells: int = option(
        12, "'map' fires once this many evidence cells of the global map were added or removed "
        "since the last retrieval (12: a cart or two seen from a few sides; single cells come "
        "and go with the sonar's noise and the odometry's drift).",
        validator=attrs.validators.ge(1))
    near: float = option(
        1.5, "'person' fires when a person comes within this many metres (rim to rim) ahead "
        "and none was at the last retrieval.", validator=_POSITIVE)
    ahead: float = option(
        60.0, "Degrees off the heading within which a person counts as ahead for 'person'.",
        validator=attrs.validators.and_(attrs.validators.gt(0.0), attrs.validators.le(180.0)))
    hold: float = option(
        14.0, "Seconds after a retrieval during which only the critical triggers ('person', "
        "'message', 'impasse') fire: the installed case acts for a while before it is judged "
        "again (its avoid behaviors meet what comes up meanwhile).",
        validator=attrs.validators.ge(0.0))
    period: float = option(
        20.0, "Seconds since the last retrieval after which 'period' fires when nothing else "
        "does (004 errs on retrieving too often).", validator=_POSITIVE)
    distance: float = option(
        6.0, "Metres driven since the last retrieval after which 'period' fires when nothing "
        "else does (twenty seconds at 0.3 m/s).", validator=_POSITIVE)


def _ranges(value: object) -> np.ndarray:
    ranges = np.array(value, dtype=np.float64).reshape(-1)
    ranges.flags.writeable = False
    return ranges


@attrs.frozen(eq=False)
class Snapshot:
    """The robot's situation at one step, as the triggers see it.

    ``t`` seconds; ``pose`` the pose the robot believes it has; ``sonar`` its ranges (metres);
    ``confidence`` its location confidence; ``added`` and ``removed`` the object cells the
    global map gained and lost since the previous snapshot; ``critical`` the critical messages
    that arrived since then; ``plan_installed`` whether a high-level plan was installed since
    then; ``distance`` the distance driven so far (an odometer, metres); ``target`` the point
    the robot heads for (None: none); ``status`` the progress monitor's status;
    ``situation`` the values of :data:`cbr_behaviors.index.SITUATION` (None: not known);
    ``waiting`` whether the robot waits before a shut door on its route; ``busy`` whether it
    has a message to deliver (an idle robot on its way home is on no errand to be stuck on).
    """

    t: float
    pose: Pose
    sonar: np.ndarray = attrs.field(converter=_ranges)
    confidence: float = 1.0
    added: int = 0
    removed: int = 0
    critical: int = 0
    plan_installed: bool = False
    distance: float = 0.0
    target: Point | None = None
    status: str = "moving"
    situation: np.ndarray | None = None
    waiting: bool = False
    busy: bool = True


class ReplanMonitor:
    """Decides when to re-plan (see the module docstring)."""

    def __init__(self, options: TriggerOptions | None = None) -> None:
        self.options = options if options is not None else TriggerOptions()
        self._base: Snapshot | None = None
        self._events: set[str] = set()
        self._changed = 0
        self._moved: float | None = None
        self._person: float | None = None
        self._target: Point | None = None
        # (t, distance to the target) since the last target change or impasse
        self._progress: deque[tuple[float, float]] = deque()

    def _record(self, snapshot: Snapshot) -> float | None:
        """Put the distance to the target into the window (a new target starts a new one);
        the distance, None without a target."""
        target = snapshot.target
        if target != self._target:
            self._progress.clear()
            self._target = target
        if target is None:
            return None
        distance = math.hypot(target[0] - snapshot.pose.x, target[1] - snapshot.pose.y)
        self._progress.append((snapshot.t, distance))
        start = snapshot.t - self.options.window
        # the oldest sample kept is the latest one at least a window old
        while len(self._progress) >= 2 and self._progress[1][0] <= start:
            self._progress.popleft()
        return distance

    def _no_progress(self, snapshot: Snapshot) -> bool:
        """Record the distance to the target; whether it shrank by less than ``progress`` over
        a whole window ending now."""
        if snapshot.waiting or not snapshot.busy:
            self._progress.clear()
        distance = self._record(snapshot)
        if distance is None:
            return False
        t0, d0 = self._progress[0]
        # a robot at its target has no progress left to make
        return (t0 <= snapshot.t - self.options.window and distance > self.options.progress
                and d0 - distance < self.options.progress)

    def check(self, snapshot: Snapshot) -> list[str]:
        """The triggers that fire at ``snapshot``, in the order of :data:`TRIGGERS`."""
        o = self.options
        self._note_events(snapshot)
        fired = set(self._events)
        base = self._base
        if base is not None:
            fired |= self._changes(snapshot, base)
        if base is not None and snapshot.t - base.t < o.hold:
            fired &= CRITICAL
            if self._person is not None and snapshot.t - self._person < o.hold:
                fired.discard("person")
            if "person" in fired:
                self._person = snapshot.t
            return [name for name in TRIGGERS if name in fired]
        if not fired and (base is None or snapshot.t - base.t >= o.period
                          or snapshot.distance - base.distance >= o.distance):
            fired.add("period")
        return [name for name in TRIGGERS if name in fired]

    def _note_events(self, snapshot: Snapshot) -> None:
        """Remember the events since the last retrieval that ``snapshot`` reports: map
        changes, critical messages, an installed plan, no progress."""
        self._changed += snapshot.added + snapshot.removed
        if self._changed >= self.options.map_cells:
            self._events.add("map")
        if snapshot.critical:
            self._events.add("message")
        if snapshot.plan_installed:
            self._events.add("plan")
        if self._no_progress(snapshot):
            self._events.add("impasse")
            self._progress.clear()
            self._record(snapshot)

    def _changes(self, snapshot: Snapshot, base: Snapshot) -> set[str]:
        """The triggers that fire on what changed since the last retrieval ``base``: the
        situation (once it has settled), a person coming into the way, the robot getting
        stuck, the location confidence falling."""
        o = self.options
        fired: set[str] = set()
        if snapshot.sonar.shape != base.sonar.shape:
            raise ValueError(f"the sonar has {snapshot.sonar.shape[0]} ranges now and had "
                             f"{base.sonar.shape[0]} at the last retrieval")
        if (snapshot.situation is not None and base.situation is not None
                and float(np.max(np.abs(snapshot.situation[_WATCHED]
                                        - base.situation[_WATCHED]))) > o.change):
            if self._moved is None:
                self._moved = snapshot.t
            if snapshot.t - self._moved >= o.settle:
                fired.add("situation")
        else:
            self._moved = None
        if self._in_way(snapshot) and not self._in_way(base):
            fired.add("person")
        if (snapshot.status in STUCK and base.status not in STUCK
                and not snapshot.waiting and snapshot.busy):
            fired.add("impasse")
        if (snapshot.confidence < o.confidence <= base.confidence
                or base.confidence - snapshot.confidence >= o.confidence_drop):
            fired.add("location")
        return fired

    def _in_way(self, snapshot: Snapshot) -> bool:
        """Whether a person stands within ``near`` metres and ``ahead`` degrees ahead."""
        situation = snapshot.situation
        if situation is None:
            return False
        return (situation[_PERSON] * PERSON_REACH < self.options.near
                and situation[_BEARING] * 180.0 < self.options.ahead)

    def retrieved(self, snapshot: Snapshot) -> None:
        """A retrieval happened at ``snapshot``: it becomes the baseline and the events
        remembered are cleared (the impasse window goes on, with this snapshot in it)."""
        self._base = snapshot
        self._events.clear()
        self._changed = 0
        self._moved = None
        self._record(snapshot)
