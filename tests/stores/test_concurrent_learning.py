"""Several processes learning into one SQLite case base at once, for each grid family.

Each learner is a process (spawned) running the ``trips`` workload on the same generated map with
its own seed, into one case base file. Every learner logs each learn step it committed: the
revision the step committed as, the path it retained, the drive report's cells, and the ids it
added and removed (the store's ``add`` and ``remove`` are watched). A retainer of this module,
listed last, stamps every step with a marker in the case base's meta (the digest of everything
the step leaves behind), written in the step's own transaction. From the logs the tests check:

- nothing is lost or resurrected: replaying the adds and removes of every committed step in
  revision order gives exactly the case ids the store holds;
- the families' invariants hold (``cbr casebase check``), and a reader process opening the store
  read-only again and again sees, in every snapshot, the marker's digest of what it sees and a
  sound family: never half a step;
- the case graph merges what the robots retained exactly as one robot driving all their paths in
  commit order would; the learned risks are exactly the risk changes of all trips applied in
  commit order (no update lost);
- a learner killed inside a learn step leaves the others running to completion and nothing of
  its step in the store.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import multiprocessing
import os
import signal
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import attrs
import numpy as np
import pytest

from cbr_casegraph.graph import CaseGraph
from cbr_grid.generate import generate
from cbr_grid.query import without_loops
from cbr_grid.risk import LEARNED_RISK, risk_changes
from cbr_pathcases.hausdorff import hausdorff
from cbr_stores.sqlite import SQLiteStore
from cbrcore.casebase import MemoryStore
from cbrcore.casebase.store import CaseStore
from cbrcore.cli.casebase import family_problems
from cbrcore.engine import Engine
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Case, Outcome, Solution
from cbrcore.plugins import load_plugins, use_plugins
from cbrcore.registry import Registry

MAP = {"kind": "office", "width": 24, "height": 24}
MAP_SEED = 5
"""Every learner drives on this map; only the trips differ, by the learner's seed."""

STEPS = 12
"""Learn steps per learner."""

RISK = {"hit_risk": 0.5, "pass_relief": 0.05}
TRIPS = {"use": "trips", "count": STEPS, "unknown_static": 6, "unknown_dynamic": 2,
         "appear": 0.3, "min_distance": 6}
FAMILIES: dict[str, dict[str, Any]] = {
    "casegraph": {"retrieve": {"use": "casegraph", "delta": 4}, "reuse": "casegraph",
                  "retain": [{"use": "risk_map", **RISK}, "casegraph", "step_marker"]},
    "pathcases": {"retrieve": {"use": "path_cases", "delta": 3}, "reuse": "path_cases",
                  "retain": [{"use": "risk_map", **RISK}, "path_cases", "step_marker"]},
    "riskmap": {"retain": [{"use": "risk_map", **RISK}, "step_marker"]},
}
"""The learning of each family, without forgetters: what is retained stays, unless the family's
own retain step replaces it (a split segment, a costlier similar path), which the logs record."""

MARKER = "test.step"
SENTINEL = "test.sentinel"
TIMEOUT = 120.0
"""Seconds a test waits for a process at most: a hang fails instead of blocking the suite."""


def the_map() -> Any:
    return generate(MAP["kind"], MAP["width"], MAP["height"], MAP_SEED)


def digest(cases: list[Case], meta: dict[str, Any]) -> str:
    """What a learn step leaves behind, as one string: the cases and the families' meta."""
    content = [[c.id, c.kind, c.problem, c.solution, c.uses] for c in cases]
    kept = {k: v for k, v in meta.items() if k != MARKER}
    return hashlib.sha256(json.dumps([content, kept], sort_keys=True).encode()).hexdigest()


# -- the learner process -------------------------------------------------------------------------


class Step:
    """The learn step under way in this process: its commit revision and what it wrote."""

    def __init__(self) -> None:
        self.revision = 0
        self.added: list[int] = []
        self.removed: list[int] = []
        self.path: list[list[int]] = []
        self.success = False
        self.report: dict[str, Any] = {}
        self.pause_at: int | None = None
        """The step (counted from 0) this learner is killed in; None: it is not."""
        self.inside: Path | None = None
        """The file written once the learner waits inside the step to be killed."""
        self.count = 0
        """The steps this learner committed."""


STEP = Step()


