"""The primitive behaviors of 004 Table 1, the name overloads of the behavior registry, and
retargeting a running simulation.

Closed-loop cases drive a Pioneer 2 DX (radius 0.25 m, sonar noise 1 cm) a few hundred steps of
0.1 s in small worlds built here, through :class:`Simulation`; single-step cases use synthetic
observations whose proposals are worked out by hand in the comments. Speeds and turn rates by
name: moderate 0.2 m/s or 50 deg/s, slow 0.1 m/s or 25 deg/s, very-slow 0.05 m/s; priorities
med 0.6, high 1.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import attrs
import numpy as np
import pytest

from cbr_world2d.navigator import Navigator
from cbr_world2d.pilots import BEHAVIORS, BehaviorPilot, Proposal, parse_behavior_set
from cbr_world2d.pilots.behaviors import lookup_behavior, register_behavior
from cbr_world2d.pilots.kernels import sides
from cbr_world2d.pilots.primitives import (
    FACING,
    HOLD_MAX,
    HOLD_MIN,
    EnterDoorway,
    FollowWall,
    SlowAvoid,
    TurnToAngle,
    TurnToPos,
)
from cbr_world2d.robot import PIONEER_2DX, Pose
from cbr_world2d.sensors import PIONEER_SONAR_DEGREES, Observation, Sensors
from cbr_world2d.simulation import Simulation
from cbr_world2d.world import Wall, World

RADIUS = PIONEER_2DX.radius
ANGLES = np.radians(PIONEER_SONAR_DEGREES)
OPEN = World(bounds=(0.0, 0.0, 10.0, 10.0))
HALL = World(bounds=(0.0, 0.0, 16.0, 6.0))
"""A long wall, the bounds' side at y = 0, to follow."""
DOOR = World(bounds=(0.0, 0.0, 10.0, 6.0),
             walls=(Wall((5.0, 0.0), (5.0, 2.4)), Wall((5.0, 3.6), (5.0, 6.0))))
"""A wall at x = 5 with a doorway 1.2 m wide centred at (5, 3)."""
BLOCK = World(bounds=(0.0, 0.0, 10.0, 6.0), walls=(Wall((5.0, 1.0), (5.0, 5.0)),))
"""A wall across the way at x = 5."""


def simulation(world: World, behaviors: list[Any], start: tuple[float, float, float],
               target: tuple[float, float] = (9.0, 3.0)) -> tuple[Simulation, BehaviorPilot]:
    """A robot at ``start`` driven by the behavior set ``behaviors`` (centimetres)."""
    pilot = BehaviorPilot.from_data(behaviors)
    sim = Simulation(world, PIONEER_2DX, Sensors(camera=None).fitted(RADIUS), Navigator(pilot),
                     Pose(*start), target, seed=0)
    return sim, pilot


def run(sim: Simulation, steps: int) -> np.ndarray:
    """``steps`` more steps; the trajectory so far, rows ``t, x, y, theta, v, w``."""
    for _ in range(steps):
        sim.step()
    return sim.trajectory


def observation(x: float, y: float, theta: float, **readings: float) -> Observation:
    """An observation at ``(x, y, theta)`` with every Pioneer beam at 5 m but ``b<i>=r``."""
    ranges = np.full(16, 5.0)
    for name, value in readings.items():
        ranges[int(name[1:])] = value
    pose = Pose(x, y, theta)
    return Observation(t=0.0, pose=pose, true_pose=pose, sonar=ranges, sonar_angles=ANGLES,
                       bumped=False, sightings=(), confidence=1.0, v=0.0, w=0.0)


def heading_error(a: float, b: float) -> float:
    return abs((a - b + math.pi) % (2.0 * math.pi) - math.pi)


# --- stop, avoidCollision, slowAvoid ------------------------------------------------------


def test_stop_stops() -> None:
    sim, pilot = simulation(OPEN, [[["moveForward", "moderate"], "high"]], (2.0, 5.0, 0.0))
    run(sim, 20)
    assert sim.state.v == pytest.approx(0.2)
    pilot.install(parse_behavior_set([[["stop"], "high"]]))
    # braking from 0.2 m/s at the Pioneer's 0.3 m/s^2 takes 0.67 s: 7 steps
    run(sim, 7)
    assert sim.state.v == 0.0
    x = sim.state.x
    run(sim, 10)
    assert sim.state.x == x and sim.state.v == 0.0


