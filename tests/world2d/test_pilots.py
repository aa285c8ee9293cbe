"""The pilots of the 2D world, the progress monitor, the Rescuer and the navigator.

Closed-loop cases drive a Pioneer 2 DX (radius 0.25 m) in small hand-made worlds, and both
robots in 002's two scenarios as shipped, with the real robot step and sensors, through
:func:`drive` below. The U-shape of the trap is the one of 002's scenario 2 reduced to its
core: the robot starts at (3, 5) facing +x, the target (10, 5) lies behind the U's closed end,
and the U (walls from (5, 4) to (7, 4) to (7, 6) to (5, 6)) opens toward the robot, 2 m wide
and 2 m deep. The straight way is 7 m, 17.5 s at the pilot's 0.4 m/s, so 600 s is a generous
timeout. Single-step cases use synthetic observations whose forces, fits and merges are worked
out by hand in the comments.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import attrs
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cbr_world2d
from cbr_world2d.navigator import Event, Navigator, NavigatorOptions
from cbr_world2d.pilots import (
    BEHAVIORS,
    PILOT,
    PRIORITIES,
    SPEEDS,
    TURN_RATES,
    BehaviorPilot,
    BehaviorPilotOptions,
    MonitorOptions,
    Pilot,
    PotentialField,
    PotentialFieldOptions,
    ProgressMonitor,
    Proposal,
    Rescuer,
    RescuerOptions,
    merge,
    parse_behavior_set,
    register_behavior,
)
from cbr_world2d.pilots.behaviors import (
    HOLD_STEPS,
    NEGLIGIBLE,
    Arbiter,
    AvoidCollision,
    AvoidObstacle,
    GoStraight,
    GoToPos,
    MoveForward,
    Stop,
)
from cbr_world2d.pilots.kernels import sector
from cbr_world2d.robot import PIONEER_2DX, ROS_2005, Pose, RobotSpec, RobotState, step
from cbr_world2d.sensors import PIONEER_SONAR_DEGREES, Observation, Sensors
from cbr_world2d.world import Wall, World
from cbr_world2d.worldfile import load_world
from cbrcore.options import option_problems
from cbrcore.stash import StashKey

RADIUS = PIONEER_2DX.radius
ANGLES = np.radians(PIONEER_SONAR_DEGREES)
MAX_RANGE = 5.0

OPEN = World(bounds=(0.0, 0.0, 14.0, 10.0))
POINT = World(bounds=(0.0, 0.0, 14.0, 10.0), points=((6.0, 5.0, 0.3),))
U_SHAPE = World(bounds=(0.0, 0.0, 14.0, 10.0),
                walls=(Wall((5.0, 4.0), (7.0, 4.0)), Wall((7.0, 4.0), (7.0, 6.0)),
                       Wall((7.0, 6.0), (5.0, 6.0))))
WALL = World(bounds=(0.0, 0.0, 14.0, 10.0), walls=(Wall((7.0, 2.0), (7.0, 8.0)),))
U_START, U_TARGET = (3.0, 5.0), (10.0, 5.0)
PILOT_ONLY = NavigatorOptions(rescue="off")
RESCUED = NavigatorOptions(rescue="blocked")
"""002's navigation system without CBR: the Rescuer diverts on its own when blocked."""


@attrs.frozen
class Run:
    """A drive: ``trajectory`` rows ``t, x, y, theta`` (the start first), every event the
    navigator raised, how many steps collided, and whether the target was reached."""

    trajectory: np.ndarray
    events: tuple[Event, ...]
    collisions: int
    reached: bool

    def named(self, name: str) -> list[Event]:
        return [e for e in self.events if e.name == name]


def drive(world: World, start: tuple[float, float], heading: float,
          target: tuple[float, float], navigator: Navigator, *, timeout: float,
          divert: tuple[float, float] | None = None, seed: int = 0, dt: float = 0.1,
          tolerance: float = 0.3, spec: RobotSpec = PIONEER_2DX) -> Run:
    """Drive from ``start`` toward ``target`` until within ``tolerance`` or ``timeout``;
    ``divert`` asks the navigator for a diverting target at the start (as 002's CBR agent does
    at point A)."""
    rng = np.random.default_rng(seed)
    sensors = Sensors(camera=None).fitted(spec.radius)
    state = RobotState(start[0], start[1], heading)
    navigator.start(target)
    if divert is not None:
        navigator.divert(divert, 0.0)
    obs = sensors.observe(state, world, 0.0, False, rng)
    rows = [(0.0, state.x, state.y, state.theta)]
    events: list[Event] = []
    collisions = 0
    reached = False
    for k in range(1, round(timeout / dt) + 1):
        command = navigator.command(obs)
        events.extend(navigator.events)
        state, collided = step(state, command, spec, dt, world.static_segments,
                               world.static_discs)
        collisions += collided
        obs = sensors.observe(state, world, k * dt, collided, rng)
        rows.append((k * dt, state.x, state.y, state.theta))
        if math.hypot(state.x - target[0], state.y - target[1]) <= tolerance:
            reached = True
            break
    return Run(np.array(rows), tuple(events), collisions, reached)


def observation(x: float, y: float, theta: float, ranges: Sequence[float] | np.ndarray,
                angles: Sequence[float] | np.ndarray = ANGLES, t: float = 0.0) -> Observation:
    """An observation at the pose ``(x, y, theta)`` with the given sonar readings."""
    pose = Pose(x, y, theta)
    return Observation(t=t, pose=pose, true_pose=pose, sonar=np.asarray(ranges, dtype=float),
                       sonar_angles=np.asarray(angles, dtype=float), bumped=False,
                       sightings=(), confidence=1.0, v=0.0, w=0.0)


def clear(**readings: float) -> np.ndarray:
    """All 16 Pioneer beams at the maximum range except ``b<index>=reading``."""
    ranges = np.full(16, MAX_RANGE)
    for name, value in readings.items():
        ranges[int(name[1:])] = value
    return ranges


