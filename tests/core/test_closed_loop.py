"""Closed-loop workloads: a workload that runs its own loop on a ``cbrcore.workload.Session``.

The lane of ``closed_loop_domain`` (length 14, sight 2) holds, in order, obstacles at 2 (size 1,
in view from 0, passed at 3), 4 (size 1, in view from 2, passed at 5), 6 (size 3, in view from
0, passed at 9), 10 (size 1, in view from 8, passed at 11) and 12 (size 3, in view from 6, its
far end 15 beyond the lane: it fails when the lap ends). By hand, the first lap, empty case base:

=====  ==========================================  =================================
tick   what happens                                case base afterwards
=====  ==========================================  =================================
0      consult q0 (at 2, size 1): solver           {}
0      consult q1 (at 6, size 3): solver           {}
2      consult q2 (at 4, size 1): solver, q0 open  {}
3      learn q0: passed                            {1: 2}
5      learn q2: passed (size 1 is stored)         {1: 2}
6      consult q3 (at 12, size 3): solver, q1 open {1: 2}
8      consult q4 (at 10, size 1): case base       {1: 2}
9      learn q1: passed                            {1: 2, 3: 4}
11     learn q4: passed                            {1: 2, 3: 4}
14     lap over: learn q3, failed                  {1: 2, 3: 4}
=====  ==========================================  =================================

The second lap consults in the same order (q5 at 2, q6 at 6, q7 at 4, q8 at 12, q9 at 10), every
answer from the case base, and learns q5, q7, q6, q9, then q8 failed. The solver swerves by size
+ 1, so a size 1 swerve costs 2 and a size 3 swerve 4.
"""

from __future__ import annotations

import csv
import json
import re
import types
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import attrs
import pytest
import yaml

import cbr_observers
import cbrcore.builtins
import closed_loop_domain
from cbrcore import Engine, Outcome, Proposal, hookimpl
from cbrcore.config import parse_config
from cbrcore.context import Context
from cbrcore.errors import ConfigError, PluginError
from cbrcore.options import option
from cbrcore.plugins import Plugins, load_plugins
from cbrcore.registry import Registry
from cbrcore.run import run_workload
from cbrcore.workload import ClosedLoopWorkload, Decision, QueryWorkload, Session
from repo_paths import ROOT

GUIDE = ROOT / "docs" / "plugins-closed-loop.md"
GUIDE_EXAMPLE = re.compile(r"^```python\n(# lane\.py\n.*?)^```$", re.S | re.M)

COLUMNS = ["query", "q_lap", "q_at", "q_size", "source", "fallback_reason", "retrieved",
           "best_similarity", "solution_cost", "success", "outcome_cost", "ms_retrieve",
           "ms_reuse", "ms_revise", "ms_solve", "ms_retain", "ms_forget", "ms_learn",
           "ctx_step"]
SOLVER = "solver:margin"
# (query, lap, at, size, source, success, outcome cost) in the order the outcomes are known
EXPECTED = [
    (0, 0, 2, 1, SOLVER, True, 2.0),
    (2, 0, 4, 1, SOLVER, True, 2.0),
    (1, 0, 6, 3, SOLVER, True, 4.0),
    (4, 0, 10, 1, "casebase", True, 2.0),
    (3, 0, 12, 3, SOLVER, False, None),
    (5, 1, 2, 1, "casebase", True, 2.0),
    (7, 1, 4, 1, "casebase", True, 2.0),
    (6, 1, 6, 3, "casebase", True, 4.0),
    (9, 1, 10, 1, "casebase", True, 2.0),
    (8, 1, 12, 3, "casebase", False, None),
]


