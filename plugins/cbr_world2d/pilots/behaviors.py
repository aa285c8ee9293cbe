"""The behavior-merging controller of 004 (RUPART on Saphira): behaviors as fuzzy control rules.

A *behavior* looks at the observation and proposes a turn rate and a speed together with a
*degree of fit* in [0, 1], how well its context holds now (its activation: 0 means it has
nothing to say, say avoidCollision with nothing ahead). It may leave the turn or the speed
unspecified (``None``): ``moveForward`` has no opinion on turning. A behavior set activates
several behaviors at once, each with a *priority*; the controller merges their proposals as a
fuzzy controller defuzzifies its rules, by a weighted average with weight priority x fit, for
the turn and the speed separately, over the behaviors that specify each::

    turn  = sum(p_i * f_i * turn_i)  / sum(p_i * f_i)      (behaviors with a turn)
    speed = sum(p_i * f_i * speed_i) / sum(p_i * f_i)      (behaviors with a speed)

When no behavior specifies one (or every weight is 0, at most :data:`NEGLIGIBLE`), it is 0:
with nothing asking to move, the robot stands still and keeps its heading.

Named levels (004 Figure 4 gives the names, not the numbers; these are our choice, each a
fraction of :data:`TOP_SPEED` and :data:`TOP_TURN_RATE`). ``fast`` turns at 100 deg/s, the turn
rate limit of the Pioneer 2 DX preset :data:`cbr_world2d.robot.PIONEER_2DX`, but drives at
0.4 m/s, an indoor cruising speed (the ``potential_field`` pilot's default too), not at the
preset's top speed of 0.75 m/s, so that the robot's speed limit never cuts a named speed:

=============  =========  ===========  ============
name           fraction   speed (m/s)  turn (deg/s)
=============  =========  ===========  ============
very-slow      1/8        0.05         12.5
slow           1/4        0.1          25
moderate       1/2        0.2          50
mod-fast       3/4        0.3          75
fast           1          0.4          100
=============  =========  ===========  ============

Priorities ``low, med-low, med, med-high, high`` are 0.2, 0.4, 0.6, 0.8, 1.0 (004: "fixed
priority levels are converted to fuzzy values"; evenly spaced, high = 1).

A behavior set is written as plain data, one item per behavior, ``[[name, arg, ...],
priority]``, as in 004 Figure 4::

    [[["avoidObstacle", 150, "moderate"], "med"],
     [["goToPos", "curr-goal", "mod-fast", 20], "high"],
     [["avoidCollision", 50, "mod-fast"], "high"]]

Lengths in that data are centimetres by default, as in 004 ("distances are given in
centimeters"); :func:`parse_behavior_set` takes ``length_unit="m"`` for metres. A speed is a
name above or a number of length units per second, a turn rate a name or a number of degrees
per second, a direction ``"curr-head"`` (the heading when the behavior starts) or degrees
counter-clockwise from +x, a position ``"curr-goal"`` (the pilot's current target) or
``[x, y]`` in length units. The Python classes take metres, m/s and radians.

New behaviors are added by name with :func:`register_behavior`, new kinds of argument with
:func:`register_argument`; the parser and the ``behaviors`` pilot know them at once.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, Literal, Protocol

import attrs
import numpy as np

from cbr_world2d.pilots.base import Command, Point, bearing_error, wrap_angle
from cbrcore.options import option

if TYPE_CHECKING:
    from cbr_world2d.sensors import Observation

TOP_SPEED = 0.4
"""m/s: the speed named ``fast``, an indoor cruising speed for a Pioneer 2 DX, about half the
top speed of :data:`cbr_world2d.robot.PIONEER_2DX` (0.75 m/s)."""
TOP_TURN_RATE = math.radians(100.0)
"""rad/s: the turn rate named ``fast``, the turn rate limit of
:data:`cbr_world2d.robot.PIONEER_2DX` (100 deg/s)."""

LEVELS: dict[str, float] = {"very-slow": 0.125, "slow": 0.25, "moderate": 0.5,
                            "mod-fast": 0.75, "fast": 1.0}
"""Named speed and turn-rate levels as fractions of the top speed and turn rate."""
SPEEDS: dict[str, float] = {name: TOP_SPEED * f for name, f in LEVELS.items()}
"""Named speeds in m/s."""
TURN_RATES: dict[str, float] = {name: TOP_TURN_RATE * f for name, f in LEVELS.items()}
"""Named turn rates in rad/s."""
PRIORITIES: dict[str, float] = {"low": 0.2, "med-low": 0.4, "med": 0.6, "med-high": 0.8,
                                "high": 1.0}
"""Named priorities as the numbers merging weighs by."""

CURRENT_GOAL = "curr-goal"
"""The position argument meaning the pilot's current target."""
CURRENT_HEADING = "curr-head"
"""The direction argument meaning the heading when the behavior starts."""

