"""The situation features of :mod:`cbr_behaviors.situation`, worked by hand: sonar sectors and the
free width from hand-made rings, the person tracker and the doorway ahead in small hand-built
worlds, and the progress along the route."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_behaviors.index import SONAR_MAX
from cbr_behaviors.situation import (
    DOOR_REACH,
    FRONT_ARC,
    PERSON_REACH,
    REAR_ARC,
    SIDE_ARC,
    door_ahead,
    free_width,
    people_in_view,
    progress,
    sectors,
)
from cbr_world2d.crowd import Crowd
from cbr_world2d.robot import Pose
from cbr_world2d.world import Door, Mover, Wall, World
from cbr_world2d.worldfile import world_from_data

DT = 0.1
RADIUS = 0.25
"""The people's radius in these worlds."""


def deg(*values: float) -> np.ndarray:
    return np.radians(np.asarray(values, dtype=float))


# --- sonar sectors -------------------------------------------------------------------------------


def test_the_arcs_are_the_documented_angles() -> None:
    assert math.isclose(FRONT_ARC, math.radians(15.0))
    assert math.isclose(REAR_ARC, math.radians(150.0))
    assert SONAR_MAX == 5.0


def test_each_sector_reads_its_nearest_beam() -> None:
    #            front...........  left..............  rear..............  right...........
    angles = deg(0, 14, -14, 16, 90, 149, 151, 180, -170, -16, -90, -149)
    ranges = [4.0, 2.5, 3.0, 4.5, 1.2, 2.0, 3.3, 0.8, 2.9, 1.7, 0.9, 4.0]
    front, left, right, rear = sectors(ranges, angles)
    assert front == pytest.approx(2.5)   # 14 degrees is within 15
    assert left == pytest.approx(1.2)    # 16 to 149 degrees, counter-clockwise
    assert right == pytest.approx(0.9)   # -16 to -149 degrees
    assert rear == pytest.approx(0.8)    # beyond 150 degrees either way


def test_sectors_cap_at_the_sonar_range_and_read_it_with_no_beam() -> None:
    # far readings (and no echo at all) are capped at 5 m
    front, left, right, rear = sectors([7.0, math.inf, 12.0, 5.5], deg(0, 90, -90, 180))
    assert (front, left, right, rear) == (SONAR_MAX, SONAR_MAX, SONAR_MAX, SONAR_MAX)
    # only a front beam: the other three sectors have none and read the maximum
    assert sectors([1.0], deg(5)) == (1.0, SONAR_MAX, SONAR_MAX, SONAR_MAX)
    # only a rear beam
    assert sectors([0.4], deg(-179)) == (SONAR_MAX, SONAR_MAX, SONAR_MAX, 0.4)
    assert sectors([], []) == (SONAR_MAX,) * 4


def test_sector_angles_wrap_round_the_circle() -> None:
    # 370 degrees is 10 degrees (front), -270 is 90 (left), 270 is -90 (right), 540 is 180
    front, left, right, rear = sectors([1.0, 2.0, 3.0, 4.0], deg(370, -270, 270, 540))
    assert (front, left, right, rear) == pytest.approx((1.0, 2.0, 3.0, 4.0))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0.0, 20.0), st.floats(-10.0, 10.0)), max_size=20))
def test_sectors_are_the_minima_of_a_brute_force_partition(beams: list[tuple[float,
                                                                              float]]) -> None:
    ranges = [r for r, _ in beams]
    angles = [a for _, a in beams]
    expected = {"front": SONAR_MAX, "left": SONAR_MAX, "right": SONAR_MAX, "rear": SONAR_MAX}
    for r, a in beams:
        # the angle off the heading in degrees, left positive, by atan2 (independent of the
        # module's modulo arithmetic); beams within a hair of an arc's edge are skipped
        off = math.degrees(math.atan2(math.sin(a), math.cos(a)))
        if min(abs(abs(off) - 15.0), abs(abs(off) - 150.0), abs(abs(off) - 180.0)) < 1e-6:
            return
        if abs(off) <= 15.0:
            name = "front"
        elif abs(off) > 150.0:
            name = "rear"
        else:
            name = "left" if off > 0 else "right"
        expected[name] = min(expected[name], min(r, SONAR_MAX))
    assert sectors(ranges, angles) == pytest.approx(
        (expected["front"], expected["left"], expected["right"], expected["rear"]))


