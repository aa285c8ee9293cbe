"""Seeded 2D world generators: every world validates and round-trips, one seed one world, the
shapes of 002's Figure 1 are there, offices are connected through their doors."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from matplotlib.path import Path as Outline
from scipy import ndimage

from cbr_world2d.generate import SCENES, office, scenario, semi_structured
from cbr_world2d.shapes import free_point
from cbr_world2d.world import World
from cbr_world2d.worldfile import world_from_data
from cbr_world2d.worldfile_writer import dump_world, world_yaml
from cbrcore.errors import CbrError

ROBOT = 0.25
"""A robot radius the generated places must leave room for."""

GENERATORS: dict[str, Callable[[int], World]] = {
    "semi_structured": semi_structured,
    "scenario": scenario,
    "office": office,
    "office_two_hallways": lambda seed: office(seed, hallways=2),
}


def round_trips(world: World) -> None:
    again = world_from_data(yaml.safe_load(world_yaml(world)), "again")
    assert dump_world(again) == dump_world(world)
    assert np.array_equal(again.static_segments, world.static_segments)
    assert np.array_equal(again.static_discs, world.static_discs)
    assert again.doors == world.doors and again.movers == world.movers


@pytest.mark.parametrize("name", GENERATORS)
def test_same_seed_same_world_and_different_seeds_differ(name: str) -> None:
    make = GENERATORS[name]
    assert dump_world(make(3)) == dump_world(make(3))
    first = dump_world(make(3))
    others = [dump_world(make(seed)) for seed in (4, 5)]
    assert all({k: v for k, v in first.items() if k != "name"}
               != {k: v for k, v in other.items() if k != "name"} for other in others)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), width=st.floats(6.0, 24.0),
       height=st.floats(6.0, 20.0), shapes=st.integers(0, 6), links=st.floats(0.0, 1.0),
       points=st.integers(0, 12))
def test_semi_structured_worlds_validate_and_round_trip(seed: int, width: float, height: float,
                                                        shapes: int, links: float,
                                                        points: int) -> None:
    world = semi_structured(seed, width=width, height=height, shapes=shapes, links=links,
                            points=points)
    round_trips(world)
    assert len(world.points) <= points
    for name in ("start", "target"):
        assert free_point(world, *world.places[name], ROBOT) is None


def _crosses(p: tuple[float, float], q: tuple[float, float], a: tuple[float, float],
             b: tuple[float, float]) -> bool:
    """Whether segments pq and ab cross (their ends on either side of each other's line)."""
    def side(o: tuple[float, float], u: tuple[float, float], v: tuple[float, float]) -> float:
        return (u[0] - o[0]) * (v[1] - o[1]) - (u[1] - o[1]) * (v[0] - o[0])

    return side(p, q, a) * side(p, q, b) < 0 and side(a, b, p) * side(a, b, q) < 0


WALLS = {"v": 2, "u": 3, "wall": 1, "corridor": 3, "gap": 2, "room": 5}
"""How many linear obstacles each scenario shape has."""


def passable(world: World, radius: float, step: float = 0.05) -> np.ndarray:
    """A raster of the world: True where a robot of ``radius`` fits, rows by y."""
    xmin, ymin, xmax, ymax = world.bounds
    gx, gy = np.meshgrid(np.arange(xmin + step / 2, xmax, step),
                         np.arange(ymin + step / 2, ymax, step))
    centres = np.stack([gx.ravel(), gy.ravel()], axis=1)
    room = np.minimum.reduce([centres[:, 0] - xmin, xmax - centres[:, 0],
                              centres[:, 1] - ymin, ymax - centres[:, 1]])
    for x0, y0, x1, y1 in world.static_segments:
        d = np.array([x1 - x0, y1 - y0])
        u = np.clip(((centres - [x0, y0]) @ d) / (d @ d), 0, 1)
        room = np.minimum(room, np.hypot(*(centres - [x0, y0] - u[:, None] * d).T))
    for x, y, r in world.static_discs:
        room = np.minimum(room, np.hypot(centres[:, 0] - x, centres[:, 1] - y) - r)
    return (room > radius).reshape(gx.shape)


def joined_for(world: World, radius: float, a: tuple[float, float], b: tuple[float, float],
               step: float = 0.05) -> bool:
    """Whether a robot of ``radius`` can drive from ``a`` to ``b``."""
    labels, _ = ndimage.label(passable(world, radius, step))

    def at(p: tuple[float, float]) -> int:
        return int(labels[int((p[1] - world.bounds[1]) / step),
                          int((p[0] - world.bounds[0]) / step)])

    return at(a) > 0 and at(a) == at(b)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31))
