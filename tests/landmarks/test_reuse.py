"""Safe reuse of landmark cases and positive cases (``cbr_landmarks.reach``, the ``landmarks``
reuser and the ``landmark_trouble`` retainer).

The geometry is checked against figures worked out by hand: a U of three walls whose inside is
its rectangle, a single wall whose way round passes the waypoints beside its end. The reuser is
checked on 002's kind of trap turned: a U turned 40 degrees seen from the start, with a case
that lays its diverting target inside the U (refused: the point, taken back into the U's own
frame, lies inside its rectangle) and one that lays it outside (used); a diversion is given up
after the time its way takes; a target that failed is not used again in the trial. The
retainer learns a positive case from a consultation that needed no action when nothing went
wrong after it, and none when trouble came.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import attrs
import numpy as np
import pytest
import yaml

import cbr_landmarks
import cbr_world2d
import cbrcore.builtins
from cbr_landmarks.action import DivertAction
from cbr_landmarks.case import SITUATION, LandmarkCase
from cbr_landmarks.components import FAILED, linked
from cbr_landmarks.problem import RegionOptions, problem_view
from cbr_landmarks.reach import (
    Way,
    crossing,
    distance_to_walls,
    hull,
    inside_chain,
    known_walls,
    narrow_gaps,
    outline,
    route,
    way,
)
from cbr_world2d.actions import GIVEN_UP, REACHED, ActionReport, Divert, GiveUp
from cbr_world2d.navigator import Navigator
from cbr_world2d.pilots import PotentialFieldOptions, potential_field_pilot
from cbr_world2d.pilots.rescuer import Rescuer
from cbr_world2d.robot import PIONEER_2DX, Pose, RobotState
from cbr_world2d.sensors import Camera, Sensors
from cbr_world2d.simulation import Simulation
from cbr_world2d.workload import Situation, situation
from cbr_world2d.world import World
from cbr_world2d.worldfile import load_world, world_from_data
from cbrcore.config import parse_config
from cbrcore.engine import Engine
from cbrcore.model import Outcome, Proposal
from cbrcore.plugins import Plugins, load_plugins
from repo_paths import ROOT

# --- the geometry, by hand ----------------------------------------------------------------------

# a U open towards -x: a(2, 0) - b(4, 0) - c(4, 2) - d(2, 2); its inside is the rectangle
U_WALLS = np.array([[[2.0, 0.0], [4.0, 0.0]], [[4.0, 0.0], [4.0, 2.0]],
                    [[4.0, 2.0], [2.0, 2.0]]])
U_PAIRS = [("a", "b"), ("b", "c"), ("c", "d")]


@pytest.mark.parametrize(("point", "inside"), [
    ((3.0, 1.0), True), ((2.1, 1.9), True), ((1.0, 1.0), False), ((5.0, 1.0), False),
    ((3.0, -0.5), False), ((3.0, 2.0), False)])
def test_a_point_is_inside_a_chain_when_inside_the_hull_of_its_landmarks(
        point: tuple[float, float], inside: bool) -> None:
    assert inside_chain(point, U_WALLS, U_PAIRS) is inside


def test_a_single_wall_or_a_straight_chain_has_no_inside() -> None:
    straight = np.array([[[0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [2.0, 0.0]]])
    assert len(hull(straight.reshape(-1, 2))) == 2
    assert not inside_chain((1.0, 0.0), straight, [("a", "b"), ("b", "c")])
    # two walls that share no landmark are two chains of one wall each: no inside either
    assert not inside_chain((3.0, 1.0), U_WALLS[[0, 2]], [("a", "b"), ("c", "d")])


def test_distances_and_crossings_of_walls() -> None:
    points = np.array([[3.0, -0.2], [5.0, 1.0], [1.0, 3.0]])
    assert distance_to_walls(points, U_WALLS) == pytest.approx([0.2, 1.0, math.sqrt(2.0)])
    starts = np.array([[1.0, 1.0], [1.0, 1.0], [3.0, 1.0]])
    ends = np.array([[5.0, 1.0], [1.5, 3.0], [2.0, 2.0]])
    # through the closed end; clear of the U; out of the U through its corner d, between the
    # two walls that meet there: touching counts
    assert crossing(starts, ends, U_WALLS).tolist() == [True, False, True]
    # along a wall, through both its ends
    assert crossing(np.array([[1.0, 0.0]]), np.array([[5.0, 0.0]]), U_WALLS).tolist() == [True]


def test_the_way_round_a_wall_passes_the_waypoints_beside_its_end() -> None:
    """A wall from (0, -1) to (0, 1) between (-1, 0) and (1, 0), clearance 0.5: the waypoints
    stand 1 m from each end in eight directions; a leg must pass the wall's end 0.5 m off, so
    the straight legs to (0, 2) (0.45 m off the end) do not count and the shortest way is
    (-1, 0), (-1, 1), (0, 2), (1, 1), (1, 0) (or its mirror below), 2 + 2 sqrt(2) m, its
    diagonal legs 0.71 m off the end."""
    wall, pairs = np.array([[[0.0, -1.0], [0.0, 1.0]]]), [("p", "q")]
    length, via = route((-1.0, 0.0), (1.0, 0.0), wall, 0.5)
    assert length == pytest.approx(2.0 + 2.0 * math.sqrt(2.0))
    side = math.copysign(1.0, via[1][1])
    assert np.allclose(via, [(-1.0, side), (0.0, 2.0 * side), (1.0, side)])
    found = way((-1.0, 0.0), (1.0, 0.0), wall, pairs, 0.5, 3.0)
    assert (found.metres, found.how, found.via) == (pytest.approx(length), "route", via)
    assert way((-1.0, 0.0), (1.0, 0.0), wall, pairs, 0.5, 1.5).metres is None
    assert way((-1.0, 0.0), (-1.0, 3.0), wall, pairs, 0.5, 1.5) == Way(3.0, "line of sight")
    too_near = way((-1.0, 0.0), (0.2, 0.5), wall, pairs, 0.5, 3.0)
    assert (too_near.metres, too_near.how) == (None, "within 0.5 m of a known wall")


# a wall with a gap: (0, -3) - (0, -0.5), then (0, 0.5) - (0, 1), 1 m between their ends
GAP_WALLS = np.array([[[0.0, -3.0], [0.0, -0.5]], [[0.0, 0.5], [0.0, 1.0]]])


def test_narrow_gaps_join_ends_to_the_nearest_point_of_another_wall_or_post() -> None:
    assert narrow_gaps(GAP_WALLS, 1.5) == pytest.approx(np.array([[[0.0, -0.5], [0.0, 0.5]]]))
    assert len(narrow_gaps(GAP_WALLS, 1.0)) == 0  # exactly the passage is no narrow gap
    # joined walls meet in no gap; the end of a wall 0.5 m from the middle of another
    corner = np.array([[[0.0, 0.0], [4.0, 0.0]], [[4.0, 0.0], [4.0, 4.0]],
                       [[2.0, 0.5], [2.0, 3.0]]])
    assert narrow_gaps(corner, 1.5) == pytest.approx(np.array([[[2.0, 0.0], [2.0, 0.5]]]))
    # a post 1.2 m beyond the short wall's end closes that gap too; one within 0.2 m of an
    # end is that end
    posts = np.array([[0.0, 2.2], [0.1, 1.05]])
    assert narrow_gaps(GAP_WALLS, 1.5, posts) == pytest.approx(np.array([
        [[0.0, -0.5], [0.0, 0.5]], [[0.0, 1.0], [0.0, 2.2]]]))


def test_a_way_goes_round_a_narrow_gap_and_through_it_square_only_when_it_must() -> None:
    """From (-1, 0) to (1, 0) past GAP_WALLS (clearance 0.3): with gaps open the way goes
    straight through the 1 m gap; with a passage of 1.5 m round the short wall's free end
    (1 m above the gap); with the long wall reaching the arena's side below and a post closing
    the way above, only through the gap, entering and leaving it square: by its gate points
    0.6 m either side of its middle."""
    assert route((-1.0, 0.0), (1.0, 0.0), GAP_WALLS, 0.3) == (pytest.approx(2.0), ())
    length, via = route((-1.0, 0.0), (1.0, 0.0), GAP_WALLS, 0.3, 1.5)
    assert min(y for _, y in via) > 1.0 and length > 2.0
    assert not crossing(np.array([(-1.0, 0.0), *via]), np.array([*via, (1.0, 0.0)]),
                        np.concatenate((GAP_WALLS, narrow_gaps(GAP_WALLS, 1.5)))).any()
    closed = np.concatenate((GAP_WALLS, outline((-3.0, -3.0, 3.0, 3.0))))
    length, via = route((-1.0, 0.0), (1.0, 0.0), closed, 0.3, 1.5, np.array([[0.0, 2.0]]))
    assert via == (pytest.approx((-0.6, 0.0)), pytest.approx((0.6, 0.0)))
    assert length == pytest.approx(2.0)
    # the straight way through the narrow gap is no line of sight
    found = way((-1.0, 0.0), (1.0, 0.0), GAP_WALLS, [("a", "b"), ("c", "d")], 0.3, 3.0, 1.5)
    assert found.how == "route" and min(y for _, y in found.via) > 1.0


def test_the_known_walls_are_the_map_and_the_arena() -> None:
    sides = outline((0.0, 0.0, 4.0, 3.0))
    assert sides.tolist() == [[[0, 0], [4, 0]], [[4, 0], [4, 3]], [[4, 3], [0, 3]],
                              [[0, 3], [0, 0]]]
    assert outline(None).shape == (0, 2, 2)
    problem = Situation(0, 0.0, "landmarks", Pose(1.0, 1.0, 0.0), (3.0, 2.0), (), (),
                        np.zeros(0), np.zeros(0), False, 1.0,
                        walls=(((2.0, 0.5), (2.0, 2.5)),), bounds=(0.0, 0.0, 4.0, 3.0))
    assert known_walls(problem).tolist() == [[[2.0, 0.5], [2.0, 2.5]], *sides.tolist()]


def test_a_target_inside_the_u_is_refused_however_short_the_way_in() -> None:
    assert way((1.0, 1.0), (3.0, 1.0), U_WALLS, U_PAIRS, 0.3, 3.0) == Way(
        None, "inside a known obstacle chain")


def test_a_diversion_may_have_its_own_give_up_time() -> None:
    rescuer = Rescuer(target=(9.0, 9.0))
    rescuer.divert((5.0, 5.0), t=10.0, give_up=30.0)
    assert rescuer.update(0.0, 0.0, 39.9) is None
    assert rescuer.update(0.0, 0.0, 40.0).reason == GIVEN_UP
    rescuer.divert((5.0, 5.0), t=10.0)  # the Rescuer's own give_up, 120 s
    assert rescuer.update(0.0, 0.0, 129.9) is None
    assert rescuer.update(0.0, 0.0, 130.0).reason == GIVEN_UP
    # 002's robot: 5 m at 5 cm/s is 100 s, twice that and 30 s more
    assert GiveUp(5.0, 2.0, 30.0).seconds(0.05) == pytest.approx(230.0)


def divert_in_open_space(divert: Divert, steps: int = 3000) -> tuple[str | None, Simulation]:
    """Start ``divert`` on a Pioneer at (1, 5) facing (9, 5) in an empty 10 m square, and step
    until it ends; why it ended, and the simulation."""
    world = World((0.0, 0.0, 10.0, 10.0), name="open")
    pilot = potential_field_pilot(PotentialFieldOptions(), None)  # type: ignore[arg-type]
    sim = Simulation(world, PIONEER_2DX, Sensors().fitted(PIONEER_2DX.radius), Navigator(pilot),
                     Pose(1.0, 5.0, 0.0), (9.0, 5.0))
    sim.step()
    divert.start(sim)
    for _ in range(steps):
        sim.step()
        reason = divert.ended(sim)
        if reason is not None:
            return reason, sim
    return None, sim


def test_a_diversion_through_waypoints_reaches_each_in_turn() -> None:
    reason, sim = divert_in_open_space(Divert(5.0, 8.0, via=((2.0, 8.0),)))
    assert reason == REACHED
    tolerance = sim.navigator.rescuer.options.tolerance
    diverted = [e.point for e in sim.history if e.name == "diverted"]
    assert diverted == [(2.0, 8.0), (5.0, 8.0)]
    path = sim.trajectory[:, 1:3]
    near_via = np.flatnonzero(np.hypot(*(path - (2.0, 8.0)).T) <= tolerance + 1e-9)
    near_end = np.flatnonzero(np.hypot(*(path - (5.0, 8.0)).T) <= tolerance + 1e-9)
    assert near_via.size and near_end.size and near_via[0] < near_end[0]
    assert not sim.navigator.diverting


def test_a_diversion_is_given_up_when_its_time_for_the_whole_way_is_out() -> None:
    # 1 m at the Pioneer's 0.75 m/s: 4/3 s; the way is far longer
    reason, sim = divert_in_open_space(Divert(9.0, 9.0, GiveUp(1.0, 1.0, 0.0),
                                              via=((1.0, 9.0),)))
    assert reason == GIVEN_UP
    assert sim.t == pytest.approx(1.0 / PIONEER_2DX.max_speed + sim.dt, abs=2 * sim.dt)


def test_a_diversion_blocked_on_its_way_is_given_up_at_once() -> None:
    """A wall across the whole square at x = 3 stands between the robot and a diverting point
    at (5, 5), whose way is given 1000 s: the robot stops at the wall, the monitor reports it
    blocked one window after, and the diversion is given up then, the original target back."""
    world = world_from_data({"bounds": [0, 0, 10, 10], "walls": [{"a": [3, 0], "b": [3, 10]}]},
                            "walled")
    pilot = potential_field_pilot(PotentialFieldOptions(), None)  # type: ignore[arg-type]
    sim = Simulation(world, PIONEER_2DX, Sensors().fitted(PIONEER_2DX.radius), Navigator(pilot),
                     Pose(1.0, 5.0, 0.0), (9.0, 5.0))
    sim.step()
    divert = Divert(5.0, 5.0, GiveUp(1000.0, 1.0, 0.0))
    divert.start(sim)
    reason = None
    while reason is None and sim.t < 200.0:
        sim.step()
        reason = divert.ended(sim)
    assert reason == GIVEN_UP
    assert any(e.name == "blocked" for e in sim.history)
    assert sim.navigator.current_target == (9.0, 5.0) and not sim.navigator.diverting
    assert sim.t < 100.0 and sim.trajectory[-1, 1] < 3.0


# --- the reuser on a U turned 40 degrees ----------------------------------------------------------

TURN = math.radians(40.0)
CENTRE = (5.2, 4.0)
SIZE, HALF = 2.6, 1.25
U_SHAPE = [(-SIZE, HALF), (0.0, HALF), (0.0, -HALF), (-SIZE, -HALF)]
"""The U of the generated scenarios (:func:`cbr_world2d.generate.scenario`), open towards the
start, in its own frame."""


def u_world(path: Path) -> Path:
    c, s = math.cos(TURN), math.sin(TURN)
    marks = [[round(CENTRE[0] + c * x - s * y, 4), round(CENTRE[1] + s * x + c * y, 4)]
             for x, y in U_SHAPE]
    data = {"name": "U turned 40", "bounds": [0.0, 0.0, 11.0, 8.0],
            "landmarks": [{"id": f"l{k + 1}", "at": m, "radius": 0.15}
                          for k, m in enumerate(marks)],
            "walls": [{"between": [f"l{k + 1}", f"l{k + 2}"]} for k in range(3)],
            "places": {"start": [1.0, 4.0], "target": [10.0, 4.0]}}
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def in_u_frame(point: tuple[float, float]) -> tuple[float, float]:
    """``point`` in the U's own frame (undoing the turn about its centre)."""
    dx, dy = point[0] - CENTRE[0], point[1] - CENTRE[1]
    c, s = math.cos(TURN), math.sin(TURN)
    return c * dx + s * dy, -s * dx + c * dy