def path_length(trajectory: np.ndarray) -> float:
    return float(np.sum(np.hypot(np.diff(trajectory[:, 1]), np.diff(trajectory[:, 2]))))


# --- the potential field, one step ------------------------------------------------------


def test_pilots_satisfy_the_protocol() -> None:
    assert isinstance(PotentialField(), Pilot)
    assert isinstance(BehaviorPilot(()), Pilot)
    assert isinstance(PILOT, StashKey)


def test_force_with_nothing_near_is_the_unit_pull_toward_the_target() -> None:
    pilot = PotentialField()
    fx, fy = pilot.force(observation(1.0, 1.0, 2.0, clear()), (4.0, 5.0))
    assert (fx, fy) == pytest.approx((0.6, 0.8))  # the 3-4-5 triangle


def test_force_of_one_echo_is_khatibs_term_along_the_beam() -> None:
    pilot = PotentialField()  # k = 0.05, d0 = 1, pull 1
    # beam 3 points 10 degrees left of the heading (0): an echo at 0.5 m pushes with
    # 0.05 * (1/0.5 - 1/1) / 0.25 = 0.2 toward -(cos 10, sin 10)
    fx, fy = pilot.force(observation(0.0, 0.0, 0.0, clear(b3=0.5)), (10.0, 0.0))
    push = 0.2
    assert (fx, fy) == pytest.approx((1.0 - push * math.cos(math.radians(10.0)),
                                      -push * math.sin(math.radians(10.0))))
    # an echo beyond the influence distance does not push at all
    assert pilot.force(observation(0.0, 0.0, 0.0, clear(b3=1.2)), (10.0, 0.0)) == \
        pytest.approx((1.0, 0.0))


def test_force_stays_finite_on_contact() -> None:
    pilot = PotentialField()
    # readings under min_range (0.02) push as 0.02 does: 0.05 * (50 - 1) / 0.0004
    fx, _ = pilot.force(observation(0.0, 0.0, 0.0, clear(b3=0.0, b4=0.0),
                                    ), (10.0, 0.0))
    expected = 1.0 - 2 * 0.05 * 49.0 / 0.0004 * math.cos(math.radians(10.0))
    assert fx == pytest.approx(expected)


@settings(max_examples=200, deadline=None)
@given(theta=st.floats(-math.pi, math.pi),
       ranges=st.lists(st.floats(0.0, MAX_RANGE), min_size=16, max_size=16),
       bearing=st.floats(-math.pi, math.pi))
def test_repulsion_is_a_sum_of_pushes_each_straight_back_along_its_beam(
        theta: float, ranges: list[float], bearing: float) -> None:
    pilot = PotentialField()
    target = (10.0 * math.cos(bearing), 10.0 * math.sin(bearing))
    pull = np.array([math.cos(bearing), math.sin(bearing)])
    total = np.array(pilot.force(observation(0.0, 0.0, theta, ranges), target)) - pull
    pushes = np.zeros(2)
    for k, d in enumerate(ranges):
        push = np.array(pilot.force(observation(0.0, 0.0, theta, clear(**{f"b{k}": d})),
                                    target)) - pull
        beam = np.array([math.cos(theta + ANGLES[k]), math.sin(theta + ANGLES[k])])
        # against the beam, never across it, and only from echoes within d0 = 1 m (up to the
        # rounding of taking the pull away)
        size = float(np.hypot(*push))
        assert push @ beam <= 1e-12
        assert abs(push[0] * beam[1] - push[1] * beam[0]) <= 1e-12 + 1e-9 * size
        if d >= 1.0:
            assert size <= 1e-12
        pushes += push
    assert np.allclose(total, pushes, rtol=1e-9, atol=1e-9)


def test_command_turns_toward_the_force_and_waits_when_it_points_behind() -> None:
    pilot = PotentialField()  # gain 1.5, max turn 1 rad/s, speed 0.4
    # target 30 degrees to the left, nothing near: w = 1.5 * 0.5236 = 0.785, v = 0.4 cos 30
    v, w = pilot.command(observation(0.0, 0.0, 0.0, clear()),
                         (10.0 * math.cos(math.pi / 6), 10.0 * math.sin(math.pi / 6)))
    assert w == pytest.approx(1.5 * math.pi / 6)
    assert v == pytest.approx(0.4 * math.cos(math.pi / 6))
    # target straight behind: turn at the limit, no forward speed
    v, w = pilot.command(observation(0.0, 0.0, 0.0, clear()), (-10.0, 0.1))
    assert v == 0.0 and abs(w) == pytest.approx(1.0)
    # an echo 0.25 m ahead (beams 3 and 4) slows the robot to 0.25 of its speed, and the
    # push 2 * 0.05 * (4 - 1) / 0.0625 * cos 10 = 4.73 outweighs the pull: it stops, turning
    v, _ = pilot.command(observation(0.0, 0.0, 0.0, clear(b3=0.25, b4=0.25)), (10.0, 0.0))
    assert v == 0.0
    # the same echoes at 0.8 m: push 2 * 0.05 * 0.25 / 0.64 * cos 10 = 0.038, still ahead
    v, w = pilot.command(observation(0.0, 0.0, 0.0, clear(b3=0.8, b4=0.8)), (10.0, 0.0))
    assert v == pytest.approx(0.4 * 0.8) and w == pytest.approx(0.0, abs=1e-12)


def test_potential_field_options_are_checked() -> None:
    options, problems = option_problems(PotentialFieldOptions, {"influence": 1.5}, "pilot")
    assert problems == [] and options.influence == 1.5
    for data, path in (({"repulsion": -1.0}, "pilot.repulsion"), ({"speed": 1}, "pilot.speed"),
                       ({"max_speed": "fast"}, "pilot.max_speed")):
        _, problems = option_problems(PotentialFieldOptions, data, "pilot")
        assert [p for p, _ in problems] == [path]


# --- the potential field, closed loop -----------------------------------------------------


@pytest.mark.parametrize(("start", "target"), [((2.0, 2.0), (11.0, 8.0)),
                                                ((12.0, 8.0), (1.5, 1.0)),
                                                ((7.0, 1.0), (7.0, 9.0))])
