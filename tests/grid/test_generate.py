"""Seeded grid generators: repeatability, density, connectivity, terrain risk, the world."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from scipy import ndimage

import cbr_grid
from cbr_grid.generate import generate, maze, office, random_obstacles, terrain_risk
from cbr_grid.grid import Grid
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.options import structure_options
from cbrcore.registry import Registry

EIGHT = np.ones((3, 3), dtype=bool)

GENERATORS: dict[str, Callable[[int], Grid]] = {
    "random": lambda seed: random_obstacles(40, 30, 0.3, seed),
    "office": lambda seed: office(40, 30, seed),
    "maze": lambda seed: maze(41, 31, seed),
    "terrain": lambda seed: terrain_risk(office(40, 30, 0), seed),
}


def components(grid: Grid) -> int:
    return int(ndimage.label(grid.passable, structure=EIGHT)[1])


@pytest.mark.parametrize("name", GENERATORS)
def test_same_seed_same_grid_and_different_seed_different(name: str) -> None:
    make = GENERATORS[name]
    np.testing.assert_array_equal(make(7).risk, make(7).risk)
    assert not np.array_equal(make(7).risk, make(8).risk)


@pytest.mark.parametrize("density", [0.0, 0.1, 0.35, 1.0])
def test_random_obstacle_density(density: float) -> None:
    grid = random_obstacles(50, 40, density, seed=3)
    assert (grid.width, grid.height) == (50, 40)
    assert set(np.unique(grid.risk).tolist()) <= {0.0, 1.0}
    assert (~grid.passable).sum() == round(density * 2000)


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize(("width", "height"), [(40, 30), (23, 57), (9, 9), (64, 12)])
def test_office_free_cells_are_one_component(seed: int, width: int, height: int) -> None:
    grid = office(width, height, seed, room=5, door=1)
    assert (grid.width, grid.height) == (width, height)
    assert components(grid) == 1
    # the office has walls as well as floor
    assert 0 < (~grid.passable).sum() < grid.passable.sum()


def test_office_layout() -> None:
    grid = office(30, 9, seed=0, room=4, door=1, corridor=2)
    blocked = ~grid.passable
    # corridors along rows 0-1 and 8 and down columns 0-1; the band's walls are rows 2 and 7
    assert not blocked[[0, 1, 8]].any() and not blocked[:, :2].any()
    walls = blocked[[2, 7], 2:]
    # rooms: the free runs of the band's interior rows, split by wall columns
    rooms, count = ndimage.label(grid.passable[3:7, 2:])
    assert count >= 3
    assert (blocked[3:7, 2:].all(axis=0) == blocked[3:7, 2:].any(axis=0)).all()
    # each room has exactly one door (one cell wide) in its top or bottom wall
    doors = ~walls
    room_of_door = np.where(doors, rooms[[0, -1]], 0)
    assert sorted(room_of_door[room_of_door > 0].tolist()) == list(range(1, count + 1))


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize(("width", "height"), [(41, 31), (20, 16), (3, 3), (5, 41)])
def test_maze_is_perfect(seed: int, width: int, height: int) -> None:
    grid = maze(width, height, seed)
    free = grid.passable
    cols, rows = (width - 1) // 2, (height - 1) // 2
    # every odd cell is free, every even-even cell and the border blocked
    assert free[1::2, 1::2][:rows, :cols].all()
    assert not free[::2, ::2].any()
    assert not (free[0].any() or free[:, 0].any() or free[2 * rows:].any()
                or free[:, 2 * cols:].any())
    assert components(grid) == 1
    # a tree: the passages between maze cells number one fewer than the cells
    east = free[1:2 * rows:2, 2:2 * cols - 1:2].sum()
    north = free[2:2 * rows - 1:2, 1:2 * cols:2].sum()
    assert east + north == rows * cols - 1


@pytest.mark.parametrize("seed", range(3))
def test_terrain_risk_is_smooth_and_keeps_obstacles(seed: int) -> None:
    base = random_obstacles(48, 32, 0.2, seed)
    grid = terrain_risk(base, seed, scale=3.0, amount=0.6)
    free = base.passable
    np.testing.assert_array_equal(grid.passable, free)
    assert (grid.risk[~free] == 1).all()
    assert (grid.risk[free] >= 0).all() and (grid.risk[free] < 1).all()
    assert grid.risk[free].max() <= 0.6 and grid.risk[free].max() > 0.3
    # smooth: neighbouring cells differ far less than independent draws would
    hazard = terrain_risk(random_obstacles(48, 32, 0.0, 0), seed, scale=3.0, amount=0.6).risk
    shuffled = np.random.default_rng(0).permutation(hazard.ravel()).reshape(hazard.shape)
    assert np.abs(np.diff(hazard, axis=1)).mean() < 0.3 * np.abs(np.diff(shuffled, axis=1)).mean()
    assert grid.corner_cutting == base.corner_cutting


def test_terrain_on_existing_risk_stays_below_one() -> None:
    base = Grid(np.array([[0.0, 0.9, 1.0], [0.5, 0.99, 0.0]]))
    grid = terrain_risk(base, 1, scale=1.0, amount=0.99)
    assert grid.risk[0, 2] == 1
    assert (grid.risk[base.passable] >= base.risk[base.passable]).all()
    assert (grid.risk[base.passable] < 1).all()


def test_bad_generator_arguments() -> None:
    with pytest.raises(CbrError, match="density must be within"):
        random_obstacles(5, 5, 1.5, 0)
    with pytest.raises(CbrError, match="at least 3x3"):
        maze(2, 9, 0)
    with pytest.raises(CbrError, match="at least 1"):
        office(10, 10, 0, door=0)
    with pytest.raises(CbrError, match=r"within \[0, 1\)"):
        terrain_risk(maze(5, 5, 0), 0, amount=1.0)
    with pytest.raises(CbrError, match="scale must be positive"):
        terrain_risk(maze(5, 5, 0), 0, scale=0)
    with pytest.raises(CbrError, match="expected a grid kind"):
        generate("cave", 10, 10, 0)


def test_generate_keeps_the_layout_when_terrain_is_added() -> None:
    plain = generate("maze", 21, 21, 5)
    rough = generate("maze", 21, 21, 5, terrain=0.4)
    np.testing.assert_array_equal(plain.passable, rough.passable)
    assert rough.risk[rough.passable].max() > 0


@pytest.mark.parametrize("kind", ["random", "office", "maze"])
def test_generated_world_component(kind: str) -> None:
    registry = Registry()
    cbr_grid.cbr_register(registry=registry)
    options = structure_options(registry.get("world", "generated").options,
                                {"kind": kind, "width": 33, "height": 21, "density": 0.25,
                                 "terrain": 0.3, "corner_cutting": True}, "world")

    def build(seed: int) -> Grid:
        return registry.create("world", "generated", options,
                               Context(registry=registry, seed=seed))

    world = build(11)
    assert (world.width, world.height, world.corner_cutting) == (33, 21, True)
    np.testing.assert_array_equal(world.risk, build(11).risk)
    assert not np.array_equal(world.risk, build(12).risk)
    assert (world.risk[world.passable] < 1).all()
