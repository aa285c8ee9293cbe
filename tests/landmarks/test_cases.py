"""Landmark-graph situations (``cbr_landmarks``, Ros et al. 2005, 002): the graph, the problem
case, the action, the stored case, the detour solver and the hand-made cases.

Bad input is checked against the field it names; the region in front of the robot against
landmarks placed by hand (robot frame: x ahead, y to the left); the fuzzy labels of
``from_points`` and the placing of a diverting target against properties (hypothesis); the
detour solver on scenario 2 of 002 against the geometry its docstring states; the hand-made
cases against the landmarks and obstacles 002 section 4 names and the shipped file.
"""

from __future__ import annotations

import copy
import itertools
import math
import re
import subprocess
import sys
from collections.abc import Sequence
from importlib import resources
from typing import Any

import attrs
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from cbr_landmarks.action import DivertAction
from cbr_landmarks.case import SITUATION, LandmarkCase
from cbr_landmarks.detour import DetourOptions, LandmarkDetour, chain_ends
from cbr_landmarks.graph import GraphError, LandmarkGraph
from cbr_landmarks.handmade import paper_case, paper_document, shipped_path
from cbr_landmarks.problem import RegionOptions, problem_view
from cbr_world2d.actions import Divert
from cbr_world2d.fuzzy import Triangle
from cbr_world2d.robot import Pose, RobotState
from cbr_world2d.sensors import Camera, Sensors, Sighting, sighted_points
from cbr_world2d.workload import Situation, situation
from cbr_world2d.worldfile import load_world
from cbrcore.casebase.exchange import document_to_data, read_document
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.model import Case
from cbrcore.registry import Registry

Point = tuple[float, float]


# --- helpers ---------------------------------------------------------------------------------


