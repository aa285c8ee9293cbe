"""The behavior-merging controller of 004 (RUPART on Saphira): the behaviors known by name, a
behavior set read from plain data, the merge, and the ``behaviors`` pilot.

Behaviors are fuzzy control rules (:mod:`.primitives`): each step each proposes a turn rate and
a speed, either possibly unspecified, with a degree of fit in [0, 1]. A behavior set activates
several behaviors at once, each with a *priority*; the controller merges their proposals as a
fuzzy controller defuzzifies its rules, weighing each by priority x fit, but so that opposite
proposals never cancel (Saffiotti's context-dependent blending; a plain weighted average of a
left turn and a right turn is no turn at all, and a robot can freeze against an obstacle):

- **turn**: the proposals turning left (turn above :data:`DEADBAND`) and those turning right
  each weigh ``sum(p_i * f_i * |turn_i|)``. When both sides ask, one side is chosen, the heavier,
  and *held* (:class:`Arbiter`): a side chosen before stays chosen while its weight is at least
  1 / :data:`HOLD` of the other's, until no opposition has been seen for :data:`HOLD_STEPS`
  steps. The turn is the weighted average over the proposals of the chosen side and those
  asking for no turn to speak of: ``sum(p_i f_i turn_i) / sum(p_i f_i)``;
- **speed**: the weighted average of the speeds asked for, ``sum(p_i f_i speed_i) /
  sum(p_i f_i)``, capped by each *limit* (a behavior slowing for an obstacle,
  :attr:`Proposal.limit`) to the degree it fits: at most ``s_i + (1 - f_i) (top - s_i)``,
  ``top`` the fastest speed asked for, so that a fully fitting avoidCollision's 0 stops the
  robot however hard goToPos pulls, and a limit fading out lets go gradually. When a behavior
  asks to back up (a speed below 0), only the backing proposals count, since an escape
  averaged with a push forward goes nowhere.

When no behavior specifies one (or every weight is 0, at most :data:`NEGLIGIBLE`), it is 0:
with nothing asking to move, the robot stands still and keeps its heading.

A behavior set is written as plain data, one item per behavior, ``[[name, arg, ...],
priority]``, as in 004 Figure 4::

    [[["avoidObstacle", 150, "moderate"], "med"],
     [["goToPos", "curr-goal", "mod-fast", 20], "high"],
     [["avoidCollision", 50, "mod-fast"], "high"]]

The arguments and priorities are read as :mod:`.arguments` says (centimetres by default;
:func:`parse_behavior_set` takes ``length_unit="m"`` for metres). The twelve behaviors of 004
Table 1 are registered here by name; one name may have several signatures of different
argument counts (``(turnTo pos)`` and ``(turnTo direction angle)``), told apart by how many
arguments an item gives. New behaviors are added with :func:`register_behavior`, new kinds of
argument with :func:`cbr_world2d.pilots.arguments.register_argument`; the parser and the
``behaviors`` pilot know them at once.

The vocabulary of behaviors (the named levels, symbolic values and argument kinds of
:mod:`.arguments`, :class:`Proposal` and the behavior classes of :mod:`.primitives`) is handed
on here (``__all__``), so that this is the one module to import behavior names from.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, Literal

import attrs

from cbr_world2d.pilots.arguments import (
    ARGUMENTS,
    CURRENT_GOAL,
    CURRENT_HEADING,
    LENGTH_UNITS,
    PRIORITIES,
    SPEEDS,
    TOP_SPEED,
    TOP_TURN_RATE,
    TURN_RATES,
    priority_argument,
    register_argument,
)
from cbr_world2d.pilots.base import Command, Point
from cbr_world2d.pilots.primitives import (
    AvoidCollision,
    AvoidObstacle,
    BackOff,
    Behavior,
    EnterDoorway,
    FollowWall,
    GoStraight,
    GoToPos,
    Localize,
    MoveForward,
    Proposal,
    SlowAvoid,
    Stop,
    TurnToAngle,
    TurnToPos,
)
from cbrcore.options import option

if TYPE_CHECKING:
    from cbr_world2d.sensors import Observation

__all__ = [
    "ARGUMENTS",
    "BEHAVIORS",
    "CURRENT_GOAL",
    "CURRENT_HEADING",
    "DEADBAND",
    "HOLD",
    "HOLD_STEPS",
    "LENGTH_UNITS",
    "NEGLIGIBLE",
    "OPEN_AREA",
    "PRIORITIES",
    "SPEEDS",
    "TOP_SPEED",
    "TOP_TURN_RATE",
    "TURN_RATES",
    "ActiveBehavior",
    "Arbiter",
    "AvoidCollision",
    "AvoidObstacle",
    "BackOff",
    "Behavior",
    "BehaviorPilot",
    "BehaviorPilotOptions",
    "BehaviorType",
    "EnterDoorway",
    "FollowWall",
    "GoStraight",
    "GoToPos",
    "Localize",
    "MoveForward",
    "Proposal",
    "SlowAvoid",
    "Stop",
    "TurnToAngle",
    "TurnToPos",
    "lookup_behavior",
    "merge",
    "parse_behavior",
    "parse_behavior_set",
    "register_argument",
    "register_behavior",
]

NEGLIGIBLE = 1e-12
"""Merging leaves out weights (priority x fit) at or below this: they say nothing, and
subnormal ones would spoil the ratio of the weighted sums."""


DEADBAND = 0.02
"""rad/s: a turn this small (about a degree a second) is no turn to either side: it goes with
whichever side is chosen."""
HOLD = 2.0
"""A side chosen to turn to is kept while its weight is at least 1 / HOLD of the other side's:
noise that shifts the balance a little does not flip the robot back and forth."""
HOLD_STEPS = 10
"""Steps (a second at the default 0.1 s) without opposing proposals after which the side held
is forgotten: a new conflict is judged afresh."""


@attrs.define
class Arbiter:
    """Merges proposals step after step, holding the side it chose to turn to (see the module
    docstring)."""

    side: int = 0
    """+1 left, -1 right: the side chosen at the last conflict; 0 none held."""
    quiet: int = 0
    """Steps since the last conflict."""

    def merge(self, proposals: Sequence[tuple[Proposal, float]]) -> Command:
        """``(speed, turn)`` merged from ``(proposal, priority)`` pairs."""
        weighed = [(p, priority * p.fit) for p, priority in proposals
                   if priority * p.fit > NEGLIGIBLE]
        mass = {1: 0.0, -1: 0.0}
        for p, w in weighed:
            if p.turn is not None and abs(p.turn) > DEADBAND:
                mass[1 if p.turn > 0 else -1] += w * abs(p.turn)
        chosen = 0
        if mass[1] > 0.0 and mass[-1] > 0.0:
            held = self.side
            chosen = (held if held and HOLD * mass[held] >= mass[-held]
                      else (1 if mass[1] >= mass[-1] else -1))
            self.side, self.quiet = chosen, 0
        else:
            self.quiet += 1
            if self.quiet >= HOLD_STEPS:
                self.side = 0
        turns = [(p.turn, w) for p, w in weighed if p.turn is not None
                 and (chosen == 0 or abs(p.turn) <= DEADBAND or (p.turn > 0) == (chosen > 0))]
        speeds = [(p.speed, w) for p, w in weighed if p.speed is not None]
        if any(v < 0.0 for v, _ in speeds):
            return _mean([(v, w) for v, w in speeds if v < 0.0]), _mean(turns)
        speed = _mean(speeds)
        top = max((v for v, _ in speeds), default=0.0)
        for p, _ in weighed:
            if p.limit and p.speed is not None:
                speed = min(speed, p.speed + (1.0 - p.fit) * (top - p.speed))
        return speed, _mean(turns)

    def reset(self) -> None:
        self.side, self.quiet = 0, 0


def _mean(values: Sequence[tuple[float, float]]) -> float:
    total = sum(w for _, w in values)
    return sum(v * w for v, w in values) / total if total > 0.0 else 0.0


def merge(proposals: Sequence[tuple[Proposal, float]]) -> Command:
    """``(speed, turn)`` merged from ``(proposal, priority)`` pairs by an :class:`Arbiter` that
    holds no side yet (one step on its own)."""
    return Arbiter().merge(proposals)


# --- the behaviors known by name --------------------------------------------------------


@attrs.frozen
class BehaviorType:
    """A behavior the parser knows: its name, its arguments ``(name, kind)`` in order (kinds of
    :data:`cbr_world2d.pilots.arguments.ARGUMENTS`) and ``build``, called with the converted
    arguments as keywords."""

    name: str
    params: tuple[tuple[str, str], ...]
    build: Callable[..., Behavior]
    doc: str = ""

    @property
    def signature(self) -> str:
        """The behavior as 004 Table 1 writes it, say ``(turnTo direction angle)``."""
        return "(" + " ".join([self.name, *(keyword for keyword, _ in self.params)]) + ")"


BEHAVIORS: dict[str, dict[int, BehaviorType]] = {}
"""The behaviors known by name (004 Table 1's names), each with its signatures by argument
count: ``BEHAVIORS["turnTo"][2]`` is ``(turnTo direction angle)``."""


def register_behavior(name: str, build: Callable[..., Behavior],
                      params: Sequence[tuple[str, str]], doc: str = "") -> None:
    """Add a behavior by ``name``; ``build(**arguments)`` makes it, ``params`` lists its
    arguments ``(keyword, kind)`` in the order plain data gives them. A name registered
    already gains another signature when the argument count differs from its others'; the same
    name and count are registered once."""
    params = tuple(params)
    signatures = BEHAVIORS.get(name, {})
    if len(params) in signatures:
        raise ValueError(f"the behavior {name!r} with {len(params)} argument(s) is already "
                         f"registered: {signatures[len(params)].signature}")
    for keyword, kind in params:
        if kind not in ARGUMENTS:
            raise ValueError(f"behavior {name!r}: argument {keyword!r} has the unknown kind "
                             f"{kind!r}; known kinds: {', '.join(sorted(ARGUMENTS))}")
    BEHAVIORS.setdefault(name, {})[len(params)] = BehaviorType(name, params, build, doc)


def lookup_behavior(name: Any, arity: int) -> BehaviorType:
    """The behavior ``name`` taking ``arity`` arguments; a ValueError naming the known
    behaviors, or the behavior's signatures, otherwise."""
    signatures = BEHAVIORS.get(name) if isinstance(name, str) else None
    if not signatures:
        raise ValueError(f"unknown behavior {name!r}; known: {', '.join(sorted(BEHAVIORS))}")
    if arity not in signatures:
        counts = " or ".join(str(n) for n in sorted(signatures))
        forms = " or ".join(signatures[n].signature for n in sorted(signatures))
        raise ValueError(f"{name} takes {counts} argument(s) {forms}, got {arity}")
    return signatures[arity]


register_behavior("stop", Stop, (), "Stop forward movement.")
register_behavior("moveForward", MoveForward, [("velocity", "speed")],
                  "Move the robot forward with given velocity.")
register_behavior("goStraight", GoStraight, [("velocity", "speed"), ("direction", "direction")],
                  "Attempt a straight path in some direction with given speed.")
register_behavior("avoidObstacle", AvoidObstacle, [("distance", "distance"), ("speed", "speed")],
                  "Slow to speed and turn away from obstacles within given distance.")
register_behavior("avoidCollision", AvoidCollision,
                  [("distance", "distance"), ("turn_rate", "turn_rate")],
                  "Turn at given rate away from an imminent collision at given distance.")
register_behavior("backOff", BackOff, [("distance", "distance"), ("speed", "speed")],
                  "Back up, turning toward the freer side, from an obstacle within the given "
                  "distance ahead (not in 004 Table 1: the escape its behaviors lack).")
register_behavior("slowAvoid", SlowAvoid, [("distance", "distance"), ("speed", "speed")],
                  "Slow but continue toward obstacle.")
register_behavior("goToPos", GoToPos,
                  [("position", "position"), ("speed", "speed"), ("accuracy", "distance")],
                  "Head towards a given point on the map with some speed.")
register_behavior("followWall", FollowWall, [("direction", "direction")],
                  "Travel along a detected wall.")
register_behavior("enterDoorway", EnterDoorway, [("door", "position"), ("direction", "direction")],
                  "Go through a doorway.")
register_behavior("turnTo", TurnToPos, [("pos", "position")], "Turn to face a position.")
register_behavior("turnTo", TurnToAngle, [("direction", "direction"), ("angle", "angle")],
                  "Turn a given angle left or right.")
register_behavior("localize", Localize, (),
                  "Make sensor observations for the localization algorithm.")


# --- behavior sets as plain data --------------------------------------------------------


@attrs.frozen
class ActiveBehavior:
    """One behavior of a set: the behavior, its priority (a number in (0, 1]) and the plain
    data it was read from (None when built in Python)."""

    behavior: Behavior
    priority: float
    data: Any = None


def parse_behavior(item: Any, unit: float) -> ActiveBehavior:
    """One item ``[[name, arg, ...], priority]`` of a behavior set, lengths in ``unit`` metres;
    ValueError when wrong."""
    if (isinstance(item, str) or not isinstance(item, Sequence) or len(item) != 2
            or isinstance(item[0], str) or not isinstance(item[0], Sequence) or not item[0]):
        raise ValueError(f"expected [[name, arg, ...], priority], got {item!r}")
    call, priority = item
    name, *args = call
    kind = lookup_behavior(name, len(args))
    values = {}
    for (keyword, arg_kind), value in zip(kind.params, args, strict=True):
        try:
            values[keyword] = ARGUMENTS[arg_kind](value, unit)
        except ValueError as exc:
            raise ValueError(f"{name} {keyword}: {exc}") from None
    try:
        level = priority_argument(priority)
    except ValueError as exc:
        raise ValueError(f"{name} priority: {exc}") from None
    return ActiveBehavior(kind.build(**values), level, item)


def parse_behavior_set(data: Any, length_unit: Literal["cm", "m"] = "cm"
                       ) -> tuple[ActiveBehavior, ...]:
    """A behavior set from plain data (see the module docstring); a ValueError naming the item
    (counted from 0) and what was wrong otherwise."""
    if length_unit not in LENGTH_UNITS:
        raise ValueError(f"unknown length unit {length_unit!r}; expected cm or m")
    if isinstance(data, str) or not isinstance(data, Sequence):
        raise ValueError(f"expected a list of behaviors, got {data!r}")
    unit = LENGTH_UNITS[length_unit]
    parsed = []
    for index, item in enumerate(data):
        try:
            parsed.append(parse_behavior(item, unit))
        except ValueError as exc:
            raise ValueError(f"item {index}: {exc}") from None
    return tuple(parsed)


OPEN_AREA: list[Any] = [
    [["avoidObstacle", 150, "moderate"], "med"],
    [["goToPos", "curr-goal", "mod-fast", 20], "high"],
    [["avoidCollision", 50, "mod-fast"], "high"],
]
"""004 Figure 4(a), the behavior case of an open area with few obstacles, in centimetres; the
goal accuracy is 20 cm where the figure has 100, so that the robot comes within the trials'
default tolerance (0.3 m) of its target."""


# --- the pilot --------------------------------------------------------------------------


def _behavior_set(instance: Any, attribute: attrs.Attribute, value: Any) -> None:
    try:
        parse_behavior_set(value, instance.length_unit)
    except ValueError as exc:
        raise ValueError(f"'{attribute.name}' must be a behavior set: {exc}") from None


@attrs.frozen
class BehaviorPilotOptions:
    """The options of the ``behaviors`` pilot."""

    length_unit: Literal["cm", "m"] = option(
        "cm", "The unit of the lengths in 'behaviors' (004 writes centimetres).")
    behaviors: list[Any] = option(
        doc="The behavior set: items [[name, arg, ...], priority] (004 Figure 4); the default "
        "is Figure 4(a), the open-area case.", factory=lambda: copy.deepcopy(OPEN_AREA),
        validator=_behavior_set)


class BehaviorPilot:
    """A pilot merging the proposals of its active behaviors (see the module docstring)."""

    def __init__(self, behaviors: Sequence[ActiveBehavior]) -> None:
        self.behaviors: tuple[ActiveBehavior, ...] = tuple(behaviors)
        self.proposals: tuple[Proposal, ...] = ()
        """The proposals of the last step, in the order of :attr:`behaviors`."""
        self.arbiter = Arbiter()

    @classmethod
    def from_data(cls, data: Any, length_unit: Literal["cm", "m"] = "cm") -> BehaviorPilot:
        """A pilot with the behavior set written as plain data."""
        return cls(parse_behavior_set(data, length_unit))

    @property
    def localizing(self) -> bool:
        """Whether a ``localize`` behavior of the set fitted at the last step: the robot is
        making observations for the localization algorithm (004), and the map subsystem takes
        them."""
        return any(isinstance(active.behavior, Localize) and proposal.fit > 0.0
                   for active, proposal in zip(self.behaviors, self.proposals, strict=False))

    def install(self, behaviors: Sequence[ActiveBehavior]) -> None:
        """Replace the behavior set (a behavior case retrieved, 004); the new behaviors start
        afresh."""
        self.behaviors = tuple(behaviors)
        self.reset()

    def command(self, obs: Observation, target: Point) -> Command:
        self.proposals = tuple(a.behavior.propose(obs, target) for a in self.behaviors)
        return self.arbiter.merge([(p, a.priority) for p, a in zip(self.proposals,
                                                                   self.behaviors, strict=True)])

    def reset(self) -> None:
        self.proposals = ()
        self.arbiter.reset()
        for active in self.behaviors:
            active.behavior.reset()
