"""Whole-path cases (``cbr_pathcases``): retention (eqs. 6/8) and the forgetting strategies.

Retention is checked on parallel and overlapping straight paths on a free grid, whose
Hausdorff distances and costs are worked out by hand: a path is kept unless a similar stored
one costs no more, replaces the costlier similar ones, and a reused path learns the cost of
its traversals. Each forgetting strategy is run on one hand-built case base of five paths,
where every strategy forgets a different sequence, and against a brute force written from the
survey's words (§2.2; Šeda & Dvořák §4) on random ones.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_grid.costs import path_length
from cbr_grid.drive import DriveReport
from cbr_grid.true_world import Blocked
from cbr_pathcases.base import PATH, base_of
from cbr_pathcases.components import PathRetainer, RetainOptions
from cbr_pathcases.forgetting import (
    CAPACITY_STRATEGIES,
    CapacityOptions,
    NearDuplicateOptions,
    NearDuplicatePaths,
)
from cbrcore.context import Context
from cbrcore.model import Outcome, Solution

from .test_pathcases import Cell, context, free, keep, run, stored_ids

# --- retention --------------------------------------------------------------------------------


def learn(ctx: Context, retainer: PathRetainer, path: np.ndarray, *, cases: Sequence[int] = (),
          travel_time: float | None = None, success: bool = True,
          stops: Sequence[Cell] | None = None) -> None:
    """One learn step as the engine takes it: one transaction, the reused cases' uses counted,
    then retention of the path driven. With ``travel_time`` the outcome carries the drive report
    of the trip: its travel time and the cells the robot stopped at (``stops``, none if None)."""
    report = None
    if travel_time is not None:
        report = DriveReport(path, met=(), stops=tuple((x, y) for x, y in stops or ()),
                             blocked=Blocked(np.zeros((0, 2), dtype=np.int64), ()),
                             travel_time=travel_time)
    with ctx.casebase.transaction():
        if cases:
            ctx.casebase.touch(cases)
        retainer.cbr_retain(solution=Solution(path.tolist(), cases=tuple(cases)),
                            outcome=Outcome(success, report=report), ctx=ctx)


def retainer(ctx: Context, **options: Any) -> PathRetainer:
    return PathRetainer(RetainOptions(**options), ctx)


def paths(ctx: Context) -> dict[int, list[list[int]]]:
    """The stored paths by id, from the store itself."""
    return {int(c.id or 0): c.solution for c in ctx.casebase.cases(PATH)}


# Rows of a free 12x10 grid, each 9 cells from x = 1 to x = 9: driven without trouble, a row
# costs 1 by the ratio F = l / g, and two rows k apart are k apart by the Hausdorff distance.
def row(y: int, x0: int = 1, x1: int = 9) -> np.ndarray:
    return run((x0, y), (x1, y))


def test_a_new_path_is_stored_with_its_measured_cost() -> None:
    ctx = context(free(12, 10))
    learn(ctx, retainer(ctx), row(2), travel_time=8 + 5)
    (case,) = ctx.casebase.cases(PATH)
    assert case.solution == row(2).tolist()
    assert case.problem == {"start": [1, 2], "goal": [9, 2]}
    assert case.meta == pytest.approx({"cost": 13 / 8, "length": 8.0, "risk": 5.0,
                                       "ideal": 8.0, "traversals": 1})
    learn(ctx, retainer(ctx, combine="sum", risk_weight=2.0), row(7), travel_time=8 + 5)
    assert ctx.casebase.get(2).meta["cost"] == pytest.approx(8 + 2 * 5)


def test_a_stop_in_a_dead_end_cut_from_the_path_is_charged_to_the_reused_case() -> None:
    # the robot reused row 2 from (1, 2) to (9, 2), was stopped at (5, 2) by a shut door at
    # (6, 2), went back to (3, 2) and round by row 4: the dead end (3, 2)-(5, 2) and back is
    # cut from the kept path, and with it the stop and its 5 steps of lost time
    ctx = context(free(12, 10))
    reused = keep(ctx, row(2), 1.0)
    driven = np.concatenate((run((1, 2), (5, 2), (3, 2))[:-1], run((3, 2), (5, 4), (7, 4),
                                                                    (9, 2))))
    kept = run((1, 2), (3, 2), (5, 4), (7, 4), (9, 2))
    trip = path_length(driven)
    # at threshold 1 the detour, 2 rows off, is not similar to row 2
    learn(ctx, retainer(ctx, threshold=1.0), driven, cases=[reused], travel_time=trip + 5,
          stops=[(5, 2)])
    assert paths(ctx)[reused] == row(2).tolist()
    assert ctx.casebase.get(reused).meta["cost"] == pytest.approx((1.0 + (trip + 5) / 8) / 2)
    (new,) = set(paths(ctx)) - {reused}
    assert paths(ctx)[new] == kept.tolist()
    assert ctx.casebase.get(new).meta == pytest.approx({
        "cost": path_length(kept) / 8, "length": path_length(kept), "risk": 0.0, "ideal": 8.0,
        "traversals": 1})
    # a stop on the kept path stays with it
    ctx = context(free(12, 10))
    learn(ctx, retainer(ctx), kept, travel_time=path_length(kept) + 5, stops=[(3, 2)])
    assert ctx.casebase.get(1).meta["risk"] == pytest.approx(5.0)


@pytest.mark.parametrize("stored_cost", [1.0, 0.875])
def test_a_similar_stored_path_that_costs_no_more_refuses_the_new_one(stored_cost: float) -> None:
    ctx = context(free(12, 10))
    old = keep(ctx, row(2), stored_cost)
    # one row away, and costing 1: similar to the stored row at threshold 2
    learn(ctx, retainer(ctx, threshold=2.0), row(3))
    assert paths(ctx) == {old: row(2).tolist()}
    # not stored twice: the stored path's use count grows instead
    assert ctx.casebase.get(old).uses == 1
    assert base_of(ctx).uses.tolist() == [1]
    assert base_of(ctx).costs.tolist() == [stored_cost]


def test_a_cheaper_new_path_replaces_the_costlier_similar_ones() -> None:
    ctx = context(free(12, 10))
    above = keep(ctx, row(1), 1.5)
    below = keep(ctx, row(4), 1.25)
    far = keep(ctx, row(8), 1.75)  # 5 rows from the new one: not similar
    learn(ctx, retainer(ctx, threshold=2.0), row(3))
    stored = paths(ctx)
    assert above not in stored and below not in stored
    assert stored[far] == row(8).tolist()
    (new,) = set(stored) - {far}
    assert stored[new] == row(3).tolist()
    assert ctx.casebase.get(new).meta["cost"] == pytest.approx(1.0)
    assert base_of(ctx).ids.tolist() == stored_ids(ctx.casebase) == [far, new]


def test_one_cheaper_similar_path_refuses_the_new_one_and_keeps_the_costlier() -> None:
    ctx = context(free(12, 10))
    cheap = keep(ctx, row(1), 0.875)
    costly = keep(ctx, row(5), 1.5)
    learn(ctx, retainer(ctx, threshold=2.0), row(3))
    assert set(paths(ctx)) == {cheap, costly}
    assert [ctx.casebase.get(i).uses for i in (cheap, costly)] == [1, 0]


def test_the_threshold_bounds_similarity() -> None:
    # three rows apart: similar at threshold 3, not at 2.9
    ctx = context(free(12, 10))
    keep(ctx, row(2), 1.0)
    learn(ctx, retainer(ctx, threshold=2.9), row(5))
    assert len(paths(ctx)) == 2
    learn(ctx, retainer(ctx, threshold=3.0), row(8))
    assert len(paths(ctx)) == 2


@pytest.mark.parametrize(("hausdorff", "stored"), [("directed", 1), ("symmetric", 2)])
def test_a_short_path_along_a_longer_stored_one(hausdorff: str, stored: int) -> None:
    # . L L L S S S S L L L L     S = (3..6, 3) lies on L = (0..10, 3)
    # D(S, L) = 0: every cell of S is a cell of L; D(L, S) = 3: from (0, 3) to (3, 3).
    # At threshold 2 S is similar to L by eq. (6) as written (directed), not by the symmetric
    # distance; S costs 1, as does L, so only the directed reading refuses it.
    ctx = context(free(12, 6))
    long = keep(ctx, row(3, 0, 10), 1.0)
    learn(ctx, retainer(ctx, threshold=2.0, hausdorff=hausdorff), row(3, 3, 6))
    assert len(paths(ctx)) == stored
    assert ctx.casebase.get(long).uses == (1 if hausdorff == "directed" else 0)


def test_the_hausdorff_cell_distance_is_an_option() -> None:
    # a path one cell off diagonally: sqrt 2 apart by euclidean, 2 by manhattan
    ctx = context(free(12, 10))
    keep(ctx, row(2), 1.0)
    learn(ctx, retainer(ctx, threshold=1.5, distance="euclidean"), row(3, 2, 10))
    assert len(paths(ctx)) == 1
    learn(ctx, retainer(ctx, threshold=1.5, distance="manhattan"), row(3, 2, 10))
    assert len(paths(ctx)) == 2


def test_a_failed_trip_forgets_the_case_it_reused() -> None:
    ctx = context(free(12, 10))
    reused = keep(ctx, row(2), 1.0)
    other = keep(ctx, row(6), 1.0)
    learn(ctx, retainer(ctx), row(2, 1, 5), cases=[reused], success=False)
    assert paths(ctx) == {other: row(6).tolist()}
    assert base_of(ctx).ids.tolist() == [other]
    # a failed trip planned by the solver stores nothing
    learn(ctx, retainer(ctx), row(4), success=False)
    assert set(paths(ctx)) == {other}


# Traversals of row 2 (length 8, ideal 8) with the time lost to obstacles: F = (8 + lost) / 8.
TRAVERSALS = [(8.0, 2.0), (24.0, 4.0), (0.0, 1.0)]


@pytest.mark.parametrize(("experience", "learned"), [
    # the stored path's cost 3 is its first traversal's
    ("mean", [(3 + 2) / 2, (3 + 2 + 4) / 3, (3 + 2 + 4 + 1) / 4]),
    ("last", [2.0, 4.0, 1.0]),
])
def test_a_reused_path_learns_the_cost_of_its_traversals(experience: str,
                                                         learned: list[float]) -> None:
    ctx = context(free(12, 10))
    case = keep(ctx, row(2), 3.0)
    retain = retainer(ctx, experience=experience)
    for traversal, ((lost, cost), expected) in enumerate(zip(TRAVERSALS, learned, strict=True),
                                                         start=2):
        learn(ctx, retain, row(2), cases=[case], travel_time=8 + lost)
        assert cost == pytest.approx((8 + lost) / 8)
        # the traversal is the stored case's own: no second copy, whatever it cost this time
        assert list(paths(ctx)) == [case]
        stored = ctx.casebase.get(case)
        assert stored.meta["cost"] == pytest.approx(expected)
        assert stored.meta["traversals"] == traversal
        assert stored.uses == traversal - 1
        base = base_of(ctx)
        assert base.costs.tolist() == pytest.approx([expected])
        assert base.traversals.tolist() == [traversal] and base.uses.tolist() == [traversal - 1]


def test_the_cells_of_a_stored_path_planned_and_driven_again_are_one_more_traversal() -> None:
    # the solver planned row 2 anew, the other way round, and the robot drove it without
    # trouble (F = 1): not a new case, but row 2's second traversal
    ctx = context(free(12, 10))
    case = keep(ctx, row(2), 3.0)
    learn(ctx, retainer(ctx), row(2)[::-1])
    assert list(paths(ctx)) == [case]
    stored = ctx.casebase.get(case)
    assert stored.meta["cost"] == pytest.approx((3 + 1) / 2)
    assert stored.meta["traversals"] == 2 and stored.uses == 1


def test_a_path_driven_off_the_reused_case_learns_its_cost_and_is_kept_if_new() -> None:
    # the robot reused row 2 but drove row 6 (replanned far around something): row 2 learns
    # the cost of that trip, and row 6, unlike any stored path, is kept as well
    ctx = context(free(12, 10))
    case = keep(ctx, row(2), 3.0)
    learn(ctx, retainer(ctx), row(6), cases=[case])
    assert ctx.casebase.get(case).meta["cost"] == pytest.approx((3 + 1) / 2)
    assert len(paths(ctx)) == 2


# --- forgetting -------------------------------------------------------------------------------

# Five paths, ids 1 to 5 stored in that order (created at revisions 1 to 5), with these costs,
# then used at revisions 6 to 11: 2 once; 3 twice; 1; 3 and 5 together; 1 again.
COSTS = {1: 1.5, 2: 1.0, 3: 2.0, 4: 1.25, 5: 1.75}
TOUCHES = [[2], [3], [3], [1], [3, 5], [1]]
# uses:       1: 2, 2: 1, 3: 3, 4: 0, 5: 1
# last used:  1: 11, 2: 6, 3: 10, 4: never (created 4), 5: 10
FORGOTTEN = {
    # highest cost: 2.0, 1.75, 1.5
    "worst_paths": [3, 5, 1],
    # lowest cost: 1.0, 1.25, 1.5
    "best_paths": [2, 4, 1],
    # mean 1.5: path 1 itself; then mean 1.5 again, 4 (1.25) and 5 (1.75) tie at 0.25, the
    # lower id goes; then mean of 1.0, 2.0, 1.75 = 1.583: 5 is nearest
    "average_paths": [1, 4, 5],
    # last use (or creation): 4 (created 4), 2 (6), then 3 and 5 (both 10): the lower id
    "least_recent_paths": [4, 2, 3],
    # uses: 4 (0), then 2 and 5 (1 each): the lower id first
    "least_used_paths": [4, 2, 5],
    "oldest_paths": [1, 2, 3],
    "newest_paths": [5, 4, 3],
}


def hand_built() -> Context:
    ctx = context(free(12, 8))
    for y, (case_id, cost) in enumerate(COSTS.items(), start=1):
        assert keep(ctx, row(y), cost) == case_id
    for ids in TOUCHES:
        base_of(ctx).touch(ids)
    base = base_of(ctx)
    assert base.uses.tolist() == [2, 1, 3, 0, 1]
    assert base.last_used.tolist() == [11, 6, 10, -1, 10]
    assert base.created.tolist() == [1, 2, 3, 4, 5]
    return ctx


def test_every_strategy_forgets_a_different_sequence() -> None:
    assert sorted(FORGOTTEN) == sorted(CAPACITY_STRATEGIES)
    assert len({tuple(order) for order in FORGOTTEN.values()}) == len(FORGOTTEN)


@pytest.mark.parametrize("name", sorted(FORGOTTEN))
def test_each_strategy_forgets_what_the_paper_says(name: str) -> None:
    ctx = hand_built()
    forgotten = []
    for capacity in (5, 4, 3, 2):
        before = set(stored_ids(ctx.casebase))
        with ctx.casebase.transaction():
            CAPACITY_STRATEGIES[name](CapacityOptions(capacity), ctx).cbr_forget(ctx=ctx)
        after = set(stored_ids(ctx.casebase))
        assert len(after) == capacity
        forgotten.extend(before - after)
        assert base_of(ctx).ids.tolist() == sorted(after)
    assert forgotten == FORGOTTEN[name]


@pytest.mark.parametrize("name", sorted(FORGOTTEN))
def test_one_forget_down_to_capacity_forgets_the_same(name: str) -> None:
    ctx = hand_built()
    CAPACITY_STRATEGIES[name](CapacityOptions(2), ctx).cbr_forget(ctx=ctx)
    assert stored_ids(ctx.casebase) == sorted(set(COSTS) - set(FORGOTTEN[name]))


def reference_order(name: str, costs: list[float], uses: list[int], stamps: list[int],
                    keep_count: int) -> list[int]:
    """The ids (1-based, in storing order) forgotten until ``keep_count`` remain, one at a time,
    each strategy's rank written from its description; ties to the lower id."""
    alive = list(range(1, len(costs) + 1))
    forgotten = []
    while len(alive) > keep_count:
        mean = sum(costs[i - 1] for i in alive) / len(alive)
        rank = {
            "worst_paths": lambda i: -costs[i - 1],
            "best_paths": lambda i: costs[i - 1],
            "average_paths": lambda i, mean=mean: abs(costs[i - 1] - mean),
            "least_recent_paths": lambda i: stamps[i - 1],
            "least_used_paths": lambda i: uses[i - 1],
            "oldest_paths": lambda i: i,
            "newest_paths": lambda i: -i,
        }[name]
        victim = min(alive, key=lambda i: (rank(i), i))
        alive.remove(victim)
        forgotten.append(victim)
    return forgotten