def test_potential_field_reaches_a_target_in_open_space(start: tuple[float, float],
                                                        target: tuple[float, float]) -> None:
    heading = math.atan2(target[1] - start[1], target[0] - start[0]) + 1.0  # not facing it
    run = drive(OPEN, start, heading, target, Navigator(PotentialField(), PILOT_ONLY),
                timeout=120.0)
    assert run.reached and run.collisions == 0
    # nothing in the way: the path is hardly longer than the straight line
    assert path_length(run.trajectory) < 1.1 * math.dist(start, target)


def test_potential_field_passes_a_point_obstacle_on_the_straight_line() -> None:
    run = drive(POINT, (2.0, 5.0), 0.0, (11.0, 5.0), Navigator(PotentialField(), PILOT_ONLY),
                timeout=120.0)
    assert run.reached and run.collisions == 0
    gap = np.hypot(run.trajectory[:, 1] - 6.0, run.trajectory[:, 2] - 5.0) - 0.3 - RADIUS
    # it went round the obstacle (the straight line runs through it) without touching it
    assert gap.min() > 0.0
    assert np.abs(run.trajectory[:, 2] - 5.0).max() > 0.3


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_potential_field_is_trapped_in_a_u_shape(seed: int) -> None:
    run = drive(U_SHAPE, U_START, 0.0, U_TARGET, Navigator(PotentialField(), PILOT_ONLY),
                timeout=600.0, seed=seed)
    assert not run.reached and run.collisions == 0
    trajectory = run.trajectory
    inside = (trajectory[:, 1] > 5.0) & (trajectory[:, 1] < 7.0) \
        & (trajectory[:, 2] > 4.0) & (trajectory[:, 2] < 6.0)
    entered = int(np.argmax(inside))
    assert inside[entered] and inside[entered:].all()  # once in, it never gets out
    # it keeps moving back and forth on the spot: in the last 300 s it drives far more than
    # the size of the region it stays in
    late = trajectory[trajectory[:, 0] >= 300.0]
    spread = math.hypot(np.ptp(late[:, 1]), np.ptp(late[:, 2]))
    assert spread < 0.6
    assert path_length(late) > 5.0 * spread
    # and the monitor says so, again and again until the timeout
    stuck = [e for e in run.events if e.name in ("blocked", "oscillating")]
    assert len(stuck) >= 30
    assert stuck[-1].t > 550.0
    assert not run.named("diverted")  # the pilot alone: nothing else takes over


def test_a_diverting_target_beside_the_u_leads_to_the_target() -> None:
    # 002 scenario 2 with CBR: at point A a diverting target is set beside the U; once it is
    # reached the original target comes back and the pilot gets there round the U
    navigator = Navigator(PotentialField(), PILOT_ONLY)
    run = drive(U_SHAPE, U_START, 0.0, U_TARGET, navigator, timeout=600.0, divert=(6.0, 7.5))
    assert run.reached and run.collisions == 0
    assert [(e.name, e.detail) for e in run.events] == [("diverted", "asked"),
                                                         ("restored", "reached")]
    diverted, restored = run.events
    assert diverted.point == (6.0, 7.5) and restored.point == U_TARGET
    assert math.hypot(restored.x - 6.0, restored.y - 7.5) <= RescuerOptions().tolerance
    assert not navigator.diverting and navigator.current_target == U_TARGET


def test_the_rescuers_own_way_out_of_the_u_leads_back_into_it() -> None:
    # 002's baseline Rescuer knows no map: the sonar's way out is back out of the U's mouth,
    # and with the original target restored the pilot drives right back in
    navigator = Navigator(PotentialField(), RESCUED)
    run = drive(U_SHAPE, U_START, 0.0, U_TARGET, navigator, timeout=300.0)
    assert not run.reached and run.collisions == 0
    diverted = run.named("diverted")
    restored = run.named("restored")
    assert len(diverted) >= 3 and all(e.detail == "rescuer" for e in diverted)
    assert all(e.detail == "reached" for e in restored)
    for event in diverted:
        assert event.point is not None and event.point[0] < event.x  # back, away from the end
        # each diversion follows a blocked report at the same step
        assert any(e.name == "blocked" and e.t == event.t for e in run.events)


def scenario(name: str) -> World:
    return load_world(Path(cbr_world2d.__file__).parent / "worlds" / f"{name}.yaml")


@pytest.mark.parametrize("spec", [PIONEER_2DX, ROS_2005], ids=lambda s: s.name)
def test_002_scenarios_without_cbr(spec: RobotSpec) -> None:
    # 002 section 4 without CBR: in scenario 1 the navigation system gets round the linear
    # obstacle (the Rescuer diverts once, past its end); in scenario 2 it never reaches the
    # target: the Rescuer's way out is back out of the dead end, and the pilot returns into it
    # three times as long as the straight way at half the speed the pilot drives at
    speed = 0.5 * min(spec.max_speed, PotentialFieldOptions().max_speed)
    for name, reached in (("scenario1", True), ("scenario2", False)):
        world = scenario(name)
        start, target = world.places["start"], world.places["target"]
        heading = math.atan2(target[1] - start[1], target[0] - start[0])
        timeout = 3 * math.dist(start, target) / speed
        run = drive(world, start, heading, target, Navigator(PotentialField(), RESCUED),
                    spec=spec, timeout=timeout)
        assert run.reached == reached and run.collisions == 0, name
        assert run.named("diverted"), name
    # the pilot alone stops in front of scenario 1's obstacle: the Rescuer got it past
    world = scenario("scenario1")
    start, target = world.places["start"], world.places["target"]
    heading = math.atan2(target[1] - start[1], target[0] - start[0])
    run = drive(world, start, heading, target, Navigator(PotentialField(), PILOT_ONLY),
                spec=spec, timeout=3 * math.dist(start, target) / speed)
    assert not run.reached and run.collisions == 0


