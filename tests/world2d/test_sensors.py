"""Fuzzy numbers and the senses of cbr_world2d: sonar, camera, bumper, odometry and the
observation, against analytic cases, brute force and independent geometry."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_world2d.fuzzy import (
    Triangle,
    angle_contains,
    angle_overlap,
    overlap,
    overlap_arrays,
    unchecked,
    wrap_angle,
)
from cbr_world2d.geometry import wrap
from cbr_world2d.robot import PIONEER_2DX, Pose, RobotState, step
from cbr_world2d.sensors import (
    PIONEER_SONAR_DEGREES,
    Bumper,
    Camera,
    Odometry,
    Sensors,
    SonarRing,
)
from cbr_world2d.world import Landmark, Wall, World

NO_DISCS = np.zeros((0, 3))
NO_SEGMENTS = np.zeros((0, 4))


# Fuzzy numbers.

def test_triangle_membership_and_support() -> None:
    t = Triangle(1.0, 2.0, 4.0)
    assert [t.membership(x) for x in (0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0)] == [
        0.0, 0.0, 0.5, 1.0, 0.5, 0.0, 0.0]
    assert t.contains(1.0) and t.contains(4.0) and not t.contains(4.01)
    assert Triangle(3.0, 3.0, 3.0).membership(3.0) == 1.0
    assert Triangle.around(2.0, 0.5) == Triangle(1.5, 2.0, 2.5)
    assert t.spread == 3.0
    assert unchecked(1.0, 2.0, 4.0) == t


@pytest.mark.parametrize("corners", [(2.0, 1.0, 3.0), (0.0, 3.0, 2.0), (math.nan, 1.0, 2.0),
                                     (0.0, 1.0, math.inf)])
def test_a_triangle_needs_ordered_finite_corners(corners: tuple[float, float, float]) -> None:
    with pytest.raises(ValueError, match="triangle"):
        Triangle(*corners)


def test_overlap_on_figure_3_cases() -> None:
    assert overlap(Triangle(0, 1, 2), Triangle(1, 2, 3)) == 0.5
    assert overlap(Triangle(0, 1, 2), Triangle(0, 1, 2)) == 1.0
    assert overlap(Triangle(0, 1, 2), Triangle(2, 3, 4)) == 0.0
    assert overlap(Triangle(0, 1, 2), Triangle(5, 6, 7)) == 0.0
    assert overlap(Triangle(0, 0, 4), Triangle(1, 4, 4)) == pytest.approx(3.0 / 7.0)
    # A crisp number's similarity is the other's membership at it.
    assert overlap(Triangle(1.5, 1.5, 1.5), Triangle(1, 2, 3)) == 0.5


triangles = st.tuples(st.floats(-10, 10), st.floats(0.05, 6), st.floats(0.05, 6)).map(
    lambda t: Triangle(t[0] - t[1], t[0], t[0] + t[2]))


@settings(max_examples=200, deadline=None)
@given(a=triangles, b=triangles)
def test_overlap_matches_brute_force_on_a_dense_grid(a: Triangle, b: Triangle) -> None:
    lo, hi = min(a.low, b.low), max(a.high, b.high)
    step = (hi - lo) / 40_000
    xs = np.concatenate([np.linspace(lo, hi, 40_001), [a.peak, b.peak]])

    def membership(t: Triangle, x: np.ndarray) -> np.ndarray:
        return np.clip(np.minimum((x - t.low) / (t.peak - t.low),
                                  (t.high - x) / (t.high - t.peak)), 0.0, 1.0)

    brute = float(np.max(np.minimum(membership(a, xs), membership(b, xs))))
    slope = max(1 / (a.peak - a.low), 1 / (a.high - a.peak), 1 / (b.peak - b.low),
                1 / (b.high - b.peak))
    value = overlap(a, b)
    assert brute <= value + 1e-9
    assert value - brute <= slope * step + 1e-9
    assert overlap(b, a) == value


@settings(max_examples=100, deadline=None)
@given(rows=st.lists(st.tuples(triangles, triangles), min_size=1, max_size=20))
def test_overlap_arrays_is_overlap_row_by_row(rows: list[tuple[Triangle, Triangle]]) -> None:
    a = np.array([p.as_tuple() for p, _ in rows])
    b = np.array([q.as_tuple() for _, q in rows])
    assert overlap_arrays(a, b) == pytest.approx([overlap(p, q) for p, q in rows], abs=1e-12)
    shifted = [(p, q.shifted(2 * math.pi * 3)) for p, q in rows]
    b_shifted = np.array([q.as_tuple() for _, q in shifted])
    assert overlap_arrays(a, b_shifted, angular=True) == pytest.approx(
        [angle_overlap(p, q) for p, q in shifted], abs=1e-9)


def test_angles_are_compared_across_the_wrap() -> None:
    deg = math.radians
    a = Triangle.around(deg(179.0), deg(3.0))
    b = Triangle.around(deg(-179.0), deg(3.0))
    assert overlap(a, b) == 0.0
    assert angle_overlap(a, b) == pytest.approx(2.0 / 3.0)
    assert angle_overlap(b, a) == pytest.approx(2.0 / 3.0)
    assert angle_contains(a, deg(-179.5))
    assert not angle_contains(a, deg(-175.0))


@settings(deadline=None)
@given(st.floats(-50.0, 50.0))
def test_wrap_angle_agrees_with_the_kernel(angle: float) -> None:
    assert -math.pi < wrap_angle(angle) <= math.pi
    assert wrap_angle(angle) == pytest.approx(wrap(angle), abs=1e-12)
    assert math.cos(wrap_angle(angle)) == pytest.approx(math.cos(angle), abs=1e-9)


# Sonar.

def test_the_ring_is_the_pioneer_2dx_ring() -> None:
    ring = SonarRing()
    assert ring.directions.shape == (16,)
    assert np.degrees(ring.directions) == pytest.approx(PIONEER_SONAR_DEGREES)
    front, rear = PIONEER_SONAR_DEGREES[:8], PIONEER_SONAR_DEGREES[8:]
    assert sorted(front) == [-90, -50, -30, -10, 10, 30, 50, 90]
    assert sorted(rear) == [-170, -150, -130, -90, 90, 130, 150, 170]
    assert ring.max_range == 5.0
    assert ring.beam_width == pytest.approx(math.radians(30.0))
    assert ring.mount_radius == PIONEER_2DX.radius


def _room() -> np.ndarray:
    return np.array([[0, 0, 10, 0], [10, 0, 10, 6], [10, 6, 0, 6], [0, 6, 0, 0]], dtype=float)


def test_single_ray_beams_read_the_distance_from_the_rim() -> None:
    ring = SonarRing(rays_per_beam=1, noise=0.0)
    pose = Pose(4.0, 3.0, 0.0)
    got = dict(zip(PIONEER_SONAR_DEGREES[:8], ring.read(pose, _room(), NO_DISCS,
                                                        np.random.default_rng(0)), strict=False))
    r = ring.mount_radius
    assert got[90.0] == pytest.approx(3.0 - r)
    assert got[10.0] == pytest.approx(5.0)  # 6 / cos(10) - r is beyond range
    assert got[50.0] == pytest.approx(3.0 / math.sin(math.radians(50.0)) - r)
    assert got[-30.0] == pytest.approx(min(3.0 / math.sin(math.radians(30.0)) - r, 5.0))


def test_a_cone_reads_its_nearest_ray_and_a_rotated_robot_rotates_the_ring() -> None:
    ring = SonarRing(noise=0.0)
    wall = np.array([[2.0, -10.0, 2.0, 10.0]])
    r = ring.mount_radius
    facing = ring.read(Pose(0.0, 0.0, 0.0), wall, NO_DISCS, np.random.default_rng(0))
    index = PIONEER_SONAR_DEGREES.index(10.0)
    # the cone spans -5 to 25 degrees: the wall's nearest point, straight ahead, is inside it
    assert facing[index] == pytest.approx(2.0 - r)
    away = ring.read(Pose(0.0, 0.0, math.pi), wall, NO_DISCS, np.random.default_rng(0))
    assert away[PIONEER_SONAR_DEGREES.index(170.0)] == pytest.approx(2.0 - r)
    # the 50 degree beam spans 35 to 65 degrees: its nearest point is on its 35 degree edge
    assert facing[PIONEER_SONAR_DEGREES.index(50.0)] == pytest.approx(
        2.0 / math.cos(math.radians(35.0)) - r)


def test_a_thin_obstacle_between_the_rays_of_a_cone_is_seen() -> None:
    ring = SonarRing(noise=0.0)
    r = ring.mount_radius
    # a wall's end points straight at the robot: no ray of the +-10 degree beams meets it
    end_on = np.array([[1.0, 0.0, 3.0, 0.0]])
    got = ring.read(Pose(0.0, 0.0, 0.0), end_on, NO_DISCS, np.random.default_rng(0))
    for degrees in (10.0, -10.0):
        assert got[PIONEER_SONAR_DEGREES.index(degrees)] == pytest.approx(1.0 - r)
    post = np.array([[1.5, 0.0, 0.02]])
    got = ring.read(Pose(0.0, 0.0, 0.0), np.empty((0, 4)), post, np.random.default_rng(0))
    assert got[PIONEER_SONAR_DEGREES.index(10.0)] == pytest.approx(1.5 - 0.02 - r)


def _cone_brute_force(ring: SonarRing, pose: Pose, segments: np.ndarray,
                      discs: np.ndarray) -> np.ndarray:
    """Each beam's reading from points sampled densely along every surface, kept when inside
    the beam's cone: distance from the centre less the mount radius, capped at the range."""
    t = np.linspace(0.0, 1.0, 4001)[:, None]
    points = [segments[:, :2] + t[..., None] * (segments[:, 2:] - segments[:, :2])]
    angle = np.linspace(0.0, 2.0 * math.pi, 4001)[:, None]
    points.append(discs[:, :2] + discs[:, 2][None, :, None]
                  * np.stack([np.cos(angle), np.sin(angle)], -1))
    cloud = np.concatenate([p.reshape(-1, 2) for p in points]) - (pose.x, pose.y)
    reach = np.hypot(cloud[:, 0], cloud[:, 1])
    bearing = np.arctan2(cloud[:, 1], cloud[:, 0])
    half = ring.beam_width / 2.0
    readings = []
    for direction in ring.directions:
        off = np.abs((bearing - pose.theta - direction + math.pi) % (2.0 * math.pi) - math.pi)
        inside = reach[off <= half + 1e-12]
        nearest = inside.min() if inside.size else math.inf
        readings.append(min(max(nearest - ring.mount_radius, 0.0), ring.max_range))
    return np.array(readings)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_a_beam_reads_the_nearest_surface_inside_its_cone(seed: int) -> None:
    rng = np.random.default_rng(seed)
    segments = rng.uniform(-4.0, 4.0, (6, 4))
    discs = np.column_stack([rng.uniform(-4.0, 4.0, (4, 2)), rng.uniform(0.02, 0.4, 4)])
    pose = Pose(0.0, 0.0, float(rng.uniform(-math.pi, math.pi)))
    # the robot stands free: no surface within its radius, where sampling cannot follow a
    # bearing that sweeps round as a segment passes next to the centre
    apart = np.hypot(discs[:, 0], discs[:, 1]) > discs[:, 2] + 0.3
    direction = segments[:, 2:] - segments[:, :2]
    along = np.clip(-np.einsum("ij,ij->i", segments[:, :2], direction)
                    / np.einsum("ij,ij->i", direction, direction), 0.0, 1.0)
    feet = segments[:, :2] + along[:, None] * direction
    clear = np.hypot(feet[:, 0], feet[:, 1]) > 0.3
    ring = SonarRing(noise=0.0, mount_radius=0.25)
    got = ring.read(pose, segments[clear], discs[apart], np.random.default_rng(0))
    expected = _cone_brute_force(ring, pose, segments[clear], discs[apart])
    # the sampled surfaces lie at most a few millimetres from the exact nearest point
    assert np.all(got <= expected + 1e-9)
    assert np.allclose(got, expected, atol=5e-3)


