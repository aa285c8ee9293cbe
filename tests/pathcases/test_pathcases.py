"""Whole-path cases (``cbr_pathcases``): the cost F, the path base, retrieval and selection.

The cost F(l, r, g) is checked on a path worked out by hand around a wall; the path base against
the store after committed and rolled-back learn steps; the retrieval rule of eq. (5)/(7)
(survey; Šeda & Dvořák) against a brute force written from the equation, under each distance;
the selection rules against their formulas worked by hand, and the retriever's choices against
them by a chi-square test over many queries. Grids are drawn with x to the right, y downwards.
The helpers here are shared by test_learning.py and test_reuse.py.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from typing import Any

import attrs
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import chisquare

from cbr_grid.grid import Grid
from cbr_grid.query import GridQuery
from cbr_pathcases.base import PATH, PathBase, base_of, path_case
from cbr_pathcases.components import PathRetriever, RetrieveOptions
from cbr_pathcases.cost import Measure, ideal_length, measure
from cbr_pathcases.selection import probabilities
from cbrcore.casebase.memory import MemoryStore
from cbrcore.casebase.store import CaseStore, Changes
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.model import Case, Retrieval
from cbrcore.registry import Registry

Cell = tuple[int, int]
SQRT2 = math.sqrt(2.0)
DISTANCES = ("euclidean", "manhattan", "octile", "chebyshev")


# --- helpers (shared by the other test_pathcases_* modules) ----------------------------------


def free(width: int, height: int) -> Grid:
    return Grid(np.zeros((height, width)))


def run(*corners: Cell) -> np.ndarray:
    """The cells from corner to corner in 8-neighbour steps, each leg diagonal first, then
    straight: a shortest path on a free grid."""
    x, y = corners[0]
    cells = [(x, y)]
    for tx, ty in corners[1:]:
        while (x, y) != (tx, ty):
            x += (tx > x) - (tx < x)
            y += (ty > y) - (ty < y)
            cells.append((x, y))
    return np.array(cells, dtype=np.int64)


def context(grid: Grid, store: CaseStore | None = None, seed: int = 0) -> Context:
    return Context(registry=Registry(), seed=seed, world=grid,
                   casebase=MemoryStore() if store is None else store)


def keep(ctx: Context, path: np.ndarray, cost: float, traversals: int = 1) -> int:
    """Store ``path`` with cost ``cost`` in the run's path base; its id."""
    return base_of(ctx).add(path, {"cost": cost, "length": float(len(path) - 1), "risk": 0.0,
                                   "ideal": 1.0, "traversals": traversals})


def reference_distance(name: str, a: Sequence[int], b: Sequence[int]) -> float:
    """Eqs. (1), (2), (3) and (9) written from the papers."""
    dx, dy = abs(a[0] - b[0]), abs(a[1] - b[1])
    return {"euclidean": math.sqrt(dx * dx + dy * dy), "manhattan": float(dx + dy),
            "octile": (SQRT2 - 1) * min(dx, dy) + max(dx, dy),
            "chebyshev": float(max(dx, dy))}[name]


def retrieve(ctx: Context, start: Cell, goal: Cell, **options: Any) -> Retrieval:
    """One retrieval by a fresh retriever (explore 0 unless given)."""
    retriever = PathRetriever(RetrieveOptions(**{"explore": 0.0, **options}), ctx)
    return retriever.cbr_retrieve(problem=GridQuery(start, goal), casebase=ctx.casebase,
                                  ctx=ctx)


def assert_same_base(base: PathBase, other: PathBase) -> None:
    for name in ("ids", "starts", "goals", "costs", "traversals", "uses", "created",
                 "last_used", "boxes"):
        assert np.array_equal(getattr(base, name), getattr(other, name)), name
    assert len(base.paths) == len(other.paths)
    for path, again in zip(base.paths, other.paths, strict=True):
        assert np.array_equal(path, again)


# --- the cost F(l, r, g) ----------------------------------------------------------------------