def inside_u(point: tuple[float, float]) -> bool:
    x, y = in_u_frame(point)
    return -SIZE < x < 0.0 and abs(y) < HALF


def to_world(point: tuple[float, float]) -> tuple[float, float]:
    c, s = math.cos(TURN), math.sin(TURN)
    return (CENTRE[0] + c * point[0] - s * point[1], CENTRE[1] + s * point[0] + c * point[1])


INSIDE = to_world((-1.6, 0.5))
OUTSIDE = to_world((1.0, 2.5))
OUTSIDE_TOO = to_world((1.0, 3.1))


@pytest.fixture(scope="module")
def plugins() -> Plugins:
    return load_plugins(extra=[("core", cbrcore.builtins), ("world2d", cbr_world2d),
                               ("landmarks", cbr_landmarks)], entry_points=False, environ={})


@pytest.fixture(scope="module")
def world_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return u_world(tmp_path_factory.mktemp("u") / "u.yaml")


def engine_for(plugins: Plugins, world_file: Path, reuse: dict[str, Any] | None = None,
               retain: dict[str, Any] | None = None) -> Engine:
    config: dict[str, Any] = {
        "seed": 0, "world": {"use": "world2d_file", "path": str(world_file)},
        "pilot": {"use": "potential_field"}, "casebase": "memory",
        "workload": {"use": "trials", "trials": [{"start": "start", "target": "target"}],
                     "robot": "ros2005"},
        "retrieve": "landmarks", "reuse": {"use": "landmarks", **(reuse or {})}}
    if retain is not None:
        config["retain"] = [{"use": "landmark_trouble", **retain}]
    return Engine(parse_config(config, plugins.registry), plugins=plugins)