def test_sonar_noise_stays_within_range_and_follows_the_seed() -> None:
    ring = SonarRing(noise=0.5)
    pose = Pose(4.0, 3.0, 0.3)
    first = ring.read(pose, _room(), NO_DISCS, np.random.default_rng(3))
    again = ring.read(pose, _room(), NO_DISCS, np.random.default_rng(3))
    other = ring.read(pose, _room(), NO_DISCS, np.random.default_rng(4))
    assert np.array_equal(first, again)
    assert not np.array_equal(first, other)
    assert np.all((first >= 0.0) & (first <= ring.max_range))


# Camera.

def _seen_truth(pose: Pose, landmarks: np.ndarray, walls: np.ndarray,
                camera: Camera) -> dict[int, tuple[float, float]]:
    """Which landmarks an ideal camera sees, with true distance and bearing (pure Python)."""
    def orient(o: tuple[float, float], u: tuple[float, float], v: tuple[float, float]) -> float:
        return (u[0] - o[0]) * (v[1] - o[1]) - (u[1] - o[1]) * (v[0] - o[0])

    seen = {}
    p = (pose.x, pose.y)
    for i, (x, y, _) in enumerate(landmarks):
        distance = math.hypot(x - pose.x, y - pose.y)
        bearing = math.atan2(math.sin(math.atan2(y - pose.y, x - pose.x) - pose.theta),
                             math.cos(math.atan2(y - pose.y, x - pose.x) - pose.theta))
        if distance > camera.max_range or abs(bearing) > camera.fov / 2:
            continue
        blocked = False
        for ax, ay, bx, by in walls:
            a, b, q = (ax, ay), (bx, by), (x, y)
            if (orient(a, b, p) * orient(a, b, q) < 0 and orient(p, q, a) * orient(p, q, b) < 0):
                blocked = True
        if not blocked:
            seen[i] = (distance, bearing)
    return seen


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), fov=st.floats(0.2, 2 * math.pi),
       noise=st.floats(0.0, 0.99), spread=st.floats(0.0, 0.5), per_metre=st.floats(0.0, 0.3),
       bearing_spread=st.floats(0.0, 0.3), bearing_per_metre=st.floats(0.0, 0.1))
