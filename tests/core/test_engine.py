"""The engine: the hybrid rule, proposals and statistics, learning, phase errors and construction.

Expectations are worked out by hand from the toy domain (``toy_domain``): a query x has the
answer x²; reuse adapts a stored (x0, x0²) along the tangent, x0² + 2·x0·(x - x0), whose error is
exactly (x - x0)²; the ``tolerance`` reviser accepts an error up to its tolerance; the ``compute``
solver answers x² directly.
"""

from __future__ import annotations

import json
import sqlite3
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

import cbr_observers
import cbr_stores
import cbrcore.builtins
import toy_domain
from cbr_stores.sqlite import SQLiteStore
from cbrcore import Case, Engine, Outcome, Proposal, Retrieval, Revision, Solution, hookimpl
from cbrcore.casebase import MemoryStore
from cbrcore.casebase.store import CaseStore
from cbrcore.config import parse_config
from cbrcore.context import Context
from cbrcore.errors import PhaseError, PluginError
from cbrcore.plugins import Plugins, load_plugins
from cbrcore.registry import Registry
from cbrcore.stash import StashKey

COUNT_CALLS = StashKey[toy_domain.CountCalls]()
"""The counting observer of the engine under test."""

KIND = toy_domain.KIND
FULL_CYCLE = """\
retrieve: {use: nearest, radius: 1}
reuse: tangent
revise: {use: tolerance, tolerance: 0}
solver: compute
retain: [keep]
"""


class _Component:
    """Base of the test-only components: built as ``factory(options, ctx)``."""

    def __init__(self, options: object, ctx: Context) -> None:
        self.ctx = ctx


def _raising(hook: str) -> type:
    """A component class whose ``hook`` raises ValueError."""

    def impl(self: _Component) -> None:
        raise ValueError(f"{hook} went wrong")

    return type(f"Raising_{hook}", (_Component,), {hook: hookimpl(impl)})


def _returning(hook: str, value: Any) -> type:
    """A component class whose ``hook`` returns ``value``."""

    def impl(self: _Component) -> Any:
        return value

    return type(f"Returning_{hook}", (_Component,), {hook: hookimpl(impl)})


class Repair(_Component):
    """A reviser that accepts every reused answer after replacing it with the exact one."""

    @hookimpl
    def cbr_revise(self, problem: int, solution: Solution) -> Revision:
        repaired = Solution(problem * problem, cases=solution.cases,
                            detail={"reused": solution.value})
        return Revision(True, "repaired", repaired)


class Greedy(_Component):
    """A retriever that also implements reuse: two phase hooks where one is allowed."""

    @hookimpl
    def cbr_retrieve(self) -> Retrieval:
        return Retrieval()

    @hookimpl
    def cbr_reuse(self) -> None:
        return None


class NosyObserver(_Component):
    """An observer that fails after seeing a retrieval."""

    @hookimpl(wrapper=True)
    def cbr_retrieve(self) -> Iterator[None]:
        yield
        raise RuntimeError("the observer failed")


class WipeThenFail(_Component):
    """A forgetter that removes every case, then raises: the learn step must leave no trace."""

    @hookimpl
    def cbr_forget(self, casebase: CaseStore) -> None:
        casebase.remove([case.id for case in casebase.cases()])
        raise RuntimeError("forgetting failed")


class TrackedStore(MemoryStore):
    """A memory store that logs when it is closed."""

    def __init__(self, log: list[str]) -> None:
        super().__init__()
        self.log = log

    def close(self) -> None:
        self.log.append("store closed")


class ClosingRetriever(_Component):
    """A retriever with a ``close`` method that logs its call."""

    log: list[str]

    @hookimpl
    def cbr_retrieve(self) -> Retrieval:
        return Retrieval()

    def close(self) -> None:
        self.log.append("retriever closed")


