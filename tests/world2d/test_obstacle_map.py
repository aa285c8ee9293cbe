"""The robot's map of linear obstacles between landmarks, learned from its sonar and bumper.

The world files' ``between`` declarations (and walls given by their ends) are the ground truth
the tests compare the robot's map against: it perceives an obstacle it drove along, never one
it was not near, never one from returns that lie off the segment, unlearns one it finds gone,
and, in the ``trials`` workload, keeps what it learned from one trial to the next.
"""

from __future__ import annotations

import csv
import itertools
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

import cbr_world2d
import cbrcore.builtins
from cbr_world2d.obstacle_map import BINS, ObstacleMap, PerceptionOptions
from cbr_world2d.robot import Pose, RobotState
from cbr_world2d.sensors import Camera, Observation, Sensors, SonarRing
from cbr_world2d.workload import Situation, situation
from cbr_world2d.world import Point, World
from cbr_world2d.worldfile import load_world, world_from_data
from cbrcore import Retrieval, hookimpl
from cbrcore.config import parse_config
from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.plugins import Plugins, load_plugins
from cbrcore.registry import Registry
from cbrcore.run import run_workload
from cbrcore.testing import CliResult

WORLDS = Path(cbr_world2d.__file__).parent / "worlds"
RADIUS = 0.2
MARKER = "TOPSECRET"


def make_world(a: Point, b: Point, walls: Sequence[dict[str, Any]], size: float = 30.0) -> World:
    return world_from_data({"bounds": [0.0, 0.0, size, size],
                            "landmarks": [{"id": "l1", "at": list(a), "radius": 0.15},
                                          {"id": "l2", "at": list(b), "radius": 0.15}],
                            "walls": list(walls)}, "test world")


def drive(world: World, path: Sequence[Point], known: ObstacleMap | None = None,
          camera_range: float = 12.0, step: float = 0.05) -> ObstacleMap:
    """Move a robot along ``path`` (facing along it, ``step`` metres at a time), sensing the
    world into ``known`` (a new map by default)."""
    sensors = Sensors(camera=Camera(fov=2 * math.pi, max_range=camera_range, noise=0.5)
                      ).fitted(RADIUS)
    assert sensors.sonar is not None
    if known is None:
        known = ObstacleMap(PerceptionOptions(), sensors.sonar)
    rng = np.random.default_rng(0)
    t = 0.0
    for (x0, y0), (x1, y1) in itertools.pairwise(path):
        heading = math.atan2(y1 - y0, x1 - x0)
        n = max(1, math.ceil(math.dist((x0, y0), (x1, y1)) / step))
        for k in range(n + 1):
            u = k / n
            state = RobotState(x0 + u * (x1 - x0), y0 + u * (y1 - y0), heading)
            known.sense(sensors.observe(state, world, t, False, rng))
            t += 0.1
    return known


def frame(a: Point, b: Point) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The segment's start, unit direction and left normal."""
    start = np.array(a)
    along = np.array(b) - start
    along /= np.linalg.norm(along)
    return start, along, np.array([-along[1], along[0]])


def beside(a: Point, b: Point, offset: float, overshoot: float = 0.5) -> list[Point]:
    """A path parallel to ``a -> b`` at ``offset`` metres (to the left when positive), from a
    little before ``a`` to a little past ``b``."""
    start, along, left = frame(a, b)
    length = math.dist(a, b)
    ends = (start - overshoot * along + offset * left,
            start + (length + overshoot) * along + offset * left)
    return [(float(p[0]), float(p[1])) for p in ends]


layouts = st.tuples(st.floats(2.0, 6.0), st.floats(-math.pi, math.pi))


def placed(layout: tuple[float, float]) -> tuple[Point, Point]:
    length, angle = layout
    a = (15.0 - 0.5 * length * math.cos(angle), 15.0 - 0.5 * length * math.sin(angle))
    return a, (a[0] + length * math.cos(angle), a[1] + length * math.sin(angle))


def rim_ends(a: Point, b: Point) -> dict[str, Any]:
    start, along, _ = frame(a, b)
    length = math.dist(a, b)
    return {"a": [float(v) for v in start + 0.15 * along],
            "b": [float(v) for v in start + (length - 0.15) * along]}


# --- the evidence rule ------------------------------------------------------------------------


@settings(max_examples=15, deadline=None)
@given(layout=layouts, offset=st.floats(0.5, 1.5), side=st.sampled_from([-1.0, 1.0]),
       declared=st.booleans())
def test_a_robot_driven_along_a_wall_between_two_landmarks_perceives_that_pair(
        layout: tuple[float, float], offset: float, side: float, declared: bool) -> None:
    a, b = placed(layout)
    # a wall written by its ends is just as much an obstacle between the landmarks
    wall = {"between": ["l1", "l2"]} if declared else rim_ends(a, b)
    world = make_world(a, b, [wall])

    known = drive(world, beside(a, b, side * offset))

    assert known.perceived() == (("l1", "l2"),)
    occupied, free = known.evidence("l1", "l2")
    assert occupied - free >= BINS // 2
    assert known.place("l1") == pytest.approx(a, abs=0.1)
    # the map's walls: the perceived pair as the segment between the places it believes
    assert known.walls() == ((known.place("l1"), known.place("l2")),)