def test_free_width_adds_the_nearest_side_readings_and_the_diameter() -> None:
    assert math.isclose(SIDE_ARC, math.radians(20.0))
    # left: 90 degrees reads 2.0, 75 (15 off) 1.5, 65 (25 off: not a side beam) 0.5;
    # right: -90 reads 3.0, -100 (10 off) 6.0, capped to 5
    angles = deg(90, 75, 65, -90, -100, 0, 180)
    ranges = [2.0, 1.5, 0.5, 3.0, 6.0, 0.1, 0.1]
    assert free_width(ranges, angles, 0.5) == pytest.approx(1.5 + 3.0 + 0.5)
    # a hallway 2 m wide, the robot 0.5 m across in its middle: 0.75 m each side
    assert free_width([0.75, 0.75], deg(90, -90), 0.5) == pytest.approx(2.0)
    # no side beam: each side reads the maximum
    assert free_width([1.0, 1.0], deg(0, 180), 0.4) == pytest.approx(2 * SONAR_MAX + 0.4)
    # far readings are capped
    assert free_width([9.0, 9.0], deg(90, -90), 0.5) == pytest.approx(2 * SONAR_MAX + 0.5)


# --- the person tracker --------------------------------------------------------------------------


def person(*waypoints: tuple[float, float], speed: float = 0.0, kind: str = "person",
           appears: float = 0.0) -> Mover:
    return Mover(tuple(waypoints), speed, RADIUS, kind, appears)


def open_world(*movers: Mover, walls: tuple[Wall, ...] = (),
               doors: tuple[Door, ...] = ()) -> World:
    return World(bounds=(-10.0, -10.0, 10.0, 10.0), walls=walls, doors=doors, movers=movers)


def test_a_person_in_the_open_is_reported_with_distance_to_the_rim_and_bearing() -> None:
    world = open_world(person((3.0, 4.0)))
    here = Pose(0.0, 0.0, 0.0)
    [seen] = people_in_view(Crowd(world, 10.0, DT), here, here, DT, 0.0)
    # the centre lies 5 m away, the rim 5 - 0.25; the bearing is atan2(4, 3) to the left
    assert seen.distance == pytest.approx(5.0 - RADIUS)
    assert seen.bearing == pytest.approx(math.atan2(4.0, 3.0))
    assert seen.closing == pytest.approx(0.0)
    assert (seen.x, seen.y) == pytest.approx((3.0, 4.0))
    # facing +y, the same person lies to the right
    facing = Pose(0.0, 0.0, math.pi / 2)
    [seen] = people_in_view(Crowd(world, 10.0, DT), facing, facing, DT, 0.0)
    assert seen.bearing == pytest.approx(math.atan2(4.0, 3.0) - math.pi / 2)
    # facing -x, the bearing wraps into (-pi, pi]: 180 - 53.13 degrees to the right
    back = Pose(0.0, 0.0, math.pi)
    [seen] = people_in_view(Crowd(world, 10.0, DT), back, back, DT, 0.0)
    assert seen.bearing == pytest.approx(math.atan2(4.0, 3.0) - math.pi)


