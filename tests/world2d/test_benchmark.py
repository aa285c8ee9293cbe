"""benchmarks/world2d_speed.py: its world has the size the target names, our simulator drives in
it, the ir-sim scenario holds the same world (when ir-sim is installed), and a quick run writes
its outputs. No timing is asserted."""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest

from cbr_world2d import robot
from cbr_world2d.robot import RobotState
from repo_paths import ROOT

SCRIPT = ROOT / "benchmarks" / "world2d_speed.py"


def _has_irsim() -> bool:
    try:
        return importlib.util.find_spec("irsim") is not None
    except (ImportError, ValueError):
        return False


HAS_IRSIM = _has_irsim()


@pytest.fixture(scope="module")
def bench() -> ModuleType:
    spec = importlib.util.spec_from_file_location("world2d_speed", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    with pytest.MonkeyPatch.context() as patch:
        patch.syspath_prepend(str(SCRIPT.parent))  # as a script, its folder is on the path
        spec.loader.exec_module(module)
    return module


def _point_to_segment(px: float, py: float, seg: np.ndarray, samples: int = 2001) -> float:
    """Brute force: the least distance from the point to ``samples`` points along ``seg``."""
    u = np.linspace(0.0, 1.0, samples)
    xs = seg[0] + u * (seg[2] - seg[0])
    ys = seg[1] + u * (seg[3] - seg[1])
    return float(np.hypot(xs - px, ys - py).min())


@pytest.fixture(scope="module")
def run(bench: ModuleType) -> Any:
    """The benchmark's setup: its world (seed 0), robot, start and tour."""
    return bench.setup(0)


def _samples(seg: np.ndarray, count: int = 201) -> np.ndarray:
    u = np.linspace(0.0, 1.0, count)[:, None]
    return seg[:2] + u * (seg[2:] - seg[:2])


def test_world_has_the_targets_size_and_keeps_its_gaps(bench: ModuleType, run: Any) -> None:
    world = run.world
    assert world.static_segments.shape == (200, 4)
    assert len(world.landmarks) == 30
    assert world.static_discs.shape == (30, 3)
    xmin, ymin, xmax, ymax = world.bounds
    segments = world.static_segments
    assert (segments[:, [0, 2]] >= xmin - 1e-9).all() and (segments[:, [0, 2]] <= xmax + 1e-9).all()
    assert (segments[:, [1, 3]] >= ymin - 1e-9).all() and (segments[:, [1, 3]] <= ymax + 1e-9).all()
    # a linear obstacle between landmarks runs from rim to rim
    for wall in world.walls:
        if wall.between is not None:
            a, b = (world.landmark(i) for i in wall.between)
            assert math.hypot(wall.a[0] - a.x, wall.a[1] - a.y) == pytest.approx(a.radius)
            assert math.hypot(wall.b[0] - b.x, wall.b[1] - b.y) == pytest.approx(b.radius)
    # the clutter boxes stay GAP away from every landmark and from each other (checked by
    # sampling their edges densely)
    assert world.polygons
    edges = [np.array([*box[i], *box[(i + 1) % len(box)]])
             for box in world.polygons for i in range(len(box))]
    points = np.concatenate([_samples(edge, 41) for edge in edges])
    owner = np.repeat(np.arange(len(edges)) // 4, 41)
    for mark in world.landmarks:
        assert np.hypot(points[:, 0] - mark.x, points[:, 1] - mark.y).min() >= (
            mark.radius + bench.GAP - 1e-3)
    for k in range(0, len(world.polygons), 5):
        mine, others = points[owner == k], points[owner != k]
        apart = np.hypot(*(mine[:, None, :] - others[None, :, :]).transpose(2, 0, 1)).min()
        assert apart >= bench.GAP - 0.02


def test_same_seed_same_world_other_seed_other_world(bench: ModuleType, run: Any) -> None:
    again, other = bench.build_world(0), bench.build_world(1)
    assert np.array_equal(again.static_segments, run.world.static_segments)
    assert not np.array_equal(other.static_segments, run.world.static_segments)


def test_segment_distances_against_brute_force(bench: ModuleType) -> None:
    rng = np.random.default_rng(7)
    segments = rng.uniform(0, 10, (40, 4))
    one = rng.uniform(0, 10, 4)
    got = bench.segment_distances(one, segments)
    u = np.linspace(0.0, 1.0, 801)
    pa = one[:2] + u[:, None] * (one[2:] - one[:2])
    for k, seg in enumerate(segments):
        pb = seg[:2] + u[:, None] * (seg[2:] - seg[:2])
        brute = np.hypot(*(pa[:, None, :] - pb[None, :, :]).transpose(2, 0, 1)).min()
        assert got[k] == pytest.approx(brute, abs=0.03)


def test_tour_legs_start_and_end_in_free_space_and_chain(bench: ModuleType, run: Any) -> None:
    segments, discs = run.world.static_segments, run.world.static_discs
    points = [(start.x, start.y) for start, _ in run.legs] + [run.legs[-1][1]]
    for x, y in points:
        near = min(_point_to_segment(x, y, seg, 401) for seg in segments)
        rims = np.hypot(discs[:, 0] - x, discs[:, 1] - y) - discs[:, 2]
        assert min(near, float(rims.min())) >= bench.CLEARANCE - 0.05
    for (start, target), (following, _) in zip(run.legs, run.legs[1:], strict=False):
        assert (following.x, following.y) == target
        assert bench.LEG[0] <= math.hypot(target[0] - start.x, target[1] - start.y) <= bench.LEG[1]
        # each leg starts facing its target
        assert math.atan2(target[1] - start.y, target[0] - start.x) == pytest.approx(start.theta)


def _drive(run: Any, start: Any, velocities: list[tuple[float, float]]) -> Any:
    state = RobotState(start.x, start.y, start.theta)
    for command in velocities:
        state, _ = robot.step(state, command, run.spec, 0.1, run.world.static_segments,
                              run.world.static_discs)
    return state


def test_our_simulator_drives_a_few_steps_of_the_tour(bench: ModuleType, run: Any) -> None:
    record = bench.Record()
    bench._legs(run, 40, 0, record)
    assert len(record.states) == len(record.velocities) == 40
    assert record.starts == [0] and record.legs == 1
    spec = run.spec
    xmin, ymin, xmax, ymax = run.world.bounds
    for state, (v, w) in zip(record.states, record.velocities, strict=True):
        assert xmin < state.x < xmax and ymin < state.y < ymax
        assert -spec.max_reverse - 1e-9 <= v <= spec.max_speed + 1e-9
        assert abs(w) <= spec.max_turn_rate + 1e-9
    # it moved toward the first leg's target
    start, target = run.leg(0)
    last = record.ends[0]
    assert math.hypot(last.x - target[0], last.y - target[1]) < math.hypot(
        start.x - target[0], start.y - target[1])
    # the replay cut of the recorded steps
    legs = bench.replay_legs(run, record, 25)
    assert len(legs) == 1 and legs[0][0] == start and len(legs[0][1]) == 25
    assert legs[0][2] == record.states[25]
    # the bare loop and the part replays run on the same world
    assert bench.direct_steps(run, 20, 0) > 0
    parts = bench.part_costs(run, record, 0)
    assert all(seconds > 0 for seconds in parts.values())


@pytest.mark.skipif(not HAS_IRSIM, reason="ir-sim (the bench extra) is not installed")
def test_irsim_scenario_holds_the_same_world_and_robot(bench: ModuleType, run: Any,
                                                       tmp_path: Path) -> None:
    # two legs from two starts: ir-sim's robot is put back at each leg's start and, driven at
    # the same velocities, ends where ours does (straight ahead, its acceleration limit
    # holding it back as ours is, nothing within reach)
    velocities = [(0.2, 0.0)] * 5
    legs = [(start, velocities, _drive(run, start, velocities))
            for start, _ in run.legs[:2]]
    # the speed ramps up by max_accel * dt a step toward 0.2 m/s
    ramp = sum(min(0.2, k * run.spec.max_accel * 0.1) * 0.1 for k in range(1, 6))
    for start, _, end in legs:
        assert math.hypot(end.x - start.x, end.y - start.y) == pytest.approx(ramp)
    seconds, built, how = bench.irsim_steps(run, legs, 16, 5.0, tmp_path)
    assert seconds > 0 and built > 0
    assert how["objects"] == 1 + 200 + 30
    assert how["beams"] == 16
    assert how["steps_in_collision"] == 0
    assert how["largest_apart_from_ours_m"] < 1e-9


def test_quick_run_writes_outputs(bench: ModuleType, tmp_path: Path) -> None:
    argv = ["--quick", "--steps", "200", "--irsim-steps", "20", "--out", str(tmp_path)]
    result = bench.main(argv)
    written = json.loads((tmp_path / "world2d_speed.json").read_text())
    assert written["quick"] is True
    assert written["world"]["segments"] == 200 and written["world"]["landmarks"] == 30
    assert written["irsim_version"] == result["irsim_version"]
    assert (written["irsim_version"] is not None) == HAS_IRSIM
    text = (tmp_path / "world2d_speed.md").read_text()
    assert "Simulation.step" in text
    assert ("ir-sim" in text and "env.step" in text) == HAS_IRSIM
