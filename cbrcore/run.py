"""Running a configured workload and writing its results.

A query workload is run by the default loop: each query is solved, executed and learned before
the next. A closed-loop workload runs its own loop on a :class:`~cbrcore.workload.Session`,
consulting the engine when its simulation needs a decision and learning each decision when its
outcome becomes known (:mod:`cbrcore.workload`). A run writes into its output folder:

``results.csv``
    One row per learned decision, in the order the outcomes became known (query order for the
    default loop), appended as the run goes (a killed run keeps the rows so far). A row is
    measured before its learn step and written once the step has committed, so the rows and
    the case base's learn steps agree when a metric, a phase or the step itself fails. A step
    skipped because another process held the case base's write lock too long
    (:meth:`~cbrcore.engine.Engine.learn`) has its row written when a retry commits it.
``summary.json``
    Where answers came from, the CBR share, success rate, phase timings and metric means.
``manifest.json``
    The configuration as resolved, the seed, and the versions of Python, cbrcore, its
    dependencies and every loaded plugin: what is needed to repeat the run.

The summary and the manifest are replaced whole or not at all (:mod:`cbrcore.files`). A run into
a folder that holds an earlier run's results continues them (:mod:`cbrcore.run_folder`): its rows
are appended to ``results.csv`` with query numbers following on, and the summary covers the latest
run, saying where it started.
"""

from __future__ import annotations

import contextlib
import csv
import datetime as dt
import json
import math
import platform
import re
import statistics
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

from cbrcore import files
from cbrcore.config import Config
from cbrcore.engine import Engine, output_folder
from cbrcore.errors import CbrError, ConfigError, PluginError
from cbrcore.hookspecs import PHASE_HOOKS
from cbrcore.model import CASEBASE, Outcome, Proposal
from cbrcore.plugins import Plugins
from cbrcore.run_folder import RESULTS, check_continuable, config_sha256, earlier_results
from cbrcore.workload import Decision, Session, Write

PHASES = (*PHASE_HOOKS, "learn")


def _dependencies() -> list[str]:
    """The distributions cbrcore requires (its extras left out), as its metadata names them."""
    try:
        required = metadata.requires("cbrcore") or []
    except metadata.PackageNotFoundError:
        return []
    return [re.match(r"[A-Za-z0-9_.-]+", line)[0] for line in required if "extra ==" not in line]


