"""What the global map (:class:`cbr_behaviors.globalmap.GlobalMap`) does not take for a transient
object: an echo at a person the tracker sees, on a doorway's line (a shut door) or within a
margin of a permanent wall. Each case is set against the same echo without the mask, which two
updates (``confirm``) make an object cell.

The robot stands at (1, 3) facing +x with one beam straight ahead; a reading of 1.5 m from the
rim (0.25 m from the centre) ends at (2.75, 3), in the evidence cell [2.75, 3.0] x [3.0, 3.25].
"""

from __future__ import annotations

import numpy as np
import pytest

from cbr_behaviors.globalmap import (
    DOOR_MARGIN,
    PERSON_MARGIN,
    WALL_MARGIN,
    GlobalMap,
    MapChange,
)
from cbr_world2d.robot import Pose
from cbr_world2d.sensors import SonarRing
from cbr_world2d.world import Door, Wall, World

POSE = Pose(1.0, 3.0, 0.0)
AHEAD = np.array([0.0])
READING = [1.5]
ECHO = (2.75, 3.0)
OPEN = World(bounds=(0.0, 0.0, 10.0, 6.0))


def sightings(gmap: GlobalMap, people: np.ndarray | None = None, times: int = 2) -> int:
    """Object cells after ``times`` updates with the echo ahead, ``people`` tracked at each."""
    added = 0
    for k in range(times):
        change = gmap.update(POSE, READING, AHEAD, 0.1 * k, people=people)
        added += change.added - change.removed
    assert added == len(gmap.object_points())
    return added


def test_the_margins_are_as_documented() -> None:
    assert (PERSON_MARGIN, DOOR_MARGIN, WALL_MARGIN) == (0.6, 0.3, 0.35)


def test_the_echo_alone_becomes_an_object_on_the_second_update() -> None:
    gmap = GlobalMap(OPEN)
    assert gmap.update(POSE, READING, AHEAD, 0.0) == MapChange(0, 0)
    assert gmap.update(POSE, READING, AHEAD, 0.1) == MapChange(1, 0)
    assert gmap.object_points().tolist() == [[2.875, 3.125]]
    # no one tracked, given as None or as an empty array, is the same
    assert sightings(GlobalMap(OPEN), people=np.zeros((0, 2))) == 1


@pytest.mark.parametrize("times", [2, 3, 6])
def test_an_echo_at_a_tracked_person_adds_no_object(times: int) -> None:
    at_person = np.array([ECHO])
    assert sightings(GlobalMap(OPEN), people=at_person, times=times) == 0
    assert sightings(GlobalMap(OPEN), times=times) == 1


@pytest.mark.parametrize("offset, masked", [
    ((0.0, 0.0), True),
    ((0.25, 0.0), True),     # the person's centre a radius beyond the echo off their front
    ((0.0, -0.55), True),
    ((0.4, 0.4), True),      # 0.57 m away
    ((0.0, 0.65), False),
    ((0.5, 0.5), False),     # 0.71 m away
    ((-2.0, 0.0), False),
])
def test_only_echoes_within_the_margin_of_a_person_are_theirs(offset: tuple[float, float],
                                                               masked: bool) -> None:
    person = np.array([[ECHO[0] + offset[0], ECHO[1] + offset[1]]])
    assert sightings(GlobalMap(OPEN), people=person) == (0 if masked else 1)


def test_any_of_several_people_masks_the_echo() -> None:
    people = np.array([[8.0, 1.0], [ECHO[0] + 0.1, ECHO[1] - 0.1], [1.0, 5.0]])
    assert sightings(GlobalMap(OPEN), people=people) == 0
    assert sightings(GlobalMap(OPEN), people=people[[0, 2]]) == 1


def test_a_person_masks_only_the_echoes_near_them() -> None:
    # two beams: ahead (ends at (2.75, 3)) and to the left (ends at (1, 4.75)); the person
    # stands ahead: the left echo still becomes an object
    angles = np.array([0.0, np.pi / 2])
    gmap = GlobalMap(OPEN)
    person = np.array([ECHO])
    for t in (0.0, 0.1):
        gmap.update(POSE, [1.5, 1.5], angles, t, people=person)
    assert gmap.object_points().tolist() == [[1.125, 4.875]]


