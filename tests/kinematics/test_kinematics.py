"""The nonholonomic planner of cbr_kinematics (section 5 of the case graph paper).

The edge-based searches are checked against hand-worked graphs and grids, against a brute-force
oracle (an explicit state graph built here with networkx straight from the paper's condition
P(i, j, k), searched by networkx's Dijkstra), against the ordinary vertex searches when every
turn is allowed, and against an independent checker of the paths they return.
"""

from __future__ import annotations

import itertools
import math
from typing import NamedTuple

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_grid import directions
from cbr_kinematics.models import Forward, ForwardBackward, Holonomic, Kinematics
from cbr_solvers.aistar import heuristic_map
from cbr_solvers.graph_search import DirectedGraph, GraphPath, graph_search
from cbr_solvers.kinematic_search import KinematicPath, kinematic_search
from cbr_solvers.manoeuvres import decode
from cbr_solvers.search import dijkstra

SQRT2 = math.sqrt(2.0)

# The compass of the brief, written out again so the oracle does not lean on directions.STEPS:
# 0 = E, counter-clockwise, rows counted downwards (north is (0, -1)).
COMPASS = [(1, 0), (1, -1), (0, -1), (-1, -1), (-1, 0), (-1, 1), (0, 1), (1, 1)]
E, NE, N, NW, W, SW, S, SE = range(8)

MODELS = {"holonomic": Holonomic(), "forward": Forward(), "forward_backward": ForwardBackward()}


def gentle(a: int, b: int) -> bool:
    """The paper's forward condition: alpha = |a - b| in {0, 1, 7}, a turn of at most 45 deg."""
    return abs(a - b) in (0, 1, 7)


def any_turn(a: int, b: int) -> bool:
    return True


# Each model as the paper states it: the direct turns allowed and how many intermediate edges a
# backward manoeuvre may use (forward_backward: the two of the paper's condition).
RULES = {"holonomic": (any_turn, 0), "forward": (gentle, 0), "forward_backward": (gentle, 2)}


class Problem(NamedTuple):
    factor: np.ndarray
    passable: np.ndarray
    corner_cutting: bool
    start: tuple[int, int]
    goal: tuple[int, int]
    heading: int | None
    final: int | None
    window: tuple[int, int, int, int] | None


def open_grid(w: int, h: int) -> tuple[np.ndarray, np.ndarray]:
    """A ``w`` x ``h`` grid, every cell passable with factor 1."""
    return np.ones((h, w)), np.ones((h, w), dtype=bool)


def search(problem: Problem, model: str, **options: object) -> KinematicPath | None:
    """kinematic_search on a problem; everything past the goal is passed by keyword."""
    return kinematic_search(problem.factor, problem.passable, problem.corner_cutting,
                            problem.start, problem.goal, kinematics=MODELS[model],
                            heading=problem.heading, final_heading=problem.final,
                            window=problem.window, **options)


def step_cost(problem: Problem, x: int, y: int, d: int) -> float | None:
    """F of the grid step from (x, y) in direction d under the cost contract, None if the step is
    not allowed: both cells passable and inside the window, and a diagonal step passing the
    corner rule (judged on the whole grid)."""
    h, w = problem.passable.shape
    x0, y0, x1, y1 = problem.window or (0, 0, w - 1, h - 1)
    dx, dy = COMPASS[d]
    nx_, ny_ = x + dx, y + dy

    def usable(cx: int, cy: int) -> bool:
        return (max(x0, 0) <= cx <= min(x1, w - 1) and max(y0, 0) <= cy <= min(y1, h - 1)
                and bool(problem.passable[cy, cx]))

    if not (usable(x, y) and usable(nx_, ny_)):
        return None
    if dx and dy:
        beside = (bool(problem.passable[y, nx_]), bool(problem.passable[ny_, x]))
        if not (any(beside) if problem.corner_cutting else all(beside)):
            return None
    length = SQRT2 if dx and dy else 1.0
    return length * (problem.factor[y, x] + problem.factor[ny_, nx_]) / 2


def leave_cost(problem: Problem, model: str, x: int, y: int, arrival: int | None,
               b: int) -> float:
    """The least cost added before leaving (x, y) in direction b after arriving moving in
    ``arrival`` (None: free), enumerated naively from the paper's condition P: no manoeuvre if
    the turn itself is allowed, else an out-and-back along an edge (j, l) with P(i, j, l) and
    P(l, j, k), or along (j, l) then (j, p) with P(i, j, l), P(l, j, p), P(p, j, k); each
    intermediate edge costs twice its step. inf if there is no way."""
    if arrival is None:
        return 0.0
    allowed, most = RULES[model]
    best = 0.0 if allowed(arrival, b) else math.inf
    for dl in range(8) if most >= 1 else ():  # δ(j, l), the first intermediate edge
        out_l = step_cost(problem, x, y, dl)
        if out_l is None or not allowed(arrival, dl):
            continue
        back_l = (dl + 4) % 8  # δ(l, j): the robot comes back moving this way
        if allowed(back_l, b):
            best = min(best, 2 * out_l)
        for dp in range(8) if most >= 2 else ():  # δ(j, p), the second one
            out_p = step_cost(problem, x, y, dp)
            if out_p is None or not allowed(back_l, dp):
                continue
            if allowed((dp + 4) % 8, b):
                best = min(best, 2 * out_l + 2 * out_p)
    return best