def observe(world_file: Path, trigger: str = "landmarks", t: float = 0.0,
            at: tuple[float, float] | None = None) -> Situation:
    """What the robot sees, without noise, at ``at`` (default: the start) facing the target."""
    world = load_world(world_file)
    start = at or world.places["start"]
    target = world.places["target"]
    heading = math.atan2(target[1] - start[1], target[0] - start[0])
    sensors = Sensors(sonar=None, camera=Camera(fov=math.pi, noise=0.0))
    obs = sensors.observe(RobotState(start[0], start[1], heading), world, 0.0, False,
                          np.random.default_rng(0))
    return attrs.evolve(situation(world, 0, trigger, obs, target), t=t)


def case_toward(problem: Situation, point: tuple[float, float]) -> LandmarkCase:
    """A V case, as if learned in another world, that matches what the robot sees from the
    start of the U: the three landmarks it sees (l1, l2 and l4; the U's closed end hides l3),
    with walls l1-l2 (the one the robot sees) and l2-l4, a dead end of apex l2; its action
    diverts to ``point``."""
    view = problem_view(problem, RegionOptions())
    assert view is not None and view.graph.ids == ("l1", "l2", "l4")
    assert problem.obstacles == (("l1", "l2"),)
    graph = attrs.evolve(view.graph, obstacles={(0, 1), (1, 2)})
    world = view.world_points()
    places = {landmark: world[i] for i, landmark in enumerate(graph.ids)}
    return LandmarkCase(graph, DivertAction.toward(point, places, linked(graph)))


