"""The case graph planner (``cbr_casegraph``): the graph, eq. (11)/(12), planning, state, storage.

Small cases are worked out by hand and drawn as grids (x to the right, y downwards; ``#`` an
obstacle, letters the cells named in the test). Properties compare the planner with
independent references: Dijkstra on the grid, the cost contract summed step by step and a
brute-force cell count over every edge.
"""

from __future__ import annotations

import itertools
import math
from collections import Counter
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from cbr_casegraph.geometry import is_straight, segment_cells
from cbr_casegraph.graph import SEGMENT, CaseGraph, segment_costs
from cbr_casegraph.planner import Failure, Plan, Settings, plan, searched
from cbr_casegraph.state import graph_of
from cbr_grid.costs import path_cost, step_costs
from cbr_grid.grid import Grid
from cbr_grid.query import without_loops
from cbr_solvers import load_search
from cbr_solvers.search import astar, dijkstra
from cbrcore.casebase.memory import MemoryStore
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.registry import Registry

Cell = tuple[int, int]


# --- helpers ----------------------------------------------------------------------------------


def free(width: int, height: int) -> Grid:
    return Grid(np.zeros((height, width)))


def line(*corners: Cell) -> np.ndarray:
    """The 8-connected cell path through straight runs between the given corner cells."""
    cells = [np.asarray(corners[0])]
    for a, b in itertools.pairwise(corners):
        cells.extend(segment_cells(a, b)[1:])
    return np.array(cells, dtype=np.int64)


def edge_set(graph: CaseGraph) -> set[frozenset[Cell]]:
    """The edges as unordered pairs of end cells: the graph's shape, independent of ids."""
    a, b = graph.ends(graph.edge_ids())
    return {frozenset({tuple(p), tuple(q)}) for p, q in zip(a.tolist(), b.tolist(), strict=True)}


def seg(a: Cell, b: Cell) -> frozenset[Cell]:
    return frozenset({a, b})


def snapshot(graph: CaseGraph) -> dict[str, Any]:
    """Everything a query could change in the stored graph, copied."""
    ids = graph.edge_ids()
    a, b = graph.ends(ids)
    return {"ids": ids.copy(), "a": a.copy(), "b": b.copy(), "cost": graph.costs(ids).copy(),
            "owner": graph.owner.copy(), "vertex_at": graph.vertex_at.copy(),
            "vertices": graph.vertex_count}


def assert_same(before: dict[str, Any], after: dict[str, Any]) -> None:
    assert before.keys() == after.keys()
    for key, value in before.items():
        assert np.array_equal(value, after[key]), key


def check_consistent(graph: CaseGraph) -> None:
    """The graph's invariants, recomputed from its edge list alone.

    Every edge is straight; no cell is shared by two edges except a vertex cell (an end of each);
    an edge's interior holds no vertex; ``owner`` marks exactly the edges' interior cells with
    their edge and ``vertex_at`` exactly their end cells; degrees agree with the edge list.
    """
    ids = graph.edge_ids()
    a, b = graph.ends(ids)
    interior: Counter[Cell] = Counter()
    ends: Counter[Cell] = Counter()
    owner = np.full(graph.owner.shape, -1, dtype=np.int64)
    for edge, p, q in zip(ids.tolist(), a.tolist(), b.tolist(), strict=True):
        assert is_straight(p, q), (edge, p, q)
        cells = [tuple(c) for c in segment_cells(p, q).tolist()]
        ends.update([cells[0], cells[-1]])
        interior.update(cells[1:-1])
        for x, y in cells[1:-1]:
            owner[y, x] = edge
    assert not [c for c, n in interior.items() if n > 1], "edges overlap"
    assert not set(interior) & set(ends), "an edge runs through a vertex"
    assert np.array_equal(graph.owner, owner)
    vertex_cells = {(int(x), int(y)) for y, x in np.argwhere(graph.vertex_at >= 0)}
    assert vertex_cells == set(ends)
    assert graph.vertex_count == len(ends)
    assert len(set(graph.vertex_at[graph.vertex_at >= 0].tolist())) == len(ends)
    for cell, degree in ends.items():
        assert graph.degree(cell) == degree
    # no two edges join the same pair of vertices
    assert len(edge_set(graph)) == len(ids)


# --- add_path ---------------------------------------------------------------------------------


def test_an_l_shaped_path_is_two_segments_meeting_at_the_turn() -> None:
    # . . . . . .
    # . a - - - t
    # . . . . . |
    # . . . . . b
    graph = CaseGraph(free(8, 6))
    added = graph.add_path(line((1, 1), (5, 1), (5, 3)))
    assert len(added) == 2
    assert edge_set(graph) == {seg((1, 1), (5, 1)), seg((5, 1), (5, 3))}
    assert graph.degree((5, 1)) == 2
    check_consistent(graph)


def test_a_crossing_path_splits_both_at_the_crossing_cell() -> None:
    # . . . . n . . . .
    # . . . . | . . . .
    # . . . . | . . . .
    # a - - - x - - - b     stored a-b, new n-s crosses it at x = (4, 3)
    # . . . . | . . . .
    # . . . . s . . . .
    graph = CaseGraph(free(9, 6))
    graph.add_path(line((0, 3), (8, 3)))
    graph.add_path(line((4, 0), (4, 5)))
    assert edge_set(graph) == {seg((0, 3), (4, 3)), seg((4, 3), (8, 3)),
                               seg((4, 0), (4, 3)), seg((4, 3), (4, 5))}
    assert graph.degree((4, 3)) == 4
    check_consistent(graph)


