"""Office floors whose layout is drawn from the seed (:func:`cbr_world2d.generate.office_floor`)
and the office options of the ``world2d_generated`` world: one seed one floor, the layouts vary
over seeds within the documented ranges, every place leaves room for a robot, the counts and
``doors_open`` override the draw, and bad configurations are refused naming the option."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cbr_world2d
import cbrcore.builtins
from cbr_world2d.generate import office_floor
from cbr_world2d.shapes import free_point
from cbr_world2d.world import World
from cbr_world2d.world_components import GeneratedWorldOptions, generated_world
from cbr_world2d.worldfile_writer import dump_world
from cbrcore.config import parse_config
from cbrcore.context import Context
from cbrcore.errors import CbrError, ConfigError
from cbrcore.plugins import Plugins, load_plugins

ROBOT = 0.25
"""A robot radius (the Pioneer's) the places must leave room for."""
SEEDS = range(31)


def layout(world: World) -> tuple[int, int]:
    """``(rooms a side, hallways)`` read back from a floor: with one hallway there are two
    rows of ``rooms`` rooms; with two a middle row of ``rooms - 1`` as well."""
    hallways = 2 if "hall_1_west" in world.places else 1
    doors = len(world.doors)
    rooms = doors // 2 if hallways == 1 else (doors + 1) // 3
    assert doors == (2 * rooms if hallways == 1 else 3 * rooms - 1)
    return rooms, hallways


def without_name(world: World) -> dict:
    return {k: v for k, v in dump_world(world).items() if k != "name"}


@pytest.fixture(scope="module")
def floors() -> dict[int, World]:
    return {seed: office_floor(seed) for seed in SEEDS}


def test_the_same_seed_gives_the_same_floor() -> None:
    for seed in (0, 7, 12):
        first, again = office_floor(seed), office_floor(seed)
        assert dump_world(first) == dump_world(again)
        assert np.array_equal(first.static_segments, again.static_segments)
        assert first.doors == again.doors and first.movers == again.movers
    # a seed sequence as well as an integer
    assert dump_world(office_floor(np.random.SeedSequence(5))) == dump_world(
        office_floor(np.random.SeedSequence(5)))


def test_different_seeds_give_different_layouts(floors: dict[int, World]) -> None:
    layouts = {seed: layout(world) for seed, world in floors.items()}
    rooms = {r for r, _ in layouts.values()}
    hallways = {h for _, h in layouts.values()}
    # 3 to 6 rooms a side, one hallway or two, and over 31 seeds more than one of each
    assert rooms <= {3, 4, 5, 6} and len(rooms) >= 3
    assert hallways == {1, 2}
    # two hallways with probability 0.3: neither never nor always (31 draws)
    twos = sum(h == 2 for _, h in layouts.values())
    assert 2 <= twos <= 20
    # no two floors alike
    dumps = [without_name(world) for world in floors.values()]
    assert all(dumps[i] != dumps[j] for i in range(len(dumps)) for j in range(i))


def test_the_drawn_sizes_lie_in_the_documented_ranges(floors: dict[int, World]) -> None:
    for seed, world in floors.items():
        rooms, hallways = layout(world)
        room_width = (world.bounds[2] - world.bounds[0]) / rooms
        assert room_width >= 3.5 - 1e-3, seed
        if hallways == 1:
            assert room_width <= 5.0 + 1e-3, seed
        for door in world.doors:
            assert 0.9 - 1e-3 <= math.dist(door.a, door.b) <= 1.2 + 1e-3, seed
        # the hallway's width: twice the offset of its west end from the first row of rooms,
        # whose depth is where the hallway's wall runs
        west = world.places["hall_west"]
        depth = min(d.a[1] for d in world.doors)
        hall = 2 * (west[1] - depth)
        assert 1.8 - 2e-3 <= hall <= 2.6 + 2e-3, seed
        assert 3.5 - 1e-3 <= depth <= 5.0 + 1e-3, seed
        people = [m for m in world.movers if m.kind == "person"]
        objects = [m for m in world.movers if m.kind == "object"]
        assert 2 <= len(people) <= 5, seed
        assert 1 <= len(objects) <= 3, seed


def test_every_floor_has_hallway_ends_and_room_for_a_robot_at_every_place(
        floors: dict[int, World]) -> None:
    for seed, world in floors.items():
        assert {"hall_west", "hall_east"} <= set(world.places), seed
        _, hallways = layout(world)
        assert {f"room_{k}" for k in range(1, len(world.doors) + 1)} <= set(world.places)
        if hallways == 2:
            assert {"hall_1_west", "hall_1_east", "hall_2_west", "hall_2_east"} <= set(
                world.places)
            assert world.places["hall_west"] == world.places["hall_1_west"]
        for name, point in world.places.items():
            assert free_point(world, *point, ROBOT) is None, (seed, name)


@pytest.mark.parametrize("people, objects", [(0, 0), (7, 0), (0, 5), (3, 2)])
def test_people_and_objects_override_the_counts(people: int, objects: int) -> None:
    for seed in (1, 2):
        world = office_floor(seed, people=people, objects=objects)
        assert sum(m.kind == "person" for m in world.movers) == people
        assert sum(m.kind == "object" for m in world.movers) == objects
        # the layout is the seed's whatever the counts
        plain = office_floor(seed)
        assert world.bounds == plain.bounds
        assert [(d.a, d.b) for d in world.doors] == [(d.a, d.b) for d in plain.doors]
    # one count alone leaves the other as drawn
    drawn = office_floor(4)
    only = office_floor(4, people=1)
    assert sum(m.kind == "object" for m in only.movers) == sum(
        m.kind == "object" for m in drawn.movers)


def test_doors_open_leaves_every_door_open_all_the_time() -> None:
    for seed in (0, 2, 11):
        shut_some = office_floor(seed)
        assert any(not d.is_open(t) for d in shut_some.doors for t in np.arange(0.0, 200.0, 1.7))
        world = office_floor(seed, doors_open=True)
        for t in (0.0, 3.3, 17.0, 59.9, 123.4, 1e4 + 0.7):
            assert all(d.is_open(t) for d in world.doors), (seed, t)
            # and so no door blocks: the segments at t are the static ones
            assert np.array_equal(world.segments_at(t), world.static_segments)


def test_a_negative_count_is_refused() -> None:
    with pytest.raises(CbrError, match="people"):
        office_floor(0, people=-1)


# --- the world2d_generated options ---------------------------------------------------------------


@pytest.fixture(scope="module")
def plugins() -> Plugins:
    return load_plugins(extra=[("core", cbrcore.builtins), ("world2d", cbr_world2d)],
                        entry_points=False, environ={})


def world_of(plugins: Plugins, **options: object) -> World:
    config = parse_config({"seed": 9, "world": {"use": "world2d_generated", **options}},
                          plugins.registry)
    assert config.world is not None
    ctx = Context(registry=plugins.registry, seed=config.seed)
    return plugins.registry.create("world", "world2d_generated", config.world.options, ctx)


def test_the_generated_world_passes_the_office_options_on(plugins: Plugins) -> None:
    world = world_of(plugins, kind="office_floor", seed=3, people=4, objects=1, doors_open=True)
    assert dump_world(world) == dump_world(office_floor(3, people=4, objects=1, doors_open=True))
    # without a seed of its own the run's seed (9) draws the floor
    assert dump_world(world_of(plugins, kind="office_floor")) == dump_world(office_floor(9))
    # without counts the generator's own choice
    direct = generated_world(GeneratedWorldOptions(kind="office_floor", seed=5),
                             Context(registry=plugins.registry, seed=0))
    assert dump_world(direct) == dump_world(office_floor(5))


@pytest.mark.parametrize("kind", ["scenario", "semi_structured"])
@pytest.mark.parametrize("option, value", [("people", 3), ("objects", 1), ("doors_open", True)])
def test_office_options_are_refused_for_other_kinds(plugins: Plugins, kind: str, option: str,
                                                    value: object) -> None:
    with pytest.raises(ConfigError) as caught:
        parse_config({"world": {"use": "world2d_generated", "kind": kind, option: value}},
                     plugins.registry)
    message = str(caught.value)
    assert f"'{option}'" in message and kind in message
    # the same value is fine on an office floor
    parse_config({"world": {"use": "world2d_generated", "kind": "office_floor",
                            option: value}}, plugins.registry)


@pytest.mark.parametrize("option", ["people", "objects"])
def test_a_negative_count_is_refused_in_the_configuration(plugins: Plugins, option: str) -> None:
    with pytest.raises(ConfigError, match=rf"world\.{option}"):
        parse_config({"world": {"use": "world2d_generated", "kind": "office_floor",
                                option: -1}}, plugins.registry)