def solve_with(plugins: Plugins, world_file: Path, problem: Situation,
               targets: list[tuple[float, float]], reuse: dict[str, Any] | None = None
               ) -> Proposal:
    """The engine's proposal for ``problem`` with a V case toward each of ``targets`` stored,
    in that order (:func:`case_toward`)."""
    with engine_for(plugins, world_file, reuse) as engine:
        assert engine.casebase is not None
        for point in targets:
            engine.casebase.add(case_toward(problem, point).to_case())
        return engine.solve(problem)


def test_the_points_of_the_u_test_are_where_they_should_be() -> None:
    assert inside_u(INSIDE) and not inside_u(OUTSIDE) and not inside_u(OUTSIDE_TOO)
    assert math.dist(OUTSIDE, OUTSIDE_TOO) < 1.0
    # INSIDE lies in the triangle l1, l2, l4 (the V case's inside): in the U's frame above the
    # line from l2 (0, HALF) to l4 (-SIZE, -HALF)
    x, y = in_u_frame(INSIDE)
    assert x > -SIZE and HALF + x * (2 * HALF / SIZE) < y < HALF


@pytest.mark.parametrize("safe", [False, True])
def test_a_case_that_lays_its_target_inside_the_u_is_not_reused_when_safe(
        plugins: Plugins, world_file: Path, safe: bool) -> None:
    proposal = solve_with(plugins, world_file, observe(world_file), [INSIDE], {"safe": safe})
    if safe:
        assert proposal.solution is None and proposal.fallback_reason == "reuse failed"
    else:
        divert = proposal.solution.value
        assert inside_u((divert.x, divert.y))  # the trap the safe reuser keeps out of