class Misnamed:
    """A retriever asking for an argument the hookspec does not have."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_retrieve(self, problem: int, case_base: CaseStore) -> Retrieval:
        return Retrieval()


class FaultyPlugin:
    """The test-only components, registered by a plugin named ``faulty``."""

    def __init__(self) -> None:
        self.log: list[str] = []

    def _closing_retriever(self, options: object, ctx: Context) -> ClosingRetriever:
        retriever = ClosingRetriever(options, ctx)
        retriever.log = self.log
        return retriever

    @staticmethod
    def _counted(options: object, ctx: Context) -> toy_domain.CountCalls:
        observer = toy_domain.CountCalls(options, ctx)
        ctx.stash[COUNT_CALLS] = observer
        return observer

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        for kind, hook in (("retriever", "cbr_retrieve"), ("reuser", "cbr_reuse"),
                           ("reviser", "cbr_revise"), ("solver", "cbr_solve"),
                           ("retainer", "cbr_retain"), ("forgetter", "cbr_forget")):
            registry.add(kind, "boom", _raising(hook))
        registry.add("retriever", "wrong", _returning("cbr_retrieve", ["not", "a", "retrieval"]))
        registry.add("reuser", "wrong", _returning("cbr_reuse", 16))
        registry.add("reviser", "wrong", _returning("cbr_revise", True))
        registry.add("solver", "wrong", _returning("cbr_solve", {"value": 16}))
        registry.add("reuser", "give_up", _returning("cbr_reuse", None))
        registry.add("reviser", "no_verdict", _returning("cbr_revise", None))
        registry.add("reviser", "silent_no", _returning("cbr_revise", Revision(False)))
        registry.add("solver", "nothing", _returning("cbr_solve", None))
        registry.add("reviser", "repair", Repair)
        registry.add("retriever", "hookless", _Component)
        registry.add("retriever", "greedy", Greedy)
        registry.add("retriever", "misnamed", Misnamed)
        registry.add("retriever", "reuses", _returning("cbr_reuse", None))
        registry.add("retriever", "closing", self._closing_retriever)
        registry.add("observer", "nosy", NosyObserver)
        registry.add("observer", "hookless", _Component)
        registry.add("observer", "counted", self._counted)
        registry.add("forgetter", "wipe_then_fail", WipeThenFail)
        registry.add("store", "tracked", lambda options, ctx: TrackedStore(self.log))


def load() -> Plugins:
    """The toy domain, the built-in plugins and the test-only components."""
    return load_plugins(extra=[("toy", toy_domain), ("core", cbrcore.builtins),
                               ("stores", cbr_stores),
                               ("observers", cbr_observers), ("faulty", FaultyPlugin())],
                        entry_points=False, environ={})


def engine_for(plugins: Plugins, config: str | dict[str, Any], *stored: int) -> Engine:
    """An engine for ``config`` whose case base holds the solved cases (x, x²) for ``stored``."""
    data = yaml.safe_load(config) if isinstance(config, str) else config
    engine = Engine(parse_config(data, plugins.registry), plugins=plugins)
    for x in stored:
        engine.casebase.add(Case(x, x * x, kind=KIND))
    return engine


def execute(problem: int, proposal: Proposal) -> Outcome:
    """Carry out a proposal: success when it answers x²."""
    if proposal.solution is None:
        return Outcome(success=False)
    return Outcome(success=proposal.solution.value == problem * problem)


@pytest.fixture
def plugins() -> Plugins:
    return load()


@pytest.fixture
def build(plugins: Plugins) -> Iterator[Callable[..., Engine]]:
    """``build(config, *stored)``: engines closed when the test ends."""
    engines: list[Engine] = []

    def make(config: str | dict[str, Any], *stored: int) -> Engine:
        engine = engine_for(plugins, config, *stored)
        engines.append(engine)
        return engine

    yield make
    for engine in engines:
        engine.close()


def _case_id(engine: Engine, x: int) -> int:
    (case,) = [c for c in engine.casebase.cases(KIND) if c.problem == x]
    assert case.id is not None
    return case.id


# --- the hybrid rule --------------------------------------------------------------------------


def test_without_a_retriever_every_query_goes_to_the_solver(build: Callable[..., Engine]) -> None:
    """No retriever configured: the solver answers every query and the reason says why."""
    engine = build("solver: compute\n", 2, 3)
    for x in (0, 2, 7):
        proposal = engine.solve(x)
        assert proposal.source == "solver:compute"
        assert proposal.fallback_reason == "no retriever configured"
        assert proposal.solution == Solution(x * x, cost=0.0)
        assert proposal.retrieval is None and proposal.revision is None
        assert set(proposal.timings) == {"solve"}


def test_an_empty_case_base_gives_no_usable_retrieval(build: Callable[..., Engine]) -> None:
    """With nothing stored the retrieval is empty and the solver answers."""
    engine = build(FULL_CYCLE)
    proposal = engine.solve(4)
    assert proposal.source == "solver:compute"
    assert proposal.fallback_reason == "no usable retrieval"
    assert proposal.retrieval == Retrieval()
    assert proposal.solution is not None and proposal.solution.value == 16
    assert set(proposal.timings) == {"retrieve", "solve"}


def test_an_exact_neighbour_answers_from_the_case_base(build: Callable[..., Engine]) -> None:
    """A stored case for the query itself is reused exactly and accepted with tolerance 0."""
    engine = build(FULL_CYCLE, 4, 9)
    proposal = engine.solve(4)
    assert proposal.source == "casebase" and proposal.from_casebase
    assert proposal.fallback_reason is None
    assert proposal.solution == Solution(16, cases=(_case_id(engine, 4),))
    assert proposal.revision == Revision(True)
    assert set(proposal.timings) == {"retrieve", "reuse", "revise"}


def test_a_neighbour_at_distance_one_is_rejected_with_tolerance_zero(
        build: Callable[..., Engine]) -> None:
    """Stored 3, query 4: the tangent gives 9 + 2·3·1 = 15, error 1 > 0, so the solver answers."""
    engine = build(FULL_CYCLE, 3)
    proposal = engine.solve(4)
    assert proposal.source == "solver:compute"
    assert proposal.fallback_reason == "revision rejected: error 1 above 0.0"
    assert proposal.revision == Revision(False, "error 1 above 0.0")
    assert proposal.solution is not None and proposal.solution.value == 16
    assert set(proposal.timings) == {"retrieve", "reuse", "revise", "solve"}


@pytest.mark.parametrize("tolerance", [1, 1.5, 4])
def test_a_tolerance_of_at_least_one_accepts_the_tangent(build: Callable[..., Engine],
                                                         tolerance: float) -> None:
    """Stored 3, query 4: the tangent's error is (4 - 3)² = 1, accepted from tolerance 1 on."""
    engine = build(FULL_CYCLE.replace("tolerance: 0", f"tolerance: {tolerance}"), 3)
    proposal = engine.solve(4)
    assert proposal.source == "casebase"
    assert proposal.solution == Solution(15, cases=(_case_id(engine, 3),))


