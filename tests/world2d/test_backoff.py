"""backOff (:class:`cbr_world2d.pilots.primitives.BackOff`) step by step on synthetic Pioneer
sonar rings, and properties of the merge (:class:`cbr_world2d.pilots.behaviors.Arbiter`) that
must hold for any proposals."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_world2d.pilots.behaviors import NEGLIGIBLE, Arbiter, BackOff, Proposal, merge
from cbr_world2d.pilots.primitives import (
    BACK_CLEAR,
    BACK_REST,
    BACK_TIME,
    NOTHING,
    REAR_ROOM,
    TURN_RATES,
)
from cbr_world2d.robot import PIONEER_2DX, Pose, RobotState, step
from cbr_world2d.sensors import PIONEER_SONAR_DEGREES, Observation

ANGLES = np.radians(PIONEER_SONAR_DEGREES)
MAX_RANGE = 5.0
TARGET = (10.0, 0.0)
DISTANCE, SPEED = 0.5, 0.1
"""The backOff of these tests: within 0.5 m ahead, back up at 0.1 m/s."""
SLOW_TURN = TURN_RATES["slow"]

# beams by heading: 90 (0, 15), 50 (1), 30 (2), 10 (3), -10 (4), -30 (5), -50 (6), -90 (7, 8),
# -130 (9), -150 (10), -170 (11), 170 (12), 150 (13), 130 (14)
FRONT = (3, 4)
LEFT = (0, 15)
RIGHT = (7, 8)
REAR = (9, 10, 11, 12, 13, 14)


def observation(ranges: Sequence[float] | np.ndarray, t: float = 0.0) -> Observation:
    """An observation at the origin facing +x with the given sonar readings."""
    pose = Pose(0.0, 0.0, 0.0)
    return Observation(t=t, pose=pose, true_pose=pose, sonar=np.asarray(ranges, dtype=float),
                       sonar_angles=ANGLES, bumped=False, sightings=(), confidence=1.0,
                       v=0.0, w=0.0)


def ring(front: float = MAX_RANGE, left: float = MAX_RANGE, right: float = MAX_RANGE,
         rear: float = MAX_RANGE) -> np.ndarray:
    """All 16 beams at the maximum except the two front beams (+-10 degrees), the side ones
    (+-90) and the rear ones (130 degrees and beyond)."""
    ranges = np.full(16, MAX_RANGE)
    ranges[list(FRONT)] = front
    ranges[list(LEFT)] = left
    ranges[list(RIGHT)] = right
    ranges[list(REAR)] = rear
    return ranges


def backing(proposal: Proposal) -> bool:
    return proposal.fit == 1.0 and proposal.speed == -SPEED


def test_the_constants_are_as_documented() -> None:
    assert (REAR_ROOM, BACK_CLEAR, BACK_TIME, BACK_REST) == (0.4, 2.0, 3.0, 4.0)


def test_nothing_when_the_way_ahead_is_clear() -> None:
    behavior = BackOff(DISTANCE, SPEED)
    assert behavior.propose(observation(ring()), TARGET) == NOTHING
    # something at the distance itself is not within it; something to the side is not ahead
    assert behavior.propose(observation(ring(front=DISTANCE)), TARGET) == NOTHING
    assert behavior.propose(observation(ring(left=0.1, right=0.1)), TARGET) == NOTHING
    # a beam at 50 degrees is within the 60 degree collision arc
    ranges = ring()
    ranges[1] = 0.3
    assert backing(behavior.propose(observation(ranges), TARGET))


def test_nothing_when_something_is_close_behind() -> None:
    behavior = BackOff(DISTANCE, SPEED)
    assert behavior.propose(observation(ring(front=0.3, rear=REAR_ROOM)), TARGET) == NOTHING
    assert behavior.propose(observation(ring(front=0.3, rear=0.1)), TARGET) == NOTHING
    # one rear beam close is enough
    ranges = ring(front=0.3)
    ranges[14] = 0.2  # 130 degrees
    assert behavior.propose(observation(ranges), TARGET) == NOTHING
    # a beam at 90 degrees is no rear beam
    assert backing(behavior.propose(observation(ring(front=0.3, left=0.2)), TARGET))


def test_blocked_ahead_with_room_behind_it_backs_up_at_fit_one() -> None:
    behavior = BackOff(DISTANCE, SPEED)
    proposal = behavior.propose(observation(ring(front=0.3, left=3.0, right=1.0)), TARGET)
    assert proposal.speed == pytest.approx(-SPEED)
    assert proposal.fit == 1.0
    assert not proposal.limit
    assert abs(proposal.turn) == pytest.approx(SLOW_TURN)
    # the freer side on the other hand turns the other way
    mirrored = BackOff(DISTANCE, SPEED).propose(observation(ring(front=0.3, left=1.0,
                                                                 right=3.0)), TARGET)
    assert mirrored.turn == pytest.approx(-proposal.turn)
    assert mirrored.speed == proposal.speed and mirrored.fit == 1.0


def heading_after(proposal: Proposal, seconds: float = 2.0) -> float:
    """The heading of a Pioneer at rest facing +x after following ``proposal`` in open space."""
    state = RobotState(0.0, 0.0, 0.0)
    none4, none3 = np.zeros((0, 4)), np.zeros((0, 3))
    for _ in range(round(seconds / 0.1)):
        state, _ = step(state, (proposal.speed, proposal.turn), PIONEER_2DX, 0.1, none4, none3)
    return state.theta


def test_backing_up_swings_the_nose_toward_the_freer_side() -> None:
    # left freer: the nose (the heading) should turn counter-clockwise, theta growing
    left_freer = BackOff(DISTANCE, SPEED).propose(observation(ring(front=0.3, left=3.0,
                                                                   right=1.0)), TARGET)
    assert heading_after(left_freer) > 0.0
    right_freer = BackOff(DISTANCE, SPEED).propose(observation(ring(front=0.3, left=1.0,
                                                                    right=3.0)), TARGET)
    assert heading_after(right_freer) < 0.0


def test_the_side_is_latched_while_backing_up() -> None:
    behavior = BackOff(DISTANCE, SPEED)
    first = behavior.propose(observation(ring(front=0.3, left=3.0, right=1.0), 0.0), TARGET)
    # the sides swap while it backs: it keeps turning the way it chose
    then = behavior.propose(observation(ring(front=0.4, left=1.0, right=3.0), 0.5), TARGET)
    assert then == first


def test_it_stops_after_the_back_time_then_rests() -> None:
    behavior = BackOff(DISTANCE, SPEED)
    blocked = ring(front=0.3, left=3.0, right=1.0)
    for t in (0.0, 1.0, 2.0, 2.9):
        assert backing(behavior.propose(observation(blocked, t), TARGET)), t
    # 3 s after it started: done, resting until 3 + 4 = 7
    assert behavior.propose(observation(blocked, 3.0), TARGET) == NOTHING
    for t in (3.1, 5.0, 6.9):
        assert behavior.propose(observation(blocked, t), TARGET) == NOTHING, t
    # rested: backs up again, for another 3 s
    assert backing(behavior.propose(observation(blocked, 7.0), TARGET))
    assert backing(behavior.propose(observation(blocked, 9.9), TARGET))
    assert behavior.propose(observation(blocked, 10.0), TARGET) == NOTHING


def test_it_stops_once_clear_by_twice_the_distance_then_rests() -> None:
    behavior = BackOff(DISTANCE, SPEED)
    assert backing(behavior.propose(observation(ring(front=0.3), 0.0), TARGET))
    # beyond the distance but short of twice it: still backing
    assert backing(behavior.propose(observation(ring(front=0.7), 0.5), TARGET))
    assert backing(behavior.propose(observation(ring(front=0.99), 1.0), TARGET))
    # at 2 x 0.5 m: clear, resting until 1.5 + 4
    assert behavior.propose(observation(ring(front=1.0), 1.5), TARGET) == NOTHING
    assert behavior.propose(observation(ring(front=0.3), 5.4), TARGET) == NOTHING
    assert backing(behavior.propose(observation(ring(front=0.3), 5.5), TARGET))


def test_it_stops_when_something_comes_close_behind() -> None:
    behavior = BackOff(DISTANCE, SPEED)
    assert backing(behavior.propose(observation(ring(front=0.3), 0.0), TARGET))
    assert behavior.propose(observation(ring(front=0.4, rear=0.35), 0.5), TARGET) == NOTHING
    # and rests like after any back-up
    assert behavior.propose(observation(ring(front=0.3), 4.4), TARGET) == NOTHING
    assert backing(behavior.propose(observation(ring(front=0.3), 4.5), TARGET))


def test_reset_forgets_the_rest_and_the_latched_side() -> None:
    behavior = BackOff(DISTANCE, SPEED)
    blocked = ring(front=0.3, left=3.0, right=1.0)
    first = behavior.propose(observation(blocked, 0.0), TARGET)
    assert behavior.propose(observation(ring(front=1.2), 0.5), TARGET) == NOTHING
    # resting now; reset: it may back up at once
    behavior.reset()
    assert behavior.propose(observation(blocked, 1.0), TARGET) == first
    # reset while backing: the side is chosen afresh
    behavior.reset()
    swapped = behavior.propose(observation(ring(front=0.3, left=1.0, right=3.0), 1.1), TARGET)
    assert swapped.turn == pytest.approx(-first.turn)
    # reset also starts the back time afresh (from t = 2, not 1)
    behavior.reset()
    assert backing(behavior.propose(observation(blocked, 2.0), TARGET))
    assert backing(behavior.propose(observation(blocked, 4.5), TARGET))
    assert behavior.propose(observation(blocked, 5.0), TARGET) == NOTHING


def test_reset_behavior_matches_a_fresh_one() -> None:
    used, fresh = BackOff(DISTANCE, SPEED), BackOff(DISTANCE, SPEED)
    for t in (0.0, 1.0, 3.0):
        used.propose(observation(ring(front=0.3), t), TARGET)
    used.reset()
    assert used == fresh


# --- merging: properties that must hold for any proposals -----------------------------------

def _plain(value: float) -> bool:
    """Not a subnormal-sized value: a weighted mean of -1e-320 rounds to 0."""
    return value == 0.0 or abs(value) >= 1e-9


turns = st.one_of(st.none(), st.floats(-2.0, 2.0).filter(_plain),
                  st.sampled_from([0.0, 0.01, -0.01]))
speeds = st.one_of(st.none(), st.floats(-0.4, 0.8).filter(_plain))
fits = st.one_of(st.floats(0.0, 1.0), st.sampled_from([0.0, 1.0, 1e-13]))
priorities = st.one_of(st.floats(0.0, 1.0), st.sampled_from([0.2, 0.6, 1.0]))


@st.composite
def proposals(draw: st.DrawFn) -> tuple[Proposal, float]:
    limit = draw(st.booleans())
    # a limit caps the speed at something at most as fast as it asks: a speed >= 0 (behaviors
    # that slow for an obstacle never ask to back up)
    speed = draw(st.floats(0.0, 0.8)) if limit else draw(speeds)
    return Proposal(draw(turns), speed, draw(fits), limit), draw(priorities)


steps = st.lists(st.lists(proposals(), max_size=6), min_size=1, max_size=8)


def check(merged: tuple[float, float], given_: Sequence[tuple[Proposal, float]]) -> None:
    speed, turn = merged
    counting = [p for p, priority in given_ if priority * p.fit > NEGLIGIBLE]
    asked_turns = [p.turn for p in counting if p.turn is not None]
    asked_speeds = [p.speed for p in counting if p.speed is not None]
    eps = 1e-12
    if asked_turns:
        assert min(asked_turns) - eps <= turn <= max(asked_turns) + eps
    else:
        assert turn == 0.0
    if asked_speeds:
        assert min(asked_speeds) - eps <= speed <= max(asked_speeds) + eps
    else:
        assert speed == 0.0
    # a fully fitting limit holds, whatever else asks
    for p in counting:
        if p.limit and p.fit == 1.0 and p.speed is not None:
            assert speed <= p.speed + eps
    # backing up exactly when some proposal asks to
    assert (speed < 0.0) == any(v < 0.0 for v in asked_speeds)


@settings(max_examples=100, deadline=None)
@given(steps)
def test_the_merge_stays_within_what_the_proposals_ask(sequence: list) -> None:
    arbiter = Arbiter()
    for given_ in sequence:
        check(arbiter.merge(given_), given_)
        # the one-step merge (no side held) as well
        check(merge(given_), given_)


def test_a_negligible_weight_says_nothing() -> None:
    # a fit of 1e-13 at priority 1 weighs less than NEGLIGIBLE: as if absent
    assert merge([(Proposal(1.0, 0.4, 1e-13), 1.0)]) == (0.0, 0.0)
    assert merge([(Proposal(1.0, 0.4, 1e-13), 1.0), (Proposal(-0.5, 0.2, 1.0), 0.5)]) == (
        pytest.approx(0.2), pytest.approx(-0.5))


def test_backing_up_merged_with_a_push_forward_backs_up() -> None:
    back = Proposal(-SLOW_TURN, -SPEED, 1.0)
    forward = Proposal(0.3, 0.3, 1.0)
    speed, turn = merge([(back, 1.0), (forward, 1.0)])
    # only the backing proposal's speed counts; the turns of both sides: the heavier (|turn|
    # weighted) right turn of 0.436 rad/s against 0.3 left, so the right one alone
    assert speed == pytest.approx(-SPEED)
    assert turn == pytest.approx(-SLOW_TURN)