def test_a_person_walking_straight_at_a_standing_robot_closes_at_their_speed() -> None:
    # from (4, 0) toward the robot at the origin at 1.1 m/s (the loop turns back at (1, 0))
    walker = person((4.0, 0.0), (1.0, 0.0), speed=1.1)
    here = Pose(0.0, 0.0, math.radians(30.0))
    [seen] = people_in_view(Crowd(open_world(walker), 1.0, DT), here, here, DT, 0.0)
    # at t = 1 the walker is at (2.9, 0)
    assert seen.distance == pytest.approx(2.9 - RADIUS)
    assert seen.closing == pytest.approx(1.1)
    assert seen.bearing == pytest.approx(math.radians(-30.0))
    # walking away (on the way back after the turn at (1, 0), t = 3/1.1 + 1): parting
    later = 3.0 / 1.1 + 1.0
    [seen] = people_in_view(Crowd(open_world(walker), later, DT), here, here, DT, 0.0)
    assert seen.closing == pytest.approx(-1.1)


def test_a_robot_driving_at_a_standing_person_closes_at_its_speed() -> None:
    world = open_world(person((3.0, 0.0)))
    ahead = Pose(0.0, 0.0, 0.0)
    [seen] = people_in_view(Crowd(world, 5.0, DT), ahead, ahead, DT, 0.4)
    assert seen.closing == pytest.approx(0.4)
    # heading 60 degrees off the line to the person: half the speed along it
    slanted = Pose(0.0, 0.0, math.radians(60.0))
    [seen] = people_in_view(Crowd(world, 5.0, DT), slanted, slanted, DT, 0.4)
    assert seen.closing == pytest.approx(0.2)
    # across the line: no closing; backing away from them: parting
    across = Pose(0.0, 0.0, math.pi / 2)
    crowd = Crowd(world, 5.0, DT)
    assert people_in_view(crowd, across, across, DT, 0.4)[0].closing == pytest.approx(0.0)
    assert people_in_view(crowd, ahead, ahead, DT, -0.3)[0].closing == pytest.approx(-0.3)


def test_both_moving_close_at_the_sum_of_their_speeds_along_the_line() -> None:
    # the walker comes down the x axis at 0.8 m/s, the robot drives up it at 0.4 m/s
    walker = person((6.0, 0.0), (-6.0, 0.0), speed=0.8)
    here = Pose(0.0, 0.0, 0.0)
    [seen] = people_in_view(Crowd(open_world(walker), 2.0, DT), here, here, DT, 0.4)
    assert seen.closing == pytest.approx(1.2)
    assert seen.distance == pytest.approx(6.0 - 1.6 - RADIUS)


def test_a_person_behind_a_wall_or_a_shut_door_is_not_reported() -> None:
    hidden = person((3.0, 0.0))
    wall = Wall((1.5, -2.0), (1.5, 2.0))
    here = Pose(0.0, 0.0, 0.0)
    hides = Crowd(open_world(hidden, walls=(wall,)), 0.0, DT)
    assert people_in_view(hides, here, here, DT, 0.0) == []
    # a wall off to the side hides nothing
    aside = Wall((1.5, 1.0), (1.5, 3.0))
    beside = Crowd(open_world(hidden, walls=(aside,)), 0.0, DT)
    assert len(people_in_view(beside, here, here, DT, 0.0)) == 1
    # a door across the line of sight: open for t in [0, 5) of every 10 s, shut after
    door = Door((1.5, -1.0), (1.5, 1.0), period=10.0, open_for=5.0, phase=0.0)
    world = open_world(hidden, doors=(door,))
    assert len(people_in_view(Crowd(world, 2.0, DT), here, here, DT, 0.0)) == 1
    assert people_in_view(Crowd(world, 7.0, DT), here, here, DT, 0.0) == []


def test_the_tracker_reaches_as_far_as_its_reach_to_the_rim() -> None:
    assert PERSON_REACH == 5.0
    here = Pose(0.0, 0.0, 0.0)
    # rim at 4.95 m: reported; rim at 5.05 m: not
    near, far = person((5.2, 0.0)), person((0.0, -5.3))
    seen = people_in_view(Crowd(open_world(near, far), 0.0, DT), here, here, DT, 0.0)
    assert [round(p.distance, 6) for p in seen] == [4.95]
    # a shorter reach of the caller's
    assert people_in_view(Crowd(open_world(near), 0.0, DT), here, here, DT, 0.0, reach=4.0) == []