class StepSeen:
    """A metric reporting the ``ctx.step`` it sees."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    def measure(self, problem: Any, proposal: Proposal, outcome: Outcome,
                ctx: Context) -> Mapping[str, float]:
        return {"ctx_step": float(ctx.step)}


@attrs.frozen
class MisbehavesOptions:
    mistake: str = option("open", "What the loop does wrong.", validator=attrs.validators.in_(
        ["open", "twice", "outcome", "handle", "raise"]))


class Scripted:
    """A closed-loop workload consulting on a script rather than a lane."""

    def __len__(self) -> int:
        return 2

    def describe(self, problem: Any) -> Mapping[str, Any]:
        return problem


class Misbehaves(Scripted):
    """Consults twice (sizes 1 and 2), learns the first, then makes its mistake."""

    def __init__(self, options: MisbehavesOptions, ctx: Context) -> None:
        self.mistake = options.mistake

    def run(self, session: Session) -> None:
        first = session.consult({"lap": 0, "at": 2, "size": 1})
        session.learn(first, Outcome(True, cost=2.0))
        second = session.consult({"lap": 0, "at": 4, "size": 2})
        if self.mistake == "twice":
            session.learn(first, Outcome(True, cost=2.0))
        elif self.mistake == "outcome":
            session.learn(second, True)  # type: ignore[arg-type]
        elif self.mistake == "handle":
            session.learn(second.index, Outcome(True))  # type: ignore[arg-type]
        elif self.mistake == "raise":
            raise ValueError("the simulator crashed")


class Keeps(Scripted):
    """Consults and learns once per run, keeping the decision and the session; a later run
    first learns the decision the run before kept."""

    def __init__(self, options: object, ctx: Context) -> None:
        self.kept: Decision | None = None
        self.session: Session | None = None

    def run(self, session: Session) -> None:
        if self.kept is not None:
            session.learn(self.kept, Outcome(True, cost=2.0))
        self.session = session
        self.kept = session.consult({"lap": 0, "at": 2, "size": 1})
        session.learn(self.kept, Outcome(True, cost=2.0))


class BothLoops(closed_loop_domain.Lane):
    """A lane that also offers queries and execute."""

    def queries(self, ctx: Context) -> list[Any]:
        return []

    def execute(self, problem: Any, proposal: Proposal, ctx: Context) -> Outcome:
        return Outcome(True)


class NoLoop:
    """A workload with neither loop."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    def __len__(self) -> int:
        return 0

    def describe(self, problem: Any) -> Mapping[str, Any]:
        return {}