def test_the_next_match_is_reused_when_the_best_lays_its_target_inside(
        plugins: Plugins, world_file: Path) -> None:
    problem = observe(world_file)
    proposal = solve_with(plugins, world_file, problem, [INSIDE, OUTSIDE])
    divert = proposal.solution.value
    assert isinstance(divert, Divert)
    assert (divert.x, divert.y) == pytest.approx(OUTSIDE, abs=1e-3)  # offsets kept to 0.1 mm
    # the straight way is clear: the give-up time follows the straight distance
    here = (problem.pose.x, problem.pose.y)
    assert proposal.solution.detail["way"] == "line of sight"
    assert divert.give_up is not None
    assert (divert.give_up.slack, divert.give_up.margin, divert.via) == (1.5, 30.0, ())
    assert divert.give_up.metres == pytest.approx(math.dist(here, OUTSIDE), abs=1e-3)


@pytest.mark.parametrize("needed", [False, True])
def test_a_case_is_not_reused_where_the_way_to_the_target_is_clear(
        plugins: Plugins, world_file: Path, needed: bool) -> None:
    """The same sighting, but the robot's target lies beside the start, the straight way to it
    clear of the U's wall and of the case's: the case is not needed there."""
    problem = attrs.evolve(observe(world_file), target=(1.0, 0.5))
    proposal = solve_with(plugins, world_file, problem, [OUTSIDE], {"needed": needed})
    if needed:
        assert proposal.solution is None and proposal.fallback_reason == "reuse failed"
    else:
        assert isinstance(proposal.solution.value, Divert)


