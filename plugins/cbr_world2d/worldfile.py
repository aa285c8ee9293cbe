"""The YAML world file: its schema, reading it into a :class:`~cbr_world2d.world.World` with
every problem reported at once, and writing a world back.

A world file is a mapping (lengths in metres, times in seconds)::

    name: scenario 1
    bounds: [0, 0, 8, 6]                   # xmin, ymin, xmax, ymax: the four outer walls
    landmarks:
      - {id: l1, at: [3.5, 1.2], radius: 0.15}
      - {id: l2, at: [3.5, 3.9], radius: 0.15}
    walls:
      - {between: [l1, l2]}                # a linear obstacle joining the two landmarks' rims
      - {a: [6, 0], b: [6, 1]}
    polygons: [[[1, 1], [2, 1], [2, 2]]]  # solid obstacles, vertices in order
    points: [{at: [5, 5], radius: 0.05}]   # small point obstacles
    doors: [{a: [7, 0], b: [8, 0], period: 30, open_for: 20}]   # phase drawn from the seed
    people: [{waypoints: [[1, 5], [7, 5]], speed: 0.8, radius: 0.25}]
    movers: [{waypoints: [[4, 5]], speed: 0, radius: 0.3, kind: object, appears: 10}]
    places: {start: [1, 3], target: [6, 3]}
    seed: 7

Each section's keys are the fields of the schema classes below (:func:`schema_reference`
writes them out as the tables of the user docs). Reading is strict, as for configurations:
numbers must be numbers, unknown keys are refused, and every problem is reported in one
:class:`~cbrcore.errors.ConfigError`, each line naming the YAML path, its line and column, the
value and what was expected (``landmarks.3.radius (line 12, column 13): expected a positive
number, got -1``). Every number lies within ±:data:`MAX_MAGNITUDE`. After the types, the
geometry is checked: NaN or infinite numbers,
zero-length walls and doors, polygons with fewer than three vertices, no area or crossing
edges, anything outside the bounds, radii that are not positive, duplicate landmark ids, a
``between`` naming an unknown landmark, a door open longer than its period, a speed below 0
or above :data:`MAX_SPEED`, and a place outside the bounds or inside an obstacle.
"""

from __future__ import annotations

import functools
import math
import re
import typing
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, Literal, NewType, Protocol

import attrs
import numpy as np
import yaml

from cbr_world2d.world import Door, Landmark, Mover, Point, Wall, World
from cbrcore.config import read_yaml
from cbrcore.documents import found
from cbrcore.errors import ConfigError
from cbrcore.names import name_problem
from cbrcore.options import converter, option, option_problems

MIN_LENGTH = 1e-6
"""Walls, doors and polygon edges shorter than this (a micrometre) count as zero-length: the
geometry kernels divide by their lengths."""

MAX_MAGNITUDE = 1e6
"""The largest magnitude of a number in a world file: coordinates within a thousand
kilometres, times within 11 days. Beyond it the geometry's products and the plots' scales
lose all precision or overflow."""

MAX_SPEED = 100.0
"""The fastest a person or object of a world file may move, in metres per second: at a larger
speed one step of the simulation carries it through walls and robots unseen."""

XY = NewType("XY", tuple[float, float])
"""A point ``[x, y]`` of two finite numbers."""
Finite = NewType("Finite", float)
"""A finite number (NaN and infinities are refused)."""
Pair = NewType("Pair", tuple[str, str])
"""Two landmark ids."""
Box = NewType("Box", tuple[float, float, float, float])
"""Bounds ``[xmin, ymin, xmax, ymax]`` with ``xmin < xmax`` and ``ymin < ymax``."""

def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _num(value: float) -> str:
    """A number as an error shows it: integers without a decimal point, 15 digits at most."""
    try:
        return format(float(value), ".15g")
    except OverflowError:  # an integer past the largest float
        return found(value, setting=True)


def _finite(value: float) -> bool:
    """Whether ``value`` is finite; an integer always is, even one past the largest float."""
    return isinstance(value, int) or math.isfinite(value)


def _pt(point: Sequence[float]) -> str:
    return f"[{', '.join(_num(v) for v in point)}]"


def _numbers(value: Any, count: int, label: str) -> tuple[float, ...]:
    if not (isinstance(value, list | tuple) and len(value) == count
            and all(_number(v) for v in value)):
        raise TypeError(f"expected {label}, got {found(value, setting=True)}")
    if not all(_finite(v) for v in value):
        raise ValueError(f"expected {label} of finite numbers, got {_pt(value)}")
    if not all(abs(v) <= MAX_MAGNITUDE for v in value):
        raise ValueError(f"expected {label} of numbers within ±{MAX_MAGNITUDE:g} (the limit), "
                         f"got {_pt(value)}")
    return tuple(float(v) for v in value)


def _structure_xy(value: Any, _: type) -> tuple[float, float]:
    x, y = _numbers(value, 2, "a point [x, y]")
    return x, y


