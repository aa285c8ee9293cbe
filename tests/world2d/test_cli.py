"""``cbr sim show``, ``run`` and ``batch`` through the installed plugins, the pictures they draw
(checked by file signature and frame count), and every bad input refused with exit code 2 and
a message naming the item, never a traceback."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from cbr_world2d.plot import animate_trial, plot_trial, plot_world
from cbr_world2d.simulation import Trial, run_trial
from cbr_world2d.world import Door, Landmark, Mover, Wall, World
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult
from repo_paths import ROOT

Cli = Callable[..., CliResult]

WORLDS = ROOT / "plugins" / "cbr_world2d" / "worlds"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
GIF_SIGNATURE = b"GIF89a"

# an open room with a pillar, a linear obstacle between two landmarks, a door, a person and
# two places: every kind of thing `show` counts
ROOM = """\
name: room
bounds: [0, 0, 8, 6]
landmarks:
  - {id: l1, at: [5, 1], radius: 0.2}
  - {id: l2, at: [5, 2.5], radius: 0.2}
walls:
  - {between: [l1, l2]}
  - {a: [7, 4], b: [7, 6]}
polygons:
  - [[2, 4], [3, 4], [3, 5]]
points:
  - {at: [1.5, 3], radius: 0.1}
doors:
  - {a: [7, 3], b: [7, 4], period: 10, open_for: 5, phase: 0}
people:
  - {waypoints: [[6, 5], [2, 5.5]], speed: 0.5, radius: 0.25}
places:
  home: [1, 1]
  desk: [6.5, 1.5]