def wrap(angle: float) -> float:
    """``angle`` in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def sighting(landmark: str, pose: Pose, at: Point, spread: float = 0.1,
             bearing_spread: float = 0.02) -> Sighting:
    """What a noise-free camera at ``pose`` reports of a landmark at world point ``at``: the
    peaks are the true distance and bearing."""
    d = math.hypot(at[0] - pose.x, at[1] - pose.y)
    b = wrap(math.atan2(at[1] - pose.y, at[0] - pose.x) - pose.theta)
    return Sighting(landmark, Triangle.around(d, min(spread, d)),
                    Triangle.around(b, bearing_spread))


def robot_to_world(pose: Pose, ahead: float, left: float) -> Point:
    """The world point ``ahead`` metres in front of a robot at ``pose`` and ``left`` to its
    left."""
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    return (pose.x + c * ahead - s * left, pose.y + s * ahead + c * left)


def make_situation(pose: Pose, landmarks: dict[str, Point], obstacles: Sequence[tuple[str, str]]
                   = (), target: Point = (10.0, 0.0), trigger: str = "landmarks") -> Situation:
    sightings = tuple(sighting(k, pose, at) for k, at in landmarks.items())
    return Situation(0, 0.0, trigger, pose, target, sightings, tuple(obstacles), np.zeros(0),
                     np.zeros(0), False, 1.0)


def pairs(graph: LandmarkGraph) -> set[frozenset[str]]:
    return {frozenset((graph.ids[i], graph.ids[j])) for i, j in graph.obstacles}


def world_situation(scenario: str, trigger: str) -> Situation:
    """What the robot sees, without noise, at the start of the shipped world ``scenario``,
    facing its target (as :func:`cbr_landmarks.handmade.paper_case` observes)."""
    world = load_world(resources.files("cbr_world2d") / "worlds" / f"{scenario}.yaml")
    start, target = world.places["start"], world.places["target"]
    heading = math.atan2(target[1] - start[1], target[0] - start[0])
    sensors = Sensors(camera=Camera(fov=math.pi, noise=0.0))
    obs = sensors.observe(RobotState(start[0], start[1], heading), world, 0.0, False,
                          np.random.default_rng(0))
    return situation(world, 0, trigger, obs, target)


def two_landmark_case(case_id: int = 42) -> Case:
    """A well-formed stored case: l1 and l2 joined by an obstacle, the target beside l2."""
    graph = LandmarkGraph.from_points(["l1", "l2"], np.array([[2.0, -1.0], [2.0, 1.5]]),
                                      np.array([0.1, 0.2]), [("l1", "l2")])
    action = DivertAction("l2", "l1", 0.5, 0.3)
    return Case(graph.to_data(), action.to_data(), kind=SITUATION,
                meta={"sign": "negative", "origin": "learned", "helped": 0, "failed": 0},
                id=case_id)


# --- the graph and the stored case: bad input ------------------------------------------------


def _broken(change: str) -> Case:
    case = two_landmark_case()
    problem = copy.deepcopy(case.problem)
    solution = copy.deepcopy(case.solution)
    if change == "one landmark":
        problem.update(landmarks=["l1"], obstacles=[], delta=[[[0.0, 0.0, 0.0]]],
                       alpha=[[[0.0, 0.0, 0.0]]])
    elif change == "obstacle to a missing landmark":
        problem["obstacles"] = [["l1", "l9"]]
    elif change == "low above peak":
        problem["delta"][0][1] = [3.0, 2.0, 4.0]
    elif change == "peak above high":
        problem["alpha"][1][0] = [-1.0, 0.5, 0.2]
    elif change == "nan measure":
        problem["delta"][1][0] = [1.0, math.nan, 3.0]
    elif change == "anchor not a landmark":
        solution["anchor"] = "l9"
    elif change == "base not a landmark":
        solution["base"] = "l7"
    elif change == "along not a number":
        solution["along"] = "far"
    else:  # pragma: no cover
        raise AssertionError(change)
    return attrs.evolve(case, problem=problem, solution=solution)


@pytest.mark.parametrize(("change", "field"), [
    ("one landmark", r"landmarks: a case needs at least two landmarks"),
    ("obstacle to a missing landmark", r"obstacles\[0\]: 'l9' is not one of the landmarks"),
    ("low above peak", r"delta\[0\]\[1\]: a triangle needs low <= peak <= high"),
    ("peak above high", r"alpha\[1\]\[0\]: a triangle needs low <= peak <= high"),
    ("nan measure", r"delta\[1\]\[0\]: every measure must be a finite number"),
    ("anchor not a landmark", r"action\.anchor: 'l9' is not one of the case's landmarks"),
    ("base not a landmark", r"action\.base: 'l7' is not one of the case's landmarks"),
    ("along not a number", r"action\.along: expected a finite number"),
])
def test_a_malformed_case_is_refused_naming_the_case_and_the_field(change: str,
                                                                   field: str) -> None:
    with pytest.raises(GraphError) as caught:
        LandmarkCase.from_case(_broken(change), "case base test.sqlite")
    message = str(caught.value)
    assert isinstance(caught.value, CbrError)
    assert message.startswith("case base test.sqlite, landmark_situation case 42: "), message
    assert re.search(field, message), message


def test_a_well_formed_case_reads_back_as_written() -> None:
    case = LandmarkCase.from_case(two_landmark_case())
    assert case.graph.ids == ("l1", "l2")
    assert pairs(case.graph) == {frozenset(("l1", "l2"))}
    assert case.action == DivertAction("l2", "l1", 0.5, 0.3)
    assert (case.sign, case.origin, case.helped, case.failed, case.id) == (
        "negative", "learned", 0, 0, 42)
    again = LandmarkCase.from_case(case.to_case())
    np.testing.assert_allclose(again.graph.delta, case.graph.delta, atol=1e-6)
    np.testing.assert_allclose(again.graph.alpha, case.graph.alpha, atol=1e-6)


def _triangles(n: int, value: Sequence[float] = (1.0, 2.0, 3.0)) -> np.ndarray:
    return np.tile(np.asarray(value, dtype=float), (n, n, 1))


@pytest.mark.parametrize(("ids", "obstacles", "delta", "alpha", "field"), [
    (("a",), (), _triangles(1), _triangles(1), "landmarks"),
    (("a", "b"), {(0, 2)}, _triangles(2), _triangles(2), "obstacles"),
    (("a", "b"), (), _triangles(2, (2.0, 1.0, 3.0)), _triangles(2), r"delta\[0\]\[0\]"),
    (("a", "b"), (), _triangles(2), _triangles(2, (0.0, 1.0, 0.5)), r"alpha\[0\]\[0\]"),
    (("a", "b"), (), _triangles(2, (0.0, math.inf, 1.0)), _triangles(2), r"delta\[0\]\[0\]"),
    (("a", "b"), (), _triangles(3), _triangles(2), "delta: expected 2 x 2 triangles"),
    (("a", "b"), (), _triangles(2, (-1.0, 0.0, 1.0)), _triangles(2),
     r"delta\[0\]\[0\]: a distance cannot be negative"),
])
def test_the_graph_constructor_names_where_and_the_field(ids: tuple[str, ...], obstacles: Any,
                                                         delta: np.ndarray, alpha: np.ndarray,
                                                         field: str) -> None:
    with pytest.raises(GraphError, match=rf"^the graph under test: {field}"):
        LandmarkGraph(ids, obstacles, delta, alpha, "the graph under test")


def test_from_points_names_an_obstacle_to_a_missing_landmark_and_a_nan_place() -> None:
    with pytest.raises(GraphError, match=r"^here: obstacles: 'c' is not one of the landmarks"):
        LandmarkGraph.from_points(["a", "b"], np.array([[0.0, 0.0], [1.0, 0.0]]),
                                  np.array([0.1, 0.1]), [("a", "c")], where="here")
    with pytest.raises(GraphError, match=r"^here: landmarks: .*finite"):
        LandmarkGraph.from_points(["a", "b"], np.array([[0.0, math.nan], [1.0, 0.0]]),
                                  np.array([0.1, 0.1]), where="here")


def test_a_case_whose_action_names_no_landmark_of_its_graph_is_refused() -> None:
    graph = LandmarkGraph.from_points(["a", "b"], np.array([[0.0, 0.0], [1.0, 0.0]]),
                                      np.array([0.1, 0.1]), where="the case")
    with pytest.raises(GraphError, match=r"^the case: action: 'z' is not one of"):
        LandmarkCase(graph, DivertAction("z", "a", 0.5))
    with pytest.raises(GraphError, match="a negative case needs an action"):
        LandmarkCase(graph, None, "negative")
    with pytest.raises(GraphError, match="a positive case has none"):
        LandmarkCase(graph, DivertAction("a", "b", 0.5), "positive")


# --- the problem case: the region in front of the robot --------------------------------------

# robot-frame places (x ahead, y to the left), worked by hand against the default sector
# (6 m, 180 degrees) and a 6 m x 4 m rectangle, without margin:
#   A (1, 3)      3.16 m at 71.6 deg: sector yes; rectangle no (|y| = 3 > 2)
#   B (5.5, 0.5)  5.52 m at 5.2 deg:  both
#   C (5.9, 1.9)  6.20 m at 17.8 deg: sector no (beyond 6 m); rectangle yes
#   D (-0.5, 0.2) behind the robot:   neither
#   E (2, -1)     2.24 m at -26.6 deg: both
# and a 60 degree sector (|angle| <= 30 deg) takes B and E only. With the default margin of
# 1 m the sector reaches 7 m and opens by 1/6 rad (9.55 deg) on each side: it takes C too
# (within 7 m) but not D (158 deg); the 60 degree sector (|angle| <= 39.55 deg) takes B, C and
# E; the rectangle with a margin of 0.5 m (6.5 m, |y| <= 2.5) still leaves A out.
PLACES = {"A": (1.0, 3.0), "B": (5.5, 0.5), "C": (5.9, 1.9), "D": (-0.5, 0.2),
          "E": (2.0, -1.0)}
OBSTACLES = (("A", "B"), ("C", "E"), ("B", "E"), ("D", "E"))
POSES = [Pose(0.0, 0.0, 0.0), Pose(3.0, -2.0, 2.3), Pose(-1.0, 4.0, -2.9)]


@pytest.mark.parametrize("pose", POSES, ids=["origin", "turned left", "turned right"])
@pytest.mark.parametrize(("region", "inside", "kept"), [
    (RegionOptions(margin=0.0), {"A", "B", "E"}, {("A", "B"), ("B", "E")}),
    (RegionOptions(shape="rectangle", depth=6.0, width=4.0, margin=0.0), {"B", "C", "E"},
     {("C", "E"), ("B", "E")}),
    (RegionOptions(angle=60.0, margin=0.0), {"B", "E"}, {("B", "E")}),
    (RegionOptions(), {"A", "B", "C", "E"}, {("A", "B"), ("C", "E"), ("B", "E")}),
    (RegionOptions(shape="rectangle", depth=6.0, width=4.0, margin=0.5), {"B", "C", "E"},
     {("C", "E"), ("B", "E")}),
    (RegionOptions(angle=60.0), {"B", "C", "E"}, {("C", "E"), ("B", "E")}),
], ids=["sector", "rectangle", "narrow sector", "sector with margin", "rectangle with margin",
        "narrow sector with margin"])
def test_the_problem_case_holds_the_landmarks_in_the_region_and_the_obstacles_between_them(
        pose: Pose, region: RegionOptions, inside: set[str],
        kept: set[tuple[str, str]]) -> None:
    world = {k: robot_to_world(pose, *xy) for k, xy in PLACES.items()}
    view = problem_view(make_situation(pose, world, OBSTACLES), region)
    assert view is not None
    assert set(view.graph.ids) == inside
    assert pairs(view.graph) == {frozenset(p) for p in kept}
    # nearest first
    distances = [math.hypot(*PLACES[k]) for k in view.graph.ids]
    assert distances == sorted(distances)
    # the places in the robot's frame, and back in the world's, are the true ones
    np.testing.assert_allclose(view.points, [PLACES[k] for k in view.graph.ids], atol=1e-9)
    np.testing.assert_allclose(view.world_points(), [world[k] for k in view.graph.ids],
                               atol=1e-9)


def test_fewer_than_two_landmarks_in_the_region_is_no_problem_case() -> None:
    pose = POSES[1]
    world = {k: robot_to_world(pose, *PLACES[k]) for k in ("A", "C", "D")}
    rectangle = RegionOptions(shape="rectangle", depth=6.0, width=4.0, margin=0.0)
    sector = RegionOptions(margin=0.0)
    assert problem_view(make_situation(pose, world), rectangle) is None  # C alone inside
    assert problem_view(make_situation(pose, {"A": world["A"]}), sector) is None
    assert problem_view(make_situation(pose, {}), sector) is None
    # the sector takes A only of the three: C lies beyond 6 m, D behind
    assert problem_view(make_situation(pose, world), sector) is None
    world["E"] = robot_to_world(pose, *PLACES["E"])
    view = problem_view(make_situation(pose, world), sector)
    assert view is not None and set(view.graph.ids) == {"A", "E"}


def test_the_course_frame_points_x_at_the_target() -> None:
    pose = Pose(1.0, 1.0, 2.0)  # facing away to the upper left; the target lies at 36.9 deg
    target = (5.0, 4.0)
    world = {"ahead": (3.0, 2.5),  # 2.5 m straight toward the target
             "left": (2.0, 3.5), "right": (3.5, 0.5)}
    problem = make_situation(pose, world, [("ahead", "left")], target=target)
    course = problem_view(problem, RegionOptions(), course=True)
    assert course is not None
    places = dict(zip(course.graph.ids, course.points.tolist(), strict=True))
    assert places["ahead"] == pytest.approx([2.5, 0.0], abs=1e-9)
    assert places["left"][1] > 0.0 > places["right"][1]
    assert course.frame == pytest.approx((1.0, 1.0, math.atan2(3.0, 4.0)))
    np.testing.assert_allclose(course.world_points(), [world[k] for k in course.graph.ids],
                               atol=1e-9)
    # the angle labels are measured against the course: ahead -> left points along (-1, 1)
    # in the world, 135 deg, so 135 - 36.9 deg against the course
    i, j = course.graph.index("ahead"), course.graph.index("left")
    world_angle = math.atan2(3.5 - 2.5, 2.0 - 3.0)
    assert course.graph.alpha[i, j, 1] == pytest.approx(wrap(world_angle - math.atan2(3, 4)))
    # in the heading's frame the region turns with the robot: 'right' lies at -126 deg of the
    # heading, behind it; the world points do not move
    heading = problem_view(problem, RegionOptions())
    assert heading is not None and heading.frame == (1.0, 1.0, 2.0)
    assert set(heading.graph.ids) == {"ahead", "left"}
    np.testing.assert_allclose(heading.world_points(), [world[k] for k in heading.graph.ids],
                               atol=1e-9)


@settings(max_examples=100, deadline=None)
@given(st.floats(-math.pi, math.pi), st.lists(
    st.tuples(st.floats(0.4, 5.9), st.floats(-1.5, 1.5)), min_size=1, max_size=4),
    st.integers(0, 2**32 - 1))
def test_a_camera_sighting_places_the_landmark_within_its_uncertainty(
        theta: float, polar: list[tuple[float, float]], seed: int) -> None:
    """The camera's measures always hold the true value (its noise < 1); the place taken at the
    peaks is then within the uncertainty of the true place, in the robot's frame."""
    pose = Pose(0.5, -1.0, theta)
    true = np.array([[d * math.cos(b), d * math.sin(b)] for d, b in polar])
    world = np.array([[*robot_to_world(pose, x, y), 0.1] for x, y in true])
    camera = Camera(fov=math.pi, noise=0.99)
    seen = camera.see(pose, world, [f"l{k}" for k in range(len(polar))], np.zeros((0, 4)),
                      np.random.default_rng(seed))
    assume(len(seen) == len(polar))  # two landmarks hiding each other
    points, uncertainty = sighted_points(seen)
    off = np.hypot(*(points - true).T)
    assert (off <= uncertainty + 1e-9).all(), (off, uncertainty)


