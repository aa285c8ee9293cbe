"""What the CBR agent can tell a robot in the 2D world, and how each action ends.

A proposal's ``solution.value`` in the 2D world is an :class:`Action`. The trials workload
starts it on the running simulation and watches it each step until it ends; the decision that
proposed it is learned then, with an :class:`ActionReport` as the outcome's report. A family
adds an action by writing a class with ``start`` and ``ended``; the workload needs no change.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

import attrs

if TYPE_CHECKING:
    from cbr_world2d.simulation import Simulation

REACHED = "reached"
"""The action did what it was for (a diverting target reached)."""
GIVEN_UP = "given_up"
"""The navigation system gave the action up (a diverting target not reached in time)."""
TRIAL_ENDED = "trial_ended"
"""The trial ended (target reached or timeout) while the action was under way."""


@runtime_checkable
class Action(Protocol):
    """An action of the CBR agent carried out by the running simulation."""

    def start(self, simulation: Simulation) -> None:
        """Begin the action on ``simulation`` (set a diverting target, install behaviors)."""
        ...

    def ended(self, simulation: Simulation) -> str | None:
        """After each step: why the action ended (:data:`REACHED`, :data:`GIVEN_UP`), or None
        while it is under way."""
        ...


@attrs.frozen
class GiveUp:
    """When a diverting target is given up: ``slack`` times the time a way of ``metres`` takes
    at the robot's top speed, plus ``margin`` seconds (the pilot swerves, turns, slows)."""

    metres: float = attrs.field(validator=attrs.validators.ge(0.0))
    slack: float = attrs.field(validator=attrs.validators.gt(0.0))
    margin: float = attrs.field(validator=attrs.validators.ge(0.0))

    def seconds(self, speed: float) -> float:
        """The give-up time, in seconds, of a robot whose top speed is ``speed`` m/s."""
        return self.margin + self.slack * self.metres / speed


@attrs.define
class _Legs:
    """Where a diversion under way is: the points still to reach, and when it is given up."""

    points: list[tuple[float, float]] = attrs.field(factory=list)
    deadline: float | None = None


@attrs.frozen
class Divert:
    """Ask the Rescuer to lead the robot to ``(x, y)`` before it heads for its target again
    (002 section 3.3), through the waypoints ``via`` first (each a diverting target in turn:
    the pilot heads straight for its target, so a way round walls is followed point by point);
    it ends when the Rescuer restores the original target after the last point. It is given
    up after ``give_up`` for the whole way (None: the Rescuer's fixed ``give_up`` seconds for
    each point), and as soon as the progress monitor reports the robot blocked on the way
    (it got no closer to the point it heads for and hardly moved for a whole window since
    that point was set): the way is not what whoever proposed it believed, and waiting out
    the give-up time there is time lost."""

    x: float
    y: float
    give_up: GiveUp | None = None
    via: tuple[tuple[float, float], ...] = attrs.field(default=(), converter=tuple)
    _legs: _Legs = attrs.field(factory=_Legs, init=False, eq=False, repr=False)

    def __str__(self) -> str:
        via = f" via {len(self.via)} waypoints" if self.via else ""
        return f"divert to ({self.x:.2f}, {self.y:.2f}){via}"

    def start(self, simulation: Simulation) -> None:
        self._legs.points = [*self.via, (self.x, self.y)]
        self._legs.deadline = (None if self.give_up is None else
                               simulation.t + self.give_up.seconds(simulation.spec.max_speed))
        self._next(simulation)

    def _next(self, simulation: Simulation) -> None:
        point = self._legs.points.pop(0)
        deadline = self._legs.deadline
        left = None if deadline is None else max(deadline - simulation.t, 0.0)
        simulation.navigator.divert(point, give_up=left)

    def ended(self, simulation: Simulation) -> str | None:
        for event in simulation.events:
            if event.name == "blocked":
                simulation.navigator.drop_diversion()
                return GIVEN_UP
            if event.name == "restored":
                if event.detail == REACHED and self._legs.points:
                    self._next(simulation)
                    return None
                return REACHED if event.detail == REACHED else GIVEN_UP
        return None


@attrs.frozen
class ActionReport:
    """How one action went: why it ended, when it started and ended (seconds into the trial),
    the distance driven and collisions meanwhile, and, when the trial ended with it, whether
    the trial reached its target (None while the trial went on)."""

    reason: str
    started: float
    ended: float
    distance: float
    collisions: int
    trial_success: bool | None = None
