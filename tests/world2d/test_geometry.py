"""The geometry kernels of cbr_world2d against analytic cases and independent pure-Python or
numpy reference computations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_world2d.geometry import (
    GAP,
    cast_rays,
    clearance,
    landmark_view,
    nearest_point,
    ring_ranges,
    ring_ranges_into,
    sweep,
    visible,
    wrap,
)

NO_DISCS = np.zeros((0, 3))
NO_SEGMENTS = np.zeros((0, 4))


def _segments(*rows: tuple[float, float, float, float]) -> np.ndarray:
    return np.array(rows, dtype=float).reshape(-1, 4)


def _discs(*rows: tuple[float, float, float]) -> np.ndarray:
    return np.array(rows, dtype=float).reshape(-1, 3)


# Independent references, written without the kernels' formulas.

def ref_point_segment(px: float, py: float, seg: np.ndarray) -> float:
    a = np.array(seg[:2])
    b = np.array(seg[2:])
    p = np.array([px, py])
    ab = b - a
    if not ab.any():
        return float(np.linalg.norm(p - a))
    s = min(max(float(np.dot(p - a, ab) / np.dot(ab, ab)), 0.0), 1.0)
    return float(np.linalg.norm(p - (a + s * ab)))


def ref_ray_hit(x: float, y: float, angle: float, segments: np.ndarray,
                discs: np.ndarray) -> float:
    """Nearest hit by solving each 2x2 system with numpy (inf when missed)."""
    d = np.array([math.cos(angle), math.sin(angle)])
    best = math.inf
    for seg in segments:
        a = seg[:2]
        e = seg[2:] - seg[:2]
        matrix = np.column_stack([d, -e])
        if abs(np.linalg.det(matrix)) < 1e-12:
            continue
        t, s = np.linalg.solve(matrix, a - np.array([x, y]))
        if t >= 0.0 and -1e-12 <= s <= 1.0 + 1e-12:
            best = min(best, float(t))
    for cx, cy, r in discs:
        if math.hypot(x - cx, y - cy) <= r:
            return 0.0
        roots = np.roots([1.0, 2.0 * ((x - cx) * d[0] + (y - cy) * d[1]),
                          (x - cx) ** 2 + (y - cy) ** 2 - r * r])
        real = [float(v.real) for v in roots if abs(v.imag) < 1e-12 and v.real >= 0.0]
        if real:
            best = min(best, min(real))
    return best


def ref_intersect(p: tuple[float, float], q: tuple[float, float], a: tuple[float, float],
                  b: tuple[float, float]) -> bool:
    """Whether closed segments pq and ab meet (orientation tests)."""
    def orient(o: tuple[float, float], u: tuple[float, float], v: tuple[float, float]) -> float:
        return (u[0] - o[0]) * (v[1] - o[1]) - (u[1] - o[1]) * (v[0] - o[0])

    def on(o: tuple[float, float], u: tuple[float, float], v: tuple[float, float]) -> bool:
        return (min(o[0], u[0]) <= v[0] <= max(o[0], u[0])
                and min(o[1], u[1]) <= v[1] <= max(o[1], u[1]))

    d1, d2 = orient(a, b, p), orient(a, b, q)
    d3, d4 = orient(p, q, a), orient(p, q, b)
    if ((d1 > 0) != (d2 > 0) and d1 != 0 and d2 != 0
            and (d3 > 0) != (d4 > 0) and d3 != 0 and d4 != 0):
        return True
    return ((d1 == 0 and on(a, b, p)) or (d2 == 0 and on(a, b, q))
            or (d3 == 0 and on(p, q, a)) or (d4 == 0 and on(p, q, b)))


# Ray casting: analytic cases.

def test_a_wall_at_a_known_distance() -> None:
    wall = _segments((3.0, -5.0, 3.0, 5.0))
    angles = np.array([0.0, math.pi / 4, -math.pi / 4, math.pi, math.pi / 2])
    got = cast_rays(0.0, 0.0, angles, 20.0, wall, NO_DISCS)
    assert got == pytest.approx([3.0, 3.0 * math.sqrt(2), 3.0 * math.sqrt(2), 20.0, 20.0])


def test_a_corner() -> None:
    corner = _segments((2.0, -1.0, 2.0, 2.0), (2.0, 2.0, -1.0, 2.0))
    below = math.radians(30.0)
    above = math.radians(60.0)
    got = cast_rays(0.0, 0.0, np.array([math.pi / 4, below, above]), 10.0, corner, NO_DISCS)
    assert got == pytest.approx([2.0 * math.sqrt(2), 2.0 / math.cos(below),
                                 2.0 / math.sin(above)])


def test_a_disc() -> None:
    disc = _discs((5.0, 0.0, 1.0))
    a = math.radians(5.0)
    chord = 5.0 * math.cos(a) - math.sqrt(1.0 - 25.0 * math.sin(a) ** 2)
    tangent = math.asin(1.0 / 5.0)
    got = cast_rays(0.0, 0.0, np.array([0.0, a, tangent + 1e-6, math.pi]), 10.0, NO_SEGMENTS,
                    disc)
    assert got == pytest.approx([4.0, chord, 10.0, 10.0])


def test_a_ray_from_inside_a_disc_reads_zero() -> None:
    got = cast_rays(0.0, 0.0, np.array([0.0, 2.0]), 10.0, NO_SEGMENTS, _discs((0.1, 0.0, 0.5)))
    assert got.tolist() == [0.0, 0.0]


def test_a_ray_parallel_to_a_wall_misses_it_and_a_collinear_one_hits_its_end() -> None:
    beside = _segments((0.0, 1.0, 5.0, 1.0))
    assert cast_rays(0.0, 0.0, np.array([0.0]), 10.0, beside, NO_DISCS)[0] == 10.0
    ahead = _segments((4.0, 0.0, 2.0, 0.0))
    got = cast_rays(0.0, 0.0, np.array([0.0, math.pi]), 10.0, ahead, NO_DISCS)
    assert got.tolist() == [2.0, 10.0]


def test_nothing_within_range_reads_max_range() -> None:
    wall = _segments((10.0, -1.0, 10.0, 1.0))
    assert cast_rays(0.0, 0.0, np.array([0.0]), 5.0, wall, _discs((0.0, 9.0, 1.0)))[0] == 5.0
    assert cast_rays(0.0, 0.0, np.array([0.0, 1.0]), 5.0, NO_SEGMENTS, NO_DISCS).tolist() == [
        5.0, 5.0]


def _random_world(rng: np.random.Generator, n: int, m: int,
                  size: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    a = rng.uniform(0.0, size, (n, 2))
    heading = rng.uniform(-math.pi, math.pi, n)
    length = rng.uniform(0.2, 4.0, n)
    b = a + np.column_stack([np.cos(heading), np.sin(heading)]) * length[:, None]
    discs = np.column_stack([rng.uniform(0.0, size, (m, 2)), rng.uniform(0.05, 0.6, m)])
    return np.column_stack([a, b]), discs


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), max_range=st.floats(0.5, 15.0))
def test_ray_casting_matches_an_independent_solver(seed: int, max_range: float) -> None:
    rng = np.random.default_rng(seed)
    segments, discs = _random_world(rng, 25, 8)
    x, y = rng.uniform(0.0, 10.0, 2)
    angles = rng.uniform(-math.pi, math.pi, 24)
    got = cast_rays(x, y, angles, max_range, segments, discs)
    for angle, value in zip(angles, got, strict=True):
        expected = min(ref_ray_hit(x, y, angle, segments, discs), max_range)
        assert value == pytest.approx(expected, abs=1e-9)


def test_ring_ranges_are_measured_from_the_rim_and_read_the_nearest_point_of_a_cone() -> None:
    wall = _segments((3.0, -10.0, 3.0, 10.0))
    radius = 0.25
    directions = np.array([0.0, math.radians(10.0), math.pi, math.radians(30.0)])
    offsets = np.radians([-15.0, 0.0, 15.0])
    got = ring_ranges(0.0, 0.0, 0.0, directions, offsets, 5.0, radius, wall, NO_DISCS)
    # the beam at 10 degrees spans -5 to 25 and holds the wall's foot straight ahead; the beam
    # at 30 degrees spans 15 to 45, nearest the wall along its 15 degree edge
    assert got == pytest.approx([3.0 - radius, 3.0 - radius, 5.0,
                                 3.0 / math.cos(math.radians(15.0)) - radius])
    turned = ring_ranges(0.0, 0.0, math.pi, directions, offsets, 5.0, radius, wall, NO_DISCS)
    assert turned[2] == pytest.approx(3.0 - radius)
    into = np.empty(4)
    ring_ranges_into(0.0, 0.0, 0.0, directions, offsets, 5.0, radius, wall, NO_DISCS, into)
    assert into.tolist() == got.tolist()


def test_a_beam_touching_a_wall_reads_zero() -> None:
    wall = _segments((0.25, -1.0, 0.25, 1.0))
    got = ring_ranges(0.0, 0.0, 0.0, np.array([0.0]), np.zeros(1), 5.0, 0.25, wall, NO_DISCS)
    assert got[0] == 0.0


# Sweep.

def test_sweep_stops_a_gap_short_of_a_wall_and_a_disc() -> None:
    wall = _segments((5.0, -3.0, 5.0, 3.0))
    u = sweep(0.0, 0.0, 10.0, 0.0, 0.5, wall, NO_DISCS)
    assert u * 10.0 == pytest.approx(4.5 - GAP, abs=1e-12)
    u = sweep(0.0, 0.0, 10.0, 0.0, 0.5, NO_SEGMENTS, _discs((5.0, 0.0, 1.0)))
    assert u * 10.0 == pytest.approx(3.5 - GAP, abs=1e-12)


def test_sweep_touches_a_wall_end_on_its_round_cap() -> None:
    wall = _segments((5.0, 1.0, 5.0, 10.0))
    assert sweep(0.0, 0.0, 10.0, 0.0, 0.5, wall, NO_DISCS) == 1.0
    u = sweep(0.0, 0.0, 10.0, 0.0, 1.5, wall, NO_DISCS)
    r = 1.5 + GAP
    assert u * 10.0 == pytest.approx(5.0 - math.sqrt(r * r - 1.0), abs=1e-12)


def test_sweep_is_free_when_nothing_is_in_the_way() -> None:
    wall = _segments((0.0, 2.0, 10.0, 2.0))
    assert sweep(0.0, 0.0, 10.0, 0.0, 0.5, wall, _discs((5.0, -3.0, 1.0))) == 1.0
    assert sweep(1.0, 1.0, 1.0, 1.0, 0.5, wall, NO_DISCS) == 1.0


def test_a_disc_in_contact_can_leave_or_slide_but_not_push_in() -> None:
    wall = _segments((0.0, 0.0, 10.0, 0.0))
    y = 0.5 + GAP / 2
    assert sweep(5.0, y, 5.0, y - 1.0, 0.5, wall, NO_DISCS) == 0.0
    assert sweep(5.0, y, 5.0, y + 1.0, 0.5, wall, NO_DISCS) == 1.0
    assert sweep(5.0, y, 6.0, y, 0.5, wall, NO_DISCS) == 1.0
    assert sweep(5.0, y, 6.0, y - 0.01, 0.5, wall, NO_DISCS) == 0.0
    disc = _discs((5.0, 2.0, 1.0))
    start = 2.0 - 1.5 - GAP / 2
    assert sweep(5.0, start, 5.0, start + 1.0, 0.5, NO_SEGMENTS, disc) == 0.0
    assert sweep(5.0, start, 5.0, start - 1.0, 0.5, NO_SEGMENTS, disc) == 1.0


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), radius=st.floats(0.05, 0.8),
       reach=st.floats(0.01, 8.0))
def test_a_swept_move_never_ends_overlapping_or_crossing_anything(seed: int, radius: float,
                                                                  reach: float) -> None:
    rng = np.random.default_rng(seed)
    segments, discs = _random_world(rng, 15, 6)
    for _ in range(50):
        x0, y0 = rng.uniform(0.0, 10.0, 2)
        if clearance(x0, y0, segments, discs) > radius + 1e-3:
            break
    else:
        return
    heading = rng.uniform(-math.pi, math.pi)
    x1, y1 = x0 + reach * math.cos(heading), y0 + reach * math.sin(heading)
    u = sweep(x0, y0, x1, y1, radius, segments, discs)
    assert 0.0 <= u <= 1.0
    xe, ye = x0 + u * (x1 - x0), y0 + u * (y1 - y0)
    for seg in segments:
        assert not ref_intersect((x0, y0), (xe, ye), tuple(seg[:2]), tuple(seg[2:]))
        # The disc along the travelled part stays clear: sample it densely.
        for s in np.linspace(0.0, 1.0, 41):
            px, py = x0 + s * (xe - x0), y0 + s * (ye - y0)
            assert ref_point_segment(px, py, seg) >= radius
    for cx, cy, r in discs:
        for s in np.linspace(0.0, 1.0, 41):
            px, py = x0 + s * (xe - x0), y0 + s * (ye - y0)
            assert math.hypot(px - cx, py - cy) >= r + radius
    if u < 1.0:
        # Stopped by contact: the first thing along the way is within a hair beyond the gap.
        assert clearance(xe, ye, segments, discs) == pytest.approx(radius + GAP, abs=1e-9)


# Clearance, nearest point, polygons, visibility.

def test_clearance_and_nearest_point() -> None:
    segments = _segments((0.0, 0.0, 4.0, 0.0))
    discs = _discs((2.0, 3.0, 0.5))
    assert clearance(2.0, 1.0, segments, discs) == pytest.approx(1.0)
    assert clearance(2.0, 2.0, segments, discs) == pytest.approx(0.5)
    assert clearance(2.0, 3.2, segments, discs) == pytest.approx(-0.3)
    assert clearance(6.0, 0.0, segments, NO_DISCS) == pytest.approx(2.0)
    assert clearance(0.0, 0.0, NO_SEGMENTS, NO_DISCS) == math.inf
    d, qx, qy = nearest_point(2.0, 2.0, segments, discs)
    assert (d, qx, qy) == pytest.approx((0.5, 2.0, 2.5))
    d, qx, qy = nearest_point(5.0, 1.0, segments, discs)
    assert (d, qx, qy) == pytest.approx((math.sqrt(2.0), 4.0, 0.0))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_clearance_matches_an_independent_distance(seed: int) -> None:
    rng = np.random.default_rng(seed)
    segments, discs = _random_world(rng, 10, 5)
    for x, y in rng.uniform(0.0, 10.0, (20, 2)):
        expected = min([ref_point_segment(x, y, s) for s in segments]
                       + [math.hypot(x - cx, y - cy) - r for cx, cy, r in discs])
        assert clearance(x, y, segments, discs) == pytest.approx(expected, abs=1e-12)


def test_visible_through_gaps_and_blocked_by_walls() -> None:
    walls = _segments((2.0, -1.0, 2.0, 1.0))
    assert not visible(0.0, 0.0, 4.0, 0.0, walls)
    assert visible(0.0, 2.0, 4.0, 2.0, walls)
    assert not visible(0.0, 1.0, 4.0, 1.0, walls)  # grazing the end counts as blocked
    assert visible(0.0, 0.0, 1.9, 0.0, walls)
    assert visible(0.0, 0.0, 4.0, 0.0, NO_SEGMENTS)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_visible_agrees_with_an_independent_intersection_test(seed: int) -> None:
    rng = np.random.default_rng(seed)
    segments, _ = _random_world(rng, 12, 0)
    for x0, y0, x1, y1 in rng.uniform(0.0, 10.0, (30, 4)):
        expected = not any(ref_intersect((x0, y0), (x1, y1), tuple(s[:2]), tuple(s[2:]))
                           for s in segments)
        assert visible(x0, y0, x1, y1, segments) == expected


def test_landmark_view_checks_range_field_of_view_and_line_of_sight() -> None:
    landmarks = _discs((3.0, 0.0, 0.1), (0.0, 3.0, 0.1), (8.0, 0.0, 0.1), (3.0, -0.5, 0.1))
    wall = _segments((2.0, -1.0, 2.0, -0.2))
    seen, distance, bearing = landmark_view(0.0, 0.0, 0.0, landmarks, math.radians(60.0), 6.0,
                                            wall)
    assert seen.tolist() == [True, False, False, False]
    assert distance == pytest.approx([3.0, 3.0, 8.0, math.hypot(3.0, 0.5)])
    assert bearing == pytest.approx([0.0, math.pi / 2, 0.0, math.atan2(-0.5, 3.0)])


def test_wrap_keeps_angles_in_the_half_open_interval() -> None:
    cases = [(0.0, 0.0), (math.pi, math.pi), (-math.pi, math.pi), (3 * math.pi, math.pi),
             (2 * math.pi + 0.5, 0.5), (-4.0, 2 * math.pi - 4.0)]
    for angle, expected in cases:
        assert wrap(angle) == pytest.approx(expected)