def oracle(problem: Problem, model: str) -> tuple[float, list[float]]:
    """The optimal cost by networkx's Dijkstra over an explicit state graph, and the distance of
    each state (goal, a), the edge entering the goal moving in direction a.

    A state is (cell, a): at the cell, having arrived moving in direction a. "start" is the
    fictitious edge (s', s) (arrival = the heading, or free), "goal" the end: reached from every
    goal state, or with a final heading w_g through the condition P at g towards w_g.
    """
    h, w = problem.passable.shape
    graph = nx.DiGraph()
    graph.add_node("start")

    def add(u: object, v: object, weight: float) -> None:
        if math.isfinite(weight) and (not graph.has_edge(u, v) or weight < graph[u][v]["weight"]):
            graph.add_edge(u, v, weight=weight)

    def inside(cell: tuple[int, int]) -> bool:
        # a cell the robot may stand on: passable and inside the window
        x, y = cell
        x0, y0, x1, y1 = problem.window or (0, 0, w - 1, h - 1)
        return x0 <= x <= x1 and y0 <= y <= y1 and bool(problem.passable[y, x])

    if not (inside(problem.start) and inside(problem.goal)):
        return math.inf, [math.inf] * 8
    states: list[tuple[object, tuple[int, int], int | None]] = [
        ("start", problem.start, problem.heading)]
    states += [(((x, y), a), (x, y), a) for y in range(h) for x in range(w) if inside((x, y))
               for a in range(8)]
    for node, (x, y), arrival in states:
        for b in range(8):
            forward = step_cost(problem, x, y, b)
            if forward is not None:
                dx, dy = COMPASS[b]
                add(node, ((x + dx, y + dy), b),
                    leave_cost(problem, model, x, y, arrival, b) + forward)
        if (x, y) == problem.goal and (node != "start" or problem.final is not None):
            add(node, "goal", 0.0 if problem.final is None else
                leave_cost(problem, model, x, y, arrival, problem.final))
    if problem.start == problem.goal and problem.final is None:
        add("start", "goal", 0.0)
    dist = nx.single_source_dijkstra_path_length(graph, "start")
    return dist.get("goal", math.inf), [dist.get((problem.goal, a), math.inf) for a in range(8)]


def assert_drivable(result: KinematicPath, problem: Problem, model: str) -> None:
    """Assert the path is one the robot can drive, costing what was reported.

    A walk of 8-neighbour steps on usable cells, from the start to the goal, with the cost of the
    contract; read as moves and manoeuvres (a cusp, a step straight back, closes an out-and-back
    along an intermediate edge), every vertex satisfies P: a direct turn the model allows, or at
    most the model's number of out-and-backs each entered with an allowed turn, the heading
    constraining the first move and the final heading the way out of the goal.
    """
    path = result.path
    assert path.ndim == 2 and path.shape[1] == 2
    assert tuple(path[0]) == problem.start and tuple(path[-1]) == problem.goal
    moves, total = [], 0.0
    for (ax, ay), (bx, by) in itertools.pairwise(path.tolist()):
        assert (bx - ax, by - ay) in COMPASS, (ax, ay, bx, by)
        d = COMPASS.index((bx - ax, by - ay))
        cost = step_cost(problem, ax, ay, d)
        assert cost is not None, f"step {(ax, ay)} -> {(bx, by)} is not allowed"
        total += cost
        moves.append(d)
    assert math.isclose(total, result.cost, rel_tol=1e-9, abs_tol=1e-12)

    allowed, most = RULES[model]
    motion = problem.heading  # the robot's direction of motion; None: free
    out_and_backs = 0  # intermediate edges used at the current vertex
    i = 0
    while i < len(moves):
        d = moves[i]
        assert motion is None or allowed(motion, d), (moves, i)
        if most and i + 1 < len(moves) and moves[i + 1] == (d + 4) % 8:
            out_and_backs += 1
            assert out_and_backs <= most, (moves, i)
            motion = moves[i + 1]
            i += 2
        else:
            out_and_backs = 0
            motion = d
            i += 1
    if problem.final is None:
        assert out_and_backs == 0, "a manoeuvre at the goal buys nothing without a final heading"
    else:
        assert motion is None or allowed(motion, problem.final), moves