def test_every_sighting_contains_the_true_distance_and_bearing(
        seed: int, fov: float, noise: float, spread: float, per_metre: float,
        bearing_spread: float, bearing_per_metre: float) -> None:
    rng = np.random.default_rng(seed)
    camera = Camera(fov=fov, max_range=6.0, distance_spread=spread,
                    distance_spread_per_metre=per_metre, bearing_spread=bearing_spread,
                    bearing_spread_per_metre=bearing_per_metre, noise=noise)
    landmarks = np.column_stack([rng.uniform(0, 10, (12, 2)), np.full(12, 0.1)])
    a = rng.uniform(0, 10, (4, 2))
    walls = np.column_stack([a, a + rng.uniform(-2, 2, (4, 2))])
    pose = Pose(*rng.uniform(2, 8, 2), rng.uniform(-math.pi, math.pi))
    ids = [f"l{i}" for i in range(12)]
    sightings = camera.see(pose, landmarks, ids, walls, rng)
    truth = _seen_truth(pose, landmarks, walls, camera)
    assert [s.id for s in sightings] == [ids[i] for i in sorted(truth)]
    for sighting in sightings:
        # The truth here is computed apart from the kernel, so it may differ in the last bits.
        distance, bearing = truth[ids.index(sighting.id)]
        assert sighting.distance.low - 1e-9 <= distance <= sighting.distance.high + 1e-9
        assert sighting.bearing.low - 1e-9 <= bearing <= sighting.bearing.high + 1e-9
        assert sighting.distance.low >= 0.0