def _structure_finite(value: Any, _: type) -> float:
    if not _number(value):
        raise TypeError(f"expected a number, got {found(value, setting=True)}")
    if not _finite(value):
        raise ValueError(f"expected a finite number, got {_num(value)}")
    if abs(value) > MAX_MAGNITUDE:
        raise ValueError(f"expected a number within ±{MAX_MAGNITUDE:g} (the limit), got "
                         f"{_num(value)}")
    return float(value)


def _structure_pair(value: Any, _: type) -> tuple[str, str]:
    if not (isinstance(value, list | tuple) and len(value) == 2
            and all(isinstance(v, str) for v in value)):
        raise TypeError(f"expected two landmark ids [id1, id2], got {found(value, setting=True)}")
    return value[0], value[1]


def _structure_box(value: Any, _: type) -> tuple[float, float, float, float]:
    xmin, ymin, xmax, ymax = _numbers(value, 4, "bounds [xmin, ymin, xmax, ymax]")
    if not (xmin < xmax and ymin < ymax):
        raise ValueError(f"expected bounds [xmin, ymin, xmax, ymax] with xmin < xmax and "
                         f"ymin < ymax, got {_pt(value)}")
    return xmin, ymin, xmax, ymax


# the hooks are for this module's own types, so registering them leaves every other option alone
converter.register_structure_hook(XY, _structure_xy)
converter.register_structure_hook(Finite, _structure_finite)
converter.register_structure_hook(Pair, _structure_pair)
converter.register_structure_hook(Box, _structure_box)


@attrs.frozen
class WallSpec:
    """A wall or linear obstacle: the segment from ``a`` to ``b``, or ``between`` two landmarks
    (then the segment joins the points of their rims that face each other)."""

    a: XY | None = option(None, "One end [x, y] (with `b`).")
    b: XY | None = option(None, "The other end [x, y] (with `a`).")
    between: Pair | None = option(
        None, "Two landmark ids [id1, id2], instead of `a` and `b`: a linear obstacle joining "
        "their rims (002, Figure 1).")


@attrs.frozen
class PointSpec:
    """A small point obstacle (a disc) the pilot avoids alone (002, section 2)."""

    at: XY = option(doc="The centre [x, y].")
    radius: Finite = option(doc="The radius (> 0).")


@attrs.frozen
class LandmarkSpec:
    """A landmark: a disc the camera recognises by its id."""

    id: str = option(doc="A non-empty identifier, unique in the world.")
    at: XY = option(doc="The centre [x, y].")
    radius: Finite = option(doc="The radius (> 0).")


@attrs.frozen
class DoorSpec:
    """A door: a segment that is an obstacle while shut; it is open while
    ``(t + phase) mod period < open_for``."""

    a: XY = option(doc="One end [x, y].")
    b: XY = option(doc="The other end [x, y].")
    period: Finite = option(doc="Seconds of one open-and-shut cycle (> 0).")
    open_for: Finite = option(doc="Seconds it is open in each cycle, from 0 (always shut) to "
                              "`period` (always open).")
    phase: Finite | None = option(
        None, "Seconds the schedule is advanced; left out, drawn uniformly from [0, period) "
        "with the world's seed.")
    name: str = option("", "A name for messages and plots.")


@attrs.frozen
class MoverSpec:
    """A mover walking the closed loop of its waypoints (back to the first after the last)."""

    waypoints: list[XY] = option(doc="The loop's points [[x, y], ...]; one point: it stands "
                                 "still.")
    speed: Finite = option(doc="Metres per second along the loop (>= 0).")
    radius: Finite = option(doc="The radius of its disc (> 0).")
    kind: Literal["person", "object"] = option(
        "object", "`person` or `object` (a transient object: a cart, a box).")
    appears: Finite = option(0.0, "When it appears, at its first waypoint (seconds).")
    leaves: Finite | None = option(None, "When it leaves (seconds, after `appears`); left "
                                   "out, it stays.")
    yields: bool = option(False, "Whether it stops while the robot is in its way, as people "
                                 "do (up to 5 s, then it walks on); false: it walks its loop "
                                 "regardless.")


@attrs.frozen
class PersonSpec(MoverSpec):
    """A person: a mover whose ``kind`` defaults to ``person``."""

    kind: Literal["person", "object"] = option(
        "person", "`person` or `object`; written under `people`, `person` unless said.")


@attrs.frozen
class WorldFileSpec:
    """The world file's top-level keys; only ``bounds`` is required."""

    bounds: Box = option(doc="[xmin, ymin, xmax, ymax]: the four outer walls.")
    name: str = option("", "The world's name (a loaded file's stem when left out).")
    seed: int = option(0, "The seed (>= 0) door phases left out are drawn from.")
    landmarks: list[LandmarkSpec] = option(factory=list, doc="Landmarks.")
    walls: list[WallSpec] = option(factory=list, doc="Walls and linear obstacles.")
    polygons: list[list[XY]] = option(
        factory=list, doc="Solid obstacles, each a list of at least three vertices [[x, y], "
        "...] in order (either way round), its edges not crossing.")
    points: list[PointSpec] = option(factory=list, doc="Point obstacles.")
    doors: list[DoorSpec] = option(factory=list, doc="Doors on schedules.")
    people: list[PersonSpec] = option(factory=list, doc="People (movers of kind person).")
    movers: list[MoverSpec] = option(factory=list, doc="Movers: people and transient objects.")
    places: dict[str, XY] = option(
        factory=dict, doc="Named points {name: [x, y]}, inside the bounds and outside every "
        "obstacle, for starts and targets.")