def test_a_case_whose_walls_stand_where_the_robot_saw_the_way_open_is_not_reused(
        plugins: Plugins, world_file: Path) -> None:
    """The V case says l2-l4 is a wall; a robot whose map has seen the way between l2 and l4
    open does not take it."""
    problem = observe(world_file)
    solutions = [solve_with(plugins, world_file, attrs.evolve(problem, open=seen_open),
                            [OUTSIDE]).solution for seen_open in ((), (("l4", "l2"),))]
    assert isinstance(solutions[0].value, Divert) and solutions[1] is None


def test_a_target_behind_a_known_wall_is_reached_round_its_end(
        plugins: Plugins, world_file: Path) -> None:
    """Beyond the U's closed end the straight way crosses the wall l1-l2 the robot sees; the
    way round passes waypoints 0.6 m (twice the clearance) from l2, the wall's free end; the
    diversion is given up after the time of the whole way, and with ``follow`` the robot is
    led through the waypoints."""
    problem = observe(world_file)
    behind = to_world((1.0, 0.0))
    for follow in (False, True):
        with engine_for(plugins, world_file, {"follow": follow}) as engine:
            assert engine.casebase is not None
            engine.casebase.add(case_toward(problem, behind).to_case())
            proposal = engine.solve(problem)
        divert = proposal.solution.value
        assert proposal.solution.detail["way"] == "route"
        assert bool(divert.via) == follow  # without follow, straight at the target
    here = (problem.pose.x, problem.pose.y)
    for point in divert.via:
        assert math.dist(point, to_world(U_SHAPE[1])) == pytest.approx(0.6, abs=1e-3)
    legs = [here, *divert.via, (divert.x, divert.y)]
    assert divert.give_up.metres == pytest.approx(
        sum(math.dist(a, b) for a, b in itertools.pairwise(legs)), abs=1e-3)


def test_a_target_near_one_that_failed_is_not_used_again_in_the_trial(
        plugins: Plugins, world_file: Path) -> None:
    problem = observe(world_file)
    for reason, again in ((GIVEN_UP, False), (REACHED, True)):
        with engine_for(plugins, world_file, retain={}) as engine:
            assert engine.casebase is not None
            engine.casebase.add(case_toward(problem, OUTSIDE).to_case())
            engine.casebase.add(case_toward(problem, OUTSIDE_TOO).to_case())
            first = engine.solve(problem)
            report = ActionReport(reason, 0.0, 50.0, 2.0, 0)
            engine.learn(problem, first, Outcome(reason == REACHED, 50.0, report=report))
            later = attrs.evolve(problem, t=60.0)
            second = engine.solve(later)
            assert (second.solution is not None) is again, reason
            failed = engine.ctx.stash[FAILED]
            assert len(failed) == (reason == GIVEN_UP)
            # the next trial starts afresh
            assert engine.solve(attrs.evolve(problem, trial=1)).solution is not None