def doorway(x: float, y0: float, y1: float) -> World:
    """The open floor with one door from ``(x, y0)`` to ``(x, y1)`` (always shut)."""
    return World(bounds=OPEN.bounds, doors=(Door((x, y0), (x, y1), period=10.0, open_for=0.0,
                                                 phase=0.0),))


@pytest.mark.parametrize("world, masked", [
    (doorway(2.75, 2.5, 3.5), True),    # the echo on the door
    (doorway(3.0, 2.5, 3.5), True),     # 0.25 m before the door's line
    (doorway(2.5, 2.0, 4.0), True),     # 0.25 m past it
    (doorway(3.1, 2.5, 3.5), False),    # 0.35 m: beyond the margin
    (doorway(2.75, 3.5, 4.5), False),   # on the door's line, but 0.5 m past its end
    (doorway(2.75, 3.25, 4.25), True),  # 0.25 m from its end
])
def test_an_echo_on_a_doorway_line_adds_no_object(world: World, masked: bool) -> None:
    assert sightings(GlobalMap(world)) == (0 if masked else 1)
    # an open door is masked just the same: the doorway is part of the building
    door = world.doors[0]
    always_open = World(bounds=world.bounds, doors=(Door(door.a, door.b, period=10.0,
                                                         open_for=10.0, phase=0.0),))
    assert sightings(GlobalMap(always_open)) == (0 if masked else 1)


# one ray per beam, so that a wall alongside the beam's axis does not explain the echo by the
# range (the cone of three rays would read it nearer than the echo)
NARROW = SonarRing(rays_per_beam=1)


def walled(y: float) -> World:
    """The open floor with a wall alongside the beam, from (2, y) to (4, y)."""
    return World(bounds=OPEN.bounds, walls=(Wall((2.0, y), (4.0, y)),))


@pytest.mark.parametrize("y, masked", [
    (3.2, True),     # 0.2 m from the echo
    (2.7, True),     # 0.3 m
    (3.34, True),    # within 0.35 m
    (3.4, False),    # 0.4 m
    (2.4, False),    # 0.6 m
])
def test_an_echo_within_the_margin_of_a_wall_adds_no_object(y: float, masked: bool) -> None:
    world = walled(y)
    # the wall is not on the beam's axis: the map alone expects the far wall, 8.75 m on (the
    # sonar's 5 m), so the echo is unexplained by the range
    assert sightings(GlobalMap(world, sonar=NARROW)) == (0 if masked else 1)


def test_a_wall_end_near_the_echo_masks_it_too() -> None:
    # a wall ending 0.3 m to the side of the echo, running away from the beam
    world = World(bounds=OPEN.bounds, walls=(Wall((2.75, 3.3), (2.75, 5.0)),))
    assert sightings(GlobalMap(world, sonar=NARROW)) == 0
    world = World(bounds=OPEN.bounds, walls=(Wall((2.75, 3.5), (2.75, 5.0)),))
    assert sightings(GlobalMap(world, sonar=NARROW)) == 1


def test_the_masks_keep_the_sonar_clearing() -> None:
    # an object confirmed earlier (echo at 1.5 m), then the tracked person passes in front:
    # the masked echo adds nothing but still clears the cells short of it
    gmap = GlobalMap(OPEN)
    for t in (0.0, 0.1):
        gmap.update(POSE, [2.5], AHEAD, t)
    assert gmap.object_points().tolist() == [[3.875, 3.125]]
    # a tracked person now stands beyond the old object, where the sonar reads 3.5 m (the
    # echo at (4.75, 3)): the ray passes the object's cell more than a tolerance and a cell
    # (0.55 m) short of the echo, so the cell is cleared, and the person adds nothing
    change = gmap.update(POSE, [3.5], AHEAD, 0.2, people=np.array([[4.75, 3.0]]))
    assert change == MapChange(0, 1)
    assert len(gmap.object_points()) == 0