LENGTH_UNITS: dict[str, float] = {"cm": 0.01, "m": 1.0}
"""Metres per length unit of a behavior set's plain data."""

TURN_GAIN = TOP_TURN_RATE / math.pi
"""1/s: turn rate per radian of heading error of the heading behaviors (goToPos, goStraight),
so that a heading straight behind asks for the top turn rate. Gentler than a pilot of its own
would turn, on purpose: merged with equal weight, avoidCollision turning at rate R out-turns
goToPos until the goal lies R / TURN_GAIN off the heading, beyond 90 degrees for R from
``mod-fast`` up, where goToPos asks for no speed; so the pair stops before a wall instead of
creeping into it at an angle."""
APPROACH = 0.5
"""m: goToPos slows in proportion to the distance left within this much of its position."""
COLLISION_ARC = math.radians(60.0)
"""avoidCollision watches the beams within this angle of the heading (on a Pioneer the front
beams at 10, 30 and 50 degrees either side): what the robot would run into."""
OBSTACLE_ARC = math.radians(90.0)
"""avoidObstacle watches the front half of the ring, side beams included."""
NEGLIGIBLE = 1e-12
"""Merging leaves out weights (priority x fit) at or below this: they say nothing, and
subnormal ones would spoil the ratio of the weighted sums."""
COLLISION_FADE = 1.5
"""avoidCollision fits fully within its distance and fades out linearly to this many times it."""


@attrs.frozen
class Proposal:
    """What one behavior asks for: a turn rate (rad/s) and a speed (m/s), either None when it
    has no opinion, with its degree of fit in [0, 1]."""

    turn: float | None
    speed: float | None
    fit: float


class Behavior(Protocol):
    """A behavior: proposes a turn rate and a speed with a degree of fit each step."""

    def propose(self, obs: Observation, target: Point) -> Proposal:
        """This step's proposal; ``target`` is the pilot's current target."""
        ...

    def reset(self) -> None:
        """Forget what was latched at the start (a new trial or a newly installed set)."""
        ...


def _clip(value: float, low: float, high: float) -> float:
    return min(max(value, low), high)


SectorKernel = Callable[[np.ndarray, np.ndarray, float, float], tuple[float, float]]
""":func:`cbr_world2d.pilots.kernels.sector`: ``(nearest, side)`` of the sonar beams within an
arc of the heading."""


def _sector_kernel() -> SectorKernel:
    # numba loads when a behavior that reads the sonar is built, not with the registration at
    # every start of cbr; the behavior keeps the kernel so that a step looks up no module
    from cbr_world2d.pilots.kernels import sector

    return sector


def _floats(values: np.ndarray) -> np.ndarray:
    return np.asarray(values, dtype=np.float64)


@attrs.define
class Stop:
    """``(stop)``: stop forward movement (speed 0, turn unspecified)."""

    def propose(self, obs: Observation, target: Point) -> Proposal:
        return Proposal(None, 0.0, 1.0)

    def reset(self) -> None:
        pass


@attrs.define
class MoveForward:
    """``(moveForward velocity)``: move forward at ``velocity`` m/s (turn unspecified)."""

    velocity: float

    def propose(self, obs: Observation, target: Point) -> Proposal:
        return Proposal(None, self.velocity, 1.0)

    def reset(self) -> None:
        pass


