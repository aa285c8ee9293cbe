"""The navigation subsystem of 002 section 2, reduced to what local navigation needs: a pilot,
a progress monitor and the Rescuer.

:class:`Navigator` heads the pilot for the Rescuer's current target (the original target, or a
diverting one for a while), watches progress with a :class:`ProgressMonitor`, and reports what
happened as :class:`Event` objects, the events of one step:

* ``blocked`` / ``oscillating``: the monitor's status turned from moving to that, or the robot
  has stayed stuck (blocked or oscillating, either) for another whole window since the last
  such event, so that a listener that did nothing the first time hears it again, but not at
  every flip between the two;
* ``diverted``: a diverting target was set (``point``), by :meth:`Navigator.divert` or by the
  Rescuer itself; ``detail`` says who (``"asked"`` or ``"rescuer"``);
* ``restored``: the original target is back (``point``); ``detail`` is ``"reached"`` when the
  diverting target was reached, ``"given_up"`` when its time ran out.

Everything uses the pose the robot believes it has (the observation's odometry estimate), as a
robot would. Whether the Rescuer diverts on its own is ``rescue``: ``"off"`` (the default: only
:meth:`Navigator.divert` diverts, so the pilot alone drives unless someone, the CBR agent or the
engine's ``rescuer`` solver in the trials workload, asks), ``"blocked"`` (002's navigation
system without CBR: the Rescuer recovers the robot from blocked situations, which gets it past a
single linear obstacle, 002's scenario 1, but not out of a dead end, scenario 2) or ``"stuck"``
(blocked or oscillating). It acts when the monitor reports, and never while a diverting target
is already set. The monitor starts afresh whenever the target changes, since its progress is
measured toward the target; :meth:`Navigator.retarget` changes the original target mid-run,
leaving the pilot as it is.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

import attrs

from cbr_world2d.pilots.base import Command, Pilot, Point
from cbr_world2d.pilots.monitor import MonitorOptions, ProgressMonitor, Status
from cbr_world2d.pilots.rescuer import Rescuer, RescuerOptions
from cbrcore.options import option

if TYPE_CHECKING:
    from cbr_world2d.sensors import Observation

EventName = Literal["blocked", "oscillating", "diverted", "restored"]
Rescue = Literal["off", "blocked", "stuck"]

_RESCUED_ON: dict[str, frozenset[str]] = {
    "off": frozenset(), "blocked": frozenset({"blocked"}),
    "stuck": frozenset({"blocked", "oscillating"}),
}


@attrs.frozen
class Event:
    """Something the navigator reports: its ``name``, the time ``t``, the pose ``(x, y)`` the
    robot believed it had, ``point`` (the target concerned) and ``detail`` (see the module
    docstring)."""

    name: EventName
    t: float
    x: float
    y: float
    point: Point | None = None
    detail: str = ""


@attrs.frozen
class NavigatorOptions:
    """The navigation subsystem's options: the monitor's, the Rescuer's, and when the Rescuer
    diverts on its own."""

    rescue: Rescue = option(
        "off", "When the Rescuer diverts on its own: 'off' (only when asked: the pilot alone), "
        "'blocked' (002's navigation system without CBR) or 'stuck' (blocked or "
        "oscillating).")
    monitor: MonitorOptions = option(factory=MonitorOptions, doc="The progress monitor.")
    rescuer: RescuerOptions = option(factory=RescuerOptions, doc="The Rescuer.")


class Navigator:
    """A pilot, a progress monitor and the Rescuer driving the robot to a target."""

    def __init__(self, pilot: Pilot, options: NavigatorOptions | None = None,
                 target: Point | None = None) -> None:
        self.options = options if options is not None else NavigatorOptions()
        self.pilot = pilot
        self.monitor = ProgressMonitor(self.options.monitor)
        self.rescuer = Rescuer(self.options.rescuer)
        self.events: tuple[Event, ...] = ()
        """The events of the last :meth:`command`, those of :meth:`divert` calls made since the
        step before included."""
        self._pending: list[Event] = []
        self._repeat_at = 0.0
        self._last = (0.0, 0.0, 0.0)
        if target is not None:
            self.start(target)

    @property
    def target(self) -> Point:
        """The original target."""
        if self.rescuer.target is None:
            raise ValueError("the navigator has no target; call start(target) first")
        return self.rescuer.target

    @property
    def current_target(self) -> Point:
        """The target the pilot heads for now."""
        return self.rescuer.current_target

    @property
    def diverting(self) -> bool:
        """Whether the Rescuer holds a diverting target."""
        return self.rescuer.diverting

    @property
    def status(self) -> Status:
        """The monitor's status at the last step."""
        return self.monitor.status

    def start(self, target: Point) -> None:
        """Begin a trial toward ``target``: pilot, monitor and Rescuer start afresh."""
        self.rescuer.set_target(target)
        self.pilot.reset()
        self.monitor.reset()
        self.events = ()
        self._pending.clear()
        self._repeat_at = 0.0
        self._last = (0.0, 0.0, 0.0)

    def retarget(self, target: Point) -> None:
        """Send the robot to a new original ``target`` mid-run (a delivery robot's goal
        changes): any diverting target is dropped and the monitor starts afresh, since its
        progress is measured toward the target, but the pilot keeps what it has latched (a
        heading, a wall it follows), unlike :meth:`start`."""
        self.rescuer.set_target(target)
        self.monitor.reset()

    def divert(self, point: Point, t: float | None = None, give_up: float | None = None
               ) -> None:
        """Head for ``point`` until it is reached or given up (002: the CBR agent asks the
        Rescuer), after ``give_up`` seconds (None: the Rescuer's option); ``t`` defaults to
        the time of the last step."""
        when, x, y = self._last
        self._divert(point, when if t is None else t, x, y, "asked", give_up)

    def drop_diversion(self) -> None:
        """Give the diverting target up at once (whoever set it judged the way lost): head
        for the original target again, the monitor afresh."""
        self.rescuer.drop()
        self.monitor.reset()

    def _divert(self, point: Point, t: float, x: float, y: float, who: str,
                give_up: float | None = None) -> None:
        self.rescuer.divert(point, t, give_up)
        self.monitor.reset()
        self._pending.append(Event("diverted", t, x, y, self.rescuer.current_target, who))

    def command(self, obs: Observation) -> Command:
        """The pilot's command toward the current target for this observation; sets
        :attr:`events`."""
        pose, t = obs.pose, obs.t
        self._last = (t, pose.x, pose.y)
        events, self._pending = self._pending, []
        restored = self.rescuer.update(pose.x, pose.y, t)
        if restored is not None:
            self.monitor.reset()
            events.append(Event("restored", t, pose.x, pose.y, self.target, restored.reason))
        before = self.monitor.status
        status = self.monitor.update(t, pose.x, pose.y, self.current_target)
        if status != "moving" and (before == "moving" or t >= self._repeat_at):
            self._repeat_at = t + self.monitor.options.window
            name: EventName = "blocked" if status == "blocked" else "oscillating"
            events.append(Event(name, t, pose.x, pose.y, self.current_target))
            if status in _RESCUED_ON[self.options.rescue] and not self.rescuer.diverting:
                point = self.rescuer.escape(obs)
                if point is not None:
                    self._divert(point, t, pose.x, pose.y, "rescuer")
                    events.extend(self._pending)
                    self._pending.clear()
        self.events = tuple(events)
        return self.pilot.command(obs, self.current_target)
