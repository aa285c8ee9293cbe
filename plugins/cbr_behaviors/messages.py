"""Messages for the delivery robot of 004 and the seeded days they arrive in.

004: "Messages arrive asynchronously by wireless Ethernet. Each message has a priority level or
a deadline, and becomes a navigational goal for the robot: to deliver a message it must
navigate to the proper location." A :class:`Message` carries both a priority and a deadline.

:func:`message_day` draws a day of messages from a ``numpy.random.Generator``:

- arrivals are a Poisson process of ``rate_per_hour`` over ``[0, length)`` seconds: the gaps
  between arrivals are exponential with mean ``3600 / rate_per_hour`` seconds;
- each message goes to one of ``places`` (default: the world's places whose name starts with
  ``room``, the offices of :func:`cbr_world2d.generate.office`), uniformly;
- its priority is drawn with the probabilities :data:`PRIORITY_CHANCES`;
- its deadline is its arrival plus a slack: a factor drawn uniformly from the priority's range
  in :data:`SLACK` times the place's reference trip time, the longest estimated drive to it
  from ``origin`` or any of the other destinations (where the robot may be when the message
  arrives), at least :data:`MIN_TRIP`. ``eta`` estimates the seconds between two points
  (default :func:`straight_line` at :data:`CRUISE_SPEED`; a caller with a map passes route
  lengths over a speed) and ``origin`` is where the robot waits for work (default the centre of
  the world's bounds, the middle of an office's hallway). So by the estimate a free robot at
  the origin or at any destination meets every deadline: they conflict when messages crowd.

The draws come in a fixed order, all arrival gaps first, then the places, the priorities and
the slack factors, so the same generator state always gives the same day.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import attrs
import numpy as np

from cbr_world2d.pilots.behaviors import SPEEDS
from cbr_world2d.world import Point, World
from cbrcore.errors import CbrError

PRIORITIES: tuple[str, ...] = ("low", "normal", "high", "critical")
"""The priority levels of a message, least urgent first."""

PRIORITY_CHANCES: Mapping[str, float] = {"low": 0.3, "normal": 0.4, "high": 0.2,
                                         "critical": 0.1}
"""How often a message has each priority (004 gives none): most mail is routine, one in ten
is critical, so that a day holds a few conflicts for the goal manager to resolve."""

SLACK: Mapping[str, tuple[float, float]] = {"low": (6.0, 12.0), "normal": (4.0, 8.0),
                                            "high": (2.5, 5.0), "critical": (1.5, 3.0)}
"""The range of the deadline's slack per priority, in reference trip times. A critical
message leaves at most three trips' time, so it must be served nearly at once; a low one can
wait behind several others."""

MIN_TRIP = 30.0
"""Seconds: the least reference trip time, so that in a small world a message still leaves
time to turn round and get there."""

CRUISE_SPEED = SPEEDS["mod-fast"]
"""m/s: the speed trip times assume by default, the ``mod-fast`` speed at which 004's open-area
behavior case (Figure 4a) heads for its goal (0.3 m/s)."""

Eta = Callable[[Point, Point], float]
"""An estimate of the seconds it takes to drive from one point to another."""


def straight_line(speed: float = CRUISE_SPEED) -> Eta:
    """An :data:`Eta`: the straight-line distance over ``speed`` (m/s)."""
    if not (math.isfinite(speed) and speed > 0.0):
        raise ValueError(f"speed must be a finite number > 0, not {speed!r}")
    return lambda a, b: math.dist(a, b) / speed


def _priority(instance: object, attribute: attrs.Attribute, value: str) -> None:
    if value not in PRIORITIES:
        raise ValueError(f"priority must be one of {', '.join(PRIORITIES)}, not {value!r}")


def _point(value: Sequence[float]) -> Point:
    x, y = (float(v) for v in value)
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"a message's point must be finite, not {value!r}")
    return x, y


@attrs.frozen
class Message:
    """A message to deliver at ``place`` (a place of the world, at ``point``), arriving at
    ``arrives`` and due by ``deadline`` (seconds of the day)."""

    id: str
    place: str
    point: Point = attrs.field(converter=_point)
    priority: str = attrs.field(validator=_priority)
    arrives: float = attrs.field(converter=float)
    deadline: float = attrs.field(converter=float)

    def __attrs_post_init__(self) -> None:
        if not (math.isfinite(self.arrives) and math.isfinite(self.deadline)
                and self.deadline >= self.arrives):
            raise ValueError(f"message {self.id}: expected finite times with the deadline "
                             f"not before the arrival, got arrives={self.arrives}, "
                             f"deadline={self.deadline}")

    @property
    def rank(self) -> int:
        """The priority's position in :data:`PRIORITIES` (0 low ... 3 critical)."""
        return PRIORITIES.index(self.priority)


