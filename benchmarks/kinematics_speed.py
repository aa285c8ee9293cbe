"""The edge-based (nonholonomic) Dijkstra and A* of section 5 against the ordinary grid A*.

On a few of the Moving AI maps the repository ships, of different character (a small Dragon
Age arena, a MAPF room map, a MAPF maze of wide corridors, a larger Dragon Age map, a city, a
512x512 room map and a 512x512 maze of one-cell corridors), the scenario problems spread
evenly over each file's buckets are planned, side by side in one process, by the ordinary A*
(``cbr_solvers.search.astar``) and, for each kinematic model (``holonomic``, ``forward``,
``forward_backward``; :mod:`cbr_kinematics.models`), by the edge-based A* and Dijkstra
(:mod:`cbr_solvers.kinematic_search`), the robot starting in a random initial heading (seeded, the
same for every model; any final heading).

Per map and model the table gives the share of queries solved (and how many of the unsolved
ones start facing a wall: no legal step within 45 degrees of the initial heading), the median
over queries of the per-query time ratio edge-based / ordinary A*, the median expanded states
(cells for the ordinary A*, directed edges for the edge-based searches, over the solved
queries), how many solved queries the search had to exhaust (an edge into the goal the robot
cannot drive along: the paper's step 4 waits for every edge into the goal to be settled, so the
search only stops when nothing is left to settle), and the median and largest cost ratio to
the holonomic optimum (the scenario's optimal length). Checks, counted in the output: the
holonomic edge-based costs equal the ordinary optimum, the edge-based A* and Dijkstra agree (on
whether a path exists and its cost), no constrained cost undercuts the optimum, and the
ordinary A* agrees with the scenario file. Each call runs ``--repeats`` times and keeps its
median, or once when the first run takes longer than 0.1 s; the order of the calls rotates from
query to query. A pooled row per model takes the medians over the queries of every map.

    python benchmarks/kinematics_speed.py [--queries 30] [--repeats 3] [--seed 0]
                                          [--quick] [--data DIR] [--out benchmarks/results]

Writes ``kinematics_speed.json`` and ``kinematics_speed.md``. ``--quick`` is a smoke run of a
few seconds: the three smallest maps, 3 queries each, one run per call.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from docfigures.provenance import script_command, write_results

from cbr_grid.directions import STEPS
from cbr_grid.movingai import Scenario, load_map, load_scen
from cbr_kinematics.models import Forward, ForwardBackward, Holonomic, Kinematics
from cbr_solvers import kinematic_search
from cbr_solvers.search import astar

DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "movingai"

# (map, scenario file) under the data folder's maps/ and scenarios/, smallest first
MAPS = (
    ("dao/arena.map", "dao/arena.map.scen"),
    ("mapf/room-64-64-8.map", "mapf/room-64-64-8-random-1.scen"),
    ("mapf/maze-128-128-10.map", "mapf/maze-128-128-10-random-1.scen"),
    ("dao/den520d.map", "dao/den520d.map.scen"),
    ("cities/Berlin_1_256.map", "cities/Berlin_1_256.map.scen"),
    ("rooms/8room_000.map", "rooms/8room_000.map.scen"),
    ("mazes/maze512-1-0.map", "mazes/maze512-1-0.map.scen"),
)
QUICK_MAPS = 3
MODELS: dict[str, Kinematics] = {"holonomic": Holonomic(), "forward": Forward(),
                                 "forward_backward": ForwardBackward()}
LONG_S = 0.1
"""A call whose first run takes longer than this is not repeated."""
TOLERANCE = 1e-9

Cell = tuple[int, int]


def _timed(call: Callable[[], Any], repeats: int) -> tuple[Any, float]:
    """(result, median milliseconds) of ``repeats`` runs of ``call``, or of one when it is
    slower than :data:`LONG_S`."""
    began = time.perf_counter()
    result = call()
    runs = [time.perf_counter() - began]
    if runs[0] < LONG_S:
        for _ in range(repeats - 1):
            began = time.perf_counter()
            call()
            runs.append(time.perf_counter() - began)
    return result, statistics.median(runs) * 1e3


def entering_edges(passable: np.ndarray, goal: Cell) -> int:
    """How many grid steps lead into ``goal`` (8-connected, no corner cutting): the edges E(g)
    the paper's step 4 waits for."""
    h, w = passable.shape
    gx, gy = goal
    count = 0
    for dx, dy in STEPS.tolist():
        px, py = gx - dx, gy - dy
        if not (0 <= px < w and 0 <= py < h and passable[py, px]):
            continue
        if dx and dy and not (passable[py, gx] and passable[gy, px]):
            continue
        count += 1
    return count