@settings(max_examples=10, deadline=None)
@given(layout=layouts, side=st.sampled_from([-1.0, 1.0]))
def test_a_robot_that_never_went_near_the_wall_does_not_perceive_it(
        layout: tuple[float, float], side: float) -> None:
    a, b = placed(layout)
    world = make_world(a, b, [{"between": ["l1", "l2"]}])

    # the camera sees both landmarks all the way, the sonar (5 m) never reaches the wall
    known = drive(world, beside(a, b, side * 5.6))

    assert set(known.landmarks) == {"l1", "l2"}
    assert known.evidence("l1", "l2") == (0, 0)
    assert known.perceived() == ()


@settings(max_examples=15, deadline=None)
@given(layout=layouts, offset=st.floats(0.45, 1.5), crossing=st.floats(0.1, 0.9),
       shape=st.sampled_from(["parallel", "across"]))
def test_no_obstacle_is_perceived_from_sonar_returns_off_the_segment(
        layout: tuple[float, float], offset: float, crossing: float, shape: str) -> None:
    a, b = placed(layout)
    start, along, left = frame(a, b)
    length = math.dist(a, b)
    if shape == "parallel":
        # a wall behind the pair, beyond the segment from where the robot drives
        ends = (start - 0.5 * along - offset * left,
                start + (length + 0.5) * along - offset * left)
    else:
        # a wall across the segment, the robot's side of it short of its path
        foot = start + crossing * length * along
        ends = (foot - 3.0 * left, foot + 0.3 * left)
    wall = {"a": [float(v) for v in ends[0]], "b": [float(v) for v in ends[1]]}
    world = make_world(a, b, [wall])

    known = drive(world, beside(a, b, 0.8))

    assert known.perceived() == ()


def test_a_gap_found_where_an_obstacle_was_perceived_unlearns_it() -> None:
    a, b = (12.0, 15.0), (16.0, 15.0)
    walled = make_world(a, b, [{"between": ["l1", "l2"]}])
    open_ = make_world(a, b, [])
    known = drive(walled, beside(a, b, 0.8))
    assert known.perceives("l1", "l2")

    drive(open_, beside(a, b, 0.8), known)

    assert not known.perceives("l1", "l2")
    assert known.evidence("l1", "l2")[1] >= BINS // 2
    assert known.sees_open("l1", "l2") and known.open_between(["l2", "l1"]) == (("l2", "l1"),)


def test_the_way_between_landmarks_is_open_only_once_sensed_so() -> None:
    a, b = (12.0, 15.0), (16.0, 15.0)
    known = drive(make_world(a, b, [{"between": ["l1", "l2"]}]), beside(a, b, 0.8))
    assert not known.sees_open("l1", "l2")
    far = drive(make_world(a, b, []), beside(a, b, 5.6))
    assert far.evidence("l1", "l2") == (0, 0) and not far.sees_open("l1", "l2")


def test_bumps_along_a_wall_alone_make_it_perceived() -> None:
    # the sonar reads 0 all round (something touching hides everything): only the bumps vote
    world = make_world((12.0, 15.0), (16.0, 15.0), [{"between": ["l1", "l2"]}])
    camera = Camera(fov=2 * math.pi, max_range=12.0)
    ring = SonarRing().fitted(RADIUS)
    known = ObstacleMap(PerceptionOptions(), ring)
    rng = np.random.default_rng(0)
    for x in np.arange(12.0, 16.05, 0.1):
        pose = Pose(float(x), 15.0 - RADIUS, 0.0)
        sightings = camera.see(pose, world.landmark_array, ["l1", "l2"], world.static_segments,
                               rng)
        known.sense(Observation(t=0.0, pose=pose, true_pose=pose,
                                sonar=np.zeros(len(ring.directions)),
                                sonar_angles=ring.directions, bumped=True, sightings=sightings,
                                confidence=1.0, v=0.0, w=0.0, bump_bearing=math.pi / 2))

    assert known.perceived() == (("l1", "l2"),)
    assert known.evidence("l1", "l2") == (BINS, 0)


def test_a_landmark_between_two_others_splits_the_obstacle() -> None:
    # l1 - l3 - l2 in a line with walls between neighbours: two obstacles, not one from l1 to l2
    world = world_from_data({
        "bounds": [0.0, 0.0, 30.0, 30.0],
        "landmarks": [{"id": "l1", "at": [10.0, 15.0], "radius": 0.15},
                      {"id": "l2", "at": [16.0, 15.0], "radius": 0.15},
                      {"id": "l3", "at": [13.0, 15.0], "radius": 0.15}],
        "walls": [{"between": ["l1", "l3"]}, {"between": ["l3", "l2"]}]}, "three in a line")

    known = drive(world, beside((10.0, 15.0), (16.0, 15.0), 0.8))

    assert set(known.perceived()) == {("l1", "l3"), ("l2", "l3")}


