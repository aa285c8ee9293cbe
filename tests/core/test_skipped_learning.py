"""A learner that finds the case base's write lock held past its store's ``busy_timeout`` (another
learner frozen inside its step) skips the learn step instead of ending its run: the step is kept,
retried before the next one and at the end of the run, and stored once the lock is free.

The lock is held by a connection of the test (``BEGIN IMMEDIATE``), as a frozen learner's open
transaction holds it. Expectations come from the toy domain (``toy_domain``): what a learner that
was never blocked stores when it learns the same decisions in the same order.
"""

from __future__ import annotations

import csv
import json
import sqlite3
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

import toy_domain
from cbr_stores.sqlite import SQLiteStore
from cbrcore import Engine, Outcome, Proposal, hookimpl
from cbrcore.context import Context
from cbrcore.plugins import Plugins
from cbrcore.registry import Registry
from cbrcore.run import run_workload
from cbrcore.testing import CliResult

Cli = Callable[..., CliResult]
COUNT = 12
CYCLE = {"seed": 3, "workload": {"use": "squares", "count": COUNT, "high": 8},
         "retrieve": {"use": "nearest", "radius": 1}, "reuse": "tangent",
         "revise": {"use": "tolerance", "tolerance": 0}, "solver": "compute",
         "retain": ["keep"]}


def _stored(path: Path, **options: Any) -> dict[str, Any]:
    # a short wait: the lock is held on purpose, and a skipped step is what is tested
    return {"use": "sqlite", "path": str(path), "busy_timeout": 0.01, **options}