class StepMarker:
    """Last retainer: stamps the step's marker, and pauses inside the step when told to."""

    def __init__(self, options: object, ctx: object) -> None:
        pass

    @hookimpl
    def cbr_retain(self, solution: Solution, outcome: Outcome, casebase: CaseStore) -> None:
        # inside the transaction, with the write lock held: the step commits as the next one
        STEP.revision = casebase.revision + 1
        STEP.path = [list(map(int, cell)) for cell in solution.value]
        STEP.success = outcome.success
        report = outcome.report
        STEP.report = {"driven": [] if report is None else np.asarray(report.driven).tolist(),
                       "met": [] if report is None else [list(map(int, c)) for c in report.met]}
        if STEP.count == STEP.pause_at and STEP.inside is not None:
            casebase.add(Case("killed", None, kind=SENTINEL))
            casebase.set_meta(SENTINEL, STEP.revision)
            STEP.inside.write_text(str(os.getpid()))
            time.sleep(TIMEOUT)  # killed here, inside the transaction
        casebase.set_meta(MARKER, {"revision": STEP.revision,
                                   "digest": digest(casebase.cases(), casebase.meta_items())})


class MarkerPlugin:
    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("retainer", "step_marker", StepMarker)


def _watched(store: Any) -> None:
    """Log the ids the learn step under way adds and removes."""
    add, remove = store.add, store.remove

    def watched_add(case: Case) -> Case:
        stored = add(case)
        STEP.added.append(int(stored.id))
        return stored

    def watched_remove(ids: Any) -> None:
        ids = [int(i) for i in ids]
        remove(ids)
        STEP.removed.extend(ids)

    store.add, store.remove = watched_add, watched_remove


def learner(family: str, path: str, seed: int, log: str, ready: Any, go: Any, first: Any,
            pause_at: int | None = None, inside: str | None = None) -> None:
    """Run ``STEPS`` trips of ``family`` with ``seed``, learning into the case base ``path``;
    append each committed step to ``log`` as a JSON line. Every learner waits at ``first``
    after its first step, so that the learners' steps interleave however busy the machine."""
    plugins = load_plugins(extra=[("marker", MarkerPlugin())], environ={})
    config = {"seed": seed, "casebase": {"use": "sqlite", "path": path, "busy_timeout": 30.0},
              "workload": TRIPS, "solver": "astar", **FAMILIES[family]}
    STEP.pause_at, STEP.inside = pause_at, None if inside is None else Path(inside)
    with use_plugins(plugins), Engine.from_dict(config, world=the_map(),
                                                plugins=plugins) as engine:
        _watched(engine.casebase)
        ready.set()
        go.wait(TIMEOUT)
        with open(log, "a", encoding="utf-8") as out:
            for problem in engine.workload.queries(engine.ctx):
                proposal = engine.solve(problem)
                outcome = engine.workload.execute(problem, proposal, engine.ctx)
                STEP.added, STEP.removed = [], []
                engine.learn(problem, proposal, outcome)
                STEP.count += 1
                out.write(json.dumps({"revision": STEP.revision, "added": STEP.added,
                                      "removed": STEP.removed, "path": STEP.path,
                                      "success": STEP.success, "report": STEP.report}) + "\n")
                out.flush()
                if STEP.count == 1:
                    first.wait(TIMEOUT)


def reader(path: str, stop: Any, result: str) -> None:
    """Read the case base in snapshots until told to stop; write what was wrong with any."""
    plugins = load_plugins(environ={})
    seen, wrong = 0, []
    with use_plugins(plugins):
        while True:
            done = stop.is_set()  # one more snapshot after the learners finished
            with SQLiteStore(path, read_only=True) as store, store.transaction():
                cases, meta = store.cases(), store.meta_items()
                marker = meta.get(MARKER)
                if marker is not None:
                    seen += 1
                    if marker["revision"] != store.revision:
                        wrong.append(f"marker of revision {marker['revision']} in a snapshot "
                                     f"at revision {store.revision}")
                    if marker["digest"] != digest(cases, meta):
                        wrong.append(f"revision {store.revision}: half a step")
                    wrong += family_problems(store)
            if done:
                break
    Path(result).write_text(json.dumps({"snapshots": seen, "wrong": wrong}))


# -- running them ----------------------------------------------------------------------------------


