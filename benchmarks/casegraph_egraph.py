"""The experience-graph reuser against the 9-step planner on the Moving AI maps the
repository ships.

The protocol of ``benchmarks/casegraph_movingai.py``: per map, the A* paths of the first half of
the scenario file's problems are retained in an empty case graph; the second half is planned.
Each query is planned, interleaved in one process (the methods after A* in an order that
turns from query to query), by

- A*, the reference time (``cbr_solvers.search.astar``), and jump point search
  (``cbr_solvers.jps.jps``), the fastest exact solver on these uniform-cost maps;
- the 9-step planner (``cbr_casegraph.planner.plan``, default settings), its path accepted
  when its length is at most 1.5 times the octile distance;
- the experience-graph reuser for each (epsilon, eps_E) pair, behind the ``casegraph``
  retriever's gate (no case within delta of start or goal, or start and goal within delta of
  each other: the case graph is not used, as in the hybrid); its path is accepted on its
  guarantee when epsilon · eps_E <= 1.5, otherwise by the same octile test.

Reported per map and pooled, per method: the share of queries answered by an accepted path;
the mean and largest deviation of their cost from the optimum (A*'s cost on the query: the
scenario files round their optimal lengths, bg512's to two decimals, more than the bound's
check can bear; on these risk-free maps cost is length); the median
over those queries of the method's time / A*'s time and / jump point search's time (for the
experience graph also of the reuser's own time, the retriever's gate left out), and over all
queries of the hybrid's time (the attempt, plus A* when it gave no accepted path) / A*'s time;
for the experience graph, the largest ratio of any returned path's cost to the optimum and
whether it held the bound on every query.

    python benchmarks/casegraph_egraph.py [--limit N] [--data DIR] [--out benchmarks/results]

``--limit`` keeps only every k-th problem so that at most N remain per map. Writes
``casegraph_egraph.json`` and ``casegraph_egraph.md``.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from casegraph_movingai import DATA, PAIRS
from docfigures.provenance import write_results

from cbr_casegraph.experience import plan as experience_plan
from cbr_casegraph.experiments.common import MAX_RATIO, accepted
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.planner import Failure, Plan, Settings, neighbourhoods
from cbr_casegraph.planner import plan as nine_step_plan
from cbr_grid.costs import path_cost
from cbr_grid.movingai import Scenario, load_map, load_scen
from cbr_solvers.jps import jps
from cbr_solvers.search import astar

FACTOR_PAIRS = ((1.0, 1.0), (1.35, 1.1), (1.2, 1.25), (1.0, 1.5), (1.5, 1.0), (1.5, 2.0),
                (2.0, 5.0))
"""The (epsilon, eps_E) pairs measured: optimal, the defaults (bound 1.485), three other ways to
a bound of 1.5 (the experience or the inflation alone among them), and two looser bounds."""

NINE_STEP = "9-step"

Attempt = tuple[np.ndarray | None, bool, float | None]
"""A method's answer to a query: its path (None when it gave none), whether it is accepted, and
the seconds of the retriever's gate in its time (None for the 9-step planner, whose gate is a
part of its algorithm)."""


def _label(epsilon: float, experience: float) -> str:
    return f"egraph {epsilon:g}x{experience:g}"


class _Tally:
    """What one method did over a map's queries."""

    def __init__(self, bound: float | None) -> None:
        self.bound = bound
        self.deviations: list[float] = []
        self.ratios: list[float] = []
        self.jps_ratios: list[float] = []
        self.reuser_ratios: list[float] = []
        self.reuser_jps_ratios: list[float] = []
        self.gate_ratios: list[float] = []
        self.hybrid_ratios: list[float] = []
        self.worst = 0.0  # largest cost / optimum of any returned path
        self.queries = 0

    def add(self, cost: float | None, ok: bool, spent: float, gate: float | None,
            reference: float, fastest: float, optimal: float) -> None:
        self.queries += 1
        if cost is not None:
            self.worst = max(self.worst, cost / optimal)
        if ok and cost is not None:
            self.deviations.append(cost / optimal - 1)
            self.ratios.append(spent / reference)
            self.jps_ratios.append(spent / fastest)
            if gate is not None:
                self.reuser_ratios.append((spent - gate) / reference)
                self.reuser_jps_ratios.append((spent - gate) / fastest)
                self.gate_ratios.append(gate / reference)
            self.hybrid_ratios.append(spent / reference)
        else:
            self.hybrid_ratios.append((spent + reference) / reference)

    def merge(self, other: _Tally) -> None:
        self.deviations += other.deviations
        self.ratios += other.ratios
        self.jps_ratios += other.jps_ratios
        self.reuser_ratios += other.reuser_ratios
        self.reuser_jps_ratios += other.reuser_jps_ratios
        self.gate_ratios += other.gate_ratios
        self.hybrid_ratios += other.hybrid_ratios
        self.worst = max(self.worst, other.worst)
        self.queries += other.queries

    def row(self) -> dict[str, Any]:
        row: dict[str, Any] = {
            "queries": self.queries,
            "share": len(self.deviations) / self.queries if self.queries else None,
            "deviation_mean_pct": float(np.mean(self.deviations)) * 100
            if self.deviations else None,
            "deviation_max_pct": float(np.max(self.deviations)) * 100
            if self.deviations else None,
            "over_astar_median": statistics.median(self.ratios) if self.ratios else None,
            "over_jps_median": statistics.median(self.jps_ratios) if self.jps_ratios else None,
            "reuser_over_astar_median": statistics.median(self.reuser_ratios)
            if self.reuser_ratios else None,
            "reuser_over_jps_median": statistics.median(self.reuser_jps_ratios)
            if self.reuser_jps_ratios else None,
            "gate_over_astar_median": statistics.median(self.gate_ratios)
            if self.gate_ratios else None,
            "hybrid_over_astar_median": statistics.median(self.hybrid_ratios)
            if self.hybrid_ratios else None,
        }
        if self.bound is not None:
            # 1e-9: the float sums of one cost in two orders
            row.update(bound=self.bound, worst_ratio=self.worst,
                       bound_held=bool(self.worst <= self.bound * (1 + 1e-9)))
        return row