def room_places(world: World) -> list[str]:
    """The world's places whose name starts with ``room``, in the world's order."""
    return [name for name in world.places if name.startswith("room")]


def message_day(world: World, rng: np.random.Generator, *, length: float,
                rate_per_hour: float, places: Sequence[str] | None = None,
                origin: Point | None = None, eta: Eta | None = None,
                chances: Mapping[str, float] = PRIORITY_CHANCES,
                slack: Mapping[str, tuple[float, float]] = SLACK) -> list[Message]:
    """A day of messages in order of arrival, ids ``m1, m2, ...`` (see the module docstring).

    ``chances`` are the priorities' probabilities (normalised to sum 1; priorities left out
    never occur) and ``slack`` their slack ranges. A CbrError names what is wrong with the
    arguments.
    """
    if not (math.isfinite(length) and length > 0.0):
        raise CbrError(f"message_day: length must be a finite number of seconds > 0, "
                       f"not {length!r}")
    if not (math.isfinite(rate_per_hour) and rate_per_hour > 0.0):
        raise CbrError(f"message_day: rate_per_hour must be a finite number > 0, "
                       f"not {rate_per_hour!r}")
    names = room_places(world) if places is None else list(places)
    if not names:
        raise CbrError(f"message_day: world {world.name!r} has no places named room*; "
                       f"give the destinations as places")
    unknown = [name for name in names if name not in world.places]
    if unknown:
        raise CbrError(f"message_day: {', '.join(map(repr, unknown))} not among the places of "
                       f"world {world.name!r} ({', '.join(world.places) or 'none'})")
    weights = np.array([float(chances.get(p, 0.0)) for p in PRIORITIES])
    extra = sorted(set(chances) - set(PRIORITIES))
    if extra or not np.all(np.isfinite(weights)) or (weights < 0).any() or weights.sum() <= 0:
        raise CbrError(f"message_day: chances must map priorities among "
                       f"{', '.join(PRIORITIES)} to probabilities >= 0 with a positive sum, "
                       f"got {dict(chances)!r}")
    for p in PRIORITIES:
        low, high = slack.get(p, (math.nan, math.nan))
        if weights[PRIORITIES.index(p)] > 0 and not 0.0 < low <= high < math.inf:
            raise CbrError(f"message_day: slack of {p!r} must be a range 0 < low <= high, "
                           f"got {slack.get(p)!r}")
    if origin is None:
        xmin, ymin, xmax, ymax = world.bounds
        origin = ((xmin + xmax) / 2, (ymin + ymax) / 2)
    estimate = straight_line() if eta is None else eta
    starts = [origin, *(world.places[name] for name in names)]
    trips = {name: max(MIN_TRIP, *(estimate(start, world.places[name]) for start in starts))
             for name in names}
    mean_gap = 3600.0 / rate_per_hour
    arrivals: list[float] = []
    t = rng.exponential(mean_gap)
    while t < length:
        arrivals.append(float(t))
        t += rng.exponential(mean_gap)
    n = len(arrivals)
    where = rng.integers(len(names), size=n)
    levels = rng.choice(len(PRIORITIES), size=n, p=weights / weights.sum())
    factors = rng.random(n)
    day = []
    for k in range(n):
        place = names[int(where[k])]
        priority = PRIORITIES[int(levels[k])]
        low, high = slack[priority]
        deadline = arrivals[k] + (low + float(factors[k]) * (high - low)) * trips[place]
        day.append(Message(f"m{k + 1}", place, world.places[place], priority, arrivals[k],
                           deadline))
    return day