def test_a_path_along_a_stored_segment_reuses_it_and_splits_it_where_it_joins_and_leaves() -> None:
    # . . n . . . . . .
    # . . | . . . . . .
    # . . | . . . . . .
    # a - j = = = l - b     stored a-b; the new path n-j-l-s runs along j..l
    # . . . . . . | . .
    # . . . . . . s . .
    graph = CaseGraph(free(9, 6))
    graph.add_path(line((0, 3), (8, 3)))
    added = graph.add_path(line((2, 0), (2, 3), (6, 3), (6, 5)))
    assert edge_set(graph) == {seg((0, 3), (2, 3)), seg((2, 3), (6, 3)), seg((6, 3), (8, 3)),
                               seg((2, 0), (2, 3)), seg((6, 3), (6, 5))}
    # only the two stretches off the stored segment are new cases
    new = {frozenset(map(tuple, pair)) for pair in zip(*(e.tolist() for e in graph.ends(added)),
                                                       strict=True)}
    assert new == {seg((2, 0), (2, 3)), seg((6, 3), (6, 5))}
    check_consistent(graph)


def test_a_path_already_stored_adds_nothing() -> None:
    graph = CaseGraph(free(8, 8))
    path = line((0, 0), (4, 4), (4, 7))
    graph.add_path(path)
    before = snapshot(graph)
    assert graph.add_path(path) == []
    assert graph.add_path(path[::-1]) == []
    assert_same(before, snapshot(graph))


def test_a_path_with_a_loop_is_stored_without_it() -> None:
    # the path goes right, up, left, down back to (2, 2) and on: the loop is driven once and
    # need not be learnt, the rest is a straight run
    path = np.concatenate([line((0, 2), (2, 2), (2, 0), (1, 0), (1, 1), (2, 2))[:-1],
                           line((2, 2), (6, 2))])
    assert np.array_equal(without_loops(path), line((0, 2), (6, 2)))
    graph = CaseGraph(free(8, 4))
    graph.add_path(path)
    assert edge_set(graph) == {seg((0, 2), (6, 2))}


# --- eq. (12) ---------------------------------------------------------------------------------


@pytest.mark.parametrize("reverse", [False, True], ids=["forward", "backward"])
def test_a_parallel_segment_within_delta_is_skipped_and_one_further_is_kept(reverse: bool
                                                                            ) -> None:
    # a - - - - - - - b    stored
    # c - - - - - - - d    one row away: similar for delta 1, in either orientation
    # e - - - - - - - f    two rows away: kept
    graph = CaseGraph(free(9, 3))
    graph.add_path(line((0, 0), (8, 0)))
    near, far = line((0, 1), (8, 1)), line((0, 2), (8, 2))
    if reverse:
        near, far = near[::-1], far[::-1]
    assert graph.add_path(near, similarity_delta=1) == []
    assert len(graph.add_path(far, similarity_delta=1)) == 1
    assert edge_set(graph) == {seg((0, 0), (8, 0)), seg((0, 2), (8, 2))}


def test_a_staircase_keeps_every_step_though_its_steps_are_similar_to_each_other() -> None:
    # a staircase right, down, right, down ...: each step lies within one cell of the one two
    # steps before it, but eq. (12) compares with what was stored before the path
    #   s-+
    #     +-+
    #       +-+
    stairs = line((0, 0), (1, 0), (1, 1), (2, 1), (2, 2), (3, 2), (3, 3))
    graph = CaseGraph(free(5, 5))
    assert len(graph.add_path(stairs, similarity_delta=1)) == 6
    assert graph.vertex_count == 7


def test_a_diagonal_crossing_between_cells_joins_the_two_paths() -> None:
    # stored: (0, 0) -> (3, 3) diagonally; new: (0, 3) -> (3, 0) diagonally. They cross in the
    # 2x2 block of (1, 1), (2, 1), (1, 2), (2, 2) without sharing a cell: the new step from
    # (1, 2) to (2, 1) passes between the stored cells (1, 1) and (2, 2), so the new path is
    # cut at (1, 2) and joined to (2, 2) by a one-step edge.
    graph = CaseGraph(free(4, 4))
    graph.add_path(line((0, 0), (3, 3)))
    graph.add_path(line((0, 3), (3, 0)))
    assert edge_set(graph) == {seg((0, 0), (2, 2)), seg((2, 2), (3, 3)), seg((0, 3), (1, 2)),
                               seg((1, 2), (3, 0)), seg((1, 2), (2, 2))}
    check_consistent(graph)


# The new segment is the stored one (0, 0)-(8, 0) moved by `offset`; its ends are then `offset`
# away from the stored ends: chebyshev max(dx, dy), euclidean hypot, manhattan dx + dy,
# octile max + (sqrt 2 - 1) min.
SIMILARITY_CASES = [
    # offset, delta, skipped by name
    ((1, 1), 1, {"chebyshev": True, "euclidean": False, "manhattan": False, "octile": False}),
    ((3, 2), 4, {"chebyshev": True, "euclidean": True, "manhattan": False, "octile": True}),
    ((4, 3), 5, {"chebyshev": True, "euclidean": True, "manhattan": False, "octile": False}),
]