def test_spread_grows_with_distance() -> None:
    camera = Camera(noise=0.0)
    landmarks = np.array([[1.0, 0.0, 0.1], [5.0, 0.5, 0.1]])
    near, far = camera.see(Pose(0.0, 0.0, 0.0), landmarks, ["near", "far"], NO_SEGMENTS,
                           np.random.default_rng(0))
    assert near.distance == Triangle.around(1.0, 0.05 + 0.05 * 1.0)
    assert far.distance.spread > near.distance.spread
    assert far.bearing.spread > near.bearing.spread
    assert far.bearing.peak == pytest.approx(math.atan2(0.5, 5.0))


def test_an_occluded_landmark_is_not_seen() -> None:
    camera = Camera()
    landmarks = np.array([[4.0, 0.0, 0.1], [4.0, 2.2, 0.1]])
    wall = np.array([[2.0, -1.0, 2.0, 1.0]])
    seen = camera.see(Pose(0.0, 0.0, 0.0), landmarks, ["hidden", "visible"], wall,
                      np.random.default_rng(0))
    assert [s.id for s in seen] == ["visible"]
    assert camera.see(Pose(0.0, 0.0, 0.0), landmarks, ["hidden", "visible"], NO_SEGMENTS,
                      np.random.default_rng(0))[0].id == "hidden"