@pytest.fixture
def plugins(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    return cbr_plugins(toy_domain, entry_points=True)


@pytest.fixture
def blocker(tmp_path: Path) -> Iterator[sqlite3.Connection]:
    """A connection to ``tmp_path/cb.sqlite``, which the test makes hold the write lock."""
    conn = sqlite3.connect(tmp_path / "cb.sqlite", isolation_level=None)
    yield conn
    conn.close()


def _contents(engine: Engine) -> list[tuple[Any, ...]]:
    assert engine.casebase is not None
    return [(c.id, c.problem, c.solution, c.uses) for c in engine.casebase.cases()]


class Lock:
    """Holds a store's write lock as a learner frozen inside its learn step does."""

    def __init__(self, request: pytest.FixtureRequest, tmp_path: Path, store: str) -> None:
        if store == "sqlite":
            self.casebase = _stored(tmp_path / "cb.sqlite")
            self._conn: Any = sqlite3.connect(tmp_path / "cb.sqlite", isolation_level=None)
            self._take = ["BEGIN IMMEDIATE"]
        else:
            psycopg = pytest.importorskip("psycopg")
            dsn = request.getfixturevalue("postgres_database")
            self.casebase = {"use": "postgres", "dsn": dsn, "busy_timeout": 0.01}
            self._conn = psycopg.connect(dsn, autocommit=True)
            # the store's own write lock: the clock row, locked by every writing transaction
            self._take = ["BEGIN", "SELECT revision FROM cbrcore.clock FOR UPDATE"]

    def take(self) -> None:
        for statement in self._take:
            self._conn.execute(statement)

    def release(self) -> None:
        self._conn.execute("ROLLBACK")

    def close(self) -> None:
        self._conn.close()


@pytest.mark.parametrize("store", ["sqlite", "postgres"])
def test_a_locked_step_is_skipped_kept_and_stored_once_the_lock_is_free(
        plugins: Plugins, tmp_path: Path, request: pytest.FixtureRequest, store: str) -> None:
    lock = Lock(request, tmp_path, store)
    request.addfinalizer(lock.close)
    engine = Engine.from_dict({**CYCLE, "casebase": lock.casebase}, plugins=plugins)
    decisions: list[tuple[int, Proposal, Outcome]] = []
    committed: list[int] = []
    assert engine.workload is not None
    queries = iter(engine.workload.queries(engine.ctx))

    def drive(steps: int) -> list[dict[str, float] | None]:
        returned = []
        for problem in [next(queries) for _ in range(steps)]:
            proposal = engine.solve(problem)
            outcome = engine.workload.execute(problem, proposal, engine.ctx)
            decisions.append((problem, proposal, outcome))
            returned.append(engine.learn(problem, proposal, outcome,
                                         then=lambda _, x=problem: committed.append(x)))
        return returned

    with engine:
        lock.take()
        assert drive(4) == [None] * 4
        assert (engine.stats.learn_skipped, engine.stats.learn_pending) == (4, 4)
        assert (committed, engine.stats.learned, engine.casebase.revision) == ([], 0, 0)
        # still locked: the skipped steps stay queued, in order, with nothing lost
        assert engine.retry_skipped() == 4

        lock.release()
        assert all(timings is not None for timings in drive(COUNT - 4))
        assert engine.retry_skipped() == 0
        assert (engine.stats.learn_skipped, engine.stats.learn_pending) == (4, 0)
        assert engine.stats.learned == COUNT
        assert committed == [problem for problem, _, _ in decisions]
        learned = _contents(engine)

    with Engine.from_dict({**CYCLE, "casebase": "memory"}, plugins=plugins) as unblocked:
        for problem, proposal, outcome in decisions:
            assert unblocked.learn(problem, proposal, outcome) is not None
        assert learned == _contents(unblocked)
    assert {x for x, _, outcome in decisions[:4] if outcome.success} <= {
        problem for _, problem, _, _ in learned}


class LockReleaser:
    """A plugin whose ``release_lock`` metric ends the blocker's transaction when the run
    measures its ``at``-th query (before that query's learn step)."""

    def __init__(self, blocker: sqlite3.Connection, at: int) -> None:
        self.blocker, self.at, self.measured = blocker, at, 0

    def measure(self, problem: Any, proposal: Proposal, outcome: Outcome,
                ctx: Context) -> dict[str, float]:
        self.measured += 1
        if self.measured == self.at:
            self.blocker.execute("ROLLBACK")
        return {}

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("metric", "release_lock", lambda options, ctx: self)


def test_a_run_records_skipped_steps_and_writes_their_rows_once_stored(
        cbr_plugins: Callable[..., Plugins], tmp_path: Path,
        blocker: sqlite3.Connection) -> None:
    releaser = LockReleaser(blocker, at=5)
    plugins = cbr_plugins(toy_domain, ("releaser", releaser), entry_points=True)
    config = {**CYCLE, "casebase": _stored(tmp_path / "cb.sqlite"),
              "metrics": ["release_lock"]}
    with Engine.from_dict(config, plugins=plugins) as engine:
        blocker.execute("BEGIN IMMEDIATE")
        summary = run_workload(engine, tmp_path / "run")

    # the first four steps waited out the lock; the fifth found it free and learned them all
    assert (summary["learn_skipped"], summary["learn_pending"]) == (4, 0)
    assert (summary["queries"], summary["learned"]) == (COUNT, COUNT)
    with (tmp_path / "run" / "results.csv").open(encoding="utf-8") as rows:
        assert [int(row["query"]) for row in csv.DictReader(rows)] == list(range(COUNT))


def test_a_run_that_never_gets_the_lock_ends_and_says_what_it_could_not_learn(
        invoke_cbr: Cli, plugins: Plugins, tmp_path: Path, blocker: sqlite3.Connection) -> None:
    config = tmp_path / "run.yaml"
    config.write_text(json.dumps({**CYCLE, "casebase": _stored(tmp_path / "cb.sqlite")}),
                      encoding="utf-8")
    SQLiteStore(tmp_path / "cb.sqlite").close()
    blocker.execute("BEGIN IMMEDIATE")

    result = invoke_cbr("run", str(config), "--out", str(tmp_path / "run"))

    assert result.exit_code == 0, result
    assert "learn steps skipped (locked)" in result.stdout
    summary = json.loads((tmp_path / "run" / "summary.json").read_text(encoding="utf-8"))
    assert (summary["learn_skipped"], summary["learn_pending"], summary["learned"]) == (
        COUNT, COUNT, 0)
    # no row for a step that was not learned: the rows and the case base agree
    assert (tmp_path / "run" / "results.csv").read_text(encoding="utf-8") == ""