def test_objects_and_people_not_yet_there_are_not_reported() -> None:
    here = Pose(0.0, 0.0, 0.0)
    cart = person((2.0, 0.0), kind="object")
    assert people_in_view(Crowd(open_world(cart), 0.0, DT), here, here, DT, 0.0) == []
    late = person((2.0, 1.0), appears=30.0)
    assert people_in_view(Crowd(open_world(late), 10.0, DT), here, here, DT, 0.0) == []
    assert len(people_in_view(Crowd(open_world(late), 30.0, DT), here, here, DT, 0.0)) == 1


def test_people_are_reported_nearest_first() -> None:
    here = Pose(0.0, 0.0, 0.0)
    world = open_world(person((4.0, 0.0)), person((0.0, 2.0)), person((-3.0, 0.0)))
    seen = people_in_view(Crowd(world, 0.0, DT), here, here, DT, 0.0)
    assert [round(p.distance, 6) for p in seen] == [1.75, 2.75, 3.75]


def test_positions_are_reported_in_the_believed_frame() -> None:
    # truly at the origin facing +x, a person 3 m dead ahead at (3, 0); the robot believes it
    # stands at (1, 2) facing +y: it puts the person 3 m ahead of that, at (1, 5)
    world = open_world(person((3.0, 0.0)))
    true, believed = Pose(0.0, 0.0, 0.0), Pose(1.0, 2.0, math.pi / 2)
    [seen] = people_in_view(Crowd(world, 0.0, DT), true, believed, DT, 0.0)
    assert (seen.x, seen.y) == pytest.approx((1.0, 5.0))
    # distance and bearing are measured from the true pose, whatever the belief
    assert seen.distance == pytest.approx(3.0 - RADIUS)
    assert seen.bearing == pytest.approx(0.0)
    # a person 2 m to the true left (bearing +90 degrees): to the believed pose's left
    world = open_world(person((0.0, 2.0)))
    [seen] = people_in_view(Crowd(world, 0.0, DT), true, believed, DT, 0.0)
    assert (seen.x, seen.y) == pytest.approx((1.0 - 2.0, 2.0))


@settings(max_examples=40, deadline=None)
@given(px=st.floats(-3.5, 3.5), py=st.floats(-3.5, 3.5), theta=st.floats(-math.pi, math.pi),
       bx=st.floats(-5.0, 5.0), by=st.floats(-5.0, 5.0), btheta=st.floats(-math.pi, math.pi))
def test_believed_positions_keep_distance_and_bearing(px: float, py: float, theta: float,
                                                      bx: float, by: float,
                                                      btheta: float) -> None:
    if math.hypot(px, py) < 0.3:
        return
    world = open_world(person((px, py)))
    true, believed = Pose(0.0, 0.0, theta), Pose(bx, by, btheta)
    [seen] = people_in_view(Crowd(world, 0.0, DT), true, believed, DT, 0.0)
    # the reported point lies the centre distance from the believed pose, at the bearing off
    # the believed heading
    assert math.hypot(seen.x - bx, seen.y - by) == pytest.approx(math.hypot(px, py))
    direction = math.atan2(seen.y - by, seen.x - bx) - btheta
    assert math.cos(direction - seen.bearing) == pytest.approx(1.0)
    # with the belief equal to the truth, the true position
    [same] = people_in_view(Crowd(world, 0.0, DT), true, true, DT, 0.0)
    assert (same.x, same.y) == pytest.approx((px, py), abs=1e-9)