# Bumper and odometry.

def test_the_bumper_reports_the_contact_bearing() -> None:
    wall = np.array([[2.0, -5.0, 2.0, 5.0]])
    state = RobotState(0.0, 0.0, 0.2, 0.5, 0.0)
    bumped = False
    for _ in range(100):
        state, bumped = step(state, (0.5, 0.0), PIONEER_2DX, 0.1, wall, NO_DISCS)
        if bumped:
            break
    assert bumped
    hit, bearing = Bumper().read(state, True, wall, NO_DISCS)
    assert hit
    assert bearing == pytest.approx(-0.2)
    assert Bumper().read(state, False, wall, NO_DISCS)[0] is False


def _drive(n: int, seed: int) -> list[RobotState]:
    rng = np.random.default_rng(seed)
    state = RobotState(1.0, 1.0, 0.0)
    states = [state]
    for _ in range(n):
        command = (float(rng.uniform(-0.3, 0.75)), float(rng.uniform(-1.5, 1.5)))
        state, _ = step(state, command, PIONEER_2DX, 0.1, NO_SEGMENTS, NO_DISCS)
        states.append(state)
    return states


def test_noiseless_odometry_is_the_truth_with_full_confidence() -> None:
    odometry = Odometry()
    states = _drive(300, 1)
    odometry.reset(states[0])
    rng = np.random.default_rng(0)
    for before, after in itertools.pairwise(states):
        estimate = odometry.update(before, after, 0.1, rng)
        assert (estimate.x, estimate.y) == pytest.approx((after.x, after.y), abs=1e-9)
        assert math.cos(estimate.theta - after.theta) == pytest.approx(1.0)
        assert odometry.speed == pytest.approx(after.v, abs=1e-9)
        assert odometry.confidence == 1.0