@pytest.mark.parametrize("spec", [PIONEER_2DX, ROS_2005], ids=lambda s: s.name)
def test_002_scenario_2_with_a_diverting_target_beside_l3(spec: RobotSpec) -> None:
    # as 002's CBR agent does at point A: divert to l3, here to a point 0.5 m beyond it on
    # the side away from the dead end (l3's centre lies inside its disc, closer than the
    # tolerance lets a robot come)
    world = scenario("scenario2")
    start, target = world.places["start"], world.places["target"]
    l3 = world.landmark("l3")
    beside = (l3.x, l3.y - 0.5)
    heading = math.atan2(target[1] - start[1], target[0] - start[0])
    run = drive(world, start, heading, target, Navigator(PotentialField(), RESCUED), spec=spec,
                timeout=3000.0, divert=beside)
    assert run.reached and run.collisions == 0
    assert [(e.name, e.detail) for e in run.events] == [("diverted", "asked"),
                                                         ("restored", "reached")]


# --- the progress monitor -------------------------------------------------------------------


def feed(monitor: ProgressMonitor, points: Sequence[tuple[float, float, float]],
         target: tuple[float, float]) -> list[str]:
    return [monitor.update(t, x, y, target) for t, x, y in points]


def test_monitor_judges_nothing_before_a_whole_window() -> None:
    monitor = ProgressMonitor()  # window 10 s
    statuses = feed(monitor, [(0.1 * k, 0.0, 0.0) for k in range(100)], (5.0, 0.0))
    assert set(statuses) == {"moving"}  # 9.9 s of standing still
    assert monitor.update(10.0, 0.0, 0.0, (5.0, 0.0)) == "blocked"


def test_monitor_sees_progress_toward_the_target() -> None:
    monitor = ProgressMonitor()
    # 0.05 m/s straight at the target: 0.5 m closer in any 10 s window (min progress 0.2)
    statuses = feed(monitor, [(0.1 * k, 0.005 * k, 0.0) for k in range(300)], (20.0, 0.0))
    assert set(statuses) == {"moving"}


def test_monitor_calls_driving_round_the_target_moving() -> None:
    monitor = ProgressMonitor()
    # a circle of radius 3 round the target at 0.1 m/s: no progress, but over 10 s the
    # displacement is a 1 m chord, far more than 0.3 m and a third of the 1 m driven
    points = [(0.1 * k, 3 * math.cos(0.01 * k / 3), 3 * math.sin(0.01 * k / 3))
              for k in range(300)]
    assert set(feed(monitor, points, (0.0, 0.0))) == {"moving"}


def test_monitor_flags_back_and_forth_as_oscillating() -> None:
    monitor = ProgressMonitor()
    # sideways across the target's bearing, 0.4 m each way at 0.2 m/s (a 4 s period): over
    # 10 s it drives 2 m, ends within 0.4 m of where it began, and gets no closer
    points = [(0.1 * k, 0.0, 0.2 * (0.1 * k % 4.0 if 0.1 * k % 4.0 < 2.0 else 4.0 - 0.1 * k % 4.0))
              for k in range(300)]
    statuses = feed(monitor, points, (5.0, 0.0))
    assert statuses[:100] == ["moving"] * 100
    assert set(statuses[100:]) == {"oscillating"}


def test_monitor_thresholds_are_options() -> None:
    monitor = ProgressMonitor(MonitorOptions(window=2.0, min_displacement=0.05))
    # 0.01 m/s sideways: 0.02 m in 2 s is under 0.05 m
    statuses = feed(monitor, [(0.1 * k, 0.0, 0.001 * k) for k in range(40)], (5.0, 0.0))
    assert statuses[19] == "moving" and statuses[-1] == "blocked"
    monitor.reset()
    assert monitor.status == "moving"
    assert monitor.update(100.0, 0.0, 0.0, (5.0, 0.0)) == "moving"


# --- the Rescuer ----------------------------------------------------------------------------


def test_rescuer_restores_the_original_target_when_the_diverting_one_is_reached() -> None:
    rescuer = Rescuer(RescuerOptions(tolerance=0.3, give_up=60.0))
    rescuer.set_target((10.0, 0.0))
    assert not rescuer.diverting and rescuer.current_target == (10.0, 0.0)
    rescuer.divert((2.0, 3.0), t=5.0)
    assert rescuer.diverting and rescuer.current_target == (2.0, 3.0)
    assert rescuer.update(0.0, 0.0, 10.0) is None
    assert rescuer.update(2.0, 2.65, 20.0) is None  # 0.35 m off
    restored = rescuer.update(2.0, 2.75, 21.0)  # 0.25 m off
    assert restored is not None and restored.reason == "reached"
    assert restored.diverting == (2.0, 3.0) and restored.t == 21.0
    assert not rescuer.diverting and rescuer.current_target == (10.0, 0.0)
    assert rescuer.update(2.0, 3.0, 22.0) is None


def test_rescuer_gives_up_a_diverting_target_in_time() -> None:
    rescuer = Rescuer(RescuerOptions(give_up=60.0), target=(10.0, 0.0))
    rescuer.divert((2.0, 3.0), t=5.0)
    assert rescuer.update(0.0, 0.0, 64.9) is None
    restored = rescuer.update(0.0, 0.0, 65.0)
    assert restored is not None and restored.reason == "given_up"
    assert rescuer.current_target == (10.0, 0.0)


def test_rescuer_without_a_target_says_so() -> None:
    with pytest.raises(ValueError, match="no target"):
        _ = Rescuer().current_target


def test_rescuer_takes_the_most_open_beam_turned_away_from_the_blocked_heading() -> None:
    rescuer = Rescuer(target=(10.0, 0.0))  # distance 1.5, clearance 0.4, min turn 60 deg
    # facing the target; the longest reading is beam 4 (-10 deg) but it points at the target;
    # among the beams at least 60 deg away, beam 10 (-150 deg) reads longest, 3.0 m
    ranges = np.full(16, 1.0)
    ranges[4] = 4.5
    ranges[10] = 3.0
    point = rescuer.escape(observation(0.0, 0.0, 0.0, ranges))
    angle = math.radians(-150.0)
    assert point == pytest.approx((1.5 * math.cos(angle), 1.5 * math.sin(angle)))
    # a short opening: 1.2 m read, the target 0.4 short of it, at 0.8 m
    ranges[10] = 1.2
    point = rescuer.escape(observation(0.0, 0.0, 0.0, ranges))
    assert ranges[10] - 0.4 == pytest.approx(0.8)
    # with beam 10 at 1.2, every candidate but beam 10 reads 1.0: 0.6 m, so beam 10 wins
    assert point == pytest.approx((0.8 * math.cos(angle), 0.8 * math.sin(angle)))