@pytest.mark.parametrize("offset, delta, expected", SIMILARITY_CASES)
@pytest.mark.parametrize("name", ["chebyshev", "euclidean", "manhattan", "octile"])
def test_eq_12_under_each_distance(offset: Cell, delta: int, expected: dict[str, bool],
                                   name: str) -> None:
    dx, dy = offset
    # the hand table above agrees with the formulas
    formula = {"chebyshev": max(dx, dy), "euclidean": math.hypot(dx, dy),
               "manhattan": dx + dy, "octile": max(dx, dy) + (math.sqrt(2) - 1) * min(dx, dy)}
    assert (formula[name] <= delta) == expected[name]
    for reverse in (False, True):
        graph = CaseGraph(free(16, 8))
        graph.add_path(line((0, 0), (8, 0)))
        new = line((dx, dy), (8 + dx, dy))
        added = graph.add_path(new[::-1] if reverse else new, similarity_delta=delta,
                               distance=name)
        assert (added == []) == expected[name]


# --- merge_redundant and remove ----------------------------------------------------------------


def test_a_collinear_degree_two_vertex_is_merged_and_the_costs_add_up() -> None:
    # a - - - m - - - b    two edges a-m and m-b on a map with risk: one edge a-b
    risk = np.zeros((3, 9))
    risk[1, :] = np.linspace(0.0, 0.8, 9)
    grid = Grid(risk)
    graph = CaseGraph(grid)
    first = graph.add_path(line((0, 1), (4, 1)))
    second = graph.add_path(line((4, 1), (8, 1)))
    assert edge_set(graph) == {seg((0, 1), (4, 1)), seg((4, 1), (8, 1))}
    total = float(graph.costs(first + second).sum())
    assert graph.merge_redundant() == 1
    assert edge_set(graph) == {seg((0, 1), (8, 1))}
    (edge,) = graph.edge_ids()
    assert graph.costs([edge])[0] == pytest.approx(total)
    assert graph.costs([edge])[0] == pytest.approx(step_costs(grid, line((0, 1), (8, 1))).sum())
    assert graph.vertex_at[1, 4] == -1
    check_consistent(graph)


def test_turn_and_degree_three_vertices_stay() -> None:
    # a - - - t      t is a turn       c - - - x - - - d    x has degree 3
    #         |                                |
    #         b                                e
    graph = CaseGraph(free(12, 8))
    graph.add_path(line((0, 0), (4, 0), (4, 3)))
    graph.add_path(line((0, 5), (8, 5)))
    graph.add_path(line((4, 5), (4, 7)))
    before = edge_set(graph)
    assert graph.merge_redundant() == 0
    assert edge_set(graph) == before
    # removing the branch leaves x collinear with degree 2: now it goes
    graph.remove(graph.edges_at((4, 6)))
    assert graph.merge_redundant() == 1
    assert seg((0, 5), (8, 5)) in edge_set(graph)
    check_consistent(graph)


