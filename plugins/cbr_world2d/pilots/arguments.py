"""Behavior arguments as plain data: the named levels, the symbolic values, the length units and
the converter of each kind of argument.

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

Lengths in plain data are centimetres by default, as in 004 ("distances are given in
centimeters"), or metres (:data:`LENGTH_UNITS`). The kinds of argument (:data:`ARGUMENTS`):

- ``speed``: a name above or a number >= 0 of length units per second;
- ``turn_rate``: a name above or a number >= 0 of degrees per second;
- ``distance``: a number > 0 of length units;
- ``position``: ``"curr-goal"`` (the pilot's current target) or ``[x, y]`` in length units;
- ``direction``: ``"curr-head"`` (the heading when the behavior starts) or degrees
  counter-clockwise from +x;
- ``angle``: degrees in [-180, 180], positive to the left (counter-clockwise).

Each converter returns what the behavior classes take: metres, m/s, radians, and None for the
symbolic values the behavior resolves itself. :func:`register_argument` adds a kind.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from cbr_world2d.pilots.base import Point, wrap_angle
from cbrcore.documents import found

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

Converter = Callable[[Any, float], Any]
"""Turns one plain-data argument into the value a behavior takes, given the metres per length
unit; raises ValueError saying what was expected."""


MAX_ARGUMENT = 1e6
"""The largest magnitude of a numeric behavior argument, in its own unit (10 km in
centimetres): a speed, distance or position past it turns the pilot's arithmetic to
infinities."""


def _number(value: Any) -> float:
    # the bound first: an integer past the largest float is no float, finite or not
    if isinstance(value, bool) or not isinstance(value, int | float) or not (
            abs(value) <= MAX_ARGUMENT and math.isfinite(value)):
        raise ValueError(f"expected a finite number within ±{MAX_ARGUMENT:g} (the limit), got "
                         f"{found(value, setting=True)}")
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
    speed = _number(value)
    if speed < 0.0:
        raise ValueError(f"expected a speed >= 0, got {value!r}")
    return speed * unit


def turn_rate_argument(value: Any, unit: float) -> float:
    """A turn rate: a name of :data:`TURN_RATES` or a number >= 0 of degrees per second."""
    named = _named(TURN_RATES, "turn rate", value)
    if named is not None:
        return named
    rate = _number(value)
    if rate < 0.0:
        raise ValueError(f"expected a turn rate >= 0, got {value!r}")
    return math.radians(rate)


def distance_argument(value: Any, unit: float) -> float:
    """A distance: a number > 0 of length units."""
    distance = _number(value)
    if distance <= 0.0:
        raise ValueError(f"expected a distance > 0, got {value!r}")
    return distance * unit


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


def angle_argument(value: Any, unit: float) -> float:
    """An angle to turn: degrees in [-180, 180], positive to the left. A half turn is the
    widest, so that every angle says unambiguously which way the robot turns."""
    angle = _number(value)
    if not -180.0 <= angle <= 180.0:
        raise ValueError(f"expected an angle in [-180, 180] degrees, got {value!r}")
    return math.radians(angle)


def priority_argument(value: Any) -> float:
    """A priority: a name of :data:`PRIORITIES` or a number in (0, 1]."""
    named = _named(PRIORITIES, "priority", value)
    if named is not None:
        return named
    priority = _number(value)
    if not 0.0 < priority <= 1.0:
        raise ValueError(f"expected a priority in (0, 1], got {value!r}")
    return priority


ARGUMENTS: dict[str, Converter] = {
    "speed": speed_argument,
    "turn_rate": turn_rate_argument,
    "distance": distance_argument,
    "position": position_argument,
    "direction": direction_argument,
    "angle": angle_argument,
}
"""The kinds of behavior argument, by name, with their converters."""


def register_argument(kind: str, convert: Converter) -> None:
    """Add a kind of behavior argument; a kind is registered once."""
    if kind in ARGUMENTS:
        raise ValueError(f"the behavior argument kind {kind!r} is already registered")
    ARGUMENTS[kind] = convert