def test_rescuer_prefers_the_open_beam_nearest_the_blocked_heading() -> None:
    bearing = math.radians(85.0)
    rescuer = Rescuer(target=(10.0 * math.cos(bearing), 10.0 * math.sin(bearing)))
    # robot facing +x, the target 85 deg left, all clear: the candidates are the beams at
    # least 60 deg from 85 deg, all reading 5 m; the nearest of them to 85 deg are +150 deg
    # (65 deg away, beam 13) and +10 deg (75 deg away): +150 deg wins
    point = rescuer.escape(observation(0.0, 0.0, 0.0, clear()))
    angle = math.radians(150.0)
    assert point == pytest.approx((1.5 * math.cos(angle), 1.5 * math.sin(angle)))


def test_rescuer_does_not_divert_when_boxed_in_or_already_diverting() -> None:
    rescuer = Rescuer(target=(10.0, 0.0))
    boxed = observation(0.0, 0.0, 0.0, np.full(16, 0.6))  # 0.6 - 0.4 = 0.2 <= tolerance 0.3
    assert rescuer.escape(boxed) is None and rescuer.rescue(boxed) is None
    assert not rescuer.diverting
    free = observation(0.0, 0.0, 0.0, clear(), t=3.0)
    point = rescuer.rescue(free)
    assert point is not None and rescuer.current_target == point and rescuer.diverted_at == 3.0
    assert rescuer.rescue(free) is None and rescuer.current_target == point


# --- the navigator --------------------------------------------------------------------------


def test_navigator_diverts_and_restores_in_open_space() -> None:
    navigator = Navigator(PotentialField(), PILOT_ONLY)
    run = drive(OPEN, (2.0, 2.0), 0.0, (11.0, 2.0), navigator, timeout=120.0,
                divert=(5.0, 6.0))
    assert run.reached and run.collisions == 0
    assert [e.name for e in run.events] == ["diverted", "restored"]
    # on the way there it came within the tolerance of the diverting target
    near = np.hypot(run.trajectory[:, 1] - 5.0, run.trajectory[:, 2] - 6.0)
    assert near.min() <= 0.3
    assert run.events[1].t == pytest.approx(run.trajectory[int(np.argmax(near <= 0.3)), 0])


def test_navigator_reports_a_divert_at_the_next_step_and_needs_a_target() -> None:
    with pytest.raises(ValueError, match="no target"):
        _ = Navigator(PotentialField(), PILOT_ONLY).target
    navigator = Navigator(PotentialField(), target=(5.0, 0.0))
    obs = observation(0.0, 0.0, 0.0, clear(), t=1.0)
    navigator.command(obs)
    assert navigator.events == ()
    navigator.divert((0.0, 5.0))
    assert navigator.events == ()  # reported with the next step's events
    _, w = navigator.command(attrs.evolve(obs, t=1.1))
    assert [(e.name, e.t, e.point, e.detail) for e in navigator.events] == \
        [("diverted", 1.0, (0.0, 5.0), "asked")]
    assert w > 0.0  # heading for the diverting target, to the left
    assert navigator.current_target == (0.0, 5.0) and navigator.target == (5.0, 0.0)
    navigator.command(attrs.evolve(obs, t=1.2))
    assert navigator.events == ()


def test_navigator_repeats_a_stuck_report_each_window_and_starts_afresh() -> None:
    navigator = Navigator(PotentialField(), PILOT_ONLY, target=(5.0, 0.0))

    def stand(until: float) -> list[tuple[str, float]]:
        reported = []
        for k in range(round(until / 0.1) + 1):
            navigator.command(observation(0.0, 0.0, 0.0, clear(), t=round(0.1 * k, 1)))
            reported += [(e.name, e.t) for e in navigator.events]
        return reported

    # standing still: blocked once the first 10 s window is full, then every 10 s
    assert stand(35.0) == [("blocked", 10.0), ("blocked", 20.0), ("blocked", 30.0)]
    navigator.start((0.0, 5.0))  # a new trial, its clock from 0 again
    assert stand(12.0) == [("blocked", 10.0)]


# --- behaviors: merging ---------------------------------------------------------------------


def test_merge_is_the_priority_times_fit_weighted_average() -> None:
    proposals = [
        (Proposal(0.5, 0.4, 1.0), 1.0),    # weight 1.0
        (Proposal(0.2, None, 0.5), 0.6),   # weight 0.3, no speed
        (Proposal(None, 0.1, 0.25), 0.8),  # weight 0.2, no turn
        (Proposal(3.0, 3.0, 0.0), 1.0),    # fit 0: ignored
    ]
    speed, turn = merge(proposals)
    # turn: (1.0 * 0.5 + 0.3 * 0.2) / (1.0 + 0.3) = 0.56 / 1.3
    assert turn == pytest.approx(0.56 / 1.3)
    # speed: (1.0 * 0.4 + 0.2 * 0.1) / (1.0 + 0.2) = 0.42 / 1.2 = 0.35
    assert speed == pytest.approx(0.35)


def test_opposite_turns_do_not_cancel_the_heavier_side_wins() -> None:
    # left weighs 1.0 * 0.5 = 0.5, right 0.3 * 1.0 = 0.3: left, averaged with the neutral one
    proposals = [(Proposal(0.5, None, 1.0), 1.0), (Proposal(-1.0, None, 0.5), 0.6),
                 (Proposal(0.0, None, 1.0), 0.5)]
    _, turn = merge(proposals)
    assert turn == pytest.approx(0.5 / 1.5)