#   x 0 1 2 3 4
# y0  S . # . G
# y1  . . # . .
# y2  . . . r .      r: risk 0.5
# The only way past the wall is (2, 2), entered straight from (1, 2) or (3, 2) (the diagonals
# would cut a blocked corner): the shortest path from S to G is 2 · (2 + sqrt 2) long.
WALL = np.array([[0, 0, 1, 0, 0],
                 [0, 0, 1, 0, 0],
                 [0, 0, 0, 0.5, 0]])
AROUND = np.array([(0, 0), (0, 1), (0, 2), (1, 2), (2, 2), (3, 2), (4, 2), (4, 1), (4, 0)])


def test_the_ideal_cost_is_the_shortest_length_around_the_wall() -> None:
    grid = Grid(WALL)
    assert ideal_length(grid, (0, 0), (4, 0)) == pytest.approx(4 + 2 * SQRT2)
    # risk is ignored: the risky cell (3, 2) lies on every shortest path anyway, and moving the
    # risk elsewhere changes nothing
    assert ideal_length(Grid(np.where(WALL == 0.5, 0, WALL)), (0, 0), (4, 0)) == pytest.approx(
        4 + 2 * SQRT2)
    # a path back to its start: at least 1, so a ratio to it is defined
    assert ideal_length(grid, (1, 1), (1, 1)) == 1.0
    # no way through: the octile distance
    walled = WALL.copy()
    walled[2, 2] = 1
    assert ideal_length(Grid(walled), (0, 0), (4, 1)) == pytest.approx(3 + SQRT2)


def test_the_measure_of_a_path_driven_around_the_wall() -> None:
    grid = Grid(WALL)
    # eight straight steps; one obstacle met cost collision time 5 besides them; the two steps
    # into and out of the risky cell cost (1 + 1.5) / 2 each, 0.5 more than their length
    driven = measure(grid, AROUND, lost=5)
    assert driven.length == pytest.approx(8)
    assert driven.risk == pytest.approx(5 + 0.5)
    assert driven.ideal == pytest.approx(4 + 2 * SQRT2)
    assert measure(grid, AROUND).risk == pytest.approx(0.5)
    assert measure(grid, AROUND, ideal=2.5).ideal == 2.5
    # diagonal steps are sqrt 2 long
    diagonal = measure(grid, np.array([(0, 0), (1, 1), (1, 2), (2, 2)]))
    assert diagonal.length == pytest.approx(2 + SQRT2)
    assert diagonal.ideal == pytest.approx(2 + SQRT2)


@pytest.mark.parametrize(("combine", "weight", "expected"), [
    ("ratio", 1.0, 13.5 / (4 + 2 * SQRT2)),
    ("sum", 1.0, 13.5),
    ("sum", 2.0, 8 + 2 * 5.5),
    ("ratio", 2.0, 19 / (4 + 2 * SQRT2)),
    ("ratio", 0.0, 8 / (4 + 2 * SQRT2)),
])
def test_ratio_and_sum_combine_length_risk_and_ideal(combine: Any, weight: float,
                                                      expected: float) -> None:
    assert Measure(8.0, 5.5, 4 + 2 * SQRT2).cost(combine, weight) == pytest.approx(expected)


def test_a_shortest_path_driven_without_trouble_costs_one_by_the_ratio() -> None:
    grid = free(10, 6)
    # three diagonal steps, then six straight ones; driven in exactly its length
    path = run((0, 0), (3, 3), (9, 3))
    assert measure(grid, path).cost("ratio", 1.0) == pytest.approx(1.0)


# --- the path base ----------------------------------------------------------------------------


def stored_ids(store: CaseStore) -> list[int]:
    return [int(case.id or 0) for case in store.cases(PATH)]


