"""Our grid Dijkstra, A* and jump point search against other shortest-path libraries, query by
query.

Runs, side by side in one process, the same queries through ``cbr_solvers.search.astar`` and
``dijkstra``, our jump point search ``cbr_solvers.jps.jps``, and through pyastar2d (C++ grid
A*), tcod (``tcod.path.Pathfinder`` on a ``CustomGraph``), scipy's ``csgraph.dijkstra`` and
networkx's ``astar_path_length``. The maps are the Moving AI maps the repository ships
(scenarios sampled evenly over each file's buckets) and random square maps with about 20%
obstacles, queried between random free cells of one connected component.
Every answer is checked against our cost (and the Moving AI optimal length); per query each
solver's time is the median of its repeats, and the table shows medians over the queries of a
map and the ratios ours / other. The maps are given to our searches as read-only arrays, as a
``cbr_grid.grid.Grid`` gives them, so what they keep per grid is kept. Jump point search is
also run over every scenario of every Moving AI file (``--jps-limit`` caps it per file) against
the file's optimal length, and its target is checked: at most 1/3 of pyastar2d's median time
on the pooled 512x512 maps. One-time costs (loading or compiling our numba kernel, building
the scipy and networkx graphs) are reported apart. Libraries that are not installed are skipped
with a note (``pip install -e '.[bench]'`` installs them).

    python benchmarks/solvers.py [--limit 10] [--sizes 200 600 1000] [--queries 20]
                                 [--repeats 5] [--nx-queries 5] [--nx-max-cells 1000000]
                                 [--jps-limit N] [--quick] [--data DIR]
                                 [--out benchmarks/results]

Writes ``solvers.json`` and ``solvers.md`` into the output folder.

With ``--genetic`` it runs instead the genetic algorithm planner (``cbr_solvers.genetic``, a
stochastic solver that may miss the goal and is rarely optimal) on small random maps with about
20% obstacles, one map and one query per seed, and compares it with Dijkstra's optimal cost:
success rate, cost ratios and times per map size. It writes ``genetic.json`` and ``genetic.md``.

    python benchmarks/solvers.py --genetic [--ga-sizes 32 64] [--ga-queries 30]
                                 [--out benchmarks/results]
"""

from __future__ import annotations

import argparse
import importlib
import math
import statistics
import time
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
from docfigures.provenance import write_results

from cbr_grid.movingai import load_map, load_scen
from cbr_solvers.genetic import genetic
from cbr_solvers.jps import jps
from cbr_solvers.search import astar, dijkstra

DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "movingai"
SQRT2 = math.sqrt(2.0)
# tcod's graph costs are integers: a unit step costs ORTHO, a diagonal one DIAG (sqrt(2) rounded
# to five decimals), so its distances are exact for the movement rules up to that rounding.
ORTHO, DIAG = 100_000, 141_421
# One (dx, dy) of each pair of opposite steps; a step is legal both ways or neither.
FORWARD = ((1, 0), (0, 1), (1, 1), (-1, 1))
SOLVERS = ("astar", "dijkstra", "pyastar2d", "tcod", "scipy", "networkx", "jps")
JPS_TARGET = 1 / 3
"""The most jps may take of pyastar2d's median time on the pooled 512x512 maps."""

Cell = tuple[int, int]

RULES = ("\\* pyastar2d follows other movement rules: every step, diagonal or not, costs "
         "the weight of the cell entered (1 here), and a diagonal step may pass between two "
         "obstacles. It solves a different problem, so its time is not like for like; its "
         "mismatches column gives how many of its paths cut a corner and how their octile "
         "length compares with the optimum. tcod runs the exact movement rules with integer "
         "step costs 100000 and 141421. networkx is timed once per query on an evenly spread "
         "subset (the count in brackets), and its ratio is taken over that subset.")


def _optional(name: str, notes: list[str]) -> ModuleType | None:
    """The module ``name``, or None with a note when it is not installed."""
    try:
        return importlib.import_module(name)
    except ImportError:
        notes.append(f"{name} is not installed: skipped")
        return None