def test_the_arbiter_holds_its_side_until_the_other_weighs_twice_as_much() -> None:
    arbiter = Arbiter()
    left, right = Proposal(1.0, None, 1.0), Proposal(-1.0, None, 1.0)
    assert arbiter.merge([(left, 1.0), (right, 0.8)])[1] == 1.0
    # the balance tips a little to the right: the side held stays
    assert arbiter.merge([(left, 0.8), (right, 1.0)])[1] == 1.0
    # past the hold ratio it flips
    assert arbiter.merge([(left, 0.4), (right, 1.0)])[1] == -1.0
    # a second without conflict and the side held is forgotten
    for _ in range(HOLD_STEPS):
        arbiter.merge([(left, 1.0)])
    assert arbiter.side == 0
    assert arbiter.merge([(left, 0.8), (right, 1.0)])[1] == -1.0


def test_a_fitting_limit_caps_the_speed_and_backing_up_wins() -> None:
    go = Proposal(None, 0.4, 1.0)
    # avoidCollision's 0 at full fit stops the robot however goToPos pulls
    assert merge([(go, 1.0), (Proposal(None, 0.0, 1.0, limit=True), 1.0)])[0] == 0.0
    # at half fit it caps at 0 + 0.5 * (0.4 - 0), below the average 0.4 * 1 / 1.5
    assert merge([(go, 1.0), (Proposal(None, 0.0, 0.5, limit=True), 1.0)])[0] == \
        pytest.approx(0.2)
    assert merge([(go, 1.0), (Proposal(None, 0.1, 0.9, limit=True), 0.2)])[0] == \
        pytest.approx(0.1 + 0.1 * 0.3)
    # an escape backing up is not averaged with the pull forward
    assert merge([(go, 1.0), (Proposal(0.5, -0.1, 1.0), 0.6)])[0] == -0.1


def test_merge_of_nothing_stands_still() -> None:
    assert merge([]) == (0.0, 0.0)
    assert merge([(Proposal(None, None, 1.0), 1.0)]) == (0.0, 0.0)
    assert merge([(Proposal(1.0, 1.0, 0.0), 1.0)]) == (0.0, 0.0)


_value = st.floats(-2.0, 2.0)
_proposal = st.builds(Proposal, st.none() | _value, st.none() | _value, st.floats(0.0, 1.0))


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(_proposal, st.sampled_from(sorted(PRIORITIES.values()))),
                max_size=6))
def test_merge_stays_between_the_proposals_that_count(
        proposals: list[tuple[Proposal, float]]) -> None:
    speed, turn = merge(proposals)
    for channel, merged in (("turn", turn), ("speed", speed)):
        values = [getattr(p, channel) for p, priority in proposals
                  if getattr(p, channel) is not None and p.fit * priority > NEGLIGIBLE]
        if values:
            assert min(values) - 1e-9 <= merged <= max(values) + 1e-9
        else:
            assert merged == 0.0


def test_priority_orders_the_merge() -> None:
    # two behaviors pulling opposite ways with full fit: the higher priority wins the side,
    # whole: no average of a left and a right turn
    _, turn = merge([(Proposal(1.0, None, 1.0), PRIORITIES["high"]),
                     (Proposal(-1.0, None, 1.0), PRIORITIES["low"])])
    assert turn == 1.0


# --- behaviors: each one --------------------------------------------------------------------


def test_simple_behaviors_propose_what_table_1_says() -> None:
    obs = observation(0.0, 0.0, 0.0, clear())
    assert Stop().propose(obs, (1.0, 0.0)) == Proposal(None, 0.0, 1.0)
    assert MoveForward(0.3).propose(obs, (1.0, 0.0)) == Proposal(None, 0.3, 1.0)


def test_go_to_pos_heads_for_its_position_and_holds_within_accuracy() -> None:
    behavior = GoToPos(None, 0.3, 0.2)
    gain = math.radians(100.0) / math.pi
    # goal 45 deg left, 2 m away: turn gain * pi/4, speed 0.3 cos 45
    p = behavior.propose(observation(0.0, 0.0, 0.0, clear()), (math.sqrt(2), math.sqrt(2)))
    assert p.turn == pytest.approx(gain * math.pi / 4)
    assert p.speed == pytest.approx(0.3 * math.cos(math.pi / 4)) and p.fit == 1.0
    # 0.25 m straight ahead: slows to 0.25 / 0.5 of its speed
    p = behavior.propose(observation(0.0, 0.0, 0.0, clear()), (0.25, 0.0))
    assert p.speed == pytest.approx(0.15) and p.turn == pytest.approx(0.0)
    # within accuracy: hold still
    assert behavior.propose(observation(0.0, 0.0, 0.0, clear()), (0.1, 0.1)) == \
        Proposal(0.0, 0.0, 1.0)
    # a position of its own overrides the pilot's target
    p = GoToPos((0.0, -3.0), 0.3, 0.2).propose(observation(0.0, 0.0, 0.0, clear()), (5.0, 0.0))
    assert p.turn == pytest.approx(-gain * math.pi / 2) and p.speed == pytest.approx(0.0)


def test_go_straight_latches_the_heading_it_starts_with() -> None:
    behavior = GoStraight(0.2)
    assert behavior.propose(observation(0.0, 0.0, 0.3, clear()), (9.0, 9.0)).turn == 0.0
    p = behavior.propose(observation(0.0, 0.0, 0.5, clear()), (9.0, 9.0))
    assert p.turn == pytest.approx(-0.2 * math.radians(100.0) / math.pi)
    behavior.reset()
    assert behavior.propose(observation(0.0, 0.0, 0.5, clear()), (9.0, 9.0)).turn == 0.0


