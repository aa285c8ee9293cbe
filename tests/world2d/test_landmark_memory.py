"""The short-term landmark memory of the ``trials`` workload (:mod:`cbr_world2d.landmark_memory`)
and the panning camera it serves: remembered sightings carried by odometry into the robot's
current frame, blurred with the time and distance since they were seen, dropped after the
memory's seconds; and, in scenario 2 of 002, the workload's situations holding them."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import cbr_world2d
import cbrcore.builtins
from cbr_world2d.fuzzy import Triangle
from cbr_world2d.landmark_memory import LandmarkMemory, MemoryOptions
from cbr_world2d.robot import Pose
from cbr_world2d.sensors import Camera, Observation, Sighting
from cbr_world2d.workload import Situation
from cbr_world2d.worldfile import load_world
from cbrcore import Retrieval, hookimpl
from cbrcore.config import parse_config
from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.plugins import Plugins, load_plugins
from cbrcore.registry import Registry
from cbrcore.run import run_workload

WORLDS = Path(cbr_world2d.__file__).parent / "worlds"

SEEN = Sighting("l1", Triangle(2.85, 3.0, 3.15), Triangle(-0.05, 0.0, 0.05))
"""A landmark 3 m straight ahead, known within 0.15 m and 0.05 rad."""


def observe(t: float, x: float = 0.0, y: float = 0.0, theta: float = 0.0,
            sightings: tuple[Sighting, ...] = ()) -> Observation:
    pose = Pose(x, y, theta)
    return Observation(t, pose, pose, np.zeros(0), np.zeros(0), False, sightings, 1.0, 0.0, 0.0)


def remembered_after(moves: list[Observation], options: MemoryOptions | None = None
                     ) -> tuple[tuple[Sighting, ...], tuple[str, ...]]:
    """What a memory that saw SEEN at the origin at t = 0 gives after the observations
    ``moves``."""
    memory = LandmarkMemory(options or MemoryOptions(seconds=30.0))
    memory.update(observe(0.0, sightings=(SEEN,)))
    for obs in moves:
        memory.update(obs)
    return memory.sightings(moves[-1])


def corners(t: Triangle) -> tuple[float, float, float]:
    return t.low, t.peak, t.high


def test_a_robot_that_drives_straight_1_m_sees_a_remembered_landmark_1_m_nearer() -> None:
    # driven 1 m in 20 s, in steps: the landmark is 2 m ahead; blurred by
    # 0.05 m/m * 1 m + 0.01 m/s * 20 s = 0.25 m: the distance within 0.15 + 0.25 = 0.4 m, the
    # bearing within the arc seen (3 m * 0.05 rad = 0.15 m) plus 0.25 m, seen from 2 m: 0.2 rad
    moves = [observe(2.0 * k, x=0.1 * k) for k in range(1, 11)]
    (sighting,), ids = remembered_after(moves)
    assert ids == ("l1",) and sighting.id == "l1"
    assert corners(sighting.distance) == pytest.approx((1.6, 2.0, 2.4))
    assert corners(sighting.bearing) == pytest.approx((-0.2, 0.0, 0.2))


def test_a_robot_that_turned_sees_a_remembered_landmark_at_the_bearing_of_its_place() -> None:
    # turned 90 degrees left on the spot: the landmark that was ahead is now to the right,
    # as far as it was; no metre driven, 1 s: blurred by 0.01 m
    (sighting,), _ = remembered_after([observe(1.0, theta=math.pi / 2)])
    assert corners(sighting.distance) == pytest.approx((2.84, 3.0, 3.16))
    half = (3.0 * 0.05 + 0.01) / 3.0
    assert corners(sighting.bearing) == pytest.approx((-math.pi / 2 - half, -math.pi / 2,
                                                       -math.pi / 2 + half))


def test_a_remembered_sighting_widens_with_the_time_since_it_was_seen() -> None:
    widths = []
    for t in (1.0, 5.0, 9.0):
        (sighting,), _ = remembered_after([observe(t)])
        widths.append(sighting.distance.high - sighting.distance.low)
    # 2 x (0.15 + 0.01 t): 4 s more is 0.08 m wider
    assert widths == pytest.approx([0.32, 0.40, 0.48])


def test_with_no_time_and_no_motion_the_remembered_sighting_is_the_one_seen() -> None:
    (sighting,), _ = remembered_after([observe(0.0)], MemoryOptions(seconds=30.0))
    assert sighting.id == SEEN.id
    assert corners(sighting.distance) == pytest.approx(corners(SEEN.distance))
    assert corners(sighting.bearing) == pytest.approx(corners(SEEN.bearing))


def test_a_landmark_unseen_for_longer_than_the_memory_is_dropped() -> None:
    options = MemoryOptions(seconds=10.0)
    assert remembered_after([observe(10.0)], options)[1] == ("l1",)
    assert remembered_after([observe(10.1)], options) == ((), ())
    # once dropped it does not come back
    assert remembered_after([observe(10.1), observe(10.2)], options) == ((), ())


def test_a_landmark_in_view_now_uses_its_current_sighting() -> None:
    now = Sighting("l1", Triangle(1.9, 2.0, 2.1), Triangle(0.2, 0.3, 0.4))
    other = Sighting("l2", Triangle(0.9, 1.0, 1.1), Triangle(-0.1, 0.0, 0.1))
    memory = LandmarkMemory(MemoryOptions(seconds=30.0))
    memory.update(observe(0.0, sightings=(SEEN, other)))
    obs = observe(1.0, x=0.5, sightings=(now,))
    memory.update(obs)
    sightings, ids = memory.sightings(obs)
    assert sightings[0] is now and [s.id for s in sightings] == ["l1", "l2"]
    assert ids == ("l2",)


def test_the_memory_counts_the_metres_the_odometry_drove() -> None:
    memory = LandmarkMemory(MemoryOptions(seconds=1.0))
    for obs in (observe(0.0), observe(1.0, x=3.0), observe(2.0, x=3.0, y=4.0)):
        memory.update(obs)
    assert memory.driven == pytest.approx(7.0)


# --- the panning camera ----------------------------------------------------------------------


def test_a_panning_camera_sweeps_out_and_back_and_keeps_bearings_on_the_heading() -> None:
    camera = Camera(fov=math.radians(60.0), pan=math.radians(60.0),
                    pan_rate=math.radians(60.0), noise=0.0)
    aims = [round(math.degrees(camera.aim(t)), 6) for t in (0.0, 0.5, 1.0, 2.0, 3.0, 3.5, 4.0)]
    assert aims == [0.0, 30.0, 60.0, 0.0, -60.0, -30.0, 0.0]
    # a landmark 45 degrees left: out of a 60 degree view on the heading, in view with the
    # camera 60 degrees left, at its bearing from the heading
    mark = np.array([[3.0 * math.cos(math.pi / 4), 3.0 * math.sin(math.pi / 4), 0.1]])
    rng = np.random.default_rng(0)
    assert camera.see(Pose(0.0, 0.0, 0.0), mark, ["l1"], np.zeros((0, 4)), rng, 0.0) == ()
    (seen,) = camera.see(Pose(0.0, 0.0, 0.0), mark, ["l1"], np.zeros((0, 4)), rng, 1.0)
    assert seen.bearing.peak == pytest.approx(math.pi / 4)
    assert seen.distance.peak == pytest.approx(3.0)


# --- the workload's situations ---------------------------------------------------------------

SITUATIONS: list[Situation] = []


class Look:
    """A retriever that keeps every situation it is asked about and finds nothing."""

    def __init__(self, options: object, ctx: Context) -> None:
        SITUATIONS.clear()

    @hookimpl
    def cbr_retrieve(self, problem: Situation) -> Retrieval:
        SITUATIONS.append(problem)
        return Retrieval(())


class Looker:
    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("retriever", "look", Look)


@pytest.fixture(scope="module")
def plugins() -> Plugins:
    return load_plugins(extra=[("core", cbrcore.builtins), ("world2d", cbr_world2d),
                               ("looker", Looker())], entry_points=False, environ={})


def situations(plugins: Plugins, out: Path, memory: float) -> list[Situation]:
    """The situations of 3 s at scenario 2's point A, facing the target, with a 60 degree
    camera panning 60 degrees each side, consulting as landmarks come into view."""
    config: dict[str, Any] = {
        "seed": 0, "casebase": "memory", "pilot": "potential_field", "retrieve": "look",
        "world": {"use": "world2d_file", "path": str(WORLDS / "scenario2.yaml")},
        "workload": {"use": "trials", "trials": [{"start": "start", "target": "target"}],
                     "robot": "ros2005", "timeout": 3.0, "consult_on": ["landmarks"],
                     "camera": {"fov": 60, "pan": 60}, "memory": {"seconds": memory}}}
    with Engine(parse_config(config, plugins.registry), plugins=plugins, out_dir=out) as engine:
        run_workload(engine, out)
    return list(SITUATIONS)


def test_the_situation_holds_the_landmarks_of_the_sweep_where_they_are(
        plugins: Plugins, tmp_path: Path) -> None:
    found = situations(plugins, tmp_path, memory=10.0)
    world = load_world(WORLDS / "scenario2.yaml")
    # l2 ahead at the start; l1 (45 degrees left) and l3 (43 degrees right) come into view as
    # the camera pans; a remembered landmark is not one that comes into view, so three
    # consultations, each holding the landmarks seen so far
    assert [sorted(s.id for s in p.sightings) for p in found] == [
        ["l2"], ["l1", "l2"], ["l1", "l2", "l3"]]
    assert [p.remembered for p in found] == [(), ("l2",), ("l2", "l1")]
    last = found[-1]
    marks = {mark.id: (mark.x, mark.y) for mark in world.landmarks}
    pose = last.pose
    for s in last.sightings:
        x, y = marks[s.id]
        d = math.hypot(x - pose.x, y - pose.y)
        b = math.atan2(y - pose.y, x - pose.x) - pose.theta
        assert s.distance.contains(d) and s.bearing.contains(b)


def test_without_memory_the_situation_is_the_camera_s_view(plugins: Plugins,
                                                           tmp_path: Path) -> None:
    found = situations(plugins, tmp_path, memory=0.0)
    assert [sorted(s.id for s in p.sightings) for p in found] == [["l2"], ["l1"], ["l3"]]
    assert all(p.remembered == () for p in found)
