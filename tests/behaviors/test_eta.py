"""The goal manager's time estimate (:mod:`cbr_behaviors.eta`): the route fields against a
brute-force Dijkstra of our own over small random grids, and :class:`RouteEta`'s lengths and
running mean of the speed worked by hand."""

from __future__ import annotations

import heapq
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_behaviors.eta import DETOUR, PRIOR_WEIGHT, SLOWEST, RouteEta, route_fields

SQRT2 = math.sqrt(2.0)


def brute_force(blocked: np.ndarray, cell: float, source: tuple[int, int]) -> np.ndarray:
    """Shortest 8-connected path lengths from ``source`` (column, row) over the free cells of
    ``blocked`` (rows y, columns x), a diagonal step only when both cells beside it are free;
    steps cost ``cell`` and ``cell * sqrt(2)``; inf where no path leads."""
    rows, cols = blocked.shape
    out = np.full((rows, cols), math.inf)
    sx, sy = source
    out[sy, sx] = 0.0
    heap = [(0.0, sx, sy)]
    while heap:
        d, x, y = heapq.heappop(heap)
        if d > out[y, x]:
            continue
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                if dx == dy == 0:
                    continue
                nx, ny = x + dx, y + dy
                if not (0 <= nx < cols and 0 <= ny < rows) or blocked[ny, nx]:
                    continue
                if dx and dy and (blocked[y, nx] or blocked[ny, x]):
                    continue
                nd = d + (cell * SQRT2 if dx and dy else cell)
                if nd < out[ny, nx]:
                    out[ny, nx] = nd
                    heapq.heappush(heap, (nd, nx, ny))
    return out


def centre(x: int, y: int, cell: float, origin: tuple[float, float]) -> tuple[float, float]:
    return origin[0] + (x + 0.5) * cell, origin[1] + (y + 0.5) * cell


@st.composite
def grids(draw: st.DrawFn) -> tuple[np.ndarray, float, tuple[float, float], dict]:
    rows, cols = draw(st.integers(1, 8)), draw(st.integers(1, 8))
    density = draw(st.sampled_from([0.0, 0.2, 0.35, 0.5]))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    blocked = rng.random((rows, cols)) < density
    free = np.argwhere(~blocked)
    if not len(free):
        blocked[0, 0] = False
        free = np.argwhere(~blocked)
    cell = draw(st.sampled_from([0.2, 0.25, 1.0]))
    origin = (draw(st.floats(-5.0, 5.0)), draw(st.floats(-5.0, 5.0)))
    count = draw(st.integers(1, 3))
    picks = [free[int(k)] for k in rng.integers(len(free), size=count)]
    # each point somewhere inside a free cell (not merely its centre)
    points = {f"p{k}": (origin[0] + (int(x) + float(u)) * cell,
                        origin[1] + (int(y) + float(v)) * cell)
              for k, ((y, x), u, v) in enumerate(zip(picks, rng.uniform(0.05, 0.95, count),
                                                     rng.uniform(0.05, 0.95, count),
                                                     strict=True))}
    return blocked, cell, origin, points


@settings(max_examples=80, deadline=None)
@given(grids())
def test_route_fields_match_a_brute_force_dijkstra(case: tuple) -> None:
    blocked, cell, origin, points = case
    fields = route_fields(blocked, cell, origin, points)
    assert set(fields) == set(points)
    for name, (x, y) in points.items():
        cx = math.floor((x - origin[0]) / cell)
        cy = math.floor((y - origin[1]) / cell)
        expected = brute_force(blocked, cell, (cx, cy))
        field = fields[name]
        assert field.shape == blocked.shape
        assert np.array_equal(np.isinf(field), np.isinf(expected))
        finite = np.isfinite(expected)
        np.testing.assert_allclose(field[finite], expected[finite], rtol=1e-12, atol=1e-12)
        # a blocked cell is never reached
        assert np.isinf(field[blocked]).all()