@settings(max_examples=40, deadline=None)
@given(x0=st.integers(-40, 40), dx=st.integers(-3, 3), tolerance=st.integers(0, 10))
def test_revision_accepts_exactly_when_the_tangent_error_is_within_tolerance(
        x0: int, dx: int, tolerance: int) -> None:
    """The tangent's error is (x - x0)²: accepted iff it is at most the tolerance."""
    config = {"retrieve": {"use": "nearest", "radius": 3}, "reuse": "tangent",
              "revise": {"use": "tolerance", "tolerance": tolerance}, "solver": "compute"}
    with engine_for(load(), config, x0) as engine:
        proposal = engine.solve(x0 + dx)
    assert proposal.solution is not None
    if dx * dx <= tolerance:
        assert proposal.source == "casebase"
        assert proposal.solution.value == x0 * x0 + 2 * x0 * dx
    else:
        assert proposal.source == "solver:compute"
        assert proposal.fallback_reason == f"revision rejected: error {dx * dx} above " \
                                           f"{float(tolerance)}"
        assert proposal.solution.value == (x0 + dx) ** 2


def test_without_a_reviser_a_reused_solution_is_accepted_as_it_is(
        build: Callable[..., Engine]) -> None:
    """No reviser: the tangent's wrong answer 15 for query 4 (stored 3) is the proposal."""
    engine = build("retrieve: nearest\nreuse: tangent\nsolver: compute\n", 3)
    proposal = engine.solve(4)
    assert proposal.source == "casebase"
    assert proposal.revision is None
    assert proposal.solution is not None and proposal.solution.value == 15
    assert set(proposal.timings) == {"retrieve", "reuse"}


def test_without_a_reuser_a_usable_retrieval_goes_to_the_solver(
        build: Callable[..., Engine]) -> None:
    """A retrieval with matches but no reuser configured: the solver answers."""
    engine = build("retrieve: nearest\nsolver: compute\n", 4)
    proposal = engine.solve(4)
    assert proposal.source == "solver:compute"
    assert proposal.fallback_reason == "no reuser configured"
    assert proposal.retrieval is not None and len(proposal.retrieval.matches) == 1


