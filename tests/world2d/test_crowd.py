"""People who yield to the robot: the crowd's clocks against hand-worked walks."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_world2d.crowd import PATIENCE, YIELD_GAP, Crowd
from cbr_world2d.world import Mover, World

DT = 0.1
ROBOT = 0.25


def corridor(*movers: Mover) -> World:
    return World((-10.0, -3.0, 10.0, 3.0), movers=movers)


def walk(crowd: Crowd, seconds: float, robot: tuple[float, float]) -> None:
    for _ in range(round(seconds / DT)):
        crowd.advance(round(crowd.t / DT + 1) * DT, robot, ROBOT)


def walker(yields: bool) -> Mover:
    # from x = -5 toward the robot at the origin at 1 m/s, back after x = 5
    return Mover(((-5.0, 0.0), (5.0, 0.0)), 1.0, 0.25, "person", yields=yields)


def test_a_yielding_person_stops_short_of_the_robot() -> None:
    crowd = Crowd(corridor(walker(True)))
    walk(crowd, 6.0, (0.0, 0.0))
    # it would be at x = 1 after 6 s; it stops where one more step would come within the gap
    x, y = crowd.now[0]
    room = ROBOT + 0.25 + YIELD_GAP
    assert y == 0.0
    assert -room - 1.0 * DT - 1e-9 <= x <= -room + 1e-9
    assert crowd.clocks[0] == pytest.approx(5.0 + x)


def test_a_person_who_does_not_yield_walks_through() -> None:
    crowd = Crowd(corridor(walker(False)))
    walk(crowd, 5.0, (0.0, 0.0))
    assert crowd.now[0] == pytest.approx((0.0, 0.0))
    assert crowd.clocks[0] == pytest.approx(5.0)


def test_a_yielding_person_walks_on_after_its_patience() -> None:
    crowd = Crowd(corridor(walker(True)))
    walk(crowd, 4.0 + PATIENCE + 1.0, (0.0, 0.0))
    # it waited PATIENCE seconds (to a step) and then walked on regardless
    waited = 4.0 + PATIENCE + 1.0 - crowd.clocks[0]
    assert PATIENCE - DT - 1e-9 <= waited <= PATIENCE + 2 * DT
    assert crowd.now[0][0] > -ROBOT - 0.25 - YIELD_GAP + 0.5


def test_a_person_walking_away_is_not_held() -> None:
    # the robot stands just behind the walker's start: the person walks off at once
    crowd = Crowd(corridor(walker(True)))
    walk(crowd, 2.0, (-5.5, 0.0))
    assert crowd.clocks[0] == pytest.approx(2.0)


def test_the_way_clear_again_the_person_walks_on() -> None:
    crowd = Crowd(corridor(walker(True)))
    walk(crowd, 3.0, (0.0, 0.0))
    held = crowd.clocks[0]
    walk(crowd, 1.0, (0.0, 2.5))  # the robot steps aside
    assert crowd.clocks[0] == pytest.approx(held + 1.0)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.tuples(st.floats(-8, 8), st.floats(-2.5, 2.5)), min_size=1, max_size=30),
       st.floats(0.3, 1.5))
def test_without_yielding_movers_the_crowd_is_the_world_at_its_time(
        robot: list[tuple[float, float]], speed: float) -> None:
    world = corridor(Mover(((-8.0, -1.0), (8.0, 1.0), (0.0, 2.0)), speed, 0.3, "person"),
                     Mover(((2.0, 0.5),), 0.0, 0.2, "object", appears=0.5, leaves=2.0))
    crowd = Crowd(world)
    for k, where in enumerate(robot, start=1):
        t = k * DT
        crowd.advance(t, where, ROBOT)
        assert np.array_equal(crowd.discs(), world.discs_at(t))


def test_a_crowd_at_a_time_is_where_the_loops_put_it() -> None:
    world = corridor(walker(True))
    crowd = Crowd(world, 2.0, DT)
    assert crowd.now[0] == pytest.approx((-3.0, 0.0))
    assert crowd.before[0] == pytest.approx((-3.1, 0.0))
    assert math.isclose(crowd.clocks[0], 2.0)