def first_steps(passable: np.ndarray, start: Cell, heading: int) -> int:
    """How many legal first steps turn at most 45 degrees from ``heading``: with none, a robot
    that only turns that much (forward, and forward_backward, whose manoeuvres start with such
    a step) cannot leave the start."""
    h, w = passable.shape
    sx, sy = start
    count = 0
    for turn in (-1, 0, 1):
        dx, dy = STEPS[(heading + turn) % 8].tolist()
        nx, ny = sx + dx, sy + dy
        if not (0 <= nx < w and 0 <= ny < h and passable[ny, nx]):
            continue
        if dx and dy and not (passable[sy, nx] and passable[ny, sx]):
            continue
        count += 1
    return count


def _same(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=TOLERANCE, abs_tol=TOLERANCE)


def _queries(scenarios: list[Scenario], count: int) -> list[Scenario]:
    """``count`` scenarios spread evenly over the buckets (sorted by bucket)."""
    ordered = sorted(scenarios, key=lambda s: s.bucket)
    picks = np.unique(np.linspace(0, len(ordered) - 1, count).round().astype(int))
    return [ordered[i] for i in picks]


def bench_map(label: str, grid: Any, scenarios: list[Scenario], headings: list[int],
              repeats: int) -> dict[str, Any]:
    """Every query of one map through the ordinary A* and each model's edge-based searches."""
    factor, passable, cutting = grid.factor, grid.passable, grid.corner_cutting

    def ordinary(s: Scenario) -> Callable[[], Any]:
        return lambda: astar(factor, passable, cutting, s.start, [s.goal])

    def edge(s: Scenario, heading: int, model: str, informed: bool) -> Callable[[], Any]:
        return lambda: kinematic_search.kinematic_search(
            factor, passable, cutting, s.start, s.goal, kinematics=MODELS[model],
            heading=heading, informed=informed)

    calls = [("ordinary", None)] + [(f"{m} {kind}", (m, kind == "astar"))
                                    for m in MODELS for kind in ("astar", "dijkstra")]
    if scenarios:
        # one untimed run each first: numba cache loads and working arrays of this map's size
        for _, spec in calls:
            (ordinary(scenarios[0]) if spec is None else edge(scenarios[0], headings[0], *spec))()
    queries = []
    for number, (scenario, heading) in enumerate(zip(scenarios, headings, strict=True)):
        answers: dict[str, tuple[Any, float]] = {}
        for turn in range(len(calls)):
            # rotate the order so drift on a noisy machine hits every search alike
            name, spec = calls[(number + turn) % len(calls)]
            call = ordinary(scenario) if spec is None else edge(scenario, heading, *spec)
            answers[name] = _timed(call, repeats)
        best, best_ms = answers["ordinary"]
        query: dict[str, Any] = {
            "start": list(scenario.start), "goal": list(scenario.goal), "heading": heading,
            "bucket": scenario.bucket, "optimal": scenario.optimal,
            "scen_agrees": best is not None and scenario.agrees(best.cost),
            "ordinary": {"cost": None if best is None else best.cost,
                         "expanded": None if best is None else best.expanded, "ms": best_ms},
            "entering": entering_edges(passable, scenario.goal),
            "first_steps": first_steps(passable, scenario.start, heading)}
        for model in MODELS:
            found: dict[str, Any] = {}
            for kind in ("astar", "dijkstra"):
                result, ms = answers[f"{model} {kind}"]
                found[kind] = {
                    "cost": None if result is None else result.cost,
                    "expanded": None if result is None else result.expanded,
                    "settled_into_goal": None if result is None
                    else int(np.isfinite(result.arrivals).sum()),
                    "ms": ms, "over_ordinary": ms / best_ms}
            query[model] = found
        queries.append(query)
    return {"map": label, "size": f"{grid.width}x{grid.height}", "queries": queries}


def _median(values: list[float]) -> float | None:
    return statistics.median(values) if values else None