def test_the_cell_layers_take_a_tile_only_where_the_graph_has_cells() -> None:
    # a 1000x1000 map, 125x125 tiles of 8x8 cells: one diagonal and one row touch only the
    # tiles their cells lie in, and a tile straddling the map's ragged edge reads -1 past it
    graph = CaseGraph(free(1003, 1001))
    graph.add_path(line((0, 0), (999, 999)))
    graph.add_path(line((0, 1000), (1002, 1000)))
    cells = graph.index.cells
    touched = {(x // 8, x // 8) for x in range(1000)} | {(x // 8, 125) for x in range(1003)}
    assert cells.count == len(touched)
    assert cells.nbytes < 2 * len(touched) * 512 + cells.directory.nbytes
    assert cells.directory.nbytes == 126 * 126 * 4
    vertex, owner = graph.vertex_at, graph.owner
    assert vertex.shape == owner.shape == (1001, 1003)
    assert set(map(tuple, np.argwhere(vertex >= 0)[:, ::-1].tolist())) == {
        (0, 0), (999, 999), (0, 1000), (1002, 1000)}
    assert (owner >= 0).sum() == 998 + 1001


def test_a_graph_covering_the_whole_map_keeps_no_more_tiles_than_the_map_has() -> None:
    # 3 x 3 tiles; rows 0, 2, 4, ... each a segment: every tile is made, none spare
    graph = CaseGraph(free(20, 20))
    for y in range(0, 20, 2):
        graph.add_path(line((0, y), (19, y)))
    cells = graph.index.cells
    assert cells.count == len(cells.tiles) == cells.directory.size == 9
    assert cells.nbytes == 9 * 4 + 9 * 512


def test_removing_every_edge_leaves_an_empty_graph() -> None:
    graph = CaseGraph(free(8, 8))
    graph.add_path(line((0, 0), (5, 5), (5, 7)))
    graph.add_path(line((0, 3), (7, 3)))
    graph.remove(graph.edge_ids())
    assert graph.edge_count == 0 and graph.vertex_count == 0
    assert (graph.owner == -1).all() and (graph.vertex_at == -1).all()
    with pytest.raises(KeyError):
        graph.remove([0])


# --- eq. (11) ---------------------------------------------------------------------------------


def brute_meeting(graph: CaseGraph, cell: Cell, delta: int, selective: bool) -> list[int]:
    """Eq. (11) by enumeration of each edge's cells; the selective rule by its end points."""
    found = []
    ids = graph.edge_ids()
    a, b = graph.ends(ids)
    for edge, p, q in zip(ids.tolist(), a, b, strict=True):
        cells = segment_cells(p, q)
        if np.abs(cells - cell).max(axis=1).min() > delta:
            continue
        if selective and min(np.abs(p - cell).max(), np.abs(q - cell).max()) > 3 * delta:
            continue
        found.append(edge)
    return found


def test_selective_adaptation_drops_a_long_segment_whose_ends_are_far() -> None:
    # N(c, 3) around c = (20, 22); the long segment L on row 20 passes through it with both
    # ends farther than 9 = 3·delta; the short S has an end at (18, 24) inside N; F has an end
    # within 9 of c but no cell in N; G is far away.
    #
    # L - - - - - - - - - - - - - - - - - - - L   row 20, x 0..39
    #                   [ . c . ]
    #                   S                         (18, 24) down to (18, 30)
    #                           F - - F           row 26, x 26..30
    graph = CaseGraph(free(40, 40))
    graph.add_path(line((0, 20), (39, 20)))
    graph.add_path(line((18, 24), (18, 30)))
    graph.add_path(line((26, 26), (30, 26)))
    graph.add_path(line((0, 0), (10, 0)))
    ids = {edge_set_key(graph, e): e for e in graph.edge_ids().tolist()}
    long, short = ids[seg((0, 20), (39, 20))], ids[seg((18, 24), (18, 30))]
    cell = (20, 22)
    full = graph.meeting(cell, 3).tolist()
    selective = graph.meeting(cell, 3, selective=True).tolist()
    assert full == sorted([long, short])
    assert selective == [short]
    assert full == brute_meeting(graph, cell, 3, False)
    assert selective == brute_meeting(graph, cell, 3, True)


def edge_set_key(graph: CaseGraph, edge: int) -> frozenset[Cell]:
    a, b = graph.ends([edge])
    return seg(tuple(a[0].tolist()), tuple(b[0].tolist()))


def test_meeting_at_the_map_border() -> None:
    graph = CaseGraph(free(10, 10))
    graph.add_path(line((0, 9), (9, 9)))
    graph.add_path(line((9, 0), (9, 5)))
    for cell in [(0, 0), (9, 9), (0, 9), (8, 2)]:
        for selective in (False, True):
            assert (graph.meeting(cell, 2, selective=selective).tolist()
                    == brute_meeting(graph, cell, 2, selective))


# --- segment costs ----------------------------------------------------------------------------


def test_segment_costs_are_the_summed_step_costs_on_a_map_with_risk() -> None:
    rng = np.random.default_rng(5)
    grid = Grid(rng.uniform(0.0, 0.9, (12, 12)))
    graph = CaseGraph(grid)
    graph.add_path(line((0, 0), (6, 6), (6, 11), (11, 11)))
    graph.add_path(line((0, 8), (11, 8)))
    ids = graph.edge_ids()
    a, b = graph.ends(ids)
    for edge, p, q in zip(ids.tolist(), a, b, strict=True):
        cells = segment_cells(p, q)
        expected = sum(math.hypot(*(v - u)) * (1 + grid.risk[u[1], u[0]] + 1
                                               + grid.risk[v[1], v[0]]) / 2
                       for u, v in itertools.pairwise(cells))
        assert graph.costs([edge])[0] == pytest.approx(expected)
        assert graph.costs([edge])[0] == pytest.approx(step_costs(grid, cells).sum())
        assert graph.risks([edge])[0] == pytest.approx(grid.risk[cells[:, 1], cells[:, 0]].mean())


def test_a_diagonal_past_a_blocked_corner_costs_infinity() -> None:
    # a #      the diagonal a-b passes the blocked (1, 0): refused without corner cutting
    # . b
    risk = np.zeros((3, 3))
    risk[0, 1] = 1.0
    cost, _ = segment_costs(Grid(risk), [(0, 0)], [(2, 2)])
    assert cost[0] == np.inf
    cost, _ = segment_costs(Grid(risk, corner_cutting=True), [(0, 0)], [(2, 2)])
    assert cost[0] == pytest.approx(2 * math.sqrt(2))


def test_a_segment_through_an_obstacle_costs_infinity_and_is_not_planned_on() -> None:
    # s = = = = = = # = = = = = = g      route A: straight, blocked later at (15, 10)
    # |                           |
    # + - - - - - - - - - - - - - +      route B: round about, rows 10..20
    grid = free(30, 24)
    graph = CaseGraph(grid)
    graph.add_path(line((2, 10), (27, 10)))
    graph.add_path(line((2, 10), (2, 20), (27, 20), (27, 10)))
    (direct,) = graph.edges_at((15, 10))
    options = Settings(delta=3)
    found = plan(graph, (2, 10), (27, 10), options)
    assert isinstance(found, Plan)
    assert found.cost == pytest.approx(25) and found.edges == (direct,)
    risk = np.zeros((24, 30))
    risk[10, 15] = 1.0
    graph.set_grid(Grid(risk))
    assert graph.costs([direct])[0] == np.inf
    found = plan(graph, (2, 10), (27, 10), options)
    assert isinstance(found, Plan)
    assert direct not in found.edges
    assert found.cost == pytest.approx(45)
    assert graph.grid.path_problems(found.path) == []


# --- planning ---------------------------------------------------------------------------------


def l_graph() -> CaseGraph:
    # the stored path a - - - - t along row 5, down to b = (25, 25); s = (10, 5) lies inside
    # the edge a-t, g = (27, 27) is two diagonal steps from the vertex b
    #
    # a - - - s - - - - - - - t      y = 5
    #                         |
    #                         b      y = 25
    #                           .
    #                             g
    graph = CaseGraph(free(30, 30), MemoryStore())
    graph.add_path(line((2, 5), (25, 5), (25, 25)))
    return graph


def test_a_start_inside_a_stored_edge_uses_it_without_a_temporary_edge() -> None:
    graph = l_graph()
    before = snapshot(graph)
    (row,) = graph.edges_at((10, 5))
    (column,) = graph.edges_at((25, 15))
    found = plan(graph, (10, 5), (27, 27), Settings(delta=3))
    assert isinstance(found, Plan)
    assert np.array_equal(found.path, line((10, 5), (25, 5), (25, 25), (27, 27)))
    assert found.edges == (row, column)
    assert found.cost == pytest.approx(15 + 20 + 2 * math.sqrt(2))
    # the start takes the stored edge it lies in: its two virtual halves are the only
    # temporary edges besides the goal's one link to b
    assert found.detail["start_cases"] == 1
    assert found.detail["temporary_edges"] == 3
    assert_same(before, snapshot(graph))
    assert graph.store is not None and graph.store.count(SEGMENT) == 2


def test_start_and_goal_within_delta_fail() -> None:
    graph = l_graph()
    found = plan(graph, (10, 5), (13, 8), Settings(delta=3))
    assert isinstance(found, Failure) and "within delta" in found.reason


def test_no_case_near_the_goal_fails() -> None:
    graph = l_graph()
    found = plan(graph, (10, 5), (5, 25), Settings(delta=3))
    assert isinstance(found, Failure) and "goal" in found.reason
    found = plan(graph, (5, 25), (10, 5), Settings(delta=3))
    assert isinstance(found, Failure) and "start" in found.reason


def test_temporary_edges_never_persist() -> None:
    graph = l_graph()
    graph.add_path(line((0, 15), (29, 15)))
    before = snapshot(graph)
    rng = np.random.default_rng(1)
    plans = 0
    for _ in range(60):
        start, goal = (tuple(int(v) for v in rng.integers(0, 30, 2)) for _ in range(2))
        for options in (Settings(delta=4), Settings(delta=4, selective=True),
                        Settings(delta=4, graph_search="dijkstra")):
            plans += isinstance(plan(graph, start, goal, options), Plan)
    assert plans > 20
    assert_same(before, snapshot(graph))

    def broken(*args: object) -> None:
        raise RuntimeError("search failed")

    with pytest.raises(RuntimeError, match="search failed"):
        plan(graph, (12, 7), (27, 27), Settings(delta=4, connector="astar"), broken)
    assert_same(before, snapshot(graph))
    # and the graph still plans as before
    assert isinstance(plan(graph, (12, 7), (27, 27), Settings(delta=4)), Plan)


# --- state and persistence --------------------------------------------------------------------


def stored_edges(store: Any) -> set[frozenset[Cell]]:
    return {seg(tuple(c.problem["a"]), tuple(c.problem["b"])) for c in store.cases(SEGMENT)}


def graph_context(grid: Grid, store: Any) -> Context:
    return Context(registry=Registry(), seed=0, world=grid, casebase=store)


def test_the_graph_reloads_after_a_rolled_back_learn_step(store: Any) -> None:
    grid = free(20, 20)
    ctx = graph_context(grid, store)
    with ctx.mirror.transaction():
        graph_of(ctx).add_path(line((0, 5), (19, 5)))
    kept = graph_of(ctx)
    assert edge_set(kept) == {seg((0, 5), (19, 5))}
    with pytest.raises(RuntimeError), ctx.mirror.transaction():
        # crosses the stored edge: splits it in two and adds two more, all rolled back
        graph_of(ctx).add_path(line((8, 0), (8, 12)))
        assert len(edge_set(graph_of(ctx))) == 4
        raise RuntimeError("learn step failed")
    graph = graph_of(ctx)
    assert graph is not kept
    assert edge_set(graph) == stored_edges(store) == {seg((0, 5), (19, 5))}
    assert np.array_equal(graph.edge_ids(), CaseGraph.load(grid, store).edge_ids())
    check_consistent(graph)
    # a committed step after the reload is kept without another one
    with ctx.mirror.transaction():
        graph_of(ctx).add_path(line((8, 0), (8, 12)))
    assert graph_of(ctx) is graph
    assert edge_set(graph) == stored_edges(store)


def test_the_graph_follows_another_writers_commits(store: Any) -> None:
    grid = free(20, 20)
    ctx = graph_context(grid, store)
    kept = graph_of(ctx)
    other = CaseGraph(grid, store)
    with store.transaction():
        other.add_path(line((0, 0), (10, 10)))
    assert graph_of(ctx) is kept  # the engine syncs the mirror before each query
    ctx.mirror.sync()
    assert graph_of(ctx) is kept
    assert edge_set(kept) == stored_edges(store) == {seg((0, 0), (10, 10))}
    with store.transaction():
        # splits the other's diagonal at (5, 5): two segments removed, four added
        other.add_path(line((5, 0), (5, 15), (19, 15)))
    with ctx.mirror.transaction():  # a learn step catches up before it writes
        graph_of(ctx).add_path(line((2, 19), (2, 17)))
    assert graph_of(ctx) is kept and ctx.mirror.reloads == 0
    assert edge_set(kept) == stored_edges(store)
    assert len(stored_edges(store)) == 6
    check_consistent(kept)


def graph_state(graph: CaseGraph) -> dict[frozenset[Cell], tuple[int, float, int]]:
    """Each edge's id, cost and use count, by its ends."""
    ids = graph.edge_ids()
    a, b = graph.ends(ids)
    return {frozenset({tuple(p), tuple(q)}): (edge, cost, uses) for p, q, edge, cost, uses in zip(
        a.tolist(), b.tolist(), ids.tolist(), graph.costs(ids).tolist(),
        graph.uses(ids).tolist(), strict=True)}


corner = st.tuples(st.integers(0, 11), st.integers(0, 11))


@given(st.lists(st.tuples(st.sampled_from(["path", "path", "remove", "touch"]),
                          st.lists(corner, min_size=2, max_size=3)), max_size=8),
       st.integers(1, 3))
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_a_followed_graph_equals_one_loaded_anew(steps: list[tuple[str, list[Cell]]],
                                                 every: int) -> None:
    """Whatever another writer retains, splits, merges or forgets, the graph that followed its
    commits (caught up every ``every`` commits) equals the graph loaded from the store."""
    rng = np.random.default_rng(len(steps))
    grid = Grid(np.where(rng.random((12, 12)) < 0.15, 0.5, 0.0))
    store = MemoryStore()
    ctx = graph_context(grid, store)
    followed = graph_of(ctx)
    other = CaseGraph(grid, store)
    for n, (op, corners) in enumerate(steps):
        with store.transaction():
            ids = other.edge_ids().tolist()
            if op == "path" or not ids:
                # straight runs between the corners, bent to the 8 directions
                cells = [corners[0]]
                for (x0, y0), (x1, y1) in itertools.pairwise(corners):
                    d = min(abs(x1 - x0), abs(y1 - y0))
                    mid = (x0 + d * np.sign(x1 - x0), y0 + d * np.sign(y1 - y0))
                    cells += [(int(mid[0]), int(mid[1])), (x1, y1)]
                path = line(*dict.fromkeys(cells))
                if len(path) > 1:
                    other.add_path(path)
            elif op == "remove":
                other.remove([ids[corners[0][0] % len(ids)]])
            else:
                touched = [ids[x % len(ids)] for x, _ in corners]
                store.touch(touched)
                other.record_use(touched)
            other.merge_redundant()
        if n % every == 0:
            ctx.mirror.sync()
    ctx.mirror.sync()
    assert graph_of(ctx) is followed
    check_consistent(followed)
    assert graph_state(followed) == graph_state(CaseGraph.load(grid, store))


def test_a_stored_graph_loads_back_the_same(store: Any) -> None:
    rng = np.random.default_rng(3)
    grid = Grid(np.where(rng.random((20, 20)) < 0.1, 0.5, 0.0))
    graph = CaseGraph(grid, store)
    graph.add_path(line((0, 0), (10, 10), (10, 19)))
    graph.add_path(line((0, 12), (19, 12)))
    graph.add_path(line((3, 19), (3, 8), (15, 8)))
    graph.remove(graph.edges_at((15, 8)))
    graph.merge_redundant()
    loaded = CaseGraph.load(grid, store)
    assert np.array_equal(loaded.edge_ids(), graph.edge_ids())
    for end, again in zip(graph.ends(graph.edge_ids()), loaded.ends(loaded.edge_ids()),
                          strict=True):
        assert np.array_equal(end, again)
    assert np.array_equal(loaded.costs(loaded.edge_ids()), graph.costs(graph.edge_ids()))
    assert np.array_equal(loaded.owner, graph.owner)
    check_consistent(loaded)


def test_a_case_base_of_another_map_size_is_refused_naming_the_case(store: Any) -> None:
    graph = CaseGraph(free(20, 20), store)
    graph.add_path(line((0, 0), (3, 0)))
    graph.add_path(line((10, 10), (15, 10)))
    far = graph.edges_at((12, 10))[0]
    with pytest.raises(CbrError, match=rf"segment case {far} .*outside the 8x8 map"):
        CaseGraph.load(free(8, 8), store)


# --- properties -------------------------------------------------------------------------------


@st.composite
def worlds(draw: st.DrawFn, ties: bool = True
           ) -> tuple[Grid, list[tuple[Cell, Cell]], list[tuple[Cell, Cell]], int | None]:
    """A random map, pairs of cells whose Dijkstra paths are retained, and queries.

    With ``ties`` the free cells have risk 0 or 0.6, so many paths cost the same; without, each
    free cell draws its own risk, so that (almost surely) no two paths cost the same.
    """
    width = draw(st.integers(8, 20))
    height = draw(st.integers(8, 20))
    seed = draw(st.integers(0, 2**32 - 1))
    density = draw(st.sampled_from([0.0, 0.1, 0.2, 0.3]))
    rng = np.random.default_rng(seed)
    hazard = (np.where(rng.random((height, width)) < 0.2, 0.6, 0.0) if ties
              else rng.uniform(0.05, 0.9, (height, width)))
    risk = np.where(rng.random((height, width)) < density, 1.0, hazard)
    free_cells = np.argwhere(risk < 1)
    if len(free_cells) < 2:
        risk[:] = 0.0
        free_cells = np.argwhere(risk < 1)

    def pairs(count: int) -> list[tuple[Cell, Cell]]:
        picks = rng.integers(0, len(free_cells), (count, 2))
        return [((int(free_cells[i][1]), int(free_cells[i][0])),
                 (int(free_cells[j][1]), int(free_cells[j][0]))) for i, j in picks.tolist()]

    similarity = draw(st.sampled_from([0, 1, 2]))
    return (Grid(risk, corner_cutting=draw(st.booleans())), pairs(draw(st.integers(1, 8))),
            pairs(12), similarity)


def retained(grid: Grid, pairs: Sequence[tuple[Cell, Cell]], similarity: int,
             merge: bool) -> CaseGraph:
    graph = CaseGraph(grid)
    for start, goal in pairs:
        found = dijkstra(grid.factor, grid.passable, grid.corner_cutting, start, [goal])
        if found is not None and len(found.path) > 1:
            graph.add_path(found.path, similarity_delta=similarity)
            check_consistent(graph)
    if merge:
        graph.merge_redundant()
    return graph


@given(worlds())
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_at_similarity_radius_zero_no_new_segment_repeats_a_stored_ones_ends(
        world: tuple[Grid, list[tuple[Cell, Cell]], list[tuple[Cell, Cell]], int | None]
        ) -> None:
    """Eq. (12) at δr = 0 skips a new segment whose two ends a stored segment has: add_path
    leaves the test out, since a new segment never has them. Checked against the segments
    stored before each path, as eq. (12) compares."""
    grid, pairs, _, _ = world
    graph = CaseGraph(grid)
    for start, goal in pairs:
        found = dijkstra(grid.factor, grid.passable, grid.corner_cutting, start, [goal])
        if found is None or len(found.path) < 2:
            continue
        before = edge_set(graph)
        added = graph.add_path(found.path)
        a, b = graph.ends(np.asarray(added, dtype=np.int64))
        new = {frozenset({tuple(p), tuple(q)}) for p, q in zip(a.tolist(), b.tolist(),
                                                                strict=True)}
        assert not new & before


def optimal(grid: Grid, start: Cell, goal: Cell) -> float:
    found = dijkstra(grid.factor, grid.passable, grid.corner_cutting, start, [goal])
    return np.inf if found is None else found.cost


def check_plan(grid: Grid, start: Cell, goal: Cell, found: Plan) -> None:
    assert grid.path_problems(found.path) == []
    assert tuple(found.path[0]) == start and tuple(found.path[-1]) == goal
    expected = path_cost(grid, found.path) if len(found.path) > 1 else 0.0
    assert found.cost == pytest.approx(expected)
    assert found.cost >= optimal(grid, start, goal) - 1e-9
    # the loops are cut out: each cell once
    assert len({tuple(c) for c in found.path.tolist()}) == len(found.path)


PROPERTY = settings(max_examples=40, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


@PROPERTY
@given(worlds(), st.booleans(), st.integers(1, 4), st.booleans())
def test_plans_are_valid_and_never_beat_dijkstra(world: Any, merge: bool, delta: int,
                                                 selective: bool) -> None:
    grid, pairs, queries, similarity = world
    graph = retained(grid, pairs, similarity, merge)
    check_consistent(graph)
    before = snapshot(graph)
    for start, goal in queries:
        found = plan(graph, start, goal, Settings(delta=delta, selective=selective))
        event(type(found).__name__)
        if isinstance(found, Plan):
            check_plan(grid, start, goal, found)
    assert_same(before, snapshot(graph))


@PROPERTY
@given(worlds(), st.data())
def test_the_graph_stays_consistent_under_retain_forget_and_merge(world: Any,
                                                                  data: st.DataObject) -> None:
    grid, pairs, queries, similarity = world
    graph = retained(grid, pairs, similarity, merge=False)
    for start, goal in queries[:4]:
        found = dijkstra(grid.factor, grid.passable, grid.corner_cutting, start, [goal])
        if found is not None and len(found.path) > 1:
            graph.add_path(found.path, similarity_delta=similarity)
        ids = graph.edge_ids().tolist()
        if ids:
            graph.remove(data.draw(st.lists(st.sampled_from(ids), max_size=3, unique=True)))
        check_consistent(graph)
        graph.merge_redundant()
        check_consistent(graph)


@PROPERTY
@given(worlds(ties=False), st.integers(1, 4))
def test_connectors_and_graph_searches_agree_on_the_cost(world: Any, delta: int) -> None:
    grid, pairs, queries, similarity = world
    graph = retained(grid, pairs, similarity, merge=True)
    variants: list[tuple[Settings, Callable[..., Any] | None]] = [
        (Settings(delta=delta, connector="dijkstra", graph_search="astar"), None),
        (Settings(delta=delta, connector="dijkstra", graph_search="dijkstra"), None),
        (Settings(delta=delta, connector="astar", graph_search="astar"), searched(astar)),
        (Settings(delta=delta, connector="astar", graph_search="dijkstra"), searched(astar)),
        (Settings(delta=delta, connector="jps", graph_search="astar"),
         searched(load_search("jps"))),
    ]
    for start, goal in queries:
        results = [plan(graph, start, goal, options, search) for options, search in variants]
        kinds = {type(r) for r in results}
        assert len(kinds) == 1, results
        plans = [r for r in results if isinstance(r, Plan)]
        event(f"plans: {len(plans)}")
        for found in plans:
            check_plan(grid, start, goal, found)
        if plans:
            assert max(p.cost for p in plans) == pytest.approx(min(p.cost for p in plans))


def test_equally_near_cells_of_a_case_do_not_change_the_plan() -> None:
    # the case runs diagonally between (0, 0) and (10, 10); from s = (2, 5) its cells p and q
    # are equally near (1 + sqrt 2), and only q leads on to g = (13, 13) without doubling back
    #
    # a . . . .
    # . \ . . .
    # . . \ . .
    # . . . p .     p = (3, 3)
    # . . . . q     q = (4, 4)
    # . . s . . \   s = (2, 5)
    best = 1 + math.sqrt(2) + 6 * math.sqrt(2) + 3 * math.sqrt(2)
    costs = {}
    for reverse in (False, True):
        graph = CaseGraph(free(14, 14))
        path = line((0, 0), (10, 10))
        graph.add_path(path[::-1] if reverse else path)
        for name, search in (("dijkstra", None), ("astar", searched(astar))):
            found = plan(graph, (2, 5), (13, 13), Settings(delta=3, connector=name), search)
            assert isinstance(found, Plan)
            costs[name, reverse] = found.cost
    # the Dijkstra connector links s to both p and q, whichever way the case was stored; a
    # connector that searches once per case keeps the one nearest cell its search reaches first,
    # so its plan may go by p and pay the sqrt 2 back to q
    assert costs["dijkstra", False] == pytest.approx(best)
    assert costs["dijkstra", True] == pytest.approx(best)
    for reverse in (False, True):
        assert costs["astar", reverse] in (pytest.approx(best), pytest.approx(best + math.sqrt(2)))


def test_a_cell_turning_obstacle_beside_a_diagonal_edge_makes_it_infinite() -> None:
    # the stored diagonal (0, 0)-(3, 3) steps from (1, 1) to (2, 2) past the corner (2, 1);
    # when (2, 1) becomes an obstacle that step cuts a blocked corner
    grid = free(4, 4)
    graph = CaseGraph(grid)
    graph.add_path(line((0, 0), (3, 3)))
    risk = grid.risk.copy()
    risk[1, 2] = 1.0
    graph.set_grid(Grid(risk), [(2, 1)])
    assert not np.isfinite(graph.costs(graph.edge_ids())).any()


# --- the ideal length of the quality test ---------------------------------------------------


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**31 - 1), st.integers(1, 4))
def test_the_landmark_bound_never_exceeds_the_shortest_length(seed: int, count: int) -> None:
    from cbr_grid.costs import path_length
    from cbr_grid.generate import generate
    from cbr_pathquality.ideal import Landmarks

    grid = generate("office", 24, 20, seed)
    bound = Landmarks(grid, count)
    rng = np.random.default_rng(seed)
    cells = np.argwhere(grid.passable)
    for _ in range(20):
        (y1, x1), (y2, x2) = cells[rng.integers(len(cells), size=2)]
        start, goal = (int(x1), int(y1)), (int(x2), int(y2))
        found = dijkstra(np.ones(grid.passable.shape), grid.passable, grid.corner_cutting,
                         start, [goal])
        if found is not None:
            assert bound.bound(start, goal) <= path_length(found.path) + 1e-9


def test_the_landmark_bound_sees_a_wall_that_the_octile_distance_does_not() -> None:
    from cbr_pathquality.ideal import Landmarks

    # a wall down column 4 with one gap at the bottom, (4, 9): from (2, 0) to (6, 0) the
    # shortest path runs through the gap, twice the octile distance from (2, 0) to (4, 9),
    # 2·(9 + 2·(√2 - 1)) ≈ 19.66, while the octile distance from start to goal is 4; a
    # landmark in a corner of the map sees the whole detour
    risk = np.zeros((10, 9))
    risk[:9, 4] = 1.0
    shortest = 2 * (9 + 2 * (math.sqrt(2) - 1))
    bound = Landmarks(Grid(risk), 4)
    # the tables round lengths down to their unit, which the bound may lose twice
    assert shortest - 2 * bound.unit <= bound.bound((2, 0), (6, 0)) <= shortest


def test_the_genetic_algorithm_can_make_the_temporary_edges() -> None:
    from cbr_solvers import load_search

    risk = np.zeros((40, 40))
    risk[10:30, 20] = 1.0
    grid = Grid(risk)
    graph = CaseGraph(grid)
    graph.add_path(dijkstra(grid.factor, grid.passable, False, (2, 20), [(37, 20)]).path)
    result = plan(graph, (4, 24), (35, 16), Settings(delta=6, connector="genetic"),
                  searched(load_search("genetic")))
    assert isinstance(result, Plan)
    assert grid.path_problems(result.path) == []
    assert tuple(result.path[0]) == (4, 24) and tuple(result.path[-1]) == (35, 16)
    assert result.cost == pytest.approx(path_cost(grid, result.path))


@settings(max_examples=200, deadline=None)
@given(st.integers(-20, 20), st.integers(-20, 20), st.sampled_from(
    [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)]),
    st.integers(1, 15), st.integers(-25, 25), st.integers(-25, 25))
def test_the_retrievers_distance_to_a_segment_is_the_brute_force_minimum(
        ax: int, ay: int, d: Cell, k: int, cx: int, cy: int) -> None:
    from cbr_casegraph.components import segment_distance

    a, b = (ax, ay), (ax + k * d[0], ay + k * d[1])
    brute = np.abs(segment_cells(a, b) - (cx, cy)).max(axis=1).min()
    found = segment_distance(np.array([a]), np.array([b]), np.array([cx, cy]))
    assert found[0] == brute
