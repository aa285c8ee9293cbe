"""The hybrid's choice between CBR and its solver: the fixed thresholds, the learned choice from
given times (never the clock), and the learned choice in the engine, which learns from the
proposal of the query before (``Context.previous``)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from cbr_casegraph.payoff import (
    MARGIN,
    REVISIT,
    SHORT_QUERY,
    SMALL_MAP,
    SOLVER_CHEAPER,
    Learned,
    PassableCells,
    Payoff,
    band,
)
from cbr_grid.grid import Grid
from cbr_grid.query import GridQuery
from cbrcore.engine import Engine
from cbrcore.model import CASEBASE, Proposal, Solution
from repo_paths import ROOT

CONFIG = ROOT / "configs" / "hybrid_grid.yaml"


def test_the_payoff_thresholds_by_hand() -> None:
    payoff = Payoff(min_cells=100, min_distance=20)
    assert payoff.reason(99, (0, 0), (50, 50)) == SMALL_MAP
    assert payoff.reason(100, (0, 0), (19, 5)) == SHORT_QUERY
    assert payoff.reason(100, (0, 0), (20, 5)) is None
    assert Payoff().reason(0, (0, 0), (0, 1)) is None
    grid = Grid(np.where(np.arange(12).reshape(3, 4) % 5 == 0, 1.0, 0.0))
    assert PassableCells().of(grid) == 9


def test_the_retriever_leaves_a_small_map_to_a_star_and_the_engine_counts_why() -> None:
    overrides = ["world.width=40", "world.height=40", "casebase=memory",
                 "retrieve.min_cells=1601"]
    with Engine.from_yaml(CONFIG, overrides=overrides) as engine:
        queries = iter(engine.workload.queries(engine.ctx))
        for _ in range(3):
            proposal = engine.solve(next(queries))
            assert proposal.source.startswith("solver")
            assert proposal.retrieval is not None and proposal.retrieval.reason == SMALL_MAP
        assert engine.stats.fallback_reasons == {f"no usable retrieval: {SMALL_MAP}": 3}


@given(st.integers(-3000, 3000), st.integers(-3000, 3000))
def test_a_band_is_half_an_octave_of_the_straight_line_distance(dx: int, dy: int) -> None:
    squared = float(np.hypot(dx, dy)) ** 2
    which = band((5, 7), (5 + dx, 7 + dy))
    assert which == band((5 + dx, 7 + dy), (5, 7)) == band((5, 7 + dy), (5 + dx, 7))
    if dx == dy == 0:
        assert which == 0
    else:
        assert 2 ** (which - 1) <= round(squared) < 2**which


def test_the_learned_choice_by_hand() -> None:
    learned = Learned()
    assert not learned.tries(9)  # the solver's time is measured first: no loss against it
    learned.solved(9, 1.0)
    assert learned.tries(9)  # then CBR is tried once
    learned.attempted(9, 0.5, True)
    assert learned.tries(9)  # 0.5 < 0.8 * 1.0
    # a failure halves the share of accepted paths: 0.5 + 0.5 * 1.0 saves nothing
    learned.attempted(9, 0.5, False)
    learned.solved(9, 1.0)
    assert not learned.tries(9)
    # the other bands know nothing yet
    assert not learned.tries(8)
    # cheaper CBR pays even at that share: the median of 0.5, 0.5, 0.1, 0.1 is 0.3 < 0.8 * 0.5
    learned.attempted(9, 0.1, True)
    learned.attempted(9, 0.1, False)
    learned.solved(9, 1.0)
    assert learned.tries(9)


def test_a_verdict_is_revisited_once_every_revisit_queries() -> None:
    slow, fast = Learned(), Learned()
    for learned, cbr in ((slow, 2.0), (fast, 0.1)):
        learned.solved(3, 1.0)
        learned.attempted(3, cbr, True)
    assert [i for i in range(3 * REVISIT) if slow.tries(3)] == [
        REVISIT - 1, 2 * REVISIT - 1, 3 * REVISIT - 1]
    assert [i for i in range(3 * REVISIT) if not fast.tries(3)] == [
        REVISIT - 1, 2 * REVISIT - 1, 3 * REVISIT - 1]


def _run(learned: Learned, bands: list[int], cbr: list[float], solver: list[float],
         answered: list[bool]) -> list[bool]:
    """The choices of ``learned`` over queries of ``bands``, told what a hybrid measures."""
    choices = []
    for which, c, s, ok in zip(bands, cbr, solver, answered, strict=True):
        tried = learned.tries(which)
        choices.append(tried)
        if tried:
            learned.attempted(which, c, ok)
        if not (tried and ok):
            learned.solved(which, s)
    return choices


queries = st.integers(1, 150).flatmap(lambda n: st.tuples(
    st.lists(st.integers(0, 3), min_size=n, max_size=n),
    st.lists(st.floats(0.0, 1.0), min_size=n, max_size=n),
    st.lists(st.floats(0.0, 1.0), min_size=n, max_size=n),
    st.lists(st.booleans(), min_size=n, max_size=n)))


@given(queries)
def test_where_cbr_is_slower_it_is_tried_once_and_once_per_revisit(
        drawn: tuple[list[int], list[float], list[float], list[bool]]) -> None:
    bands, cbr, solver, answered = drawn
    # every CBR attempt takes longer than every solver run
    choices = _run(Learned(), bands, [1.0 + c for c in cbr], solver, answered)
    for which in set(bands):
        mine = [tried for tried, b in zip(choices, bands, strict=True) if b == which]
        assert sum(mine) <= 1 + len(mine) // REVISIT
    # the same times give the same choices
    assert _run(Learned(), bands, [1.0 + c for c in cbr], solver, answered) == choices


@given(queries)
def test_where_cbr_always_answers_in_less_it_is_tried_but_for_the_revisits(
        drawn: tuple[list[int], list[float], list[float], list[bool]]) -> None:
    bands, cbr, solver, _ = drawn
    # every CBR attempt is accepted and takes less than MARGIN times every solver run
    choices = _run(Learned(), bands, [MARGIN * c / 2 for c in cbr], [1.0 + s for s in solver],
                   [True] * len(bands))
    for which in set(bands):
        mine = [tried for tried, b in zip(choices, bands, strict=True) if b == which]
        assert mine[:2] == [False, True][:len(mine)]
        assert mine.count(False) <= 1 + len(mine) // REVISIT


def _far_apart(grid: Grid) -> GridQuery:
    """A query between the first and the last passable cell of ``grid``."""
    free = np.argwhere(grid.passable)
    (y0, x0), (y1, x1) = free[0], free[-1]
    return GridQuery((int(x0), int(y0)), (int(x1), int(y1)))


def test_the_engine_hands_the_learned_choice_the_proposal_before() -> None:
    overrides = ["world.width=40", "world.height=40", "casebase=memory",
                 "retrieve.payoff=learned"]
    with Engine.from_yaml(CONFIG, overrides=overrides) as engine:
        query = _far_apart(engine.world)
        first = engine.solve(query)
        # nothing is known: the solver plans, and the engine keeps its proposal for the next
        assert first.retrieval is not None and first.retrieval.reason == SOLVER_CHEAPER
        assert engine.ctx.previous is first
        # the solver's time is known: CBR is tried, and fails on the empty case graph
        second = engine.solve(query)
        assert second.retrieval is not None and second.retrieval.reason != SOLVER_CHEAPER
        assert second.source.startswith("solver") and engine.ctx.previous is second
        # CBR answered none of its attempts: the solver is cheaper
        third = engine.solve(query)
        assert third.retrieval is not None and third.retrieval.reason == SOLVER_CHEAPER
        assert engine.stats.fallback_reasons[f"no usable retrieval: {SOLVER_CHEAPER}"] == 2


@pytest.mark.parametrize(("cbr_seconds", "tried"), [(0.1, True), (5.0, False)])
def test_the_retriever_learns_the_phases_of_the_proposal_before(cbr_seconds: float,
                                                                tried: bool) -> None:
    overrides = ["world.width=40", "world.height=40", "casebase=memory",
                 "retrieve.payoff=learned"]
    with Engine.from_yaml(CONFIG, overrides=overrides) as engine:
        retriever, ctx = engine.components["retrieve"], engine.ctx
        query = _far_apart(engine.world)
        solution = Solution([list(query.start), list(query.goal)])
        assert retriever.retrieve(query, ctx).reason == SOLVER_CHEAPER
        ctx.previous = Proposal(solution, "solver:astar", timings={"retrieve": 1e-6,
                                                                   "solve": 1.0})
        assert retriever.retrieve(query, ctx).reason != SOLVER_CHEAPER
        # what an answered attempt took: its retrieval, reuse and revision
        ctx.previous = Proposal(solution, CASEBASE, timings={
            "retrieve": cbr_seconds / 2, "reuse": cbr_seconds / 4, "revise": cbr_seconds / 4})
        assert (retriever.retrieve(query, ctx).reason != SOLVER_CHEAPER) is tried