@attrs.define
class GoStraight:
    """``(goStraight velocity direction)``: keep the heading ``direction`` (radians, or None
    for the heading when the behavior starts) at ``velocity`` m/s, slower when off course
    (speed times cos of the heading error) and turning :data:`TURN_GAIN` per radian of error."""

    velocity: float
    direction: float | None = None
    _latched: float | None = attrs.field(default=None, init=False)

    def propose(self, obs: Observation, target: Point) -> Proposal:
        if self._latched is None:
            self._latched = obs.pose.theta if self.direction is None else self.direction
        error = wrap_angle(self._latched - obs.pose.theta)
        return Proposal(TURN_GAIN * error, self.velocity * max(math.cos(error), 0.0), 1.0)

    def reset(self) -> None:
        self._latched = None


@attrs.define
class GoToPos:
    """``(goToPos position speed accuracy)``: head for ``position`` (None: the pilot's target)
    at ``speed`` m/s. It turns :data:`TURN_GAIN` per radian of heading error, drives at speed
    times cos of the error (not at all when the point is behind), slows
    in proportion within 0.5 m of the point, and holds still (turn and speed 0) once within
    ``accuracy`` metres of it."""

    position: Point | None
    speed: float
    accuracy: float

    def propose(self, obs: Observation, target: Point) -> Proposal:
        pose = obs.pose
        goal = target if self.position is None else self.position
        distance, error = bearing_error(pose.x, pose.y, pose.theta, goal)
        if distance <= self.accuracy:
            return Proposal(0.0, 0.0, 1.0)
        speed = self.speed * max(math.cos(error), 0.0) * min(1.0, distance / APPROACH)
        return Proposal(TURN_GAIN * error, speed, 1.0)

    def reset(self) -> None:
        pass


@attrs.define
class AvoidObstacle:
    """``(avoidObstacle distance speed)``: with something within ``distance`` metres in the
    front half, slow to ``speed`` and turn away at ``turn_rate`` (the side with the closer
    readings, see :func:`cbr_world2d.pilots.kernels.sector`). Its fit grows from 0 at
    ``distance`` to 1 at contact: ``1 - nearest / distance``. ``turn_rate`` is none of Table 1's
    arguments: plain data leaves it at ``moderate``."""

    distance: float
    speed: float
    turn_rate: float = TURN_RATES["moderate"]
    _sector: SectorKernel = attrs.field(init=False, factory=_sector_kernel, eq=False,
                                        repr=False)

    def propose(self, obs: Observation, target: Point) -> Proposal:
        nearest, side = self._sector(_floats(obs.sonar), _floats(obs.sonar_angles),
                                     OBSTACLE_ARC, self.distance)
        fit = _clip(1.0 - nearest / self.distance, 0.0, 1.0)
        if fit == 0.0:
            return Proposal(None, None, 0.0)
        return Proposal(side * self.turn_rate, self.speed, fit)

    def reset(self) -> None:
        pass


@attrs.define
class AvoidCollision:
    """``(avoidCollision distance turnRate)``: with something within ``distance`` metres ahead
    (beams within 60 degrees of the heading), stop forward movement and turn away at
    ``turn_rate`` rad/s. Its fit is 1 within ``distance`` and fades linearly to 0 at 1.5 times
    ``distance``."""

    distance: float
    turn_rate: float
    _sector: SectorKernel = attrs.field(init=False, factory=_sector_kernel, eq=False,
                                        repr=False)

    def propose(self, obs: Observation, target: Point) -> Proposal:
        reach = COLLISION_FADE * self.distance
        nearest, side = self._sector(_floats(obs.sonar), _floats(obs.sonar_angles),
                                     COLLISION_ARC, reach)
        fit = _clip((reach - nearest) / (reach - self.distance), 0.0, 1.0)
        if fit == 0.0:
            return Proposal(None, None, 0.0)
        return Proposal(side * self.turn_rate, 0.0, fit)

    def reset(self) -> None:
        pass


