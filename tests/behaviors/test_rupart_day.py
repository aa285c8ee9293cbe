"""A delivery day you can watch: the day log's file, its pictures and ``cbr rupart day``."""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from cbr_behaviors.cli import run_world
from cbr_behaviors.daylog import DayLog
from cbr_behaviors.dayplot import (
    NO_CASE,
    OTHER_CASES,
    animate_day,
    case_colours,
    frame_times,
    plot_day,
    plot_timeline,
)
from cbr_world2d.generate import office
from cbrcore.config import load_config
from cbrcore.errors import CbrError
from cbrcore.plugins import Plugins, current
from cbrcore.run import manifest, write_json
from cbrcore.testing import CliResult
from repo_paths import ROOT

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
GIF_SIGNATURE = b"GIF89a"
CONFIGS = ROOT / "configs"
SEED = 1

Cli = Callable[..., CliResult]

# the steps recorded, as given: t, x, y, theta, v, w, case, target, busy
STEPS = [(0.1 * k, 1.0 + 0.03 * k, 5.0, 0.0, 0.3, 0.0,
          "default" if k < 40 else "corridor" if k < 90 else "doorway",
          None if k < 20 else (6.0, 5.0), k >= 20) for k in range(120)]
RETRIEVALS = [(4.0, "corridor", "behavior_case", ("situation", "plan"), 0.75, False),
              (9.0, "doorway", "behavior_case", ("impasse",), 0.5, True),
              (10.0, "move-away", "meta_plan", (), 0.25, False)]
EVENTS = [(2.0, "message", 6.0, 2.0, "room_2"), (7.5, "impasse", 3.2, 5.0, ""),
          (8.0, "collision", 3.4, 5.1, ""), (9.5, "stall", 3.5, 5.0, ""),
          (11.0, "delivered", 6.0, 2.1, "room_2"), (11.5, "missed", 10.0, 2.0, "room_3"),
          (11.9, "unfinished", 2.0, 8.0, "room_5")]


def synthetic(day: int = 0) -> DayLog:
    log = DayLog(day=day)
    for step in STEPS:
        log.step(*step)
    for retrieval in RETRIEVALS:
        log.retrieval(*retrieval)
    for event in EVENTS:
        log.event(*event)
    return log


# --- the file -------------------------------------------------------------------------------

def test_a_saved_day_loads_as_it_was_recorded(tmp_path: Path) -> None:
    path = tmp_path / "day_3.npz"
    synthetic(day=3).save(path)
    assert [p.name for p in tmp_path.iterdir()] == ["day_3.npz"]  # no temporary file left
    log = DayLog.load(path)
    assert log.day == 3
    assert log.cases[:3] == ["default", "corridor", "doorway"]
    assert [(r.t, r.case, r.kind, r.triggers, r.similarity, r.adapted)
            for r in log.retrievals] == RETRIEVALS
    assert [(e.t, e.kind, e.x, e.y, e.text) for e in log.events] == EVENTS
    track = log.track()
    assert len(track) == len(STEPS)
    columns = list(zip(*STEPS, strict=True))
    for name, column in zip(("t", "x", "y", "theta", "v", "w"), columns, strict=False):
        np.testing.assert_array_equal(getattr(track, name), column)
    assert [log.cases[i] for i in track.case] == list(columns[6])
    expected = [(math.nan, math.nan) if target is None else target for target in columns[7]]
    np.testing.assert_array_equal(track.target, expected)
    np.testing.assert_array_equal(track.busy, columns[8])
    assert log.clocks is None  # nobody yielded: every mover's clock was the time
    clocked = synthetic()
    clocked.clocks = np.tile(np.array([[step[0]] for step in STEPS]), (1, 2))
    clocked.save(path)
    np.testing.assert_array_equal(DayLog.load(path).clocks, clocked.clocks)
    # a loaded log records on, and saves the same again
    log.step(12.0, 4.6, 5.0, 0.0, 0.0, 0.0, "corridor", None, False)
    assert log.cases.count("corridor") == 1 and len(log.track()) == len(STEPS) + 1


