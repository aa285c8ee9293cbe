"""The case graph planner on the Moving AI maps the repository ships: how often CBR answers,
how good, how fast.

Per map, the A* paths of the first half of the scenario file's problems are retained in an
empty case graph (``CaseGraph.add_path``, similar segments skipped as in the experiments); the
second half is then planned by CBR with the default settings (delta 10, full adaptation,
Dijkstra connector, A* in the graph). A CBR path passes the quality test (step 7) when its
length is at most 1.5 times the ideal length: the octile distance (the papers' test, the
reviser's default), or the landmark bound of ``cbr_pathquality.ideal.Landmarks`` (a lower bound
that knows the map's walls); the share each test accepts is reported, and the hybrid's figures
use the octile test. When CBR fails or its path is rejected, A* plans the query, as the hybrid
planner does. Scenario files list problems by bucket, i.e. by growing length, so the retained
half holds the shorter paths and the planned half the longer ones.

Reported per map: the CBR share under each test; how tight each lower bound is (bound / optimal
length: the median, and for the landmarks also the tenth percentile); the deviation of path
length from the scenario's optimal length (mean, median and largest) over the accepted CBR paths
and (mean, median) over all hybrid answers; and the speed, as the median over queries of CBR
time / A* time on the same query (for the queries CBR answered) and of the hybrid's time / A*
time over all queries, for two hybrids: the papers' one, which always tries CBR first (its
attempt plus any fallback) and tests against the octile distance, and the "decided" one, which
first decides per query whether CBR can pay off (``cbr_casegraph.payoff``, the ``casegraph``
retriever's ``min_cells`` and ``min_distance`` at the measured values ``payoff.MEASURED``),
leaves the query to A* when not, and tests CBR's path against the landmark bound (its share,
deviation and time / A*). Every time is
one run, after a warm-up query, CBR and A* interleaved query by query; the machine may be
shared, so medians and ratios are the figures to trust.

    python benchmarks/casegraph_movingai.py [--limit N] [--data DIR] [--out benchmarks/results]

``--limit`` keeps only every k-th problem so that at most N remain per map. Writes
``casegraph_movingai.json`` and ``casegraph_movingai.md``.

The protocol's pieces (``PAIRS``, ``DATA``, :func:`load_problems`, :func:`retain_half`,
:func:`astar_solver`) are shared by the other benchmarks on these maps.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import attrs
import numpy as np
from docfigures.provenance import write_results

from cbr_casegraph.experiments.common import MAX_RATIO, accepted
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.payoff import MEASURED, Payoff
from cbr_casegraph.planner import Plan, Settings, plan
from cbr_grid.costs import path_length
from cbr_grid.distances import octile
from cbr_grid.grid import Grid
from cbr_grid.movingai import Scenario, load_map, load_scen
from cbr_pathquality.ideal import Landmarks
from cbr_solvers.search import SearchResult, astar

DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "movingai"

PAIRS = (
    ("maps/dao/arena.map", "scenarios/dao/arena.map.scen"),
    ("maps/dao/den312d.map", "scenarios/dao/den312d.map.scen"),
    ("maps/dao/den520d.map", "scenarios/dao/den520d.map.scen"),
    ("maps/dao/brc202d.map", "scenarios/dao/brc202d.map.scen"),
    ("maps/bg512/AR0011SR.map", "scenarios/bg512/AR0011SR.map.scen"),
    ("maps/cities/Berlin_1_256.map", "scenarios/cities/Berlin_1_256.map.scen"),
    ("maps/mazes/maze512-1-0.map", "scenarios/mazes/maze512-1-0.map.scen"),
    ("maps/random/random512-10-0.map", "scenarios/random/random512-10-0.map.scen"),
    ("maps/rooms/8room_000.map", "scenarios/rooms/8room_000.map.scen"),
    ("maps/mapf/random-32-32-20.map", "scenarios/mapf/random-32-32-20-random-1.scen"),
    ("maps/mapf/empty-32-32.map", "scenarios/mapf/empty-32-32-random-1.scen"),
    ("maps/mapf/room-64-64-8.map", "scenarios/mapf/room-64-64-8-random-1.scen"),
    ("maps/mapf/maze-128-128-10.map", "scenarios/mapf/maze-128-128-10-random-1.scen"),
    ("maps/mapf/warehouse-10-20-10-2-1.map",
     "scenarios/mapf/warehouse-10-20-10-2-1-random-1.scen"),
)

LANDMARKS = 8
"""Landmarks of the landmark quality test (the reviser's default count)."""


def load_problems(map_path: Path, scen_path: Path, limit: int | None
                  ) -> tuple[Grid, list[Scenario]]:
    """The map and its scenario's problems, thinned to every k-th so at most ``limit`` remain."""
    grid = load_map(map_path)
    problems: list[Scenario] = load_scen(scen_path, grid)
    if limit is not None and len(problems) > limit:
        problems = problems[::-(-len(problems) // limit)]
    return grid, problems


def astar_solver(grid: Grid) -> Callable[[Scenario], SearchResult | None]:
    """A* on ``grid`` for one problem: the reference planner and the hybrid's fallback."""
    def solve(problem: Scenario) -> SearchResult | None:
        return astar(grid.factor, grid.passable, grid.corner_cutting, problem.start,
                     [problem.goal])
    return solve


def retain_half(grid: Grid, problems: list[Scenario]
                ) -> tuple[CaseGraph, list[Scenario], float]:
    """The case graph of the A* paths of the first half of the problems, the second half (to
    plan) and the seconds the retention took."""
    half = len(problems) // 2
    graph = CaseGraph(grid)
    solve = astar_solver(grid)
    began = time.perf_counter()
    for problem in problems[:half]:
        found = solve(problem)
        if found is not None:
            graph.add_path(found.path)
    return graph, problems[half:], time.perf_counter() - began


@attrs.frozen
class Query:
    """What one planned query measured: the times in seconds, the lengths and the verdicts."""

    cbr_s: float
    astar_s: float
    decide_s: float
    tried: bool
    planned: bool
    octile_ok: bool
    landmark_ok: bool
    cbr_length: float
    astar_length: float
    optimal: float
    octile: float
    landmark_bound: float


def retained_paths(graph: CaseGraph) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """Pairs of vertices of the graph more than delta apart, ends of stored edges first."""
    ids = graph.edge_ids()
    a, b = graph.ends(ids)
    far = np.abs(a - b).max(axis=1) > Settings().delta
    return [((int(p[0]), int(p[1])), (int(q[0]), int(q[1])))
            for p, q in zip(a[far], b[far], strict=True)]


def measure_map(grid: Grid, graph: CaseGraph, planned: list[Scenario], landmarks: Landmarks,
                payoff: Payoff) -> list[Query]:
    """Each planned problem by CBR, by the payoff decision and by A*, interleaved."""
    settings = Settings()
    solve = astar_solver(grid)
    cells = int(np.count_nonzero(grid.passable))
    # compile the searches and the planner's kernels before timing, with queries that reach
    # every kernel: the ends of retained paths lie on the graph
    for problem in planned[:3]:
        solve(problem)
    for path in retained_paths(graph)[:3]:
        plan(graph, path[0], path[1], settings)
    queries = []
    for problem in planned:
        t0 = time.perf_counter()
        result = plan(graph, problem.start, problem.goal, settings)
        t1 = time.perf_counter()
        reference = solve(problem)
        t2 = time.perf_counter()
        skip = payoff.reason(cells, problem.start, problem.goal)
        t3 = time.perf_counter()
        if reference is None or problem.optimal <= 0:
            continue
        ok = isinstance(result, Plan)
        length = path_length(result.path) if isinstance(result, Plan) else np.inf
        octile_ok = ok and accepted(result.path, problem.start, problem.goal)
        bound = landmarks.bound(problem.start, problem.goal)
        landmark_ok = ok and (bound == 0 or length / bound <= MAX_RATIO)
        queries.append(Query(t1 - t0, t2 - t1, t3 - t2, skip is None, ok, octile_ok,
                             landmark_ok, length, path_length(reference.path),
                             problem.optimal, float(octile(problem.start, problem.goal)),
                             bound))
    return queries


def _percent(values: list[float], how: str) -> float | None:
    if not values:
        return None
    pick = {"mean": np.mean, "median": np.median, "max": np.max}[how]
    return float(pick(values)) * 100


def _median(values: list[float]) -> float | None:
    return statistics.median(values) if values else None


def summary(queries: list[Query]) -> dict[str, Any]:
    """The per-map figures of the table from the measured queries."""
    cbr_dev = [q.cbr_length / q.optimal - 1 for q in queries if q.octile_ok]
    landmark_dev = [q.cbr_length / q.optimal - 1 for q in queries if q.landmark_ok]
    hybrid_dev = [(q.cbr_length if q.octile_ok else q.astar_length) / q.optimal - 1
                  for q in queries]
    # the fallback is the very A* run timed beside the attempt
    always = [(q.cbr_s if q.octile_ok else q.cbr_s + q.astar_s) / q.astar_s for q in queries]
    # the hybrid as configured for real maps: the per-query decision, then the landmark test
    decided = [(q.decide_s + (q.cbr_s if q.landmark_ok else q.cbr_s + q.astar_s)) / q.astar_s
               if q.tried else (q.decide_s + q.astar_s) / q.astar_s for q in queries]
    decided_dev = [(q.cbr_length if q.tried and q.landmark_ok else q.astar_length) / q.optimal
                   - 1 for q in queries]
    answered = [q for q in queries if q.octile_ok]
    count = len(queries)
    return {
        "queries": count,
        "cbr_share": len(cbr_dev) / count if count else None,
        "cbr_share_landmarks": len(landmark_dev) / count if count else None,
        "cbr_planned_share": sum(q.planned for q in queries) / count if count else None,
        "cbr_deviation_mean_pct": _percent(cbr_dev, "mean"),
        "cbr_deviation_median_pct": _percent(cbr_dev, "median"),
        "cbr_deviation_max_pct": _percent(cbr_dev, "max"),
        "landmark_deviation_mean_pct": _percent(landmark_dev, "mean"),
        "landmark_deviation_max_pct": _percent(landmark_dev, "max"),
        "hybrid_deviation_mean_pct": _percent(hybrid_dev, "mean"),
        "hybrid_deviation_median_pct": _percent(hybrid_dev, "median"),
        "cbr_ms_median": _median([q.cbr_s * 1000 for q in answered]),
        "cbr_ms_all_median": _median([q.cbr_s * 1000 for q in queries]),
        "astar_ms_median": _median([q.astar_s * 1000 for q in queries]),
        "cbr_over_astar_median": _median([q.cbr_s / q.astar_s for q in answered]),
        "hybrid_over_astar_median": _median(always),
        "decided_tried_share": sum(q.tried for q in queries) / count if count else None,
        "decided_share": (sum(q.tried and q.landmark_ok for q in queries) / count
                          if count else None),
        "decided_deviation_mean_pct": _percent(decided_dev, "mean"),
        "decided_deviation_max_pct": _percent(decided_dev, "max"),
        "decided_over_astar_median": _median(decided),
        "decided_over_astar_mean": float(np.mean(decided)) if decided else None,
        # how near each lower bound comes to the optimal length: bound / optimum
        "octile_tightness_median": _median([q.octile / q.optimal for q in queries]),
        "landmark_tightness_median": _median([q.landmark_bound / q.optimal for q in queries]),
        "landmark_tightness_p10": (float(np.percentile(
            [q.landmark_bound / q.optimal for q in queries], 10)) if queries else None),
    }


def run_map(map_path: Path, scen_path: Path, limit: int | None, payoff: Payoff,
            data: Path = DATA) -> dict[str, Any]:
    grid, problems = load_problems(map_path, scen_path, limit)
    graph, planned, build_s = retain_half(grid, problems)
    began = time.perf_counter()
    landmarks = Landmarks(grid, LANDMARKS)
    landmarks_s = time.perf_counter() - began
    queries = measure_map(grid, graph, planned, landmarks, payoff)
    return {"map": map_path.relative_to(data).as_posix(), "size": f"{grid.width}x{grid.height}",
            "retained_paths": len(problems) - len(planned), "vertices": graph.vertex_count,
            "edges": graph.edge_count, "coverage": graph.coverage(), "build_s": build_s,
            "landmarks_s": landmarks_s, **summary(queries)}


def _fmt(value: float | None, digits: int = 2) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def table(rows: list[dict[str, Any]]) -> list[str]:
    """The markdown table of the per-map rows (a "bound held" column when the rows have it)."""
    held = any("bound_held" in row for row in rows)
    lines = ["| map | size | retained | vertices (coverage) | queries | CBR share (octile) "
             "| CBR share (landmarks) | bound / optimum: octile, landmarks (10th pct) "
             "| CBR dev. mean / median / max % "
             "| hybrid dev. mean / median % | CBR ms | A* ms | CBR / A* | hybrid / A* "
             "| decided hybrid: share, dev. mean / max %, time / A* (tried) |"
             + (" bound held |" if held else ""),
             "|---" * (15 + held) + "|"]
    for row in rows:
        bound = (" yes |" if row.get("bound_held") else " no |") if held else ""
        lines.append(
            f"| {row['map']} | {row['size']} | {row['retained_paths']} "
            f"| {row['vertices']} ({row['coverage'] * 100:.1f}%) | {row['queries']} "
            f"| {_fmt(row['cbr_share'], 3)} | {_fmt(row['cbr_share_landmarks'], 3)} "
            f"| {_fmt(row['octile_tightness_median'])}, "
            f"{_fmt(row['landmark_tightness_median'])} "
            f"({_fmt(row['landmark_tightness_p10'])}) "
            f"| {_fmt(row['cbr_deviation_mean_pct'])} / {_fmt(row['cbr_deviation_median_pct'])}"
            f" / {_fmt(row['cbr_deviation_max_pct'])} "
            f"| {_fmt(row['hybrid_deviation_mean_pct'])} / "
            f"{_fmt(row['hybrid_deviation_median_pct'])} "
            f"| {_fmt(row['cbr_ms_median'], 3)} | {_fmt(row['astar_ms_median'], 3)} "
            f"| {_fmt(row['cbr_over_astar_median'], 3)} "
            f"| {_fmt(row['hybrid_over_astar_median'], 3)} "
            f"| {_fmt(row['decided_share'], 3)}, {_fmt(row['decided_deviation_mean_pct'])} / "
            f"{_fmt(row['decided_deviation_max_pct'])}, "
            f"{_fmt(row['decided_over_astar_median'], 3)} "
            f"({_fmt(row['decided_tried_share'], 2)}) |" + bound)
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--limit", type=int, default=None)
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    payoff = MEASURED
    rows = []
    for map_name, scen_name in PAIRS:
        row = run_map(args.data / map_name, args.data / scen_name, args.limit, payoff,
                      args.data)
        rows.append(row)
        print(f"{row['map']}: share {_fmt(row['cbr_share'], 3)} "
              f"(landmarks {_fmt(row['cbr_share_landmarks'], 3)}), "
              f"CBR/A* {_fmt(row['cbr_over_astar_median'], 3)}, "
              f"decided hybrid/A* {_fmt(row['decided_over_astar_median'], 3)}", flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    result = {"settings": {"delta": Settings().delta, "max_ratio": MAX_RATIO, "fallback": "astar",
                           "limit": args.limit, "landmarks": LANDMARKS,
                           "payoff": attrs.asdict(payoff), "decided_ideal": "landmarks"},
              "maps": rows}
    write_results(args.out / "casegraph_movingai.json", result)
    lines = table(rows)
    (args.out / "casegraph_movingai.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