@st.composite
def problems(draw: st.DrawFn, max_side: int = 7, windows: bool = True) -> Problem:
    """A small grid with obstacles and factors in [1, 3], a passable start and goal, a heading
    and a final heading (each None or 0-7) and maybe a window around the start and the goal
    (one that leaves either out is a trivial None, tested by hand).

    Half are corridors two or three cells wide with a heading, where the robot must often
    manoeuvre to turn round: on open grids it seldom needs to.
    """
    sides = st.integers(1, max_side)
    h, w = draw(sides), draw(sides)
    direction = st.sampled_from([None, *range(8)])
    heading, blocked = direction, st.sampled_from([0.0, 0.1, 0.2, 0.35])
    if draw(st.booleans()):
        narrow = draw(st.integers(2, 3))
        h, w = draw(st.sampled_from([(narrow, w), (h, narrow)]))
        heading, blocked = st.integers(0, 7), st.sampled_from([0.0, 0.1])
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    passable = rng.random((h, w)) >= draw(blocked)
    factor = rng.uniform(1.0, 3.0, (h, w))
    cell = st.tuples(st.integers(0, w - 1), st.integers(0, h - 1))
    (sx, sy), (gx, gy) = start, goal = draw(cell), draw(cell)
    passable[sy, sx] = passable[gy, gx] = True
    window = None
    if windows and draw(st.booleans()):
        margin = st.integers(0, 2)
        window = (min(sx, gx) - draw(margin), min(sy, gy) - draw(margin),
                  max(sx, gx) + draw(margin), max(sy, gy) + draw(margin))
    return Problem(factor, passable, draw(st.booleans()), start, goal, draw(heading),
                   draw(direction), window)


def ai_star_table(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
                  goals: np.ndarray, box: tuple[int, int, int, int]) -> np.ndarray:
    """Ai*'s per-cell heuristic over the search's window, for the ``heuristic`` argument."""
    return heuristic_map(factor, passable, corner_cutting, goals, box)


# --- the brute-force oracle ----------------------------------------------------------------

@settings(max_examples=120, deadline=None)
@given(problems())
def test_optimal_costs_match_the_state_graph_oracle(problem: Problem) -> None:
    for model in MODELS:
        expected, arrivals = oracle(problem, model)
        results = {"dijkstra": search(problem, model, informed=False),
                   "astar": search(problem, model, informed=True),
                   "aistar": search(problem, model, heuristic=ai_star_table)}
        for name, result in results.items():
            if math.isinf(expected):
                assert result is None, (model, name)
                continue
            assert result is not None, (model, name)
            assert math.isclose(result.cost, expected, rel_tol=1e-9, abs_tol=1e-12), (model, name)
            assert_drivable(result, problem, model)
            if problem.final is None and problem.start != problem.goal:
                # the search settles every edge into the goal it can reach before it stops
                np.testing.assert_allclose(result.arrivals, arrivals, rtol=1e-9)


# --- properties of the returned paths --------------------------------------------------------

def grid_graph(problem: Problem) -> tuple[DirectedGraph, dict[tuple[int, int], int]]:
    """The grid's explicit graph: a vertex per passable cell, an edge per allowed step weighing
    its F (a manoeuvre's part defaults to twice that, the grid's out-and-back)."""
    h, w = problem.passable.shape
    cells = [(x, y) for y in range(h) for x in range(w) if problem.passable[y, x]]
    index = {cell: k for k, cell in enumerate(cells)}
    tails, heads, weights = [], [], []
    for (x, y), d in itertools.product(cells, range(8)):
        cost = step_cost(problem, x, y, d)
        if cost is not None:
            tails.append(index[x, y])
            heads.append(index[x + COMPASS[d][0], y + COMPASS[d][1]])
            weights.append(cost)
    scale = float(problem.factor[problem.passable].min())
    return DirectedGraph.of(cells, tails, heads, weights, scale=scale), index