# --- positive cases -----------------------------------------------------------------------------


def quietly(engine: Engine, problem: Situation) -> Proposal:
    """Consult and learn at once that no action was taken, as the trials workload does."""
    proposal = engine.solve(problem)
    report = ActionReport("no_action", problem.t, problem.t, 0.0, 0)
    engine.learn(problem, proposal, Outcome(False, 0.0, report=report))
    return proposal


def stored(engine: Engine) -> list[LandmarkCase]:
    assert engine.casebase is not None
    return [LandmarkCase.from_case(c) for c in engine.casebase.cases(SITUATION)]


def test_a_quiet_consultation_becomes_a_positive_case_once_nothing_went_wrong(
        plugins: Plugins, world_file: Path) -> None:
    with engine_for(plugins, world_file, retain={"positive": 60.0, "keep": "all"}) as engine:
        first = quietly(engine, observe(world_file, t=0.0))
        assert first.solution is None
        assert stored(engine) == []  # not yet: 60 s must pass first
        quietly(engine, observe(world_file, t=30.0))
        assert stored(engine) == []
        quietly(engine, observe(world_file, t=61.0))
        cases = stored(engine)
        assert [(c.sign, c.action, c.graph.ids) for c in cases] == [
            ("positive", None, ("l1", "l2", "l4"))]
        # found again: the agent asks for nothing, and the reused case is credited when a
        # quiet while passes
        again = observe(world_file, t=100.0)
        proposal = quietly(engine, again)
        assert proposal.source == "casebase" and proposal.solution.no_action
        assert proposal.solution.cases == (cases[0].id,)
        quietly(engine, observe(world_file, t=170.0))
        assert [(c.helped, c.failed) for c in stored(engine)] == [(1, 0)]
        # trouble soon after a reused positive case blames it
        quietly(engine, observe(world_file, t=200.0))
        quietly(engine, observe(world_file, "blocked", t=220.0))
        assert [(c.helped, c.failed) for c in stored(engine)] == [(1, 1)]


def test_a_quiet_consultation_followed_by_trouble_is_no_positive_case(
        plugins: Plugins, world_file: Path) -> None:
    with engine_for(plugins, world_file, retain={"positive": 60.0, "keep": "all"}) as engine:
        quietly(engine, observe(world_file, t=0.0))
        quietly(engine, observe(world_file, "blocked", t=40.0))
        quietly(engine, observe(world_file, t=200.0))
        assert stored(engine) == []


def test_positive_cases_are_not_learned_by_default(plugins: Plugins, world_file: Path) -> None:
    with engine_for(plugins, world_file, retain={}) as engine:
        for t in (0.0, 100.0, 200.0):
            quietly(engine, observe(world_file, t=t))
        assert stored(engine) == []



# --- bad options --------------------------------------------------------------------------------

LANDMARKS = ROOT / "configs" / "landmarks.yaml"

BAD_OPTIONS = {
    "detour under 1": ("reuse={use: landmarks, detour: 0.5}", "reuse.detour: must be >= 1.0"),
    "clearance 0": ("reuse={use: landmarks, clearance: 0}", "reuse.clearance: must be > 0.0"),
    "slack 0": ("reuse={use: landmarks, slack: 0}", "reuse.slack: must be > 0.0"),
    "margin negative": ("reuse={use: landmarks, margin: -1}", "reuse.margin: must be >= 0.0"),
    "safe not a flag": ("reuse={use: landmarks, safe: maybe}",
                        "reuse.safe: expected true or false, got 'maybe'"),
    "positive 0": ("retain=[{use: landmark_trouble, positive: 0}]",
                   "retain.0.positive: must be > 0.0"),
}


@pytest.fixture
def installed(cbr_plugins: Any) -> Plugins:
    return cbr_plugins(entry_points=True)


@pytest.mark.parametrize(("setting", "message"), BAD_OPTIONS.values(), ids=list(BAD_OPTIONS))
def test_a_bad_reuse_or_retain_option_is_refused_naming_it(
        installed: Plugins, invoke_cbr: Any, setting: str, message: str) -> None:
    result = invoke_cbr("validate", str(LANDMARKS), "--set", setting)
    assert result.exit_code == 2, result
    assert message in result.stderr and "Traceback" not in result.stderr