def manifest(config: Config | None, plugins: Plugins, *, seed: int,
             extra: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """What a run or an experiment needs recorded to be repeated.

    An option that may hold a secret is shown as its options class declares (a PostgreSQL
    DSN without its password), in the configuration and in the command line alike.
    """

    def version(name: str) -> str | None:
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            return None

    def shown(text: str) -> str:
        return config.masked(text) if config is not None else text

    return {
        "created": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "command": [shown(arg) for arg in (Path(sys.argv[0]).name, *sys.argv[1:])],
        "seed": seed,
        "python": platform.python_version(),
        "platform": platform.platform(),
        "cbrcore": version("cbrcore"),
        "packages": {name: version(name) for name in _dependencies()},
        "plugins": [{"name": p.name, "distribution": p.distribution, "version": p.version}
                    for p in plugins.loaded],
        "config_file": str(config.source) if config is not None and config.source else None,
        "config": config.resolved() if config is not None else None,
        "config_sha256": config_sha256(config) if config is not None else None,
        **(extra or {}),
    }


@contextlib.contextmanager
def writing(path: Path) -> Iterator[None]:
    """Turn an OSError while ``path`` is written (a full disk, a folder where the file goes)
    into a CbrError naming the file."""
    try:
        yield
    except OSError as exc:
        raise CbrError(f"{path}: cannot be written ({exc.strerror or exc})") from exc


def write_json(path: Path, data: Any) -> None:
    """Write ``data`` as indented JSON, replacing the file only once it is complete."""
    with writing(path):
        files.write_text(path, json.dumps(data, indent=2, default=str) + "\n")


def _milliseconds(timings: Mapping[str, float]) -> dict[str, float]:
    return {f"ms_{phase}": round(seconds * 1000, 4) for phase, seconds in timings.items()
            if phase in PHASES}


def _row(query: int, problem: Any, proposal: Proposal, outcome: Outcome, engine: Engine
         ) -> dict[str, Any]:
    """A decision's row before its learn step: the learn step's columns are left empty, to be
    filled in once it has committed."""
    matches = proposal.retrieval.matches if proposal.retrieval is not None else ()
    row: dict[str, Any] = {
        "query": query,
        **{f"q_{key}": value for key, value in engine.workload.describe(problem).items()},
        "source": proposal.source,
        "fallback_reason": proposal.fallback_reason or "",
        "retrieved": len(matches),
        "best_similarity": matches[0].similarity if matches else "",
        "solution_cost": proposal.solution.cost if proposal.solution is not None else "",
        "success": outcome.success,
        "outcome_cost": "" if outcome.cost is None else outcome.cost,
        **{f"ms_{phase}": "" for phase in PHASES},
        **_milliseconds(proposal.timings),
        **engine.measure(problem, proposal, outcome),
    }
    return row


def _numbers(rows: Sequence[Mapping[str, Any]], key: str) -> list[float]:
    return [float(r[key]) for r in rows if isinstance(r.get(key), int | float)
            and not isinstance(r.get(key), bool)]


PLANNING = ("retrieve", "reuse", "revise", "solve")
"""The phases whose time is the time to answer a query."""

WINDOWS = 10
"""How many consecutive stretches of queries the summary's ``evolution`` reports."""


def _metric_keys(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    builtin = {"query", "best_similarity", "solution_cost", "outcome_cost", "retrieved"}
    return [key for key in (rows[0] if rows else {})
            if key not in builtin and not key.startswith(("ms_", "q_"))
            and _numbers(rows, key)]


def evolution(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """How the run changed as it learned: per stretch of consecutive queries, the CBR share,
    the median planning time (retrieve to solve) and each metric's mean.

    Stretches follow the query index, not the order of the rows: a closed-loop workload learns
    its decisions in the order their outcomes became known, while the CBR share of a query
    depends on what had been learned when it was consulted.
    """
    rows = sorted(rows, key=lambda row: row["query"])
    stretches = min(WINDOWS, len(rows))
    keys = _metric_keys(rows)
    result = []
    for k in range(stretches):
        part = rows[k * len(rows) // stretches:(k + 1) * len(rows) // stretches]
        planning = [sum(float(r[f"ms_{p}"]) for p in PLANNING if r.get(f"ms_{p}") != "")
                    for r in part]
        entry: dict[str, Any] = {
            "first": part[0]["query"], "last": part[-1]["query"],
            "cbr_share": sum(r["source"] == CASEBASE for r in part) / len(part),
            "median_plan_ms": statistics.median(planning),
        }
        for key in keys:
            values = [v for v in _numbers(part, key) if math.isfinite(v)]
            entry[key] = statistics.fmean(values) if values else None
        result.append(entry)
    return result


def summarise(rows: Sequence[Mapping[str, Any]], engine: Engine, seconds: float
              ) -> dict[str, Any]:
    """The run's summary: counters, success rate, median phase times, metric means and how
    they evolved over the run."""
    summary: dict[str, Any] = {**engine.stats.as_dict(), "seconds": round(seconds, 3)}
    summary["success_rate"] = (sum(bool(r["success"]) for r in rows) / len(rows)) if rows else 0.0
    costs = _numbers(rows, "outcome_cost")
    summary["mean_outcome_cost"] = statistics.fmean(costs) if costs else None
    summary["median_ms"] = {
        phase: statistics.median(values) for phase in PHASES
        if (values := _numbers(rows, f"ms_{phase}"))
    }
    summary["metric_means"] = {
        key: statistics.fmean(values) for key in _metric_keys(rows)
        if (values := [v for v in _numbers(rows, key) if math.isfinite(v)])
    }
    summary["evolution"] = evolution(rows)
    return summary


def run_workload(engine: Engine, out_dir: Path, *, overrides: Sequence[str] = (),
                 progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Run the engine's workload, writing results, summary and manifest into ``out_dir``.

    A folder holding an earlier run of the same configuration is continued: the rows are
    appended to its ``results.csv``, numbered after the earlier ones. One whose manifest records
    another configuration is refused with a CbrError before anything is written
    (:func:`~cbrcore.run_folder.check_continuable`). ``progress(done, total)`` is called once
    before the first query and after each results row, ``total`` being ``len(workload)``.
    Returns the summary, which covers this run.
    """
    if engine.workload is None:
        raise ConfigError(str(engine.config.source or "configuration"),
                          ["workload: required to run; name the workload component that "
                           "produces the queries"])
    loop = _own_loop if _owns_its_loop(engine) else _default_loop
    output_folder(out_dir)
    check_continuable(out_dir, engine.config)
    earlier = earlier_results(out_dir)
    cases = len(engine.casebase) if engine.casebase is not None else 0
    write_json(out_dir / "manifest.json", manifest(
        engine.config, engine.plugins, seed=engine.config.seed,
        extra={"overrides": [engine.config.masked(text) for text in overrides]}))
    total = len(engine.workload)
    if progress is not None:
        progress(0, total)
    rows: list[dict[str, Any]] = []
    started = time.perf_counter()
    path = out_dir / RESULTS
    with writing(path):
        # appended row by row rather than replaced whole: a killed run keeps its rows, and a
        # run continuing the folder keeps the earlier runs'
        handle = path.open("a", newline="", encoding="utf-8")
    with handle:
        writer: csv.DictWriter[str] | None = None
        columns: list[str] = list(earlier.columns)

        def record(decision: Decision, outcome: Outcome) -> Write:
            row = _row(earlier.next_query + decision.index, decision.problem,
                       decision.proposal, outcome, engine)
            if not columns:
                columns.extend(row)
            elif row.keys() != set(columns):
                whose = ("the earlier runs' in results.csv" if earlier.columns
                         else "those of the first query")
                raise PluginError(f"query {decision.index}: the workload's describe() or a "
                                  f"metric gave columns {sorted(row)} instead of "
                                  f"{sorted(columns)}, {whose}")

            def write(learn_timings: Mapping[str, float]) -> None:
                nonlocal writer
                row.update(_milliseconds(learn_timings))
                with writing(path):
                    if writer is None:
                        writer = csv.DictWriter(handle, fieldnames=columns)
                        if not earlier.columns:
                            writer.writeheader()
                    writer.writerow(row)
                    handle.flush()
                rows.append(row)
                if progress is not None:
                    progress(len(rows), total)

            return write

        session = Session(engine, record=record)
        loop(engine, session)
        session.close()
        # learn steps skipped while another process held the case base's lock: their rows
        # are written as they commit; the summary counts any the lock still keeps out
        engine.retry_skipped()
    summary = {**summarise(rows, engine, time.perf_counter() - started),
               "first_query": earlier.next_query, "earlier_queries": earlier.rows,
               "cases_at_start": cases}
    write_json(out_dir / "summary.json", summary)
    return summary


def _owns_its_loop(engine: Engine) -> bool:
    """Whether the workload runs its own loop; a PluginError unless it has exactly one loop."""
    present = [method for method in ("run", "queries", "execute")
               if callable(getattr(engine.workload, method, None))]
    if present in (["run"], ["queries", "execute"]):
        return present == ["run"]
    has = ", ".join(f"{method}()" for method in present) or "none of run(), queries(), execute()"
    raise PluginError(f"workload {engine.config.workload.name!r} has {has}: a workload "
                      "implements either run(session), running its own loop, or queries(ctx) "
                      "and execute(problem, proposal, ctx)")


def _default_loop(engine: Engine, session: Session) -> None:
    for problem in engine.workload.queries(engine.ctx):
        decision = session.consult(problem)
        session.learn(decision, _execute(engine, problem, decision.proposal))


def _own_loop(engine: Engine, session: Session) -> None:
    try:
        engine.workload.run(session)
    except CbrError:
        raise
    except Exception as exc:
        raise PluginError(f"workload {engine.config.workload.name!r} failed in run() after "
                          f"{session.consulted} consultations: {type(exc).__name__}: {exc}"
                          ) from exc


def _execute(engine: Engine, problem: Any, proposal: Proposal) -> Outcome:
    try:
        outcome = engine.workload.execute(problem, proposal, engine.ctx)
    except CbrError:
        raise
    except Exception as exc:
        ref = engine.config.workload
        raise PluginError(f"workload {ref.name!r} failed to execute query {engine.ctx.step}: "
                          f"{type(exc).__name__}: {exc}") from exc
    if not isinstance(outcome, Outcome):
        raise PluginError(f"workload {engine.config.workload.name!r} returned "
                          f"{type(outcome).__name__} from execute(), expected Outcome")
    return outcome