def test_a_reuser_returning_none_means_reuse_failed(build: Callable[..., Engine]) -> None:
    """Reuse answering None sends the query to the solver with reason 'reuse failed'."""
    engine = build("retrieve: nearest\nreuse: give_up\nsolver: compute\n", 4)
    proposal = engine.solve(4)
    assert proposal.source == "solver:compute"
    assert proposal.fallback_reason == "reuse failed"
    assert set(proposal.timings) == {"retrieve", "reuse", "solve"}


@pytest.mark.parametrize(("reviser", "reason"), [
    ("no_verdict", "revision rejected: no verdict"),
    ("silent_no", "revision rejected"),
])
def test_a_revision_without_a_verdict_or_reason_rejects(
        build: Callable[..., Engine], reviser: str, reason: str) -> None:
    """A reviser answering None rejects ('no verdict'); a rejection without reason says so."""
    engine = build(f"retrieve: nearest\nreuse: tangent\nrevise: {reviser}\nsolver: compute\n", 4)
    proposal = engine.solve(4)
    assert proposal.source == "solver:compute"
    assert proposal.fallback_reason == reason


def test_without_a_solver_a_failed_cycle_leaves_the_query_unsolved(
        build: Callable[..., Engine]) -> None:
    """No solver configured and no usable retrieval: source 'none', no solution, counted."""
    engine = build("retrieve: nearest\nreuse: tangent\n", 9)
    proposal = engine.solve(4)
    assert proposal == Proposal(None, "none", "no usable retrieval", Retrieval(), None,
                                proposal.timings)
    assert set(proposal.timings) == {"retrieve"}
    assert engine.stats.unsolved == 1 and engine.stats.from_solver == 0


def test_a_solver_returning_none_leaves_the_query_unsolved(build: Callable[..., Engine]) -> None:
    """A solver that finds no solution makes the proposal's source 'none'."""
    engine = build("solver: nothing\n")
    proposal = engine.solve(4)
    assert proposal.source == "none" and proposal.solution is None
    assert proposal.fallback_reason == "no retriever configured"
    assert set(proposal.timings) == {"solve"}


def test_a_revision_carrying_a_solution_replaces_the_reused_one(
        build: Callable[..., Engine]) -> None:
    """Stored 3, query 4: the reviser repairs the tangent's 15 into 16; the repair is used."""
    engine = build("retrieve: nearest\nreuse: tangent\nrevise: repair\nsolver: compute\n", 3)
    proposal = engine.solve(4)
    case_id = _case_id(engine, 3)
    assert proposal.source == "casebase"
    assert proposal.solution == Solution(16, cases=(case_id,), detail={"reused": 15})
    assert proposal.revision is not None and proposal.revision.solution == proposal.solution


# --- proposals and statistics -----------------------------------------------------------------


def test_a_proposal_carries_the_matches_with_their_feature_detail(
        build: Callable[..., Engine]) -> None:
    """Stored 2, 3, 5 and 9, query 4 within radius 2: 3 and 5 at distance 1 (by id), then 2."""
    engine = build(FULL_CYCLE.replace("radius: 1", "radius: 2"), 2, 3, 5, 9)
    proposal = engine.solve(4)
    assert proposal.retrieval is not None
    found = [(m.case.problem, m.similarity, dict(m.features)) for m in proposal.retrieval.matches]
    assert found == [(3, 0.5, {"dx": 1.0}), (5, 0.5, {"dx": 1.0}), (2, 1 / 3, {"dx": 2.0})]
    assert proposal.retrieval.matches[0].case == engine.casebase.get(_case_id(engine, 3))