def merge(proposals: Sequence[tuple[Proposal, float]]) -> Command:
    """``(speed, turn)`` merged from ``(proposal, priority)`` pairs (see the module docstring)."""
    turn_sum = turn_weight = speed_sum = speed_weight = 0.0
    for proposal, priority in proposals:
        weight = priority * proposal.fit
        if weight <= NEGLIGIBLE:
            continue
        if proposal.turn is not None:
            turn_sum += weight * proposal.turn
            turn_weight += weight
        if proposal.speed is not None:
            speed_sum += weight * proposal.speed
            speed_weight += weight
    speed = speed_sum / speed_weight if speed_weight > 0.0 else 0.0
    turn = turn_sum / turn_weight if turn_weight > 0.0 else 0.0
    return speed, turn


# --- plain data -------------------------------------------------------------------------

Converter = Callable[[Any, float], Any]
"""Turns one plain-data argument into the value a behavior takes, given the metres per length
unit; raises ValueError saying what was expected."""


def _number(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"expected a finite number, got {value!r}")
    return float(value)


def _named(table: Mapping[str, float], what: str, value: Any) -> float | None:
    if isinstance(value, str):
        if value not in table:
            raise ValueError(f"unknown {what} {value!r}; expected a number or one of "
                             f"{', '.join(table)}")
        return table[value]
    return None


def speed_argument(value: Any, unit: float) -> float:
    """A speed: a name of :data:`SPEEDS` or a number >= 0 of length units per second."""
    named = _named(SPEEDS, "speed", value)
    if named is not None:
        return named
    number = _number(value)
    if number < 0.0:
        raise ValueError(f"expected a speed >= 0, got {value!r}")
    return number * unit


def turn_rate_argument(value: Any, unit: float) -> float:
    """A turn rate: a name of :data:`TURN_RATES` or a number >= 0 of degrees per second."""
    named = _named(TURN_RATES, "turn rate", value)
    if named is not None:
        return named
    number = _number(value)
    if number < 0.0:
        raise ValueError(f"expected a turn rate >= 0, got {value!r}")
    return math.radians(number)


def distance_argument(value: Any, unit: float) -> float:
    """A distance: a number > 0 of length units."""
    number = _number(value)
    if number <= 0.0:
        raise ValueError(f"expected a distance > 0, got {value!r}")
    return number * unit


def position_argument(value: Any, unit: float) -> Point | None:
    """A position: ``"curr-goal"`` (None: the pilot's target) or ``[x, y]`` in length units."""
    if value == CURRENT_GOAL:
        return None
    if isinstance(value, str) or not isinstance(value, Sequence) or len(value) != 2:
        raise ValueError(f"expected {CURRENT_GOAL!r} or [x, y], got {value!r}")
    return _number(value[0]) * unit, _number(value[1]) * unit


def direction_argument(value: Any, unit: float) -> float | None:
    """A direction: ``"curr-head"`` (None: the heading at the start) or degrees from +x."""
    if value == CURRENT_HEADING:
        return None
    if isinstance(value, str):
        raise ValueError(f"expected {CURRENT_HEADING!r} or degrees, got {value!r}")
    return wrap_angle(math.radians(_number(value)))


ARGUMENTS: dict[str, Converter] = {
    "speed": speed_argument,
    "turn_rate": turn_rate_argument,
    "distance": distance_argument,
    "position": position_argument,
    "direction": direction_argument,
}
"""The kinds of behavior argument, by name, with their converters."""


@attrs.frozen
class BehaviorType:
    """A behavior the parser knows: its name, its arguments ``(name, kind)`` in order (kinds of
    :data:`ARGUMENTS`) and ``build``, called with the converted arguments as keywords."""

    name: str
    params: tuple[tuple[str, str], ...]
    build: Callable[..., Behavior]
    doc: str = ""


BEHAVIORS: dict[str, BehaviorType] = {}
"""The behaviors known by name (004 Table 1's names)."""


def register_argument(kind: str, convert: Converter) -> None:
    """Add a kind of behavior argument; a kind is registered once."""
    if kind in ARGUMENTS:
        raise ValueError(f"the behavior argument kind {kind!r} is already registered")
    ARGUMENTS[kind] = convert