def test_a_world_read_from_a_file_reports_its_people() -> None:
    world = world_from_data({"bounds": [0, 0, 10, 6], "walls": [{"a": [5, 0], "b": [5, 4]}],
                             "people": [{"waypoints": [[7, 2]], "speed": 0, "radius": 0.25},
                                        {"waypoints": [[7, 5]], "speed": 0, "radius": 0.25}],
                             "movers": [{"waypoints": [[2, 3]], "speed": 0, "radius": 0.3,
                                         "kind": "object"}]}, "test")
    here = Pose(3.0, 2.0, 0.0)
    # from (3, 2) the line to (7, 2) meets the wall (x = 5, y up to 4) at y = 2 and the line to
    # (7, 5) at y = 3.5: both hidden; the object at (2, 3) is no person
    assert people_in_view(Crowd(world, 0.0, DT), here, here, DT, 0.0) == []
    # from (3, 4.5) the line to (7, 5) passes x = 5 at y = 4.75, over the wall's end; the one
    # to (7, 2) at y = 3.25, still hidden
    high = Pose(3.0, 4.5, 0.0)
    [p] = people_in_view(Crowd(world, 0.0, DT), high, high, DT, 0.0)
    assert p.distance == pytest.approx(math.hypot(4.0, 0.5) - 0.25)


# --- the doorway ahead ---------------------------------------------------------------------------

DOOR = Door((5.0, 2.5), (5.0, 3.5), period=10.0, open_for=4.0, phase=0.0, name="d")
"""Open for t in [0, 4) of every 10 s, shut for [4, 10)."""
DOORWAY = World(bounds=(0.0, 0.0, 12.0, 6.0),
                walls=(Wall((5.0, 0.0), (5.0, 2.5)), Wall((5.0, 3.5), (5.0, 6.0))),
                doors=(DOOR,))
"""A 12 x 6 m floor split by a wall at x = 5 with a 1 m doorway centred on (5, 3)."""


@pytest.mark.parametrize("t", [0.0, 1.5, 3.9, 4.0, 6.0, 9.9, 10.0, 15.0, 23.7])
def test_a_route_through_the_doorway_reads_its_distance_and_whether_it_is_shut(t: float) -> None:
    found = door_ahead(DOORWAY, (2.0, 3.0), [(4.0, 3.0), (6.0, 3.0), (8.0, 3.0)], t)
    assert found is not None
    distance, shut = found
    assert distance == pytest.approx(3.0)
    assert shut == (not DOOR.is_open(t))
    assert shut == ((t % 10.0) >= 4.0)


def test_a_waypoint_at_the_doorway_centre_counts() -> None:
    # the leg ends on the door's line, which is no proper crossing; the waypoint is its centre
    assert door_ahead(DOORWAY, (3.0, 2.0), [(5.0, 3.0), (7.0, 3.0)], 5.0) == pytest.approx(
        (math.hypot(2.0, 1.0), True))
    # a slanted leg crossing the doorway off its centre
    found = door_ahead(DOORWAY, (4.0, 2.0), [(6.0, 4.0)], 1.0)
    assert found == pytest.approx((math.hypot(1.0, 1.0), False))


def test_no_door_ahead_when_the_route_crosses_none_within_reach() -> None:
    assert DOOR_REACH == 5.0
    # a route that stays on the west side
    assert door_ahead(DOORWAY, (1.0, 1.0), [(4.0, 1.0), (4.0, 5.0)], 5.0) is None
    # a route crossing the wall line outside the doorway is no crossing of the door (it does
    # not happen on a real route, but the leg test must not count it)
    assert door_ahead(DOORWAY, (4.0, 1.0), [(6.0, 1.0)], 5.0) is None
    # the doorway 5.5 m away in a straight line: beyond reach
    assert door_ahead(DOORWAY, (0.5, 0.8), [(7.0, 3.0)], 5.0) is None
    # within reach the same way
    assert door_ahead(DOORWAY, (1.0, 3.0), [(7.0, 3.0)], 5.0) == pytest.approx((4.0, True))
    # the route first wanders off: the leg that crosses starts beyond reach
    far = [(0.5, 5.5), (0.5, 0.5), (4.5, 0.5), (4.5, 3.0), (6.0, 3.0)]
    assert door_ahead(DOORWAY, (4.0, 5.5), far, 5.0) is None
    # a caller's shorter reach
    assert door_ahead(DOORWAY, (2.0, 3.0), [(8.0, 3.0)], 5.0, reach=2.5) is None