def test_stats_match_a_hand_count(build: Callable[..., Engine]) -> None:
    """Queries 2, 2, 3, 5, 3, 4 with radius 1, tolerance 0 and learning after each query.

    2: empty case base, solver (2 is kept). 2: exact, case base. 3: neighbour 2, 4 + 4 = 8 ≠ 9,
    rejected, solver (3 kept). 5: nothing within 1, solver (5 kept). 3: exact, case base.
    4: neighbours 3 and 5, 3 first, 15 ≠ 16, rejected, solver.
    """
    engine = build(FULL_CYCLE)
    sources = []
    for x in (2, 2, 3, 5, 3, 4):
        proposal = engine.solve(x)
        engine.learn(x, proposal, execute(x, proposal))
        sources.append(proposal.source)
    assert sources == ["solver:compute", "casebase", "solver:compute", "solver:compute",
                       "casebase", "solver:compute"]
    rejected = "revision rejected: error 1 above 0.0"
    assert engine.stats.as_dict() == {
        "queries": 6, "from_casebase": 2, "from_solver": 4, "unsolved": 0, "learned": 6,
        "learn_skipped": 0, "learn_pending": 0,
        "cbr_share": 2 / 6, "fallback_reasons": {"no usable retrieval": 2, rejected: 2},
    }
    assert sorted(c.problem for c in engine.casebase.cases(KIND)) == [2, 3, 4, 5]


def test_stats_count_unsolved_queries(build: Callable[..., Engine]) -> None:
    """Without a solver: stored 4 answers query 4; 6 and 7 stay unsolved."""
    engine = build("retrieve: {use: nearest, radius: 1}\nreuse: tangent\nrevise: tolerance\n", 4)
    for x in (4, 6, 7):
        engine.solve(x)
    stats = engine.stats
    assert (stats.queries, stats.from_casebase, stats.from_solver, stats.unsolved) == (3, 1, 0, 2)
    assert stats.cbr_share == pytest.approx(1 / 3)
    assert stats.fallback_reasons == {"no usable retrieval": 2}


def test_cbr_share_is_zero_before_any_query(build: Callable[..., Engine]) -> None:
    """A fresh engine reports a CBR share of 0 rather than dividing by zero."""
    assert build(FULL_CYCLE).stats.cbr_share == 0.0


def test_the_step_counts_the_queries(build: Callable[..., Engine]) -> None:
    """``ctx.step`` is the index of the query being handled."""
    engine = build("solver: compute\n")
    for expected in range(3):
        engine.solve(expected)
        assert engine.ctx.step == expected


def test_the_context_holds_the_proposal_of_the_query_before(
        build: Callable[..., Engine]) -> None:
    """``ctx.previous`` is the engine's last proposal, whichever way it was reached."""
    engine = build(FULL_CYCLE, 4)
    assert engine.ctx.previous is None
    seen = []
    for problem in (4, 9, 4):
        proposal = engine.solve(problem)
        assert engine.ctx.previous is proposal
        seen.append(proposal.source)
    assert len(set(seen)) > 1, seen


# --- learning ---------------------------------------------------------------------------------


def test_a_failing_forgetter_leaves_the_store_as_before_the_learn_step(
        build: Callable[..., Engine]) -> None:
    """Retain and forget share one transaction: the touch, the retained case and the forgetter's
    own removals are all undone when the forgetter raises."""
    engine = build(FULL_CYCLE + "forget: [wipe_then_fail]\n", 2, 3)
    before = (engine.casebase.cases(), engine.casebase.revision)
    for x in (2, 7):  # 2 touches its case, 7 is retained
        proposal = engine.solve(x)
        with pytest.raises(PhaseError) as caught:
            engine.learn(x, proposal, execute(x, proposal))
        assert "plugin 'wipe_then_fail (faulty)' failed in phase 'forget'" in str(caught.value)
        assert (caught.value.phase, caught.value.plugin) == ("forget", "wipe_then_fail (faulty)")
        assert isinstance(caught.value.__cause__, RuntimeError)
        assert (engine.casebase.cases(), engine.casebase.revision) == before
    assert engine.stats.learned == 0


def test_learning_counts_the_use_of_the_cases_a_solution_came_from(
        build: Callable[..., Engine]) -> None:
    """Stored 3 (revision 1) and 5 (revision 2), tolerance 1: query 4 reuses 3 (lower id at equal
    distance); the learn step commits as revision 3, stamping case 3 alone."""
    engine = build(FULL_CYCLE.replace("tolerance: 0", "tolerance: 1"), 3, 5)
    three, five = _case_id(engine, 3), _case_id(engine, 5)
    proposal = engine.solve(4)
    assert proposal.solution is not None and proposal.solution.cases == (three,)
    engine.learn(4, proposal, execute(4, proposal))  # 15 ≠ 16: nothing retained
    assert engine.casebase.revision == 3
    assert (engine.casebase.get(three).uses, engine.casebase.get(three).last_used) == (1, 3)
    assert (engine.casebase.get(five).uses, engine.casebase.get(five).last_used) == (0, None)
    assert engine.casebase.count(KIND) == 2
    proposal = engine.solve(3)
    engine.learn(3, proposal, execute(3, proposal))
    assert (engine.casebase.get(three).uses, engine.casebase.get(three).last_used) == (2, 4)