def test_a_file_that_is_not_a_day_log_is_refused_by_name(tmp_path: Path) -> None:
    text = tmp_path / "notes.npz"
    text.write_text("not numpy at all\n")
    other = tmp_path / "trajectories.npz"
    np.savez_compressed(other, day_0=np.zeros((3, 4)))
    lone = tmp_path / "array.npy"
    np.save(lone, np.zeros(3))
    for path in (text, other, lone):
        with pytest.raises(CbrError, match=rf"^{re.escape(str(path))}: not a day log "
                                           r".*workload\.log: true"):
            DayLog.load(path)
    with pytest.raises(CbrError, match=rf"^{re.escape(str(tmp_path / 'day_9.npz'))}: no such "
                                       "file"):
        DayLog.load(tmp_path / "day_9.npz")


def test_the_recorder_refuses_unknown_kinds() -> None:
    log = DayLog(day=0)
    with pytest.raises(ValueError, match="event kind 'crash'"):
        log.event(0.0, "crash", 0.0, 0.0)
    with pytest.raises(ValueError, match="retrieval kind 'adaptation_strategy'"):
        log.retrieval(0.0, "a", "adaptation_strategy", (), 1.0, False)


# --- the pictures -------------------------------------------------------------------------

def assert_png(path: Path) -> None:
    data = path.read_bytes()
    assert data.startswith(PNG_SIGNATURE) and len(data) > 1000


def test_each_case_keeps_its_colour_and_a_day_s_cases_differ() -> None:
    names = [f"case-{k}" for k in range(18)]
    colours = case_colours(["", *names], shown=18)
    assert colours[""] == NO_CASE
    assert len({colours[n] for n in names}) == len(names)  # as many colours as tab20 has
    # the order of the cases shown does not matter
    assert case_colours(list(reversed(names)), shown=18) == {n: colours[n] for n in names}
    # past the cases shown, one grey for all
    fewer = case_colours(names, shown=5)
    assert [fewer[n] for n in names[5:]] == [OTHER_CASES] * 13
    assert len({fewer[n] for n in names[:5]} | {OTHER_CASES}) == 6
    # a name's colour does not depend on the other cases of the day when it is the first
    # to choose (in sorted order), whatever the others are
    assert {case_colours(["a-case", *others])["a-case"]
            for others in ([], ["b"], ["zeta", "x"], names)} == {case_colours(["a-case"])["a-case"]}


def test_the_day_s_pictures_and_its_gif(tmp_path: Path) -> None:
    world = office(0)
    log = synthetic()
    plot_day(world, log, tmp_path / "day.png")
    plot_timeline(log, tmp_path / "timeline.png")
    assert_png(tmp_path / "day.png")
    assert_png(tmp_path / "timeline.png")
    # 11.9 s of day at 4 s a GIF second and 5 frames a second: a frame every 0.8 s from 0,
    # the last at 11.2 s
    np.testing.assert_allclose(frame_times(log.track(), 5, 4.0), np.arange(15) * 0.8)
    out = tmp_path / "day.gif"
    assert animate_day(world, log, out, fps=5, speedup=4.0) == 15
    assert out.read_bytes().startswith(GIF_SIGNATURE)
    with Image.open(out) as gif:
        assert gif.n_frames == 15
        assert gif.info["duration"] == 200
    with pytest.raises(ValueError, match="speedup"):
        frame_times(log.track(), 5, 0.0)


# --- cbr rupart day ---------------------------------------------------------------------------

@pytest.fixture
def cli(cbr_plugins: Callable[..., Plugins], invoke_cbr: Cli) -> Cli:
    cbr_plugins(entry_points=True)
    return invoke_cbr


def run_folder(path: Path, config_file: Path, *overrides: str) -> Path:
    """A run folder as ``cbr run`` leaves it, its manifest written by the same function."""
    plugins = current()
    config = load_config(config_file, plugins.registry, overrides)
    path.mkdir()
    write_json(path / "manifest.json", manifest(config, plugins, seed=config.seed))
    return path


