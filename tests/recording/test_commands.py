"""``--record`` on the commands, ``cbr record info``, and what bad input gets."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from cbr_recording.info import contents
from cbr_recording.recorder import Recorder
from cbrcore.testing import CliResult
from repo_paths import ROOT

GRID = str(ROOT / "configs/hybrid_grid.yaml")


def test_info_lists_what_the_recording_holds(tmp_path: Path,
                                             invoke_cbr: Callable[..., CliResult]) -> None:
    recording = tmp_path / "r.mcap"
    with Recorder(recording) as recorder:
        recorder.episode()
        for t in (0.0, 0.5, 2.0):
            recorder.at(t)
            recorder.transform(t, 0.0, 0.0)
        recorder.path("/plan", np.array([[0.0, 0.0], [1.0, 1.0]]))
    result = invoke_cbr("record", "info", str(recording), "--json")
    assert result.exit_code == 0, result.stderr
    found = json.loads(result.stdout)
    assert found["closed"] is True and found["profile"] == "ros2"
    assert (found["start"], found["end"]) == (0.0, 2.0)
    assert {t["name"]: (t["type"], t["count"], t["first"], t["last"])
            for t in found["topics"]} == {"/tf": ("tf2_msgs/msg/TFMessage", 3, 0.0, 2.0),
                                          "/plan": ("nav_msgs/msg/Path", 1, 2.0, 2.0)}
    table = invoke_cbr("record", "info", str(recording))
    assert table.exit_code == 0 and "/tf" in table.stdout and "4 messages" in table.stdout


def test_episodes_follow_one_another(tmp_path: Path) -> None:
    with Recorder(tmp_path / "r.mcap") as recorder:
        for _ in range(3):
            recorder.episode()
            recorder.at(10.0)
            recorder.pose("/robot/pose", 0.0, 0.0, 0.0)
    topic, = contents(tmp_path / "r.mcap").topics
    assert (topic.count, topic.first, topic.last) == (3, 10.0, 32.0)


def test_a_recording_never_closed_reads_up_to_its_last_chunk(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    recorder = Recorder(path)
    recorder.episode()
    ranges = np.random.default_rng(0).random(360)
    for step in range(4000):  # more than one chunk of scans
        recorder.at(step * 0.1)
        recorder.scan("/sonar", -np.pi, np.pi / 180, ranges, 0.0, 5.0, 0.1)
    recorder._file.flush()  # what a killed process leaves: the chunks written, no summary
    found = contents(path)
    assert not found.closed
    topic, = found.topics
    assert 0 < topic.count < 4000 and topic.first == 0.0
    recorder.close()


def test_an_existing_recording_is_refused_and_the_run_left_as_it_was(
        tmp_path: Path, invoke_cbr: Callable[..., CliResult]) -> None:
    out, recording = tmp_path / "run", tmp_path / "r.mcap"
    first = invoke_cbr("run", GRID, "--out", str(out), "--set", "workload.count=3")
    assert first.exit_code == 0, first.stderr
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    recording.write_bytes(b"an earlier recording")
    for args in ([], ["--fresh"]):
        result = invoke_cbr("run", GRID, "--out", str(out), "--set", "workload.count=3",
                            "--record", str(recording), *args)
        assert result.exit_code == 2
        assert "exists" in result.stderr and "--force" in result.stderr
        assert "Traceback" not in result.stderr
        assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before
    assert recording.read_bytes() == b"an earlier recording"
    # observers change no results: the recorded run continues the folder's
    forced = invoke_cbr("run", GRID, "--out", str(out), "--set", "workload.count=3",
                        "--record", str(recording), "--force")
    assert forced.exit_code == 0, forced.stderr
    assert "continuing" in forced.stderr
    assert contents(recording).closed


def test_a_continued_run_numbers_its_decisions_as_its_results(
        tmp_path: Path, invoke_cbr: Callable[..., CliResult]) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out = tmp_path / "run"
    for name in ("first", "second"):
        result = invoke_cbr("run", GRID, "--out", str(out), "--set", "workload.count=3",
                            "--record", str(tmp_path / f"{name}.mcap"))
        assert result.exit_code == 0, result.stderr
    with (tmp_path / "second.mcap").open("rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        queries = [decoded.query for *_, decoded in reader.iter_decoded_messages(
            topics=["/cbr/decision"])]
    assert queries == [3, 4, 5]


def test_the_configured_observer_records_each_run_of_a_folder(
        tmp_path: Path, invoke_cbr: Callable[..., CliResult]) -> None:
    config = tmp_path / "recorded.yaml"
    config.write_text((ROOT / "configs/hybrid_grid.yaml").read_text(encoding="utf-8")
                      + "observers: [record]\n", encoding="utf-8")
    out = tmp_path / "run"
    for args in ([], [], ["--fresh"]):
        result = invoke_cbr("run", str(config), "--out", str(out), "--set", "workload.count=2",
                            *args)
        assert result.exit_code == 0, result.stderr
    assert sorted(p.name for p in out.glob("*.mcap")) == [
        "recording-2.mcap", "recording-3.mcap", "recording.mcap"]
    assert all(contents(p).closed for p in out.glob("*.mcap"))


def test_a_run_that_fails_to_start_leaves_no_recording(
        tmp_path: Path, invoke_cbr: Callable[..., CliResult]) -> None:
    recording = tmp_path / "r.mcap"
    # more unknown obstacles than free cells: the workload refuses when the engine is built,
    # after the observer
    result = invoke_cbr("run", GRID, "--out", str(tmp_path / "run"), "--set",
                        "workload.unknown_static=1000000", "--record", str(recording))
    assert result.exit_code == 2 and "unknown_static" in result.stderr
    assert not recording.exists()


def test_bad_recording_options_exit_2(tmp_path: Path,
                                      invoke_cbr: Callable[..., CliResult]) -> None:
    blocker = tmp_path / "a file"
    blocker.write_text("not a folder")
    cases = {
        ("run", GRID, "--out", str(tmp_path / "a"), "--record", str(blocker / "r.mcap")):
            "cannot be written",
        ("run", GRID, "--out", str(tmp_path / "b"), "--record", str(tmp_path)):
            "is a folder",
        ("run", GRID, "--out", str(tmp_path / "c"), "--force"): "--force goes with",
        ("sim", "batch", "generated:office:1", "--record", str(tmp_path / "x.mcap")):
            "records none",
        ("experiment", "anything", "--record", str(tmp_path / "x.mcap")): "records none",
        ("record", "info", str(tmp_path / "missing.mcap")): "no such file",
        ("record", "info", GRID): "not a readable MCAP file",
    }
    for args, words in cases.items():
        result = invoke_cbr(*args)
        assert result.exit_code == 2, args
        assert words in result.stderr, (args, result.stderr)
        assert "Traceback" not in result.stderr
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_sim_run_records_one_trial(tmp_path: Path,
                                   invoke_cbr: Callable[..., CliResult]) -> None:
    recording = tmp_path / "trial.mcap"
    result = invoke_cbr("sim", "run", "generated:office:3", "--start", "hall_west", "--target",
                        "room_1", "--timeout", "60", "--record", str(recording), "--json")
    assert result.exit_code == 0, result.stderr
    summary = json.loads(result.stdout)
    found = {t.name: t for t in contents(recording).topics}
    assert found["/tf"].count == int(summary["time"] * 2) + 1
    assert found["/tf"].last == summary["time"]
    again = invoke_cbr("sim", "run", "generated:office:3", "--start", "hall_west", "--target",
                       "room_1", "--record", str(recording))
    assert again.exit_code == 2 and "exists" in again.stderr