def summarise(label: str, queries: list[dict[str, Any]], model: str) -> dict[str, Any]:
    """One row of the table: ``model`` over ``queries`` (of one map or pooled)."""
    solved = [q for q in queries if q[model]["astar"]["cost"] is not None]
    ratios = [q[model]["astar"]["cost"] / q["optimal"] for q in solved if q["optimal"] > 0]
    blocked = sum(q["first_steps"] == 0 for q in queries
                  if q[model]["astar"]["cost"] is None) if model != "holonomic" else 0
    exhaustive = sum(q[model]["astar"]["settled_into_goal"] < q["entering"] for q in solved)
    agree = sum(1 for q in queries
                if (q[model]["astar"]["cost"] is None) != (q[model]["dijkstra"]["cost"] is None)
                or (q[model]["astar"]["cost"] is not None
                    and not _same(q[model]["astar"]["cost"], q[model]["dijkstra"]["cost"])))
    below = sum(1 for q in solved for kind in ("astar", "dijkstra")
                if q["ordinary"]["cost"] is not None
                and q[model][kind]["cost"] < q["ordinary"]["cost"] * (1 - TOLERANCE) - TOLERANCE)
    row: dict[str, Any] = {
        "map": label, "model": model, "queries": len(queries), "solved": len(solved),
        "blocked_start": blocked,
        "solved_share": len(solved) / len(queries) if queries else None,
        "astar_over_ordinary": _median([q[model]["astar"]["over_ordinary"] for q in queries]),
        "dijkstra_over_ordinary": _median(
            [q[model]["dijkstra"]["over_ordinary"] for q in queries]),
        "astar_over_ordinary_solved": _median(
            [q[model]["astar"]["over_ordinary"] for q in solved]),
        "ordinary_ms": _median([q["ordinary"]["ms"] for q in queries]),
        "astar_ms": _median([q[model]["astar"]["ms"] for q in queries]),
        "dijkstra_ms": _median([q[model]["dijkstra"]["ms"] for q in queries]),
        "ordinary_expanded": _median([q["ordinary"]["expanded"] for q in solved]),
        "astar_expanded": _median([q[model]["astar"]["expanded"] for q in solved]),
        "dijkstra_expanded": _median([q[model]["dijkstra"]["expanded"] for q in solved]),
        "exhaustive": exhaustive,
        "cost_ratio_median": _median(ratios), "cost_ratio_max": max(ratios, default=None),
        "mismatches": {"astar_vs_dijkstra": agree, "below_optimum": below,
                       "ordinary_vs_scen": sum(not q["scen_agrees"] for q in queries)}}
    if model == "holonomic":
        row["mismatches"]["holonomic_vs_ordinary"] = sum(
            1 for q in queries for kind in ("astar", "dijkstra")
            if (q[model][kind]["cost"] is None) != (q["ordinary"]["cost"] is None)
            or (q["ordinary"]["cost"] is not None
                and not _same(q[model][kind]["cost"], q["ordinary"]["cost"])))
    return row