@settings(max_examples=40, deadline=None)
@given(name=st.sampled_from(sorted(CAPACITY_STRATEGIES)),
       cases=st.lists(st.tuples(st.sampled_from([1.0, 1.25, 1.5, 2.0, 3.0]),
                                st.integers(0, 3)), min_size=1, max_size=7),
       capacity=st.integers(1, 7))
def test_the_strategies_match_a_brute_force(name: str, cases: list[tuple[float, int]],
                                            capacity: int) -> None:
    ctx = context(free(12, 10))
    for y, (cost, _) in enumerate(cases):
        keep(ctx, row(y), cost)
    # case i is created at revision i; each commit after that is one revision more: a turn
    # uses every case drawn to be used more often than that, together
    stamps = list(range(1, len(cases) + 1))
    revision = len(cases)
    for turn in range(3):
        used = [i + 1 for i, (_, n) in enumerate(cases) if n > turn]
        if used:
            base_of(ctx).touch(used)
            revision += 1
            for i in used:
                stamps[i - 1] = revision
    expected = reference_order(name, [c for c, _ in cases], [n for _, n in cases], stamps,
                               capacity)
    CAPACITY_STRATEGIES[name](CapacityOptions(capacity), ctx).cbr_forget(ctx=ctx)
    assert stored_ids(ctx.casebase) == sorted(set(range(1, len(cases) + 1)) - set(expected))