def test_day_draws_a_recorded_day_in_its_world(cli: Cli, tmp_path: Path) -> None:
    run = run_folder(tmp_path / "run", CONFIGS / "rupart.yaml", f"seed={SEED}")
    synthetic(day=1).save(run / "day_1.npz")
    out = tmp_path / "pictures"
    # a frame every 8 / 2 = 4 s of the 11.9 s day: at 0, 4 and 8 s
    result = cli("rupart", "day", str(run), "--day", "1", "--out", str(out), "--fps", "2",
                 "--speedup", "8")
    assert result.exit_code == 0, result.stderr
    assert sorted(p.name for p in out.iterdir()) == ["day_1.gif", "day_1.png",
                                                     "day_1_timeline.png"]
    assert_png(out / "day_1.png")
    with Image.open(out / "day_1.gif") as gif:
        assert gif.n_frames == 3
    assert f"wrote {out / 'day_1.gif'} (3 frames, 2 s)" in result.stdout
    # by default into the run folder, and without the GIF when asked
    assert cli("rupart", "day", str(run), "--day", "1", "--no-gif").exit_code == 0
    assert {"day_1.png", "day_1_timeline.png"} <= {p.name for p in run.iterdir()}
    assert not (run / "day_1.gif").exists()


@pytest.mark.usefixtures("cli")
def test_the_run_s_world_is_rebuilt_with_the_run_s_seed(tmp_path: Path) -> None:
    """configs/rupart.yaml generates its office from the run's seed: the world drawn is the
    one the run drove in, not the office of another seed."""
    run = run_folder(tmp_path / "run", CONFIGS / "rupart.yaml", f"seed={SEED}")
    world, expected, other = run_world(run), office(SEED), office(SEED + 1)
    assert world.name == expected.name != other.name
    assert world.points == expected.points != other.points
    assert [(w.a, w.b) for w in world.walls] == [(w.a, w.b) for w in expected.walls]


def test_day_says_what_is_missing_or_wrong(cli: Cli, tmp_path: Path) -> None:
    def refused(*args: str) -> str:
        result = cli("rupart", "day", *args)
        assert result.exit_code == 2, result.stdout
        assert "Traceback" not in result.stderr
        assert len(result.stderr.strip().splitlines()) == 1, result.stderr
        return result.stderr

    missing = tmp_path / "nowhere"
    assert refused(str(missing)).startswith(f"error: {missing}: no such run folder")
    run = run_folder(tmp_path / "run", CONFIGS / "rupart.yaml")
    assert refused(str(run), "--day", "2").startswith(
        f"error: {run / 'day_2.npz'}: no such day log; expected the day_N.npz the delivery "
        "workload writes with workload.log: true (it records none")
    synthetic(day=1).save(run / "day_1.npz")
    assert refused(str(run), "--day", "1", "--speedup", "1e-9").startswith(
        "error: --speedup 1e-09: the day's GIF would have 119000000001 frames at 10 a second, "
        "more than the 10000 an animation may have (the limit)")
    (run / "day_0.npz").write_bytes(b"PK\x03\x04 not really a zip")
    assert refused(str(run)).startswith(f"error: {run / 'day_0.npz'}: not a day log")
    trials = run_folder(tmp_path / "trials", CONFIGS / "world2d_trials.yaml")
    assert refused(str(trials)).startswith(
        f"error: {trials / 'manifest.json'}: a run of the workload 'trials', not 'delivery'")
    bare = tmp_path / "bare"
    bare.mkdir()
    assert refused(str(bare)).startswith(f"error: {bare / 'manifest.json'}: no such file")


def test_a_delivery_run_with_log_writes_a_day_the_command_draws(cli: Cli,
                                                                tmp_path: Path) -> None:
    run = tmp_path / "run"
    result = cli("run", str(CONFIGS / "rupart.yaml"), "--set", "workload.log=true",
                 "--set", "workload.length=3", "--out", str(run))
    assert result.exit_code == 0, result.stderr
    log = DayLog.load(run / "day_0.npz")
    assert len(log.track()) == 30  # a step every 0.1 s of the 3 s day
    # the office's people yield to the robot: each one's clock at each step is recorded, and
    # none runs ahead of the day's time
    assert log.clocks is not None and log.clocks.shape[0] == 30
    assert np.all(log.clocks <= log.track().t[:, None] + 1e-9)
    drawn = cli("rupart", "day", str(run), "--no-gif")
    assert drawn.exit_code == 0, drawn.stderr
    assert_png(run / "day_0.png")