def test_avoid_collision_turns_away_at_its_distance() -> None:
    # heading 0.3 rad toward a wall across the way: the front beams' nearest reading is the
    # rim's perpendicular distance to the wall, 4.75 - x; avoidCollision (50 cm) fades in from
    # 1.5 x 50 = 75 cm and turns away, left, since the wall is nearer on the right
    sim, _ = simulation(BLOCK, [[["moveForward", "moderate"], "med"],
                                [["avoidCollision", 50, "mod-fast"], "high"]], (2.0, 3.0, 0.3))
    trajectory = run(sim, 150)
    gap = 5.0 - RADIUS - trajectory[:, 1]
    turning = np.flatnonzero(trajectory[:, 5] != 0.0)
    assert turning.size and sim.collisions == 0
    first = turning[0]
    # straight on until the gap is within 75 cm (3 cm for the sonar's noise), turning before
    # the 50 cm
    assert np.all(trajectory[:first, 3] == 0.3)
    assert 0.5 < gap[first] <= 0.75 + 0.03
    assert np.all(trajectory[turning, 5] > 0.0)
    assert gap.min() > 0.0 and math.cos(sim.state.theta) < 0.0  # now heading away


def test_slow_avoid_proposes_its_speed_with_a_fit_growing_as_the_obstacle_nears() -> None:
    behavior = SlowAvoid(1.0, 0.05)
    # beam 3 (+10 deg) at 0.25 m: fit 1 - 0.25 / 1 = 0.75, speed only
    assert behavior.propose(observation(0.0, 0.0, 0.0, b3=0.25), (9.0, 0.0)) == \
        Proposal(None, 0.05, pytest.approx(0.75), limit=True)
    # beyond its distance, or beside the robot (beam 0, +90 deg), nothing to say
    assert behavior.propose(observation(0.0, 0.0, 0.0, b3=1.2), (9.0, 0.0)).fit == 0.0
    assert behavior.propose(observation(0.0, 0.0, 0.0, b0=0.2), (9.0, 0.0)).fit == 0.0


def test_slow_avoid_slows_near_an_obstacle_but_keeps_going() -> None:
    # moveForward moderate (med) with slowAvoid 100 very-slow (high), straight at a wall: at a
    # gap d < 1 m the weighted average is (0.6 * 0.2 + (1 - d) * 0.05) / (0.6 + 1 - d)
    sim, _ = simulation(BLOCK, [[["moveForward", "moderate"], "med"],
                                [["slowAvoid", 100, "very-slow"], "high"]], (2.0, 3.0, 0.0))
    trajectory = run(sim, 150)
    gap = 5.0 - RADIUS - trajectory[:, 1]
    speed = trajectory[:, 4]
    far = (gap > 1.05) & (trajectory[:, 0] > 1.0)  # past the 0.67 s speeding up
    assert np.all(speed[far] == pytest.approx(0.2))
    near = gap < 0.95
    assert near.any() and gap[-1] > 0.0 and sim.collisions == 0
    # slower and slower, never stopping: the speed follows the merge, capped by slowAvoid's
    # limit to the degree it fits (fit 1 - d: at most 0.05 + d * (0.2 - 0.05)), within the
    # speed the robot can shed in a step at 0.3 m/s^2 (3 cm/s) and the sonar's 1 cm noise
    d = gap[near]
    expected = np.minimum((0.12 + (1.0 - d) * 0.05) / (1.6 - d), 0.05 + d * 0.15)
    assert np.all(np.abs(speed[near] - expected) < 0.03 + 0.01)
    assert speed[near][-1] < speed[near][0] - 0.05 and speed[near].min() > 0.05
    assert np.all(np.diff(trajectory[near, 1]) > 0.0)


# --- followWall ---------------------------------------------------------------------------


def test_sides_reads_the_beams_beside_the_robot() -> None:
    ranges = np.array([0.7, 0.4, 0.9, 0.3, 2.0])
    angles = np.radians([90.0, 50.0, -90.0, 10.0, -100.0])
    # within 20 deg of +-90: left 0.7 (the 50 deg beam is 40 off), right min(0.9, 2.0)
    assert sides(ranges, angles, math.radians(20.0)) == (0.7, 0.9)
    assert sides(ranges[:2], angles[:2], math.radians(20.0)) == (0.7, math.inf)


