"""Moving AI maps and scenarios: every shipped benchmark file, hand-checked lines, bad inputs."""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

import numpy as np
import pytest

import cbr_grid
import repo_paths
from cbr_grid.distances import octile
from cbr_grid.grid import Grid
from cbr_grid.movingai import Scenario, load_map, load_scen
from cbrcore.context import Context
from cbrcore.errors import CbrError, ConfigError
from cbrcore.options import paths_relative_to, structure_options
from cbrcore.registry import Registry

DATA = repo_paths.DATA / "movingai"

# map, scenario file, width, height, scenarios (non-blank lines after the version line)
PAIRS = [
    ("dao/arena.map", "dao/arena.map.scen", 49, 49, 160),
    ("dao/den312d.map", "dao/den312d.map.scen", 65, 81, 320),
    ("dao/den520d.map", "dao/den520d.map.scen", 256, 257, 888),
    ("dao/brc202d.map", "dao/brc202d.map.scen", 530, 481, 2519),
    ("bg512/AR0011SR.map", "bg512/AR0011SR.map.scen", 512, 512, 1280),
    ("cities/Berlin_1_256.map", "cities/Berlin_1_256.map.scen", 256, 256, 910),
    ("mazes/maze512-1-0.map", "mazes/maze512-1-0.map.scen", 512, 512, 11960),
    ("random/random512-10-0.map", "random/random512-10-0.map.scen", 512, 512, 1670),
    ("rooms/8room_000.map", "rooms/8room_000.map.scen", 512, 512, 1940),
    ("mapf/random-32-32-20.map", "mapf/random-32-32-20-random-1.scen", 32, 32, 409),
    ("mapf/empty-32-32.map", "mapf/empty-32-32-random-1.scen", 32, 32, 512),
    ("mapf/room-64-64-8.map", "mapf/room-64-64-8-random-1.scen", 64, 64, 1000),
    ("mapf/maze-128-128-10.map", "mapf/maze-128-128-10-random-1.scen", 128, 128, 1000),
    ("mapf/warehouse-10-20-10-2-1.map", "mapf/warehouse-10-20-10-2-1-random-1.scen",
     161, 63, 1000),
]


def test_every_shipped_map_and_scenario_file_is_listed() -> None:
    assert sorted(str(p.relative_to(DATA / "maps")) for p in DATA.glob("maps/*/*.map")) == sorted(
        m for m, *_ in PAIRS)
    assert sorted(str(p.relative_to(DATA / "scenarios"))
                  for p in DATA.glob("scenarios/*/*.scen")) == sorted(s for _, s, *_ in PAIRS)


@pytest.mark.parametrize(("map_file", "scen_file", "width", "height", "count"), PAIRS,
                         ids=[m for m, *_ in PAIRS])
def test_shipped_pair_loads(map_file: str, scen_file: str, width: int, height: int,
                           count: int) -> None:
    path = DATA / "maps" / map_file
    grid = load_map(path)
    assert (grid.width, grid.height) == (width, height)
    rows = path.read_text().splitlines()[4:]
    assert int(grid.passable.sum()) == sum(row.count(c) for row in rows for c in ".GS")
    assert set(np.unique(grid.risk).tolist()) <= {0.0, 1.0}

    scenarios = load_scen(DATA / "scenarios" / scen_file, grid)
    assert len(scenarios) == count
    starts = np.array([s.start for s in scenarios])
    goals = np.array([s.goal for s in scenarios])
    optimal = np.array([s.optimal for s in scenarios])
    precision = np.array([s.precision for s in scenarios])
    # every problem is posed between passable cells and is at least its octile distance, within
    # the tolerance Scenario.agrees allows
    assert grid.passable[starts[:, 1], starts[:, 0]].all()
    assert grid.passable[goals[:, 1], goals[:, 0]].all()
    assert (octile(starts, goals) <= optimal + 2 * precision + 1e-9 * optimal).all()


def test_optimal_lengths_on_the_empty_map_agree_with_octile() -> None:
    # without obstacles the optimal length is the octile distance; the file truncates it
    scenarios = load_scen(DATA / "scenarios" / "mapf" / "empty-32-32-random-1.scen")
    assert all(s.agrees(float(octile(s.start, s.goal))) for s in scenarios)
    truncated = [s for s in scenarios if float(octile(s.start, s.goal)) > s.optimal + s.precision]
    assert truncated, "half a unit is not enough: the file truncates"


def test_agrees_allows_one_unit_in_the_last_digit() -> None:
    scenario = Scenario(0, "m.map", 9, 9, (0, 0), (1, 1), 1.41, 0.005)
    assert scenario.agrees(1.4142) and scenario.agrees(1.4199) and scenario.agrees(1.4001)
    assert not scenario.agrees(1.4201) and not scenario.agrees(1.3999)