def test_a_case_forgotten_by_another_process_since_the_proposal_is_not_touched(
        build: Callable[..., Engine], tmp_path: Path) -> None:
    """Two engines share one SQLite case base: the second forgets case 3 between the first's
    proposal that reused it and the first's learn step, which then counts no use of it (and
    does not fail) while its retainer still stores the new case."""
    config = (FULL_CYCLE.replace("tolerance: 0", "tolerance: 1")
              + f"casebase: {{use: sqlite, path: {tmp_path / 'cb.sqlite'}}}\n")
    first = build(config, 3)
    second = build(config)
    three = _case_id(first, 3)
    proposal = first.solve(4)
    assert proposal.solution is not None and proposal.solution.cases == (three,)
    second.casebase.remove([three])
    first.learn(4, proposal, Outcome(success=True))
    assert [c.problem for c in second.casebase.cases(KIND)] == [4]


def test_learning_a_solver_answer_touches_no_case(build: Callable[..., Engine]) -> None:
    """A solution from the solver was built from no case: no use is counted."""
    engine = build(FULL_CYCLE, 3)
    proposal = engine.solve(4)
    timings = engine.learn(4, proposal, execute(4, proposal))
    assert set(timings) == {"retain", "forget", "learn"}
    assert timings["learn"] >= timings["retain"] + timings["forget"]
    assert engine.casebase.get(_case_id(engine, 3)).uses == 0
    assert engine.casebase.get(_case_id(engine, 4)).solution == 16


@settings(max_examples=30, deadline=None)
@given(queries=st.lists(st.integers(0, 12), max_size=40), limit=st.integers(0, 4),
       radius=st.integers(0, 2))
def test_the_capacity_forgetter_keeps_the_limit(queries: list[int], limit: int,
                                                radius: int) -> None:
    """Over any query sequence the store never exceeds the limit, holds only correct and distinct
    cases, and every answer executed is correct (tolerance 0 accepts only exact reuse)."""
    config = yaml.safe_load(FULL_CYCLE)
    config["retrieve"]["radius"] = radius
    config["forget"] = [{"use": "capacity", "limit": limit}]
    with engine_for(load(), config) as engine:
        for x in queries:
            proposal = engine.solve(x)
            outcome = execute(x, proposal)
            assert outcome.success
            engine.learn(x, proposal, outcome)
            stored = engine.casebase.cases(KIND)
            assert len(stored) <= limit
            assert all(c.solution == c.problem ** 2 for c in stored)
            assert len({c.problem for c in stored}) == len(stored)
        assert engine.stats.from_casebase + engine.stats.from_solver == len(queries)


# --- phase errors -----------------------------------------------------------------------------

PHASE_CONFIGS = {
    "retrieve": "retrieve: boom\nsolver: compute\n",
    "reuse": "retrieve: nearest\nreuse: boom\nsolver: compute\n",
    "revise": "retrieve: nearest\nreuse: tangent\nrevise: boom\nsolver: compute\n",
    "solve": "solver: boom\n",
    "retain": "solver: compute\nretain: [boom]\n",
    "forget": "solver: compute\nforget: [boom]\n",
}


@pytest.mark.parametrize("phase", list(PHASE_CONFIGS))
def test_a_component_raising_in_a_phase_gives_a_phase_error(
        build: Callable[..., Engine], phase: str) -> None:
    """The error names the plugin and the phase; the original exception is the cause."""
    engine = build(PHASE_CONFIGS[phase], 4)
    with pytest.raises(PhaseError) as caught:
        proposal = engine.solve(4)
        engine.learn(4, proposal, execute(4, proposal))
    error = caught.value
    assert (error.phase, error.plugin) == (phase, "boom (faulty)")
    assert str(error) == (f"plugin 'boom (faulty)' failed in phase {phase!r}: "
                          f"ValueError: cbr_{phase} went wrong")
    assert isinstance(error.__cause__, ValueError)