SECTIONS: dict[str, type] = {
    "world file": WorldFileSpec, "landmarks": LandmarkSpec, "walls": WallSpec,
    "points": PointSpec, "doors": DoorSpec, "people": PersonSpec, "movers": MoverSpec}
"""The schema classes by the section they describe, in the order the docs list them."""


class Marks(Protocol):
    """Where YAML paths were written: ``where("landmarks.3")`` gives `` (line L, column C)``,
    ``top()`` that of the document, and ``unknown_key`` a problem line locating a key without
    quoting it (as :func:`cbrcore.config.read_yaml` returns)."""

    def where(self, path: str) -> str: ...

    def top(self) -> str: ...

    def unknown_key(self, path: str, message: str) -> str: ...


class _NoMarks:
    def where(self, path: str) -> str:
        return ""

    def top(self) -> str:
        return ""

    def unknown_key(self, path: str, message: str) -> str:
        return f"{path}: {message}"


Problems = list[tuple[str, str]]


# --- structuring ---------------------------------------------------------------------------------

@functools.cache
def _holder(kind: Any) -> type:
    """An attrs class with one field ``value`` of ``kind``, to structure a bare value with the
    options' converter and its path-labelled problems."""
    return attrs.make_class("Value", {"value": attrs.field(type=kind)}, frozen=True)


def _structure_one(kind: Any, raw: Any, path: str, problems: Problems) -> Any:
    """``raw`` structured as ``kind``, or None with its problems appended."""
    if attrs.has(kind):
        value, found = option_problems(kind, raw, path)
        if not found:
            return value
    else:
        holder, found = option_problems(_holder(kind), {"value": raw}, path)
        if not found:
            return holder.value
        found = [(where.replace(f"{path}.value", path, 1), message) for where, message in found]
    problems.extend(found)
    return None


def _fields() -> dict[str, attrs.Attribute[Any]]:
    return attrs.fields_dict(attrs.resolve_types(WorldFileSpec))


def _structure(data: Mapping[str, Any], problems: Problems) -> dict[str, Any]:
    """Each top-level key structured on its own, and each list item and place on its own, so
    that one bad item hides nothing else; list sections become ``[(index, item), ...]`` of the
    items that structured, ``places`` a mapping of those that did."""
    fields = _fields()
    values: dict[str, Any] = {}
    for name, field in fields.items():
        raw = data.get(name)
        origin, args = typing.get_origin(field.type), typing.get_args(field.type)
        if raw is None:
            if field.default is attrs.NOTHING:
                problems.append((name, "required key is missing; expected [xmin, ymin, xmax, "
                                       "ymax]"))
                values[name] = None
            elif origin is list:
                values[name] = []
            elif origin is dict:
                values[name] = {}
            else:
                values[name] = field.default
        elif origin is list:
            if not isinstance(raw, list):
                problems.append((name, f"expected a list, got {found(raw, setting=True)}"))
                values[name] = []
                continue
            items = ((i, _structure_one(args[0], item, f"{name}.{i}", problems))
                     for i, item in enumerate(raw))
            values[name] = [(i, item) for i, item in items if item is not None]
        elif origin is dict:
            if not isinstance(raw, Mapping):
                problems.append((name, f"expected a mapping of names to points, got "
                                       f"{found(raw, setting=True)}"))
                values[name] = {}
                continue
            places = {}
            for key, item in raw.items():
                if not isinstance(key, str) or not key:
                    # YAML 1.1 reads yes/no/on/off as booleans
                    hint = "; quote it" if isinstance(key, bool) else ""
                    problems.append((f"{name}.{key}", f"expected a place name (a non-empty "
                                                      f"string), got {key!r}{hint}"))
                    continue
                problem = name_problem(key)
                if problem is not None:
                    # the path would print the character itself
                    problems.append((name, f"expected place names, but {problem}"))
                    continue
                point = _structure_one(args[1], item, f"{name}.{key}", problems)
                if point is not None:
                    places[key] = point
            values[name] = places
        else:
            value = _structure_one(field.type, raw, name, problems)
            # a bad name or seed is reported; its default lets the other checks go on
            keep = value is None and field.default is not attrs.NOTHING
            values[name] = field.default if keep else value
    return values


# --- geometry checks -----------------------------------------------------------------------------

def _box(bounds: Sequence[float]) -> str:
    return _pt(bounds)