def test_avoid_collision_fit_and_turn() -> None:
    behavior = AvoidCollision(0.5, 1.0)
    target = (10.0, 0.0)
    # beam 2 (+30 deg) at 0.4 m: within the distance, full fit, turn right (away), slowing to
    # slow (0.1 m/s) times (0.4 - 0.25) / (0.75 - 0.25), 0 at half the distance
    assert behavior.propose(observation(0, 0, 0, clear(b2=0.4)), target) == \
        Proposal(-1.0, pytest.approx(0.1 * 0.3), 1.0, limit=True)
    assert behavior.propose(observation(0, 0, 0, clear(b2=0.2)), target).speed == 0.0
    # at 0.625 m the fit is halfway down its fade from 0.5 to 0.75
    behavior.reset()
    p = behavior.propose(observation(0, 0, 0, clear(b5=0.625)), target)  # -30 deg: turn left
    assert p.fit == pytest.approx(0.5) and p.turn == 1.0
    assert p.speed == pytest.approx(0.1 * 0.75)
    # the side is held while the obstacle stays in reach, even as it moves across
    assert behavior.propose(observation(0, 0, 0, clear(b2=0.6)), target).turn == 1.0
    # beyond 0.75 m, or outside the 60 deg front arc (beam 0 at +90 deg), nothing to say
    assert behavior.propose(observation(0, 0, 0, clear(b2=0.8)), target).fit == 0.0
    assert behavior.propose(observation(0, 0, 0, clear(b0=0.1)), target).fit == 0.0


def test_avoid_obstacle_fit_grows_as_the_obstacle_nears() -> None:
    behavior = AvoidObstacle(1.5, 0.2, turn_rate=0.8)
    # beam 0 (+90 deg, the front half's edge) at 0.6 m: fit 1 - 0.6/1.5 = 0.6, turn right
    p = behavior.propose(observation(0, 0, 0, clear(b0=0.6)), (10.0, 0.0))
    assert p == Proposal(-0.8, 0.2, pytest.approx(0.6), limit=True)
    # behind the robot (beam 11, -170 deg) does not count
    assert behavior.propose(observation(0, 0, 0, clear(b11=0.1)), (10.0, 0.0)).fit == 0.0


def test_sector_finds_the_nearest_reading_and_the_side_away_from_the_close_ones() -> None:
    angles = np.radians([10.0, -10.0, 120.0])
    arc = math.radians(90.0)
    # left beam closer: weight (1 - 0.3) sin 10 > (1 - 0.5) sin 10 on the right: turn right;
    # the beam at 120 deg is outside the arc, however close
    assert sector(np.array([0.3, 0.5, 0.1]), angles, arc, 1.0) == (0.3, -1.0)
    assert sector(np.array([0.5, 0.3, 0.1]), angles, arc, 1.0) == (0.3, 1.0)
    assert sector(np.array([0.4, 0.4, 0.1]), angles, arc, 1.0) == (0.4, 1.0)  # balanced: left
    assert sector(np.array([2.0, 2.0, 0.1]), angles, arc, 1.0) == (2.0, 1.0)  # none within 1 m
    assert sector(np.array([0.1]), np.radians([150.0]), arc, 1.0) == (math.inf, 1.0)


# --- behaviors: plain data ------------------------------------------------------------------


FIGURE_4A = [
    [["avoidObstacle", 150, "moderate"], "med"],
    [["goToPos", "curr-goal", "mod-fast", 100], "high"],
    [["avoidCollision", 50, "mod-fast"], "high"],
]


def test_figure_4a_parses_in_centimetres() -> None:
    obstacle, goal, collision = parse_behavior_set(FIGURE_4A)
    assert obstacle.behavior == AvoidObstacle(1.5, 0.2) and obstacle.priority == 0.6
    assert isinstance(goal.behavior, GoToPos) and goal.priority == 1.0
    assert goal.behavior.position is None
    assert (goal.behavior.speed, goal.behavior.accuracy) == pytest.approx((0.3, 1.0))
    assert collision.behavior == AvoidCollision(0.5, math.radians(75.0))
    assert collision.priority == 1.0 and collision.data == FIGURE_4A[2]


def test_plain_data_numbers_follow_the_length_unit() -> None:
    (goal, forward, straight) = parse_behavior_set(
        [[["goToPos", [2, 3], 0.25, 0.1], 0.5], [["moveForward", "very-slow"], "low"],
         [["goStraight", 20, 90], "med-low"]], length_unit="m")
    assert goal.behavior == GoToPos((2.0, 3.0), 0.25, 0.1) and goal.priority == 0.5
    assert forward.behavior == MoveForward(0.05) and forward.priority == 0.2
    assert straight.behavior == GoStraight(20.0, math.pi / 2)
    (goal,) = parse_behavior_set([[["goToPos", [200, 300], 25, 10], "high"]])
    assert goal.behavior == GoToPos((2.0, 3.0), 0.25, 0.1)


def test_named_levels() -> None:
    speeds = {"very-slow": 0.05, "slow": 0.1, "moderate": 0.2, "mod-fast": 0.3, "fast": 0.4}
    degrees = {"very-slow": 12.5, "slow": 25.0, "moderate": 50.0, "mod-fast": 75.0,
               "fast": 100.0}
    assert set(SPEEDS) == set(TURN_RATES) == set(speeds)
    for name in speeds:
        assert SPEEDS[name] == pytest.approx(speeds[name])
        assert TURN_RATES[name] == pytest.approx(math.radians(degrees[name]))
    assert PRIORITIES == {"low": 0.2, "med-low": 0.4, "med": 0.6, "med-high": 0.8, "high": 1.0}


def test_fast_is_the_pioneer_turn_limit_and_the_cruising_speed_under_its_top_speed() -> None:
    assert TURN_RATES["fast"] == PIONEER_2DX.max_turn_rate
    assert SPEEDS["fast"] == PotentialFieldOptions().max_speed < PIONEER_2DX.max_speed