def test_the_path_base_follows_the_store_and_loads_back_the_same(store: Any) -> None:
    ctx = context(free(12, 8), store)
    base = base_of(ctx)
    first = keep(ctx, run((0, 1), (9, 1)), 1.5)
    second = keep(ctx, run((0, 5), (4, 1)), 1.25, traversals=3)
    third = keep(ctx, run((2, 7), (11, 7)), 2.0)
    base.set_cost(second, 1.125, 4)
    base.touch([third, first])
    base.touch([third])
    base.remove([first])
    assert base.ids.tolist() == stored_ids(store) == [second, third]
    assert base.costs.tolist() == [1.125, 2.0]
    assert base.traversals.tolist() == [4, 1]
    assert base.uses.tolist() == [0, 2]
    assert base.starts.tolist() == [[0, 5], [2, 7]]
    assert base.goals.tolist() == [[4, 1], [11, 7]]
    assert store.get(second).meta["cost"] == 1.125
    assert_same_base(base, PathBase.load(store))
    assert base.boxes.tolist() == [[0, 1, 4, 5], [2, 7, 11, 7]]
    # a path along part of row 7 lies along the third path only, and one row off, within 1
    assert base.near(run((3, 7), (8, 7)), 0.0).tolist() == base.rows([third]).tolist()
    assert base.near(run((3, 6), (8, 6)), 0.0).tolist() == []
    rows, forward, _ = base.hausdorff(run((3, 6), (8, 6)), distance="chebyshev",
                                      limit=1.0)
    assert rows[forward <= 1.0].tolist() == base.rows([third]).tolist()
    assert forward[rows == base.rows([third])[0]].tolist() == [1.0]


def next_query(ctx: Context) -> None:
    """Move on to the next query, as the engine does before it retrieves."""
    ctx.step += 1
    ctx.mirror.sync()


def test_the_path_base_reloads_after_a_rolled_back_learn_step(store: Any) -> None:
    ctx = context(free(12, 8), store)
    with ctx.mirror.transaction():
        first = keep(ctx, run((0, 1), (9, 1)), 1.5)
    next_query(ctx)
    kept = base_of(ctx)
    assert base_of(ctx) is kept and kept.ids.tolist() == [first]
    with pytest.raises(RuntimeError), ctx.mirror.transaction():
        base = base_of(ctx)
        base.add(run((0, 5), (9, 5)), {"cost": 1.0, "length": 9.0, "risk": 0.0, "ideal": 9.0,
                                        "traversals": 1})
        base.set_cost(first, 1.25, 2)
        base.touch([first])
        # a later phase of the same step sees the step's own writes, not a reload
        assert base_of(ctx) is base and len(base) == 2
        raise RuntimeError("learn step failed")
    next_query(ctx)
    base = base_of(ctx)
    assert base is not kept
    assert base.ids.tolist() == stored_ids(store) == [first]
    assert base.costs.tolist() == [1.5] and base.traversals.tolist() == [1]
    assert base.uses.tolist() == [0] and base.last_used.tolist() == [-1]
    assert_same_base(base, PathBase.load(store))
    # a committed step after the reload is kept without another one
    with ctx.mirror.transaction():
        second = base.add(run((0, 5), (9, 5)), {"cost": 1.0, "length": 9.0, "risk": 0.0,
                                                "ideal": 9.0, "traversals": 1})
        third = base_of(ctx).add(run((0, 7), (9, 7)), {"cost": 1.0, "length": 9.0,
                                                       "risk": 0.0, "ideal": 9.0,
                                                       "traversals": 1})
    next_query(ctx)
    assert base_of(ctx) is base
    assert base.ids.tolist() == stored_ids(store) == [first, second, third]


