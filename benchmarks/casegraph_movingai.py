"""The case graph planner on the shared Moving AI maps: how often CBR answers, how good, how fast.

Per map, the A* paths of the first half of the scenario file's problems are retained in an
empty case graph (``CaseGraph.add_path``, similar segments skipped as in the experiments); the
second half is then planned by CBR with the default settings (delta 10, full adaptation,
Dijkstra connector, A* in the graph). A CBR path passes the quality test (step 7) when its
length is at most 1.5 times the octile distance; otherwise, or when CBR fails, A* plans it, as
the hybrid planner does. Scenario files list problems by bucket, i.e. by growing length, so the
retained half holds the shorter paths and the planned half the longer ones.

Reported per map: the CBR share; the deviation of path length from the scenario's optimal length
(mean and median) over the CBR paths and over all hybrid answers; and the speed, as the median
over queries of CBR time / A* time on the same query (for the queries CBR answered) and of the
hybrid's time (CBR attempt plus any fallback) / A* time over all queries. Every time is one run,
after a warm-up query; the machine is shared, so medians and ratios are the figures to trust.

    python benchmarks/casegraph_movingai.py [--limit N] [--data DIR] [--out benchmarks/results]

``--limit`` keeps only every k-th problem so that at most N remain per map. Writes
``casegraph_movingai.json`` and ``casegraph_movingai.md``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np

from cbr_casegraph.experiments.common import accepted
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.planner import Plan, Settings, plan
from cbr_grid.costs import path_length
from cbr_grid.movingai import Scenario, load_map, load_scen
from cbr_solvers.search import astar

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


def _percent(values: list[float], how: str) -> float | None:
    if not values:
        return None
    return float(np.mean(values) if how == "mean" else np.median(values)) * 100


def run_map(map_path: Path, scen_path: Path, limit: int | None) -> dict[str, Any]:
    grid = load_map(map_path)
    problems: list[Scenario] = load_scen(scen_path, grid)
    if limit is not None and len(problems) > limit:
        problems = problems[::-(-len(problems) // limit)]
    half = len(problems) // 2
    graph = CaseGraph(grid)
    settings = Settings()

    def solve(p: Scenario) -> Any:
        return astar(grid.factor, grid.passable, grid.corner_cutting, p.start, [p.goal])

    began = time.perf_counter()
    for problem in problems[:half]:
        found = solve(problem)
        if found is not None:
            graph.add_path(found.path)
    build_s = time.perf_counter() - began
    # compile the searches and the planner's kernels before timing
    plan(graph, problems[half].start, problems[half].goal, settings)
    solve(problems[half])

    cbr_dev: list[float] = []
    hybrid_dev: list[float] = []
    cbr_ratio: list[float] = []
    hybrid_ratio: list[float] = []
    cbr_ms: list[float] = []
    astar_ms: list[float] = []
    for problem in problems[half:]:
        t0 = time.perf_counter()
        result = plan(graph, problem.start, problem.goal, settings)
        t1 = time.perf_counter()
        reference = solve(problem)
        t2 = time.perf_counter()
        if reference is None or problem.optimal <= 0:
            continue
        a_star = t2 - t1
        astar_ms.append(a_star * 1000)
        if isinstance(result, Plan) and accepted(result.path, problem.start, problem.goal):
            length = path_length(result.path)
            cbr_dev.append(length / problem.optimal - 1)
            cbr_ratio.append((t1 - t0) / a_star)
            cbr_ms.append((t1 - t0) * 1000)
            hybrid_ratio.append((t1 - t0) / a_star)
        else:
            # the fallback is the very A* run just timed
            length = path_length(reference.path)
            hybrid_ratio.append((t1 - t0 + a_star) / a_star)
        hybrid_dev.append(length / problem.optimal - 1)
    planned = len(hybrid_dev)
    return {
        "map": map_path.relative_to(DATA).as_posix(), "size": f"{grid.width}x{grid.height}",
        "retained_paths": half, "vertices": graph.vertex_count, "edges": graph.edge_count,
        "coverage": graph.coverage(), "build_s": build_s, "queries": planned,
        "cbr_share": len(cbr_dev) / planned if planned else None,
        "cbr_deviation_mean_pct": _percent(cbr_dev, "mean"),
        "cbr_deviation_median_pct": _percent(cbr_dev, "median"),
        "hybrid_deviation_mean_pct": _percent(hybrid_dev, "mean"),
        "hybrid_deviation_median_pct": _percent(hybrid_dev, "median"),
        "cbr_ms_median": statistics.median(cbr_ms) if cbr_ms else None,
        "astar_ms_median": statistics.median(astar_ms) if astar_ms else None,
        "cbr_over_astar_median": statistics.median(cbr_ratio) if cbr_ratio else None,
        "hybrid_over_astar_median": statistics.median(hybrid_ratio) if hybrid_ratio else None,
    }


def _fmt(value: float | None, digits: int = 2) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--limit", type=int, default=None)
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    rows = []
    for map_name, scen_name in PAIRS:
        row = run_map(args.data / map_name, args.data / scen_name, args.limit)
        rows.append(row)
        print(f"{row['map']}: share {_fmt(row['cbr_share'], 3)}, "
              f"CBR/A* {_fmt(row['cbr_over_astar_median'], 3)}", flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    result = {"settings": {"delta": Settings().delta, "max_ratio": 1.5, "fallback": "astar",
                           "limit": args.limit}, "maps": rows}
    (args.out / "casegraph_movingai.json").write_text(json.dumps(result, indent=2) + "\n")
    lines = ["| map | size | retained | vertices (coverage) | queries | CBR share "
             "| CBR dev. mean / median % | hybrid dev. mean / median % | CBR ms | A* ms "
             "| CBR / A* | hybrid / A* |", "|---" * 12 + "|"]
    for row in rows:
        lines.append(
            f"| {row['map']} | {row['size']} | {row['retained_paths']} "
            f"| {row['vertices']} ({row['coverage'] * 100:.1f}%) | {row['queries']} "
            f"| {_fmt(row['cbr_share'], 3)} "
            f"| {_fmt(row['cbr_deviation_mean_pct'])} / {_fmt(row['cbr_deviation_median_pct'])} "
            f"| {_fmt(row['hybrid_deviation_mean_pct'])} / "
            f"{_fmt(row['hybrid_deviation_median_pct'])} "
            f"| {_fmt(row['cbr_ms_median'], 3)} | {_fmt(row['astar_ms_median'], 3)} "
            f"| {_fmt(row['cbr_over_astar_median'], 3)} "
            f"| {_fmt(row['hybrid_over_astar_median'], 3)} |")
    (args.out / "casegraph_movingai.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