def test_a_door_hidden_by_a_wall_reads_as_not_shut() -> None:
    screen = Wall((3.5, 0.5), (3.5, 2.5))
    hidden = World(bounds=DOORWAY.bounds, walls=(*DOORWAY.walls, screen), doors=(DOOR,))
    route = [(3.0, 3.0), (6.0, 3.0)]
    at = (3.0, 1.0)
    # the line from (3, 1) to the door's centre (5, 3) crosses x = 3.5 at y = 1.5: on the screen
    t = 5.0
    assert not DOOR.is_open(t)
    assert door_ahead(hidden, at, route, t) == pytest.approx((math.hypot(2.0, 2.0), False))
    # without the screen the robot sees the door shut
    assert door_ahead(DOORWAY, at, route, t) == pytest.approx((math.hypot(2.0, 2.0), True))


@settings(max_examples=60, deadline=None)
@given(t=st.floats(0.0, 1000.0), x0=st.floats(0.5, 4.8), y0=st.floats(0.5, 5.5),
       crossing=st.floats(2.55, 3.45))
def test_a_crossing_leg_in_sight_reads_the_schedule(t: float, x0: float, y0: float,
                                                    crossing: float) -> None:
    # a leg from (x0, y0) through the doorway at (5, crossing) on to x = 7; from the west side
    # nothing stands between the robot and the doorway's centre
    end = (7.0, y0 + (crossing - y0) * (7.0 - x0) / (5.0 - x0))
    found = door_ahead(DOORWAY, (x0, y0), [end], t)
    distance = math.dist((x0, y0), (5.0, 3.0))
    if distance > DOOR_REACH:
        assert found is None
        return
    assert found is not None
    assert found[0] == pytest.approx(distance)
    assert found[1] == (not DOOR.is_open(t))


def test_of_two_doors_on_one_leg_the_first_along_the_route_is_ahead() -> None:
    near = Door((3.0, 2.5), (3.0, 3.5), period=10.0, open_for=10.0, phase=0.0, name="near")
    far = Door((6.0, 2.5), (6.0, 3.5), period=10.0, open_for=0.0, phase=0.0, name="far")
    walls = (Wall((3.0, 0.0), (3.0, 2.5)), Wall((3.0, 3.5), (3.0, 6.0)),
             Wall((6.0, 0.0), (6.0, 2.5)), Wall((6.0, 3.5), (6.0, 6.0)))
    world = World(bounds=(0.0, 0.0, 12.0, 6.0), walls=walls, doors=(far, near))
    # one leg from (1, 3) to (8, 3) passes the open door at x = 3 first, 2 m away
    assert door_ahead(world, (1.0, 3.0), [(8.0, 3.0)], 0.0) == pytest.approx((2.0, False))


# --- progress ------------------------------------------------------------------------------------


def test_progress_is_the_part_of_the_route_driven() -> None:
    assert progress(10.0, 10.0) == 0.0
    assert progress(2.5, 10.0) == pytest.approx(0.75)
    assert progress(0.0, 10.0) == 1.0
    # no route at all: done
    assert progress(0.0, 0.0) == 1.0
    assert progress(3.0, 0.0) == 1.0
    assert progress(3.0, -1.0) == 1.0
    # a route grown longer than planned (a detour): clipped to 0; overshoot clipped to 1
    assert progress(12.0, 10.0) == 0.0
    assert progress(-1.0, 10.0) == 1.0


@given(st.floats(-100.0, 100.0), st.floats(-100.0, 100.0))
def test_progress_lies_in_the_unit_interval(remaining: float, total: float) -> None:
    assert 0.0 <= progress(remaining, total) <= 1.0
