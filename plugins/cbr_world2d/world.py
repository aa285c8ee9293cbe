"""The continuous 2D world: what is where, and when.

Lengths are metres, times seconds and angles radians, counter-clockwise from the x axis. A world
holds static geometry (walls and linear obstacles as segments, polygons, point obstacles and
landmarks as discs, the bounds as four walls), doors that open and shut on a schedule, and
movers (people and transient objects) that walk closed waypoint loops. The simulator asks it
for the obstacles present at a time as two plain arrays, segments ``(n, 4)`` rows
``x0, y0, x1, y1`` and discs ``(m, 3)`` rows ``x, y, radius``, so that ray casting and
collision run on arrays, never on objects.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence

import attrs
import numpy as np

from cbrcore.context import Context
from cbrcore.errors import CbrError

Point = tuple[float, float]


@attrs.frozen
class Landmark:
    """A distinguishable object the camera recognises by ``id``; a disc the robot avoids."""

    id: str
    x: float
    y: float
    radius: float


@attrs.frozen
class Wall:
    """A wall or linear obstacle from ``a`` to ``b``; ``between`` names the two landmarks it
    joins when it is a linear obstacle between landmarks (002, Figure 1), else None."""

    a: Point
    b: Point
    between: tuple[str, str] | None = None


@attrs.frozen
class Door:
    """A segment that is shut (an obstacle) or open (nothing) on a periodic schedule.

    The door is open while ``(t + phase) mod period < open_for``; ``phase`` comes from the
    world's seed when the world file leaves it out, so a seed repeats the schedule.
    """

    a: Point
    b: Point
    period: float
    open_for: float
    phase: float
    name: str = ""

    def is_open(self, t: float) -> bool:
        return (t + self.phase) % self.period < self.open_for


@attrs.frozen
class Mover:
    """A person or transient object walking a closed loop of ``waypoints`` at ``speed``.

    It starts at the first waypoint at ``t = appears`` and is present until ``leaves`` (None: to
    the end of time); a mover with one waypoint stands still. :meth:`position` takes the
    mover's own clock, which is the world's time unless it ``yields`` to a robot in its way
    (:mod:`cbr_world2d.crowd`).
    """

    waypoints: tuple[Point, ...]
    speed: float
    radius: float
    kind: str = "person"
    appears: float = 0.0
    leaves: float | None = None
    yields: bool = False
    _legs: np.ndarray = attrs.field(init=False, repr=False, eq=False)
    _cumulative: np.ndarray = attrs.field(init=False, repr=False, eq=False)

    def __attrs_post_init__(self) -> None:
        points = np.asarray(self.waypoints, dtype=float).reshape(-1, 2)
        legs = np.concatenate([points, np.roll(points, -1, axis=0)], axis=1)
        lengths = np.hypot(legs[:, 2] - legs[:, 0], legs[:, 3] - legs[:, 1])
        object.__setattr__(self, "_legs", legs)
        object.__setattr__(self, "_cumulative", np.concatenate([[0.0], np.cumsum(lengths)]))

    def present(self, t: float) -> bool:
        return t >= self.appears and (self.leaves is None or t < self.leaves)

    def position(self, t: float) -> Point:
        """Where the mover is at clock ``t`` (its first waypoint before it appears)."""
        loop = self._cumulative[-1]
        if loop <= 0.0 or self.speed <= 0.0:
            return float(self._legs[0, 0]), float(self._legs[0, 1])
        s = (max(t - self.appears, 0.0) * self.speed) % loop
        leg = min(int(np.searchsorted(self._cumulative, s, side="right")) - 1, len(self._legs) - 1)
        length = self._cumulative[leg + 1] - self._cumulative[leg]
        u = 0.0 if length <= 0.0 else (s - self._cumulative[leg]) / length
        x0, y0, x1, y1 = self._legs[leg]
        return float(x0 + u * (x1 - x0)), float(y0 + u * (y1 - y0))


def _segments(rows: Sequence[Sequence[float]]) -> np.ndarray:
    return np.asarray(rows, dtype=float).reshape(-1, 4)


def _discs(rows: Sequence[Sequence[float]]) -> np.ndarray:
    return np.asarray(rows, dtype=float).reshape(-1, 3)


@attrs.frozen(eq=False)
class World:
    """A 2D world. Build it with :func:`cbr_world2d.worldfile.load_world`, a generator of
    :mod:`cbr_world2d.generate`, or directly; it is immutable once built.

    ``bounds`` is ``(xmin, ymin, xmax, ymax)``; its four sides are walls. ``polygons`` are
    solid obstacles given by their vertices in order; ``points`` are small point obstacles
    ``(x, y, radius)`` the pilot avoids alone (002 section 2); ``places`` names points.
    """

    bounds: tuple[float, float, float, float]
    walls: tuple[Wall, ...] = ()
    polygons: tuple[tuple[Point, ...], ...] = ()
    points: tuple[tuple[float, float, float], ...] = ()
    landmarks: tuple[Landmark, ...] = ()
    doors: tuple[Door, ...] = ()
    movers: tuple[Mover, ...] = ()
    places: Mapping[str, Point] = attrs.field(factory=dict)
    name: str = ""

    static_segments: np.ndarray = attrs.field(init=False, repr=False)
    """Bounds, walls and polygon edges, ``(n, 4)``."""
    static_discs: np.ndarray = attrs.field(init=False, repr=False)
    """Point obstacles and landmarks, ``(m, 3)``."""
    landmark_array: np.ndarray = attrs.field(init=False, repr=False)
    """Landmarks as ``(k, 3)`` rows ``x, y, radius``, in the order of ``landmarks``."""
    door_segments: np.ndarray = attrs.field(init=False, repr=False)

    def __attrs_post_init__(self) -> None:
        xmin, ymin, xmax, ymax = self.bounds
        rows = [(xmin, ymin, xmax, ymin), (xmax, ymin, xmax, ymax),
                (xmax, ymax, xmin, ymax), (xmin, ymax, xmin, ymin)]
        rows += [(*w.a, *w.b) for w in self.walls]
        for polygon in self.polygons:
            rows += [(*polygon[i], *polygon[(i + 1) % len(polygon)]) for i in range(len(polygon))]
        landmarks = _discs([(m.x, m.y, m.radius) for m in self.landmarks])
        set_ = object.__setattr__
        set_(self, "static_segments", _segments(rows))
        set_(self, "landmark_array", landmarks)
        set_(self, "static_discs", np.concatenate([_discs(self.points), landmarks]))
        set_(self, "door_segments", _segments([(*d.a, *d.b) for d in self.doors]))
        for array in (self.static_segments, self.static_discs, self.landmark_array,
                      self.door_segments):
            array.flags.writeable = False

    @property
    def dynamic(self) -> bool:
        """Whether anything changes with time (doors or movers)."""
        return bool(self.doors or self.movers)

    def segments_at(self, t: float) -> np.ndarray:
        """The segments that block at time ``t``: the static ones and the shut doors."""
        if not self.doors:
            return self.static_segments
        shut = [not d.is_open(t) for d in self.doors]
        return np.concatenate([self.static_segments, self.door_segments[shut]])

    def discs_at(self, t: float, centres: Sequence[Point] | None = None) -> np.ndarray:
        """The discs that block at time ``t``: point obstacles, landmarks, movers present, at
        ``centres`` (one per mover; None: where their loops put them at ``t``)."""
        if not self.movers:
            return self.static_discs
        if centres is None:
            centres = [m.position(t) for m in self.movers]
        moving = [(*c, m.radius) for c, m in zip(centres, self.movers, strict=True)
                  if m.present(t)]
        return np.concatenate([self.static_discs, _discs(moving)])

    def obstacles_between(self, ids: Collection[str]) -> tuple[tuple[str, str], ...]:
        """The linear obstacles joining two of the landmarks ``ids``, as pairs of ids in the
        order of :attr:`walls` (002: a linear obstacle lies between two landmarks)."""
        wanted = set(ids)
        return tuple(w.between for w in self.walls
                     if w.between is not None and w.between[0] in wanted
                     and w.between[1] in wanted)

    def landmark(self, id: str) -> Landmark:
        for mark in self.landmarks:
            if mark.id == id:
                return mark
        raise KeyError(id)

    def inside(self, x: float, y: float) -> bool:
        """Whether ``(x, y)`` lies within the bounds."""
        xmin, ymin, xmax, ymax = self.bounds
        return xmin <= x <= xmax and ymin <= y <= ymax

    def point(self, text: str, where: str) -> Point:
        """The point ``text`` names: a place of the world or ``X,Y`` in metres; a CbrError
        naming ``where`` otherwise."""
        if text in self.places:
            return self.places[text]
        parts = text.split(",")
        try:
            x, y = (float(part) for part in parts)
        except ValueError:
            known = ", ".join(sorted(self.places)) or "none"
            raise CbrError(f"{where}: expected X,Y in metres or a place of the world "
                           f"(places: {known}), got {text!r}") from None
        if not (math.isfinite(x) and math.isfinite(y)):
            raise CbrError(f"{where}: expected finite coordinates, got {text!r}")
        return x, y


def world_of(ctx: Context, what: str) -> World:
    """The run's world, checked to be a 2D world; ``what`` names the component in the error."""
    if not isinstance(ctx.world, World):
        raise CbrError(f"{what} needs a 2D world (cbr_world2d); the configured world is "
                       f"{type(ctx.world).__name__}")
    return ctx.world