def run_learners(tmp_path: Path, family: str, learners: int, *, pause: int | None = None
                 ) -> dict[str, Any]:
    """Run ``learners`` processes (seeds 1, 2, ...) and a reader on one case base.

    With ``pause`` (after the first step), the first learner is killed inside its learn step
    number ``pause``. Returns the exit codes, every committed step (in revision order) and what
    the reader found.
    """
    assert pause is None or pause > 1, "every learner gets past its first step"
    spawn = multiprocessing.get_context("spawn")
    first = spawn.Barrier(learners)
    path = tmp_path / "shared.sqlite"
    go, stop = spawn.Event(), spawn.Event()
    inside = tmp_path / "inside"
    processes, readies = [], []
    for seed in range(1, learners + 1):
        ready = spawn.Event()
        paused = pause if seed == 1 else None
        process = spawn.Process(target=learner, args=(
            family, str(path), seed, str(tmp_path / f"log{seed}.jsonl"), ready, go, first,
            paused, str(inside)))
        process.start()
        processes.append(process)
        readies.append(ready)
    watcher = spawn.Process(target=reader, args=(str(path), stop, str(tmp_path / "read.json")))
    try:
        for ready in readies:
            assert ready.wait(TIMEOUT), "a learner did not start"
        watcher.start()  # the case base exists now
        go.set()  # all at once, each engine built and warm
        if pause is not None:
            deadline = time.monotonic() + TIMEOUT
            while not inside.exists():
                assert time.monotonic() < deadline, "the learner to kill never paused"
                time.sleep(0.01)
            os.kill(processes[0].pid, signal.SIGKILL)
        for process in processes:
            process.join(TIMEOUT)
        stop.set()
        watcher.join(TIMEOUT)
    finally:
        for process in (*processes, watcher):
            if process.is_alive():
                process.kill()
    steps = []
    for seed in range(1, learners + 1):
        log = tmp_path / f"log{seed}.jsonl"
        if log.exists():
            steps += [{**json.loads(line), "seed": seed}
                      for line in log.read_text().splitlines()]
    steps.sort(key=lambda step: step["revision"])
    return {"codes": [p.exitcode for p in processes], "steps": steps, "path": path,
            "read": json.loads((tmp_path / "read.json").read_text())}


def assert_consistent(run: dict[str, Any]) -> None:
    """Every committed step's writes are there and nothing else is; the store and families are
    sound; the reader never saw half a step."""
    revisions = [step["revision"] for step in run["steps"]]
    assert len(set(revisions)) == len(revisions), "two steps committed as one revision"
    # the learners took turns (the barrier after every learner's first step sees to it), so the
    # steps interleaved rather than one learner finishing before the next began
    turns = sum(a["seed"] != b["seed"] for a, b in itertools.pairwise(run["steps"]))
    assert turns >= len({step["seed"] for step in run["steps"]})
    expected: set[int] = set()
    for step in run["steps"]:
        assert set(step["removed"]) <= expected | set(step["added"]), (
            f"revision {step['revision']} removed a case nobody committed")
        expected = (expected | set(step["added"])) - set(step["removed"])
    with SQLiteStore(run["path"], read_only=True) as store:
        assert {int(c.id) for c in store.cases()} == expected
        assert store.revision == max(revisions)
        assert store.check() == []
        assert family_problems(store) == []
    assert run["read"]["wrong"] == []
    assert run["read"]["snapshots"] > 0


@pytest.fixture
def installed() -> Any:
    with use_plugins(load_plugins(environ={})) as plugins:
        yield plugins


# -- the tests -------------------------------------------------------------------------------------


def learned_together(tmp_path: Path, family: str, learners: int) -> dict[str, Any]:
    """``learners`` processes learning ``family`` into one case base, every one of them having
    finished and committed all its steps, and the case base consistent with their logs."""
    run = run_learners(tmp_path, family, learners)
    assert run["codes"] == [0] * learners
    assert len(run["steps"]) == STEPS * learners
    assert_consistent(run)
    return run


def replayed_graph(steps: list[dict[str, Any]]) -> CaseGraph:
    """The case graph one robot builds by retaining every successful trip in commit order."""
    graph = CaseGraph(the_map(), MemoryStore())
    for step in steps:
        if step["success"] and len(step["path"]) > 1:
            graph.add_path(step["path"])
    return graph


def structure(ends: tuple[np.ndarray, np.ndarray]) -> set[frozenset[tuple[int, int]]]:
    return {frozenset({(int(a[0]), int(a[1])), (int(b[0]), int(b[1]))})
            for a, b in zip(ends[0].tolist(), ends[1].tolist(), strict=True)}


