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
    SAMPLES,
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


def _known(learned: Learned, which: int, cbr: float, solver: float = 1.0) -> None:
    """Tell ``learned`` of SAMPLES answered attempts of ``cbr`` s and solver runs of
    ``solver`` s in band ``which``."""
    for _ in range(SAMPLES):
        learned.attempted(which, cbr, True)
        learned.solved(which, solver)


def test_a_band_alternates_between_the_solver_and_cbr_until_both_are_measured() -> None:
    learned = Learned()
    choices = []
    for _ in range(2 * SAMPLES):
        tried = learned.tries(9)
        choices.append(tried)
        if tried:
            learned.attempted(9, 5.0, True)
        else:
            learned.solved(9, 1.0)
    assert choices == [False, True] * SAMPLES
    assert not learned.tries(9)  # CBR is slower here
    assert not learned.tries(8)  # another band knows nothing yet


def test_a_failed_attempt_counts_as_a_measurement_of_both() -> None:
    learned = Learned()
    assert not learned.tries(9)
    learned.solved(9, 1.0)
    for _ in range(SAMPLES):
        assert learned.tries(9)
        learned.attempted(9, 0.1, False)
        learned.solved(9, 1.0)
    assert not learned.tries(9)  # CBR answered none


def test_the_learned_choice_by_hand() -> None:
    learned = Learned()
    _known(learned, 9, 0.5)
    assert learned.tries(9)  # 0.5 < 0.8 * 1.0
    # failures lower the share of accepted paths: at 1/2, 0.5 + 0.5 * 1.0 saves nothing
    for _ in range(SAMPLES):
        learned.attempted(9, 0.5, False)
        learned.solved(9, 1.0)
    assert not learned.tries(9)
    # cheaper CBR pays even at that share: the median CBR time falls to 0.1 < 0.8 * 1/2 * 1.0
    for _ in range(2 * SAMPLES):
        learned.attempted(9, 0.1, True)
        learned.attempted(9, 0.1, False)
    assert learned.tries(9)


def test_a_verdict_is_revisited_once_every_revisit_queries() -> None:
    slow, fast = Learned(), Learned()
    _known(slow, 3, 2.0)
    _known(fast, 3, 0.1)
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
        assert sum(mine) <= SAMPLES + len(mine) // REVISIT
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
        assert mine[:2 * SAMPLES] == ([False, True] * SAMPLES)[:len(mine)]
        assert mine.count(False) <= SAMPLES + len(mine) // REVISIT


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
        reasons = []
        for _ in range(SAMPLES + 2):
            proposal = engine.solve(query)
            # the engine keeps its proposal for the next query
            assert engine.ctx.previous is proposal and proposal.source.startswith("solver")
            assert proposal.retrieval is not None
            reasons.append(proposal.retrieval.reason == SOLVER_CHEAPER)
        # nothing known: the solver; then CBR, which fails on the empty case graph and so
        # measures the solver too, until SAMPLES attempts; CBR answered none: the solver
        assert reasons == [True] + [False] * SAMPLES + [True]
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
        for _ in range(2 * SAMPLES):
            if retriever.retrieve(query, ctx).reason == SOLVER_CHEAPER:
                ctx.previous = Proposal(solution, "solver:astar",
                                        timings={"retrieve": 1e-6, "solve": 1.0})
            else:  # what an answered attempt took: its retrieval, reuse and revision
                ctx.previous = Proposal(solution, CASEBASE, timings={
                    "retrieve": cbr_seconds / 2, "reuse": cbr_seconds / 4,
                    "revise": cbr_seconds / 4})
        assert (retriever.retrieve(query, ctx).reason != SOLVER_CHEAPER) is tried
        # a proposal that never came (the query's solve raised) teaches nothing: the choice
        # stands whatever the previous proposal said
        for _ in range(3):
            assert (retriever.retrieve(query, ctx).reason != SOLVER_CHEAPER) is tried