@pytest.mark.parametrize(("scen_file", "index", "expected"), [
    # line 2 of arena: "0 maps/dao/arena.map 49 49 1 11 1 12 1", an integer length
    ("dao/arena.map.scen", 0,
     Scenario(0, "maps/dao/arena.map", 49, 49, (1, 11), (1, 12), 1.0, 0.5)),
    # line 3 of bg512: "33 maps/bgmaps/AR0011SR.map 512 512 244 370 359 376 132.40", spaces
    ("bg512/AR0011SR.map.scen", 1,
     Scenario(33, "maps/bgmaps/AR0011SR.map", 512, 512, (244, 370), (359, 376), 132.40, 0.005)),
    # line 2 of Berlin: 8 decimals
    ("cities/Berlin_1_256.map.scen", 0,
     Scenario(0, "Berlin_1_256.map", 256, 256, (233, 225), (231, 224), 2.41421356, 5e-9)),
    # line 3 of brc202d: 6 significant digits
    ("dao/brc202d.map.scen", 1,
     Scenario(0, "maps/dao/brc202d.map", 530, 481, (108, 144), (107, 146), 2.41421, 5e-6)),
    # line 5 of maze512-1-0: "1 maps/mazes/maze512-1-0.map 512 512 505 197 502 199 7"
    ("mazes/maze512-1-0.map.scen", 3,
     Scenario(1, "maps/mazes/maze512-1-0.map", 512, 512, (505, 197), (502, 199), 7.0, 0.5)),
])
def test_scenario_lines_by_hand(scen_file: str, index: int, expected: Scenario) -> None:
    assert load_scen(DATA / "scenarios" / scen_file)[index] == expected


def test_shipped_map_cells_by_hand() -> None:
    # arena.map: row 0 is all trees, row 1 starts "TTT" then ground
    grid = load_map(DATA / "maps" / "dao" / "arena.map")
    assert not grid.passable[0].any()
    assert grid.passable[1, :3].tolist() == [False, False, False]
    assert grid.passable[1, 3]


MAP_3X2 = "type octile\nheight 2\nwidth 3\nmap\n.G@\nSTW\n"


def write(tmp_path: Path, name: str, text: str, newline: str = "\n") -> Path:
    path = tmp_path / name
    path.write_bytes(text.replace("\n", newline).encode("ascii"))
    return path


def test_small_map(tmp_path: Path) -> None:
    grid = load_map(write(tmp_path, "small.map", MAP_3X2), corner_cutting=True)
    assert grid.risk.tolist() == [[0.0, 0.0, 1.0], [0.0, 1.0, 1.0]]
    assert grid.corner_cutting is True


def test_crlf_map_equals_lf_map(tmp_path: Path) -> None:
    crlf = load_map(write(tmp_path, "crlf.map", MAP_3X2, "\r\n"))
    lf = load_map(write(tmp_path, "lf.map", MAP_3X2))
    assert np.array_equal(crlf.risk, lf.risk)


@pytest.mark.parametrize(("text", "line", "message"), [
    ("", 1, "expected the Moving AI header 'type octile', the file ends"),
    ("type hex\nheight 2\nwidth 3\nmap\n", 1, "expected the Moving AI header 'type octile'"),
    ("type octile\nheight two\nwidth 3\nmap\n", 2,
     "expected 'height' followed by a positive integer"),
    ("type octile\nwidth 3\nheight 2\nmap\n", 2,
     "expected 'height' followed by a positive integer"),
    ("type octile\nheight 2\nwidth 0\nmap\n", 3, "positive integer, got '0'"),
    ("type octile\nheight 2\nwidth 3\n", 4, "expected 'map', got the end of the file"),
    ("type octile\nheight 2\nwidth 3\nmaps\n", 4, "expected 'map'"),
    ("type octile\nheight 2\nwidth 3\nmap\n...\n", 6,
     "expected 2 map rows (height 2), the file ends after 1"),
    ("type octile\nheight 2\nwidth 3\nmap\n...\n..\n", 6,
     "expected a row of 3 characters (width 3), got 2"),
    ("type octile\nheight 2\nwidth 3\nmap\n...\n.x.\n", 6,
     "unknown map character at column 2; expected one of . G S (passable) or @ O T W"),
    ("type octile\nheight 2\nwidth 3\nmap\n...\n...\n\n...\n", 8,
     "expected the end of the map after 2 rows (height 2), got more text"),
])
def test_bad_map_names_file_and_line(tmp_path: Path, text: str, line: int,
                                     message: str) -> None:
    path = write(tmp_path, "bad.map", text)
    with pytest.raises(CbrError) as error:
        load_map(path)
    assert str(error.value).startswith(f"{path}, line {line}: ")
    assert message in str(error.value)


