"""The YAML world file: its schema, and reading it into a :class:`~cbr_world2d.world.World`
with every problem reported at once (:mod:`cbr_world2d.worldfile_writer` writes a world back).

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
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, Literal, NewType, Protocol, TypeVar

import attrs
import numpy as np

from cbr_world2d.checks import number_text, point_text
from cbr_world2d.shapes import MIN_LENGTH, free_point, polygon_problem, rim_wall
from cbr_world2d.world import Door, Landmark, Mover, Point, Wall, World
from cbrcore.config import read_yaml
from cbrcore.documents import found
from cbrcore.errors import ConfigError
from cbrcore.names import name_problem
from cbrcore.options import converter, option, option_problems

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

def is_number(value: Any) -> bool:
    """Whether ``value`` is a number as YAML writes one (a boolean is not)."""
    return isinstance(value, int | float) and not isinstance(value, bool)


def _finite(value: float) -> bool:
    """Whether ``value`` is finite; an integer always is, even one past the largest float."""
    return isinstance(value, int) or math.isfinite(value)


def _numbers(value: Any, count: int, label: str) -> tuple[float, ...]:
    if not (isinstance(value, list | tuple) and len(value) == count
            and all(is_number(v) for v in value)):
        raise TypeError(f"expected {label}, got {found(value, setting=True)}")
    if not all(_finite(v) for v in value):
        raise ValueError(f"expected {label} of finite numbers, got {point_text(value)}")
    if not all(abs(v) <= MAX_MAGNITUDE for v in value):
        raise ValueError(f"expected {label} of numbers within ±{MAX_MAGNITUDE:g} (the limit), "
                         f"got {point_text(value)}")
    return tuple(float(v) for v in value)


def _structure_xy(value: Any, _: type) -> tuple[float, float]:
    x, y = _numbers(value, 2, "a point [x, y]")
    return x, y


def _structure_finite(value: Any, _: type) -> float:
    if not is_number(value):
        raise TypeError(f"expected a number, got {found(value, setting=True)}")
    if not _finite(value):
        raise ValueError(f"expected a finite number, got {number_text(value)}")
    if abs(value) > MAX_MAGNITUDE:
        raise ValueError(f"expected a number within ±{MAX_MAGNITUDE:g} (the limit), got "
                         f"{number_text(value)}")
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
                         f"ymin < ymax, got {point_text(value)}")
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
T = TypeVar("T")
Bounds = Sequence[float] | None
"""A world file's bounds, None when they are wrong themselves (and reported)."""


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



def _in_bounds(bounds: Bounds, x: float, y: float, margin: float = 0.0) -> bool:
    if bounds is None:
        return True  # the bounds are wrong themselves, and reported
    xmin, ymin, xmax, ymax = bounds
    return xmin + margin <= x <= xmax - margin and ymin + margin <= y <= ymax - margin


def _check_point(bounds: Bounds, point: Point, path: str,
                 problems: Problems) -> None:
    if not _in_bounds(bounds, *point):
        assert bounds is not None
        problems.append((path, f"expected a point inside the bounds {point_text(bounds)}, got "
                               f"{point_text(point)}"))


def _check_disc(bounds: Bounds, at: Point, radius: float, path: str,
                problems: Problems) -> None:
    if radius <= 0:
        problems.append((f"{path}.radius", f"expected a positive number, got "
                                           f"{number_text(radius)}"))
    elif not _in_bounds(bounds, *at, radius):
        assert bounds is not None
        problems.append((f"{path}.at", f"expected a disc inside the bounds "
                                       f"{point_text(bounds)}, got centre {point_text(at)} and "
                                       f"radius {number_text(radius)}"))


def _check_segment(bounds: Bounds, a: Point, b: Point, path: str,
                   problems: Problems) -> bool:
    _check_point(bounds, a, f"{path}.a", problems)
    _check_point(bounds, b, f"{path}.b", problems)
    if math.hypot(b[0] - a[0], b[1] - a[1]) < MIN_LENGTH:
        problems.append((f"{path}.b", f"expected an end apart from a {point_text(a)} (a "
                                      f"zero-length segment), got {point_text(b)}"))
        return False
    return True


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
    landmarks, marks = _landmarks(values["landmarks"], bounds, problems)
    known = set(landmarks) | _ids(raw.get("landmarks"))
    walls = _made(_wall(spec, f"walls.{i}", bounds, landmarks, known, problems)
                  for i, spec in values["walls"])
    polygons = _made(_polygon(vertices, f"polygons.{i}", bounds, problems)
                     for i, vertices in values["polygons"])
    points = []
    for i, spec in values["points"]:
        _check_disc(bounds, spec.at, spec.radius, f"points.{i}", problems)
        points.append((spec.at[0], spec.at[1], spec.radius))
    doors = _made(_door(spec, i, seed, bounds, problems) for i, spec in values["doors"])
    movers = _made(_mover(spec, f"{section}.{i}", bounds, problems)
                   for section in ("people", "movers") for i, spec in values[section])
    if bounds is None:
        return None
    world = World(bounds, walls, polygons, tuple(points), tuple(marks), doors, movers, {},
                  values["name"])
    return attrs.evolve(world, places=_places(world, values["places"], problems))


def _made(built: Iterable[T | None]) -> tuple[T, ...]:
    """The items built, without those that were not (their problems are reported)."""
    return tuple(item for item in built if item is not None)