"""


@pytest.fixture(autouse=True)
def installed(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    """The installed plugins, world2d among them, made current for every test."""
    return cbr_plugins(entry_points=True)


@pytest.fixture
def room(tmp_path: Path) -> Path:
    path = tmp_path / "room.yaml"
    path.write_text(ROOM, encoding="utf-8")
    return path


def lines_of(output: str) -> dict[str, str]:
    """``key value`` lines as a mapping."""
    pairs = (line.split(None, 1) for line in output.splitlines() if line.strip())
    return {pair[0]: pair[1] if len(pair) > 1 else "" for pair in pairs}


def assert_png(path: Path) -> None:
    data = path.read_bytes()
    assert data.startswith(PNG_SIGNATURE)
    assert len(data) > 1000


def gif_frames(path: Path) -> int:
    assert path.read_bytes().startswith(GIF_SIGNATURE)
    with Image.open(path) as image:
        return int(image.n_frames)


# --- loading the plugin ------------------------------------------------------------------

LOADED = "print('numba' in sys.modules, 'matplotlib' in sys.modules)"


@pytest.mark.parametrize("code", [
    "import cbr_world2d",
    "from cbrcore.cli import main; main(['--help'])",
], ids=["import", "cbr --help"])
def test_loading_the_plugin_imports_neither_numba_nor_matplotlib(code: str) -> None:
    """The plugin loads at every start of cbr: its compiled kernels and its pictures are
    imported where a simulation runs or a picture is drawn, not then."""
    result = subprocess.run([sys.executable, "-c", f"import sys; {code}; {LOADED}"],
                            capture_output=True, text=True, timeout=120, check=True)
    assert result.stdout.splitlines()[-1] == "False False"


# --- show ----------------------------------------------------------------------------------

def test_show_counts_what_a_world_file_holds_and_draws_it(invoke_cbr: Cli, room: Path,
                                                          tmp_path: Path) -> None:
    out = tmp_path / "room.png"
    result = invoke_cbr("sim", "show", str(room), "--plot", str(out))
    assert result.exit_code == 0, result.stderr
    shown = lines_of(result.stdout)
    assert shown["world"] == "room"
    assert shown["bounds"] == "0,0 to 8,6 (8 x 6 m)"
    assert shown["walls"] == "2 (1 linear obstacles between landmarks)"
    assert (shown["polygons"], shown["points"], shown["landmarks"]) == ("1", "1", "2")
    assert (shown["doors"], shown["movers"]) == ("1", "1")
    assert shown["places"] == "desk, home"
    # four sides of the bounds, two walls, three polygon edges
    assert shown["segments"] == "9"
    assert f"wrote {out}" in result.stdout
    assert_png(out)


def test_show_json_counts_what_a_world_file_holds(invoke_cbr: Cli, room: Path,
                                                  tmp_path: Path) -> None:
    out = tmp_path / "room.png"
    result = invoke_cbr("sim", "show", str(room), "--json", "--plot", str(out))
    assert result.exit_code == 0, result.stderr
    assert json.loads(result.stdout) == {
        "world": "room", "bounds": [0, 0, 8, 6], "walls": 2, "linear_obstacles": 1,
        "polygons": 1, "points": 1, "landmarks": 2, "doors": 1, "movers": 1,
        "places": ["desk", "home"], "segments": 9}
    assert_png(out)


@pytest.mark.parametrize("kind", ["semi_structured", "office"])
def test_show_builds_a_generated_world(invoke_cbr: Cli, kind: str) -> None:
    from cbr_world2d import generate

    world = getattr(generate, kind)(5)
    result = invoke_cbr("sim", "show", f"generated:{kind}:5")
    assert result.exit_code == 0, result.stderr
    shown = lines_of(result.stdout)
    assert shown["landmarks"] == str(len(world.landmarks))
    assert shown["doors"] == str(len(world.doors))
    assert shown["segments"] == str(world.static_segments.shape[0])


@pytest.mark.parametrize("name", ["scenario1", "scenario2", "office"])
def test_show_reads_every_shipped_world(invoke_cbr: Cli, name: str) -> None:
    result = invoke_cbr("sim", "show", str(WORLDS / f"{name}.yaml"))
    assert result.exit_code == 0, result.stderr
    assert lines_of(result.stdout)["bounds"]


# --- run -----------------------------------------------------------------------------------

def test_run_reaches_a_place_and_writes_a_plot_and_a_gif(invoke_cbr: Cli, room: Path,
                                                         tmp_path: Path) -> None:
    png, gif = tmp_path / "trial.png", tmp_path / "trial.gif"
    result = invoke_cbr("sim", "run", str(room), "--start", "home", "--target", "3.5,1.5",
                     "--timeout", "60", "--plot", str(png), "--gif", str(gif), "--frames", "12")
    assert result.exit_code == 0, result.stderr
    shown = lines_of(result.stdout)
    assert shown["success"] == "yes (reached)"
    assert shown["trial"].startswith("1.00,1.00 -> 3.50,1.50, pilot potential_field")
    assert float(shown["time"].split()[0]) <= 60.0
    # at least the straight line, less the tolerance
    assert float(shown["distance"].split()[0]) >= math.dist((1, 1), (3.5, 1.5)) - 0.3
    assert_png(png)
    assert 2 <= gif_frames(gif) <= 12


def test_run_json_agrees_with_the_trial_run_in_code(invoke_cbr: Cli, room: Path) -> None:
    from cbr_world2d.robot import ROS_2005
    from cbr_world2d.simulation import PilotRecipe
    from cbr_world2d.worldfile import load_world

    result = invoke_cbr("sim", "run", str(room), "--start", "1,3.5", "--target", "desk",
                     "--timeout", "40", "--dt", "0.2", "--seed", "4", "--robot", "ros2005",
                     "--json")
    assert result.exit_code == 0, result.stderr
    record = json.loads(result.stdout)
    trial = Trial.facing((1.0, 3.5), (6.5, 1.5), timeout=40.0, dt=0.2)
    expected = run_trial(load_world(room), trial, PilotRecipe.named("potential_field"),
                         spec=ROS_2005, seed=4)
    assert record == {"world": "room", "start": [1.0, 3.5], "target": [6.5, 1.5],
                      "pilot": "potential_field", "robot": "ros2005", **expected.summary()}
    # 002's robot drives at 5 cm/s: 40 s cannot take it farther than 2 m
    assert record["distance"] <= 0.05 * 40.0 + 1e-9
    assert not record["success"]


def test_run_times_out_in_scenario_2_and_reports_where_it_got_stuck(invoke_cbr: Cli) -> None:
    result = invoke_cbr("sim", "run", str(WORLDS / "scenario2.yaml"), "--start", "start",
                     "--target", "target", "--timeout", "80")
    assert result.exit_code == 0, result.stderr
    shown = lines_of(result.stdout)
    assert shown["success"] == "no (timeout)"
    assert shown["time"] == "80.0 s"
    assert int(shown["stuck"].split()[0]) > 0


# --- batch ---------------------------------------------------------------------------------

def test_batch_on_two_workers_prints_what_one_worker_prints(invoke_cbr: Cli, room: Path) -> None:
    args = ("sim", "batch", str(room), "--trials", "3", "--seed", "9", "--timeout", "20",
            "--json")
    two = invoke_cbr(*args, "--workers", "2")
    one = invoke_cbr(*args, "--workers", "1")
    assert two.exit_code == 0, two.stderr
    assert one.exit_code == 0, one.stderr
    assert two.stdout == one.stdout
    *records, summary = [json.loads(line) for line in two.stdout.splitlines()]
    assert [r["trial"] for r in records] == [0, 1, 2]
    reached = [r for r in records if r["success"]]
    assert summary["trials"] == 3
    assert summary["reached"] == len(reached)
    assert summary["success_rate"] == len(reached) / 3
    if reached:
        assert summary["median_time"] == pytest.approx(float(np.median(
            [r["time"] for r in reached])), abs=1e-3)


def test_batch_prints_a_table_and_the_success_rate(invoke_cbr: Cli) -> None:
    result = invoke_cbr("sim", "batch", "generated:semi_structured:2", "--trials", "2",
                     "--timeout", "10", "--workers", "1")
    assert result.exit_code == 0, result.stderr
    header, *rows, summary = result.stdout.splitlines()
    assert header.split()[:4] == ["trial", "start", "target", "success"]
    assert [row.split()[0] for row in rows] == ["0", "1"]
    reached = sum(row.split()[3] == "yes" for row in rows)
    assert summary.startswith(f"reached {reached} of 2 ")


# --- pictures ------------------------------------------------------------------------------

BUSY = World((0.0, 0.0, 10.0, 6.0),
             walls=(Wall((5.0, 0.0), (5.0, 2.0)), Wall((4.0, 4.0), (6.0, 4.0), ("a", "b"))),
             landmarks=(Landmark("a", 3.8, 4.0, 0.2), Landmark("b", 6.2, 4.0, 0.2)),
             doors=(Door((5.0, 2.0), (5.0, 3.0), 6.0, 3.0, 0.0, "d"),),
             movers=(Mover(((8.0, 1.0), (8.0, 5.0)), 0.5, 0.25),), name="busy")


@pytest.fixture(scope="module")
def busy_result() -> object:
    from cbr_world2d.simulation import PilotRecipe

    return run_trial(BUSY, Trial.facing((1.0, 1.0), (9.0, 3.0), timeout=30.0),
                     PilotRecipe.named("potential_field"))


def test_pictures_of_a_world_and_a_trial(busy_result: object, tmp_path: Path) -> None:
    plot_world(BUSY, tmp_path / "world.png", t=2.0)
    plot_trial(BUSY, busy_result, tmp_path / "trial.png")  # type: ignore[arg-type]
    assert_png(tmp_path / "world.png")
    assert_png(tmp_path / "trial.png")


def test_an_animation_has_one_frame_per_sampled_step(busy_result: object,
                                                     tmp_path: Path) -> None:
    from cbr_world2d.simulation import PilotRecipe

    out = tmp_path / "trial.gif"
    assert animate_trial(BUSY, busy_result, out, fps=5, max_frames=7) == 7  # type: ignore[arg-type]
    assert gif_frames(out) == 7
    # fewer steps than frames asked: one frame per step
    short = run_trial(BUSY, Trial.facing((1.0, 1.0), (9.0, 3.0), timeout=0.5),
                      PilotRecipe.named("potential_field"))
    assert short.trajectory.shape[0] == 6
    assert animate_trial(BUSY, short, out, max_frames=50) == 6
    assert gif_frames(out) == 6


# --- bad input -----------------------------------------------------------------------------

def assert_refused(result: CliResult, *named: str) -> None:
    assert result.exit_code == 2, result.stdout
    assert "Traceback" not in result.stderr
    for text in named:
        assert text in result.stderr, result.stderr


@pytest.mark.parametrize(("start", "target", "named"), [
    ("5,1.75", "desk", "--start 5,1.75 is"),
    ("2.6,4.3", "desk", "--start 2.6,4.3 is inside polygon 0"),
    ("9,1", "desk", "--start 9,1 is outside the bounds"),
    ("0.1,3", "desk", "--start 0.1,3 is 0.1 m from the edge of the bounds"),
    ("home", "9,1", "--target 9,1 is outside the bounds [0, 0, 8, 6]"),
    ("home", "3,-0.5", "--target 3,-0.5 is outside the bounds"),
])
def test_run_refuses_a_start_in_the_way_or_a_target_outside(invoke_cbr: Cli, room: Path,
                                                            start: str, target: str,
                                                            named: str) -> None:
    assert_refused(invoke_cbr("sim", "run", str(room), "--start", start, "--target", target),
                   f"error: {named}")


def test_run_names_the_linear_obstacle_a_start_stands_on(invoke_cbr: Cli, room: Path) -> None:
    assert_refused(invoke_cbr("sim", "run", str(room), "--start", "5,1.75", "--target", "desk"),
                   "wall 0 (between 'l1' and 'l2')")


@pytest.mark.parametrize("written", ["1,x", "1", "1,2,3", "", "nan,1", "kitchen"])
def test_run_refuses_a_malformed_point_or_an_unknown_place(invoke_cbr: Cli, room: Path,
                                                          written: str) -> None:
    assert_refused(invoke_cbr("sim", "run", str(room), "--start", "home", "--target", written),
                   "error: --target:")


def test_an_unknown_place_lists_the_places(invoke_cbr: Cli, room: Path) -> None:
    assert_refused(invoke_cbr("sim", "run", str(room), "--start", "kitchen", "--target", "desk"),
                   "--start", "places: desk, home", "'kitchen'")


def test_an_unknown_pilot_is_named_with_the_registered_ones(invoke_cbr: Cli, room: Path) -> None:
    assert_refused(invoke_cbr("sim", "run", str(room), "--start", "home", "--target", "desk",
                           "--pilot", "wander"),
                   "unknown pilot 'wander'", "potential_field")
    assert_refused(invoke_cbr("sim", "batch", str(room), "--pilot", "wander"),
                   "unknown pilot 'wander'")


@pytest.mark.parametrize("text", ["bounds: [0, 0, .nan, 5]\n",
                                  "bounds: [0, 0, 5, 5]\nwalls:\n  - {a: [1, 1], b: [1, 1]}\n",
                                  "bounds: [0, 0, 5, 5\n"])
def test_a_broken_world_file_is_named_with_its_problem(invoke_cbr: Cli, tmp_path: Path,
                                                       text: str) -> None:
    path = tmp_path / "broken.yaml"
    path.write_text(text, encoding="utf-8")
    for args in (("show",), ("run", "--start", "1,1", "--target", "2,2"), ("batch",)):
        command, *options = args
        assert_refused(invoke_cbr("sim", command, str(path), *options), f"error: {path}")


def test_a_missing_world_file_is_named(invoke_cbr: Cli, tmp_path: Path) -> None:
    missing = tmp_path / "nowhere.yaml"
    assert_refused(invoke_cbr("sim", "show", str(missing)), f"error: {missing}", "file not found")


@pytest.mark.parametrize("world", ["generated:maze:1", "generated:office:x",
                                   "generated:office", "generated:office:-1"])
def test_a_bad_generated_world_is_named(invoke_cbr: Cli, world: str) -> None:
    assert_refused(invoke_cbr("sim", "show", world), "Invalid value for 'WORLD'", repr(world))


@pytest.mark.parametrize(("option", "value", "message"), [
    ("--timeout", "0", "Invalid value for '--timeout'"),
    ("--timeout", "-5", "Invalid value for '--timeout'"),
    ("--dt", "0", "Invalid value for '--dt'"),
    ("--tolerance", "inf", "Invalid value for '--tolerance'"),
    ("--robot", "r2d2", "--robot: 'r2d2' is not one of pioneer2dx, ros2005"),
    ("--rescue", "always", "--rescue: 'always' is not one of off, blocked, stuck")])
def test_run_refuses_a_bad_option(invoke_cbr: Cli, room: Path, option: str, value: str,
                                  message: str) -> None:
    assert_refused(invoke_cbr("sim", "run", str(room), "--start", "home", "--target", "desk",
                           option, value), message)


@pytest.mark.parametrize(("option", "value"), [("--trials", "0"), ("--workers", "0"),
                                               ("--seed", "-1"), ("--timeout", "nan")])
def test_batch_refuses_a_bad_option(invoke_cbr: Cli, room: Path, option: str, value: str) -> None:
    assert_refused(invoke_cbr("sim", "batch", str(room), option, value),
                   f"Invalid value for '{option}'")


@pytest.mark.parametrize("option", ["--plot", "--gif"])
def test_a_picture_in_a_missing_folder_is_refused_before_the_trial(invoke_cbr: Cli, room: Path,
                                                                   tmp_path: Path,
                                                                   option: str) -> None:
    out = tmp_path / "missing" / "picture"
    assert_refused(invoke_cbr("sim", "run", str(room), "--start", "home", "--target", "desk",
                           option, str(out)),
                   f"error: {option} {out}: cannot write the picture")
    assert not out.parent.exists()