def _in_bounds(bounds: Sequence[float] | None, x: float, y: float, margin: float = 0.0) -> bool:
    if bounds is None:
        return True  # the bounds are wrong themselves, and reported
    xmin, ymin, xmax, ymax = bounds
    return xmin + margin <= x <= xmax - margin and ymin + margin <= y <= ymax - margin


def _check_point(bounds: Sequence[float] | None, point: Point, path: str,
                 problems: Problems) -> None:
    if not _in_bounds(bounds, *point):
        assert bounds is not None
        problems.append((path, f"expected a point inside the bounds {_box(bounds)}, got "
                               f"{_pt(point)}"))


def _check_disc(bounds: Sequence[float] | None, at: Point, radius: float, path: str,
                problems: Problems) -> None:
    if radius <= 0:
        problems.append((f"{path}.radius", f"expected a positive number, got {_num(radius)}"))
    elif not _in_bounds(bounds, *at, radius):
        assert bounds is not None
        problems.append((f"{path}.at", f"expected a disc inside the bounds {_box(bounds)}, got "
                                       f"centre {_pt(at)} and radius {_num(radius)}"))


def _check_segment(bounds: Sequence[float] | None, a: Point, b: Point, path: str,
                   problems: Problems) -> bool:
    _check_point(bounds, a, f"{path}.a", problems)
    _check_point(bounds, b, f"{path}.b", problems)
    if math.hypot(b[0] - a[0], b[1] - a[1]) < MIN_LENGTH:
        problems.append((f"{path}.b", f"expected an end apart from a {_pt(a)} (a zero-length "
                                      f"segment), got {_pt(b)}"))
        return False
    return True


def _orient(ox: np.ndarray, oy: np.ndarray, ax: np.ndarray, ay: np.ndarray, bx: np.ndarray,
            by: np.ndarray) -> np.ndarray:
    return np.sign((ax - ox) * (by - oy) - (ay - oy) * (bx - ox))


def _on_box(p: np.ndarray, qx: np.ndarray, qy: np.ndarray) -> np.ndarray:
    """Whether ``(qx, qy)``, collinear with segment ``p``, lies within its bounding box."""
    return ((np.minimum(p[:, 0], p[:, 2]) <= qx) & (qx <= np.maximum(p[:, 0], p[:, 2]))
            & (np.minimum(p[:, 1], p[:, 3]) <= qy) & (qy <= np.maximum(p[:, 1], p[:, 3])))