class LoopComponents:
    """The test-only components of this module, registered as plugin ``loops``."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("metric", "step_seen", StepSeen)
        registry.add("workload", "misbehaves", Misbehaves, options=MisbehavesOptions)
        registry.add("workload", "keeps", Keeps)
        registry.add("workload", "both_loops", BothLoops,
                     options=closed_loop_domain.LaneOptions)
        registry.add("workload", "no_loop", NoLoop)


@pytest.fixture
def plugins() -> Plugins:
    return load_plugins(extra=[("lane", closed_loop_domain), ("core", cbrcore.builtins),
                               ("observers", cbr_observers), ("loops", LoopComponents())],
                        entry_points=False, environ={})


def engine_for(plugins: Plugins, config: str, out_dir: Path, **changes: Any) -> Engine:
    data = {**yaml.safe_load(config), **changes}
    return Engine(parse_config(data, plugins.registry), plugins=plugins, out_dir=out_dir)


def read_rows(out_dir: Path) -> list[dict[str, str]]:
    with (out_dir / "results.csv").open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def laps(rows: list[dict[str, str]]) -> list[tuple[Any, ...]]:
    """The rows as EXPECTED lists them."""
    return [(int(r["query"]), int(r["q_lap"]), int(r["q_at"]), int(r["q_size"]), r["source"],
             r["success"] == "True", float(r["outcome_cost"]) if r["outcome_cost"] else None)
            for r in rows]


@pytest.fixture
def lane_run(plugins: Plugins, tmp_path: Path
             ) -> tuple[Path, dict[str, Any], list[tuple[int, int]], list[tuple[Any, ...]]]:
    """Two laps with the step_seen metric and a trace: the folder, the summary, the progress
    calls and the stored cases as (problem, solution, uses)."""
    progress: list[tuple[int, int]] = []
    with engine_for(plugins, closed_loop_domain.LANE_CONFIG, tmp_path,
                    metrics=["step_seen"], observers=["trace"]) as engine:
        summary = run_workload(engine, tmp_path,
                               progress=lambda done, total: progress.append((done, total)))
        cases = [(c.problem, c.solution, c.uses)
                 for c in engine.casebase.cases(closed_loop_domain.KIND)]
    return tmp_path, summary, progress, cases


def test_rows_are_written_as_outcomes_become_known(lane_run: tuple[Any, ...]) -> None:
    """One row per consultation, in the order of the hand-worked table; each row's metric saw
    ctx.step of its own consultation, not of the latest one."""
    out_dir, _, progress, _ = lane_run
    rows = read_rows(out_dir)
    assert list(rows[0]) == COLUMNS
    assert laps(rows) == EXPECTED
    assert [r["ctx_step"] for r in rows] == [f"{float(r['query'])}" for r in rows]
    assert progress == [(done, 10) for done in range(11)]


def test_rows_record_where_each_swerve_came_from(lane_run: tuple[Any, ...]) -> None:
    """A solver row found nothing of its size; a case base row found the one case of its size
    and swerved by its offset."""
    out_dir, _, _, _ = lane_run
    for row in read_rows(out_dir):
        offset = str(float(int(row["q_size"]) + 1))
        if row["source"] == SOLVER:
            assert (row["fallback_reason"], row["retrieved"], row["best_similarity"]) == (
                "no usable retrieval", "0", "")
            assert row["ms_solve"] and not row["ms_reuse"]
        else:
            assert (row["fallback_reason"], row["retrieved"], row["best_similarity"]) == (
                "", "1", "1.0")
            assert row["ms_reuse"] and not row["ms_solve"]
        assert row["solution_cost"] == offset
        assert row["ms_retrieve"] and row["ms_retain"] and row["ms_learn"]


def test_the_summary_counts_consultations_and_follows_the_query_index(
        lane_run: tuple[Any, ...]) -> None:
    """4 solver answers (q0-q3) then 6 from the case base; 2 failures; mean cost of the 8
    passed swerves (six of size 1 at 2, two of size 3 at 4) 2.5; ctx_step 0..9 means 4.5. The
    10 evolution stretches are single queries in index order, though rows came in another."""
    out_dir, summary, _, _ = lane_run
    assert json.loads((out_dir / "summary.json").read_text(encoding="utf-8")) == summary
    assert (summary["queries"], summary["learned"]) == (10, 10)
    assert (summary["from_solver"], summary["from_casebase"], summary["unsolved"]) == (4, 6, 0)
    assert summary["cbr_share"] == pytest.approx(0.6)
    assert summary["fallback_reasons"] == {"no usable retrieval": 4}
    assert summary["success_rate"] == pytest.approx(0.8)
    assert summary["mean_outcome_cost"] == pytest.approx(2.5)
    assert summary["metric_means"] == {"ctx_step": pytest.approx(4.5)}
    assert [(s["first"], s["last"], s["cbr_share"]) for s in summary["evolution"]] == [
        (k, k, 0.0 if k < 4 else 1.0) for k in range(10)]


def test_the_case_base_holds_exactly_the_learned_swerves(lane_run: tuple[Any, ...]) -> None:
    """Size 1 was stored by q0 and reused by q4, q5, q7, q9; size 3 was stored by q1 and reused
    by q6 and q8 (whose failure still counts the use). q2 and q3 solved sizes already stored
    or failed, and were not kept again."""
    _, _, _, cases = lane_run
    assert cases == [({"size": 1}, 2, 4), ({"size": 3}, 4, 2)]


def test_learning_runs_at_the_step_of_the_decision(lane_run: tuple[Any, ...]) -> None:
    """The trace shows each retain at its decision's step, in the order outcomes became known,
    and each consultation's retrieve at its own step."""
    out_dir, _, _, _ = lane_run
    lines = [json.loads(line) for line in
             (out_dir / "trace.jsonl").read_text(encoding="utf-8").splitlines()]
    assert [line["step"] for line in lines if line["phase"] == "retain"] == [
        query for query, *_ in EXPECTED]
    assert [line["step"] for line in lines if line["phase"] == "retrieve"] == list(range(10))