@pytest.mark.parametrize("fov", [60.0, 180.0, 360.0])
def test_a_landmark_at_the_edge_of_the_camera_is_in_the_region_whatever_the_noise(
        fov: float) -> None:
    """Landmarks at the camera's range and at the edge of its field of view, each measured 200
    times with the camera's largest noise: the default region (the camera's 6 m and a sector of
    its field) holds every one the camera sees, through its margin; without the margin the
    noise drops some, as it would on the edge of a region of the camera's size."""
    pose = Pose(2.0, 1.0, 0.7)
    half = math.radians(min(fov, 359.0)) / 2.0 - 1e-6
    edge = 6.0 - 1e-6
    polar = [(edge, 0.0), (edge, half), (edge, -half), (3.0, half), (edge, half / 2.0)]
    world = np.array([[*robot_to_world(pose, d * math.cos(b), d * math.sin(b)), 0.1]
                      for d, b in polar])
    ids = [f"l{k}" for k in range(len(polar))]
    camera = Camera(fov=math.radians(fov), max_range=6.0, noise=0.99)
    rng = np.random.default_rng(5)
    region = RegionOptions(angle=fov)
    dropped = 0
    for _ in range(200):
        seen = camera.see(pose, world, ids, np.zeros((0, 4)), rng)
        assert len(seen) == len(polar)
        problem = Situation(0, 0.0, "landmarks", pose, (10.0, 0.0), seen, (), np.zeros(0),
                            np.zeros(0), False, 1.0)
        view = problem_view(problem, region)
        assert view is not None and set(view.graph.ids) == set(ids)
        bare = problem_view(problem, attrs.evolve(region, margin=0.0))
        dropped += bare is None or len(bare.graph.ids) < len(ids)
    assert dropped > 100