def _cell(value: float | None, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def _count(value: float | None) -> str:
    return "-" if value is None else f"{value:.0f}"


def table(rows: list[dict[str, Any]]) -> str:
    lines = ["| map | model | solved | edge A* / A* | edge Dijkstra / A* | expanded A* "
             "| expanded edge A* | expanded edge Dijkstra | exhaustive | cost / optimum "
             "(median, max) | mismatches |", "|---" * 11 + "|"]
    for row in rows:
        bad = row["mismatches"]
        checks = f"A*≠Dijkstra {bad['astar_vs_dijkstra']}"
        if "holonomic_vs_ordinary" in bad:
            checks += f"; ≠ ordinary {bad['holonomic_vs_ordinary']}"
        if bad["below_optimum"]:
            checks += f"; below optimum {bad['below_optimum']}"
        if bad["ordinary_vs_scen"]:
            checks += f"; ordinary ≠ scen {bad['ordinary_vs_scen']}"
        lines.append(
            f"| {row['map']} | {row['model']} | {row['solved']}/{row['queries']}"
            + (f" ({row['blocked_start']} blocked)" if row["blocked_start"] else "") + " "
            f"| {_cell(row['astar_over_ordinary'])} | {_cell(row['dijkstra_over_ordinary'])} "
            f"| {_count(row['ordinary_expanded'])} | {_count(row['astar_expanded'])} "
            f"| {_count(row['dijkstra_expanded'])} | {row['exhaustive']}/{row['solved']} "
            f"| {_cell(row['cost_ratio_median'], 3)}, {_cell(row['cost_ratio_max'], 3)} "
            f"| {checks} |")
    return "\n".join(lines)


def totals(rows: list[dict[str, Any]]) -> dict[str, int]:
    """The mismatch counts summed over the per-map rows."""
    keys = ("astar_vs_dijkstra", "holonomic_vs_ordinary", "below_optimum")
    found = {key: sum(r["mismatches"].get(key, 0) for r in rows) for key in keys}
    found["ordinary_vs_scen"] = sum(r["mismatches"]["ordinary_vs_scen"] for r in rows
                                    if r["model"] == "holonomic")
    return found


NOTES = ("Ratios are medians over the queries of the per-query time ratio, edge-based search / "
         "ordinary A* (`cbr_solvers.search.astar`) on the same query, over all queries, solved "
         "or not (a search that fails early is cheap). Expanded states are medians over the "
         "solved queries: cells settled by the ordinary A*, directed edges settled by the "
         "edge-based searches. Exhaustive counts the solved queries on which the edge-based A* "
         "settled every edge it could reach, because an edge into the goal is never settled (the "
         "robot cannot drive along it) and the paper's step 4 waits for all of them. The cost "
         "ratio is the edge-based cost over the scenario's optimal (holonomic) length, over the "
         "solved queries. Mismatches: the edge-based A* and Dijkstra disagree on a cost or on "
         "whether a path exists; for holonomic, an edge-based cost differs from the ordinary "
         "optimum (both searches counted). Blocked: unsolved queries whose initial heading "
         "allows no first step (every step within 45 degrees of it leaves the grid, hits an "
         "obstacle or cuts a corner).")


def dumps(result: dict[str, Any]) -> str:
    """``result`` as JSON indented like the other benchmarks' files, but each query of
    ``result["maps"]`` on one line (there are hundreds)."""
    head = json.dumps({k: v for k, v in result.items() if k != "maps"}, indent=2)
    maps = ",\n".join(
        "    {" + f'"map": {json.dumps(m["map"])}, "size": {json.dumps(m["size"])}, "queries": ['
        + ",".join("\n      " + json.dumps(q) for q in m["queries"]) + "\n    ]}"
        for m in result["maps"])
    return head[:-2] + ',\n  "maps": [\n' + maps + "\n  ]\n}\n"


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--queries", type=int, default=30,
                        help="scenarios per map, spread over the buckets")
    parser.add_argument("--repeats", type=int, default=3,
                        help="timed runs per call (one when a run takes over 0.1 s)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the initial headings")
    parser.add_argument("--quick", action="store_true",
                        help="a smoke run: the three smallest maps, 3 queries, 1 run per call")
    parser.add_argument("--data", type=Path, default=DATA, help="the Moving AI data folder")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args(argv)
    maps = MAPS
    if args.quick:
        maps, args.queries, args.repeats = MAPS[:QUICK_MAPS], 3, 1
    began = time.perf_counter()

    # the first calls load the kernels from numba's disk cache, or compile them on a cold cache
    first_call: dict[str, float] = {}
    tiny = (np.ones((2, 2)), np.ones((2, 2), dtype=bool), False, (0, 0), (1, 1))
    started = time.perf_counter()
    astar(*tiny[:4], [tiny[4]])
    first_call["ordinary A*"] = time.perf_counter() - started
    started = time.perf_counter()
    kinematic_search.astar(*tiny, kinematics=MODELS["forward_backward"], heading=0)
    first_call["edge-based search"] = time.perf_counter() - started

    per_map = []
    rows = []
    for number, (map_file, scen_file) in enumerate(MAPS):
        if (map_file, scen_file) not in maps:
            continue
        grid = load_map(args.data / "maps" / map_file)
        scenarios = _queries(load_scen(args.data / "scenarios" / scen_file, grid), args.queries)
        # seeded by the map's place in MAPS, so --quick gives the full run's first headings
        headings = np.random.default_rng([args.seed, number]).integers(
            8, size=len(scenarios)).tolist()
        label = f"{Path(map_file).stem} {grid.width}x{grid.height}"
        measured = bench_map(label, grid, scenarios, headings, args.repeats)
        per_map.append(measured)
        rows += [summarise(label, measured["queries"], model) for model in MODELS]
        print(f"{label}: " + ", ".join(
            f"{r['model']} solved {r['solved']}/{r['queries']} "
            f"A*/A* {_cell(r['astar_over_ordinary'])}"
            for r in rows[-len(MODELS):]), flush=True)
    pooled = [summarise("all maps (pooled)", [q for m in per_map for q in m["queries"]], model)
              for model in MODELS]
    mismatches = totals(rows)
    elapsed = time.perf_counter() - began
    result = {"queries": args.queries, "repeats": args.repeats, "seed": args.seed,
              "quick": args.quick, "long_s": LONG_S, "first_call_s": first_call,
              "elapsed_s": elapsed, "mismatches": mismatches, "rows": rows, "pooled": pooled,
              "maps": per_map}
    args.out.mkdir(parents=True, exist_ok=True)
    write_results(args.out / "kinematics_speed.json", result, dumps=dumps,
                  command=script_command(__file__, argv))
    text = "\n\n".join([
        table(rows), "Pooled over the maps:", table(pooled), NOTES,
        "Mismatch totals: " + ", ".join(f"{k} {v}" for k, v in mismatches.items()) + ".",
        "One-time costs: first call (numba cache load or compile) "
        + ", ".join(f"{k} {v:.2f} s" for k, v in first_call.items())
        + f". Whole run {elapsed:.0f} s ({args.queries} queries per map, "
        f"{args.repeats} repeats, seed {args.seed})."])
    (args.out / "kinematics_speed.md").write_text(text + "\n")
    print(text)
    return result


if __name__ == "__main__":
    main()