def test_route_fields_worked_by_hand() -> None:
    # a 3 x 4 room with a wall cell in the middle:
    #   row 2  . . . .
    #   row 1  . # . .
    #   row 0  P . . .
    blocked = np.zeros((3, 4), dtype=bool)
    blocked[1, 1] = True
    field = route_fields(blocked, 0.5, (0.0, 0.0), {"p": (0.25, 0.25)})["p"]
    assert field[0, 0] == 0.0
    assert field[0, 3] == pytest.approx(1.5)
    # (2, 1): the diagonal from (1, 0) has the wall cell (1, 1) beside it, so along the bottom
    # to (2, 0) and up: 1.5
    assert field[1, 2] == pytest.approx(1.5)
    # (0, 2): up the left column, 1 m; no diagonal cuts past the wall cell
    assert field[2, 0] == pytest.approx(1.0)
    # (1, 2): (0, 1) -> (0, 2) -> (1, 2), since the diagonal (0, 1) -> (1, 2) passes the wall
    assert field[2, 1] == pytest.approx(1.5)
    # (3, 2): to (2, 0) in 1 m, then diagonal to (3, 1) and up: 1 + 0.5 sqrt 2 + 0.5
    assert field[2, 3] == pytest.approx(1.0 + 0.5 * SQRT2 + 0.5)
    assert math.isinf(field[1, 1])


def test_a_walled_off_region_is_unreachable() -> None:
    blocked = np.zeros((4, 5), dtype=bool)
    blocked[:, 2] = True
    field = route_fields(blocked, 1.0, (0.0, 0.0), {"west": (0.5, 0.5)})["west"]
    assert np.isfinite(field[:, :2]).all()
    assert np.isinf(field[:, 2:]).all()
    # a diagonal gap (two wall cells touching at a corner) does not let a path through
    corner = np.array([[False, True], [True, False]])
    field = route_fields(corner, 1.0, (0.0, 0.0), {"a": (0.5, 0.5)})["a"]
    assert field[0, 0] == 0.0 and math.isinf(field[1, 1])


def test_a_point_on_a_blocked_cell_starts_from_the_nearest_free_one() -> None:
    # a row of five cells, the first three blocked
    blocked = np.array([[True, True, True, False, False]])
    # the point lies in cell 1 (blocked); the nearest free cell centre is cell 3's
    field = route_fields(blocked, 1.0, (10.0, 20.0), {"p": (11.5, 20.5)})["p"]
    assert field[0, 3] == 0.0 and field[0, 4] == pytest.approx(1.0)
    assert np.isinf(field[0, :3]).all()
    # a point off the grid altogether snaps to the nearest free cell as well
    field = route_fields(blocked, 1.0, (10.0, 20.0), {"p": (30.0, 20.5)})["p"]
    assert field[0, 4] == 0.0 and field[0, 3] == pytest.approx(1.0)


# --- RouteEta ------------------------------------------------------------------------------------

ROOM = np.zeros((3, 4), dtype=bool)
ROOM[1, 1] = True
CELL = 0.5
ORIGIN = (0.0, 0.0)
PLACES = {"p": (0.25, 0.25), "q": (1.75, 1.25)}


def eta(speed: float = 0.4) -> RouteEta:
    fields = route_fields(ROOM, CELL, ORIGIN, PLACES)
    return RouteEta(fields, PLACES, CELL, ORIGIN, speed)


def test_the_length_from_a_place_is_its_field_either_way_round() -> None:
    estimate = eta()
    # from p to the point (1.6, 1.1), in the cell (3, 2): 1 + 0.5 sqrt 2 + 0.5 (see the hand
    # worked field above), longer than the straight line's 1.79
    other = (1.6, 1.1)
    expected = 1.0 + 0.5 * SQRT2 + 0.5
    assert math.dist(PLACES["p"], other) < expected
    assert estimate.length(PLACES["p"], other) == pytest.approx(expected)
    assert estimate.length(other, PLACES["p"]) == pytest.approx(expected)
    # between two places: the field of either
    assert estimate.length(PLACES["p"], PLACES["q"]) == pytest.approx(
        estimate.length(PLACES["q"], PLACES["p"]))