@pytest.mark.parametrize(("data", "message"), [
    ("stop", "expected a list of behaviors"),
    ([["stop", "high"]], "item 0: expected \\[\\[name, arg, ...\\], priority\\]"),
    ([[["stop"], "high"], [["fly", "curr-head"], "med"]],
     "item 1: unknown behavior 'fly'; known: avoidCollision, avoidObstacle, backOff, "
     "enterDoorway, "
     "followWall, goStraight, goToPos, localize, moveForward, slowAvoid, stop, turnTo"),
    ([[["goToPos", "curr-goal", "slow"], "high"]],
     "item 0: goToPos takes 3 argument\\(s\\) \\(goToPos position speed accuracy\\), got 2"),
    ([[["moveForward", "warp"], "high"]], "item 0: moveForward velocity: unknown speed 'warp'"),
    ([[["moveForward", -5], "high"]], "expected a speed >= 0"),
    ([[["avoidObstacle", 0, "slow"], "high"]], "expected a distance > 0"),
    ([[["goToPos", "home", "slow", 10], "high"]], "expected 'curr-goal' or \\[x, y\\]"),
    ([[["goStraight", "slow", "north"], "high"]], "expected 'curr-head' or degrees"),
    ([[["stop"], "urgent"]], "item 0: stop priority: unknown priority 'urgent'"),
    ([[["stop"], 1.5]], "expected a priority in \\(0, 1\\]"),
    ([[["stop"], True]], "expected a finite number"),
])
def test_bad_behavior_sets_are_refused_naming_the_item(data: Any, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        parse_behavior_set(data)


def test_behavior_pilot_options_report_a_bad_set_at_its_path() -> None:
    options, problems = option_problems(BehaviorPilotOptions, {}, "pilot")
    assert problems == [] and options.length_unit == "cm"
    assert len(BehaviorPilot.from_data(options.behaviors).behaviors) == 3
    _, problems = option_problems(BehaviorPilotOptions,
                                  {"behaviors": [[["fly"], "high"]]}, "pilot")
    assert len(problems) == 1
    path, message = problems[0]
    assert path == "pilot.behaviors"
    assert message.startswith("must be a behavior set: item 0: unknown behavior 'fly'")


def test_a_behavior_registered_by_name_is_parsed_and_merged() -> None:
    @attrs.define
    class Spin:
        rate: float

        def propose(self, obs: Observation, target: tuple[float, float]) -> Proposal:
            return Proposal(self.rate, None, 1.0)

        def reset(self) -> None:
            pass

    register_behavior("testSpin", Spin, [("rate", "turn_rate")], "Turn on the spot.")
    try:
        with pytest.raises(ValueError, match="already registered"):
            register_behavior("testSpin", Spin, [("rate", "turn_rate")])
        pilot = BehaviorPilot.from_data([[["testSpin", 50], "high"], [["stop"], "low"]])
        v, w = pilot.command(observation(0.0, 0.0, 0.0, clear()), (1.0, 1.0))
        assert (v, w) == (0.0, pytest.approx(math.radians(50.0)))
        assert pilot.proposals == (Proposal(pytest.approx(math.radians(50.0)), None, 1.0),
                                   Proposal(None, 0.0, 1.0))
    finally:
        del BEHAVIORS["testSpin"]
    with pytest.raises(ValueError, match="unknown kind 'colour'"):
        register_behavior("testPaint", Spin, [("rate", "colour")])
    assert "testPaint" not in BEHAVIORS


# --- behaviors: closed loop -----------------------------------------------------------------

GO_AND_AVOID = [[["goToPos", "curr-goal", "mod-fast", 20], "high"],
                [["avoidCollision", 50, "mod-fast"], "high"]]


@pytest.mark.parametrize(("start", "target"), [((2.0, 2.0), (11.0, 8.0)),
                                                ((12.0, 5.0), (3.0, 4.0))])
def test_go_to_pos_with_avoid_collision_reaches_a_target_in_open_space(
        start: tuple[float, float], target: tuple[float, float]) -> None:
    pilot = BehaviorPilot.from_data(GO_AND_AVOID)
    run = drive(OPEN, start, 0.0, target, Navigator(pilot, PILOT_ONLY), timeout=120.0)
    assert run.reached and run.collisions == 0


@pytest.mark.parametrize(("start", "heading"), [((3.0, 5.0), 0.0), ((3.0, 3.0), 0.3),
                                                ((3.0, 7.0), -0.3)])
def test_go_to_pos_with_avoid_collision_stops_before_a_wall(start: tuple[float, float],
                                                            heading: float) -> None:
    # the target lies behind a 6 m wall at x = 7; the pair has no way round it and must not
    # run into it
    pilot = BehaviorPilot.from_data(GO_AND_AVOID)
    run = drive(WALL, start, heading, (10.0, 5.0), Navigator(pilot, PILOT_ONLY),
                timeout=120.0)
    assert not run.reached and run.collisions == 0
    assert run.trajectory[:, 1].max() < 7.0 - RADIUS
    # it came up to the wall, within avoidCollision's reach, and stays there: in the last
    # minute it moves under 2 cm/s on average (it cruises at 0.3 m/s), creeping along the
    # wall toward the point facing the target
    late = run.trajectory[run.trajectory[:, 0] >= 60.0]
    assert late[:, 1].min() > 7.0 - RADIUS - 0.75
    assert path_length(late) < 1.2


def test_figure_4a_goes_round_the_wall() -> None:
    # with avoidObstacle turning it away from 1.5 m on, the open-area case finds the wall's end
    pilot = BehaviorPilot.from_data(FIGURE_4A)
    run = drive(WALL, (3.0, 5.0), 0.0, (10.0, 5.0), Navigator(pilot, PILOT_ONLY), timeout=200.0,
                tolerance=1.0)
    assert run.reached and run.collisions == 0


def test_behavior_pilot_install_and_reset() -> None:
    pilot = BehaviorPilot.from_data([[["goStraight", "slow", "curr-head"], "high"]])
    pilot.command(observation(0.0, 0.0, 1.0, clear()), (0.0, 0.0))
    _, w = pilot.command(observation(0.0, 0.0, 1.2, clear()), (0.0, 0.0))
    assert w < 0.0  # back toward the latched 1.0
    pilot.install(parse_behavior_set([[["moveForward", "fast"], "high"]]))
    assert pilot.proposals == ()
    assert pilot.command(observation(0.0, 0.0, 0.0, clear()), (0.0, 0.0)) == (0.4, 0.0)