def segments_meet(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Whether the closed segments ``p[i]`` and ``q[i]`` (rows ``x0, y0, x1, y1``) share a
    point, touching included; exact orientation tests, vectorised over the rows."""
    d1 = _orient(q[:, 0], q[:, 1], q[:, 2], q[:, 3], p[:, 0], p[:, 1])
    d2 = _orient(q[:, 0], q[:, 1], q[:, 2], q[:, 3], p[:, 2], p[:, 3])
    d3 = _orient(p[:, 0], p[:, 1], p[:, 2], p[:, 3], q[:, 0], q[:, 1])
    d4 = _orient(p[:, 0], p[:, 1], p[:, 2], p[:, 3], q[:, 2], q[:, 3])
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)
    touch = (((d1 == 0) & _on_box(q, p[:, 0], p[:, 1])) | ((d2 == 0) & _on_box(q, p[:, 2], p[:, 3]))
             | ((d3 == 0) & _on_box(p, q[:, 0], q[:, 1]))
             | ((d4 == 0) & _on_box(p, q[:, 2], q[:, 3])))
    return proper | touch


def polygon_problem(vertices: np.ndarray) -> tuple[int | None, str] | None:
    """Why the vertices ``(k, 2)`` do not make a simple polygon, as ``(vertex index or None,
    message)``, or None when they do: fewer than three vertices, two consecutive ones the same,
    no area, or edges that cross, touch or fold back on each other."""
    k = len(vertices)
    if k < 3:
        return None, f"expected at least 3 vertices [x, y], got {k}"
    nxt = np.roll(vertices, -1, axis=0)
    lengths = np.hypot(*(nxt - vertices).T)
    if (short := np.flatnonzero(lengths < MIN_LENGTH)).size:
        i = int(short[0])
        return (i + 1) % k, (f"expected a vertex apart from vertex {i} {_pt(vertices[i])}, got "
                             f"{_pt(vertices[(i + 1) % k])}")
    edges = np.concatenate([vertices, nxt], axis=1)
    # consecutive edges share a vertex; they overlap only when they fold straight back
    before, after = vertices - np.roll(vertices, 1, axis=0), nxt - vertices
    cross = before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0]
    dot = (before * after).sum(axis=1)
    if (fold := np.flatnonzero((cross == 0) & (dot < 0))).size:
        i = int(fold[0])
        return i, f"expected a simple polygon, got edges {(i - 1) % k} and {i} folding back at " \
                  f"vertex {i} {_pt(vertices[i])}"
    i, j = np.triu_indices(k, 2)
    apart = ~((i == 0) & (j == k - 1))
    i, j = i[apart], j[apart]
    meet = segments_meet(edges[i], edges[j])
    if meet.any():
        first = int(np.flatnonzero(meet)[0])
        return None, f"expected a simple polygon, got edges {i[first]} and {j[first]} crossing " \
                     "or touching"
    # a simple polygon has an area; this catches what rounding let through the tests above
    area = 0.5 * float(np.sum(vertices[:, 0] * nxt[:, 1] - nxt[:, 0] * vertices[:, 1]))
    extent = float(np.ptp(vertices, axis=0).max())
    if abs(area) <= 1e-12 * extent * extent:
        return None, f"expected a polygon with an area, got area {area:.3g}"
    return None


def _rim_wall(first: LandmarkSpec, second: LandmarkSpec) -> tuple[Point, Point] | None:
    """The segment joining the facing rim points of two landmarks, None when they overlap."""
    dx, dy = second.at[0] - first.at[0], second.at[1] - first.at[1]
    gap = math.hypot(dx, dy)
    if gap - first.radius - second.radius < MIN_LENGTH:
        return None
    ux, uy = dx / gap, dy / gap
    return ((first.at[0] + first.radius * ux, first.at[1] + first.radius * uy),
            (second.at[0] - second.radius * ux, second.at[1] - second.radius * uy))


def _door_phase(seed: int, index: int, period: float) -> float:
    # one stream per door, so that giving one door's phase leaves the others' alone
    return float(np.random.default_rng([seed, index]).uniform(0.0, period))


def _ids(raw: Any) -> set[str]:
    """The ids written in the raw landmarks list, the ones that failed to structure included,
    so that a bad landmark is not reported a second time as unknown by a wall."""
    if not isinstance(raw, list):
        return set()
    return {item["id"] for item in raw if isinstance(item, Mapping) and isinstance(
        item.get("id"), str)}


def _build(values: dict[str, Any], raw: Mapping[str, Any], seed: int,
           problems: Problems) -> World | None:
    """The world of the structured pieces, every geometry problem appended; None without
    bounds."""
    bounds = values["bounds"]
    if values["seed"] < 0:
        problems.append(("seed", f"expected a non-negative integer, got {values['seed']}"))
    landmarks: dict[str, LandmarkSpec] = {}
    marks = []
    for i, spec in values["landmarks"]:
        path = f"landmarks.{i}"
        if not spec.id:
            problems.append((f"{path}.id", "expected a non-empty string, got ''"))
        elif name_problem(spec.id) is not None:
            problems.append((f"{path}.id", f"expected a landmark id, but "
                                           f"{name_problem(spec.id)}"))
        elif spec.id in landmarks:
            first = next(j for j, s in values["landmarks"] if s.id == spec.id)
            problems.append((f"{path}.id", f"expected a unique landmark id, got {spec.id!r} "
                                           f"again (first at landmarks.{first})"))
        else:
            landmarks[spec.id] = spec
        _check_disc(bounds, spec.at, spec.radius, path, problems)
        marks.append(Landmark(spec.id, spec.at[0], spec.at[1], spec.radius))
    known = set(landmarks) | _ids(raw.get("landmarks"))
    walls = []
    for i, spec in values["walls"]:
        path = f"walls.{i}"
        has_ends = (spec.a is not None, spec.b is not None)
        if spec.between is not None:
            if any(has_ends):
                problems.append((path, "expected either a and b or between, got both"))
                continue
            first, second = spec.between
            missing = [(k, name) for k, name in enumerate(spec.between) if name not in known]
            for k, name in missing:
                listed = ", ".join(sorted(known)[:20]) or "none"
                problems.append((f"{path}.between.{k}", f"unknown landmark {name!r}; expected "
                                                        f"one of: {listed}"))
            if first == second:
                problems.append((f"{path}.between", f"expected two different landmarks, got "
                                                    f"{first!r} twice"))
            elif not missing and first in landmarks and second in landmarks:
                ends = _rim_wall(landmarks[first], landmarks[second])
                if ends is None:
                    problems.append((f"{path}.between", f"expected landmarks apart, got "
                                                        f"{first!r} and {second!r} touching or "
                                                        "overlapping"))
                else:
                    walls.append(Wall(*ends, between=(first, second)))
        elif all(has_ends):
            if _check_segment(bounds, spec.a, spec.b, path, problems):
                walls.append(Wall(spec.a, spec.b))
        else:
            got = "a only" if has_ends[0] else "b only" if has_ends[1] else "neither"
            problems.append((path, f"expected both a and b, or between, got {got}"))
    polygons = []
    for i, vertices in values["polygons"]:
        path = f"polygons.{i}"
        for j, vertex in enumerate(vertices):
            _check_point(bounds, vertex, f"{path}.{j}", problems)
        found = polygon_problem(np.asarray(vertices, dtype=float).reshape(-1, 2))
        if found is None:
            polygons.append(tuple(vertices))
        else:
            vertex, message = found
            problems.append((path if vertex is None else f"{path}.{vertex}", message))
    points = []
    for i, spec in values["points"]:
        _check_disc(bounds, spec.at, spec.radius, f"points.{i}", problems)
        points.append((spec.at[0], spec.at[1], spec.radius))
    doors = []
    for i, spec in values["doors"]:
        path = f"doors.{i}"
        fine = _check_segment(bounds, spec.a, spec.b, path, problems)
        if spec.period <= 0:
            problems.append((f"{path}.period", f"expected a positive number of seconds, got "
                                               f"{_num(spec.period)}"))
        elif not 0 <= spec.open_for <= spec.period:
            problems.append((f"{path}.open_for", f"expected seconds from 0 to the period "
                                                 f"{_num(spec.period)}, got "
                                                 f"{_num(spec.open_for)}"))
        elif fine:
            phase = (_door_phase(seed, i, spec.period) if spec.phase is None else spec.phase)
            doors.append(Door(spec.a, spec.b, spec.period, spec.open_for, phase, spec.name))
    movers = []
    for section in ("people", "movers"):
        for i, spec in values[section]:
            path = f"{section}.{i}"
            fine = True
            if not spec.waypoints:
                problems.append((f"{path}.waypoints", "expected at least one waypoint [x, y], "
                                                      "got none"))
                fine = False
            for j, point in enumerate(spec.waypoints):
                _check_point(bounds, point, f"{path}.waypoints.{j}", problems)
            if not 0 <= spec.speed <= MAX_SPEED:
                problems.append((f"{path}.speed", f"expected a speed from 0 to {MAX_SPEED:g} m/s "
                                                  f"(the limit), got {_num(spec.speed)}"))
                fine = False
            if spec.radius <= 0:
                problems.append((f"{path}.radius", f"expected a positive number, got "
                                                   f"{_num(spec.radius)}"))
                fine = False
            if spec.leaves is not None and spec.leaves <= spec.appears:
                problems.append((f"{path}.leaves", f"expected a time after appears "
                                                   f"({_num(spec.appears)}), got "
                                                   f"{_num(spec.leaves)}"))
            if fine:
                movers.append(Mover(tuple(spec.waypoints), spec.speed, spec.radius, spec.kind,
                                    spec.appears, spec.leaves, spec.yields))
    if bounds is None:
        return None
    world = World(bounds, tuple(walls), tuple(polygons), tuple(points), tuple(marks),
                  tuple(doors), tuple(movers), {}, values["name"])
    places = {}
    for name, point in values["places"].items():
        reason = free_point(world, *point)
        if reason is None:
            places[name] = point
        else:
            problems.append((f"places.{name}", f"expected a free point, got {_pt(point)}, which "
                                               f"{reason}"))
    return attrs.evolve(world, places=places)


def world_from_data(data: Any, source: str, marks: Marks | None = None, seed: int = 0) -> World:
    """The world described by ``data`` (a world file's parsed YAML).

    ``source`` names the data in errors; ``marks`` (from :func:`cbrcore.config.read_yaml`)
    adds the line and column of each problem; ``seed`` draws the door phases the data leaves
    out when it gives no ``seed`` of its own. Raises a :class:`ConfigError` listing every
    problem found.
    """
    marks = marks or _NoMarks()
    if not isinstance(data, Mapping):
        raise ConfigError(source, [f"the top level{marks.top()}: expected a world: a mapping "
                                   f"with at least bounds [xmin, ymin, xmax, ymax], got "
                                   f"{found(data)}"])
    fields = _fields()
    lines = [marks.unknown_key(str(key), f"unknown key; expected one of: {', '.join(fields)}")
             for key in data if key not in fields]
    problems: Problems = []
    values = _structure(data, problems)
    world = _build(values, data, values["seed"] if "seed" in data else seed, problems)
    if lines or problems or world is None:
        lines += [f"{path}{marks.where(path)}: {message}" for path, message in problems]
        # in the order of the file, whichever check found them
        raise ConfigError(source, sorted(lines, key=_position))
    return world


_MARK = re.compile(r"line (\d+), column (\d+)")


def _position(where: str) -> tuple[int, int]:
    found = _MARK.search(where)
    return (int(found[1]), int(found[2])) if found else (0, 0)


def load_world(path: str | Path) -> World:
    """The world of the YAML file at ``path`` (its stem names it unless it has a ``name``);
    a :class:`ConfigError` naming the file lists every problem."""
    path = Path(path)
    data, marks = read_yaml(path)
    world = world_from_data(data, str(path), marks)
    return world if world.name else attrs.evolve(world, name=path.stem)


# --- writing -------------------------------------------------------------------------------------

def _plain(point: Sequence[float]) -> list[float]:
    return [float(v) for v in point]


def _between_matches(world: World, wall: Wall) -> bool:
    """Whether the wall is exactly the rim segment its ``between`` names (then it is written as
    ``between``, and reading rebuilds the same floats)."""
    if wall.between is None:
        return False
    try:
        first, second = (world.landmark(id) for id in wall.between)
    except KeyError:
        return False
    ends = _rim_wall(LandmarkSpec(first.id, (first.x, first.y), first.radius),
                     LandmarkSpec(second.id, (second.x, second.y), second.radius))
    return ends is not None and ends == (tuple(wall.a), tuple(wall.b))


def dump_world(world: World) -> dict[str, Any]:
    """The world as plain data in the world file's format: :func:`world_from_data` of it gives
    the same world (every number written exactly, door phases included). A wall whose
    ``between`` no longer matches its landmarks' rims is written by its ends."""
    data: dict[str, Any] = {"name": world.name} if world.name else {}
    data["bounds"] = _plain(world.bounds)
    if world.landmarks:
        data["landmarks"] = [{"id": m.id, "at": [float(m.x), float(m.y)],
                              "radius": float(m.radius)} for m in world.landmarks]
    if world.walls:
        data["walls"] = [{"between": list(w.between)} if _between_matches(world, w)
                         else {"a": _plain(w.a), "b": _plain(w.b)} for w in world.walls]
    if world.polygons:
        data["polygons"] = [[_plain(v) for v in polygon] for polygon in world.polygons]
    if world.points:
        data["points"] = [{"at": _plain(p[:2]), "radius": float(p[2])} for p in world.points]
    if world.doors:
        data["doors"] = [{"a": _plain(d.a), "b": _plain(d.b), "period": float(d.period),
                          "open_for": float(d.open_for), "phase": float(d.phase),
                          **({"name": d.name} if d.name else {})} for d in world.doors]
    if world.movers:
        data["movers"] = [{"waypoints": [_plain(p) for p in m.waypoints],
                           "speed": float(m.speed), "radius": float(m.radius), "kind": m.kind,
                           "appears": float(m.appears),
                           **({"leaves": float(m.leaves)} if m.leaves is not None else {}),
                           **({"yields": True} if m.yields else {})}
                          for m in world.movers]
    if world.places:
        data["places"] = {name: _plain(point) for name, point in world.places.items()}
    return data


class _Flow(dict):  # type: ignore[type-arg]
    """A mapping written on one line."""


class _Dumper(yaml.SafeDumper):
    pass


def _represent_list(dumper: yaml.SafeDumper, data: list[Any]) -> yaml.Node:
    flat = all(_number(v) or (isinstance(v, list) and all(_number(w) for w in v)) for v in data)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flat and bool(data))


def _represent_flow(dumper: yaml.SafeDumper, data: _Flow) -> yaml.Node:
    return dumper.represent_mapping("tag:yaml.org,2002:map", data.items(), flow_style=True)


_Dumper.add_representer(list, _represent_list)
_Dumper.add_representer(_Flow, _represent_flow)


def world_yaml(world: World) -> str:
    """The world file text of ``world``: one line per item, points written ``[x, y]``."""
    data = dump_world(world)
    for key, value in data.items():
        if isinstance(value, list) and value and isinstance(value[0], dict):
            data[key] = [_Flow(item) for item in value]
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, width=100, allow_unicode=True)