def test_the_length_is_never_below_the_straight_line() -> None:
    estimate = eta()
    # a point in the place's own cell: the field reads 0, the straight line is the length
    near = (0.45, 0.45)
    assert estimate.length(PLACES["p"], near) == pytest.approx(math.dist(PLACES["p"], near))
    # a point a cell over, at its far corner: the field reads 0.5, the line 0.71
    corner = (0.99, 0.49)
    assert estimate.length(corner, PLACES["p"]) == pytest.approx(math.dist(PLACES["p"], corner))


def test_without_a_place_or_a_field_the_length_is_a_detour_of_the_straight_line() -> None:
    estimate = eta()
    assert DETOUR == 1.4
    a, b = (0.3, 0.4), (1.9, 1.3)
    assert estimate.length(a, b) == pytest.approx(1.4 * math.dist(a, b))
    # a place, but the other point outside the field's grid
    outside = (5.0, 4.0)
    assert estimate.length(PLACES["p"], outside) == pytest.approx(
        1.4 * math.dist(PLACES["p"], outside))
    assert estimate.length((-1.0, 0.2), PLACES["p"]) == pytest.approx(
        1.4 * math.dist(PLACES["p"], (-1.0, 0.2)))
    # a place, but the other point on a cell no path reaches (the wall cell)
    wall = (0.75, 0.75)
    assert estimate.length(PLACES["p"], wall) == pytest.approx(1.4 * math.dist(PLACES["p"], wall))


@settings(max_examples=60, deadline=None)
@given(ax=st.floats(-1.0, 3.0), ay=st.floats(-1.0, 2.0), place=st.sampled_from(["p", "q", None]),
       forward=st.booleans())
def test_every_length_is_at_least_the_straight_line(ax: float, ay: float, place: str | None,
                                                    forward: bool) -> None:
    estimate = eta()
    b = PLACES[place] if place else (1.1, 0.3)
    a = (ax, ay)
    if a in PLACES.values():
        return
    pair = (a, b) if forward else (b, a)
    assert estimate.length(*pair) >= math.dist(a, b) - 1e-12
    if place is None:
        assert estimate.length(*pair) == pytest.approx(DETOUR * math.dist(a, b))


def test_the_speed_is_a_running_mean_with_the_prior_counting_a_minute() -> None:
    assert PRIOR_WEIGHT == 60.0 and SLOWEST == 0.1
    estimate = eta(0.4)
    assert estimate.speed == pytest.approx(0.4)
    # 30 m in 60 s: (0.4 * 60 + 30) / (60 + 60) = 54 / 120
    estimate.observe(30.0, 60.0)
    assert estimate.speed == pytest.approx(0.45)
    # another 12 m in 120 s: (24 + 42) / 240
    estimate.observe(12.0, 120.0)
    assert estimate.speed == pytest.approx(66.0 / 240.0)


def test_the_speed_never_falls_below_the_slowest() -> None:
    estimate = eta(0.4)
    # waiting ten minutes: 24 / 660 = 0.036 m/s, floored at 0.1
    estimate.observe(0.0, 600.0)
    assert estimate.speed == SLOWEST
    # a prior below the floor is floored as well
    assert eta(0.05).speed == SLOWEST


def test_the_estimate_is_the_length_over_the_speed() -> None:
    estimate = eta(0.4)
    a, b = (0.3, 0.4), (1.9, 1.3)
    assert estimate(a, b) == pytest.approx(1.4 * math.dist(a, b) / 0.4)
    estimate.observe(30.0, 60.0)
    other = (1.6, 1.1)
    assert estimate(PLACES["p"], other) == pytest.approx((1.5 + 0.5 * SQRT2) / 0.45)


@given(st.floats(0.01, 2.0), st.lists(st.tuples(st.floats(0.0, 100.0), st.floats(0.1, 300.0)),
                                      max_size=6))
def test_the_speed_is_the_pooled_mean_at_least_the_slowest(prior: float,
                                                            drives: list[tuple[float,
                                                                               float]]) -> None:
    estimate = eta(prior)
    for distance, seconds in drives:
        estimate.observe(distance, seconds)
    metres = prior * 60.0 + sum(d for d, _ in drives)
    seconds = 60.0 + sum(s for _, s in drives)
    assert estimate.speed == pytest.approx(max(0.1, metres / seconds))
