"""``cbr plan`` and ``cbr map show`` through the installed plugins: paths, errors, pictures."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from cbr_grid.costs import path_length, turns
from cbr_grid.formats import load_grid
from cbr_grid.movingai import Scenario, load_scen
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult
from repo_paths import DATA

Cli = Callable[..., CliResult]

MOVINGAI = DATA / "movingai"
DEPOT = DATA / "ros" / "depot.yaml"
ARENA = MOVINGAI / "maps" / "dao" / "arena.map"
ARENA_SCEN = MOVINGAI / "scenarios" / "dao" / "arena.map.scen"
KEYS = {"solver", "length", "cost", "turns", "time_ms", "expanded", "path"}
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

# A wall down column 2 keeps the right half out of reach of the left half.
WALLED = """type octile
height 3
width 5
map
..@..
..@..
..@..
"""

@pytest.fixture(autouse=True)
def installed(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    """The installed plugins, grid and solvers among them, made current for every test."""
    return cbr_plugins(entry_points=True)


@pytest.fixture
def walled(tmp_path: Path) -> Path:
    path = tmp_path / "walled.map"
    path.write_text(WALLED, encoding="ascii")
    return path


def longest_scenario() -> Scenario:
    """The arena scenario with the longest optimal path: the most turns to get right."""
    return max(load_scen(ARENA_SCEN), key=lambda scenario: scenario.optimal)


def cell_option(cell: tuple[int, int]) -> str:
    return f"{cell[0]},{cell[1]}"


@pytest.mark.parametrize("solver", ["dijkstra", "astar"])
def test_plan_prints_an_optimal_path_as_json(invoke_cbr: Cli, solver: str) -> None:
    scenario = longest_scenario()
    result = invoke_cbr("plan", str(ARENA), "--start", cell_option(scenario.start), "--goal",
                     cell_option(scenario.goal), "--solver", solver, "--json")
    assert result.exit_code == 0, result.stderr
    record = json.loads(result.stdout)
    assert set(record) == KEYS
    assert record["solver"] == solver
    path = [tuple(cell) for cell in record["path"]]
    assert path[0] == scenario.start
    assert path[-1] == scenario.goal
    assert scenario.agrees(record["length"])
    assert record["length"] == pytest.approx(path_length(path))
    # on a map without risk a path's cost is its length
    assert record["cost"] == pytest.approx(record["length"])
    assert record["turns"] == turns(path)
    assert isinstance(record["expanded"], int)
    assert record["expanded"] >= len(path)
    assert record["time_ms"] >= 0


def test_plan_prints_the_metrics_as_text(invoke_cbr: Cli) -> None:
    scenario = longest_scenario()
    result = invoke_cbr("plan", str(ARENA), "--start", cell_option(scenario.start), "--goal",
                     cell_option(scenario.goal))
    assert result.exit_code == 0, result.stderr
    values = dict(line.split(maxsplit=1) for line in result.stdout.splitlines())
    assert list(values) == ["length", "cost", "turns", "time_ms", "expanded", "path"]
    assert scenario.agrees(float(values["length"]))
    # the path itself is left to --json and --path-out: one short line says where it goes
    assert values["path"].endswith(f"cells from {scenario.start} to {scenario.goal}")


def test_plan_without_a_path_exits_1(invoke_cbr: Cli, walled: Path) -> None:
    result = invoke_cbr("plan", str(walled), "--start", "0,0", "--goal", "4,2", "--json")
    assert result.exit_code == 1
    assert result.stdout == ""
    assert f"no path from (0, 0) to (4, 2) on {walled}" in result.stderr


@pytest.mark.parametrize(("start", "goal", "message"), [
    ("5,0", "0,2", "start (5, 0) is outside the 5x3 grid"),
    ("0,0", "0,-1", "goal (0, -1) is outside the 5x3 grid"),
    ("2,1", "0,0", "start (2, 1) is on an obstacle"),
    ("0,0", "2,2", "goal (2, 2) is on an obstacle"),
])
def test_plan_names_a_bad_cell(invoke_cbr: Cli, walled: Path, start: str, goal: str,
                               message: str) -> None:
    result = invoke_cbr("plan", str(walled), "--start", start, "--goal", goal)
    assert result.exit_code == 2
    assert f"error: {message}" in result.stderr


@pytest.mark.parametrize("written", ["1,x", "1", "1,2,3", ""])
def test_plan_refuses_a_malformed_cell(invoke_cbr: Cli, walled: Path, written: str) -> None:
    result = invoke_cbr("plan", str(walled), "--start", written, "--goal", "0,0")
    assert result.exit_code == 2
    assert "Invalid value for '--start'" in result.stderr
    assert "X,Y" in result.stderr


@pytest.mark.parametrize("args", [
    ("--start", "0,0"),
    ("--goal", "0,0"),
    ("--start", "0,0", "--goal", "1,1", "--limit", "3"),
    ("--scen", str(ARENA_SCEN), "--start", "0,0"),
    ("--scen", str(ARENA_SCEN), "--plot", "out.png"),
])
def test_plan_refuses_options_that_do_not_go_together(invoke_cbr: Cli, args: tuple[str, ...]
                                                      ) -> None:
    result = invoke_cbr("plan", str(ARENA), *args)
    assert result.exit_code == 2
    assert "Invalid value" in result.stderr


def test_plan_scen_prints_a_line_per_scenario_and_a_summary(invoke_cbr: Cli) -> None:
    result = invoke_cbr("plan", str(ARENA), "--scen", str(ARENA_SCEN), "--limit", "5", "--json")
    assert result.exit_code == 0, result.stderr
    *records, summary = [json.loads(line) for line in result.stdout.splitlines()]
    assert len(records) == 5
    scenarios = load_scen(ARENA_SCEN)
    optimal = {(s.start, s.goal): s for s in scenarios}
    for record in records:
        assert set(record) == {*KEYS, "optimal"}
        scenario = optimal[tuple(record["path"][0]), tuple(record["path"][-1])]
        assert record["optimal"] == scenario.optimal
        assert scenario.agrees(record["length"])
    # spread over the buckets: the first scenario of the first bucket and the last of the last
    by_bucket = sorted(scenarios, key=lambda scenario: scenario.bucket)
    assert records[0]["optimal"] == by_bucket[0].optimal
    assert records[-1]["optimal"] == by_bucket[-1].optimal
    assert summary["matched"] == 5
    assert summary["total"] == 5
    assert math.isfinite(summary["median_time_ms"])


def test_map_show_draws_the_map(invoke_cbr: Cli, tmp_path: Path) -> None:
    out = tmp_path / "arena.png"
    result = invoke_cbr("map", "show", str(ARENA), "--plot", str(out))
    assert result.exit_code == 0, result.stderr
    assert f"{ARENA}: 49x49" in result.stdout
    data = out.read_bytes()
    assert data.startswith(PNG_SIGNATURE)
    assert len(data) > len(PNG_SIGNATURE)


def test_plan_plot_draws_the_path(invoke_cbr: Cli, tmp_path: Path) -> None:
    scenario = longest_scenario()
    out = tmp_path / "path.png"
    result = invoke_cbr("plan", str(ARENA), "--start", cell_option(scenario.start), "--goal",
                     cell_option(scenario.goal), "--plot", str(out), "--json")
    assert result.exit_code == 0, result.stderr
    assert set(json.loads(result.stdout)) == KEYS
    data = out.read_bytes()
    assert data.startswith(PNG_SIGNATURE)
    assert len(data) > len(PNG_SIGNATURE)


def test_a_plot_that_cannot_be_written_is_a_user_error(invoke_cbr: Cli, tmp_path: Path) -> None:
    out = tmp_path / "missing" / "arena.png"
    result = invoke_cbr("map", "show", str(ARENA), "--plot", str(out))
    assert result.exit_code == 2
    assert f"error: {out}: cannot write the picture" in result.stderr


# depot (0.05 m cells, origin (0, 0), 307 rows): (2, 2) m is cell (40, 266), (20, 3.5) m cell
# (400, 236); see tests/grid/test_ros_maps.py
DEPOT_START, DEPOT_GOAL = (40, 266), (400, 236)


def depot_clearance(path: list[list[int]]) -> float:
    """The least distance in metres from a path cell to an obstacle of the depot, by brute
    force."""
    depot = load_grid(DEPOT)
    obstacles = np.argwhere(~depot.passable)[:, ::-1]
    cells = np.array(path)
    return float(np.hypot(*(cells[:, None, :] - obstacles[None]).transpose(2, 0, 1)).min()) * 0.05


def test_plan_a_ros_map_from_metres_to_metres_with_inflation(invoke_cbr: Cli, tmp_path: Path
                                                            ) -> None:
    out = tmp_path / "depot.png"
    common = ("plan", str(DEPOT), "--frame", "map", "--start", "2,2", "--goal", "20,3.5")
    result = invoke_cbr(*common, "--robot-radius", "0.22", "--json", "--plot", str(out))
    assert result.exit_code == 0, result.stderr
    record = json.loads(result.stdout)
    assert set(record) == {*KEYS, "length_m", "path_m"}
    assert tuple(record["path"][0]) == DEPOT_START
    assert tuple(record["path"][-1]) == DEPOT_GOAL
    assert record["length_m"] == pytest.approx(record["length"] * 0.05)
    # metres are the cell centres: (x + 0.5) * 0.05 and (307 - y - 0.5) * 0.05
    assert record["path_m"][0] == pytest.approx([2.025, 2.025])
    assert record["path_m"][-1] == pytest.approx([20.025, 3.525])
    assert depot_clearance(record["path"]) > 0.22
    assert out.read_bytes().startswith(PNG_SIGNATURE)
    # without inflation the shortest path passes closer than the robot's radius
    plain = invoke_cbr(*common, "--json")
    assert plain.exit_code == 0, plain.stderr
    assert depot_clearance(json.loads(plain.stdout)["path"]) < 0.22

    text = invoke_cbr(*common, "--robot-radius", "0.22", "--inflation-radius", "0.55",
                   "--cost-scaling", "3")
    assert text.exit_code == 0, text.stderr
    values = dict(line.split(maxsplit=1) for line in text.stdout.splitlines())
    assert list(values) == ["length", "cost", "turns", "time_ms", "expanded", "length_m",
                            "path"]
    # the ends are the centres of the cells the points fall in
    assert values["path"].endswith("cells from (2.025, 2.025) m [cell 40, 266] to "
                                   "(20.025, 3.525) m [cell 400, 236]")
    # the decaying cost makes the path dearer than its length
    assert float(values["cost"]) > float(values["length"])


def test_plan_takes_cells_off_a_robot_radius_on_an_inflated_map(invoke_cbr: Cli) -> None:
    # (40, 266) and (400, 236) are the cells of (2, 2) m and (20, 3.5) m, more than 0.22 m from
    # a shelf; the path found keeps off every cell the inflation blocked
    result = invoke_cbr("plan", str(DEPOT), "--start", "40,266", "--goal", "400,236",
                     "--robot-radius", "0.22", "--json")
    assert result.exit_code == 0, result.stderr
    path = np.array(json.loads(result.stdout)["path"])
    assert path[0].tolist() == [40, 266] and path[-1].tolist() == [400, 236]
    blocked = ~load_grid(DEPOT).passable
    ys, xs = np.nonzero(blocked)
    obstacles = np.column_stack((xs, ys))
    nearest = np.array([np.hypot(*(obstacles - cell).T).min() for cell in path])
    assert (nearest * 0.05 > 0.22).all()


@pytest.mark.parametrize(("args", "message"), [
    (("--frame", "map", "--start", "-1,2", "--goal", "20,3.5"),
     "--start (-1, 2) m [cell -20, 266] is outside the 604x307 grid, which covers "
     "x 0 to 30.2 m and y 0 to 15.35 m"),
    # the centre of cell (150, 75), a leg of a shelf: x 150.5 cells, y 307 - 75 - 0.5 cells
    (("--frame", "map", "--start", "2,2", "--goal", "7.525,11.575"),
     "--goal (7.525, 11.575) m [cell 150, 75] is on an obstacle"),
    (("--frame", "map", "--start", "2,2", "--goal", "20,3.5", "--robot-radius", "0.6"),
     "--goal (20, 3.5) m [cell 400, 236] is within the robot radius (0.6 m) of an "
     "obstacle"),
    (("--start", "40,266", "--goal", "400,236", "--robot-radius", "0.6"),
     "goal (400, 236) is within the robot radius (0.6 m) of an obstacle"),
])
def test_plan_names_a_bad_point_and_its_cell(invoke_cbr: Cli, args: tuple[str, ...],
                                             message: str) -> None:
    result = invoke_cbr("plan", str(DEPOT), *args)
    assert result.exit_code == 2
    assert f"error: {message}" in result.stderr
    assert "Traceback" not in result.stderr


CIRCULAR = DEPOT.parent / "map_circular.yaml"


UNKNOWN_HINT = ("on an unknown cell (lethal as unknown space is not allowed; --allow-unknown "
                "lets a planner cross it)")


@pytest.mark.parametrize(("args", "said"), [
    # map_circular: origin (-10, -10) m, 0.05 m cells, 384 rows: (0, 8) m is the cell
    # (200, 383 - 360), in the unknown space outside the mapped room
    # the goals are the unknown top-left corner cell (0, 0), in metres its centre
    (("--frame", "map", "--start", "0,8", "--goal", "-9.975,9.175"),
     "--start (0, 8) m [cell 200, 23] is"),
    (("--start", "200,23", "--goal", "0,0"), "start (200, 23) is"),
])
def test_plan_says_how_to_cross_an_unknown_cell(invoke_cbr: Cli, args: tuple[str, ...],
                                                said: str) -> None:
    assert load_grid(CIRCULAR).unknown[23, 200]
    result = invoke_cbr("plan", str(CIRCULAR), *args, "--no-allow-unknown")
    assert result.exit_code == 2
    assert f"error: {said} {UNKNOWN_HINT}" in result.stderr
    # unknown space allowed, Nav2's default, the same start is a start like any other
    for allowed in ((), ("--allow-unknown",)):
        crossing = invoke_cbr("plan", str(CIRCULAR), *args, *allowed)
        assert crossing.exit_code == 0, crossing.stderr


@pytest.mark.parametrize(("map_file", "args", "option"), [
    (ARENA, ("--frame", "map", "--start", "1,1", "--goal", "2,2"), "'--frame'"),
    (DEPOT, ("--scen", str(ARENA_SCEN)), "'--scen'"),
    (ARENA, ("--scen", str(ARENA_SCEN), "--frame", "map"), "'--frame'"),
    (DEPOT, ("--frame", "map", "--start", "2,x", "--goal", "1,1"), "'--start'"),
    (DEPOT, ("--frame", "map", "--start", "2,nan", "--goal", "1,1"), "'--start'"),
    (DEPOT, ("--start", "40,266", "--goal", "400,236", "--inflation-radius", "1"),
     "'--robot-radius'"),
    (DEPOT, ("--start", "40,266", "--goal", "400,236", "--robot-radius", "0.5",
             "--inflation-radius", "0.2"), "'--inflation-radius'"),
    (DEPOT, ("--start", "40,266", "--goal", "400,236", "--frame", "metres"),
     "--frame: 'metres' is not one of cell, map"),
])
def test_plan_refuses_frames_and_inflation_that_do_not_apply(
        invoke_cbr: Cli, map_file: Path, args: tuple[str, ...], option: str) -> None:
    result = invoke_cbr("plan", str(map_file), *args)
    assert result.exit_code == 2
    assert option in result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize(("args", "message"), [
    (("--robot-radius", "0.2", "--cost-scaling", "inf"),
     "Invalid value for '--cost-scaling': must be a finite number >= 0, got inf"),
    (("--robot-radius", "inf"), "Invalid value for '--robot-radius': must be a finite number "
                                ">= 0, got inf"),
    (("--robot-radius", "0.5", "--inflation-radius", "0.2"),
     "Invalid value for '--inflation-radius': must be at least --robot-radius (0.5), got 0.2"),
])
def test_plan_names_the_inflation_option_at_fault_as_written(
        invoke_cbr: Cli, args: tuple[str, ...], message: str) -> None:
    result = invoke_cbr("plan", str(DEPOT), "--start", "40,266", "--goal", "400,236", *args)
    assert result.exit_code == 2
    assert message in " ".join(result.stderr.split())
    assert "_" not in result.stderr.split("Invalid value")[1]


@pytest.mark.parametrize(("args", "hint"), [
    (("--robot-radius", "1"), "'--robot-radius'"),
    (("--robot-radius", "1", "--inflation-radius", "2"), "'--robot-radius' / '--inflation-radius'"),
    (("--cost-scaling", "2"), "'--cost-scaling'"),
])
def test_plan_refuses_inflation_with_scenarios(invoke_cbr: Cli, args: tuple[str, ...],
                                               hint: str) -> None:
    # the file's optimal lengths are those of the map uninflated: no inflated path could agree
    result = invoke_cbr("plan", str(ARENA), "--scen", str(ARENA_SCEN), *args)
    assert result.exit_code == 2
    assert (f"Invalid value for {hint}: a scenario file's optimal lengths are for the map as it "
            "is: --scen plans without inflation") in " ".join(result.stderr.split())
    assert "Traceback" not in result.stderr


def turned_depot(folder: Path, yaw: float) -> Path:
    """The depot map with its origin turned by ``yaw`` radians."""
    text = DEPOT.read_text(encoding="utf-8")
    path = folder / f"turned_{yaw:g}.yaml"
    path.write_text("\n".join(f"image: {DEPOT.parent / 'depot.pgm'}" if line.startswith("image:")
                              else f"origin: [0.0, 0.0, {yaw!r}]" if line.startswith("origin:")
                              else line for line in text.splitlines()), encoding="utf-8")
    return path


@pytest.mark.parametrize("command", [("map", "show"), ("plan",)])
def test_a_turned_map_warns_once_that_nav2_ignores_the_yaw(invoke_cbr: Cli, tmp_path: Path,
                                                           command: tuple[str, ...]) -> None:
    plan = ("--start", "40,266", "--goal", "400,236") if command == ("plan",) else ()
    turned = invoke_cbr(*command, str(turned_depot(tmp_path, 0.5)), *plan)
    assert turned.exit_code == 0, turned.stderr
    warnings = [line for line in turned.stderr.splitlines() if line.startswith("warning:")]
    assert warnings == [f"warning: {tmp_path / 'turned_0.5.yaml'}: the origin's yaw is 0.5 rad; "
                        "metre coordinates here are turned by the yaw, unlike Nav2, which "
                        "ignores it"]
    straight = invoke_cbr(*command, str(turned_depot(tmp_path, 0.0)), *plan)
    assert straight.exit_code == 0, straight.stderr
    assert "warning" not in straight.stderr


def test_map_show_reads_a_ros_map_with_its_frame(invoke_cbr: Cli, tmp_path: Path) -> None:
    out = tmp_path / "depot.png"
    result = invoke_cbr("map", "show", str(DEPOT), "--robot-radius", "0.22", "--plot", str(out))
    assert result.exit_code == 0, result.stderr
    lines = result.stdout.splitlines()
    plain = load_grid(DEPOT)
    # inflation blocks more cells than the map's own obstacles
    passable = int(lines[0].split(", ")[1].split()[0])
    assert passable < int(plain.passable.sum())
    assert lines[0].startswith(f"{DEPOT}: 604x307, ") and lines[0].endswith(", 0 unknown")
    assert lines[1] == ("frame: 0.05 m per cell, origin (0, 0, yaw 0), x 0 to 30.2 m, "
                        "y 0 to 15.35 m")
    assert out.read_bytes().startswith(PNG_SIGNATURE)


def test_map_show_reads_every_format(invoke_cbr: Cli, tmp_path: Path) -> None:
    (tmp_path / "small.grid").write_text(".#\n..\n", encoding="ascii")
    np.save(tmp_path / "risk.npy", np.array([[0.0, 1.0, 0.5]]))
    for path, size, passable in ((tmp_path / "small.grid", "2x2", 3),
                                 (tmp_path / "risk.npy", "3x1", 2)):
        result = invoke_cbr("map", "show", str(path))
        assert result.exit_code == 0, result.stderr
        assert result.stdout.strip() == f"{path}: {size}, {passable} passable cells, 0 unknown"


def test_map_show_json_gives_the_facts_of_the_text(invoke_cbr: Cli, tmp_path: Path) -> None:
    out = tmp_path / "depot.png"
    result = invoke_cbr("map", "show", str(DEPOT), "--json", "--plot", str(out))
    assert result.exit_code == 0, result.stderr
    plain = load_grid(DEPOT)
    assert json.loads(result.stdout) == {
        "map": str(DEPOT), "width": 604, "height": 307,
        "passable": int(plain.passable.sum()), "unknown": 0,
        "frame": {"resolution": 0.05, "origin": [0.0, 0.0, 0.0], "x": [0.0, pytest.approx(30.2)],
                  "y": [0.0, pytest.approx(15.35)]}}
    assert out.read_bytes().startswith(PNG_SIGNATURE)

    grid = tmp_path / "small.grid"
    grid.write_text(".#\n..\n", encoding="ascii")
    result = invoke_cbr("map", "show", str(grid), "--json")
    assert json.loads(result.stdout) == {"map": str(grid), "width": 2, "height": 2,
                                         "passable": 3, "unknown": 0, "frame": None}


def read_csv_path(path: Path) -> tuple[str, np.ndarray]:
    """The header and the (n, 2) points of a path CSV file, read with the csv module."""
    import csv

    with path.open(newline="", encoding="utf-8") as file:
        header, *rows = csv.reader(file)
    return ",".join(header), np.array(rows, dtype=np.float64)


@pytest.mark.parametrize("frame", ["cell", "map"])
@pytest.mark.parametrize("name", ["path.csv", "path.geojson", "path.json"])
def test_plan_writes_the_path_it_found_to_a_file(invoke_cbr: Cli, tmp_path: Path, frame: str,
                                                 name: str) -> None:
    ends = (("--start", "2,2", "--goal", "20,3.5") if frame == "map"
            else ("--start", cell_option(DEPOT_START), "--goal", cell_option(DEPOT_GOAL)))
    common = ("plan", str(DEPOT), "--frame", frame, *ends)
    cells = np.array(json.loads(invoke_cbr(*common, "--json").stdout)["path"])
    # the same cells in metres, by the map's own frame rather than by cbr plan
    expected = load_grid(DEPOT).to_map(cells) if frame == "map" else cells
    out = tmp_path / name
    result = invoke_cbr(*common, "--path-out", str(out))
    assert result.exit_code == 0, result.stderr
    if name.endswith(".csv"):
        header, points = read_csv_path(out)
        assert header == ("x_m,y_m" if frame == "map" else "x,y")
    else:
        feature = json.loads(out.read_text(encoding="utf-8"))
        assert feature["type"] == "Feature"
        assert feature["geometry"]["type"] == "LineString"
        assert feature["properties"]["units"] == ("m" if frame == "map" else "cells")
        points = np.array(feature["geometry"]["coordinates"])
    assert points.shape == expected.shape
    np.testing.assert_allclose(points, expected, rtol=0, atol=1e-9)
    # the screen gets a summary, not the path
    lines = result.stdout.splitlines()
    assert lines[-1] == f"wrote {out}"
    assert lines[-2].startswith(f"path      {len(cells)} cells from ")
    assert len(result.stdout) < 500


def test_plan_with_path_out_keeps_the_json_object(invoke_cbr: Cli, tmp_path: Path) -> None:
    out = tmp_path / "path.csv"
    result = invoke_cbr("plan", str(DEPOT), "--frame", "map", "--start", "2,2", "--goal", "20,3.5",
                     "--path-out", str(out), "--json")
    assert result.exit_code == 0, result.stderr
    record = json.loads(result.stdout)
    np.testing.assert_allclose(read_csv_path(out)[1], record["path_m"], rtol=0, atol=1e-9)


def test_plan_says_when_it_cannot_write_the_path(invoke_cbr: Cli, tmp_path: Path) -> None:
    out = tmp_path / "missing" / "path.csv"
    result = invoke_cbr("plan", str(DEPOT), "--start", cell_option(DEPOT_START), "--goal",
                     cell_option(DEPOT_GOAL), "--path-out", str(out))
    assert result.exit_code == 2
    assert f"error: {out}: cannot write the path: " in result.stderr
    assert "Traceback" not in result.stderr


def test_plan_without_a_path_in_metres_names_the_points_and_cells(
        invoke_cbr: Cli, tmp_path: Path) -> None:
    # the walled map as a ROS map of 0.5 m cells from (0, 0): 3 rows, so the cell (x, y) spans
    # x 0.5 x to 0.5 (x + 1) m and y 0.5 (2 - y) to 0.5 (3 - y) m
    rows = WALLED.splitlines()[4:]
    pixels = bytes(0 if c == "@" else 254 for row in rows for c in row)
    (tmp_path / "walled.pgm").write_bytes(b"P5\n5 3\n255\n" + pixels)
    (tmp_path / "walled.yaml").write_text(
        "image: walled.pgm\nresolution: 0.5\norigin: [0, 0, 0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n", encoding="utf-8")
    out = tmp_path / "path.csv"
    result = invoke_cbr("plan", str(tmp_path / "walled.yaml"), "--frame", "map", "--start",
                     "0.2,1.3", "--goal", "2.4,0.1", "--path-out", str(out))
    assert result.exit_code == 1
    assert ("no path from (0.2, 1.3) m [cell 0, 0] to (2.4, 0.1) m [cell 4, 2] on "
            in result.stderr)
    assert not out.exists()


@pytest.mark.parametrize("args", [
    # a Moving AI map has no metric frame to point to
    (str(ARENA), "--start", "1.5,1", "--goal", "2,2"),
    (str(ARENA), "--start", "1000,1", "--goal", "2,2"),
    # a number that is not one is no metre
    (str(DEPOT), "--start", "2,x", "--goal", "20,3"),
])
def test_plan_hints_at_metres_only_where_they_can_be(invoke_cbr: Cli, args: tuple[str, ...]
                                                     ) -> None:
    result = invoke_cbr("plan", *args)
    assert result.exit_code == 2
    assert "start" in result.stderr
    assert "--frame map" not in result.stderr
