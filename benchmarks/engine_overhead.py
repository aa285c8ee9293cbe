"""What the engine costs per query beyond the work of its components.

Runs, side by side in one process, the same query sequence of the test domain of squares
(tests/toy_domain.py) twice: through ``Engine.solve`` and ``Engine.learn`` (hook dispatch, the
typed facade's timing and checks, the transaction around each learn step), and through direct
method calls on the very same component instances in the same order. The ratio of medians is the
engine's overhead; the difference of medians is the overhead per query in microseconds. It also
times the learn step alone on the in-memory store and on the SQLite store (one transaction per
step, durable against a killed process).

    python benchmarks/engine_overhead.py [--queries 2000] [--repeats 7] [--out benchmarks/results]

Writes ``engine_overhead.json`` and ``engine_overhead.md`` into the output folder.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import yaml

import cbr_observers
import cbr_stores
import cbrcore.builtins
from cbrcore.config import parse_config
from cbrcore.engine import Engine
from cbrcore.model import CASEBASE, Proposal
from cbrcore.plugins import load_plugins

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from docfigures.provenance import write_results

import toy_domain  # the test domain lives with the tests

PLUGINS = [("core", cbrcore.builtins), ("stores", cbr_stores), ("observers", cbr_observers),
           ("toy", toy_domain)]


def _engine(queries: int, store: dict[str, Any], out_dir: Path | None) -> Engine:
    data = yaml.safe_load(toy_domain.TOY_CONFIG)
    data["workload"]["count"] = queries
    data["workload"]["high"] = 200
    data["forget"] = [{"use": "capacity", "limit": 100}]
    data["casebase"] = store
    plugins = load_plugins(PLUGINS, entry_points=False)
    return Engine(parse_config(data, plugins.registry), plugins=plugins, out_dir=out_dir)


def _through_engine(engine: Engine) -> float:
    problems = list(engine.workload.queries(engine.ctx))
    started = time.perf_counter()
    for problem in problems:
        proposal = engine.solve(problem)
        engine.learn(problem, proposal, engine.workload.execute(problem, proposal, engine.ctx))
    return time.perf_counter() - started


def _learn_steps(engine: Engine) -> float:
    """Seconds spent in ``learn`` alone: the store's transaction around retain and forget."""
    spent = 0.0
    for problem in engine.workload.queries(engine.ctx):
        proposal = engine.solve(problem)
        outcome = engine.workload.execute(problem, proposal, engine.ctx)
        started = time.perf_counter()
        engine.learn(problem, proposal, outcome)
        spent += time.perf_counter() - started
    return spent


def _direct(engine: Engine) -> float:
    parts = {name.split(":")[0]: plugin for name, plugin in engine._pm.list_name_plugin()}
    retrieve, reuse, revise = parts["retrieve"], parts["reuse"], parts["revise"]
    solve, retain, forget = parts["solver"], parts["retain.0"], parts["forget.0"]
    store, ctx, workload = engine.casebase, engine.ctx, engine.workload
    problems = list(workload.queries(ctx))
    started = time.perf_counter()
    for problem in problems:
        solution = None
        retrieval = retrieve.cbr_retrieve(problem=problem, casebase=store)
        if retrieval.usable:
            solution = reuse.cbr_reuse(problem=problem, retrieval=retrieval)
            if not revise.cbr_revise(problem=problem, solution=solution).accepted:
                solution = None
        source = CASEBASE if solution is not None else "solver:compute"
        if solution is None:
            solution = solve.cbr_solve(problem=problem)
        proposal = Proposal(solution, source)
        outcome = workload.execute(problem, proposal, ctx)
        with store.transaction():
            if proposal.from_casebase:
                store.touch(solution.cases)
            retain.cbr_retain(problem=problem, solution=solution, outcome=outcome, casebase=store)
            forget.cbr_forget(casebase=store)
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--queries", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = parser.parse_args()
    samples: dict[str, list[float]] = {"engine": [], "direct": [], "learn_memory": [],
                                       "learn_sqlite": []}
    with tempfile.TemporaryDirectory() as tmp:
        for repeat in range(args.repeats):
            # alternate the order so drift on a noisy machine hits both sides alike
            order = ["engine", "direct"] if repeat % 2 == 0 else ["direct", "engine"]
            for side in order:
                with _engine(args.queries, {"use": "memory"}, None) as engine:
                    run = _through_engine if side == "engine" else _direct
                    samples[side].append(run(engine) / args.queries)
            with _engine(args.queries, {"use": "memory"}, None) as engine:
                samples["learn_memory"].append(_learn_steps(engine) / args.queries)
            store = {"use": "sqlite", "path": str(Path(tmp) / f"cb{repeat}.sqlite")}
            with _engine(args.queries, store, Path(tmp)) as engine:
                samples["learn_sqlite"].append(_learn_steps(engine) / args.queries)
    median = {side: statistics.median(values) * 1e6 for side, values in samples.items()}
    result = {
        "queries": args.queries,
        "repeats": args.repeats,
        "median_us_per_query": median,
        "engine_over_direct": median["engine"] / median["direct"],
        "engine_overhead_us": median["engine"] - median["direct"],
        "sqlite_learn_over_memory_learn": median["learn_sqlite"] / median["learn_memory"],
    }
    args.out.mkdir(parents=True, exist_ok=True)
    write_results(args.out / "engine_overhead.json", result)
    table = "\n".join([
        "| what is timed | median µs per query | ratio |",
        "|---|---|---|",
        f"| whole cycle, direct calls, memory store | {median['direct']:.1f} | 1.00 |",
        f"| whole cycle, engine, memory store | {median['engine']:.1f} | "
        f"{result['engine_over_direct']:.2f} |",
        f"| learn step, memory store | {median['learn_memory']:.1f} | 1.00 |",
        f"| learn step, SQLite store | {median['learn_sqlite']:.1f} | "
        f"{result['sqlite_learn_over_memory_learn']:.2f} |",
    ])
    (args.out / "engine_overhead.md").write_text(table + "\n")
    print(table)


if __name__ == "__main__":
    main()
