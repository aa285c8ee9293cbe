"""Inflation by a robot's radius, by Nav2's inflation layer: hand-worked costs and brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_grid.frame import MapFrame
from cbr_grid.grid import Grid
from cbr_grid.inflation import INSCRIBED, LETHAL, Inflation, costs, inflate, obstacle_distance

# One obstacle in the middle of a 9 x 9 grid of 0.1 m cells; the robot's inscribed radius is
# 0.15 m, the cost reaches 0.35 m and decays with factor 3 per metre. Nav2's cost at distance d
# (metres, centre to centre) beyond the radius is int(252 exp(-3 (d - 0.15))):
#   d = 0.2 (2, 0):          252 exp(-0.15)      = 216.90 -> 216
#   d = 0.2236 (2, 1):       252 exp(-0.220820)  = 202.07 -> 202
#   d = 0.2828 (2, 2):       252 exp(-0.398528)  = 169.17 -> 169
#   d = 0.3 (3, 0):          252 exp(-0.45)      = 160.68 -> 160
#   d = 0.3162 (3, 1):       252 exp(-0.498683)  = 153.05 -> 153
#   d = 0.3606 (3, 2), 0.4 (4, 0): beyond 0.35 m -> 0
# and 253 within 0.15 m: (1, 0) at 0.1 and (1, 1) at 0.1414; 254 on the obstacle.
HAND = {(0, 0): LETHAL, (1, 0): INSCRIBED, (1, 1): INSCRIBED, (2, 0): 216, (2, 1): 202,
        (2, 2): 169, (3, 0): 160, (3, 1): 153, (3, 2): 0, (4, 0): 0}
NAV2 = Inflation(robot_radius=0.15, inflation_radius=0.35, cost_scaling_factor=3.0)


def single_obstacle(frame: MapFrame | None) -> Grid:
    risk = np.zeros((9, 9))
    risk[4, 4] = 1.0
    return Grid(risk, frame=frame)


def test_nav2_costs_around_one_obstacle_by_hand() -> None:
    cost = costs(single_obstacle(MapFrame(0.1, -3.0, 7.0)), NAV2)
    assert cost.dtype == np.uint8
    for (dx, dy), expected in HAND.items():
        # every symmetric copy of the offset costs the same
        for sx in (-1, 1):
            for sy in (-1, 1):
                for x, y in ((dx * sx, dy * sy), (dy * sy, dx * sx)):
                    assert cost[4 + y, 4 + x] == expected, (x, y)


def test_the_grid_gets_risk_one_within_the_radius_and_cost_over_254_beyond() -> None:
    frame = MapFrame(0.1)
    risk = single_obstacle(frame).risk.copy()
    risk[4, 8] = 0.7  # 0.4 m away, beyond the reach
    risk[4, 7] = 0.9  # 0.3 m away, above the inflation's 160 / 254
    # an unknown mask that misses the obstacle (4, 4)
    grid = Grid(risk, frame=frame, unknown=np.fliplr(np.eye(9, dtype=bool)) & (risk == 0))
    inflated = inflate(grid, NAV2)
    assert inflated.frame == frame
    np.testing.assert_array_equal(inflated.unknown, grid.unknown)
    assert inflated.risk[4, 5] == 1 and inflated.risk[5, 5] == 1  # inscribed
    assert inflated.risk[4, 6] == pytest.approx(216 / 254)
    assert inflated.risk[5, 7] == pytest.approx(153 / 254)
    # the map's own risk stays where it is higher than the inflation's
    assert inflated.risk[4, 8] == 0.7
    assert inflated.risk[4, 7] == 0.9
    assert inflated.risk[0, 0] == 0


def test_unknown_cells_are_not_inflated_even_as_obstacles() -> None:
    # Nav2's inflation layer inflates lethal cells, not unknown ones (inflate_unknown false):
    # a 9 x 9 grid whose left column is unknown and lethal, and one known obstacle at (6, 4)
    risk = np.zeros((9, 9))
    risk[:, 0] = 1.0
    risk[4, 6] = 1.0
    unknown = np.zeros((9, 9), dtype=bool)
    unknown[:, 0] = True
    frame = MapFrame(0.1)
    cost = costs(Grid(risk, frame=frame, unknown=unknown), NAV2)
    # only the known obstacle is inflated: the same costs as a map without the unknown column
    known = np.zeros((9, 9))
    known[4, 6] = 1.0
    np.testing.assert_array_equal(cost, costs(Grid(known, frame=frame), NAV2))
    assert cost[0, 1] == 0 and cost[4, 1] == 0 and cost[4, 0] == 0
    # the unknown cells keep their own risk: obstacles still, since the map made them so
    inflated = inflate(Grid(risk, frame=frame, unknown=unknown), NAV2)
    assert (inflated.risk[:, 0] == 1).all() and inflated.risk[0, 1] == 0
    # with no known obstacle nothing is inflated
    assert not costs(Grid(risk * unknown, frame=frame, unknown=unknown), NAV2).any()


def test_radii_are_cells_without_a_frame() -> None:
    # the same numbers with 1-cell units: radius 1.5, reach 3.5, factor 0.3 per cell
    cost = costs(single_obstacle(None), Inflation(1.5, 3.5, 0.3))
    assert cost[4, 6] == 216 and cost[4, 7] == 160 and cost[4, 8] == 0
    assert cost[5, 5] == INSCRIBED


def test_no_obstacles_and_no_decay() -> None:
    empty = Grid(np.zeros((3, 3)), frame=MapFrame(0.1))
    assert (costs(empty, NAV2) == 0).all()
    assert np.isinf(obstacle_distance(empty)).all()
    # without an inflation radius only the inscribed cells change
    cost = costs(single_obstacle(MapFrame(0.1)), Inflation(0.15))
    assert set(np.unique(cost)) == {0, INSCRIBED, LETHAL}
    # a radius of a whole number of cells reaches the cells that far (3 x 0.1 is not 0.3)
    assert costs(single_obstacle(MapFrame(0.1)), Inflation(0.3))[4, 7] == INSCRIBED


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"robot_radius": -0.1}, "'robot_radius' must be a finite number >= 0"),
    ({"robot_radius": math.inf}, "'robot_radius' must be a finite number >= 0"),
    ({"robot_radius": 0.3, "inflation_radius": 0.2}, "'inflation_radius' must be at least"),
    ({"robot_radius": 0.1, "cost_scaling_factor": -1.0}, "'cost_scaling_factor' must be"),
])
def test_bad_inflation(kwargs: dict[str, float], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        Inflation(**kwargs)


@settings(max_examples=60, deadline=None)
@given(data=st.data(), width=st.integers(1, 9), height=st.integers(1, 9),
       resolution=st.sampled_from([None, 0.05, 0.1, 0.3]),
       radius=st.floats(0, 3), extra=st.floats(0, 3), factor=st.floats(0, 5))
def test_costs_match_a_brute_force_distance(data: st.DataObject, width: int, height: int,
                                            resolution: float | None, radius: float,
                                            extra: float, factor: float) -> None:
    blocked = np.array(data.draw(st.lists(st.booleans(), min_size=width * height,
                                          max_size=width * height))).reshape(height, width)
    frame = None if resolution is None else MapFrame(resolution)
    unit = 1.0 if resolution is None else resolution
    inflation = Inflation(radius * unit, (radius + extra) * unit, factor / unit)
    grid = Grid(blocked.astype(float), frame=frame)
    cost = costs(grid, inflation)
    obstacles = np.argwhere(blocked)
    for y in range(height):
        for x in range(width):
            if not len(obstacles):
                assert cost[y, x] == 0
                continue
            d = min(math.hypot(x - ox, y - oy) for oy, ox in obstacles) * unit
            slack = 1e-9 * unit
            if d == 0:
                expected = LETHAL
            elif d <= inflation.robot_radius + slack:
                expected = INSCRIBED
            elif d <= inflation.reach + slack:
                expected = int((INSCRIBED - 1) * math.exp(-inflation.cost_scaling_factor
                                                          * (d - inflation.robot_radius)))
            else:
                expected = 0
            # the brute force multiplies its own rounding: allow one unit where the product
            # sits on an integer
            assert abs(int(cost[y, x]) - expected) <= (0 if expected in (0, INSCRIBED,
                                                                         LETHAL) else 1), (x, y)
    risk = inflate(grid, inflation).risk
    np.testing.assert_array_equal(risk >= 1, (cost >= INSCRIBED) | blocked)