@pytest.mark.parametrize(("config", "phase", "message"), [
    ("retrieve: wrong\n", "retrieve", "returned list, expected Retrieval or None"),
    ("retrieve: nearest\nreuse: wrong\n", "reuse", "returned int, expected Solution or None"),
    ("retrieve: nearest\nreuse: tangent\nrevise: wrong\n", "revise",
     "returned bool, expected Revision or None"),
    ("solver: wrong\n", "solve", "returned dict, expected Solution or None"),
])
def test_a_component_returning_the_wrong_type_gives_a_phase_error(
        build: Callable[..., Engine], config: str, phase: str, message: str) -> None:
    """An answer of the wrong type is refused where it is returned, naming the component."""
    engine = build(config, 4)
    with pytest.raises(PhaseError) as caught:
        engine.solve(4)
    assert (caught.value.phase, caught.value.plugin) == (phase, "wrong (faulty)")
    assert message in str(caught.value)


@pytest.mark.parametrize(("config", "message"), [
    ("retrieve: misnamed\n", "cbr_retrieve"),
    ("retrieve: hookless\n", "must implement exactly cbr_retrieve; it implements no phase hook"),
    ("retrieve: greedy\n", "must implement exactly cbr_retrieve; it implements cbr_retrieve, "
                           "cbr_reuse (cbr_reuse besides)"),
    ("retrieve: reuses\n", "must implement exactly cbr_retrieve; it implements cbr_reuse"),
    ("observers: [hookless]\n", "implements no phase hook to observe"),
])
def test_a_component_with_the_wrong_hooks_is_refused_at_construction(
        plugins: Plugins, config: str, message: str) -> None:
    """A component must implement exactly the hook of its kind; the error names it."""
    with pytest.raises(PluginError) as caught:
        engine_for(plugins, config)
    assert "(plugin 'faulty')" in str(caught.value)
    assert message in str(caught.value)


def test_a_failed_construction_closes_what_was_built(plugins: Plugins) -> None:
    """The case base built before a refused component is closed, not leaked."""
    log = plugins.pm.get_plugin("faulty").log
    with pytest.raises(PluginError):
        engine_for(plugins, "casebase: tracked\nretrieve: greedy\n")
    assert log == ["store closed"]


def test_an_observer_sees_every_call_of_the_hooks_it_wraps(build: Callable[..., Engine]) -> None:
    """The toy ``count_calls`` observer counts one retrieve per query and one solve per fallback
    (the hand count of ``test_stats_match_a_hand_count``)."""
    engine = build(FULL_CYCLE + "observers: [counted]\n")
    for x in (2, 2, 3, 5, 3, 4):
        proposal = engine.solve(x)
        engine.learn(x, proposal, execute(x, proposal))
    observer = engine.ctx.stash[COUNT_CALLS]
    assert observer.calls == {"cbr_retrieve": 6, "cbr_solve": 4}
    assert engine.components["observers.0"] is observer


def test_a_raising_observer_is_named(build: Callable[..., Engine]) -> None:
    """An observer that raises while wrapping a hook is the plugin the PhaseError names."""
    engine = build(FULL_CYCLE + "observers: [nosy]\n")
    with pytest.raises(PhaseError) as caught:
        engine.solve(4)
    assert (caught.value.phase, caught.value.plugin) == ("retrieve", "nosy (faulty)")
    assert isinstance(caught.value.__cause__, RuntimeError)


def test_an_observer_wrapping_a_failing_component_is_not_blamed(
        build: Callable[..., Engine], tmp_path: Path) -> None:
    """With the trace observer around a raising retriever, the retriever is named, and the trace
    records the error it saw."""
    trace = tmp_path / "trace.jsonl"
    engine = build({"retrieve": "boom", "solver": "compute",
                    "observers": [{"use": "trace", "file": str(trace)}, "counted"]})
    with pytest.raises(PhaseError) as caught:
        engine.solve(4)
    assert caught.value.plugin == "boom (faulty)"
    engine.close()
    (line,) = trace.read_text(encoding="utf-8").splitlines()
    record = json.loads(line)
    assert (record["step"], record["phase"]) == (0, "retrieve")
    assert record["error"] == "ValueError: cbr_retrieve went wrong"