def test_the_path_base_follows_another_writers_commits(store: Any) -> None:
    ctx = context(free(12, 8), store)
    base = base_of(ctx)
    with ctx.mirror.transaction():
        first = keep(ctx, run((0, 1), (9, 1)), 1.5)
        second = keep(ctx, run((0, 5), (9, 5)), 2.0)
    next_query(ctx)
    assert base_of(ctx) is base
    # another writer counts a use, adds a path, changes a cost and forgets a path: the base
    # takes the changes instead of loading everything anew
    store.touch([first])
    next_query(ctx)
    assert base_of(ctx) is base and base.uses.tolist() == [1, 0]
    with store.transaction():
        third = store.add(path_case(run((0, 3), (9, 3)), {
            "cost": 1.0, "length": 9.0, "risk": 0.0, "ideal": 9.0, "traversals": 1})).id
        changed = store.get(first)
        store.replace(attrs.evolve(changed, meta={**changed.meta, "cost": 4.0,
                                                  "traversals": 3}))
        store.remove([second])
    store.touch([first])
    with ctx.mirror.transaction():  # a learn step catches up before it writes
        assert base_of(ctx) is base
        assert base.ids.tolist() == stored_ids(store) == [first, third]
        assert_same_base(base, PathBase.load(store))
    assert base.costs.tolist() == [4.0, 1.0] and base.uses.tolist() == [2, 0]
    assert ctx.mirror.reloads == 0


def test_a_followed_new_case_below_the_stored_ids_keeps_the_rows_ordered_by_id() -> None:
    """The protocol promises ids never reused, not growing ones: a store may hand a new case an
    id below the stored ones, and the rows stay ordered by id as loading orders them."""
    store = MemoryStore()
    meta = {"cost": 1.0, "length": 9.0, "risk": 0.0, "ideal": 9.0, "traversals": 1}
    for y in (1, 3):
        store.add(path_case(run((0, y), (9, y)), meta))
    base = PathBase.load(store)
    lower = attrs.evolve(path_case(run((0, 5), (9, 5)), meta), id=0, created=2)
    assert base.catch_up(Changes(2, 2, (lower,), ()))
    assert base.ids.tolist() == [0, 1, 2]
    assert [int(p[0, 1]) for p in base.paths] == base.starts[:, 1].tolist() == [5, 1, 3]


@given(st.lists(st.tuples(st.sampled_from(["add", "remove", "touch", "cost"]),
                          st.integers(0, 7), st.integers(0, 7)), max_size=12),
       st.integers(1, 4))
@settings(max_examples=40, deadline=None)
def test_a_followed_path_base_equals_one_loaded_anew(steps: list[tuple[str, int, int]],
                                                       every: int) -> None:
    """Whatever another writer does, the base that followed its commits (caught up every
    ``every`` commits) equals the base loaded from the store."""
    store = MemoryStore()
    ctx = context(free(12, 8), store)
    base = base_of(ctx)
    for n, (op, a, b) in enumerate(steps):
        ids = stored_ids(store)
        if op == "add" or not ids:
            store.add(path_case(run((0, a), (9, b)), {
                "cost": float(a), "length": 9.0, "risk": 0.0, "ideal": 9.0, "traversals": 1}))
        elif op == "remove":
            store.remove([ids[a % len(ids)]])
        elif op == "touch":
            store.touch([ids[a % len(ids)], ids[b % len(ids)]])
        else:
            case = store.get(ids[a % len(ids)])
            store.replace(attrs.evolve(case, meta={**case.meta, "cost": float(b)}))
        if n % every == 0:
            next_query(ctx)
    next_query(ctx)
    assert base_of(ctx) is base
    assert_same_base(base, PathBase.load(store))


@pytest.mark.parametrize(("solution", "meta", "message"), [
    ([[0, 0], [2, 0]], {"cost": 1.0, "length": 2.0, "risk": 0.0, "ideal": 2.0,
                        "traversals": 1}, "8-neighbour steps"),
    ([], {"cost": 1.0, "length": 2.0, "risk": 0.0, "ideal": 2.0, "traversals": 1},
     "non-empty list"),
    ([[0, 0], [1, 0]], {"cost": "high", "length": 1.0, "risk": 0.0, "ideal": 1.0},
     "missing or not a number: cost, traversals"),
])
def test_a_malformed_path_case_is_refused_naming_it(solution: Any, meta: dict[str, Any],
                                                     message: str) -> None:
    store = MemoryStore()
    store.add(Case({"start": [0, 0], "goal": [1, 0]}, solution, kind=PATH, meta=meta))
    with pytest.raises(CbrError, match=f"path case 1: .*{message}"):
        PathBase.load(store)