def register_behavior(name: str, build: Callable[..., Behavior],
                      params: Sequence[tuple[str, str]], doc: str = "") -> None:
    """Add a behavior by ``name``; ``build(**arguments)`` makes it, ``params`` lists its
    arguments ``(keyword, kind)`` in the order plain data gives them. A name is registered
    once."""
    if name in BEHAVIORS:
        raise ValueError(f"the behavior {name!r} is already registered")
    for keyword, kind in params:
        if kind not in ARGUMENTS:
            raise ValueError(f"behavior {name!r}: argument {keyword!r} has the unknown kind "
                             f"{kind!r}; known kinds: {', '.join(sorted(ARGUMENTS))}")
    BEHAVIORS[name] = BehaviorType(name, tuple(params), build, doc)


register_behavior("stop", Stop, (), "Stop forward movement.")
register_behavior("moveForward", MoveForward, [("velocity", "speed")],
                  "Move the robot forward with given velocity.")
register_behavior("goStraight", GoStraight, [("velocity", "speed"), ("direction", "direction")],
                  "Attempt a straight path in some direction with given speed.")
register_behavior("goToPos", GoToPos,
                  [("position", "position"), ("speed", "speed"), ("accuracy", "distance")],
                  "Head towards a given point on the map with some speed.")
register_behavior("avoidObstacle", AvoidObstacle, [("distance", "distance"), ("speed", "speed")],
                  "Slow to speed and turn away from obstacles within given distance.")
register_behavior("avoidCollision", AvoidCollision,
                  [("distance", "distance"), ("turn_rate", "turn_rate")],
                  "Turn at given rate away from an imminent collision at given distance.")


@attrs.frozen
class ActiveBehavior:
    """One behavior of a set: the behavior, its priority (a number in (0, 1]) and the plain
    data it was read from (None when built in Python)."""

    behavior: Behavior
    priority: float
    data: Any = None


def _priority(value: Any) -> float:
    named = _named(PRIORITIES, "priority", value)
    if named is not None:
        return named
    number = _number(value)
    if not 0.0 < number <= 1.0:
        raise ValueError(f"expected a priority in (0, 1], got {value!r}")
    return number


def parse_behavior(item: Any, unit: float) -> ActiveBehavior:
    """One item ``[[name, arg, ...], priority]`` of a behavior set; ValueError when wrong."""
    if (isinstance(item, str) or not isinstance(item, Sequence) or len(item) != 2
            or isinstance(item[0], str) or not isinstance(item[0], Sequence) or not item[0]):
        raise ValueError(f"expected [[name, arg, ...], priority], got {item!r}")
    call, priority = item
    name, *args = call
    kind = BEHAVIORS.get(name) if isinstance(name, str) else None
    if kind is None:
        raise ValueError(f"unknown behavior {name!r}; known: {', '.join(sorted(BEHAVIORS))}")
    if len(args) != len(kind.params):
        signature = " ".join(keyword for keyword, _ in kind.params)
        raise ValueError(f"{name} takes {len(kind.params)} argument(s) ({name} {signature}), "
                         f"got {len(args)}")
    values = {}
    for (keyword, arg_kind), value in zip(kind.params, args, strict=True):
        try:
            values[keyword] = ARGUMENTS[arg_kind](value, unit)
        except ValueError as exc:
            raise ValueError(f"{name} {keyword}: {exc}") from None
    try:
        level = _priority(priority)
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

    @classmethod
    def from_data(cls, data: Any, length_unit: Literal["cm", "m"] = "cm") -> BehaviorPilot:
        """A pilot with the behavior set written as plain data."""
        return cls(parse_behavior_set(data, length_unit))

    def install(self, behaviors: Sequence[ActiveBehavior]) -> None:
        """Replace the behavior set (a behavior case retrieved, 004); the new behaviors start
        afresh."""
        self.behaviors = tuple(behaviors)
        self.reset()

    def command(self, obs: Observation, target: Point) -> Command:
        self.proposals = tuple(a.behavior.propose(obs, target) for a in self.behaviors)
        return merge([(p, a.priority) for p, a in zip(self.proposals, self.behaviors,
                                                      strict=True)])

    def reset(self) -> None:
        self.proposals = ()
        for active in self.behaviors:
            active.behavior.reset()
