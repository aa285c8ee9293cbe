"""Seeded world generators: semi-structured landmark worlds (002, Figure 1), worlds like 002's
scenarios (Figure 7) and office floors (004's building).

Each generator draws every choice from ``numpy.random.default_rng(seed)``, so one seed always
gives the same world, writes the world as world file data and reads it back with
:func:`cbr_world2d.worldfile.world_from_data`: a generated world passes the same checks as a
file, and :func:`~cbr_world2d.worldfile_writer.world_yaml` writes it out as one. Coordinates are
rounded to the millimetre and times to the tenth of a second, so the files read well.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import attrs
import numpy as np

from cbr_world2d.geometry import clearance
from cbr_world2d.world import World
from cbr_world2d.worldfile import world_from_data
from cbrcore.errors import CbrError

Seed = int | np.random.SeedSequence
"""What the generators accept as a seed (a run derives independent ones with ``spawn``)."""

Cell = tuple[int, int]
Edge = tuple[Cell, Cell]

SHAPES: dict[str, tuple[Edge, ...]] = {
    "dead_end": (((0, 2), (0, 1)), ((0, 1), (0, 0)), ((0, 0), (1, 0)), ((1, 0), (1, 1)),
                 ((1, 1), (1, 2))),
    "u_shape": (((0, 1), (0, 0)), ((0, 0), (1, 0)), ((1, 0), (1, 1))),
    "corner": (((0, 1), (0, 0)), ((0, 0), (1, 0))),
    "wall": (((0, 0), (1, 0)), ((1, 0), (2, 0))),
}
"""The shapes :func:`semi_structured` places on purpose, as links between lattice nodes
``(column, row)`` before rotation: a dead end (a corridor one cell wide and two long, closed at
one end), a U, a corner and a straight wall."""


def _mm(value: float) -> float:
    return round(float(value), 3)


def _name(kind: str, seed: Seed) -> str:
    return f"{kind} {seed}" if isinstance(seed, int) else kind


def _rotations(edges: Sequence[Edge]) -> Iterator[tuple[Edge, ...]]:
    """The shape turned by 0, 90, 180 and 270 degrees, shifted to non-negative offsets."""
    for turn in range(4):
        def rotate(cell: Cell, turn: int = turn) -> Cell:
            i, j = cell
            for _ in range(turn):
                i, j = -j, i
            return i, j

        turned = [(rotate(a), rotate(b)) for a, b in edges]
        low_i = min(min(a[0], b[0]) for a, b in turned)
        low_j = min(min(a[1], b[1]) for a, b in turned)
        yield tuple(((a[0] - low_i, a[1] - low_j), (b[0] - low_i, b[1] - low_j))
                    for a, b in turned)


def _place_shapes(rng: np.random.Generator, columns: int, rows: int, count: int,
                  ) -> tuple[list[Edge], set[Cell]]:
    """Links for ``count`` shapes, cycling through :data:`SHAPES`, each on nodes no other shape
    uses or neighbours (so shapes stay apart and close no region off); a shape that finds no
    room is left out."""
    links: list[Edge] = []
    used: set[Cell] = set()
    halo: set[Cell] = set()
    kinds = list(SHAPES)
    for n in range(count):
        options = [(rotated, (i, j)) for rotated in _rotations(SHAPES[kinds[n % len(kinds)]])
                   for i in range(columns) for j in range(rows)]
        for k in rng.permutation(len(options)):
            rotated, (i, j) = options[int(k)]
            placed = [((a[0] + i, a[1] + j), (b[0] + i, b[1] + j)) for a, b in rotated]
            nodes = {cell for edge in placed for cell in edge}
            if all(0 <= c[0] < columns and 0 <= c[1] < rows for c in nodes) and not (
                    nodes & halo):
                links += placed
                used |= nodes
                halo |= {(c[0] + di, c[1] + dj) for c in nodes for di in (-1, 0, 1)
                         for dj in (-1, 0, 1)}
                break
    return links, used


def _free_spot(rng: np.random.Generator, low: Sequence[float], high: Sequence[float],
               radius: float, room: float, segments: np.ndarray, discs: np.ndarray,
               avoid: Sequence[tuple[float, float, float]], tries: int = 200,
               ) -> tuple[float, float] | None:
    """A point drawn in the box ``low``-``high`` whose disc of ``radius`` keeps ``room`` from
    every segment and disc and stays outside each ``avoid`` circle ``(x, y, distance)``."""
    for _ in range(tries):
        x, y = _mm(rng.uniform(low[0], high[0])), _mm(rng.uniform(low[1], high[1]))
        if clearance(x, y, segments, discs) < radius + room:
            continue
        if all(math.hypot(x - ax, y - ay) >= far for ax, ay, far in avoid):
            return x, y
    return None


SCENES = ("v", "u", "wall", "corridor", "gap", "room")
"""The obstacles :func:`scenario` puts in the way, by seed: a V open towards the start (002's
scenario 2), a U open towards the start, a straight wall (002's scenario 1), a dead-end corridor
open towards the start, a wall with a gap to one side, and a room whose door faces away from
the target (toward the start)."""


def _scene_shape(kind: str, rng: np.random.Generator, size: float
                 ) -> tuple[list[tuple[float, float]], list[tuple[int, int]]]:
    """The landmarks of the shape ``kind`` in its own frame (x toward the target, the shape's
    centre at the origin) and the pairs of them its linear obstacles join."""
    if kind == "v":
        spread = math.radians(rng.uniform(35.0, 50.0))
        marks = [(-size * math.cos(spread), size * math.sin(spread)), (0.0, 0.0),
                 (-size * math.cos(spread), -size * math.sin(spread))]
        return marks, [(0, 1), (1, 2)]
    if kind == "u":
        half = rng.uniform(1.0, 1.5)
        return [(-size, half), (0.0, half), (0.0, -half), (-size, -half)], [(0, 1), (1, 2),
                                                                           (2, 3)]
    if kind == "wall":
        return [(0.0, size / 2 + 0.5), (0.0, -size / 2 - 0.5)], [(0, 1)]
    if kind == "corridor":
        # long and narrow, its closed end toward the target: 002's robot (0.2 m in radius)
        # fits in but cannot turn wide
        length, half = size + 0.5, rng.uniform(0.5, 0.65)
        marks = [(0.6 - length, half), (0.6, half), (0.6, -half), (0.6 - length, -half)]
        return marks, [(0, 1), (1, 2), (2, 3)]
    if kind == "gap":
        # a long piece across the straight way, the gap beside it (to the left; the caller
        # mirrors it toward the middle of the world), a short piece beyond
        near, gap, short = size / 2 + 0.3, rng.uniform(1.0, 1.3), rng.uniform(0.8, 1.2)
        ys = [-near, near, near + gap, near + gap + short]
        return [(0.0, y) for y in ys], [(0, 1), (2, 3)]
    # a room: corners (counter-clockwise from the far bottom) and the door's posts in the
    # wall facing away from the target (x < 0, toward the start), off its middle by a drawn
    # amount: pulled toward the target, the robot goes in and finds no way on
    half_w, half_h = size / 2 + 0.2, rng.uniform(1.2, 1.6)
    door = rng.uniform(1.2, 1.5)
    low = rng.uniform(-half_h + 0.3, half_h - 0.3 - door)
    marks = [(half_w, -half_h), (half_w, half_h), (-half_w, half_h), (-half_w, low + door),
             (-half_w, low), (-half_w, -half_h)]
    return marks, [(0, 1), (1, 2), (2, 3), (4, 5), (5, 0)]


def scenario(seed: Seed, *, width: float = 12.0, height: float = 9.0, free: int = 4,
             shape: str | None = None) -> World:
    """A world like 002's scenarios (Figure 7): between a ``start`` on the left and a ``target``
    on the right, one shape of linear obstacles between landmarks is in the way (see
    :data:`SCENES`), in turn by seed unless ``shape`` names one; its size, place and turn
    (within 20 degrees) are drawn from the seed. ``free`` landmarks with no obstacle stand
    elsewhere (never inside the room), at least 0.9 m from everything and 1.5 m from each
    other and the places.

    It is the family of worlds 002 means to learn across: the same kinds of situation, never
    twice the same layout.
    """
    if shape is not None and shape not in SCENES:
        raise CbrError(f"unknown scenario shape {shape!r}; expected one of {', '.join(SCENES)}")
    rng = np.random.default_rng(seed)
    index = int(seed) if isinstance(seed, int) else int(rng.integers(len(SCENES)))
    kind = shape if shape is not None else SCENES[index % len(SCENES)]
    start_y = height / 2 + rng.uniform(-1.0, 1.0)
    target_y = height / 2 + rng.uniform(-1.0, 1.0)
    start, target = (1.0, _mm(start_y)), (width - 1.0, _mm(target_y))
    cx = width / 2 + rng.uniform(-0.8, 0.8)
    cy = (start_y + target_y) / 2 + rng.uniform(-0.4, 0.4)
    turn = math.radians(rng.uniform(-20.0, 20.0))
    size = rng.uniform(2.2, 3.0)
    shape_marks, joins = _scene_shape(kind, rng, size)
    if kind == "gap" and cy > height / 2:
        shape_marks = [(x, -y) for x, y in shape_marks]
    c, s = math.cos(turn), math.sin(turn)
    marks = [(_mm(cx + c * x - s * y), _mm(cy + s * x + c * y)) for x, y in shape_marks]
    data: dict[str, Any] = {
        "name": _name("scenario", seed), "bounds": [0.0, 0.0, width, height],
        "landmarks": [{"id": f"l{k + 1}", "at": list(m), "radius": 0.15}
                      for k, m in enumerate(marks)],
        "walls": [{"between": [f"l{a + 1}", f"l{b + 1}"]} for a, b in joins],
        "places": {"start": list(start), "target": list(target)},
    }
    world = world_from_data(data, data["name"])
    avoid = [(*start, 1.5), (*target, 1.5)]
    if kind == "room":
        # no free landmark inside the room
        avoid.append((cx, cy, max(math.hypot(x, y) for x, y in shape_marks)))
    for k in range(free):
        spot = _free_spot(rng, (1.0, 1.0), (width - 1.0, height - 1.0), 0.15, 0.9,
                          world.static_segments, world.static_discs, avoid)
        if spot is not None:
            data["landmarks"].append({"id": f"l{len(marks) + k + 1}", "at": list(spot),
                                      "radius": 0.15})
            avoid.append((*spot, 1.5))
    return world_from_data(data, data["name"])


def semi_structured(seed: Seed, *, width: float = 18.0, height: float = 14.0,
                    spacing: float = 2.0, jitter: float = 0.25,
                    radius: tuple[float, float] = (0.1, 0.2), shapes: int = 4,
                    links: float = 0.15, points: int = 8,
                    point_radius: tuple[float, float] = (0.05, 0.1)) -> World:
    """A semi-structured world like 002's Figure 1: landmarks with linear obstacles between
    some neighbouring pairs, forming walls, corners, U-shapes and dead ends.

    Landmarks ``l1, l2, ...`` (row by row from the bottom left) stand on a lattice of
    ``spacing`` metres centred in the ``width`` x ``height`` bounds, each moved by up to
    ``jitter`` in x and y, with radii drawn from ``radius``. ``shapes`` shapes are placed on
    purpose, cycling through :data:`SHAPES` (dead end, U, corner, wall), each turned at random
    and kept apart from the others; then each remaining pair of lattice neighbours outside the
    shapes is linked with probability ``links``. Every link is a wall ``between`` the two
    landmarks. ``points`` point obstacles (radii from ``point_radius``) are scattered where a
    robot still passes beside them. The lattice keeps at least a spacing's corridor along the
    bounds, and the places ``start`` and ``target`` lie in its bottom-left and top-right
    corners.
    """
    if not spacing > 0:
        raise CbrError(f"spacing must be positive, got {spacing!r}")
    if not (0 < radius[0] <= radius[1] and jitter >= 0 and radius[1] + jitter < spacing / 4):
        raise CbrError(f"expected 0 < radius[0] <= radius[1] and jitter >= 0 with radius[1] + "
                       f"jitter < spacing / 4, got radius={radius}, jitter={jitter}, "
                       f"spacing={spacing}")
    if width < 3 * spacing or height < 3 * spacing:
        raise CbrError(f"the world must be at least 3 spacings wide and high, got "
                       f"{width} x {height} with spacing {spacing}")
    if not 0 <= links <= 1:
        raise CbrError(f"links is a probability in [0, 1], got {links!r}")
    if shapes < 0 or points < 0:
        raise CbrError(f"shapes and points must be >= 0, got {shapes}, {points}")
    if not 0 < point_radius[0] <= point_radius[1] < spacing / 4:
        raise CbrError(f"expected 0 < point_radius[0] <= point_radius[1] < spacing / 4, got "
                       f"{point_radius}")
    rng = np.random.default_rng(seed)
    columns, rows = int(width // spacing) - 1, int(height // spacing) - 1
    x0 = (width - (columns - 1) * spacing) / 2
    y0 = (height - (rows - 1) * spacing) / 2
    jj, ii = np.meshgrid(np.arange(rows), np.arange(columns), indexing="ij")
    xs = x0 + ii.ravel() * spacing + rng.uniform(-jitter, jitter, columns * rows)
    ys = y0 + jj.ravel() * spacing + rng.uniform(-jitter, jitter, columns * rows)
    radii = rng.uniform(radius[0], radius[1], columns * rows)

    def ident(cell: Cell) -> str:
        return f"l{cell[1] * columns + cell[0] + 1}"

    landmarks = [{"id": f"l{k + 1}", "at": [_mm(x), _mm(y)], "radius": _mm(r)}
                 for k, (x, y, r) in enumerate(zip(xs, ys, radii, strict=True))]
    placed, used = _place_shapes(rng, columns, rows, shapes)
    neighbours = [((i, j), (i + di, j + dj)) for j in range(rows) for i in range(columns)
                  for di, dj in ((1, 0), (0, 1)) if i + di < columns and j + dj < rows]
    extra = [edge for edge in neighbours if not (set(edge) & used)]
    chosen = [edge for edge, draw in zip(extra, rng.random(len(extra)), strict=True)
              if draw < links]
    walls = [{"between": [ident(a), ident(b)]} for a, b in placed + chosen]
    places = {"start": [_mm(spacing / 2), _mm(spacing / 2)],
              "target": [_mm(width - spacing / 2), _mm(height - spacing / 2)]}
    data: dict[str, Any] = {"name": _name("semi_structured", seed),
                            "bounds": [0.0, 0.0, float(width), float(height)],
                            "landmarks": landmarks, "walls": walls, "places": places}
    source = f"semi_structured(seed={seed})"
    frame = world_from_data(data, source)
    scattered = []
    avoid = [(*p, 1.0) for p in places.values()]
    for _ in range(points):
        r = _mm(rng.uniform(point_radius[0], point_radius[1]))
        spot = _free_spot(rng, (0.0, 0.0), (width, height), r, 0.6, frame.static_segments,
                          np.concatenate([frame.static_discs,
                                          np.asarray([[*p["at"], p["radius"]] for p in scattered],
                                                     dtype=float).reshape(-1, 3)]), avoid)
        if spot is not None:
            scattered.append({"at": list(spot), "radius": r})
    data["points"] = scattered
    return world_from_data(data, source)


def _pieces(x0: float, x1: float, gaps: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
    """The parts of the line from ``x0`` to ``x1`` outside the door ``gaps``."""
    pieces, at = [], x0
    for g0, g1 in sorted(gaps):
        pieces.append((at, g0))
        at = g1
    pieces.append((at, x1))
    return [(a, b) for a, b in pieces if b - a > 1e-9]


def office(seed: Seed, *, rooms: int = 4, room_width: float = 4.0, room_depth: float = 4.0,
           hallway_width: float = 2.0, hallways: int = 1, door_width: float = 1.0,
           people: int = 3, objects: int = 2, furniture: float = 0.7,
           doors_open: bool = False, name: str = "office") -> World:
    """An office floor like the building of 004: hallways with rooms on both sides.

    With one hallway, ``rooms`` rooms (``room_width`` x ``room_depth``) line each side of a
    hallway ``hallway_width`` wide that runs the floor's length. With two, the floor holds
    three rows of rooms: the outer rows open onto one hallway each, the ``rooms - 1`` rooms of
    the middle row onto either, and the hallways join at both ends, so the hallways make a
    loop. Each room has a door ``door_width`` wide at a random place of its hallway wall, on a
    seeded schedule (a third of them always open), a landmark ``sign_k`` on the hallway side
    beside it and, with probability ``furniture``, a desk (a polygon) against its far wall and
    a chair or bin (a point obstacle). ``people`` people walk the hallway (the loop with two
    hallways, back and forth with one) at 0.5 to 1.3 m/s and stop for a robot in their way (a
    mover that ``yields``); ``objects`` transient objects (carts,
    boxes) stand in a hallway for a while. Places: ``room_1`` ... at the rooms' centres (the
    bottom row first, left to right) and the hallway ends ``hall_west``, ``hall_east`` (with
    two hallways ``hall_1_west``, ... ``hall_2_east``, and ``hall_west``, ``hall_east`` for
    the first hallway's ends as well). ``doors_open`` keeps every door open all the time.
    """
    _check_office(rooms, room_width, room_depth, hallway_width, hallways, door_width)
    if people < 0 or objects < 0 or not 0 <= furniture <= 1:
        raise CbrError(f"expected people, objects >= 0 and furniture in [0, 1], got "
                       f"{people}, {objects}, {furniture}")
    rng = np.random.default_rng(seed)
    # the bounds are rounded as every coordinate is, so rounding keeps everything inside
    floor = _Floor(rooms, room_width, room_depth, hallway_width, hallways, door_width,
                   _mm(rooms * room_width),
                   _mm((3 * room_depth + 2 * hallway_width) if hallways == 2
                       else (2 * room_depth + hallway_width)))
    boxes, walls, lines = _office_rooms(rng, floor)
    doors, landmarks, places, gaps = _office_doors(rng, floor, boxes, doors_open)
    for y, x0, x1 in lines:
        for a, b in _pieces(x0, x1, gaps.get(y, [])):
            walls.append({"a": [_mm(a), _mm(y)], "b": [_mm(b), _mm(y)]})
    places.update(_hallway_places(floor))
    # furniture last, clear of everything so far: a desk against the far wall, then a chair
    frame = world_from_data({"bounds": [0.0, 0.0, floor.width, floor.height], "walls": walls,
                             "landmarks": landmarks}, "office")
    polygons, chairs = _office_furniture(rng, floor, boxes, furniture, frame, places, doors)
    movers = ([_person(rng, floor) for _ in range(people)]
              + [_object(rng, floor) for _ in range(objects)])
    data = {"name": _name(name, seed), "bounds": [0.0, 0.0, float(floor.width),
                                                  float(floor.height)],
            "landmarks": landmarks, "walls": walls, "polygons": polygons,
            "points": [{"at": c[:2], "radius": c[2]} for c in chairs], "doors": doors,
            "movers": movers, "places": places}
    return world_from_data(data, f"office(seed={seed})")


def _check_office(rooms: int, room_width: float, room_depth: float, hallway_width: float,
                  hallways: int, door_width: float) -> None:
    if rooms < (2 if hallways == 2 else 1) or hallways not in (1, 2):
        raise CbrError(f"expected hallways 1 or 2 and at least {2 if hallways == 2 else 1} "
                       f"rooms a side, got hallways={hallways}, rooms={rooms}")
    if not door_width > 0 or room_width < door_width + 1.4:
        raise CbrError(f"expected a positive door width and rooms at least 1.4 m wider than "
                       f"their doors, got door_width={door_width}, room_width={room_width}")
    if room_depth < 3.0 or hallway_width < 1.5:
        raise CbrError(f"expected rooms at least 3 m deep and hallways at least 1.5 m wide, got "
                       f"room_depth={room_depth}, hallway_width={hallway_width}")


@attrs.frozen
class _Floor:
    """An office floor's dimensions (see :func:`office`), ``width`` and ``height`` its
    bounds'."""

    rooms: int
    room_width: float
    depth: float
    hall: float
    hallways: int
    door_width: float
    width: float
    height: float

    @property
    def hallway_ys(self) -> list[float]:
        """The lower side of each hallway."""
        return [self.depth] if self.hallways == 1 else [self.depth, 2 * self.depth + self.hall]


Room = tuple[float, float, float, float, float, int]
"""A room: its box ``x0, y0, x1, y1``, the y of its door's wall and which way (+1 up, -1 down)
the hallway lies from it."""


def _office_rooms(rng: np.random.Generator, floor: _Floor
                  ) -> tuple[list[Room], list[dict[str, Any]], list[tuple[float, float, float]]]:
    """The rooms, the walls between them and the hallway walls ``(y, x0, x1)`` that the doors
    break."""
    depth, hall, width, height = floor.depth, floor.hall, floor.width, floor.height
    boxes: list[Room] = [(k * floor.room_width, 0.0, (k + 1) * floor.room_width, depth, depth, 1)
                         for k in range(floor.rooms)]
    walls: list[dict[str, Any]] = []
    lines = [(depth, 0.0, width)]
    if floor.hallways == 2:
        middle = (width - 2 * hall) / (floor.rooms - 1)
        if middle < floor.door_width + 1.4:
            raise CbrError(f"the middle row's rooms would be {middle:.3g} m wide, less than "
                           f"the door plus 1.4 m; widen the rooms or narrow the hallways")
        low, high = depth + hall, 2 * depth + hall
        for k in range(floor.rooms - 1):
            down = bool(rng.random() < 0.5)
            boxes.append((hall + k * middle, low, hall + (k + 1) * middle, high,
                          low if down else high, -1 if down else 1))
        lines += [(low, hall, width - hall), (high, hall, width - hall)]
        for x in (hall, width - hall):
            walls.append({"a": [_mm(x), _mm(low)], "b": [_mm(x), _mm(high)]})
        for k in range(1, floor.rooms - 1):
            x = _mm(hall + k * middle)
            walls.append({"a": [x, _mm(low)], "b": [x, _mm(high)]})
    top = height - depth
    boxes += [(k * floor.room_width, top, (k + 1) * floor.room_width, height, top, -1)
              for k in range(floor.rooms)]
    lines.append((top, 0.0, width))
    for k in range(1, floor.rooms):
        x = _mm(k * floor.room_width)
        walls += [{"a": [x, 0.0], "b": [x, _mm(depth)]},
                  {"a": [x, _mm(top)], "b": [x, _mm(height)]}]
    return boxes, walls, lines


def _office_doors(rng: np.random.Generator, floor: _Floor, boxes: Sequence[Room],
                  doors_open: bool) -> tuple[list[dict[str, Any]], list[dict[str, Any]],
                                             dict[str, list[float]],
                                             dict[float, list[tuple[float, float]]]]:
    """Each room's door and sign, the rooms' places, and the doors' gaps in each hallway wall
    (by its y)."""
    door_width = floor.door_width
    doors, landmarks, places, gaps = [], [], {}, {}
    for k, (bx0, by0, bx1, by1, wall_y, side) in enumerate(boxes, start=1):
        centre = _mm(rng.uniform(bx0 + door_width / 2 + 0.4, bx1 - door_width / 2 - 0.4))
        g0, g1 = _mm(centre - door_width / 2), _mm(centre + door_width / 2)
        gaps.setdefault(wall_y, []).append((g0, g1))
        period = float(rng.integers(20, 91))
        always = bool(rng.random() < 1 / 3) or doors_open
        open_for = period if always else round(period * rng.uniform(0.3, 0.9), 1)
        doors.append({"a": [g0, _mm(wall_y)], "b": [g1, _mm(wall_y)], "period": period,
                      "open_for": open_for, "phase": round(rng.uniform(0, period), 1),
                      "name": f"door_{k}"})
        sign_x = g1 + 0.3 if bx1 - g1 >= 0.5 else g0 - 0.3
        landmarks.append({"id": f"sign_{k}", "at": [_mm(sign_x), _mm(wall_y + side * 0.15)],
                          "radius": 0.1})
        places[f"room_{k}"] = [_mm((bx0 + bx1) / 2), _mm((by0 + by1) / 2)]
    return doors, landmarks, places, gaps


def _hallway_places(floor: _Floor) -> dict[str, list[float]]:
    places: dict[str, list[float]] = {}
    for n, y in enumerate(floor.hallway_ys, start=1):
        prefix = "hall" if floor.hallways == 1 else f"hall_{n}"
        places[f"{prefix}_west"] = [0.75, _mm(y + floor.hall / 2)]
        places[f"{prefix}_east"] = [_mm(floor.width - 0.75), _mm(y + floor.hall / 2)]
        if n == 1 and floor.hallways == 2:
            places["hall_west"], places["hall_east"] = places["hall_1_west"], places["hall_1_east"]
    return places


def _office_furniture(rng: np.random.Generator, floor: _Floor, boxes: Sequence[Room],
                      furniture: float, frame: World, places: Mapping[str, list[float]],
                      doors: Sequence[Mapping[str, Any]]
                      ) -> tuple[list[list[list[float]]], list[list[float]]]:
    """A desk (a polygon) against each furnished room's far wall, and a chair (a disc
    ``[x, y, radius]``) where one fits clear of the room's centre, its door and its desk."""
    polygons: list[list[list[float]]] = []
    chairs: list[list[float]] = []
    for k, (bx0, by0, bx1, by1, wall_y, side) in enumerate(boxes, start=1):
        if rng.random() >= furniture:
            continue
        desk_w, desk_d = min(1.2, 0.4 * (bx1 - bx0)), min(0.6, 0.2 * (by1 - by0))
        dx = _mm(rng.uniform(bx0 + 0.2, bx1 - 0.2 - desk_w))
        far = by0 + 0.1 if side == 1 else by1 - 0.1 - desk_d
        polygons.append([[dx, _mm(far)], [_mm(dx + desk_w), _mm(far)],
                         [_mm(dx + desk_w), _mm(far + desk_d)], [dx, _mm(far + desk_d)]])
        r = _mm(rng.uniform(0.15, 0.25))
        desk = [(dx + desk_w / 2, far + desk_d / 2, math.hypot(desk_w, desk_d) / 2 + r + 0.3)]
        door = doors[k - 1]
        spot = _free_spot(rng, (bx0, by0), (bx1, by1), r, 0.3, frame.static_segments,
                          np.asarray(chairs, dtype=float).reshape(-1, 3),
                          [(*places[f"room_{k}"], 0.8 + r),
                           ((door["a"][0] + door["b"][0]) / 2, wall_y,
                            floor.door_width / 2 + 0.7 + r),
                           *desk])
        if spot is not None:
            chairs.append([*spot, r])
    return polygons, chairs


def _person(rng: np.random.Generator, floor: _Floor) -> dict[str, Any]:
    """A person walking the hallway: back and forth along it with one, round the loop with
    two."""
    depth, hall, width = floor.depth, floor.hall, floor.width
    offset = rng.uniform(0.55, hall - 0.55)
    if floor.hallways == 1:
        y = _mm(depth + offset)
        path = [[_mm(rng.uniform(0.5, width / 2 - 1)), y],
                [_mm(rng.uniform(width / 2 + 1, width - 0.5)), y]]
    else:
        lo, hi = depth + offset, 2 * depth + 2 * hall - offset
        path = [[_mm(offset), _mm(lo)], [_mm(width - offset), _mm(lo)],
                [_mm(width - offset), _mm(hi)], [_mm(offset), _mm(hi)]]
        if rng.random() < 0.5:
            path.reverse()
        turn = int(rng.integers(len(path)))
        path = path[turn:] + path[:turn]
    return {"waypoints": path, "speed": round(rng.uniform(0.5, 1.3), 2), "radius": 0.25,
            "kind": "person", "appears": round(rng.uniform(0, 20), 1), "yields": True}


def _object(rng: np.random.Generator, floor: _Floor) -> dict[str, Any]:
    """A transient object standing in a hallway for a while."""
    lanes = [(y + 0.55, y + floor.hall - 0.55) for y in floor.hallway_ys]
    y0, y1 = lanes[int(rng.integers(len(lanes)))]
    appears = round(rng.uniform(0, 60), 1)
    return {"waypoints": [[_mm(rng.uniform(1.0, floor.width - 1.0)), _mm(rng.uniform(y0, y1))]],
            "speed": 0.0, "radius": _mm(rng.uniform(0.2, 0.35)), "kind": "object",
            "appears": appears, "leaves": round(appears + rng.uniform(30, 120), 1)}


def office_floor(seed: Seed, *, people: int | None = None, objects: int | None = None,
                 doors_open: bool = False) -> World:
    """An office floor whose layout is drawn from ``seed`` as well as its doors, furniture and
    people: :func:`office` with 3 to 6 rooms a side, one hallway or (with probability 0.3) two
    making a loop, rooms 3.5 to 5 m wide and deep, hallways 1.8 to 2.6 m wide, doors 0.9 to
    1.2 m wide, 2 to 5 people walking and 1 to 3 transient objects (``people`` and ``objects``
    fix those counts). The floors a robot tuned on one range of seeds has never seen come from
    another range."""
    rng = np.random.default_rng(seed)
    hallways = 2 if rng.random() < 0.3 else 1
    rooms = int(rng.integers(3, 7))
    hall = _mm(rng.uniform(1.8, 2.6))
    room_width = _mm(rng.uniform(3.5, 5.0))
    if hallways == 2:
        # the middle row's rooms must stay wide enough for their doors
        room_width = max(room_width, _mm((2 * hall + (rooms - 1) * 3.0) / rooms + 0.01))
    drawn = {"rooms": rooms, "room_width": room_width, "room_depth": _mm(rng.uniform(3.5, 5.0)),
             "hallway_width": hall, "hallways": hallways,
             "door_width": _mm(rng.uniform(0.9, 1.2)), "people": int(rng.integers(2, 6)),
             "objects": int(rng.integers(1, 4))}
    if people is not None:
        drawn["people"] = people
    if objects is not None:
        drawn["objects"] = objects
    # the rooms' doors, furniture and people from a stream of their own
    return office(np.random.SeedSequence(int(rng.integers(2**63))), doors_open=doors_open,
                  name=_name("office floor", seed), **drawn)