def test_the_path_base_needs_a_grid_and_a_case_base() -> None:
    with pytest.raises(CbrError, match="grid world"):
        base_of(Context(registry=Registry(), seed=0, world="a map", casebase=MemoryStore()))
    with pytest.raises(CbrError, match="case base"):
        base_of(Context(registry=Registry(), seed=0, world=free(3, 3)))


# --- retrieval, eq. (5)/(7) -------------------------------------------------------------------


def test_only_paths_with_both_ends_within_delta_are_candidates() -> None:
    # . . . . . . . . . . . .
    # . s a - - - - b g . . .    a-b stored forward: ends 1 and 1 from s and g
    # . . . . . . . . . . . .
    # . c - - - - - - - d . .    d-c stored backward (from d to c): c is 2 from s, d sqrt 5
    # . . . . . . . . . . . .    from g; offered reversed
    # e - - - - f . . . . . .    e-f: its end f is sqrt 25 from g
    ctx = context(free(12, 6))
    ab = keep(ctx, run((2, 1), (7, 1)), 1.0)
    dc = keep(ctx, run((9, 3), (1, 3)), 1.0)
    ef = keep(ctx, run((0, 5), (5, 5)), 1.0)
    found = retrieve(ctx, (1, 1), (8, 1), delta=2.5, candidates=8)
    features = {m.case.id: m.features for m in found.matches}
    assert set(features) == {ab, dc}
    assert features[ab]["reversed"] == 0.0 and features[dc]["reversed"] == 1.0
    by_id = {m.case.id: m.case for m in found.matches}
    assert by_id[ab].solution == run((2, 1), (7, 1)).tolist()
    assert by_id[dc].solution == run((1, 3), (9, 3)).tolist()
    assert by_id[dc].problem == {"start": [1, 3], "goal": [9, 3]}
    assert features[dc]["start_distance"] == pytest.approx(2.0)
    assert features[dc]["goal_distance"] == pytest.approx(math.sqrt(5))
    # the bound is inclusive; at delta 2 the reversed path's end d (sqrt 5 from g) is out
    assert {m.case.id for m in retrieve(ctx, (1, 1), (8, 1), delta=2.0).matches} == {ab}
    assert {m.case.id for m in retrieve(ctx, (1, 1), (8, 1), delta=math.sqrt(5)).matches} == {
        ab, dc}
    # e-f fits a query from near e to near f
    assert {m.case.id for m in retrieve(ctx, (0, 4), (5, 4), delta=1.0).matches} == {ef}


@pytest.mark.parametrize(("offset", "delta", "inside"), [
    # the stored path's start lies ``offset`` from the query's start; its goal is the query's
    ((3, 0), 3.0, {"euclidean", "manhattan", "octile", "chebyshev"}),
    ((3, 3), 3.0, {"chebyshev"}),                                # sqrt 18, 6, 3 + 1.24, 3
    ((2, 2), 3.0, {"euclidean", "octile", "chebyshev"}),          # 2.83, 4, 2.83, 2
    ((2, 2), 2.5, {"chebyshev"}),
    ((3, 4), 5.0, {"euclidean", "chebyshev"}),                    # 5, 7, 5.24, 4
    ((1, 2), 3.0, {"euclidean", "manhattan", "octile", "chebyshev"}),  # 2.24, 3, 2.41, 2
])
def test_each_distance_of_eq_5(offset: Cell, delta: float, inside: set[str]) -> None:
    ctx = context(free(16, 12))
    stored = keep(ctx, run((2 + offset[0], 2 + offset[1]), (14, 10)), 1.0)
    for name in DISTANCES:
        found = retrieve(ctx, (2, 2), (14, 10), delta=delta, distance=name)
        assert bool(found.matches) == (name in inside), name
        if found.matches:
            assert found.matches[0].case.id == stored
            assert found.matches[0].features["start_distance"] == pytest.approx(
                reference_distance(name, (2, 2), (2 + offset[0], 2 + offset[1])))