def retained_by(ctx: Context, forget: NearDuplicatePaths, path: np.ndarray) -> bool:
    """Whether ``path``, stored in a learn step that ``forget`` closes, is still stored."""
    with ctx.casebase.transaction():
        case_id = keep(ctx, path, 1.0)
        forget.cbr_forget(ctx=ctx)
    return case_id in stored_ids(ctx.casebase)


def test_a_path_like_more_than_count_stored_ones_is_not_kept() -> None:
    # rows one apart resemble each other at radius 1, rows two apart do not
    ctx = context(free(12, 10))
    before = [keep(ctx, row(1), 1.0), keep(ctx, row(3), 1.0)]
    forget = NearDuplicatePaths(NearDuplicateOptions(count=1, radius=1.0), ctx)
    assert not retained_by(ctx, forget, row(2))  # like rows 1 and 3: 2 > count
    assert retained_by(ctx, forget, row(7))  # like nothing stored
    assert retained_by(ctx, forget, row(5))  # like nothing stored (rows 3 and 7 are 2 away)
    assert retained_by(ctx, forget, row(8))  # like row 7 only: 1 is not more than count
    assert not retained_by(ctx, forget, row(4))  # like rows 3 and 5
    assert not retained_by(ctx, forget, row(6))  # like rows 5 and 7
    assert stored_ids(ctx.casebase)[:2] == before
    assert [c.solution[0][1] for c in ctx.casebase.cases(PATH)] == [1, 3, 7, 5, 8]


def test_near_duplicates_are_counted_up_to_count() -> None:
    ctx = context(free(12, 12))
    before = [keep(ctx, row(y), 1.0) for y in (1, 3)]
    forget = NearDuplicatePaths(NearDuplicateOptions(count=2, radius=1.0), ctx)
    assert retained_by(ctx, forget, row(2))  # like rows 1 and 3: not more than 2
    assert not retained_by(ctx, forget, row(2))  # like rows 1, 2 and 3
    assert retained_by(ctx, forget, row(9))
    assert [c.solution[0][1] for c in ctx.casebase.cases(PATH)] == [1, 3, 2, 9]
    assert stored_ids(ctx.casebase)[:2] == before


def test_near_duplicates_leave_the_paths_stored_before_alone() -> None:
    ctx = context(free(12, 10))
    before = [keep(ctx, row(y), 1.0) for y in (1, 2, 3)]
    NearDuplicatePaths(NearDuplicateOptions(count=0, radius=5.0), ctx).cbr_forget(ctx=ctx)
    assert stored_ids(ctx.casebase) == before
