"""Recordings read back by an independent decoder, checked against the run they record.

``mcap_ros2`` decodes each message from the schema text the recording carries (its own CDR
reader, not the encoders that wrote it); the values are compared with what the run wrote
elsewhere: results.csv, the map, the day's and the trials' trajectories.
"""

from __future__ import annotations

import csv
import json
import math
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from cbrcore.testing import CliResult
from repo_paths import ROOT

STANDARD = {
    "nav_msgs/msg/OccupancyGrid", "nav_msgs/msg/Path", "nav_msgs/msg/Odometry",
    "geometry_msgs/msg/PoseStamped", "tf2_msgs/msg/TFMessage", "sensor_msgs/msg/LaserScan",
    "visualization_msgs/msg/MarkerArray"}
DECISION = "cbrcore_msgs/msg/Decision"


def read(path: Path) -> dict[str, list[tuple[Any, Any]]]:
    """Every message of the recording by topic, as (channel schema name, decoded message),
    each topic's in log-time order; checks every stamp against the log time."""
    found: dict[str, list[tuple[Any, Any]]] = defaultdict(list)
    with path.open("rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        for schema, channel, message, decoded in reader.iter_decoded_messages(
                log_time_order=True):
            assert schema.name in STANDARD | {DECISION}, schema.name
            assert channel.message_encoding == "cdr"
            assert schema.encoding == "ros2msg"
            found[channel.topic].append((message.log_time, decoded))
    for topic, messages in found.items():
        times = [t for t, _ in messages]
        assert times == sorted(times), topic
        for t, message in messages:
            stamp = _stamp(message)
            if stamp is not None:
                assert stamp == t, topic
    return found


def _stamp(message: Any) -> int | None:
    if hasattr(message, "header"):
        header = message.header
    elif hasattr(message, "transforms"):
        header = message.transforms[0].header
    elif hasattr(message, "markers"):
        header = message.markers[0].header if message.markers else None
    else:
        header = message
    if header is None:
        return None
    stamp = header.stamp
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def _yaw(q: Any) -> float:
    return 2 * math.atan2(q.z, q.w)


def _base_in_map(message: Any) -> tuple[float, float, float]:
    """The pose of ``base_link`` in ``map`` that a 2D world's ``/tf`` message gives: its
    ``map`` -> ``odom`` and ``odom`` -> ``base_link`` transforms composed, as tf2 would."""
    correction, odometry = message.transforms
    assert (correction.header.frame_id, correction.child_frame_id) == ("map", "odom")
    assert (odometry.header.frame_id, odometry.child_frame_id) == ("odom", "base_link")
    c, o = correction.transform, odometry.transform
    turn = _yaw(c.rotation)
    x = c.translation.x + math.cos(turn) * o.translation.x - math.sin(turn) * o.translation.y
    y = c.translation.y + math.sin(turn) * o.translation.x + math.cos(turn) * o.translation.y
    return x, y, turn + _yaw(o.rotation)


def _decisions_match(found: dict[str, list[tuple[Any, Any]]], rows: list[dict[str, str]]
                     ) -> None:
    decisions = [message for _, message in found["/cbr/decision"]]
    assert len(decisions) == len(rows)
    by_query = {int(row["query"]): row for row in rows}
    for decision in decisions:
        row = by_query[decision.query]
        assert decision.source == row["source"]
        if row["best_similarity"]:
            assert decision.similarity == pytest.approx(float(row["best_similarity"]))
        else:
            assert math.isnan(decision.similarity)
        assert int(decision.retrieved) == int(row["retrieved"])
        json.loads(decision.detail)
        if decision.source == "casebase":
            assert decision.phases.startswith("retrieve ")


def _recorded(invoke_cbr: Callable[..., CliResult], out: Path, config: str,
              *settings: str) -> dict[str, list[tuple[Any, Any]]]:
    """Run ``configs/<config>`` into ``out`` with ``settings``, recorded; every message of the
    recording read back, its decisions checked against results.csv."""
    recording = out.with_suffix(".mcap")
    sets = [arg for setting in settings for arg in ("--set", setting)]
    result = invoke_cbr("run", str(ROOT / "configs" / config), "--out", str(out), *sets,
                        "--record", str(recording))
    assert result.exit_code == 0, result.stderr
    found = read(recording)
    _decisions_match(found, _rows(out / "results.csv"))
    return found