def test_scenario_worlds_put_their_shape_across_the_way(seed: int) -> None:
    world = scenario(seed)
    round_trips(world)
    kind = SCENES[seed % len(SCENES)]
    assert len(world.walls) == WALLS[kind]
    start, target = world.places["start"], world.places["target"]
    for name in ("start", "target"):
        assert free_point(world, *world.places[name], ROBOT) is None
    # the straight way from start to target runs into the shape: through the wall (the gap's
    # long piece, the room's side toward the target), or into the dead end, whose far side
    # (the V's arms and apex, the U's and the corridor's bottom) it crosses
    joined = {i for w in world.walls for i in (w.between or ())}
    way = np.subtract(target, start)
    def gap(x: float, y: float) -> float:
        t = min(max(float(np.dot((x - start[0], y - start[1]), way) / np.dot(way, way)), 0.0),
                1.0)
        return math.dist((x, y), (start[0] + t * way[0], start[1] + t * way[1]))

    assert any(_crosses(start, target, w.a, w.b) for w in world.walls) or any(
        gap(m.x, m.y) <= m.radius for m in world.landmarks if m.id in joined)
    # the free landmarks stand clear of the places
    for mark in world.landmarks:
        if mark.id not in joined:
            assert all(math.dist((mark.x, mark.y), p) >= 1.5 for p in (start, target))
    # every landmark within the bounds, and the robot gets from start to target
    xmin, ymin, xmax, ymax = world.bounds
    assert all(xmin < m.x - m.radius and m.x + m.radius < xmax and ymin < m.y - m.radius
               and m.y + m.radius < ymax for m in world.landmarks)
    assert joined_for(world, ROBOT, start, target)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("kind", SCENES)
def test_each_scenario_shape_is_the_trap_it_says(kind: str, seed: int) -> None:
    world = scenario(seed, shape=kind)
    assert dump_world(world) == dump_world(scenario(seed, shape=kind))
    assert len(world.walls) == WALLS[kind]
    start, target = world.places["start"], world.places["target"]
    marks = {m.id: (m.x, m.y) for m in world.landmarks}
    walls = [tuple(w.between) for w in world.walls]
    assert joined_for(world, ROBOT, start, target)
    # the straight way meets a linear obstacle, except for the V, whose apex it may pass
    # (the test above covers it)
    crossing = [w for w in walls if _crosses(start, target, marks[w[0]], marks[w[1]])]
    if kind != "v":
        assert crossing
    if kind in ("u", "corridor"):
        # closed on three sides: with the mouth closed the inside is cut off
        first, last = walls[0][0], walls[-1][1]
        mouth = (np.add(marks[first], marks[last])) / 2
        closed = world_from_data({**dump_world(world), "walls": [
            *dump_world(world)["walls"], {"between": [first, last]}]}, "closed")
        inside = mouth + 0.5 * (np.subtract(marks[walls[1][0]], marks[first]) +
                                np.subtract(marks[walls[1][1]], marks[last])) / 2
        assert joined_for(world, ROBOT, tuple(inside), target)
        assert not joined_for(closed, ROBOT, tuple(inside), target)
    if kind == "gap":
        # the gap between the two pieces lets the robot through, landmarks and all
        (_, b), (c, _) = walls
        assert math.dist(marks[b], marks[c]) - 0.3 > 2 * ROBOT
    if kind == "room":
        # the door (the one gap in the walls) faces away from the target, toward the start;
        # the robot gets in and out through it, and with it shut the room is closed
        door = next((walls[k][1], walls[k + 1][0]) for k in range(len(walls) - 1)
                    if walls[k][1] != walls[k + 1][0])
        centre = np.mean([marks[w[0]] for w in walls], axis=0)
        middle = np.add(marks[door[0]], marks[door[1]]) / 2
        assert np.dot(middle - centre, np.subtract(target, start)) < 0
        assert joined_for(world, ROBOT, tuple(centre), start)
        shut = world_from_data({**dump_world(world), "walls": [
            *dump_world(world)["walls"], {"between": list(door)}]}, "shut")
        assert not joined_for(shut, ROBOT, tuple(centre), start)