# --- construction, files, closing and seeds ----------------------------------------------------


def test_from_yaml_reads_a_file_with_overrides(plugins: Plugins, tmp_path: Path) -> None:
    """``Engine.from_yaml`` reads the file and applies ``--set`` style overrides on top; leaving
    the ``with`` block closes the SQLite case base the override chose (relative to the file)."""
    path = tmp_path / "toy.yaml"
    path.write_text(toy_domain.TOY_CONFIG, encoding="utf-8")
    overrides = ["revise.tolerance=1", "forget.0.limit=2", "seed=11",
                 "casebase={use: sqlite, path: cases.sqlite}"]
    with Engine.from_yaml(path, plugins=plugins, overrides=overrides) as engine:
        assert isinstance(engine.casebase, SQLiteStore)
        assert engine.casebase.path == tmp_path.resolve() / "cases.sqlite"
        assert engine.config.source == path.resolve()
        assert engine.config.seed == engine.ctx.seed == 11
        assert engine.config.revise is not None
        assert engine.config.revise.options.tolerance == 1.0
        assert engine.config.forget[0].options.limit == 2
        assert len(engine.workload) == 30
        assert engine.ctx.config_dir == tmp_path.resolve()
        engine.casebase.add(Case(3, 9, kind=KIND))
        assert engine.solve(4).source == "casebase"  # tolerance 1 accepts the tangent's 15
    with pytest.raises(sqlite3.ProgrammingError, match="closed database"):
        engine.casebase.count()


def test_the_context_manager_closes_components_then_the_store(plugins: Plugins) -> None:
    """Leaving the ``with`` block closes every component with ``close``, the case base last,
    once only."""
    log = plugins.pm.get_plugin("faulty").log
    with engine_for(plugins, "casebase: tracked\nretrieve: closing\n") as engine:
        assert isinstance(engine.casebase, TrackedStore)
        assert log == []
    assert log == ["retriever closed", "store closed"]
    engine.close()
    assert log == ["retriever closed", "store closed"]


def test_the_same_seed_gives_the_same_queries(plugins: Plugins) -> None:
    """The run's generator is seeded: equal seeds repeat the workload, another seed does not."""
    data = yaml.safe_load(toy_domain.TOY_CONFIG)

    def queries(seed: int) -> list[int]:
        with engine_for(plugins, {**data, "seed": seed}) as engine:
            return list(engine.workload.queries(engine.ctx))

    first = queries(3)
    assert len(first) == 30 and all(0 <= x < 8 for x in first)
    assert queries(3) == first
    assert queries(4) != first


class _Logged:
    """A retainer that appends its label to a shared log when it runs."""

    def __init__(self, label: str, log: list[str]) -> None:
        self.label, self.log = label, log

    @hookimpl
    def cbr_retain(self) -> None:
        self.log.append(f"retain {self.label}")


class _OrderPlugin:
    """Retainers ``r1``..``r3`` and forgetters ``f1``..``f3`` that log when they run."""

    def __init__(self) -> None:
        self.log: list[str] = []

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        for n in (1, 2, 3):
            registry.add("retainer", f"r{n}", lambda o, c, n=n: _Logged(f"r{n}", self.log))
            registry.add("forgetter", f"f{n}", lambda o, c, n=n: _OnlyForget(f"f{n}", self.log))


class _OnlyForget:
    """A forgetter that appends its label to a shared log when it runs."""

    def __init__(self, label: str, log: list[str]) -> None:
        self.label, self.log = label, log

    @hookimpl
    def cbr_forget(self) -> None:
        self.log.append(f"forget {self.label}")


def test_retainers_and_forgetters_run_in_the_configured_order() -> None:
    """Collect-all phases run in the order the configuration lists them, retainers first."""
    order = _OrderPlugin()
    plugins = load_plugins(extra=[("core", cbrcore.builtins),
                                  ("stores", cbr_stores), ("toy", toy_domain),
                                  ("order", order)], entry_points=False, environ={})
    with engine_for(plugins, "solver: compute\nretain: [r2, r1, r3]\nforget: [f3, f1]\n") as e:
        proposal = e.solve(3)
        e.learn(3, proposal, execute(3, proposal))
    assert order.log == ["retain r2", "retain r1", "retain r3", "forget f3", "forget f1"]