def test_a_consultation_reuses_a_case_learned_earlier_in_the_same_lap(
        plugins: Plugins, tmp_path: Path) -> None:
    """Embedded, without a run: q2 (size 1) is consulted while q0 is still open and goes to the
    solver; q4 (size 1) is consulted after q0 was learned and reuses the case q0 left."""
    decisions: list[Decision] = []

    class Watching(Session):
        def consult(self, problem: Any) -> Decision:
            decisions.append(super().consult(problem))
            return decisions[-1]

    with engine_for(plugins, closed_loop_domain.LANE_CONFIG, tmp_path) as engine:
        session = Watching(engine)
        engine.workload.run(session)
        session.close()
        (stored,) = [c for c in engine.casebase.cases(closed_loop_domain.KIND)
                     if c.problem == {"size": 1}]
        assert engine.stats.learned == 10
    assert [d.index for d in decisions] == list(range(10))
    assert decisions[2].proposal.source == SOLVER
    assert decisions[4].proposal.from_casebase
    assert decisions[4].proposal.solution.cases == (stored.id,)
    assert session.pending == ()


def test_unsolved_consultations_are_learned_at_once(plugins: Plugins, tmp_path: Path) -> None:
    """Without a solver nothing is ever stored: each consultation is unsolved, and the lane
    learns its failure at once, so rows come in consultation order."""
    config = closed_loop_domain.LANE_CONFIG.replace("solver: margin\n", "")
    with engine_for(plugins, config, tmp_path) as engine:
        summary = run_workload(engine, tmp_path)
        assert engine.casebase.count() == 0
    rows = read_rows(tmp_path)
    assert [r["query"] for r in rows] == [str(k) for k in range(10)]
    assert {(r["source"], r["success"]) for r in rows} == {("none", "False")}
    assert (summary["unsolved"], summary["learned"], summary["success_rate"]) == (10, 10, 0.0)


@pytest.mark.parametrize(("mistake", "message"), [
    ("open", "workload 'misbehaves' returned from run() with 1 consultation still open "
             "(query 1): learn each decision with session.learn(decision, outcome) before "
             "returning"),
    ("twice", "workload 'misbehaves' learned consultation 0 a second time; each decision is "
              "learned once"),
    ("outcome", "workload 'misbehaves' passed bool to session.learn() for consultation 1, "
                "expected Outcome"),
    ("handle", "workload 'misbehaves' passed int to session.learn(), expected the Decision "
               "session.consult() returned"),
    ("raise", "workload 'misbehaves' failed in run() after 2 consultations: ValueError: the "
              "simulator crashed"),
])
def test_a_misused_session_stops_the_run(plugins: Plugins, tmp_path: Path, mistake: str,
                                         message: str) -> None:
    """The run stops with a PluginError naming the workload; the first decision's row is
    written and its case kept, the open one left nothing, and there is no summary."""
    config = closed_loop_domain.LANE_CONFIG.replace(
        "use: lane, laps: 2, sight: 2", f"use: misbehaves, mistake: {mistake}")
    with engine_for(plugins, config, tmp_path) as engine, pytest.raises(PluginError) as caught:
        try:
            run_workload(engine, tmp_path)
        finally:
            cases = [c.problem for c in engine.casebase.cases()]
    assert str(caught.value) == message
    assert [r["query"] for r in read_rows(tmp_path)] == ["0"]
    assert cases == [{"size": 1}]
    assert not (tmp_path / "summary.json").exists()
    if mistake == "raise":
        assert isinstance(caught.value.__cause__, ValueError)