# --- in the trials workload -------------------------------------------------------------------


SEEN: list[Situation] = []
"""The situations the ``seen`` retriever was asked about."""


class Seen:
    """A retriever that keeps every situation it is asked about and finds nothing."""

    def __init__(self, options: object, ctx: Context) -> None:
        SEEN.clear()

    @hookimpl
    def cbr_retrieve(self, problem: Situation) -> Retrieval:
        SEEN.append(problem)
        return Retrieval(())


class Agent:
    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("retriever", "seen", Seen)


@pytest.fixture(scope="module")
def plugins() -> Plugins:
    return load_plugins(extra=[("core", cbrcore.builtins), ("world2d", cbr_world2d),
                               ("agent", Agent())], entry_points=False, environ={})


def rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def test_evidence_survives_between_the_trials_of_a_run(plugins: Plugins,
                                                        tmp_path: Path) -> None:
    config = {"seed": 1, "casebase": "memory", "pilot": "potential_field",
              "world": {"use": "world2d_file", "path": str(WORLDS / "scenario2.yaml")},
              "workload": {"use": "trials", "trials": [{"start": "start", "target": "target"}],
                           "repeat": 2, "timeout": 40, "consult_on": ["landmarks"],
                           "camera": {"fov": 180}},
              "retrieve": "seen"}
    with Engine(parse_config(config, plugins.registry), plugins=plugins,
                out_dir=tmp_path) as engine:
        run_workload(engine, tmp_path)

    starts = [next(s for s in SEEN if s.trial == k) for k in (0, 1)]
    assert [s.t for s in starts] == [0.0, 0.0]
    assert {s.id for s in starts[0].sightings} == {"l1", "l2", "l3"}
    # at point A of the first trial the robot has sensed nothing yet; in the second it knows
    # the V it was trapped in, as the world file declares it
    assert starts[0].obstacles == ()
    world = load_world(WORLDS / "scenario2.yaml")
    assert starts[1].obstacles == world.obstacles_between(["l1", "l2", "l3"])
    # the map's walls reach every situation, the landmarks in view or not
    assert starts[0].walls == ()
    assert len(starts[1].walls) == 2
    assert all(s.walls for s in SEEN if s.trial == 1)
    table = {(r["first"], r["second"]): (r["perceived"], r["declared"])
             for r in rows(tmp_path / "obstacles.csv")}
    assert table[("l1", "l2")] == ("True", "True")
    assert table[("l2", "l3")] == ("True", "True")
    assert table[("l1", "l3")] == ("False", "False")


def test_a_situation_without_a_map_holds_the_declared_obstacles() -> None:
    world = load_world(WORLDS / "scenario2.yaml")
    sensors = Sensors(camera=Camera(fov=math.pi)).fitted(RADIUS)
    obs = sensors.observe(RobotState(1.0, 3.9, 0.0), world, 0.0, False,
                          np.random.default_rng(0))
    known = ObstacleMap(PerceptionOptions(), sensors.sonar)
    known.sense(obs)

    assert situation(world, 0, "landmarks", obs, (8.0, 4.0)).obstacles == (
        ("l1", "l2"), ("l2", "l3"))
    assert situation(world, 0, "landmarks", obs, (8.0, 4.0), known).obstacles == ()


# --- bad options ------------------------------------------------------------------------------

BAD = {
    "coverage above 1": ("coverage: 1.5", "workload.perception.coverage"),
    "coverage of 0": ("coverage: 0", "workload.perception.coverage"),
    "near not positive": ("near: -0.1", "workload.perception.near"),
    "margin negative": ("margin: -1", "workload.perception.margin"),
    "reach of 0": ("reach: 0", "workload.perception.reach"),
    "unknown option": ("spread: 3", "workload.perception.spread"),
    "not a number": ("longest: far", "workload.perception.longest"),
}


@pytest.mark.parametrize(("option", "where"), BAD.values(), ids=list(BAD))
def test_a_bad_perception_option_is_refused_with_its_place(
        cbr_plugins: Callable[..., Plugins], invoke_cbr: Callable[..., CliResult], tmp_path: Path,
        option: str, where: str) -> None:
    cbr_plugins(entry_points=True)
    path = tmp_path / "run.yaml"
    path.write_text(
        f"# {MARKER} password=hunter2\n"
        + yaml.safe_dump({"world": {"use": "world2d_file",
                                    "path": str(WORLDS / "scenario2.yaml")},
                          "pilot": "potential_field"})
        + f"workload:\n  use: trials\n  perception: {{{option}}}\n", encoding="utf-8")

    result = invoke_cbr("run", str(path), "--out", str(tmp_path / "out"))

    assert result.exit_code == 2, result
    assert "Traceback" not in result.stderr
    assert where in result.stderr, result.stderr
    assert MARKER not in result.stdout + result.stderr
    assert not (tmp_path / "out" / "trials.csv").exists()