def test_an_unknown_scenario_shape_is_refused() -> None:
    with pytest.raises(CbrError, match="unknown scenario shape 'maze'; expected one of v, u"):
        scenario(0, shape="maze")


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), rooms=st.integers(2, 6), hallways=st.sampled_from([1, 2]),
       room_width=st.floats(3.0, 6.0), room_depth=st.floats(3.0, 6.0),
       hallway_width=st.floats(1.5, 3.0), people=st.integers(0, 5),
       objects=st.integers(0, 4), furniture=st.floats(0.0, 1.0))
def test_office_worlds_validate_and_round_trip(seed: int, rooms: int, hallways: int,
                                               room_width: float, room_depth: float,
                                               hallway_width: float, people: int,
                                               objects: int, furniture: float) -> None:
    if hallways == 2 and (rooms * room_width - 2 * hallway_width) / (rooms - 1) < 2.4:
        with pytest.raises(CbrError, match="middle row"):
            office(seed, rooms=rooms, room_width=room_width, hallways=2,
                   hallway_width=hallway_width)
        return
    world = office(seed, rooms=rooms, room_width=room_width, room_depth=room_depth,
                   hallway_width=hallway_width, hallways=hallways, people=people,
                   objects=objects, furniture=furniture)
    round_trips(world)
    count = 2 * rooms + (rooms - 1 if hallways == 2 else 0)
    assert len(world.doors) == count
    assert {f"room_{k}" for k in range(1, count + 1)} <= set(world.places)
    for point in world.places.values():
        assert free_point(world, *point, ROBOT) is None
    persons = [m for m in world.movers if m.kind == "person"]
    assert len(persons) == people and len(world.movers) == people + objects
    for mover in world.movers:
        if mover.kind == "object":
            assert mover.speed == 0 and mover.leaves is not None and mover.leaves > mover.appears
    assert all(0 <= d.open_for <= d.period for d in world.doors)


# --- semi-structured worlds ----------------------------------------------------------------------

def wall_graph(world: World) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {m.id: set() for m in world.landmarks}
    for wall in world.walls:
        assert wall.between is not None
        a, b = wall.between
        graph[a].add(b)
        graph[b].add(a)
    return graph


def direction(world: World, a: str, b: str) -> np.ndarray:
    pa, pb = world.landmark(a), world.landmark(b)
    v = np.array([pb.x - pa.x, pb.y - pa.y])
    return v / np.linalg.norm(v)


def paths(graph: dict[str, set[str]], length: int) -> list[list[str]]:
    """Every simple path of ``length`` edges."""
    found = [[node] for node in graph]
    for _ in range(length):
        found = [[*p, n] for p in found for n in graph[p[-1]] if n not in p]
    return found


def shapes_in(world: World) -> set[str]:
    """The shapes the walls make, judged by the turns along paths of walls: a straight wall
    (two edges in line), a corner (a right angle), a U (a right angle, then another the same
    way) and a dead end (a U whose arms are two edges long)."""
    graph = wall_graph(world)

    def turn(a: str, b: str, c: str) -> str:
        u, v = direction(world, a, b), direction(world, b, c)
        cross, dot = u[0] * v[1] - u[1] * v[0], float(u @ v)
        # jitter turns a lattice link by at most about 18 degrees, two by 37: less than 45
        if dot > math.sqrt(0.5):
            return "straight"
        if abs(dot) <= math.sqrt(0.5):
            return "left" if cross > 0 else "right"
        return "back"

    def turns(path: list[str]) -> list[str]:
        return [turn(*path[k:k + 3]) for k in range(len(path) - 2)]

    found = set()
    if any(turns(p) == ["straight"] for p in paths(graph, 2)):
        found.add("wall")
    if any(turns(p)[0] in ("left", "right") for p in paths(graph, 2)):
        found.add("corner")
    if any(t in (["left", "left"], ["right", "right"]) for t in map(turns, paths(graph, 3))):
        found.add("u_shape")
    if any(t in (["straight", "left", "left", "straight"],
                 ["straight", "right", "right", "straight"]) for t in map(turns, paths(graph, 5))):
        found.add("dead_end")
    return found


