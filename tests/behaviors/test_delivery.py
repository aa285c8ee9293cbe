"""RUPART's delivery machinery (004): messages, the goal manager, the global map and the
re-planning triggers, each against hand-worked numbers."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from cbr_behaviors.globalmap import GlobalMap, MapChange
from cbr_behaviors.goals import GoalManager
from cbr_behaviors.index import SITUATION
from cbr_behaviors.messages import (
    PRIORITIES,
    PRIORITY_CHANCES,
    SLACK,
    Message,
    message_day,
    straight_line,
)
from cbr_behaviors.triggers import ReplanMonitor, Snapshot, TriggerOptions
from cbr_grid.planning import GridPlanner, planner_of
from cbr_world2d.geometry import clearance
from cbr_world2d.robot import Pose
from cbr_world2d.sensors import SonarRing
from cbr_world2d.world import Landmark, Mover, Wall, World
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.plugins import Plugins, current

# --- messages -------------------------------------------------------------------------------

FLOOR = World(bounds=(0.0, 0.0, 20.0, 10.0),
              places={"room_1": (1.0, 1.0), "room_2": (16.0, 5.0), "hall": (10.0, 5.0)})


def test_a_day_repeats_with_its_seed_and_deadlines_keep_the_documented_slack() -> None:
    day = message_day(FLOOR, np.random.default_rng(3), length=3600.0, rate_per_hour=30.0)
    assert day == message_day(FLOOR, np.random.default_rng(3), length=3600.0,
                              rate_per_hour=30.0)
    assert day != message_day(FLOOR, np.random.default_rng(4), length=3600.0,
                              rate_per_hour=30.0)
    assert [m.id for m in day] == [f"m{k}" for k in range(1, len(day) + 1)]
    assert [m.arrives for m in day] == sorted(m.arrives for m in day)
    # the longest drive to either room, from the other (sqrt(15^2 + 4^2) m) or the bounds'
    # centre (10, 5) (sqrt(97) m and 6 m), at 0.3 m/s
    trip = {"room_1": math.sqrt(241.0) / 0.3, "room_2": math.sqrt(241.0) / 0.3}
    for m in day:
        assert 0.0 <= m.arrives < 3600.0
        assert m.point == FLOOR.places[m.place]
        low, high = SLACK[m.priority]
        slack = (m.deadline - m.arrives) / trip[m.place]
        assert low - 1e-9 <= slack <= high + 1e-9
    # the hall is no room
    assert {m.place for m in day} == {"room_1", "room_2"}


def test_arrivals_are_a_poisson_process_and_priorities_follow_their_chances() -> None:
    day = message_day(FLOOR, np.random.default_rng(11), length=100 * 3600.0,
                      rate_per_hour=60.0)
    # 6000 expected, standard deviation sqrt(6000) = 77.5: four of them either side
    assert 6000 - 310 <= len(day) <= 6000 + 310
    for p in PRIORITIES:
        share = sum(m.priority == p for m in day) / len(day)
        assert abs(share - PRIORITY_CHANCES[p]) < 0.025
    eta = straight_line(1.0)
    only = message_day(FLOOR, np.random.default_rng(1), length=3600.0, rate_per_hour=20.0,
                       places=["hall"], origin=(0.0, 5.0), eta=eta,
                       chances={"critical": 1.0})
    # the hall is 10 m from the origin, 10 s at 1 m/s, under the 30 s floor; critical slack
    # is 1.5 to 3 trips
    assert all(m.priority == "critical" and 45.0 <= m.deadline - m.arrives <= 90.0
               for m in only)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"places": ["cellar"]}, "'cellar' not among the places"),
    ({"rate_per_hour": 0.0}, "rate_per_hour"),
    ({"chances": {"urgent": 1.0}}, "chances"),
])
def test_bad_day_arguments_are_refused(kwargs: dict[str, Any], message: str) -> None:
    arguments: dict[str, Any] = {"length": 60.0, "rate_per_hour": 10.0, **kwargs}
    with pytest.raises(CbrError, match=message):
        message_day(FLOOR, np.random.default_rng(0), **arguments)
    with pytest.raises(CbrError, match="no places named room"):
        message_day(World(bounds=(0, 0, 1, 1)), np.random.default_rng(0), length=60.0,
                    rate_per_hour=10.0)


# --- goals (straight line at 1 m/s: seconds are metres) ---------------------------------------


def manager(*messages: Message, **options: float) -> GoalManager:
    goals = GoalManager(straight_line(1.0), **options)
    goals.receive(messages)
    return goals


def test_the_primary_goal_is_the_most_urgent_then_the_earliest_due() -> None:
    normal = Message("a", "p", (10.0, 0.0), "normal", 0.0, 100.0)
    sooner = Message("c", "q", (0.0, -10.0), "normal", 0.0, 60.0)
    critical = Message("b", "r", (0.0, 10.0), "critical", 0.0, 50.0)
    decision = manager(normal, sooner, critical).update((0.0, 0.0), 0.0)
    assert decision.primary == critical and decision.target == critical
    assert decision.reason == "primary"
    assert manager(normal, sooner).update((0.0, 0.0), 0.0).primary == sooner


def test_a_goal_that_cannot_be_saved_is_given_up_for_the_primary() -> None:
    primary = Message("p", "east", (10.0, 0.0), "critical", 0.0, 12.0)
    other = Message("g", "west", (-10.0, 0.0), "normal", 0.0, 25.0)
    goals = manager(primary, other)
    decision = goals.update((0.0, 0.0), 0.0)
    # east first reaches west at 10 + 20 = 30 > 25; west first reaches east at 30 > 12
    assert decision.target == primary
    assert [(m.message.id, m.why, m.against) for m in decision.missed] == [("g", "conflict",
                                                                            "p")]
    assert goals.pending == (primary,)


def test_a_goal_that_would_miss_behind_the_primary_is_served_first_when_that_saves_it() -> None:
    primary = Message("p", "east", (10.0, 0.0), "critical", 0.0, 40.0)
    other = Message("g", "west", (-5.0, 0.0), "normal", 0.0, 20.0)
    decision = manager(primary, other).update((0.0, 0.0), 0.0)
    # east first: west at 10 + 15 = 25 > 20; west first: west at 5, east at 20 <= 40
    assert (decision.primary, decision.target, decision.reason) == (primary, other, "saved")
    assert decision.missed == ()


def test_a_goal_on_the_way_is_served_opportunistically() -> None:
    primary = Message("p", "east", (10.0, 0.0), "normal", 0.0, 100.0)
    by = Message("g", "by", (2.0, 1.0), "low", 0.0, 1000.0)
    far = Message("h", "far", (0.0, 5.0), "low", 0.0, 1000.0)
    behind = Message("k", "behind", (-2.0, 0.0), "low", 0.0, 1000.0)
    # detour via g: sqrt(5) + sqrt(65) - 10 = 0.30 s; h is 5 m away, beyond near = 3 m
    decision = manager(primary, by, far, behind, detour=3.0).update((0.0, 0.0), 0.0)
    assert (decision.target, decision.reason) == (by, "opportunistic")
    # detour via k: 2 + 12 - 10 = 4 s > 3 s
    assert manager(primary, far, behind, detour=3.0).update((0.0, 0.0), 0.0).target == primary


def test_goals_arrive_on_time_are_delivered_nearby_and_miss_their_deadlines() -> None:
    goal = Message("p", "east", (3.0, 0.0), "normal", 2.0, 100.0)
    tight = Message("t", "west", (-10.0, 0.0), "high", 0.0, 5.0)
    soon = Message("s", "north", (0.0, 1.0), "low", 0.0, 3.0)
    goals = manager(goal, tight, soon)
    first = goals.update((0.0, 0.0), 1.0)
    # p has not arrived; t needs 10 s with 4 left; s is 1 m away with 2 s left
    assert [m.id for m in first.arrived] == ["s", "t"]
    assert [(m.message.id, m.why) for m in first.missed] == [("t", "infeasible")]
    assert first.target == soon
    second = goals.update((0.0, 0.0), 3.5)
    assert [m.id for m in second.arrived] == ["p"]
    assert [(m.message.id, m.why) for m in second.missed] == [("s", "expired")]
    third = goals.update((2.7, 0.0), 7.0)
    assert [(d.message.id, d.at, d.time) for d in third.delivered] == [("p", 7.0, 5.0)]
    assert third.target is None and goals.pending == ()
    late = Message("z", "far", (50.0, 0.0), "low", 8.0, 500.0)
    goals.receive([late])
    assert [m.message.id for m in goals.close(7.5)] == ["z"]
    rows = goals.records()
    assert [(r["id"], r["missed"]) for r in rows] == [("s", "expired"), ("t", "infeasible"),
                                                      ("p", ""), ("z", "unfinished")]
    assert rows[2]["time"] == 5.0
    with pytest.raises(ValueError, match="received before"):
        goals.receive([goal])


# --- the global map ------------------------------------------------------------------------

ROOM = World(bounds=(0.0, 0.0, 10.0, 6.0), walls=(Wall((5.0, 0.0), (5.0, 4.0)),),
             landmarks=(Landmark("sign", 2.0, 5.0, 0.1),))
"""A 10 x 6 m room halved by a wall from the floor up to y = 4, open above it."""
AHEAD = np.array([0.0])


def test_echoes_the_walls_do_not_explain_become_objects_after_two_sightings_and_fade() -> None:
    gmap = GlobalMap(ROOM, fade=1.0, clearing=False)
    pose = Pose(1.0, 3.0, 0.0)
    # the wall lies 4 m ahead, 3.75 m from the rim; an echo at 1.5 m ends at x = 2.75
    assert gmap.update(pose, [1.5], AHEAD, 0.0) == MapChange(0, 0)
    assert gmap.update(pose, [1.5], AHEAD, 0.1) == MapChange(1, 0)
    assert gmap.object_points().tolist() == [[2.875, 3.125]]
    # the wall's own echo (within 0.3 m of 3.75) and no echo at all add nothing
    assert gmap.update(pose, [3.6], AHEAD, 0.2) == MapChange(0, 0)
    assert gmap.update(pose, [3.6], AHEAD, 0.3) == MapChange(0, 0)
    assert gmap.update(pose, [5.0], AHEAD, 1.1) == MapChange(0, 0)
    assert gmap.objects_near((2.5, 3.0)) == ["landmark", "object"]
    assert gmap.objects_near((9.0, 1.0), 1.0) == []
    assert gmap.update(pose, [5.0], AHEAD, 1.2) == MapChange(0, 1)
    # a sighting long after the last one is fresh evidence, not a confirmation
    assert gmap.update(pose, [1.5], AHEAD, 5.0) == MapChange(0, 0)
    with pytest.raises(ValueError, match="back in time"):
        gmap.update(pose, [1.5], AHEAD, 4.0)


def test_a_beam_reaching_past_an_object_clears_it() -> None:
    pose = Pose(1.0, 3.0, 0.0)
    for reading, first in ((1.9, MapChange(0, 0)), (2.1, MapChange(0, 1))):
        gmap = GlobalMap(ROOM)
        for t in (0.0, 0.1):
            gmap.update(pose, [1.5], AHEAD, t)
        # the object's cell spans 1.75 to 2.0 m from the centre; clearing stops a tolerance
        # and a cell (0.55 m) short of the echo at 0.25 + reading, sampling from 0.25 m in
        # steps of 0.125 m: after 1.9 it stops before 1.75, after 2.1 it samples 1.75
        assert gmap.update(pose, [reading], AHEAD, 0.2) == first
        # either way the new echo, a cell or two farther, is confirmed the second time
        assert gmap.update(pose, [reading], AHEAD, 0.3) == MapChange(1, 0)
        assert len(gmap.object_points()) == (2 if reading == 1.9 else 1)


def test_a_transient_object_shows_on_the_map_and_slanted_walls_do_not() -> None:
    cart = Mover(((3.0, 2.0),), speed=0.0, radius=0.3, kind="object")
    world = World(bounds=ROOM.bounds, walls=ROOM.walls, landmarks=ROOM.landmarks,
                  movers=(cart,))
    ring = SonarRing()
    rng = np.random.default_rng(0)
    gmap = GlobalMap(ROOM)
    for k, pose in enumerate([Pose(1.2, 1.5, 0.3), Pose(1.3, 1.6, 0.2), Pose(1.4, 1.6, 0.0),
                              Pose(4.0, 5.0, -0.5), Pose(4.1, 5.0, -0.6)]):
        sonar = ring.read(pose, world.segments_at(0.0), world.discs_at(0.0), rng)
        gmap.update(pose, sonar, ring.directions, 0.1 * k)
    points = gmap.object_points()
    assert len(points) > 0
    # an echo sits on its beam's axis at the cone's nearest range: within the cart's radius,
    # the cone's half-width at 2 m (0.54 m) and half a cell's diagonal (0.18 m) of it
    assert np.hypot(points[:, 0] - 3.0, points[:, 1] - 2.0).max() < 1.1


def test_the_raster_blocks_the_walls_and_weighs_the_objects_within_the_robot_radius() -> None:
    gmap = GlobalMap(ROOM, cell=0.25)
    empty = gmap.raster(0.2)
    xs = (np.arange(empty.width) + 0.5) * 0.2
    ys = (np.arange(empty.height) + 0.5) * 0.2
    walls = np.array([[clearance(x, y, ROOM.static_segments, ROOM.static_discs) < 0.25
                       for x in xs] for y in ys])
    assert np.array_equal(empty.risk, walls.astype(float))
    pose = Pose(1.0, 3.0, 0.0)
    for t in (0.0, 0.1):
        gmap.update(pose, [1.5], AHEAD, t)
    # the object's cell is the square [2.75, 3.0] x [3.0, 3.25]
    dx = np.maximum(np.abs(xs[None, :] - 2.875) - 0.125, 0.0)
    dy = np.maximum(np.abs(ys[:, None] - 3.125) - 0.125, 0.0)
    near = (np.hypot(dx, dy) < 0.25) & ~walls
    grid = gmap.raster(0.2)
    assert near.any()
    assert np.array_equal(grid.risk, np.where(walls, 1.0, np.where(near, 0.5, 0.0)))
    # a step cost factor of 10 near the object
    assert np.all(grid.factor[near] == 10.0)
    blocking = GlobalMap(ROOM, transient_cost=math.inf)
    for t in (0.0, 0.1):
        blocking.update(pose, [1.5], AHEAD, t)
    assert np.array_equal(~blocking.raster(0.2).passable, walls | near)


@pytest.fixture
def planner(cbr_plugins: Callable[..., Plugins]) -> Callable[[GlobalMap], GridPlanner]:
    cbr_plugins(entry_points=True, environ={"CBR_PLUGINS": "core,grid,solvers"})

    def build(gmap: GlobalMap) -> GridPlanner:
        ctx = Context(registry=current().registry, seed=0, world=gmap.raster(gmap.plan_cell))
        return planner_of("astar", ctx, "test")

    return build


def test_a_route_goes_round_the_wall_in_sight_of_each_waypoint(
        planner: Callable[[GlobalMap], GridPlanner]) -> None:
    gmap = GlobalMap(ROOM)
    astar = planner(gmap)
    route = gmap.route(astar, (1.0, 1.0), (9.0, 1.0))
    assert route is not None
    assert route[0] == pytest.approx((1.1, 1.1)) and route[-1] == pytest.approx((9.1, 1.1))
    for a, b in itertools.pairwise(route):
        assert math.dist(a, b) <= 1.0 + 1e-9
        for u in np.linspace(0.0, 1.0, 20):
            x, y = a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])
            # free cells' centres keep 0.25 m; a chord through them strays by half a diagonal
            assert clearance(x, y, ROOM.static_segments, ROOM.static_discs) > 0.25 - 0.15
    # at least round the wall's end (5, 4); at most that taut path kept 0.25 m away, plus 8 %
    # for the raster's steps
    length = gmap.route_length(astar, (1.0, 1.0), (9.0, 1.0))
    assert 2 * math.dist((1.1, 1.1), (5.0, 4.0)) <= length
    assert length <= 1.08 * 2 * math.dist((1.1, 1.1), (5.0, 4.25))
    via = gmap.route(astar, (1.0, 1.0), (9.0, 1.0), via=[(8.0, 5.0)])
    assert via is not None and (8.1, 5.1) in [pytest.approx(p) for p in via]
    # a start against the wall moves to the nearest free cell within 0.5 m
    snapped = gmap.route(astar, (4.9, 1.0), (1.0, 1.0))
    assert snapped is not None and math.dist(snapped[0], (4.9, 1.0)) <= 0.5


def test_no_route_through_a_closed_wall(planner: Callable[[GlobalMap], GridPlanner]) -> None:
    closed = World(bounds=ROOM.bounds, walls=(Wall((5.0, 0.0), (5.0, 6.0)),))
    gmap = GlobalMap(closed)
    astar = planner(gmap)
    assert gmap.route(astar, (1.0, 1.0), (9.0, 1.0)) is None
    assert gmap.route_length(astar, (1.0, 1.0), (9.0, 1.0)) == math.inf
    assert gmap.route(astar, (1.0, 1.0), (11.0, 1.0)) is None


def test_a_route_goes_round_an_object_or_through_it_when_it_must(
        planner: Callable[[GlobalMap], GridPlanner]) -> None:
    hall = World(bounds=(0.0, 0.0, 10.0, 6.0))
    door = World(bounds=hall.bounds, walls=(Wall((5.0, 0.0), (5.0, 2.5)),
                                            Wall((5.0, 3.5), (5.0, 6.0))))
    # an echo 1.375 m ahead of (3.5, 3) ends at x = 5.125: the object cell [5, 5.25] x
    # [3, 3.25], in the open or in the 1 m doorway, whose jambs lie 18 degrees off the beam,
    # outside its 15 degree half-cone
    pose = Pose(3.5, 3.0, 0.0)
    routes = []
    for world, cost in ((hall, 10.0), (door, 10.0), (door, math.inf)):
        gmap = GlobalMap(world, transient_cost=cost)
        for t in (0.0, 0.1):
            gmap.update(pose, [1.375], AHEAD, t)
        assert gmap.object_points().tolist() == [[5.125, 3.125]]
        routes.append((gmap, gmap.route(planner(gmap), (1.0, 3.0), (9.0, 3.0))))
    (gmap, around), (_, through), (_, blocked) = routes
    assert around is not None and through is not None and blocked is None
    grid = gmap.raster(gmap.plan_cell)
    for a, b in itertools.pairwise(around):
        for u in np.linspace(0.0, 1.0, 20):
            x, y = a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])
            assert grid.risk[int(y / 0.2), int(x / 0.2)] == 0.0


# --- triggers --------------------------------------------------------------------------------

TARGET = (10.0, 0.0)


def snap(t: float = 1.0, x: float = 0.0, **fields: Any) -> Snapshot:
    fields.setdefault("sonar", [2.0] * 16)
    return Snapshot(t=t, pose=Pose(x, 0.0, 0.0), **fields)


def monitor(**baseline: Any) -> ReplanMonitor:
    # every event counts and nothing waits, so each test sees one trigger alone
    replan = ReplanMonitor(TriggerOptions(map_cells=1, hold=0.0))
    replan.retrieved(snap(t=0.0, **baseline))
    return replan


def test_before_any_retrieval_the_period_has_passed() -> None:
    assert ReplanMonitor().check(snap()) == ["period"]
    assert ReplanMonitor().check(snap(critical=1)) == ["message"]


def test_situation_fires_when_a_feature_moved_over_the_threshold() -> None:
    calm = np.full(len(SITUATION), 0.5)
    person = calm.copy()
    person[SITUATION.index("person")] = 0.1  # a person 0.4 nearer: over the 0.35
    drift = calm + 0.3  # every feature 0.3 off: none over it
    replan = monitor(situation=calm)
    # it must stay moved for the settle second
    assert replan.check(snap(t=1.0, situation=person)) == []
    assert replan.check(snap(t=1.5, situation=person)) == []
    assert replan.check(snap(t=2.0, situation=person)) == ["situation"]
    flicker = monitor(situation=calm)
    assert flicker.check(snap(t=1.0, situation=person)) == []
    assert flicker.check(snap(t=1.5, situation=calm)) == []
    assert flicker.check(snap(t=2.0, situation=person)) == []
    assert monitor(situation=calm).check(snap(t=3.0, situation=drift)) == []
    # the raw sonar alone fires nothing: a flicker is no change of situation
    assert monitor(situation=calm).check(snap(t=3.0, situation=calm, sonar=[0.0] * 16)) == []


@pytest.mark.parametrize(("event", "name"), [
    ({"added": 1}, "map"), ({"removed": 2}, "map"), ({"critical": 1}, "message"),
    ({"plan_installed": True}, "plan")])
def test_an_event_fires_until_the_next_retrieval(event: dict[str, Any], name: str) -> None:
    replan = monitor()
    assert replan.check(snap(**event)) == [name]
    assert replan.check(snap(t=2.0)) == [name]
    replan.retrieved(snap(t=2.0, **event))
    assert replan.check(snap(t=3.0)) == []


def test_impasse_fires_without_progress_over_a_window_or_when_the_robot_gets_stuck() -> None:
    replan = monitor(target=TARGET)
    assert replan.check(snap(t=5.0, target=TARGET)) == []
    # 0.1 m closer in 10 s, under the 0.2 m of progress
    assert replan.check(snap(t=10.0, x=0.1, target=TARGET)) == ["impasse"]
    moving = monitor(target=TARGET)
    moving.check(snap(t=5.0, x=0.1, target=TARGET))
    assert moving.check(snap(t=10.0, x=0.3, target=TARGET)) == []
    # a new target starts a new window
    turned = monitor(target=TARGET)
    assert turned.check(snap(t=10.0, target=(0.0, 10.0))) == []
    assert monitor().check(snap(status="blocked")) == ["impasse"]
    assert monitor(status="oscillating").check(snap(status="blocked")) == []


def test_location_fires_below_the_floor_or_on_a_drop() -> None:
    assert monitor(confidence=0.9).check(snap(confidence=0.45)) == ["location"]
    assert monitor(confidence=0.9).check(snap(confidence=0.75)) == []
    assert monitor(confidence=0.9).check(snap(confidence=0.65)) == ["location"]
    assert monitor(confidence=0.4).check(snap(confidence=0.35)) == []


def test_period_fires_on_time_or_distance_only_when_nothing_else_does() -> None:
    assert monitor().check(snap(t=19.9, distance=5.9)) == []
    assert monitor().check(snap(t=20.0)) == ["period"]
    assert monitor().check(snap(distance=6.0)) == ["period"]
    assert monitor().check(snap(t=20.0, added=1)) == ["map"]


def test_map_fires_once_enough_cells_changed() -> None:
    replan = ReplanMonitor(TriggerOptions(map_cells=4, hold=0.0))
    replan.retrieved(snap(t=0.0))
    assert "map" not in replan.check(snap(t=0.1, added=2))
    assert "map" not in replan.check(snap(t=0.2, removed=1))
    assert "map" in replan.check(snap(t=0.3, added=1))  # 2 + 1 + 1 = 4 cells


def situation_with(person: float, bearing: float) -> np.ndarray:
    """Every situation feature 1 (nothing near) but the person ``person`` metres off,
    ``bearing`` degrees from the heading."""
    values = np.ones(len(SITUATION))
    values[SITUATION.index("person")] = person / 5.0
    values[SITUATION.index("person-bearing")] = bearing / 180.0
    return values


def test_person_fires_at_once_when_someone_comes_into_the_way() -> None:
    clear = situation_with(5.0, 180.0)
    replan = ReplanMonitor(TriggerOptions(hold=12.0))
    replan.retrieved(snap(t=0.0, situation=clear))
    # 1.4 m ahead, 50 degrees off: within 1.5 m and 60 degrees, inside the hold
    assert replan.check(snap(t=0.5, situation=situation_with(1.4, 50.0))) == ["person"]
    # beside the robot, or farther, is not in the way
    for person, bearing in ((1.0, 70.0), (1.6, 0.0)):
        aside = ReplanMonitor(TriggerOptions(hold=12.0))
        aside.retrieved(snap(t=0.0, situation=clear))
        assert aside.check(snap(t=0.5, situation=situation_with(person, bearing))) == []
    # critical once per hold: the next person stepping into the way waits for the hold
    replan.retrieved(snap(t=0.6, situation=clear))
    assert replan.check(snap(t=1.0, situation=situation_with(1.0, 0.0))) == []
    assert "person" in replan.check(snap(t=12.6, situation=situation_with(1.0, 0.0)))
    # someone already in the way at the retrieval fires nothing more
    stays = ReplanMonitor(TriggerOptions(hold=12.0))
    stays.retrieved(snap(t=0.0, situation=situation_with(1.0, 10.0)))
    assert stays.check(snap(t=0.5, situation=situation_with(0.5, 0.0))) == []


def test_within_the_hold_only_the_critical_triggers_fire() -> None:
    replan = ReplanMonitor(TriggerOptions(map_cells=1, hold=5.0))
    replan.retrieved(snap(t=0.0))
    assert replan.check(snap(t=0.5, added=3, critical=1, plan_installed=True)) == ["message"]
    # an event fires until the next retrieval
    assert replan.check(snap(t=1.0, status="blocked")) == ["message", "impasse"]
    assert replan.check(snap(t=4.9)) == ["message"]
    # the others are remembered until the hold is over
    assert replan.check(snap(t=5.0)) == ["map", "message", "plan"]


def test_no_impasse_while_waiting_before_a_shut_door() -> None:
    replan = monitor(target=TARGET)
    for t in (2.0, 5.0, 8.0, 10.0, 12.0):
        assert "impasse" not in replan.check(snap(t=t, target=TARGET, waiting=True))
    assert replan.check(snap(t=12.0, target=TARGET, status="blocked", waiting=True)) == []
    # the window starts when the waiting ends
    assert "impasse" not in replan.check(snap(t=21.0, target=TARGET))
    assert "impasse" in replan.check(snap(t=22.0, target=TARGET))


def test_no_impasse_while_idle() -> None:
    replan = monitor(target=TARGET, busy=False)
    for t in (5.0, 10.0, 19.0):
        assert replan.check(snap(t=t, target=TARGET, busy=False)) == []
    assert replan.check(snap(t=19.5, target=TARGET, status="blocked", busy=False)) == []
    # the window starts when a message makes the robot busy
    assert "impasse" not in replan.check(snap(t=29.0, target=TARGET))
    assert "impasse" in replan.check(snap(t=29.5, target=TARGET))


def test_a_retrieval_does_not_restart_the_impasse_window_and_an_impasse_does() -> None:
    replan = monitor(target=TARGET)
    replan.check(snap(t=5.0, target=TARGET))
    replan.retrieved(snap(t=5.0, target=TARGET))  # another trigger's retrieval
    assert replan.check(snap(t=10.0, x=0.1, target=TARGET)) == ["impasse"]
    replan.retrieved(snap(t=10.0, x=0.1, target=TARGET))
    # stuck still: told again only once the next window has passed
    assert replan.check(snap(t=15.0, x=0.1, target=TARGET)) == []
    assert replan.check(snap(t=20.0, x=0.1, target=TARGET)) == ["impasse"]