# --- from_points: every true pair lies inside the labels -------------------------------------

coordinate = st.floats(-5.0, 5.0, allow_nan=False)


@st.composite
def measured_and_true(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n = draw(st.integers(2, 5))
    points = np.array([[draw(coordinate), draw(coordinate)] for _ in range(n)])
    uncertainty = np.array([draw(st.floats(0.0, 0.8)) for _ in range(n)])
    true = points.copy()
    for k in range(n):
        angle = draw(st.floats(0.0, 2.0 * math.pi))
        reach = draw(st.floats(0.0, 1.0)) * uncertainty[k]
        true[k] += reach * np.array([math.cos(angle), math.sin(angle)])
    return points, uncertainty, true


@settings(max_examples=150, deadline=None)
@given(measured_and_true())
def test_every_true_pair_lies_inside_the_distance_and_angle_supports(
        drawn: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    points, uncertainty, true = drawn
    n = len(points)
    graph = LandmarkGraph.from_points([f"l{k}" for k in range(n)], points, uncertainty)
    eps = 1e-9
    for i in range(n):
        for j in range(n):
            if i == j:
                continue
            low, peak, high = graph.delta[i, j]
            gap = true[j] - true[i]
            d = math.hypot(*gap)
            assert low - eps <= d <= high + eps
            assert peak == pytest.approx(math.hypot(*(points[j] - points[i])))
            if d < 1e-9:
                continue  # no direction between two coincident places
            a_low, a_peak, a_high = graph.alpha[i, j]
            assert -math.pi < a_peak <= math.pi
            off = wrap(math.atan2(gap[1], gap[0]) - a_peak)
            assert a_low - a_peak - eps <= off <= a_high - a_peak + eps


# --- the action: a diverting target among landmarks ------------------------------------------

ROUNDING = math.hypot(5e-5, 5e-5) + 1e-9
"""``toward`` keeps along and aside to 0.1 mm: how far the point it places may be off."""


@st.composite
def landmark_places(draw: st.DrawFn) -> dict[str, Point]:
    n = draw(st.integers(2, 5))
    places: dict[str, Point] = {}
    for k in range(n):
        p = (draw(st.floats(-10.0, 10.0)), draw(st.floats(-10.0, 10.0)))
        assume(all(math.dist(p, q) >= 0.2 for q in places.values()))
        places[f"l{k}"] = p
    return places


@settings(max_examples=150, deadline=None)
@given(landmark_places(), st.floats(-12.0, 12.0), st.floats(-12.0, 12.0), st.booleans())
def test_toward_a_point_places_the_target_back_at_it(places: dict[str, Point], x: float,
                                                     y: float, chain: bool) -> None:
    ids = list(places)
    linked = ({a: [b for b in ids if abs(int(a[1:]) - int(b[1:])) == 1] for a in ids}
              if chain else None)
    action = DivertAction.toward((x, y), places, linked)
    nearest = min(ids, key=lambda i: math.dist(places[i], (x, y)))
    assert math.dist(places[action.anchor], (x, y)) == pytest.approx(
        math.dist(places[nearest], (x, y)))
    if chain:
        assert action.base in linked[action.anchor]
    point = action.point(places)
    assert point is not None
    assert math.dist(point, (x, y)) <= ROUNDING


@settings(max_examples=150, deadline=None)
@given(landmark_places(), st.data(), st.floats(-3.0, 3.0), st.floats(-3.0, 3.0),
       st.floats(-math.pi, math.pi), st.floats(-20.0, 20.0), st.floats(-20.0, 20.0))
def test_the_target_moves_with_its_landmarks(places: dict[str, Point], data: st.DataObject,
                                             along: float, aside: float, turn: float,
                                             tx: float, ty: float) -> None:
    anchor, base = data.draw(st.permutations(list(places)))[:2]
    action = DivertAction(anchor, base, along, aside)
    c, s = math.cos(turn), math.sin(turn)

    def moved(p: Sequence[float]) -> Point:
        return (c * p[0] - s * p[1] + tx, s * p[0] + c * p[1] + ty)

    before = action.point(places)
    after = action.point({k: moved(p) for k, p in places.items()})
    assert before is not None and after is not None
    assert after == pytest.approx(moved(before), abs=1e-9)
    # and in the frame of base -> anchor it lies 'along' ahead of the anchor, 'aside' left
    ax, ay = places[anchor]
    bx, by = places[base]
    length = math.dist((ax, ay), (bx, by))
    ux, uy = (ax - bx) / length, (ay - by) / length
    assert before == pytest.approx((ax + along * ux - aside * uy, ay + along * uy + aside * ux),
                                   abs=1e-9)


def test_toward_worked_by_hand() -> None:
    places = {"l1": (0.0, 0.0), "l2": (2.0, 0.0), "l3": (0.0, 1.0)}
    # nearest to (2.5, 0.3) is l2; with nothing linked its base is the nearest other, l1
    # (2 m, against sqrt 5 for l3): the frame is the x axis
    assert DivertAction.toward((2.5, 0.3), places) == DivertAction("l2", "l1", 0.5, 0.3)
    # an obstacle joining l2 and l3 makes l3 the base: x' = (2, -1) / sqrt 5
    linked = {"l2": ["l3"], "l3": ["l2"], "l1": []}
    action = DivertAction.toward((2.5, 0.3), places, linked)
    root5 = math.sqrt(5.0)
    assert (action.anchor, action.base) == ("l2", "l3")
    assert action.along == pytest.approx((0.5 * 2 - 0.3 * 1) / root5, abs=1e-4)
    assert action.aside == pytest.approx((0.5 * 1 + 0.3 * 2) / root5, abs=1e-4)


def test_an_action_with_its_anchor_or_base_missing_or_coinciding_is_nowhere() -> None:
    action = DivertAction("a", "b", 0.5, 0.2)
    assert action.point({"a": (0.0, 0.0)}) is None
    assert action.point({"b": (0.0, 0.0), "c": (1.0, 1.0)}) is None
    assert action.point({"a": (1.0, 1.0), "b": (1.0, 1.0)}) is None
    assert action.point({"a": (1.0, 0.0), "b": (0.0, 0.0)}) == pytest.approx((1.5, 0.2))


@pytest.mark.parametrize(("data", "field"), [
    (["l1", "l2"], r"action: expected a mapping"),
    ({"anchor": "lx", "base": "l2", "along": 0.5}, r"action\.anchor: 'lx'"),
    ({"anchor": "l1", "along": 0.5}, r"action\.base: None"),
    ({"anchor": "l1", "base": "l1", "along": 0.5}, r"action: anchor and base must be two"),
    ({"anchor": "l1", "base": "l2"}, r"action\.along: expected a finite number"),
    ({"anchor": "l1", "base": "l2", "along": True}, r"action\.along: expected a finite number"),
    ({"anchor": "l1", "base": "l2", "along": 0.5, "aside": math.nan},
     r"action\.aside: expected a finite number"),
])
def test_action_data_errors_name_the_field(data: Any, field: str) -> None:
    with pytest.raises(GraphError, match=rf"^case 3: {field}"):
        DivertAction.from_data(data, ["l1", "l2"], "case 3")


def test_action_data_reads_back() -> None:
    action = DivertAction("l1", "l2", 0.5, -0.25)
    assert DivertAction.from_data(action.to_data(), ["l1", "l2"], "x") == action
    assert DivertAction.from_data({"anchor": "l1", "base": "l2", "along": 1},
                                  ["l1", "l2"], "x") == DivertAction("l1", "l2", 1.0, 0.0)


# --- the detour solver -----------------------------------------------------------------------


@pytest.mark.parametrize(("n", "obstacles", "ends"), [
    (4, {(0, 1), (1, 2), (2, 3)}, [(0, 1), (3, 2)]),  # a chain 0-1-2-3
    (3, {(0, 1), (1, 2)}, [(0, 1), (2, 1)]),  # a V, its apex 1
    (4, {(1, 3), (0, 3)}, [(0, 3), (1, 3)]),  # a V whose apex is listed last
    (4, {(0, 1), (1, 2), (0, 2)}, [(0, 1), (1, 0), (2, 0)]),  # a ring; 3 reached by none
    (3, set(), []),  # no obstacle
    (4, {(0, 1), (2, 3)}, [(0, 1), (1, 0), (2, 3), (3, 2)]),  # two separate walls
])
def test_chain_ends_worked_by_hand(n: int, obstacles: set[tuple[int, int]],
                                   ends: list[tuple[int, int]]) -> None:
    assert chain_ends(n, frozenset(obstacles)) == ends


def _side(a: np.ndarray, b: np.ndarray, p: Sequence[float]) -> float:
    """The sign of ``p`` against the line from ``a`` through ``b`` (positive: left)."""
    return float(np.sign((b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])))


def detour(seed: int = 0, **options: Any) -> LandmarkDetour:
    # the situations are seen from the start, 5 m from the V: a chain that far still counts as
    # the one in the way
    options = {"reach": 10.0, **options}
    return LandmarkDetour(DetourOptions(**options), Context(registry=Registry(), seed=seed))


def test_a_chain_beyond_reach_is_left_to_the_sonar_rescuer() -> None:
    problem = world_situation("scenario2", "blocked")
    solution = detour(reach=1.5, way="end").cbr_solve(problem)
    assert solution is None or "end" not in solution.detail


SCENARIO2 = {"l1": np.array([3.5, 6.3975]), "l2": np.array([6.0, 4.0]),
             "l3": np.array([3.5, 1.6025])}
"""The landmarks of the shipped scenario2.yaml: a V, apex l2, open toward the start."""


def test_the_detour_diverts_a_blocked_robot_beside_an_end_of_the_v_on_the_targets_side() -> None:
    problem = world_situation("scenario2", "blocked")
    assert set(problem.obstacles) == {("l1", "l2"), ("l2", "l3")}
    solution = detour(way="end").cbr_solve(problem)
    assert solution is not None and isinstance(solution.value, Divert)
    end = solution.detail["end"]
    assert end in ("l1", "l3")
    point = (solution.value.x, solution.value.y)
    # clearance 0.5 m past the end along the obstacle from the apex, 0.3 m across it on the
    # outside of the V, which is the target's side of the obstacle's line
    away = SCENARIO2[end] - SCENARIO2["l2"]
    away /= np.hypot(*away)
    across = np.array([-away[1], away[0]])
    offset = np.asarray(point) - SCENARIO2[end]
    assert float(offset @ away) == pytest.approx(0.5, abs=1e-6)
    assert abs(float(offset @ across)) == pytest.approx(0.3, abs=1e-6)
    assert _side(SCENARIO2["l2"], SCENARIO2[end], point) == \
        _side(SCENARIO2["l2"], SCENARIO2[end], problem.target) != 0.0
    # the shorter way round: l3 lies 2.3 m below the start's line, l1 2.5 m above
    assert end == "l3"


def test_random_choice_takes_either_end() -> None:
    problem = world_situation("scenario2", "blocked")
    ends = set()
    for seed in range(20):
        solution = detour(seed, choice="random", way="end").cbr_solve(problem)
        assert solution is not None
        ends.add(solution.detail["end"])
    assert ends == {"l1", "l3"}


def _crosses(a: Sequence[float], b: Sequence[float], c: np.ndarray, d: np.ndarray) -> bool:
    """Whether the segments a-b and c-d cross, by the signs of the four orientations."""
    a_, b_ = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return (_side(a_, b_, c) * _side(a_, b_, d) < 0) and (_side(c, d, a_) * _side(c, d, b_) < 0)


def test_the_way_round_leads_a_blocked_robot_past_the_v_to_where_the_target_is_in_sight(
        ) -> None:
    problem = world_situation("scenario2", "blocked")
    solution = detour().cbr_solve(problem)
    assert solution is not None and isinstance(solution.value, Divert)
    divert = solution.value
    assert solution.detail["way"] == "round"
    legs = [(problem.pose.x, problem.pose.y), *divert.via, (divert.x, divert.y),
            problem.target]
    walls = [(SCENARIO2["l1"], SCENARIO2["l2"]), (SCENARIO2["l2"], SCENARIO2["l3"])]
    # every leg, the last one from the diverting target on to the target included, passes
    # the V's arms (the sighted places are exact: the situation is seen without noise)
    for a, b in itertools.pairwise(legs):
        assert not any(_crosses(a, b, c, d) for c, d in walls)
    # the straight way crosses an arm: a way round was needed
    assert any(_crosses(legs[0], legs[-1], c, d) for c, d in walls)
    assert divert.give_up is not None
    assert divert.give_up.metres == pytest.approx(
        sum(math.dist(a, b) for a, b in itertools.pairwise(legs[:-1])), abs=1e-3)


def test_the_way_round_also_goes_round_the_walls_of_the_robots_map_out_of_view() -> None:
    problem = world_situation("scenario2", "blocked")
    # only l2 in view: no obstacle between landmarks in view, but the map knows both arms
    blind = attrs.evolve(problem, sightings=tuple(s for s in problem.sightings if s.id == "l2"),
                         obstacles=())
    arms = ((tuple(SCENARIO2["l1"]), tuple(SCENARIO2["l2"])),
            (tuple(SCENARIO2["l2"]), tuple(SCENARIO2["l3"])))
    solution = detour().cbr_solve(attrs.evolve(blind, walls=arms))
    assert solution is not None and solution.detail["way"] == "round"
    legs = [(problem.pose.x, problem.pose.y), *solution.value.via,
            (solution.value.x, solution.value.y), problem.target]
    for a, b in itertools.pairwise(legs):
        assert not any(_crosses(a, b, np.array(c), np.array(d)) for c, d in arms)
    unknown = detour().cbr_solve(blind)
    assert unknown is None or "way" not in unknown.detail


def test_with_nothing_in_the_way_the_way_round_leaves_the_choice_to_the_ends() -> None:
    problem = world_situation("scenario2", "blocked")
    # the target moved before the V: the straight way meets no arm
    before = attrs.evolve(problem, target=(2.0, 4.0))
    solution = detour().cbr_solve(before)
    assert solution is None or "way" not in solution.detail


@pytest.mark.parametrize("trigger", ["landmarks", "period"])
def test_the_detour_proposes_nothing_unless_the_robot_is_blocked(trigger: str) -> None:
    assert detour().cbr_solve(world_situation("scenario2", trigger)) is None


# --- the hand-made cases ---------------------------------------------------------------------


def test_the_shipped_hand_made_cases_are_up_to_date() -> None:
    """Run ``python -m cbr_landmarks.handmade`` when this fails."""
    assert document_to_data(paper_document()) == document_to_data(read_document(shipped_path()))


@pytest.mark.parametrize(("scenario", "landmarks", "obstacles", "target"), [
    # 002 section 4: "a previous case formed by the landmarks l1, l2 and the linear obstacle";
    # "the landmark l2 is set as the diverting target"
    ("scenario1", {"l1", "l2"}, {frozenset(("l1", "l2"))}, "l2"),
    # "a case formed by the landmarks l1, l2, l3 and both linear obstacles between them";
    # "a diverting target is computed (l3)"
    ("scenario2", {"l1", "l2", "l3"}, {frozenset(("l1", "l2")), frozenset(("l2", "l3"))},
     "l3"),
])
def test_each_hand_made_case_has_what_002_names(scenario: str, landmarks: set[str],
                                                obstacles: set[frozenset[str]],
                                                target: str) -> None:
    case = paper_case(scenario)
    assert set(case.graph.ids) == landmarks
    assert pairs(case.graph) == obstacles
    assert case.action is not None and case.action.anchor == target
    assert frozenset((case.action.anchor, case.action.base)) in obstacles
    assert (case.sign, case.origin) == ("negative", "hand-made")
    # seen without noise: the distance peaks are the true distances of the world file's
    # landmarks, and the supports are not empty
    world = load_world(resources.files("cbr_world2d") / "worlds" / f"{scenario}.yaml")
    at = {mark.id: (mark.x, mark.y) for mark in world.landmarks}
    for i, a in enumerate(case.graph.ids):
        for j, b in enumerate(case.graph.ids):
            if i != j:
                assert case.graph.delta[i, j, 1] == pytest.approx(math.dist(at[a], at[b]),
                                                                  abs=1e-9)
                assert case.graph.delta[i, j, 0] < case.graph.delta[i, j, 2]
    # and the shipped file holds the same case
    shipped = [LandmarkCase.from_case(c) for c in read_document(shipped_path()).cases]
    (same,) = [c for c in shipped if set(c.graph.ids) == landmarks]
    assert same.action == case.action
    assert pairs(same.graph) == obstacles


# --- loading the plugin ----------------------------------------------------------------------


def test_loading_the_plugin_imports_neither_numba_nor_matplotlib() -> None:
    """The plugin loads at every start of cbr; its kernels compile where situations are first
    matched and its pictures are drawn by the experiments, not then."""
    code = ("import sys, cbr_landmarks; "
            "print('numba' in sys.modules, 'matplotlib' in sys.modules)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=120, check=True)
    assert result.stdout.split() == ["False", "False"]