def test_follow_wall_latches_the_nearer_side_and_a_distance_in_its_band() -> None:
    behavior = FollowWall(0.0)
    # nothing beside within reach (1.5 m): no fit, nothing latched
    assert behavior.propose(observation(0.0, 0.0, 0.0, b0=1.6, b7=2.0), (9, 0)).fit == 0.0
    assert behavior.holding is None
    # right wall (beam 7, -90 deg) nearer: latched at 0.8 m; at 0.9 m it turns toward it by
    # atan(0.1 / 1) at 1 rad/s per rad
    assert behavior.propose(observation(0.0, 0.0, 0.0, b0=1.2, b7=0.8), (9, 0)).fit == 1.0
    assert behavior.holding == (-1, 0.8)
    p = behavior.propose(observation(0.0, 0.0, 0.0, b0=1.2, b7=0.9), (9, 0))
    assert p == Proposal(pytest.approx(-math.atan(0.1)), None, 1.0)
    # the wall ends: fit 0, and the next wall in reach is latched afresh
    assert behavior.propose(observation(0.0, 0.0, 0.0, b0=1.2, b7=3.0), (9, 0)).fit == 0.0
    assert behavior.holding is None
    behavior.propose(observation(0.0, 0.0, 0.0, b0=0.1), (9, 0))
    assert behavior.holding == (1, HOLD_MIN)
    behavior.reset()
    behavior.propose(observation(0.0, 0.0, 0.0, b15=1.4), (9, 0))
    assert behavior.holding == (1, HOLD_MAX)


@pytest.mark.parametrize(("heading", "direction"), [(0.0, "curr-head"), (0.25, 0)])
def test_follow_wall_keeps_its_distance_along_a_long_wall(heading: float,
                                                          direction: str | int) -> None:
    # the wall (y = 0) is 0.8 - 0.25 = 0.55 m from the rim on the right; moveForward moderate
    # drives along it. Started 0.25 rad off the wall, the steering (lookahead L = 1 m, gain
    # K = 1/s) makes the distance off the held one e'' + K e' + (K v / L) e = 0 from
    # e'(0) = v sin 0.25: at v = 0.2 the roots are -0.276 and -0.724 and the excursion peaks
    # at 3.8 cm (less in fact: the speed builds up from rest). The held distance is the first
    # reading, 1 cm of noise: 3 cm covers it.
    sim, pilot = simulation(HALL, [[["followWall", direction], "high"],
                                   [["moveForward", "moderate"], "med"]], (1.0, 0.8, heading),
                            target=(15.0, 0.8))
    trajectory = run(sim, 500)
    holding = pilot.behaviors[0].behavior.holding
    assert holding is not None and holding[0] == -1
    assert holding[1] == pytest.approx(0.55, abs=0.03)
    gap = trajectory[:, 2] - RADIUS
    assert trajectory[-1, 1] > 10.0 and sim.collisions == 0
    assert np.all(np.abs(gap - 0.55) < 0.038 + 0.03)
    settled = trajectory[:, 0] > 25.0
    assert np.all(np.abs(gap[settled] - 0.55) < 0.03)
    assert np.all(np.abs(trajectory[settled, 3]) < 0.02)


# --- enterDoorway -------------------------------------------------------------------------


def test_enter_doorway_fits_near_the_door_and_centres_between_the_jambs() -> None:
    behavior = EnterDoorway((5.0, 3.0), 0.0)
    # on the axis 1 m before the door, facing through it: no turn, speed
    # slow + (moderate - slow) * 1 / 2 = 0.15
    assert behavior.propose(observation(4.0, 3.0, 0.0), (9, 3)) == \
        Proposal(0.0, pytest.approx(0.15), 1.0)
    # beyond 2 m of it, or more than 0.5 m past its line: nothing to say
    assert behavior.propose(observation(2.9, 3.0, 0.0), (9, 3)).fit == 0.0
    assert behavior.propose(observation(5.6, 3.0, 0.0), (9, 3)).fit == 0.0
    # at the door's centre, jambs read 0.2 m left (beam 0) and 0.4 m right (beam 7): the robot
    # is 0.1 m left of their midpoint, so it steers for the point 0.5 m ahead and 0.1 m right:
    # error -atan(0.1 / 0.5), speed slow * cos(error)
    p = behavior.propose(observation(5.0, 3.0, 0.0, b0=0.2, b7=0.4), (9, 3))
    error = -math.atan(0.1 / 0.5)
    assert p == Proposal(pytest.approx(error), pytest.approx(0.1 * math.cos(error)), 1.0)