def test_missing_map_file(tmp_path: Path) -> None:
    with pytest.raises(CbrError, match=r"nowhere\.map: cannot read"):
        load_map(tmp_path / "nowhere.map")


SCEN = "version 1\n0\tsmall.map\t3\t2\t0\t0\t1\t1\t1.41421\n\n3 small.map 3 2 1 0 0 0 1\n"


def test_small_scen(tmp_path: Path) -> None:
    grid = load_map(write(tmp_path, "small.map", MAP_3X2))
    first, second = load_scen(write(tmp_path, "small.scen", SCEN, "\r\n"), grid)
    assert first == Scenario(0, "small.map", 3, 2, (0, 0), (1, 1), 1.41421, 5e-6)
    assert second == Scenario(3, "small.map", 3, 2, (1, 0), (0, 0), 1.0, 0.5)
    assert load_scen(write(tmp_path, "v10.scen", SCEN.replace("version 1", "version 1.0")))


@pytest.mark.parametrize(("text", "line", "message"), [
    ("", 1, "expected 'version 1' or 'version 1.0', got an empty file"),
    ("version 2\n", 1, "expected 'version 1' or 'version 1.0'"),
    ("version 1\n0 m.map 3 2 0 0 1 1\n", 2,
     "expected 9 fields (bucket map width height start_x start_y goal_x goal_y optimal), got 8"),
    ("version 1\n0 m.map 3 2 0 0 1 1 1\n0 m.map 3 2 0 a 1 1 1\n", 3,
     "expected an integer start_y"),
    ("version 1\n--1 m.map 3 2 0 0 1 1 1\n", 2, "expected an integer bucket"),
    ("version 1\n0 m.map 3 2 0 0 1 1 far\n", 2,
     "expected a non-negative optimal length"),
    ("version 1\n0 m.map 3 2 0 0 1 1 nan\n", 2, "non-negative optimal length, got 'nan'"),
    ("version 1\n0 m.map 3 2 0 0 1 1 -1\n", 2, "non-negative optimal length, got '-1'"),
    ("version 1\n0 m.map 3 2 0 0 3 1 2\n", 2, "goal (3, 1) is outside the 3x2 map"),
    ("version 1\n0 m.map 0 2 0 0 0 0 0\n", 2, "expected a positive map size, got 0x2"),
])
def test_bad_scen_names_file_and_line(tmp_path: Path, text: str, line: int,
                                      message: str) -> None:
    path = write(tmp_path, "bad.scen", text)
    with pytest.raises(CbrError) as error:
        load_scen(path)
    assert str(error.value).startswith(f"{path}, line {line}: ")
    assert message in str(error.value)


def test_scen_for_another_map_size(tmp_path: Path) -> None:
    path = write(tmp_path, "other.scen",
                 "version 1\n0 m.map 3 2 0 0 1 1 1\n0 m.map 4 2 0 0 1 1 1\n")
    grid = Grid(np.zeros((2, 3)))
    assert len(load_scen(path)) == 2
    with pytest.raises(CbrError) as error:
        load_scen(path, grid)
    assert str(error.value) == (f"{path}, line 3: the scenario is for a 4x2 map, "
                                f"the given map is 3x2")


def test_grid_plugin_is_an_installed_entry_point() -> None:
    found = {ep.name: ep.value for ep in importlib.metadata.entry_points(group="cbr")}
    assert found.get("grid") == "cbr_grid"


def test_movingai_world_component(tmp_path: Path) -> None:
    write(tmp_path, "small.map", MAP_3X2)
    registry = Registry()
    cbr_grid.cbr_register(registry=registry)
    component = registry.get("world", "movingai")
    assert component.summary.startswith("A grid read from a Moving AI .map file")
    with paths_relative_to(tmp_path):
        options = structure_options(component.options, {"map": "small.map",
                                                        "corner_cutting": True}, "world")
    world = registry.create("world", "movingai", options, Context(registry=registry, seed=0))
    assert isinstance(world, Grid)
    assert (world.width, world.height, world.corner_cutting) == (3, 2, True)


def test_movingai_world_options_are_strict() -> None:
    registry = Registry()
    cbr_grid.cbr_register(registry=registry)
    options = registry.get("world", "movingai").options
    with pytest.raises(ConfigError) as error:
        structure_options(options, {"corner_cutting": "yes"}, "world")
    assert error.value.problems == ["world.map: required option is missing",
                                    "world.corner_cutting: expected true or false, got 'yes'"]
