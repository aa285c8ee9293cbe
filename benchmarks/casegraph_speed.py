"""Case graph planning speed against the map size and against A*, with a 3000-vertex graph.

Targets: the median CBR planning time grows less than 2x from a 100x100 to a 1000x1000 map and
stays nearly constant up to 4000x4000 (less than 1.5x from 1000x1000), and on 600x600 and
1000x1000 maps CBR takes at most 1/20 of A*'s time on the same queries.

Maps are those of the reproductions (:func:`cbr_casegraph.experiments.common.make_map`: random
obstacles 15%, terrain risk 0.5). On each, a graph is grown to 3000 vertices from Dijkstra paths
of random tasks (:func:`cbr_casegraph.build.grow`), and the queries are set so that a CBR path
lies between them, as in section 6.3 of the paper (start and goal within delta / 2 of random
vertices, at least a third of the map side apart, CBR giving an accepted path;
:func:`cbr_casegraph.experiments.common.cbr_tasks`). Each query is timed ``--repeats`` times per
method and its median kept; the tables give medians over
queries and the median over queries of the per-query ratio CBR / A*, and, for scale, A*'s
median time on 20 tasks between random reachable cells. Where the planner's time goes on the
largest map: a cProfile of its CBR queries (the compiled query is one kernel call per step
group, so the profile mostly shows those calls) and the median time of each compiled piece
alone, in microseconds (``pieces_us``: the retrieval of the cases near start and goal, one
local sweep with its links, and the whole adaptation).

    python benchmarks/casegraph_speed.py [--sizes 100 600 1000] [--large] [--queries 100]
                                         [--repeats 3] [--out benchmarks/results]

``--large`` adds a 4000x4000 map (a minute or more to build and to time A* on).

Writes ``casegraph_speed.json`` and ``casegraph_speed.md``.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from docfigures.provenance import write_results

from cbr_casegraph.build import connected_cells, grow, random_task
from cbr_casegraph.experiments.common import cbr_tasks, make_map, region_mask, warm_up
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.planner import Failure, Settings, adapt, neighbourhoods, plan
from cbr_casegraph.query import local_links
from cbr_grid.distances import octile
from cbr_solvers.search import astar

VERTICES = 3000
SEED = 0
RANDOM_TASKS = 20
LARGE = 4000
"""The side of the map ``--large`` adds."""


def _median_time(call: Callable[[], Any], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        began = time.perf_counter()
        call()
        times.append(time.perf_counter() - began)
    return statistics.median(times)


def _profile(graph: CaseGraph, tasks: list[tuple[tuple[int, int], tuple[int, int]]],
             settings: Settings) -> str:
    profiler = cProfile.Profile()
    profiler.enable()
    for start, goal in tasks:
        plan(graph, start, goal, settings)
    profiler.disable()
    out = io.StringIO()
    pstats.Stats(profiler, stream=out).sort_stats("tottime").print_stats(12)
    return out.getvalue()


def _pieces(graph: CaseGraph, tasks: list[tuple[tuple[int, int], tuple[int, int]]],
            settings: Settings) -> dict[str, float]:
    """The median time of each compiled piece of a CBR query alone, in microseconds."""
    times: dict[str, list[float]] = {"cases_near": [], "local_links": [], "adapt": []}
    grid, tables = graph.grid, graph.tables()
    for start, goal in tasks:
        found = neighbourhoods(graph, start, goal, settings)
        if isinstance(found, Failure):
            continue
        times["cases_near"].append(_median_time(
            lambda s=start, g=goal: neighbourhoods(graph, s, g, settings), 3) / 2)
        times["local_links"].append(_median_time(
            lambda s=start, f=found: local_links(
                grid.factor, grid.passable, grid.corner_cutting, tables.a, tables.b,
                tables.adjacency.xy, f.start, s[0], s[1], settings.delta,
                settings.window_radius), 3))
        times["adapt"].append(_median_time(
            lambda s=start, g=goal, f=found: adapt(graph, s, g, f, settings), 3))
    return {name: statistics.median(values) * 1e6 for name, values in times.items() if values}


def run_size(side: int, queries: int, repeats: int) -> dict[str, Any]:
    rng = np.random.default_rng(SEED)
    grid = make_map(side, SEED)
    cells = connected_cells(grid, rng)
    warm_up(grid, cells, rng)
    graph = CaseGraph(grid)
    began = time.perf_counter()
    paths = grow(graph, VERTICES, rng, cells=cells)
    build_s = time.perf_counter() - began
    settings = Settings()
    tasks = cbr_tasks(graph, region_mask(grid, cells), rng, queries, settings, side / 3)
    cbr_s, astar_s = [], []
    for start, goal in tasks:
        cbr_s.append(_median_time(lambda s=start, g=goal: plan(graph, s, g, settings), repeats))
        astar_s.append(_median_time(
            lambda s=start, g=goal: astar(grid.factor, grid.passable, grid.corner_cutting, s,
                                          [g]), repeats))
    ratios = [c / a for c, a in zip(cbr_s, astar_s, strict=True)]
    # for scale: A* on tasks between random reachable cells, which CBR on a graph this sparse
    # rarely answers; they are longer than the tasks CBR answers
    random_s = []
    for _ in range(RANDOM_TASKS):
        start, goal = random_task(cells, rng)
        random_s.append(_median_time(
            lambda s=start, g=goal: astar(grid.factor, grid.passable, grid.corner_cutting, s,
                                          [g]), 1))
    return {"size": side, "vertices": graph.vertex_count, "edges": graph.edge_count,
            "paths": paths, "build_s": build_s, "queries": len(tasks),
            "octile_median": statistics.median(float(octile(s, g)) for s, g in tasks),
            "cbr_ms": statistics.median(cbr_s) * 1000,
            "astar_ms": statistics.median(astar_s) * 1000,
            "astar_random_ms": statistics.median(random_s) * 1000,
            "cbr_over_astar": statistics.median(ratios),
            "profile": _profile(graph, tasks, settings),
            "pieces_us": _pieces(graph, tasks, settings)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100, 600, 1000])
    parser.add_argument("--large", action="store_true", help="add a 4000x4000 map")
    parser.add_argument("--queries", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    rows = []
    for side in args.sizes + [LARGE] * (args.large and LARGE not in args.sizes):
        row = run_size(side, args.queries, args.repeats)
        rows.append(row)
        print(f"{side}x{side}: CBR {row['cbr_ms']:.3f} ms, A* {row['astar_ms']:.3f} ms, "
              f"CBR/A* {row['cbr_over_astar']:.3f}", flush=True)
    by_size = {row["size"]: row for row in rows}
    targets: dict[str, Any] = {}
    if 100 in by_size and 1000 in by_size:
        growth = by_size[1000]["cbr_ms"] / by_size[100]["cbr_ms"]
        targets["cbr_growth_100_to_1000"] = {"value": growth, "target": "< 2",
                                             "met": growth < 2}
    if 1000 in by_size and LARGE in by_size:
        growth = by_size[LARGE]["cbr_ms"] / by_size[1000]["cbr_ms"]
        targets[f"cbr_growth_1000_to_{LARGE}"] = {"value": growth, "target": "< 1.5",
                                                  "met": growth < 1.5}
    for side in (600, 1000):
        if side in by_size:
            ratio = by_size[side]["cbr_over_astar"]
            targets[f"cbr_over_astar_{side}"] = {"value": ratio, "target": "<= 0.05",
                                                 "met": ratio <= 0.05}
    args.out.mkdir(parents=True, exist_ok=True)
    result = {"vertices": VERTICES, "seed": SEED, "repeats": args.repeats,
              "settings": {"delta": Settings().delta, "selective": False}, "rows": rows,
              "targets": targets}
    write_results(args.out / "casegraph_speed.json", result)
    lines = ["| map | vertices | edges | paths retained | queries | median octile distance "
             "| CBR ms | A* ms | CBR / A* (median of per-query ratios) "
             "| A* ms, random tasks |", "|---" * 10 + "|"]
    for row in rows:
        lines.append(f"| {row['size']}x{row['size']} | {row['vertices']} | {row['edges']} "
                     f"| {row['paths']} | {row['queries']} | {row['octile_median']:.1f} "
                     f"| {row['cbr_ms']:.3f} | {row['astar_ms']:.3f} "
                     f"| {row['cbr_over_astar']:.3f} | {row['astar_random_ms']:.3f} |")
    lines += ["", "| target | measured | goal | met |", "|---|---|---|---|"]
    lines += [f"| {name} | {t['value']:.3f} | {t['target']} | {'yes' if t['met'] else 'no'} |"
              for name, t in targets.items()]
    (args.out / "casegraph_speed.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    print(rows[-1]["profile"])
    print("pieces (us):", rows[-1]["pieces_us"])


if __name__ == "__main__":
    main()