def test_the_main_job_reads_back(tmp_path: Path, invoke_cbr: Callable[..., CliResult],
                                 cbr_engine: Callable[..., Any]) -> None:
    from cbr_grid.recording import occupancy

    found = _recorded(invoke_cbr, tmp_path / "run", "hybrid_grid.yaml", "workload.count=40")
    # the map: the generated office, row 0 of the message its bottom row, one metre a cell
    (_, grid_message), = found["/map"]
    grid = cbr_engine(ROOT / "configs/hybrid_grid.yaml", out_dir=tmp_path / "map").ctx.world
    assert grid_message.header.frame_id == "map"
    assert (grid_message.info.width, grid_message.info.height) == (100, 100)
    assert grid_message.info.resolution == 1.0
    data = np.asarray(grid_message.data, dtype=np.int8).reshape(100, 100)
    assert np.array_equal(data, occupancy(grid))
    assert np.array_equal(data[::-1] == 100, ~grid.passable)
    # each plan runs from its trip's start to its goal, cell centre to cell centre
    plans = [message for _, message in found["/plan"]]
    decisions = [message for _, message in found["/cbr/decision"]]
    solved = [d for d in decisions if d.source != "none"]
    assert len(plans) == len(solved)
    for plan, decision in zip(plans, solved, strict=True):
        detail = json.loads(decision.detail)
        xy = np.array([(p.pose.position.x, p.pose.position.y) for p in plan.poses])
        assert plan.header.frame_id == "map"
        assert all(p.header.frame_id == "map" for p in plan.poses)
        start, goal = detail["start"], detail["goal"]
        assert np.allclose(xy[0], (start[0] + 0.5, 100 - start[1] - 0.5))
        assert np.allclose(xy[-1], (goal[0] + 0.5, 100 - goal[1] - 0.5))
        steps = np.abs(np.diff(xy, axis=0))
        assert np.allclose(steps.max(axis=1), 1.0)
    # the robot starts each trip where its plan starts, and its transform says the same
    poses = [message for _, message in found["/robot/pose"]]
    transforms = [message.transforms[0] for _, message in found["/tf"]]
    assert len(poses) == len(transforms) >= len(solved)
    for pose, tf in zip(poses, transforms, strict=True):
        assert (tf.header.frame_id, tf.child_frame_id) == ("map", "base_link")
        assert tf.transform.translation.x == pose.pose.position.x
        assert tf.transform.translation.y == pose.pose.position.y
    # the segments each answer from the case base was adapted from: straight, in the graph
    reused = {t: message.markers[0] for t, message in found["/casegraph/reused"]
              if message.markers[0].action == 0}
    # taken down at the next query: every clearing is a consultation's
    cleared = {t for t, message in found["/casegraph/reused"] if message.markers[0].action == 3}
    assert cleared and cleared <= {t for t, _ in found["/cbr/decision"]}
    graphs = found["/casegraph"]
    assert graphs and graphs[0][0] == min(reused)
    for t, decision in found["/cbr/decision"]:
        if decision.source != "casebase":
            continue
        lines = np.array([(p.x, p.y) for p in reused[t].points]).reshape(-1, 2, 2)
        assert len(lines) > 0
        steps = np.abs(lines[:, 1] - lines[:, 0])
        assert ((steps[:, 0] == 0) | (steps[:, 1] == 0) | (steps[:, 0] == steps[:, 1])).all()
        drawn = max((g for g in graphs if g[0] <= t), key=lambda g: g[0])[1].markers[0]
        assert len(drawn.colors) == len(drawn.points)
    firsts = {round(t / 1e9): p for t, p in found["/robot/pose"]}
    for t, plan in found["/plan"]:
        first = firsts[round(t / 1e9)]
        assert (first.pose.position.x, first.pose.position.y) == (
            plan.poses[0].pose.position.x, plan.poses[0].pose.position.y)


def test_a_delivery_day_reads_back(tmp_path: Path,
                                   invoke_cbr: Callable[..., CliResult]) -> None:
    out = tmp_path / "day"
    found = _recorded(invoke_cbr, out, "rupart.yaml", "workload.length=120",
                      "workload.trajectories=true")
    assert any("install" in message.action for _, message in found["/cbr/decision"])
    # the transform is the true pose of the day's trajectory at its time, 2 a second
    track = np.load(out / "trajectories.npz")["day_0"]
    transforms = found["/tf"]
    assert len(transforms) == 2 * 120 + 1
    for t, message in transforms:
        x, y, yaw = _base_in_map(message)
        row = track[round(t / 1e9 / 0.1)]
        assert row[0] == pytest.approx(t / 1e9)
        assert (x, y) == pytest.approx((row[1], row[2]), abs=1e-9)
        assert abs(math.remainder(yaw - row[3], 2 * math.pi)) < 1e-9
    # odometry is the robot's estimate, in odom, which the transforms place near the truth
    for (_, odometry), (_, tf) in zip(found["/odom"], transforms, strict=True):
        estimate = tf.transforms[1].transform.translation
        assert (odometry.header.frame_id, odometry.child_frame_id) == ("odom", "base_link")
        assert (odometry.pose.pose.position.x, odometry.pose.pose.position.y) == (
            estimate.x, estimate.y)
        truth = _base_in_map(tf)
        assert math.dist((estimate.x, estimate.y), truth[:2]) < 1.0
    for _, scan in found["/sonar"]:
        ranges = np.asarray(scan.ranges)
        assert scan.header.frame_id == "base_link" and len(ranges) == 360
        assert scan.scan_time == pytest.approx(0.5)  # 2 a second
        finite = ranges[np.isfinite(ranges)]
        assert len(finite) > 0 and (finite < scan.range_max).all()
    assert found["/world/walls"] and found["/world/doors"] and found["/world/people"]


def test_a_landmark_trial_reads_back(tmp_path: Path,
                                     invoke_cbr: Callable[..., CliResult]) -> None:
    from cbr_world2d.worldfile import load_world

    out = tmp_path / "trials"
    found = _recorded(invoke_cbr, out, "landmarks.yaml", "workload.repeat=2")
    assert any(message.action.startswith("divert to") for _, message in found["/cbr/decision"])
    # one episode a trial, its walls first; the transform follows each trial's trajectory
    world = load_world(ROOT / "plugins/cbr_world2d/worlds/scenario2.yaml")
    walls = found["/world/walls"]
    assert len(walls) == 2
    drawn = walls[0][1].markers[0]
    points = np.array([(p.x, p.y) for p in drawn.points])
    assert np.allclose(points, world.static_segments.reshape(-1, 2))
    paths = np.load(out / "trajectories.npz")
    starts = [t for t, _ in walls]
    for k, start in enumerate(starts):
        end = starts[k + 1] if k + 1 < len(starts) else math.inf
        track = paths[f"trial_{k}"]
        for t, message in found["/tf"]:
            if start <= t < end:
                row = track[round((t - start) / 1e9 / 0.1)]
                assert _base_in_map(message)[:2] == pytest.approx((row[1], row[2]), abs=1e-9)