def save_world(world: World, path: str | Path) -> None:
    """Write ``world`` as a world file at ``path``."""
    Path(path).write_text(world_yaml(world), encoding="utf-8")


# --- free points ---------------------------------------------------------------------------------

def segment_distances(x: float, y: float, segments: np.ndarray) -> np.ndarray:
    """The distance from ``(x, y)`` to each segment of ``segments`` ``(n, 4)``, ``(n,)``."""
    a = segments[:, :2]
    d = segments[:, 2:] - a
    p = np.array([x, y], dtype=float)
    length2 = (d * d).sum(axis=1)
    u = np.clip(((p - a) * d).sum(axis=1) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
    return np.hypot(*(a + u[:, None] * d - p).T)


def inside_polygon(x: float, y: float, polygon: np.ndarray) -> bool:
    """Whether ``(x, y)`` lies inside the polygon of vertices ``(k, 2)`` (even-odd rule: a ray
    from the point toward +x crosses its edges an odd number of times)."""
    xi, yi = polygon[:, 0], polygon[:, 1]
    xj, yj = np.roll(xi, 1), np.roll(yi, 1)
    spans = (yi > y) != (yj > y)
    # a horizontal edge spans nothing, so its division by zero is never counted
    with np.errstate(divide="ignore", invalid="ignore"):
        crossing = xi + (y - yi) * (xj - xi) / (yj - yi)
    return bool(np.count_nonzero(spans & (x < crossing)) % 2)


def _rows(items: Sequence[Sequence[float]], width: int) -> np.ndarray:
    return np.asarray(items, dtype=float).reshape(-1, width)


def _nearest(gaps: np.ndarray, radius: float) -> int | None:
    """The index of the first gap not above ``radius``, None when every gap is larger."""
    hit = np.flatnonzero(gaps <= radius)
    return int(hit[np.argmin(gaps[hit])]) if hit.size else None


def _phrase(gap: float, radius: float, label: str, solid: bool) -> str:
    if gap <= 0:
        return f"is {'inside' if solid else 'on'} {label}"
    return f"is {gap:.3g} m from {label}, within the radius {radius:g}"


def free_point(world: World, x: float, y: float, radius: float = 0.0,
               t: float | None = None) -> str | None:
    """Why a disc of ``radius`` at ``(x, y)`` cannot stand in ``world``, or None when it can.

    The reason is a phrase to follow the point (``"is inside polygon 2"``, ``"is 0.05 m from
    landmark 'l1', within the radius 0.2"``) naming the first thing in the way: the bounds,
    a polygon, a wall, a door (shut or open: it may shut), a point obstacle, a landmark, and,
    when ``t`` is given, a mover present at ``t``. Touching counts as in the way.
    """
    if not (math.isfinite(x) and math.isfinite(y)):
        return "is not a finite point"
    if not (math.isfinite(radius) and radius >= 0):
        raise ValueError(f"expected a non-negative radius, got {radius!r}")
    if not world.inside(x, y):
        return f"is outside the bounds {_box(world.bounds)}"
    xmin, ymin, xmax, ymax = world.bounds
    edge = min(x - xmin, xmax - x, y - ymin, ymax - y)
    if edge <= radius:
        return _phrase(edge, radius, f"the edge of the bounds {_box(world.bounds)}", False)
    for k, polygon in enumerate(world.polygons):
        vertices = _rows(polygon, 2)
        if inside_polygon(x, y, vertices):
            return f"is inside polygon {k}"
        gap = float(segment_distances(x, y, np.concatenate(
            [vertices, np.roll(vertices, -1, axis=0)], axis=1)).min())
        if gap <= radius:
            return _phrase(gap, radius, f"polygon {k}", False)
    checks: list[tuple[np.ndarray, Callable[[int], str], bool]] = [
        (segment_distances(x, y, _rows([(*w.a, *w.b) for w in world.walls], 4)),
         lambda i: _wall_label(world.walls[i], i), False),
        (segment_distances(x, y, world.door_segments),
         lambda i: f"door {world.doors[i].name or i}", False),
        (_disc_gaps(x, y, _rows(world.points, 3)), lambda i: f"point obstacle {i}", True),
        (_disc_gaps(x, y, world.landmark_array),
         lambda i: f"landmark {world.landmarks[i].id!r}", True)]
    if t is not None:
        present = [m for m in world.movers if m.present(t)]
        where = [m.position(t) for m in present]
        checks.append((_disc_gaps(x, y, _rows([(*p, m.radius) for p, m in zip(
            where, present, strict=True)], 3)),
            lambda i: f"a {present[i].kind} at {_pt(where[i])} at t = {t:g}", True))
    for gaps, label, solid in checks:
        hit = _nearest(gaps, radius)
        if hit is not None:
            return _phrase(float(gaps[hit]), radius, label(hit), solid)
    return None


def _disc_gaps(x: float, y: float, discs: np.ndarray) -> np.ndarray:
    return np.hypot(discs[:, 0] - x, discs[:, 1] - y) - discs[:, 2]


def _wall_label(wall: Wall, index: int) -> str:
    if wall.between is not None:
        return f"wall {index} (between {wall.between[0]!r} and {wall.between[1]!r})"
    return f"wall {index} from {_pt(wall.a)} to {_pt(wall.b)}"


# --- the schema as docs --------------------------------------------------------------------------

_TYPE_TEXT: dict[Any, str] = {
    XY: "[x, y]", Finite: "number", Pair: "[id, id]", Box: "[xmin, ymin, xmax, ymax]",
    str: "string", int: "integer", float: "number", bool: "true or false"}


def _type_text(kind: Any) -> str:
    if kind in _TYPE_TEXT:
        return _TYPE_TEXT[kind]
    origin, args = typing.get_origin(kind), typing.get_args(kind)
    if origin is Literal:
        return " or ".join(f"`{a}`" for a in args)
    if origin is list:
        inner = args[0]
        if attrs.has(inner):
            return "list (items below)"
        return f"list of {_type_text(inner)}"
    if origin is dict:
        return f"mapping of names to {_type_text(args[1])}"
    if args and type(None) in args:
        return " or ".join(_type_text(a) for a in args if a is not type(None))
    return str(kind)


def schema_reference() -> str:
    """The world file's keys as markdown tables, one per section (the docs page shows this)."""
    lines: list[str] = []
    for section, cls in SECTIONS.items():
        lines += [f"##### {section}", "", " ".join(cls.__doc__.split()), "",
                  "| key | type | default | meaning |", "|---|---|---|---|"]
        for field in attrs.fields(attrs.resolve_types(cls)):
            if field.default is attrs.NOTHING:
                default = "required"
            elif isinstance(field.default, attrs.Factory):  # type: ignore[arg-type]
                default = f"`{field.default.factory()!r}`"
            else:
                default = "left out" if field.default is None else f"`{field.default!r}`"
            meaning = " ".join(field.metadata.get("doc", "").split())
            lines.append(f"| `{field.name}` | {_type_text(field.type)} | {default} | "
                         f"{meaning} |")
        lines.append("")
    return "\n".join(lines)