def test_enter_doorway_passes_a_door_from_an_offset_start() -> None:
    # 1.5 m before the wall and 0.7 m to the right of the door's axis: the robot clears the
    # jambs with 0.6 - 0.25 = 0.35 m to spare on the axis; it comes through within 5 cm of it
    # (5 sigma of the jambs' readings) and stops once 0.5 m past the line, its fit gone
    sim, pilot = simulation(DOOR, [[["enterDoorway", [500, 300], 0], "high"]], (3.5, 2.3, 0.0))
    trajectory = run(sim, 250)
    through = np.argmax(trajectory[:, 1] >= 5.0)
    assert trajectory[through, 1] >= 5.0 and sim.collisions == 0
    assert abs(trajectory[through, 2] - 3.0) < 0.05
    assert 5.0 + RADIUS < sim.state.x < 5.7 and sim.state.v == 0.0
    assert pilot.proposals[0].fit == 0.0


# --- turnTo -------------------------------------------------------------------------------


def test_turn_to_pos_ends_facing_the_point() -> None:
    sim, pilot = simulation(OPEN, [[["turnTo", [200, 700]], "high"]], (5.0, 5.0, 0.3))
    trajectory = run(sim, 80)
    facing = math.atan2(7.0 - 5.0, 2.0 - 5.0)
    assert heading_error(sim.state.theta, facing) <= FACING
    assert np.all(trajectory[:, 1:3] == (5.0, 5.0))  # on the spot
    assert pilot.proposals == (Proposal(None, None, 0.0),) and sim.state.w == 0.0


@pytest.mark.parametrize(("direction", "angle", "sense"), [("curr-head", 90, 1.0),
                                                          ("curr-head", -180, -1.0),
                                                          (45, -120, -1.0)])
def test_turn_to_direction_angle_ends_at_direction_plus_angle(direction: str | int, angle: int,
                                                              sense: float) -> None:
    start = 0.3
    sim, _ = simulation(OPEN, [[["turnTo", direction, angle], "high"]], (5.0, 5.0, start))
    trajectory = run(sim, 80)
    base = start if direction == "curr-head" else math.radians(direction)
    assert heading_error(sim.state.theta, base + math.radians(angle)) <= FACING
    assert np.all(trajectory[:, 1:3] == (5.0, 5.0))
    assert np.all(sense * trajectory[:, 5] >= 0.0)  # a positive angle turns left


def test_turn_to_is_done_once_facing() -> None:
    turn = TurnToPos((1.0, 1.0))
    # bearing 45 deg from heading 0: 2/s x 0.785 rad, capped at 50 deg/s
    assert turn.propose(observation(0, 0, 0.0), (0, 0)) == \
        Proposal(pytest.approx(math.radians(50.0)), 0.0, 1.0)
    assert turn.propose(observation(0, 0, math.radians(44.0)), (0, 0)).fit == 0.0
    assert turn.propose(observation(0, 0, 0.0), (0, 0)).fit == 0.0  # done until reset
    turn.reset()
    assert turn.propose(observation(0, 0, math.radians(40.0)), (0, 0)) == \
        Proposal(pytest.approx(2.0 * math.radians(5.0)), 0.0, 1.0)
    by = TurnToAngle(None, math.radians(10.0))
    assert by.propose(observation(0, 0, 1.0), (0, 0)).turn == pytest.approx(math.radians(20.0))
    assert by.propose(observation(0, 0, 1.0 + math.radians(9.0)), (0, 0)).fit == 0.0


# --- localize -----------------------------------------------------------------------------


def test_localize_stands_still_scanning_then_is_done() -> None:
    sim, pilot = simulation(OPEN, [[["localize"], "high"]], (5.0, 5.0, 0.3))
    assert not pilot.localizing  # no step yet
    trajectory = run(sim, 20)
    assert pilot.localizing and sim.state.w == pytest.approx(math.radians(25.0))
    assert np.all(trajectory[:, 1:3] == (5.0, 5.0)) and np.all(trajectory[:, 4] == 0.0)
    # a whole turn at 25 deg/s takes 14.4 s (plus 0.25 s to reach the rate)
    trajectory = run(sim, 140)
    turned = np.sum(np.abs(np.diff(np.unwrap(trajectory[:, 3]))))
    assert not pilot.localizing and turned >= 2.0 * math.pi
    assert np.all(trajectory[:, 1:3] == (5.0, 5.0))