def _landmarks(items: list[tuple[int, LandmarkSpec]], bounds: Bounds,
               problems: Problems) -> tuple[dict[str, Landmark], list[Landmark]]:
    """The landmarks by id (those whose id is good and unique) and all of them, in order."""
    landmarks: dict[str, Landmark] = {}
    marks = []
    for i, spec in items:
        path = f"landmarks.{i}"
        mark = Landmark(spec.id, spec.at[0], spec.at[1], spec.radius)
        if not spec.id:
            problems.append((f"{path}.id", "expected a non-empty string, got ''"))
        elif name_problem(spec.id) is not None:
            problems.append((f"{path}.id", f"expected a landmark id, but "
                                           f"{name_problem(spec.id)}"))
        elif spec.id in landmarks:
            first = next(j for j, s in items if s.id == spec.id)
            problems.append((f"{path}.id", f"expected a unique landmark id, got {spec.id!r} "
                                           f"again (first at landmarks.{first})"))
        else:
            landmarks[spec.id] = mark
        _check_disc(bounds, spec.at, spec.radius, path, problems)
        marks.append(mark)
    return landmarks, marks


def _wall(spec: WallSpec, path: str, bounds: Bounds, landmarks: Mapping[str, Landmark],
          known: set[str], problems: Problems) -> Wall | None:
    """The wall ``spec`` describes, or None with its problems appended. ``known`` holds every
    landmark id written, ``landmarks`` those that make a wall."""
    has_ends = (spec.a is not None, spec.b is not None)
    if spec.between is not None:
        if any(has_ends):
            problems.append((path, "expected either a and b or between, got both"))
            return None
        return _between(spec.between, path, landmarks, known, problems)
    if all(has_ends):
        if _check_segment(bounds, spec.a, spec.b, path, problems):
            return Wall(spec.a, spec.b)
        return None
    got = "a only" if has_ends[0] else "b only" if has_ends[1] else "neither"
    problems.append((path, f"expected both a and b, or between, got {got}"))
    return None


def _between(pair: tuple[str, str], path: str, landmarks: Mapping[str, Landmark],
             known: set[str], problems: Problems) -> Wall | None:
    """The linear obstacle joining the rims of the landmarks ``pair`` names, or None with its
    problems appended."""
    first, second = pair
    missing = [(k, name) for k, name in enumerate(pair) if name not in known]
    for k, name in missing:
        listed = ", ".join(sorted(known)[:20]) or "none"
        problems.append((f"{path}.between.{k}", f"unknown landmark {name!r}; expected "
                                                f"one of: {listed}"))
    if first == second:
        problems.append((f"{path}.between", f"expected two different landmarks, got "
                                            f"{first!r} twice"))
        return None
    if missing or first not in landmarks or second not in landmarks:
        return None
    ends = rim_wall(landmarks[first], landmarks[second])
    if ends is None:
        problems.append((f"{path}.between", f"expected landmarks apart, got {first!r} and "
                                            f"{second!r} touching or overlapping"))
        return None
    return Wall(*ends, between=(first, second))


def _polygon(vertices: list[Point], path: str, bounds: Bounds,
             problems: Problems) -> tuple[Point, ...] | None:
    for j, vertex in enumerate(vertices):
        _check_point(bounds, vertex, f"{path}.{j}", problems)
    found = polygon_problem(np.asarray(vertices, dtype=float).reshape(-1, 2))
    if found is None:
        return tuple(vertices)
    vertex, message = found
    problems.append((path if vertex is None else f"{path}.{vertex}", message))
    return None


def _door(spec: DoorSpec, index: int, seed: int, bounds: Bounds,
          problems: Problems) -> Door | None:
    path = f"doors.{index}"
    fine = _check_segment(bounds, spec.a, spec.b, path, problems)
    if spec.period <= 0:
        problems.append((f"{path}.period", f"expected a positive number of seconds, got "
                                           f"{number_text(spec.period)}"))
    elif not 0 <= spec.open_for <= spec.period:
        problems.append((f"{path}.open_for", f"expected seconds from 0 to the period "
                                             f"{number_text(spec.period)}, got "
                                             f"{number_text(spec.open_for)}"))
    elif fine:
        phase = _door_phase(seed, index, spec.period) if spec.phase is None else spec.phase
        return Door(spec.a, spec.b, spec.period, spec.open_for, phase, spec.name)
    return None


def _mover(spec: MoverSpec, path: str, bounds: Bounds, problems: Problems) -> Mover | None:
    fine = True
    if not spec.waypoints:
        problems.append((f"{path}.waypoints", "expected at least one waypoint [x, y], got none"))
        fine = False
    for j, point in enumerate(spec.waypoints):
        _check_point(bounds, point, f"{path}.waypoints.{j}", problems)
    if not 0 <= spec.speed <= MAX_SPEED:
        problems.append((f"{path}.speed", f"expected a speed from 0 to {MAX_SPEED:g} m/s (the "
                                          f"limit), got {number_text(spec.speed)}"))
        fine = False
    if spec.radius <= 0:
        problems.append((f"{path}.radius", f"expected a positive number, got "
                                           f"{number_text(spec.radius)}"))
        fine = False
    if spec.leaves is not None and spec.leaves <= spec.appears:
        problems.append((f"{path}.leaves", f"expected a time after appears "
                                           f"({number_text(spec.appears)}), got "
                                           f"{number_text(spec.leaves)}"))
    if not fine:
        return None
    return Mover(tuple(spec.waypoints), spec.speed, spec.radius, spec.kind, spec.appears,
                 spec.leaves, spec.yields)


def _places(world: World, places: Mapping[str, Point], problems: Problems) -> dict[str, Point]:
    """The places that stand free in ``world``, the others' problems appended."""
    free = {}
    for name, point in places.items():
        reason = free_point(world, *point)
        if reason is None:
            free[name] = point
        else:
            problems.append((f"places.{name}", f"expected a free point, got "
                                               f"{point_text(point)}, which {reason}"))
    return free


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