@pytest.mark.parametrize("seed", range(12))
def test_semi_structured_places_each_shape(seed: int) -> None:
    world = semi_structured(seed, links=0.0)
    assert shapes_in(world) == {"wall", "corner", "u_shape", "dead_end"}
    assert len(world.walls) == 2 + 2 + 3 + 5


@pytest.mark.parametrize("seed", range(5))
def test_semi_structured_lattice_landmarks_and_links(seed: int) -> None:
    spacing, jitter = 2.0, 0.25
    world = semi_structured(seed, width=18.0, height=14.0, spacing=spacing, jitter=jitter,
                            radius=(0.1, 0.2))
    assert len(world.landmarks) == 8 * 6
    ids = {m.id for m in world.landmarks}
    assert ids == {f"l{k}" for k in range(1, 49)}
    for k, mark in enumerate(world.landmarks):
        column, row = k % 8, k // 8
        assert abs(mark.x - (2.0 + spacing * column)) <= jitter + 1e-9
        assert abs(mark.y - (2.0 + spacing * row)) <= jitter + 1e-9
        assert 0.1 - 1e-9 <= mark.radius <= 0.2 + 1e-9
    for wall in world.walls:
        a, b = (world.landmark(i) for i in wall.between)
        gap = math.hypot(a.x - b.x, a.y - b.y)
        # lattice neighbours only: never a diagonal or a longer link
        assert spacing - 2 * jitter * math.sqrt(2) <= gap <= spacing + 2 * jitter * math.sqrt(2)
    # a corridor along the bounds stays free, so start and target always join along it
    xmin, ymin, xmax, ymax = world.bounds
    discs = world.landmark_array
    edge = np.minimum.reduce([discs[:, 0] - discs[:, 2] - xmin, xmax - discs[:, 0] - discs[:, 2],
                              discs[:, 1] - discs[:, 2] - ymin, ymax - discs[:, 1] - discs[:, 2]])
    assert edge.min() >= spacing / 2


def test_semi_structured_link_probability_extremes() -> None:
    lone = semi_structured(1, shapes=0, links=0.0)
    assert lone.walls == ()
    full = semi_structured(1, shapes=0, links=1.0)
    assert len(full.walls) == 7 * 6 + 8 * 5  # every lattice neighbour pair


@pytest.mark.parametrize("bad", [
    {"spacing": 0.0}, {"jitter": 0.4}, {"radius": (0.3, 0.2)}, {"width": 5.0},
    {"links": 1.5}, {"shapes": -1}, {"point_radius": (0.0, 0.1)},
])
def test_semi_structured_refuses_bad_parameters(bad: dict) -> None:
    with pytest.raises(CbrError):
        semi_structured(0, **bad)


# --- offices -------------------------------------------------------------------------------------

def free_cells(world: World, step: float = 0.05) -> tuple[np.ndarray, float]:
    """A raster of the floor with every door open: True where a point robot may be."""
    xmin, ymin, xmax, ymax = world.bounds
    xs = np.arange(xmin + step / 2, xmax, step)
    ys = np.arange(ymin + step / 2, ymax, step)
    gx, gy = np.meshgrid(xs, ys)
    centres = np.stack([gx.ravel(), gy.ravel()], axis=1)
    blocked = np.zeros(len(centres), dtype=bool)
    for x0, y0, x1, y1 in world.static_segments:
        d = np.array([x1 - x0, y1 - y0])
        u = np.clip(((centres - [x0, y0]) @ d) / (d @ d), 0, 1)
        blocked |= np.hypot(*(centres - [x0, y0] - u[:, None] * d).T) <= step
    for x, y, r in world.static_discs:
        blocked |= np.hypot(centres[:, 0] - x, centres[:, 1] - y) <= r + step
    for polygon in world.polygons:
        blocked |= Outline(np.array(polygon)).contains_points(centres, radius=step)
    return ~blocked.reshape(len(ys), len(xs)), step