def test_localizing_needs_a_localize_behavior_that_fits() -> None:
    pilot = BehaviorPilot.from_data([[["stop"], "high"]])
    pilot.command(observation(0, 0, 0), (1, 1))
    assert not pilot.localizing


# --- names and argument counts ------------------------------------------------------------


def test_turn_to_forms_are_told_apart_by_argument_count() -> None:
    by_pos, by_angle = parse_behavior_set([[["turnTo", "curr-goal"], "high"],
                                           [["turnTo", "curr-head", -90], "med"]])
    assert by_pos.behavior == TurnToPos(None)
    assert by_angle.behavior == TurnToAngle(None, -math.pi / 2) and by_angle.priority == 0.6
    assert sorted(BEHAVIORS["turnTo"]) == [1, 2]
    assert lookup_behavior("turnTo", 2).signature == "(turnTo direction angle)"
    with pytest.raises(ValueError, match=r"^item 0: turnTo takes 1 or 2 argument\(s\) "
                       r"\(turnTo pos\) or \(turnTo direction angle\), got 3$"):
        parse_behavior_set([[["turnTo", 0, 90, 1], "high"]])
    with pytest.raises(ValueError, match=r"turnTo angle: expected an angle in \[-180, 180\]"):
        parse_behavior_set([[["turnTo", "curr-head", 270], "high"]])


def test_all_twelve_behaviors_of_table_1_are_known() -> None:
    table_1 = {"stop": [0], "moveForward": [1], "goStraight": [2], "avoidObstacle": [2],
               "avoidCollision": [2], "slowAvoid": [2], "goToPos": [3], "followWall": [1],
               "enterDoorway": [2], "turnTo": [1, 2], "localize": [0]}
    assert {name: sorted(BEHAVIORS[name]) for name in table_1} == table_1


def test_an_overload_is_registered_by_argument_count_once() -> None:
    @attrs.define
    class Hold:
        speed: float = 0.0
        rate: float = 0.0

        def propose(self, obs: Observation, target: Sequence[float]) -> Proposal:
            return Proposal(self.rate, self.speed, 1.0)

        def reset(self) -> None:
            pass

    register_behavior("testHold", Hold, [("speed", "speed")])
    try:
        register_behavior("testHold", Hold, [("speed", "speed"), ("rate", "turn_rate")])
        with pytest.raises(ValueError, match=r"'testHold' with 1 argument\(s\) is already "
                           r"registered: \(testHold speed\)"):
            register_behavior("testHold", Hold, [("rate", "turn_rate")])
        one, two = parse_behavior_set([[["testHold", 10], "high"],
                                       [["testHold", 10, 90], "high"]])
        assert one.behavior == Hold(0.1) and two.behavior == Hold(0.1, math.pi / 2)
    finally:
        del BEHAVIORS["testHold"]


# --- retargeting --------------------------------------------------------------------------


def test_retarget_changes_the_final_target_and_keeps_the_pilots_latched_state() -> None:
    sim, pilot = simulation(HALL, [[["followWall", "curr-head"], "high"],
                                   [["moveForward", "moderate"], "med"]],
                            (1.0, 0.8, 0.0), target=(15.0, 0.8))
    run(sim, 30)
    follow = pilot.behaviors[0].behavior
    holding = follow.holding
    navigator = sim.navigator
    navigator.divert((3.0, 3.0))
    assert holding is not None and navigator.diverting and not sim.reached
    here = (sim.state.x, sim.state.y)
    sim.retarget(here)
    assert sim.target == here and navigator.target == here and sim.reached
    assert not navigator.diverting and navigator.current_target == here
    assert navigator.status == "moving"
    assert follow.holding == holding
    sim.retarget((12.0, 4.0))
    assert not sim.reached
    sim.step()
    assert follow.holding == holding  # still latched after a step toward the new target
    navigator.start((12.0, 4.0))
    assert follow.holding is None  # where start() does reset the pilot