def test_a_path_that_fits_both_ways_is_offered_the_way_its_ends_are_nearer() -> None:
    # the stored path runs from a to b; the query from b to a: both ways lie within delta 4,
    # but only the reversed path joins start and goal
    # . a - - b .
    ctx = context(free(8, 3))
    stored = keep(ctx, run((1, 1), (4, 1)), 1.0)
    (match,) = retrieve(ctx, (4, 1), (1, 1), delta=4.0).matches
    assert match.case.id == stored and match.features["reversed"] == 1.0
    assert match.case.solution == run((4, 1), (1, 1)).tolist()
    assert match.features["start_distance"] == match.features["goal_distance"] == 0.0
    # the query as stored: forward
    (match,) = retrieve(ctx, (1, 1), (4, 1), delta=4.0).matches
    assert match.features["reversed"] == 0.0 and match.features["start_distance"] == 0.0


cells = st.tuples(st.integers(0, 11), st.integers(0, 11))
ends = st.tuples(cells, cells).filter(lambda e: e[0] != e[1])


@settings(max_examples=120, deadline=None)
@given(stored=st.lists(st.tuples(ends, st.sampled_from([1.0, 1.25, 1.5, 2.0])), min_size=1,
                       max_size=6),
       start=cells, goal=cells, name=st.sampled_from(DISTANCES),
       delta=st.sampled_from([0.0, 1.0, 2.0, 2.5, 4.0, 6.0]))
def test_retrieval_matches_a_brute_force_of_eq_5(stored: list[tuple[tuple[Cell, Cell], float]],
                                                 start: Cell, goal: Cell, name: str,
                                                 delta: float) -> None:
    ctx = context(free(12, 12))
    expected: dict[int, tuple[bool, float, float, float]] = {}
    for (a, b), cost in stored:
        case_id = keep(ctx, run(a, b), cost)
        d = {(p, q): reference_distance(name, p, q) for p in (start, goal) for q in (a, b)}
        forward = d[start, a] <= delta and d[goal, b] <= delta
        backward = d[start, b] <= delta and d[goal, a] <= delta
        if forward or backward:
            # offered the way its ends lie nearer the query's; as stored on a tie
            reverse = backward and (not forward
                                    or d[start, b] + d[goal, a] < d[start, a] + d[goal, b])
            near = (d[start, b], d[goal, a]) if reverse else (d[start, a], d[goal, b])
            expected[case_id] = (reverse, *near, cost)
    found = retrieve(ctx, start, goal, delta=delta, distance=name, candidates=8)
    assert {m.case.id for m in found.matches} == set(expected)
    assert found.reason == ("" if expected else
                            f"no stored path with both ends within delta {delta}")
    for match in found.matches:
        reverse, d_start, d_goal, cost = expected[match.case.id]
        assert match.features["reversed"] == float(reverse)
        assert match.features["start_distance"] == pytest.approx(d_start)
        assert match.features["goal_distance"] == pytest.approx(d_goal)
        assert match.features["cost"] == cost
        assert match.case.solution[0] == list(match.case.problem["start"])
        assert reference_distance(name, start, match.case.solution[0]) <= delta
        assert reference_distance(name, goal, match.case.solution[-1]) <= delta
    # after the chosen one, the rest by falling probability (cost), ties by id
    rest = [(m.features["cost"], m.case.id) for m in found.matches[1:]]
    assert rest == sorted(rest)