@pytest.mark.parametrize("learners", [2, 3])
def test_the_case_graph_merges_every_robots_segments(tmp_path: Path, installed: Any,
                                                    learners: int) -> None:
    run = learned_together(tmp_path, "casegraph", learners)
    replay = replayed_graph(run["steps"])
    with SQLiteStore(run["path"], read_only=True) as store:
        shared = CaseGraph.load(the_map(), store, priced=False)
    assert structure(shared.ends(shared.edge_ids())) == structure(replay.ends(replay.edge_ids()))
    assert ({tuple(v) for v in shared.vertices().tolist()}
            == {tuple(v) for v in replay.vertices().tolist()})
    # every cell of every retained path lies on a stored segment
    for step in run["steps"]:
        if step["success"]:
            cells = without_loops(step["path"])
            assert shared.vertex_count and (
                (shared.owner[cells[:, 1], cells[:, 0]] >= 0)
                | (shared.vertex_at[cells[:, 1], cells[:, 0]] >= 0)).all()


@pytest.mark.parametrize("learners", [2, 3])
def test_path_cases_keep_every_robots_paths(tmp_path: Path, installed: Any,
                                            learners: int) -> None:
    run = learned_together(tmp_path, "pathcases", learners)
    with SQLiteStore(run["path"], read_only=True) as store:
        stored = {int(c.id): c.solution for c in store.cases("path")}
    # each path kept is the loop-free path of the step that added it
    for step in run["steps"]:
        for case_id in set(step["added"]) & set(stored):
            assert stored[case_id] == without_loops(step["path"]).tolist()
    assert stored, "no path was kept"
    # a path is kept only when no similar stored path is as cheap, and it replaces the similar
    # costlier ones: the paths kept are pairwise farther apart than the default threshold, 2
    # (symmetric Hausdorff, Euclidean) whoever drove them; a retain against a stale index breaks it
    paths = [np.array(p, dtype=np.int64) for p in stored.values()]
    for i, path in enumerate(paths):
        others = paths[:i] + paths[i + 1:]
        if others:
            offsets = np.cumsum([0, *map(len, others)])
            forward, backward = hausdorff(path, np.concatenate(others), offsets, limit=2.0)
            assert (np.maximum(forward, backward) > 2.0).all()


def replayed_risks(steps: list[dict[str, Any]]) -> dict[str, float]:
    """The learned risks of one robot making every trip's risk changes in commit order."""
    configured = the_map()
    grid = configured
    for step in steps:
        report = SimpleNamespace(driven=np.array(step["report"]["driven"], dtype=np.int64),
                                 met=[tuple(c) for c in step["report"]["met"]])
        changes = risk_changes(grid, report, RISK["hit_risk"], RISK["pass_relief"])
        risk = grid.risk.copy()
        for x, y, value in changes:
            risk[y, x] = value
        grid = attrs.evolve(grid, risk=risk)
    differ = np.argwhere(grid.risk != configured.risk)
    return {f"{x},{y}": float(grid.risk[y, x]) for y, x in differ.tolist()}


@pytest.mark.parametrize("learners", [2, 3])
def test_the_risk_map_loses_no_robots_update(tmp_path: Path, installed: Any,
                                             learners: int) -> None:
    run = learned_together(tmp_path, "riskmap", learners)
    with SQLiteStore(run["path"], read_only=True) as store:
        learned = store.get_meta(LEARNED_RISK)
    assert learned == pytest.approx(replayed_risks(run["steps"]))
    assert learned, "no risk was learned"


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_a_learner_killed_inside_a_step_leaves_the_others_and_the_store_sound(
        tmp_path: Path, installed: Any, family: str) -> None:
    run = run_learners(tmp_path, family, 3, pause=4)
    assert run["codes"][0] == -signal.SIGKILL
    assert run["codes"][1:] == [0, 0]
    killed = [step for step in run["steps"] if step["seed"] == 1]
    assert len(killed) == 4  # the steps it committed before the one it died in
    assert len(run["steps"]) == 4 + 2 * STEPS
    assert_consistent(run)
    with SQLiteStore(run["path"], read_only=True) as store:
        assert store.count(SENTINEL) == 0
        assert store.get_meta(SENTINEL) is None