def _shift(a: np.ndarray, dx: int, dy: int) -> np.ndarray:
    """``out[y, x] = a[y + dy, x + dx]``, False beyond the edge."""
    h, w = a.shape
    out = np.zeros_like(a)
    out[max(0, -dy):h - max(0, dy), max(0, -dx):w - max(0, dx)] = \
        a[max(0, dy):h + min(0, dy), max(0, dx):w + min(0, dx)]
    return out


def legal_steps(passable: np.ndarray, dx: int, dy: int) -> np.ndarray:
    """Mask over cells (y, x) from which the step (dx, dy) is legal without corner cutting."""
    ok = passable & _shift(passable, dx, dy)
    if dx and dy:
        ok &= _shift(passable, dx, 0) & _shift(passable, 0, dy)
    return ok


def edges(passable: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every legal step once, as flat (source, target, length) arrays."""
    w = passable.shape[1]
    sources, targets, lengths = [], [], []
    for dx, dy in FORWARD:
        src = np.flatnonzero(legal_steps(passable, dx, dy))
        sources.append(src)
        targets.append(src + dy * w + dx)
        lengths.append(np.full(len(src), SQRT2 if dx and dy else 1.0))
    return np.concatenate(sources), np.concatenate(targets), np.concatenate(lengths)


def octile(a: Cell, b: Cell) -> float:
    """Octile distance between two (x, y) cells."""
    dx, dy = abs(a[0] - b[0]), abs(a[1] - b[1])
    return max(dx, dy) + (SQRT2 - 1.0) * min(dx, dy)


def path_length(path: np.ndarray) -> float:
    """Octile length of a path of (x, y) rows."""
    steps = np.abs(np.diff(path, axis=0))
    diagonal = (steps == 1).all(axis=1)
    return float(np.count_nonzero(diagonal) * SQRT2 + np.count_nonzero(~diagonal))


def corner_cuts(passable: np.ndarray, path: np.ndarray) -> int:
    """Number of diagonal steps of a path of (x, y) rows that pass a blocked cell beside them."""
    a, b = path[:-1], path[1:]
    diagonal = (np.abs(b - a) == 1).all(axis=1)
    a, b = a[diagonal], b[diagonal]
    return int(np.count_nonzero(~(passable[a[:, 1], b[:, 0]] & passable[b[:, 1], a[:, 0]])))


class Map:
    """One map prepared for every installed solver; preparation times go to ``setup``."""

    def __init__(self, label: str, passable: np.ndarray, libs: dict[str, ModuleType | None],
                 networkx: bool) -> None:
        self.label = label
        # read-only, as a Grid's: the searches keep what they derive from a grid that cannot change
        self.passable = np.array(passable, dtype=np.bool_)
        self.passable.setflags(write=False)
        self.factor = np.ones(passable.shape)
        self.factor.setflags(write=False)
        self.setup: dict[str, float] = {}
        h, w = passable.shape
        started = time.perf_counter()
        src, dst, length = edges(self.passable)
        self.setup["edges"] = time.perf_counter() - started
        if libs["pyastar2d"] is not None:
            # every move into a cell costs its weight; blocked cells are infinitely dear
            self.weights = np.where(self.passable, 1.0, np.inf).astype(np.float32)
        if libs["tcod"] is not None:
            started = time.perf_counter()
            self.tcod_graph = libs["tcod"].path.CustomGraph((h, w))
            cost = self.passable.astype(np.int8)
            for dx, dy in FORWARD:
                for sx, sy in ((dx, dy), (-dx, -dy)):
                    self.tcod_graph.add_edge((sy, sx), DIAG if dx and dy else ORTHO, cost=cost,
                                             condition=legal_steps(self.passable, sx, sy))
            self.tcod_graph.set_heuristic(cardinal=ORTHO, diagonal=DIAG)
            self.setup["tcod graph"] = time.perf_counter() - started
        if libs["scipy"] is not None:
            started = time.perf_counter()
            sparse = libs["scipy"].sparse
            self.csr = sparse.csr_matrix((np.concatenate((length, length)),
                                          (np.concatenate((src, dst)), np.concatenate((dst, src)))),
                                         shape=(h * w, h * w))
            self.setup["scipy graph"] = time.perf_counter() - started
        self.graph = None
        if libs["networkx"] is not None and networkx:
            started = time.perf_counter()
            graph = libs["networkx"].Graph()
            graph.add_nodes_from(np.flatnonzero(self.passable).tolist())
            graph.add_weighted_edges_from(zip(src.tolist(), dst.tolist(), length.tolist(),
                                              strict=True))
            self.graph = graph
            self.setup["networkx graph"] = time.perf_counter() - started

    def run(self, solver: str, libs: dict[str, Any], start: Cell, goal: Cell
            ) -> tuple[float, np.ndarray | None]:
        """One query: (cost, path of (x, y) rows or None when the solver gives none)."""
        w = self.passable.shape[1]
        if solver in ("astar", "dijkstra", "jps"):
            search = {"astar": astar, "dijkstra": dijkstra, "jps": jps}[solver]
            result = search(self.factor, self.passable, False, start, [goal])
            return (math.inf, None) if result is None else (result.cost, result.path)
        if solver == "pyastar2d":
            found = libs["pyastar2d"].astar_path(self.weights, start[::-1], goal[::-1],
                                                 allow_diagonal=True)
            if found is None:
                return math.inf, None
            path = np.asarray(found, dtype=np.int64)[:, ::-1]
            return path_length(path), path
        if solver == "tcod":
            finder = libs["tcod"].path.Pathfinder(self.tcod_graph)
            finder.add_root(start[::-1])
            found = finder.path_to(goal[::-1])
            if len(found) == 0 or tuple(found[-1]) != goal[::-1]:
                return math.inf, None
            path = np.asarray(found, dtype=np.int64)[:, ::-1]
            return path_length(path), path
        if solver == "scipy":
            distances = libs["scipy"].sparse.csgraph.dijkstra(self.csr,
                                                               indices=start[1] * w + start[0])
            return float(distances[goal[1] * w + goal[0]]), None
        nx = libs["networkx"]

        def heuristic(u: int, v: int) -> float:
            return octile(divmod(u, w)[::-1], divmod(v, w)[::-1])

        try:
            cost = nx.astar_path_length(self.graph, start[1] * w + start[0],
                                        goal[1] * w + goal[0], heuristic=heuristic)
        except nx.NetworkXNoPath:
            return math.inf, None
        return float(cost), None


def movingai_maps(data: Path, limit: int | None) -> list[tuple[str, np.ndarray, list[Any]]]:
    """(label, passable, scenarios) of each shared map, ``limit`` scenarios spread over buckets
    (every one when None)."""
    found = []
    for scen_path in sorted((data / "scenarios").glob("*/*.scen")):
        name = scen_path.name.removesuffix(".scen")
        if not name.endswith(".map"):
            name = name.rsplit("-random-", 1)[0] + ".map"  # the MAPF scenario naming
        grid = load_map(data / "maps" / scen_path.parent.name / name)
        scenarios = sorted(load_scen(scen_path, grid), key=lambda s: s.bucket)
        if limit is not None and limit < len(scenarios):
            picks = np.unique(np.linspace(0, len(scenarios) - 1, limit).round().astype(int))
            scenarios = [scenarios[i] for i in picks]
        found.append((f"{name.removesuffix('.map')} {grid.width}x{grid.height}", grid.passable,
                      scenarios))
    return found


def random_map(size: int, seed: int) -> np.ndarray:
    """A size x size passable mask with about 20% obstacles."""
    return np.random.default_rng(seed).random((size, size)) >= 0.2


def random_queries(passable: np.ndarray, count: int, seed: int) -> list[tuple[Cell, Cell]]:
    """``count`` pairs of free cells, each pair joined by a path (so in one component)."""
    rng = np.random.default_rng(seed)
    ys, xs = np.nonzero(passable)
    factor = np.ones(passable.shape)
    queries: list[tuple[Cell, Cell]] = []
    while len(queries) < count:
        i, j = rng.integers(len(xs), size=2)
        start, goal = (int(xs[i]), int(ys[i])), (int(xs[j]), int(ys[j]))
        if start != goal and dijkstra(factor, passable, False, start, [goal]) is not None:
            queries.append((start, goal))
    return queries


def bench_map(prepared: Map, queries: list[tuple[Cell, Cell, Any]], libs: dict[str, Any],
              repeats: int, nx_queries: int) -> dict[str, Any]:
    """Time every installed solver on the queries; medians, mismatches and path checks."""
    solvers = [s for s in SOLVERS if libs.get(s, True) is not None
               and (s != "networkx" or prepared.graph is not None)]
    # per solver one time per query, None where it was not run (networkx runs on a subset)
    times: dict[str, list[float | None]] = {s: [None] * len(queries) for s in solvers}
    nx_subset = set(np.linspace(0, len(queries) - 1, nx_queries).round().astype(int).tolist()
                    if queries and nx_queries > 0 else [])
    mismatches = dict.fromkeys(solvers, 0)
    longer = cuts = scen_mismatches = jps_scen_mismatches = 0
    excess: list[float] = []
    if queries:
        # one untimed run each first, so no solver pays first-touch costs in a timed run
        for solver in solvers:
            prepared.run(solver, libs, queries[0][0], queries[0][1])
    for number, (start, goal, scenario) in enumerate(queries):
        costs: dict[str, float] = {}
        for turn in range(len(solvers)):
            # rotate the order so drift on a noisy machine hits every solver alike
            solver = solvers[(number + turn) % len(solvers)]
            if solver == "networkx" and number not in nx_subset:
                continue
            runs = []
            for _ in range(1 if solver == "networkx" else repeats):
                started = time.perf_counter()
                cost, path = prepared.run(solver, libs, start, goal)
                runs.append(time.perf_counter() - started)
            times[solver][number] = statistics.median(runs) * 1e3
            costs[solver] = cost
            if solver == "pyastar2d" and path is not None:
                cuts += corner_cuts(prepared.passable, path) > 0
        best = costs["astar"]
        if scenario is not None and not scenario.agrees(best):
            scen_mismatches += 1
        if scenario is not None and "jps" in costs and not scenario.agrees(costs["jps"]):
            jps_scen_mismatches += 1
        for solver, cost in costs.items():
            if solver == "pyastar2d":
                # other movement rules: compare the octile length of its path with the optimum
                if cost > best * (1 + 1e-9) + 1e-9:
                    longer += 1
                excess.append(cost / best - 1 if best > 0 else 0.0)
            elif not math.isclose(cost, best, rel_tol=1e-9, abs_tol=1e-9):
                mismatches[solver] += 1
    return {
        "map": prepared.label,
        "queries": len(queries),
        "networkx_queries": sum(t is not None for t in times.get("networkx", [])),
        "median_ms": _medians(times),
        "samples_ms": times,
        "setup_s": prepared.setup,
        "mismatches": mismatches,
        "scen_mismatches": scen_mismatches if queries and queries[0][2] is not None else None,
        "jps_scen_mismatches": (jps_scen_mismatches if "jps" in solvers and queries
                                and queries[0][2] is not None else None),
        "pyastar2d": {"longer_than_optimal": longer, "cutting_corners": cuts,
                      "min_excess": min(excess) if excess else None,
                      "max_excess": max(excess) if excess else None},
    }


def jps_scenarios(data: Path, limit: int | None) -> list[dict[str, Any]]:
    """Jump point search over the scenarios of every Moving AI file (``limit`` spread over each,
    every one when None), one run each: how many miss the file's optimal length, and the times."""
    rows = []
    for label, passable, scenarios in movingai_maps(data, limit):
        passable = np.array(passable, dtype=np.bool_)
        passable.setflags(write=False)
        factor = np.ones(passable.shape)
        factor.setflags(write=False)
        jps(factor, passable, False, scenarios[0].start, [scenarios[0].goal])
        times, wrong = [], []
        for scenario in scenarios:
            started = time.perf_counter()
            found = jps(factor, passable, False, scenario.start, [scenario.goal])
            times.append((time.perf_counter() - started) * 1e3)
            if found is None or found.search != "jps" or not scenario.agrees(found.cost):
                wrong.append(scenario.line)
        rows.append({"map": label, "scenarios": len(scenarios), "mismatches": len(wrong),
                     "mismatched_lines": wrong[:20], "median_ms": statistics.median(times),
                     "max_ms": max(times)})
        print(f"{label}: jps over {len(scenarios)} scenarios, {len(wrong)} mismatches",
              flush=True)
    return rows


def jps_scenarios_table(rows: list[dict[str, Any]]) -> str:
    lines = ["| map | scenarios | jps mismatches | jps median ms | jps max ms |",
             "|---|---|---|---|---|"]
    for row in rows:
        lines.append(f"| {row['map']} | {row['scenarios']} | {row['mismatches']} | "
                     f"{row['median_ms']:.3f} | {row['max_ms']:.2f} |")
    return "\n".join(lines)


def _medians(samples: dict[str, list[float | None]]) -> dict[str, float]:
    """Median per solver over the queries it ran."""
    return {s: statistics.median(v) for s, values in samples.items()
            if (v := [t for t in values if t is not None])}


def _ratio(samples: dict[str, list[float | None]], ours: str, other: str) -> float | None:
    """Median of ``ours`` over median of ``other``, both over the queries both ran."""
    if ours not in samples or other not in samples:
        return None
    pairs = [(a, b) for a, b in zip(samples[ours], samples[other], strict=True)
             if a is not None and b is not None]
    if not pairs:
        return None
    return statistics.median(a for a, _ in pairs) / statistics.median(b for _, b in pairs)


def _cell(value: float | None, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def pooled(rows: list[dict[str, Any]], label: str) -> dict[str, Any]:
    """A row over all queries of ``rows``: medians of the pooled per-query times."""
    samples: dict[str, list[float | None]] = {}
    for row in rows:
        for solver in SOLVERS:
            values = row["samples_ms"].get(solver, [None] * row["queries"])
            samples.setdefault(solver, []).extend(values)
    return {"map": label, "queries": sum(r["queries"] for r in rows),
            "networkx_queries": sum(r["networkx_queries"] for r in rows),
            "median_ms": _medians(samples), "samples_ms": samples}


def table(rows: list[dict[str, Any]]) -> str:
    lines = [
        "| map | queries (nx) | A* ms | Dijkstra ms | pyastar2d ms* | tcod ms | scipy ms | "
        "networkx ms | jps ms | A*/pyastar2d* | A*/tcod | A*/networkx | Dijkstra/scipy | "
        "jps/pyastar2d* | jps/A* | mismatches |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        median = row["median_ms"]
        checks = ""
        if "mismatches" in row:
            bad = {s: n for s, n in row["mismatches"].items() if n}
            checks = ", ".join(f"{s} {n}" for s, n in bad.items()) or "0"
            if row["scen_mismatches"] is not None:
                checks += f"; vs scen {row['scen_mismatches']}"
            if row.get("jps_scen_mismatches") is not None:
                checks += f"; jps vs scen {row['jps_scen_mismatches']}"
            pya = row["pyastar2d"]
            if pya["max_excess"] is not None:
                checks += (f"; pyastar2d* cuts corners {pya['cutting_corners']}, longer "
                           f"{pya['longer_than_optimal']}, length {100 * pya['min_excess']:+.1f}"
                           f"..{100 * pya['max_excess']:+.1f}%")
        lines.append(
            f"| {row['map']} | {row['queries']} ({row['networkx_queries']}) | "
            + " | ".join(_cell(median.get(s)) for s in SOLVERS) + " | "
            + " | ".join(_cell(_ratio(row["samples_ms"], ours, other)) for ours, other in (
                ("astar", "pyastar2d"), ("astar", "tcod"), ("astar", "networkx"),
                ("dijkstra", "scipy"), ("jps", "pyastar2d"), ("jps", "astar")))
            + f" | {checks} |")
    return "\n".join(lines)


def bench_genetic(size: int, count: int) -> dict[str, Any]:
    """The genetic planner with its default options on ``count`` random size x size maps."""
    factor = np.ones((size, size))
    ratios: list[float] = []
    times: list[float] = []
    optimal_times: list[float] = []
    expanded: list[int] = []
    optimal = 0
    for number in range(count):
        seed = size * 1000 + number
        passable = random_map(size, seed)
        [(start, goal)] = random_queries(passable, 1, seed)
        started = time.perf_counter()
        best = dijkstra(factor, passable, False, start, [goal])
        optimal_times.append((time.perf_counter() - started) * 1e3)
        started = time.perf_counter()
        found = genetic(factor, passable, False, start, [goal], seed=number)
        times.append((time.perf_counter() - started) * 1e3)
        assert best is not None, "random_queries gives joined cells"
        if found is None:
            continue
        ratio = found.cost / best.cost
        assert ratio >= 1 - 1e-9, f"the genetic path beats Dijkstra's optimum on seed {seed}"
        ratios.append(ratio)
        optimal += ratio <= 1 + 1e-9
        expanded.append(found.expanded)
    return {
        "map": f"random {size}x{size}",
        "queries": count,
        "reached": len(ratios),
        "success_rate": len(ratios) / count if count else None,
        "optimal": optimal,
        "median_cost_ratio": statistics.median(ratios) if ratios else None,
        "max_cost_ratio": max(ratios) if ratios else None,
        "median_ms": statistics.median(times) if times else None,
        "dijkstra_median_ms": statistics.median(optimal_times) if optimal_times else None,
        "median_genes_decoded": statistics.median(expanded) if expanded else None,
        "samples_ms": times,
        "cost_ratios": ratios,
    }


def genetic_table(rows: list[dict[str, Any]]) -> str:
    lines = ["| map | queries | reached | success rate | optimal | median cost ratio | "
             "max cost ratio | GA ms | Dijkstra ms | genes decoded |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        lines.append(
            f"| {row['map']} | {row['queries']} | {row['reached']} | "
            f"{_cell(row['success_rate'])} | {row['optimal']} | "
            f"{_cell(row['median_cost_ratio'], 3)} | {_cell(row['max_cost_ratio'], 3)} | "
            f"{_cell(row['median_ms'], 1)} | {_cell(row['dijkstra_median_ms'], 3)} | "
            f"{_cell(row['median_genes_decoded'], 0)} |")
    return "\n".join(lines)


def main_genetic(sizes: list[int], queries: int, out: Path) -> None:
    """The ``--genetic`` run: write genetic.json and genetic.md into ``out``."""
    started = time.perf_counter()
    genetic(np.ones((2, 2)), np.ones((2, 2), dtype=bool), False, (0, 0), [(1, 1)])
    first_call = time.perf_counter() - started
    rows = []
    for size in sizes:
        rows.append(bench_genetic(size, queries))
        print(f"random {size}: {rows[-1]['reached']}/{queries} reached", flush=True)
    result = {"sizes": sizes, "queries": queries, "first_call_s": first_call, "maps": rows}
    out.mkdir(parents=True, exist_ok=True)
    write_results(out / "genetic.json", result)
    text = "\n\n".join([
        genetic_table(rows),
        "Default options (50000 generations, population 50, mutation 1, Euclidean distance), "
        "seeds 0, 1, ... per map size. A cost ratio is the genetic path's cost over Dijkstra's "
        "optimal one, over the queries that reached the goal; optimal counts those at ratio 1. "
        "Times are one run per query, medians in milliseconds; genes decoded is the median "
        "`expanded` of the genetic runs.",
        f"One-time cost: first call of the genetic kernel (numba cache load or compile) "
        f"{first_call:.2f} s."])
    (out / "genetic.md").write_text(text + "\n")
    print(text)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--limit", type=int, default=10, help="scenarios per Moving AI file")
    parser.add_argument("--sizes", type=int, nargs="*", default=[200, 600, 1000],
                        help="sides of the random maps")
    parser.add_argument("--queries", type=int, default=20, help="queries per random map")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per query and solver")
    parser.add_argument("--nx-queries", type=int, default=5,
                        help="queries per map for networkx (timed once each)")
    parser.add_argument("--nx-max-cells", type=int, default=1000 * 1000,
                        help="largest map (in cells) networkx gets a graph for")
    parser.add_argument("--jps-limit", type=int, default=None,
                        help="scenarios per Moving AI file for the jps check against the optimal "
                        "lengths (default: every one)")
    parser.add_argument("--data", type=Path, default=DATA, help="the Moving AI data folder")
    parser.add_argument("--quick", action="store_true",
                        help="a smoke run: 2 scenarios per file, one 200 map, 3 queries, 2 repeats")
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    parser.add_argument("--genetic", action="store_true",
                        help="run the genetic planner against Dijkstra's optimum instead")
    parser.add_argument("--ga-sizes", type=int, nargs="*", default=[32, 64],
                        help="with --genetic: sides of the random maps")
    parser.add_argument("--ga-queries", type=int, default=30,
                        help="with --genetic: queries (each on its own map) per size")
    args = parser.parse_args()
    if args.genetic:
        main_genetic(args.ga_sizes, args.ga_queries, args.out)
        return
    if args.quick:
        args.limit, args.sizes, args.queries, args.repeats, args.nx_queries = 2, [200], 3, 2, 2
        args.jps_limit = 20

    notes: list[str] = []
    libs = {name: _optional(name, notes) for name in ("pyastar2d", "tcod", "scipy", "networkx")}
    if libs["tcod"] is not None:
        importlib.import_module("tcod.path")
    if libs["scipy"] is not None:
        importlib.import_module("scipy.sparse.csgraph")

    # The first call loads the kernel from numba's disk cache, or compiles it on a cold cache.
    started = time.perf_counter()
    astar(np.ones((2, 2)), np.ones((2, 2), dtype=bool), False, (0, 0), [(1, 1)])
    first_call = time.perf_counter() - started

    rows = []
    for label, passable, scenarios in movingai_maps(args.data, args.limit):
        prepared = Map(label, passable, libs, passable.size <= args.nx_max_cells)
        queries = [(s.start, s.goal, s) for s in scenarios]
        rows.append(bench_map(prepared, queries, libs, args.repeats, args.nx_queries))
        print(f"{label}: {rows[-1]['median_ms']}", flush=True)
    for size in args.sizes:
        passable = random_map(size, seed=size)
        prepared = Map(f"random {size}x{size}", passable, libs, passable.size <= args.nx_max_cells)
        queries = [(s, g, None) for s, g in random_queries(passable, args.queries, seed=size + 1)]
        rows.append(bench_map(prepared, queries, libs, args.repeats, args.nx_queries))
        print(f"random {size}: {rows[-1]['median_ms']}", flush=True)

    summary = [pooled([r for r in rows if r["map"].endswith(" 512x512")],
                      "all 512x512 Moving AI maps (pooled)")]
    summary += [pooled([r], r["map"]) for r in rows if r["map"].startswith("random 1000x")]
    every = jps_scenarios(args.data, args.jps_limit)
    ratio = _ratio(summary[0]["samples_ms"], "jps", "pyastar2d")
    jps_target = {"ratio": ratio, "target": JPS_TARGET,
                  "met": None if ratio is None else ratio <= JPS_TARGET}
    result = {"limit": args.limit, "sizes": args.sizes, "queries": args.queries,
              "repeats": args.repeats, "nx_queries": args.nx_queries, "notes": notes,
              "first_call_s": first_call, "maps": rows, "targets": summary,
              "jps_target": jps_target, "jps_limit": args.jps_limit, "jps_scenarios": every}
    args.out.mkdir(parents=True, exist_ok=True)
    write_results(args.out / "solvers.json", result)

    # the largest Moving AI map by graph build, and the random maps, whose sizes are chosen
    shown = [max((r for r in rows if not r["map"].startswith("random ")),
                 key=lambda r: sum(r["setup_s"].values()), default=None)]
    shown += [r for r in rows if r["map"].startswith("random ")]
    one_time = (f"One-time costs: first call of our kernel (numba cache load or compile) "
                f"{first_call:.2f} s. Graph builds: "
                + "; ".join(f"{r['map']}: " + ", ".join(f"{k} {v:.2f} s"
                                                        for k, v in r["setup_s"].items())
                            for r in shown if r is not None) + ".")
    verdict = "-" if ratio is None else ("met" if ratio <= JPS_TARGET else "NOT met")
    shown_ratio = "-" if ratio is None else f"{ratio:.2f}"
    checked = sum(r["scenarios"] for r in every)
    jps_text = (f"jps target: jps/pyastar2d* on the pooled 512x512 maps at most "
                f"{JPS_TARGET:.2f}: {shown_ratio}, {verdict}. Jump point search against the "
                f"optimal lengths of {checked} Moving AI scenarios "
                f"({'every one' if args.jps_limit is None else f'up to {args.jps_limit} a file'}, "
                f"one run each): {sum(r['mismatches'] for r in every)} mismatches.")
    text = "\n\n".join([table(rows), RULES, "Targets (pooled medians):", table(summary), one_time,
                         jps_text, jps_scenarios_table(every)]
                        + (["; ".join(notes) + "."] if notes else []))
    (args.out / "solvers.md").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