def intermediate_edges(code: int) -> list[int]:
    """The directions of a manoeuvre code's out-and-backs: 0 none, 1 + l, 9 + 8·l + p."""
    if code == 0:
        return []
    if code < 9:
        return [code - 1]
    return [(code - 9) // 8, (code - 9) % 8]


def assert_graph_path(found: GraphPath, graph: DirectedGraph, source: int, goal: int) -> None:
    """Assert the edges chain from the source to the goal and the cost is their weights plus
    the part of every intermediate edge of the manoeuvres."""
    parts = {(int(t), int(d)): float(p)
             for t, d, p in zip(graph.tails, graph.departures, graph.parts, strict=True)}
    tails = [int(graph.tails[e]) for e in found.edges]
    heads = [int(graph.heads[e]) for e in found.edges]
    assert [source, *heads] == [*tails, goal]
    assert len(found.manoeuvres) == len(found.edges)
    total = sum(float(graph.weights[e]) for e in found.edges)
    for vertex, code in [*zip(tails, found.manoeuvres, strict=True), (goal, found.final)]:
        total += sum(parts[vertex, d] for d in intermediate_edges(code))
    assert math.isclose(total, found.cost, rel_tol=1e-9, abs_tol=1e-12)


@settings(max_examples=150, deadline=None)
@given(problems(max_side=12, windows=False))
def test_paths_are_drivable_and_every_search_agrees(problem: Problem) -> None:
    graph, index = grid_graph(problem)
    source, goal = index[problem.start], index[problem.goal]
    for model in MODELS:
        found = search(problem, model, informed=False)
        informed = search(problem, model, informed=True)
        on_graph = [graph_search(graph, source, goal, kinematics=MODELS[model],
                                 heading=problem.heading, final_heading=problem.final,
                                 informed=flag) for flag in (False, True)]
        if found is None:
            assert informed is None and on_graph == [None, None], model
            continue
        assert informed is not None, model
        assert math.isclose(informed.cost, found.cost, rel_tol=1e-9), model
        for result in (found, informed):
            assert_drivable(result, problem, model)
        for path in on_graph:
            assert path is not None, model
            assert math.isclose(path.cost, found.cost, rel_tol=1e-9), model
            assert_graph_path(path, graph, source, goal)


@settings(max_examples=200, deadline=None)
@given(problems(max_side=8, windows=False), st.booleans(), st.sampled_from([None, 0, 1]))
def test_holonomic_costs_equal_ordinary_dijkstra(problem: Problem, informed: bool,
                                                 blocked: int | None) -> None:
    # Every turn allowed, the heading and the final heading constrain nothing: the edge-based
    # search must find the vertex search's optimum. Blocking the start or the goal, neither
    # finds a path.
    passable = problem.passable.copy()
    if blocked is not None:
        x, y = (problem.start, problem.goal)[blocked]
        passable[y, x] = False
    problem = problem._replace(passable=passable)
    expected = dijkstra(problem.factor, passable, problem.corner_cutting, problem.start,
                        [problem.goal])
    result = search(problem, "holonomic", informed=informed)
    if expected is None:
        assert result is None
        return
    assert result is not None
    assert math.isclose(result.cost, expected.cost, rel_tol=1e-9, abs_tol=1e-12)
    assert_drivable(result, problem, "holonomic")


# --- hand-worked graphs ------------------------------------------------------------------------

# A sharp turn:       c --- g       s (0,0) -E-> a (2,0), weight 2; a -N-> g (2,-2), weight 2
#                   /       |       s -NE-> c (1,-1), weight 3;     c -NE-> g, weight 3
#                 s ------- a       Holonomic: s a g = 4, turning 90 deg at a. Forward cannot
# turn E -> N at a (alpha = 2) and takes the gentle s c g = 6 (E -> NE -> NE, alpha 1 and 0).
SHARP = DirectedGraph.of([(0, 0), (2, 0), (2, -2), (1, -1)], [0, 1, 0, 3], [1, 2, 3, 2],
                         [2.0, 2.0, 3.0, 3.0])


@pytest.mark.parametrize("informed", [False, True])
@pytest.mark.parametrize("heading", [None, E])
def test_forward_avoids_a_sharp_turn(informed: bool, heading: int | None) -> None:
    sharp = graph_search(SHARP, 0, 2, kinematics=Holonomic(), heading=heading,
                         informed=informed)
    gentle_route = graph_search(SHARP, 0, 2, kinematics=Forward(), heading=heading,
                                informed=informed)
    assert sharp is not None and gentle_route is not None
    assert (sharp.edges, sharp.cost) == ((0, 1), 4.0)
    assert (gentle_route.edges, gentle_route.cost) == ((2, 3), 6.0)
    assert gentle_route.manoeuvres == (0, 0) and gentle_route.final == 0


def test_final_heading_on_a_graph() -> None:
    # Arriving at g moving NE (the gentle route), forward may drive on N (alpha 1), not W
    # (alpha 3), and g has no edge for a manoeuvre.
    assert graph_search(SHARP, 0, 2, kinematics=Forward(), heading=E,
                        final_heading=N).cost == 6.0
    assert graph_search(SHARP, 0, 2, kinematics=Forward(), heading=E, final_heading=W) is None
    assert graph_search(SHARP, 0, 2, kinematics=ForwardBackward(), heading=E,
                        final_heading=W) is None


# A dead end:   0 -E-> 1 -NE-> 2 (a spur, no way on), 1 -S-> 3; weights 1, 1.5, 1.
# Heading E, the robot reaches 1 moving E and cannot turn S (alpha 6, i.e. 90 deg). It may drive
# out along the spur NE (alpha 1), back moving SW, then S (alpha 1): the manoeuvre 1 + NE = 2,
# costing twice the spur, 3. Total 1 + 3 + 1 = 5.
DEAD_END = ([(0, 0), (1, 0), (2, -1), (1, 1)], [0, 1, 1], [1, 2, 3], [1.0, 1.5, 1.0])


@pytest.mark.parametrize("informed", [False, True])
def test_a_dead_end_needs_a_backward_manoeuvre(informed: bool) -> None:
    graph = DirectedGraph.of(*DEAD_END)
    assert graph_search(graph, 0, 3, kinematics=Forward(), heading=E, informed=informed) is None
    found = graph_search(graph, 0, 3, kinematics=ForwardBackward(), heading=E,
                         informed=informed)
    assert found is not None
    assert (found.edges, found.manoeuvres, found.final) == ((0, 2), (0, 1 + NE), 0)
    assert found.cost == 5.0
    direct = graph_search(graph, 0, 3, kinematics=Holonomic(), heading=E, informed=informed)
    assert (direct.edges, direct.manoeuvres, direct.cost) == ((0, 2), (0, 0), 2.0)


def test_explicit_parts_price_the_manoeuvre() -> None:
    # Only the first part of the spur is driven out and back: given as 0.5, the path costs
    # 1 + 0.5 + 1 instead of 1 + 2 * 1.5 + 1.
    graph = DirectedGraph.of(*DEAD_END, parts=[2.0, 0.5, 2.0])
    found = graph_search(graph, 0, 3, kinematics=ForwardBackward(), heading=E)
    assert found.manoeuvres == (0, 1 + NE)
    assert found.cost == 2.5


@pytest.mark.parametrize("informed", [False, True])
def test_two_intermediate_edges(informed: bool) -> None:
    # 0 -E-> 1, weight 1; from 1: spurs E to 2 (weight 1) and SW to 3 (weight 1.5), the goal N
    # at 4 (weight 1). Arriving at 1 moving E: out E and back leaves the robot moving W, from
    # which N is still 90 deg; no other spur is within 45 deg of E. Out E and back (moving W),
    # out SW (45 deg from W) and back moving NE, then N (45 deg): code 9 + 8·E + SW = 14,
    # cost 1 + 2 + 3 + 1 = 7.
    graph = DirectedGraph.of([(0, 0), (1, 0), (2, 0), (0, 1), (1, -1)], [0, 1, 1, 1],
                             [1, 2, 3, 4], [1.0, 1.0, 1.5, 1.0])
    assert graph_search(graph, 0, 4, kinematics=Forward(), heading=E, informed=informed) is None
    found = graph_search(graph, 0, 4, kinematics=ForwardBackward(), heading=E,
                         informed=informed)
    assert (found.edges, found.manoeuvres, found.cost) == ((0, 3), (0, 9 + 8 * E + SW), 7.0)


def test_a_manoeuvre_at_the_goal_for_the_final_heading() -> None:
    # 0 -E-> 1 -E-> 2, weights 1. Reaching goal 1 moving E, the robot can only drive on W after
    # going out to 2 and back (the final code 1 + E), cost 1 + 2.
    graph = DirectedGraph.of([(0, 0), (1, 0), (2, 0)], [0, 1], [1, 2], [1.0, 1.0])
    assert graph_search(graph, 0, 1, kinematics=Forward(), heading=E, final_heading=W) is None
    found = graph_search(graph, 0, 1, kinematics=ForwardBackward(), heading=E, final_heading=W)
    assert (found.edges, found.manoeuvres, found.final, found.cost) == ((0,), (0,), 1 + E, 3.0)
    free = graph_search(graph, 0, 1, kinematics=Holonomic(), heading=E, final_heading=W)
    assert (free.final, free.cost) == (0, 1.0)


def test_a_curved_edge_leaves_and_arrives_in_its_own_directions() -> None:
    # Edge 0 leaves E and arrives moving N (weight 4), edge 1 goes on N (weight 1): forward may
    # take both from heading E (0 -> 0, then 2 -> 2), not from heading N (N -> E is 90 deg).
    graph = DirectedGraph.of([(0, 0), (2, -2), (2, -3)], [0, 1], [1, 2], [4.0, 1.0],
                             departures=[E, N], arrivals=[N, N])
    assert graph_search(graph, 0, 2, kinematics=Forward(), heading=E).cost == 5.0
    assert graph_search(graph, 0, 2, kinematics=Forward(), heading=N) is None


def test_free_directions_put_no_condition() -> None:
    # 0 -E-> 1, then edge 1 from 1 to 2 whose directions are given, then 2 -S-> 3; weights 1, 2,
    # 1. Departure -1 lets forward take edge 1 after arriving moving E, arrival -1 lets it leave
    # 2 in any direction: cost 4. Departing SW (135 deg from E) or arriving W (90 deg from S)
    # it cannot.
    xy, tails, heads, weights = [(0, 0), (1, 0), (0, 1), (0, 2)], [0, 1, 2], [1, 2, 3], [1, 2, 1]
    for departure, arrival, cost in ((-1, -1, 4.0), (E, -1, 4.0), (-1, SE, 4.0),
                                     (SW, SW, None), (E, W, None)):
        graph = DirectedGraph.of(xy, tails, heads, weights, departures=[E, departure, S],
                                 arrivals=[E, arrival, S])
        found = graph_search(graph, 0, 3, kinematics=Forward(), heading=E)
        assert (None if found is None else found.cost) == cost, (departure, arrival)


# --- hand-worked grids -------------------------------------------------------------------------

def test_a_corridor_dead_end_on_a_grid() -> None:
    # A 3-cell corridor, start (1, 0) heading E, goal (0, 0): forward cannot turn round;
    # forward_backward drives out to (2, 0), reverses back and on to (0, 0): cost 2 + 1, moving
    # E then W twice, in reverse after the cusp, so facing E all the way.
    factor, passable = open_grid(3, 1)
    problem = Problem(factor, passable, False, (1, 0), (0, 0), E, None, None)
    assert search(problem, "forward") is None
    found = search(problem, "forward_backward")
    assert found.path.tolist() == [[1, 0], [2, 0], [1, 0], [0, 0]]
    assert found.cost == 3.0
    assert found.directions.tolist() == [E, W, W]
    assert found.reversing.tolist() == [False, True, True]
    assert found.headings.tolist() == [E, E, E]
    # the only edge into the goal is the one from (1, 0), moving W
    assert found.arrivals.tolist() == [math.inf] * 4 + [3.0] + [math.inf] * 3
    assert search(problem, "holonomic").cost == 1.0


def test_two_intermediate_edges_on_a_grid() -> None:
    #   # g #     Start (1, 1) heading E, goal (1, 0) N of it, 90 deg away. Only E is within
    #   . s .     45 deg of E, and backing from it leaves the robot moving W, N still 90 deg off;
    #   . # #     from moving W, SW is open (cutting the corner at (1, 2)). Out E and back, out
    # SW and back (now moving NE), then N: 2 + 2 sqrt 2 + 1. Every other move leads into a dead
    # end: (0, 1) entered moving W and (0, 2) moving SW have no cell ahead within 45 deg. The
    # robot backs W and on SW in reverse, then drives forward NE and N.
    passable = np.array([[0, 1, 0], [1, 1, 1], [1, 0, 0]], dtype=bool)
    problem = Problem(np.ones((3, 3)), passable, True, (1, 1), (1, 0), E, None, None)
    assert search(problem, "forward") is None
    found = search(problem, "forward_backward")
    assert found.path.tolist() == [[1, 1], [2, 1], [1, 1], [0, 2], [1, 1], [1, 0]]
    assert found.cost == pytest.approx(3 + 2 * SQRT2)
    assert found.reversing.tolist() == [False, True, True, False, False]
    assert found.headings.tolist() == [E, E, NE, NE, N]
    # without corner cutting the step SW is not allowed, and there is no way
    assert search(problem._replace(corner_cutting=False), "forward_backward") is None


def test_a_manoeuvre_at_the_goal_appears_in_the_grid_path() -> None:
    factor, passable = open_grid(3, 1)
    problem = Problem(factor, passable, False, (0, 0), (1, 0), E, W, None)
    assert search(problem, "forward") is None
    found = search(problem, "forward_backward")
    assert found.path.tolist() == [[0, 0], [1, 0], [2, 0], [1, 0]]
    assert found.cost == 3.0


def test_arrivals_hold_the_cost_of_each_edge_into_the_goal() -> None:
    # Open 3x3, factors 1, (0, 0) to (2, 2), any turn: into the goal moving SE via (1, 1) costs
    # 2·sqrt 2; moving E via (1, 2) or S via (2, 1), sqrt 2 + 1 + 1; no other edge enters it.
    factor, passable = open_grid(3, 3)
    found = search(Problem(factor, passable, False, (0, 0), (2, 2), None, None, None),
                   "holonomic")
    expected = [math.inf] * 8
    expected[SE] = 2 * SQRT2
    expected[E] = expected[S] = 2 + SQRT2
    np.testing.assert_allclose(found.arrivals, expected)
    assert found.cost == pytest.approx(2 * SQRT2)
    assert found.path.tolist() == [[0, 0], [1, 1], [2, 2]]


def test_arrivals_are_kept_with_a_final_heading() -> None:
    # KinematicPath documents arrivals[a] as d_s of the edge entering the goal in direction a,
    # inf only when it was not settled or does not exist. With a final heading the search
    # settles the edge (1, 1) -> (2, 2) (the goal edge (g, g') is pushed from it), yet arrivals
    # stay all inf.
    factor, passable = open_grid(3, 3)
    found = search(Problem(factor, passable, False, (0, 0), (2, 2), E, SE, None), "forward")
    assert found.cost == pytest.approx(2 * SQRT2)
    assert found.arrivals[SE] == pytest.approx(2 * SQRT2)


def test_start_equals_goal() -> None:
    factor, passable = open_grid(1, 1)
    for model in MODELS:
        for heading in (None, E):
            found = search(Problem(factor, passable, False, (0, 0), (0, 0), heading, None, None),
                           model)
            assert found.path.tolist() == [[0, 0]] and found.cost == 0.0
    # A final heading must be reachable from the heading at the start: W from E needs a
    # manoeuvre, impossible on a single cell; a free heading or any-turn model needs nothing.
    turned = Problem(factor, passable, False, (0, 0), (0, 0), E, W, None)
    assert search(turned, "forward") is None
    assert search(turned, "forward_backward") is None
    assert search(turned, "holonomic").cost == 0.0
    assert search(turned._replace(heading=None), "forward").cost == 0.0


def test_blocked_start_or_goal() -> None:
    factor, passable = open_grid(3, 1)
    passable[0, 2] = False
    for start, goal in (((2, 0), (0, 0)), ((0, 0), (2, 0))):
        assert search(Problem(factor, passable, False, start, goal, None, None, None),
                      "forward_backward") is None


def test_window_limits_the_search() -> None:
    # Open 7x7, start (3, 3) heading E, goal (2, 3) just behind it. Forward can loop round; kept
    # to row 3 it cannot, while forward_backward reverses within the row.
    factor, passable = open_grid(7, 7)
    problem = Problem(factor, passable, False, (3, 3), (2, 3), E, None, None)
    assert search(problem, "forward") is not None
    row = problem._replace(window=(0, 3, 6, 3))
    assert search(row, "forward") is None
    found = search(row, "forward_backward")
    assert found.path.tolist() == [[3, 3], [4, 3], [3, 3], [2, 3]]
    assert found.cost == 3.0
    assert search(problem._replace(window=(3, 0, 6, 6)), "holonomic") is None  # goal outside


def test_the_heuristic_table_is_used() -> None:
    # The table is built for the goals and the window clipped to the grid; one of zeros keys
    # every edge by its distance alone, so A* settles exactly what Dijkstra settles.
    factor, passable = open_grid(5, 5)
    problem = Problem(factor, passable, False, (0, 0), (4, 0), S, N, (-3, -3, 4, 9))
    calls = []

    def zeros(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
              goals: np.ndarray, box: tuple[int, int, int, int]) -> np.ndarray:
        calls.append((goals.tolist(), tuple(box)))
        return np.zeros((box[3] - box[1] + 1) * (box[2] - box[0] + 1))

    tabled = search(problem, "forward", heuristic=zeros)
    plain = search(problem, "forward", informed=False)
    assert calls == [([[4, 0]], (0, 0, 4, 4))]
    assert (tabled.cost, tabled.expanded) == (plain.cost, plain.expanded)


def test_kinematic_search_errors() -> None:
    factor, passable = open_grid(3, 3)
    problem = Problem(factor, passable, False, (0, 0), (2, 2), None, None, None)
    for heading in (8, -1, True, 1.5):
        with pytest.raises(ValueError, match="heading"):
            search(problem._replace(heading=heading), "forward")
        with pytest.raises(ValueError, match="final_heading"):
            search(problem._replace(final=heading), "forward")
    as_list = kinematic_search(factor, passable, False, (0, 0), [(2, 2)], kinematics=Forward())
    assert as_list.cost == search(problem, "forward").cost
    with pytest.raises(ValueError, match="one goal"):
        kinematic_search(factor, passable, False, (0, 0), [(2, 2), (1, 1)],
                         kinematics=Forward())
    with pytest.raises(ValueError, match="outside"):
        search(problem._replace(start=(3, 0)), "forward")
    bad = factor.copy()
    bad[1, 1] = np.nan
    with pytest.raises(ValueError, match="finite and positive"):
        search(problem._replace(factor=bad), "forward", informed=False)


# --- small units -------------------------------------------------------------------------------

@pytest.mark.parametrize(("value", "expected"), [
    ("E", E), ("ne", NE), (" Sw ", SW), ("se", SE), (3, NW), ("7", SE), (0, E)])
def test_parse(value: str | int, expected: int) -> None:
    assert directions.parse(value) == expected


@pytest.mark.parametrize("value", ["8", 8, -1, "-1", "north", "", "1.0", True])
def test_parse_rejects(value: object) -> None:
    with pytest.raises(ValueError, match="expected a direction"):
        directions.parse(value)


def test_the_compass() -> None:
    assert directions.STEPS.tolist() == [list(step) for step in COMPASS]
    assert directions.NAMES == ("E", "NE", "N", "NW", "W", "SW", "S", "SE")


def test_between() -> None:
    # any distance along one of the 8 lines, its direction
    assert directions.between([(0, 0), (3, 3), (5, 5)], [(4, 0), (0, 0), (5, 2)]).tolist() == [
        E, NW, N]
    for offset in ((0, 0), (1, 2)):
        with pytest.raises(ValueError, match="not along one of the 8 grid directions"):
            directions.between([(0, 0)], [offset])


def test_of_steps() -> None:
    assert directions.of_steps([(0, 0), (1, 0), (1, -1), (0, 0)]).tolist() == [E, N, SW]
    assert directions.of_steps([(4, 4)]).tolist() == []
    for path in ([(0, 0), (2, 0)], [(0, 0), (0, 0)]):
        with pytest.raises(ValueError, match="not a move to an 8-neighbour"):
            directions.of_steps(path)


def test_reversing_flips_gear_at_each_cusp() -> None:
    assert directions.reversing([]).tolist() == []
    assert directions.reversing([E, E]).tolist() == [False, False]
    # cusps at steps 2 (SW after NE) and 4 (E after W): reverse, then forward again
    assert directions.reversing([N, NE, SW, W, E, NE]).tolist() == [
        False, False, True, True, False, False]


def test_headings_turn_round_while_reversing() -> None:
    # N, out NE, back SW in reverse (facing NE), on S in reverse (facing N)
    path = KinematicPath(np.array([(0, 0), (0, -1), (1, -2), (0, -1), (0, 0)]), 0.0, 0,
                         np.full(8, np.inf))
    assert path.directions.tolist() == [N, NE, SW, S]
    assert path.reversing.tolist() == [False, False, True, True]
    assert path.headings.tolist() == [N, NE, NE, N]


@pytest.mark.parametrize(("code", "expected"), [
    (0, (-1, -1)), (1, (E, -1)), (8, (SE, -1)), (9, (E, E)), (9 + 8 * E + SW, (E, SW)),
    (9 + 8 * N + NW, (N, NW)), (72, (SE, SE))])
def test_decode(code: int, expected: tuple[int, int]) -> None:
    assert decode(code) == expected


def test_model_tables() -> None:
    assert Holonomic().unconstrained and not Forward().unconstrained
    forward = Forward()
    allowed = [(a, b) for a in range(8) for b in range(8) if forward.table[a, b]]
    assert allowed == [(a, b) for a in range(8) for b in range(8) if gentle(a, b)]
    assert not forward.table.flags.writeable
    assert (ForwardBackward().table == forward.table).all()
    assert (Forward.manoeuvres, ForwardBackward.manoeuvres, Holonomic.manoeuvres) == (0, 2, 0)


class WrongShape(Kinematics):
    def turns(self) -> np.ndarray:
        return np.ones((8, 7), dtype=bool)


class WrongType(Kinematics):
    def turns(self) -> np.ndarray:
        return np.ones((8, 8), dtype=np.int64)


class ThreeManoeuvres(Forward):
    manoeuvres = 3


class FlagManoeuvres(Forward):
    manoeuvres = True


@pytest.mark.parametrize("model", [WrongShape, WrongType, ThreeManoeuvres, FlagManoeuvres])
def test_model_validation(model: type[Kinematics]) -> None:
    with pytest.raises(ValueError, match=model.__name__):
        _ = model().table
    factor, passable = open_grid(2, 1)
    with pytest.raises(ValueError):
        kinematic_search(factor, passable, False, (0, 0), (1, 0), kinematics=model())


@pytest.mark.parametrize(("arguments", "message"), [
    (([0, 1], [1], [1.0, 1.0]), "heads has 1 entries for 2 edges"),
    (([0], [2], [1.0]), "heads must be vertices 0..1"),
    (([-1], [1], [1.0]), "tails must be vertices 0..1"),
    (([0], [1], [0.0]), "weights must be positive"),
    (([0], [1], [np.nan]), "weights must be positive"),
])
def test_directed_graph_validation(arguments: tuple, message: str) -> None:
    # departures given, so that the constructor's own checks are reached (of derives them from
    # the positions of the ends, which needs valid vertices)
    tails = arguments[0]
    with pytest.raises(ValueError, match=message):
        DirectedGraph.of([(0, 0), (1, 0)], *arguments, departures=[E] * len(tails))


def test_a_straight_edge_needs_ends_on_a_grid_line() -> None:
    with pytest.raises(ValueError, match="not along one of the 8 grid directions"):
        DirectedGraph.of([(0, 0), (1, 2)], [0], [1], [1.0])


def test_directed_graph_direction_validation() -> None:
    xy, ends = [(0, 0), (1, 0)], ([0], [1], [1.0])
    with pytest.raises(ValueError, match="departures must be directions"):
        DirectedGraph.of(xy, *ends, departures=[8])
    with pytest.raises(ValueError, match="arrivals must be directions"):
        DirectedGraph.of(xy, *ends, departures=[E], arrivals=[-2])
    with pytest.raises(ValueError, match="parts has 2 entries for 1 edges"):
        DirectedGraph.of(xy, *ends, parts=[1.0, 1.0])


def test_graph_search_errors() -> None:
    graph = DirectedGraph.of([(0, 0), (1, 0)], [0], [1], [1.0])
    with pytest.raises(ValueError, match="source 2 is not a vertex"):
        graph_search(graph, 2, 1, kinematics=Forward())
    with pytest.raises(ValueError, match="goal -1 is not a vertex"):
        graph_search(graph, 0, -1, kinematics=Forward())
    with pytest.raises(ValueError, match="heading"):
        graph_search(graph, 0, 1, kinematics=Forward(), heading=8)
    assert graph_search(graph, 0, 0, kinematics=Forward()).cost == 0.0
    assert graph_search(graph, 1, 0, kinematics=Holonomic()) is None  # one-way edge