def run_map(map_path: Path, scen_path: Path, limit: int | None) -> tuple[dict[str, Any],
                                                                         dict[str, _Tally]]:
    grid = load_map(map_path)
    problems: list[Scenario] = load_scen(scen_path, grid)
    if limit is not None and len(problems) > limit:
        problems = problems[::-(-len(problems) // limit)]
    half = len(problems) // 2
    graph = CaseGraph(grid)
    settings = Settings()

    def reference(p: Scenario) -> Any:
        return astar(grid.factor, grid.passable, grid.corner_cutting, p.start, [p.goal])

    for problem in problems[:half]:
        found = reference(problem)
        if found is not None:
            graph.add_path(found.path)

    def fastest(p: Scenario) -> Any:
        return jps(grid.factor, grid.passable, grid.corner_cutting, p.start, [p.goal])

    def nine_step(p: Scenario) -> Attempt:
        result = nine_step_plan(graph, p.start, p.goal, settings)
        if not isinstance(result, Plan):
            return None, False, None
        return result.path, accepted(result.path, p.start, p.goal), None

    def experience(epsilon: float, factor: float) -> Callable[[Scenario], Attempt]:
        def run(p: Scenario) -> Attempt:
            t0 = time.perf_counter()
            if isinstance(neighbourhoods(graph, p.start, p.goal, settings), Failure):
                return None, False, None  # the retriever's gate: the fallback plans
            gate = time.perf_counter() - t0
            found = experience_plan(graph, p.start, p.goal, epsilon, factor)
            if found is None:
                return None, False, gate
            guaranteed = epsilon * factor <= MAX_RATIO
            return found.path, guaranteed or accepted(found.path, p.start, p.goal), gate
        return run

    methods: dict[str, Callable[[Scenario], Attempt]] = {
        NINE_STEP: nine_step,
        **{_label(e, f): experience(e, f) for e, f in FACTOR_PAIRS}}
    tallies = {NINE_STEP: _Tally(None),
               **{_label(e, f): _Tally(e * f) for e, f in FACTOR_PAIRS}}
    # compile every kernel before timing
    reference(problems[half])
    fastest(problems[half])
    for method in methods.values():
        method(problems[half])

    astar_ms: list[float] = []
    jps_ms: list[float] = []
    names = list(methods)
    for k, problem in enumerate(problems[half:]):
        t0 = time.perf_counter()
        found = reference(problem)
        spent_reference = time.perf_counter() - t0
        if found is None or found.cost <= 0:
            continue
        t0 = time.perf_counter()
        fastest(problem)
        spent_fastest = time.perf_counter() - t0
        astar_ms.append(spent_reference * 1000)
        jps_ms.append(spent_fastest * 1000)
        # a different method runs first on each query, so none always finds the caches A* left
        for name in names[k % len(names):] + names[:k % len(names)]:
            method = methods[name]
            t0 = time.perf_counter()
            path, ok, gate = method(problem)
            spent = time.perf_counter() - t0
            cost = None if path is None else path_cost(grid, path)
            tallies[name].add(cost, ok, spent, gate, spent_reference, spent_fastest, found.cost)
    row = {"map": map_path.relative_to(DATA).as_posix() if map_path.is_relative_to(DATA)
           else map_path.name, "size": f"{grid.width}x{grid.height}", "retained_paths": half,
           "vertices": graph.vertex_count, "queries": len(astar_ms),
           "astar_ms_median": statistics.median(astar_ms) if astar_ms else None,
           "jps_ms_median": statistics.median(jps_ms) if jps_ms else None,
           "methods": {name: tally.row() for name, tally in tallies.items()}}
    return row, tallies


def _fmt(value: float | None, digits: int = 2) -> str:
    # + 0.0 turns a rounding -0.0 into 0.0, so an exact method does not read "-0.00"
    return "n/a" if value is None else f"{round(value, digits) + 0.0:.{digits}f}"


def _table(methods: dict[str, dict[str, Any]]) -> list[str]:
    lines = ["| method | bound | share | dev. mean % | dev. max % | time / A* | time / JPS "
             "| reuser / A* | reuser / JPS | hybrid / A* | worst ratio | bound held |",
             "|---" * 12 + "|"]
    for name, m in methods.items():
        lines.append(
            f"| {name} | {_fmt(m.get('bound'))} | {_fmt(m['share'], 3)} "
            f"| {_fmt(m['deviation_mean_pct'])} | {_fmt(m['deviation_max_pct'])} "
            f"| {_fmt(m['over_astar_median'], 3)} | {_fmt(m['over_jps_median'], 3)} "
            f"| {_fmt(m['reuser_over_astar_median'], 3)} "
            f"| {_fmt(m['reuser_over_jps_median'], 3)} "
            f"| {_fmt(m['hybrid_over_astar_median'], 3)} "
            f"| {_fmt(m.get('worst_ratio'), 3)} "
            f"| {'n/a' if 'bound_held' not in m else ('yes' if m['bound_held'] else 'NO')} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--limit", type=int, default=None)
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    rows = []
    pooled: dict[str, _Tally] = {}
    for map_name, scen_name in PAIRS:
        row, tallies = run_map(args.data / map_name, args.data / scen_name, args.limit)
        rows.append(row)
        for name, tally in tallies.items():
            pooled.setdefault(name, _Tally(tally.bound)).merge(tally)
        summary = ", ".join(f"{name} {_fmt(m['share'], 2)}/{_fmt(m['over_astar_median'], 2)}"
                            for name, m in row["methods"].items())
        print(f"{row['map']}: share/time over A*: {summary}", flush=True)
    result = {"settings": {"delta": Settings().delta, "max_ratio": MAX_RATIO, "limit": args.limit,
                           "pairs": [list(pair) for pair in FACTOR_PAIRS]},
              "maps": rows, "pooled": {name: tally.row() for name, tally in pooled.items()}}
    args.out.mkdir(parents=True, exist_ok=True)
    write_results(args.out / "casegraph_egraph.json", result)
    lines = ["## All maps pooled", "", *_table(result["pooled"])]
    for row in rows:
        lines += ["", f"## {row['map']} ({row['size']}, {row['vertices']} vertices, "
                  f"{row['queries']} queries, A* median {_fmt(row['astar_ms_median'], 3)} ms, "
                  f"JPS median {_fmt(row['jps_ms_median'], 3)} ms)",
                  "", *_table(row["methods"])]
    (args.out / "casegraph_egraph.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