def test_exploring_empties_a_retrieval_that_had_candidates_and_says_so() -> None:
    ctx = context(free(12, 6))
    keep(ctx, run((1, 1), (9, 1)), 1.0)
    exploring = retrieve(ctx, (1, 2), (9, 2), explore=1.0)
    assert exploring.matches == () and exploring.reason == "exploring"
    assert not exploring.usable
    # no candidate: empty, and nothing to explore instead of
    nothing = retrieve(ctx, (1, 5), (2, 5), explore=1.0)
    unmatched = "no stored path with both ends within delta 5.0"
    assert nothing.matches == () and nothing.reason == unmatched
    assert retrieve(ctx, (1, 5), (2, 5)).reason == unmatched


def test_greedy_selection_picks_the_cheapest_and_hands_on_the_rest_by_cost() -> None:
    ctx = context(free(12, 8))
    ids = [keep(ctx, run((1, y), (10, y)), cost)
           for y, cost in [(1, 1.25), (2, 1.0), (3, 1.5), (4, 1.125), (5, 1.25)]]
    retriever = PathRetriever(RetrieveOptions(selection="greedy", explore=0.0, delta=3.0,
                                              candidates=4), ctx)
    for _ in range(20):
        found = retriever.cbr_retrieve(problem=GridQuery((1, 3), (10, 3)),
                                       casebase=ctx.casebase, ctx=ctx)
        assert [m.case.id for m in found.matches] == [ids[1], ids[3], ids[0], ids[4]]
        assert [m.features["probability"] for m in found.matches] == [1.0, 0.0, 0.0, 0.0]


# --- selection --------------------------------------------------------------------------------


@pytest.mark.parametrize(("rule", "temperature", "costs", "expected"), [
    # exp(-(F - Fmin) / T) with F - Fmin = T ln 2, T ln 4: weights 1, 1/2, 1/4
    ("boltzmann", 0.5, [1.0, 1.0 + 0.5 * math.log(2), 1.0 + 0.5 * math.log(4)],
     [4 / 7, 2 / 7, 1 / 7]),
    # weights e^0, e^-1, e^-3 over their sum 1.4176665095
    ("boltzmann", 0.1, [1.0, 1.1, 1.3], [0.7053845127, 0.2594964603, 0.0351190270]),
    # only differences count
    ("boltzmann", 0.1, [3.0, 3.1, 3.3], [0.7053845127, 0.2594964603, 0.0351190270]),
    # F^(-1/T): at T = 1 inversely proportional to the cost
    ("inverse", 1.0, [1.0, 2.0, 4.0], [4 / 7, 2 / 7, 1 / 7]),
    # at T = 1/2, to its square: 1, 1/4, 1/16
    ("inverse", 0.5, [1.0, 2.0, 4.0], [16 / 21, 4 / 21, 1 / 21]),
    # only ratios count
    ("inverse", 0.5, [3.0, 6.0, 12.0], [16 / 21, 4 / 21, 1 / 21]),
    ("greedy", 0.1, [1.25, 1.0, 1.5], [0.0, 1.0, 0.0]),
    ("greedy", 5.0, [1.25, 1.0, 1.0, 1.5], [0.0, 0.5, 0.5, 0.0]),
])
def test_selection_probabilities_worked_by_hand(rule: Any, temperature: float,
                                                costs: list[float],
                                                expected: list[float]) -> None:
    assert probabilities(np.array(costs), rule, temperature) == pytest.approx(expected, abs=1e-9)


def test_a_low_temperature_neither_overflows_nor_loses_the_cheapest() -> None:
    for rule in ("boltzmann", "inverse"):
        p = probabilities(np.array([500.0, 2.0, 1000.0]), rule, 1e-4)
        assert p.tolist() == [0.0, 1.0, 0.0], rule


def test_an_unknown_rule_is_refused() -> None:
    with pytest.raises(ValueError, match="unknown selection rule 'softmax'"):
        probabilities(np.array([1.0]), "softmax", 1.0)  # type: ignore[arg-type]


@settings(max_examples=80, deadline=None)
@given(costs=st.lists(st.floats(1.0, 5.0), min_size=1, max_size=8),
       temperature=st.floats(0.2, 5.0))