def test_a_decision_of_another_session_is_refused(plugins: Plugins, tmp_path: Path) -> None:
    """One engine runs its workload twice; the second run's session refuses the decision the
    first run's session made."""
    config = closed_loop_domain.LANE_CONFIG.replace("{use: lane, laps: 2, sight: 2}", "keeps")
    with engine_for(plugins, config, tmp_path) as engine:
        assert run_workload(engine, tmp_path / "first")["learned"] == 1
        with pytest.raises(PluginError) as caught:
            run_workload(engine, tmp_path / "second")
    assert str(caught.value) == ("workload 'keeps' passed consultation 0 of another session to "
                                 "session.learn(); a decision is learned by the session that "
                                 "consulted it")
    assert read_rows(tmp_path / "second") == []


def test_a_closed_session_is_refused(plugins: Plugins, tmp_path: Path) -> None:
    """A session kept past the end of its run can neither consult nor learn."""
    config = closed_loop_domain.LANE_CONFIG.replace("{use: lane, laps: 2, sight: 2}", "keeps")
    with engine_for(plugins, config, tmp_path) as engine:
        run_workload(engine, tmp_path)
        session, kept = engine.workload.session, engine.workload.kept
        for method, call in (("consult", lambda: session.consult({"size": 1})),
                             ("learn", lambda: session.learn(kept, Outcome(True)))):
            with pytest.raises(PluginError) as caught:
                call()
            assert str(caught.value) == (f"workload 'keeps' called session.{method}() after "
                                         "its session was closed; a session is used only while "
                                         "run(session) runs")
        assert engine.stats.queries == 1


@pytest.mark.parametrize(("workload", "has"), [
    ("both_loops", "run(), queries(), execute()"),
    ("no_loop", "none of run(), queries(), execute()"),
])
def test_a_workload_needs_exactly_one_loop(plugins: Plugins, tmp_path: Path, workload: str,
                                           has: str) -> None:
    """Refused before any output is written."""
    config = closed_loop_domain.LANE_CONFIG.replace("{use: lane, laps: 2, sight: 2}", workload)
    out_dir = tmp_path / "out"
    with engine_for(plugins, config, out_dir) as engine, pytest.raises(PluginError) as caught:
        run_workload(engine, out_dir)
    assert str(caught.value) == (f"workload {workload!r} has {has}: a workload implements "
                                 "either run(session), running its own loop, or queries(ctx) "
                                 "and execute(problem, proposal, ctx)")
    assert list(out_dir.iterdir()) == []


def test_a_session_needs_a_workload(plugins: Plugins, tmp_path: Path) -> None:
    with engine_for(plugins, "solver: margin\n", tmp_path) as engine, \
            pytest.raises(ConfigError) as caught:
        Session(engine)
    (problem,) = caught.value.problems
    assert problem.startswith("workload: required for a session")


def test_the_protocols_tell_the_two_loops_apart(plugins: Plugins, tmp_path: Path) -> None:
    with engine_for(plugins, closed_loop_domain.LANE_CONFIG, tmp_path) as engine:
        assert isinstance(engine.workload, ClosedLoopWorkload)
        assert not isinstance(engine.workload, QueryWorkload)


def test_the_guide_example_drives_the_same_laps(tmp_path: Path) -> None:
    """The closed-loop workload of docs/plugins-closed-loop.md, run with this domain's
    components, gives the rows of the hand-worked table."""
    (source,) = GUIDE_EXAMPLE.findall(GUIDE.read_text(encoding="utf-8"))
    lane = types.ModuleType("lane")
    exec(compile(source, str(GUIDE), "exec"), lane.__dict__)

    class GuideLane:
        @hookimpl
        def cbr_register(self, registry: Registry) -> None:
            registry.add("workload", "guide_lane", lane.Lane, options=lane.LaneOptions)

    plugins = load_plugins(extra=[("lane", closed_loop_domain), ("core", cbrcore.builtins),
                                  ("guide", GuideLane())], entry_points=False, environ={})
    config = closed_loop_domain.LANE_CONFIG.replace("{use: lane, laps: 2, sight: 2}",
                                                    "{use: guide_lane, laps: 2}")
    with engine_for(plugins, config, tmp_path) as engine:
        assert len(engine.workload) == 10
        run_workload(engine, tmp_path)
    assert laps(read_rows(tmp_path)) == EXPECTED
