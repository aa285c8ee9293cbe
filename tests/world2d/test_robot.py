"""The disc robot of cbr_world2d: exact unicycle arcs, limits, and collisions that never let
it pass through or end inside anything (checked with independent pure-Python geometry)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_world2d.geometry import GAP
from cbr_world2d.robot import PIONEER_2DX, ROS_2005, Pose, RobotSpec, RobotState, limit, step

NO_DISCS = np.zeros((0, 3))
NO_SEGMENTS = np.zeros((0, 4))
OPEN = RobotSpec(radius=0.2, max_speed=10.0, max_reverse=10.0, max_turn_rate=10.0,
                 max_accel=1e6, max_turn_accel=1e6)


def point_segment(px: float, py: float, seg: np.ndarray) -> float:
    ax, ay, bx, by = (float(v) for v in seg)
    ex, ey = bx - ax, by - ay
    length2 = ex * ex + ey * ey
    s = 0.0 if length2 == 0.0 else min(max(((px - ax) * ex + (py - ay) * ey) / length2, 0.0),
                                       1.0)
    return math.hypot(px - (ax + s * ex), py - (ay + s * ey))


def crosses(p: tuple[float, float], q: tuple[float, float], seg: np.ndarray) -> bool:
    """Whether the closed segment pq meets ``seg`` (orientation tests)."""
    a = (float(seg[0]), float(seg[1]))
    b = (float(seg[2]), float(seg[3]))

    def orient(o: tuple[float, float], u: tuple[float, float], v: tuple[float, float]) -> float:
        return (u[0] - o[0]) * (v[1] - o[1]) - (u[1] - o[1]) * (v[0] - o[0])

    def on(o: tuple[float, float], u: tuple[float, float], v: tuple[float, float]) -> bool:
        return (min(o[0], u[0]) <= v[0] <= max(o[0], u[0])
                and min(o[1], u[1]) <= v[1] <= max(o[1], u[1]))

    d1, d2, d3, d4 = orient(a, b, p), orient(a, b, q), orient(p, q, a), orient(p, q, b)
    if d1 * d2 < 0 and d3 * d4 < 0:
        return True
    return ((d1 == 0 and on(a, b, p)) or (d2 == 0 and on(a, b, q))
            or (d3 == 0 and on(p, q, a)) or (d4 == 0 and on(p, q, b)))


def segment_segment(p: tuple[float, float], q: tuple[float, float], seg: np.ndarray) -> float:
    if crosses(p, q, seg):
        return 0.0
    a, b = seg[:2], seg[2:]
    chord = np.array([*p, *q])
    return min(point_segment(*p, seg), point_segment(*q, seg),
               point_segment(float(a[0]), float(a[1]), chord),
               point_segment(float(b[0]), float(b[1]), chord))


def clear(px: float, py: float, segments: np.ndarray, discs: np.ndarray) -> float:
    return min([point_segment(px, py, s) for s in segments]
               + [math.hypot(px - cx, py - cy) - r for cx, cy, r in discs] + [math.inf])


def test_the_presets_carry_their_sourced_numbers() -> None:
    assert PIONEER_2DX.radius == 0.25
    assert PIONEER_2DX.max_speed == 0.75
    assert PIONEER_2DX.max_turn_rate == pytest.approx(math.radians(100.0))
    assert PIONEER_2DX.max_accel == 0.3
    assert ROS_2005.max_speed == 0.05


@pytest.mark.parametrize("field", ["radius", "max_speed", "max_turn_rate", "max_accel",
                                   "max_turn_accel"])
@pytest.mark.parametrize("value", [0.0, -1.0, math.nan, math.inf])
def test_a_spec_rejects_non_positive_or_non_finite_limits(field: str, value: float) -> None:
    numbers = {"radius": 0.2, "max_speed": 1.0, "max_reverse": 0.5, "max_turn_rate": 1.0,
               "max_accel": 1.0, "max_turn_accel": 1.0, field: value}
    with pytest.raises(ValueError, match=field):
        RobotSpec(**numbers)


def test_straight_motion_in_open_space() -> None:
    state = RobotState(1.0, 2.0, math.radians(30.0), 0.5, 0.0)
    after, bumped = step(state, (0.5, 0.0), OPEN, 2.0, NO_SEGMENTS, NO_DISCS)
    assert not bumped
    assert (after.x, after.y) == pytest.approx((1.0 + math.sqrt(3) / 2, 2.5))
    assert after.theta == pytest.approx(math.radians(30.0))


def test_an_arc_follows_the_exact_circle() -> None:
    v, w, dt = 0.4, 0.8, 0.1
    state = RobotState(0.0, 0.0, 0.0, v, w)
    radius = v / w
    for i in range(1, 40):
        state, bumped = step(state, (v, w), OPEN, dt, NO_SEGMENTS, NO_DISCS)
        assert not bumped
        phi = w * dt * i
        assert (state.x, state.y) == pytest.approx(
            (radius * math.sin(phi), radius * (1.0 - math.cos(phi))), abs=1e-12)
        assert state.theta == pytest.approx(math.atan2(math.sin(phi), math.cos(phi)))
    # A full circle in one long step (cut into pieces inside) comes back to the start.
    state, _ = step(RobotState(0.0, 0.0, 0.0, v, w), (v, w), OPEN, 2 * math.pi / w,
                    NO_SEGMENTS, NO_DISCS)
    assert (state.x, state.y) == pytest.approx((0.0, 0.0), abs=1e-12)


def test_turning_on_the_spot_does_not_move() -> None:
    state, bumped = step(RobotState(3.0, 4.0, 0.0, 0.0, 1.0), (0.0, 1.0), OPEN, 0.5,
                         NO_SEGMENTS, NO_DISCS)
    assert not bumped
    assert (state.x, state.y, state.theta) == (3.0, 4.0, pytest.approx(0.5))


def test_acceleration_is_limited_before_speed() -> None:
    spec = RobotSpec(radius=0.2, max_speed=1.0, max_reverse=0.2, max_turn_rate=1.0,
                     max_accel=0.5, max_turn_accel=2.0)
    assert limit(0.0, 5.0, 0.5, 1.0, -0.2, 0.1) == pytest.approx(0.05)
    assert limit(0.9, 5.0, 0.5, 1.0, -0.2, 1.0) == 1.0
    assert limit(0.0, -5.0, 0.5, 1.0, -0.2, 1.0) == -0.2
    state, _ = step(RobotState(0.0, 0.0, 0.0), (5.0, -5.0), spec, 0.1, NO_SEGMENTS, NO_DISCS)
    assert (state.v, state.w) == pytest.approx((0.05, -0.2))
    # A speed above the limit (say the spec changed) is first braked at most by accel * dt,
    # then cut to the limit.
    state, _ = step(RobotState(0.0, 0.0, 0.0, 3.0, 0.0), (3.0, 0.0), spec, 0.1, NO_SEGMENTS,
                    NO_DISCS)
    assert state.v == 1.0


@settings(max_examples=60, deadline=None)
@given(commands=st.lists(st.tuples(st.floats(-3.0, 3.0), st.floats(-6.0, 6.0)), min_size=1,
                         max_size=40),
       dt=st.floats(0.01, 0.5))
def test_speed_turn_rate_and_their_changes_stay_within_the_limits(
        commands: list[tuple[float, float]], dt: float) -> None:
    spec = PIONEER_2DX
    state = RobotState(0.0, 0.0, 0.0)
    for command in commands:
        after, bumped = step(state, command, spec, dt, NO_SEGMENTS, NO_DISCS)
        assert not bumped
        assert -spec.max_reverse - 1e-12 <= after.v <= spec.max_speed + 1e-12
        assert abs(after.w) <= spec.max_turn_rate + 1e-12
        assert abs(after.v - state.v) <= spec.max_accel * dt + 1e-12
        assert abs(after.w - state.w) <= spec.max_turn_accel * dt + 1e-12
        travelled = math.hypot(after.x - state.x, after.y - state.y)
        assert travelled <= abs(after.v) * dt + 1e-12
        state = after


def test_driving_into_a_wall_stops_at_the_contact_point() -> None:
    wall = np.array([[2.0, -5.0, 2.0, 5.0]])
    state = RobotState(0.0, 0.0, 0.0, 0.5, 0.0)
    bumps = []
    for _ in range(60):
        state, bumped = step(state, (0.5, 0.0), OPEN, 0.1, wall, NO_DISCS)
        bumps.append(bumped)
    assert bumps.index(True) == 35  # 1.8 m at 5 cm a step: the 36th step is cut short
    assert all(bumps[35:])
    assert state.x == pytest.approx(2.0 - OPEN.radius - GAP, abs=1e-12)
    assert (state.v, state.w) == (0.0, 0.0)


def test_a_blocked_step_still_turns() -> None:
    wall = np.array([[2.0, -5.0, 2.0, 5.0]])
    at_wall = RobotState(2.0 - OPEN.radius - GAP, 0.0, 0.0, 0.5, 0.5)
    state, bumped = step(at_wall, (0.5, 0.5), OPEN, 0.2, wall, NO_DISCS)
    assert bumped
    assert (state.x, state.y) == (at_wall.x, at_wall.y)
    assert state.theta == pytest.approx(0.1)
    # Turned away, it can leave.
    state, bumped = step(RobotState(state.x, state.y, math.pi), (0.5, 0.0), OPEN, 0.2, wall,
                         NO_DISCS)
    assert not bumped
    assert state.x < at_wall.x


def test_in_contact_an_arc_that_would_dip_in_is_blocked_and_one_that_leaves_is_not() -> None:
    wall = np.array([[-5.0, 0.0, 5.0, 0.0]])
    y = OPEN.radius + GAP
    # Heading 5 degrees into the wall and turning away: the chord runs away from the wall but
    # the start of the arc dips toward it.
    dipping = RobotState(0.0, y, -math.radians(5.0), 0.5, 2.0)
    state, bumped = step(dipping, (0.5, 2.0), OPEN, 0.1, wall, NO_DISCS)
    assert bumped
    assert (state.x, state.y) == (0.0, y)
    leaving = RobotState(0.0, y, math.radians(5.0), 0.5, 2.0)
    state, bumped = step(leaving, (0.5, 2.0), OPEN, 0.1, wall, NO_DISCS)
    assert not bumped
    assert state.y > y


def test_in_contact_a_robot_can_back_away_but_not_back_in() -> None:
    wall = np.array([[-5.0, 0.0, 5.0, 0.0]])
    y = OPEN.radius + GAP
    facing_in = RobotState(0.0, y, -math.radians(80.0), -0.5, 0.0)
    state, bumped = step(facing_in, (-0.5, 0.0), OPEN, 0.1, wall, NO_DISCS)
    assert not bumped
    assert state.y > y
    # Backing along the wall while turning: the tail swings into the wall at first.
    state, bumped = step(RobotState(0.0, y, math.radians(5.0), -0.5, -2.0), (-0.5, -2.0), OPEN,
                         0.1, wall, NO_DISCS)
    assert bumped
    # Backing into it.
    state, bumped = step(RobotState(0.0, y, math.radians(80.0), -0.5, 0.0), (-0.5, 0.0), OPEN,
                         0.1, wall, NO_DISCS)
    assert bumped
    assert (state.x, state.y) == (0.0, y)


def _world(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    box = [(0.0, 0.0, 6.0, 0.0), (6.0, 0.0, 6.0, 6.0), (6.0, 6.0, 0.0, 6.0),
           (0.0, 6.0, 0.0, 0.0)]
    a = rng.uniform(0.0, 6.0, (8, 2))
    heading = rng.uniform(-math.pi, math.pi, 8)
    length = rng.uniform(0.3, 3.0, 8)
    b = a + np.column_stack([np.cos(heading), np.sin(heading)]) * length[:, None]
    segments = np.vstack([np.array(box), np.column_stack([a, b])])
    discs = np.column_stack([rng.uniform(0.5, 5.5, (4, 2)), rng.uniform(0.1, 0.5, 4)])
    return segments, discs


def _start(seed: int, radius: float, segments: np.ndarray, discs: np.ndarray) -> RobotState:
    rng = np.random.default_rng(seed + 1)
    while True:
        x, y = rng.uniform(0.0, 6.0, 2)
        if clear(x, y, segments, discs) > radius + 0.02:
            return RobotState(x, y, rng.uniform(-math.pi, math.pi))


def _check_trajectory(spec: RobotSpec, dt: float, seed: int,
                      commands: list[tuple[float, float, int]]) -> int:
    """Drive ``commands`` (v, w, held for n steps) in a random world and check every step with
    independent geometry; returns the number of blocked steps."""
    segments, discs = _world(seed)
    state = _start(seed, spec.radius, segments, discs)
    r = spec.radius
    blocked = 0
    for v, w, hold in commands:
        for _ in range(hold):
            after, bumped = step(state, (v, w), spec, dt, segments, discs)
            blocked += bumped
            p, q = (state.x, state.y), (after.x, after.y)
            # Never ends overlapping anything.
            assert clear(after.x, after.y, segments, discs) >= r
            single_piece = abs(after.w if not bumped else w) * dt <= math.pi / 4
            if single_piece or bumped is False:
                # Never crosses a segment between two steps.
                for seg in segments:
                    assert not crosses(p, q, seg)
            if single_piece:
                # The disc swept along the step's chord (its path within the sagitta) stays
                # clear of every segment and disc.
                for seg in segments:
                    assert segment_segment(p, q, seg) >= r
                chord = np.array([*p, *q])
                for cx, cy, rr in discs:
                    assert point_segment(cx, cy, chord) >= rr + r
            if not bumped:
                # The exact arc, sampled densely, keeps the disc clear.
                for s in np.linspace(0.0, dt, 25):
                    phi = after.w * s
                    if abs(after.w) > 1e-12:
                        x = state.x + after.v / after.w * (math.sin(state.theta + phi)
                                                           - math.sin(state.theta))
                        y = state.y - after.v / after.w * (math.cos(state.theta + phi)
                                                           - math.cos(state.theta))
                    else:
                        x = state.x + after.v * s * math.cos(state.theta)
                        y = state.y + after.v * s * math.sin(state.theta)
                    assert clear(x, y, segments, discs) >= r - 1e-9
            else:
                assert (after.v, after.w) == (0.0, 0.0)
            state = after
    return blocked


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 2**31),
       commands=st.lists(st.tuples(st.floats(-1.0, 1.0), st.floats(-2.0, 2.0),
                                   st.integers(1, 30)), min_size=1, max_size=8))
def test_a_pioneer_never_crosses_a_segment_nor_overlaps_a_disc(
        seed: int, commands: list[tuple[float, float, int]]) -> None:
    _check_trajectory(PIONEER_2DX, 0.1, seed, commands)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31),
       commands=st.lists(st.tuples(st.floats(-4.0, 4.0), st.floats(-12.0, 12.0),
                                   st.integers(1, 15)), min_size=1, max_size=6))
def test_a_fast_robot_with_long_steps_never_passes_through_anything(
        seed: int, commands: list[tuple[float, float, int]]) -> None:
    fast = RobotSpec(radius=0.3, max_speed=3.0, max_reverse=3.0, max_turn_rate=10.0,
                     max_accel=20.0, max_turn_accel=50.0)
    _check_trajectory(fast, 0.25, seed, commands)


def test_random_driving_does_collide_so_the_property_tests_bite() -> None:
    rng = np.random.default_rng(7)
    blocked = 0
    for seed in range(5):
        commands = [(float(rng.uniform(-1, 1)), float(rng.uniform(-2, 2)), 25)
                    for _ in range(6)]
        blocked += _check_trajectory(PIONEER_2DX, 0.1, seed, commands)
    assert blocked > 0


@pytest.mark.parametrize("dt", [0.0, -0.1, math.nan])
def test_a_step_needs_a_positive_time(dt: float) -> None:
    with pytest.raises(ValueError, match="time step"):
        step(RobotState(0.0, 0.0, 0.0), (0.1, 0.0), OPEN, dt, NO_SEGMENTS, NO_DISCS)


def test_pose_and_state() -> None:
    state = RobotState(1.0, 2.0, 0.5, 0.1, 0.2)
    assert state.pose == Pose(1.0, 2.0, 0.5)