def test_boltzmann_and_inverse_follow_their_formulas(costs: list[float],
                                                     temperature: float) -> None:
    # the formulas as written, unshifted: fine for these costs and temperatures
    boltzmann = [math.exp(-f / temperature) for f in costs]
    inverse = [f ** (-1 / temperature) for f in costs]
    for rule, weights in (("boltzmann", boltzmann), ("inverse", inverse)):
        p = probabilities(np.array(costs), rule, temperature)
        assert p.sum() == pytest.approx(1.0)
        assert p.tolist() == pytest.approx([w / sum(weights) for w in weights], rel=1e-9)
        # the cheaper, the likelier
        order = np.argsort(costs, kind="stable")
        assert (np.diff(p[order]) <= 1e-12).all()


FREQUENCY_COSTS = [1.0, 1.05, 1.1, 1.3]


@pytest.mark.parametrize(("rule", "temperature", "weights"), [
    ("boltzmann", 0.1, [math.exp(-(f - 1.0) / 0.1) for f in FREQUENCY_COSTS]),
    ("boltzmann", 0.05, [math.exp(-(f - 1.0) / 0.05) for f in FREQUENCY_COSTS]),
    ("inverse", 0.1, [f ** -10 for f in FREQUENCY_COSTS]),
    ("inverse", 1.0, [1 / f for f in FREQUENCY_COSTS]),
])
def test_the_retrievers_choices_follow_the_selection_formula(rule: Any, temperature: float,
                                                             weights: list[float]) -> None:
    # four parallel paths, all within delta of the query; their order in the store is not
    # their order by cost
    ctx = context(free(12, 8), seed=20240501)
    costs = [FREQUENCY_COSTS[i] for i in (2, 0, 3, 1)]
    ids = [keep(ctx, run((1, y), (10, y)), cost) for y, cost in zip((1, 2, 3, 4), costs,
                                                                      strict=True)]
    retriever = PathRetriever(RetrieveOptions(selection=rule, temperature=temperature,
                                              explore=0.0, delta=3.0), ctx)
    queries = 4000
    chosen: Counter[int] = Counter()
    for _ in range(queries):
        found = retriever.cbr_retrieve(problem=GridQuery((1, 2), (10, 3)),
                                       casebase=ctx.casebase, ctx=ctx)
        chosen[found.matches[0].case.id] += 1
    expected = [queries * weights[FREQUENCY_COSTS.index(c)] / sum(weights) for c in costs]
    observed = [chosen[i] for i in ids]
    assert sum(observed) == queries
    assert chisquare(observed, expected).pvalue > 1e-3


def test_greedy_ties_are_chosen_equally_often() -> None:
    ctx = context(free(12, 8), seed=7)
    ids = [keep(ctx, run((1, y), (10, y)), cost) for y, cost in [(1, 1.5), (2, 1.0), (3, 1.0)]]
    retriever = PathRetriever(RetrieveOptions(selection="greedy", explore=0.0, delta=3.0), ctx)
    chosen: Counter[int] = Counter()
    for _ in range(2000):
        found = retriever.cbr_retrieve(problem=GridQuery((1, 2), (10, 2)),
                                       casebase=ctx.casebase, ctx=ctx)
        chosen[found.matches[0].case.id] += 1
    assert chosen[ids[0]] == 0
    assert chisquare([chosen[ids[1]], chosen[ids[2]]]).pvalue > 1e-3


def test_exploring_happens_with_its_probability() -> None:
    ctx = context(free(12, 6), seed=99)
    keep(ctx, run((1, 1), (9, 1)), 1.0)
    retriever = PathRetriever(RetrieveOptions(explore=0.25), ctx)
    queries = 4000
    explored = sum(
        retriever.cbr_retrieve(problem=GridQuery((1, 2), (9, 2)), casebase=ctx.casebase,
                               ctx=ctx).reason == "exploring" for _ in range(queries))
    assert chisquare([explored, queries - explored],
                     [queries * 0.25, queries * 0.75]).pvalue > 1e-3
