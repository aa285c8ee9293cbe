"""When the ``trials`` workload consults: the triggers of :mod:`cbr_world2d.triggers`, driven
step by step with made-up observations (what the camera sees, where the heading
points)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np

from cbr_world2d.fuzzy import Triangle
from cbr_world2d.robot import Pose
from cbr_world2d.sensors import Observation, Sighting
from cbr_world2d.simulation import Event
from cbr_world2d.triggers import TRIGGERS, LandmarksInView, Trigger, Triggers

DT = 0.1


def observe(t: float, ids: Iterable[str] = (), heading: float = 0.0) -> Observation:
    """An observation at ``t`` seeing ``ids``, the heading ``heading`` degrees."""
    pose = Pose(0.0, 0.0, math.radians(heading))
    sightings = tuple(Sighting(i, Triangle(2.9, 3.0, 3.1), Triangle(-0.1, 0.0, 0.1))
                      for i in ids)
    return Observation(t, pose, pose, np.zeros(0), np.zeros(0), False, sightings, 1.0, 0.0, 0.0)


def come_into_view(tracker: LandmarksInView, views: Sequence[Iterable[str]]) -> list[set[str]]:
    """What comes into view at each step of ``views`` (one step of DT each)."""
    return [set(tracker.update(k * DT, view)) for k, view in enumerate(views)]


# --- landmarks: hysteresis ----------------------------------------------------------------


def test_the_landmarks_in_view_at_the_start_come_into_view_at_once() -> None:
    assert come_into_view(LandmarksInView(0.5, 5.0), [{"a", "b"}, {"a", "b"}]) == [{"a", "b"},
                                                                                    set()]


def test_a_landmark_flickering_within_the_absence_does_not_come_into_view_again() -> None:
    # 'a' in view for 1 s, then on and off every step (the edge of the view) for 4 s, then
    # every other second: never out of view for 5 s, so it came into view once, at the start
    views = [{"a"}] * 10 + [{"a"} if k % 2 else set() for k in range(40)]
    views += [({"a"} if (k // 10) % 2 else set()) for k in range(40)]
    assert come_into_view(LandmarksInView(0.5, 5.0), views) == [{"a"}] + [set()] * 89


def test_a_landmark_back_after_the_absence_comes_into_view_once_it_settled() -> None:
    # out of view for 5 s, then back: it comes into view once in view for 0.5 s
    views = [{"a"}] + [set()] * 50 + [{"a"}] * 10
    come = come_into_view(LandmarksInView(0.5, 5.0), views)
    assert [k for k, c in enumerate(come) if c] == [0, 51 + 5]


def test_a_glimpse_shorter_than_settle_does_not_come_into_view() -> None:
    # 'b' is seen for 0.4 s three times as the robot swerves; then it stays
    views = [set()] + ([{"b"}] * 4 + [set()] * 3) * 3 + [{"b"}] * 6
    come = come_into_view(LandmarksInView(0.5, 5.0), views)
    assert [k for k, c in enumerate(come) if c] == [1 + 21 + 5]


def test_without_hysteresis_every_return_comes_into_view() -> None:
    # settle 0 and absence 0: a landmark comes into view whenever it was not in view at the
    # step before, the trigger without hysteresis
    views = [{"a"}, set(), {"a"}, {"a", "b"}, {"b"}, {"a", "b"}]
    assert come_into_view(LandmarksInView(0.0, 0.0), views) == [
        {"a"}, set(), {"a"}, {"b"}, set(), {"a"}]


# --- heading, period and their order -------------------------------------------------------


def triggers(on: Sequence[Trigger] = TRIGGERS, **changes: float) -> Triggers:
    options = {"period": 5.0, "turn": 30.0, "settle": 0.5, "absence": 5.0, **changes}
    return Triggers(on, observe(0.0), **options)


def test_the_heading_trigger_fires_on_a_turn_from_the_last_consultation() -> None:
    t = triggers(["heading"])
    assert t.update(observe(0.1, heading=29.0), ()) is None
    assert t.update(observe(0.2, heading=-29.0), ()) is None
    assert t.update(observe(0.3, heading=-30.0), ()) == "heading"
    t.consulted(observe(0.3, heading=-30.0))
    assert t.update(observe(0.4, heading=-1.0), ()) is None  # 29 degrees from there
    # across the half turn: from 170 to -170 degrees is a turn of 20
    t.consulted(observe(0.5, heading=170.0))
    assert t.update(observe(0.6, heading=-170.0), ()) is None
    assert t.update(observe(0.7, heading=-140.0), ()) == "heading"


def test_the_period_trigger_fires_a_period_after_the_last_consultation() -> None:
    t = triggers(["period"])
    assert t.update(observe(4.9), ()) is None
    assert t.update(observe(5.0), ()) == "period"
    assert t.update(observe(6.0), ()) == "period"  # not consulted (inhibited): due still
    t.consulted(observe(7.0))
    assert t.update(observe(11.9), ()) is None
    assert t.update(observe(12.0), ()) == "period"


def test_the_first_trigger_in_order_names_the_consultation() -> None:
    t = triggers()
    blocked = (Event("blocked", 6.0, 0.0, 0.0),)
    # at the start the landmarks in view come into view
    assert t.update(observe(0.0, {"a"}), ()) == "landmarks"
    assert t.update(observe(6.0, {"a"}, heading=45.0), blocked) == "blocked"
    assert t.update(observe(6.1, {"a"}, heading=45.0), ()) == "heading"
    assert t.update(observe(6.2, {"a"}), ()) == "period"
    assert triggers([]).update(observe(9.0, {"a"}, heading=90.0), blocked) is None