def test_noisy_odometry_drifts_loses_confidence_and_repeats_with_the_seed() -> None:
    states = _drive(300, 2)

    def run(seed: int) -> tuple[list[Pose], list[float]]:
        odometry = Odometry(noise_v=0.05, noise_w=0.05)
        odometry.reset(states[0])
        rng = np.random.default_rng(seed)
        poses, confidence = [], []
        for before, after in itertools.pairwise(states):
            poses.append(odometry.update(before, after, 0.1, rng))
            confidence.append(odometry.confidence)
        return poses, confidence

    poses, confidence = run(5)
    assert run(5) == (poses, confidence)
    assert run(6)[0] != poses
    assert all(0.0 < c <= 1.0 for c in confidence)
    assert all(b <= a for a, b in itertools.pairwise(confidence))
    assert confidence[-1] < 1.0
    end = states[-1]
    assert math.hypot(poses[-1].x - end.x, poses[-1].y - end.y) > 0.0


# The suite.

def _world() -> World:
    return World(bounds=(0.0, 0.0, 10.0, 6.0), walls=(Wall((5.0, 0.0), (5.0, 2.5)),),
                 landmarks=(Landmark("l1", 8.0, 4.0, 0.1), Landmark("l2", 3.0, 5.0, 0.1),
                            Landmark("l3", 4.0, 1.0, 0.1)))


def _trial(seed: int) -> list:
    world = _world()
    sensors = Sensors(odometry=Odometry(noise_v=0.02, noise_w=0.02)).fitted(PIONEER_2DX.radius)
    rng = np.random.default_rng(seed)
    state = RobotState(1.0, 1.5, 0.0)
    observations = []
    bumped = False
    for i in range(120):
        t = 0.1 * i
        observations.append(sensors.observe(state, world, t, bumped, rng))
        state, bumped = step(state, (0.6, 0.15), PIONEER_2DX, 0.1, world.segments_at(t),
                             world.discs_at(t))
    return observations


def _plain(observation: object) -> tuple:
    o = observation
    return (o.t, o.pose, o.true_pose, o.sonar.tolist(), o.sonar_angles.tolist(), o.bumped,
            o.sightings, o.confidence, o.v, o.w, str(o.bump_bearing))


def test_the_same_seed_gives_the_same_readings() -> None:
    first = [_plain(o) for o in _trial(11)]
    assert first == [_plain(o) for o in _trial(11)]
    assert first != [_plain(o) for o in _trial(12)]


def test_an_observation_carries_every_sense() -> None:
    observations = _trial(3)
    first = observations[0]
    assert first.pose == first.true_pose == Pose(1.0, 1.5, 0.0)
    assert first.confidence == 1.0
    assert first.sonar.shape == first.sonar_angles.shape == (16,)
    assert {s.id for s in first.sightings} == {"l3"}
    assert any(o.bumped for o in observations)
    bumped = next(o for o in observations if o.bumped)
    assert -math.pi / 2 < bumped.bump_bearing < math.pi / 2
    assert observations[-1].confidence < 1.0


def test_fitting_a_suite_mounts_its_sonar_and_restarts_its_odometry() -> None:
    sensors = Sensors(odometry=Odometry(noise_v=0.1))
    sensors.observe(RobotState(1.0, 1.0, 0.0), _world(), 0.0, False, np.random.default_rng(0))
    fitted = sensors.fitted(0.4)
    assert fitted.sonar is not None
    assert fitted.sonar.mount_radius == 0.4
    assert fitted.odometry.noise_v == 0.1
    assert fitted.odometry is not sensors.odometry
    observation = fitted.observe(RobotState(2.0, 2.0, 1.0), _world(), 5.0, False,
                                 np.random.default_rng(0))
    assert observation.pose == Pose(2.0, 2.0, 1.0)


def test_a_suite_without_sonar_or_camera_still_observes() -> None:
    sensors = Sensors(sonar=None, camera=None)
    observation = sensors.observe(RobotState(1.0, 1.0, 0.0), _world(), 0.0, False,
                                  np.random.default_rng(0))
    assert observation.sonar.shape == (0,)
    assert observation.sightings == ()