@pytest.mark.parametrize(("seed", "hallways"), [(0, 1), (1, 1), (2, 2), (3, 2)])
def test_office_rooms_join_the_hallway_through_their_doors(seed: int, hallways: int) -> None:
    world = office(seed, hallways=hallways, rooms=3)
    free, step = free_cells(world)
    labels, _ = ndimage.label(free)

    def label_at(point: tuple[float, float]) -> int:
        x, y = point
        return int(labels[int((y - world.bounds[1]) / step), int((x - world.bounds[0]) / step)])

    west = world.places["hall_west" if hallways == 1 else "hall_1_west"]
    hall = label_at(west)
    assert hall > 0
    assert {label_at(p) for p in world.places.values()} == {hall}
    # and with the doors shut, every room is closed off from the hallway
    shut = world_from_data({**dump_world(world), "walls": [
        *dump_world(world)["walls"],
        *({"a": list(d.a), "b": list(d.b)} for d in world.doors)], "doors": []}, "shut")
    closed, _ = free_cells(shut)
    labels, _ = ndimage.label(closed)
    rooms = [p for name, p in world.places.items() if name.startswith("room_")]
    assert len({label_at(p) for p in rooms}) == len(rooms)
    assert label_at(west) not in {label_at(p) for p in rooms}


def test_office_doors_fill_gaps_in_the_hallway_walls() -> None:
    world = office(5, rooms=4)
    walls = np.array([(*w.a, *w.b) for w in world.walls])
    for door in world.doors:
        assert math.dist(door.a, door.b) == pytest.approx(1.0)
        # each end of the door is an end of a wall piece on the same line
        ends = np.concatenate([walls[:, :2], walls[:, 2:]])
        for end in (door.a, door.b):
            assert np.isclose(ends, end).all(axis=1).any()
        # no wall runs through the doorway
        mid = np.array([(door.a[0] + door.b[0]) / 2, (door.a[1] + door.b[1]) / 2])
        d = walls[:, 2:] - walls[:, :2]
        u = np.clip(((mid - walls[:, :2]) * d).sum(axis=1) / (d * d).sum(axis=1), 0, 1)
        assert np.hypot(*(walls[:, :2] + u[:, None] * d - mid).T).min() > 0.4
    # every door has its sign beside it
    for k, door in enumerate(world.doors, start=1):
        sign = world.landmark(f"sign_{k}")
        assert min(math.dist((sign.x, sign.y), door.a), math.dist((sign.x, sign.y), door.b)) < 0.5


def test_office_people_walk_inside_the_hallway() -> None:
    world = office(7, hallways=1, people=5, objects=0)
    depth, hall = 4.0, 2.0
    for person in world.movers:
        for t in np.linspace(0, 120, 241):
            x, y = person.position(float(t))
            assert depth + person.radius < y < depth + hall - person.radius
            assert world.bounds[0] < x < world.bounds[2]
    loop = office(7, hallways=2, people=3, objects=0)
    for person in loop.movers:
        assert len(person.waypoints) == 4  # round the middle block


@pytest.mark.parametrize("bad", [
    {"rooms": 0}, {"hallways": 3}, {"hallways": 2, "rooms": 1}, {"door_width": 0.0},
    {"room_width": 2.0}, {"room_depth": 2.0}, {"hallway_width": 1.0}, {"people": -1},
    {"furniture": 1.5},
])
def test_office_refuses_bad_parameters(bad: dict) -> None:
    with pytest.raises(CbrError):
        office(0, **bad)
