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
and (mean, median) over all hybrid answers; and the speed: the median over the queries whose
CBR path the landmark test accepts of CBR time / A* time and CBR time / jump point search time
on the same query (jps,
the fastest exact solver on these maps of uniform costs), and the median over all queries of
each hybrid's time over the time of the solver it falls back to. The papers' hybrid always tries
CBR first (its attempt plus any fallback to A*) and tests against the octile distance. The
decided hybrids first choose per query whether to try CBR (``cbr_casegraph.payoff``), leave the
query to their solver when not, and test CBR's path against the landmark bound: the fixed
thresholds (``min_cells`` and ``min_distance`` at :data:`FIXED`) falling back to A*, and the
learned choice (``payoff: learned``) falling back to A* and to jps, each learning only from the
times it would itself have measured (CBR's when it tried, the solver's when the solver planned).
Every time is one run, after warm-up queries, CBR, A* and jps interleaved query by query; the
machine may be shared, so medians and ratios are the figures to trust. The learned choice's
constants were tuned on the map families of :data:`TUNING`; each row says whether its map was
in the tuning set or held out.

    python benchmarks/casegraph_movingai.py [--limit N] [--data DIR] [--out benchmarks/results]

``--limit`` keeps only every k-th problem so that at most N remain per map. Writes
``casegraph_movingai.json`` and ``casegraph_movingai.md``.

The protocol's pieces (``PAIRS``, ``DATA``, :func:`load_problems`, :func:`retain_half`,
:func:`astar_solver`, :func:`jps_solver`) are shared by the other benchmarks on these maps.
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
from cbr_casegraph.payoff import MARGIN, REVISIT, WINDOW, Learned, Payoff, band
from cbr_casegraph.planner import Plan, Settings, plan
from cbr_grid.costs import path_length
from cbr_grid.distances import octile
from cbr_grid.grid import Grid
from cbr_grid.movingai import Scenario, load_map, load_scen
from cbr_pathquality.ideal import Landmarks
from cbr_solvers.jps import JumpResult, jps
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

FIXED = Payoff(min_cells=20000, min_distance=64)
"""The fixed thresholds (the ``casegraph`` retriever's ``min_cells`` and ``min_distance``)
that were measured on these maps for the A* hybrid, before the learned choice; kept to compare
with it."""

TUNING = ("dao", "mapf")
"""The map families the learned choice's constants (``MARGIN``, ``WINDOW``, ``REVISIT`` of
:mod:`cbr_casegraph.payoff`) were tuned on; the others (bg512, cities, mazes, random, rooms)
were held out of the tuning."""

MAX_OVER_SOLVER = 1.1
"""The most a learned hybrid's median time may be of the solver's it falls back to."""

MAX_CBR_OVER_JPS = 0.2
"""The most CBR's median time may be of jump point search's on the large maps."""

LARGE_SIDE = 512
"""Maps whose shorter side has at least this many cells are the large ones."""


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


def jps_solver(grid: Grid) -> Callable[[Scenario], JumpResult | None]:
    """Jump point search on ``grid`` for one problem: the fastest exact solver on these maps
    (uniform costs, no corner cutting)."""
    def solve(problem: Scenario) -> JumpResult | None:
        return jps(grid.factor, grid.passable, grid.corner_cutting, problem.start,
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
    """What one planned query measured: the times in seconds, the lengths and the verdicts, and
    what each decided hybrid chose (``tried``: CBR first; ``decide_s``: the choice's time)."""

    cbr_s: float
    astar_s: float
    jps_s: float
    planned: bool
    octile_ok: bool
    landmark_ok: bool
    cbr_length: float
    astar_length: float
    optimal: float
    octile: float
    landmark_bound: float
    tried: dict[str, bool]
    decide_s: dict[str, float]


def retained_paths(graph: CaseGraph) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """Pairs of vertices of the graph more than delta apart, ends of stored edges first."""
    ids = graph.edge_ids()
    a, b = graph.ends(ids)
    far = np.abs(a - b).max(axis=1) > Settings().delta
    return [((int(p[0]), int(p[1])), (int(q[0]), int(q[1])))
            for p, q in zip(a[far], b[far], strict=True)]


class Hybrid:
    """One decided hybrid: a choice per query, and the solver it leaves queries to.

    ``thresholds`` is the fixed rule (:class:`cbr_casegraph.payoff.Payoff` at :data:`FIXED`,
    falling back to A*); ``learned`` the learned one (:class:`cbr_casegraph.payoff.Learned`),
    told only what the hybrid itself would have measured: CBR's time when it tried CBR, the
    solver's when the solver planned.
    """

    def __init__(self, solver: str, grid: Grid, *, learned: bool) -> None:
        self.solver = solver
        self.learned = Learned() if learned else None
        self.cells = int(np.count_nonzero(grid.passable))

    def choose(self, problem: Scenario) -> tuple[bool, float, int]:
        """Whether CBR is tried, the seconds the choice took and the query's band."""
        began = time.perf_counter()
        if self.learned is None:
            which = 0
            tried = FIXED.reason(self.cells, problem.start, problem.goal) is None
        else:
            which = band(problem.start, problem.goal)
            tried = self.learned.tries(which)
        return tried, time.perf_counter() - began, which

    def measured(self, which: int, tried: bool, cbr_s: float, answered: bool,
                 solver_s: float) -> None:
        if self.learned is None:
            return
        if tried:
            self.learned.attempted(which, cbr_s, answered)
        if not (tried and answered):
            self.learned.solved(which, solver_s)


HYBRIDS = {"thresholds": ("astar", False), "learned_astar": ("astar", True),
           "learned_jps": ("jps", True)}
"""The decided hybrids measured: the solver each falls back to and whether its choice is
learned."""


def measure_map(grid: Grid, graph: CaseGraph, planned: list[Scenario], landmarks: Landmarks
                ) -> list[Query]:
    """Each planned problem by CBR, A* and jump point search, interleaved, and each decided
    hybrid's choice for it."""
    settings = Settings()
    solve = astar_solver(grid)
    jump = jps_solver(grid)
    hybrids = {name: Hybrid(solver, grid, learned=learned)
               for name, (solver, learned) in HYBRIDS.items()}
    # compile the searches and the planner's kernels before timing, with queries that reach
    # every kernel: the ends of retained paths lie on the graph
    for problem in planned[:3]:
        solve(problem)
        jump(problem)
    for path in retained_paths(graph)[:3]:
        plan(graph, path[0], path[1], settings)
    queries = []
    for problem in planned:
        choices = {name: hybrid.choose(problem) for name, hybrid in hybrids.items()}
        t0 = time.perf_counter()
        result = plan(graph, problem.start, problem.goal, settings)
        t1 = time.perf_counter()
        reference = solve(problem)
        t2 = time.perf_counter()
        jumped = jump(problem)
        t3 = time.perf_counter()
        if reference is None or problem.optimal <= 0:
            continue
        if jumped is None or jumped.search != "jps" or abs(jumped.cost - reference.cost) > 1e-6:
            raise RuntimeError(f"jump point search did not plan {problem} as A* did")
        ok = isinstance(result, Plan)
        length = path_length(result.path) if isinstance(result, Plan) else np.inf
        octile_ok = ok and accepted(result.path, problem.start, problem.goal)
        bound = landmarks.bound(problem.start, problem.goal)
        landmark_ok = ok and (bound == 0 or length / bound <= MAX_RATIO)
        times = {"astar": t2 - t1, "jps": t3 - t2}
        for name, hybrid in hybrids.items():
            tried, _, which = choices[name]
            hybrid.measured(which, tried, t1 - t0, landmark_ok, times[hybrid.solver])
        queries.append(Query(t1 - t0, t2 - t1, t3 - t2, ok, octile_ok, landmark_ok, length,
                             path_length(reference.path), problem.optimal,
                             float(octile(problem.start, problem.goal)), bound,
                             {name: choice[0] for name, choice in choices.items()},
                             {name: choice[1] for name, choice in choices.items()}))
    return queries


def _percent(values: list[float], how: str) -> float | None:
    if not values:
        return None
    pick = {"mean": np.mean, "median": np.median, "max": np.max}[how]
    return float(pick(values)) * 100


def _median(values: list[float]) -> float | None:
    return statistics.median(values) if values else None


def decided(queries: list[Query], name: str) -> dict[str, Any]:
    """The figures of decided hybrid ``name``: its time over its solver's (median and mean of
    the per-query ratios), the share CBR answered and tried, and the path deviations."""
    solver = HYBRIDS[name][0]
    ratios, deviations = [], []
    for q in queries:
        exact = q.astar_s if solver == "astar" else q.jps_s
        tried = q.tried[name]
        spent = q.decide_s[name] + (0.0 if not tried else q.cbr_s) + (
            0.0 if tried and q.landmark_ok else exact)
        ratios.append(spent / exact)
        deviations.append((q.cbr_length if tried and q.landmark_ok else q.astar_length)
                          / q.optimal - 1)
    count = len(queries)
    return {"solver": solver,
            "over_solver_median": _median(ratios),
            "over_solver_mean": float(np.mean(ratios)) if ratios else None,
            "tried_share": sum(q.tried[name] for q in queries) / count if count else None,
            "share": (sum(q.tried[name] and q.landmark_ok for q in queries) / count
                      if count else None),
            "deviation_mean_pct": _percent(deviations, "mean"),
            "deviation_max_pct": _percent(deviations, "max"),
            "decide_us_median": _median([q.decide_s[name] * 1e6 for q in queries])}


def summary(queries: list[Query]) -> dict[str, Any]:
    """The per-map figures of the table from the measured queries."""
    cbr_dev = [q.cbr_length / q.optimal - 1 for q in queries if q.octile_ok]
    landmark_dev = [q.cbr_length / q.optimal - 1 for q in queries if q.landmark_ok]
    hybrid_dev = [(q.cbr_length if q.octile_ok else q.astar_length) / q.optimal - 1
                  for q in queries]
    # the fallback is the very A* run timed beside the attempt
    always = [(q.cbr_s if q.octile_ok else q.cbr_s + q.astar_s) / q.astar_s for q in queries]
    # the times of the answers the landmark test accepts: it is the test the decided hybrids
    # use, and the octile test accepts no path at all on a maze
    answered = [q for q in queries if q.landmark_ok]
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
        "jps_ms_median": _median([q.jps_s * 1000 for q in queries]),
        "cbr_over_astar_median": _median([q.cbr_s / q.astar_s for q in answered]),
        "cbr_over_jps_median": _median([q.cbr_s / q.jps_s for q in answered]),
        "jps_over_astar_median": _median([q.jps_s / q.astar_s for q in queries]),
        "hybrid_over_astar_median": _median(always),
        "decided": {name: decided(queries, name) for name in HYBRIDS},
        # how near each lower bound comes to the optimal length: bound / optimum
        "octile_tightness_median": _median([q.octile / q.optimal for q in queries]),
        "landmark_tightness_median": _median([q.landmark_bound / q.optimal for q in queries]),
        "landmark_tightness_p10": (float(np.percentile(
            [q.landmark_bound / q.optimal for q in queries], 10)) if queries else None),
    }


def run_map(map_path: Path, scen_path: Path, limit: int | None, data: Path = DATA
            ) -> dict[str, Any]:
    grid, problems = load_problems(map_path, scen_path, limit)
    graph, planned, build_s = retain_half(grid, problems)
    began = time.perf_counter()
    landmarks = Landmarks(grid, LANDMARKS)
    landmarks_s = time.perf_counter() - began
    queries = measure_map(grid, graph, planned, landmarks)
    name = map_path.relative_to(data).as_posix()
    return {"map": name, "size": f"{grid.width}x{grid.height}",
            "set": "tuning" if name.split("/")[1] in TUNING else "held out",
            "retained_paths": len(problems) - len(planned), "vertices": graph.vertex_count,
            "edges": graph.edge_count, "coverage": graph.coverage(), "build_s": build_s,
            "landmarks_s": landmarks_s, **summary(queries)}


def _fmt(value: float | None, digits: int = 2) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def table(rows: list[dict[str, Any]]) -> list[str]:
    """The markdown table of the per-map rows: what CBR answers and how good it is (a "bound
    held" column when the rows have it)."""
    held = any("bound_held" in row for row in rows)
    lines = ["| map | size | retained | vertices (coverage) | queries | CBR share (octile) "
             "| CBR share (landmarks) | bound / optimum: octile, landmarks (10th pct) "
             "| CBR dev. mean / median / max % "
             "| hybrid dev. mean / median % |" + (" bound held |" if held else ""),
             "|---" * (10 + held) + "|"]
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
            f"{_fmt(row['hybrid_deviation_median_pct'])} |" + bound)
    return lines


def _hybrid(figures: dict[str, Any]) -> str:
    return (f"{_fmt(figures['over_solver_median'], 3)} ({_fmt(figures['tried_share'], 2)}, "
            f"{_fmt(figures['share'], 2)})")


def speed_table(rows: list[dict[str, Any]]) -> list[str]:
    """The markdown table of the per-map times: CBR against A* and jump point search, and each
    decided hybrid against the solver it falls back to."""
    lines = ["| map | size | set | CBR ms | A* ms | jps ms | CBR / A* | CBR / jps "
             "| papers' hybrid / A* | fixed thresholds / A* (tried, answered) "
             "| learned / A* (tried, answered) | learned / jps (tried, answered) "
             "| learned dev. mean / max % |",
             "|---" * 13 + "|"]
    for row in rows:
        hybrids = row["decided"]
        lines.append(
            f"| {row['map']} | {row['size']} | {row['set']} | {_fmt(row['cbr_ms_median'], 3)} "
            f"| {_fmt(row['astar_ms_median'], 3)} | {_fmt(row['jps_ms_median'], 3)} "
            f"| {_fmt(row['cbr_over_astar_median'], 3)} | {_fmt(row['cbr_over_jps_median'], 3)} "
            f"| {_fmt(row['hybrid_over_astar_median'], 3)} "
            f"| {_hybrid(hybrids['thresholds'])} | {_hybrid(hybrids['learned_astar'])} "
            f"| {_hybrid(hybrids['learned_jps'])} "
            f"| {_fmt(hybrids['learned_astar']['deviation_mean_pct'])} / "
            f"{_fmt(hybrids['learned_astar']['deviation_max_pct'])} |")
    return lines


def targets(rows: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """The targets: every learned hybrid within 1.1 times its solver's median time on every
    map, and on the maps of 512 x 512 cells and more CBR within 1/5 of jump point search's."""
    learned = [row["decided"][name]["over_solver_median"] for row in rows
               for name in ("learned_astar", "learned_jps")]
    large = [row["cbr_over_jps_median"] for row in rows
             if min(int(side) for side in row["size"].split("x")) >= LARGE_SIDE
             and row["cbr_over_jps_median"] is not None]
    worst = max(learned)
    slowest = max(large) if large else None
    return {"learned_over_solver_max": {"value": worst, "target": f"<= {MAX_OVER_SOLVER}",
                                        "met": worst <= MAX_OVER_SOLVER},
            "cbr_over_jps_large_max": {"value": slowest, "target": f"<= {MAX_CBR_OVER_JPS}",
                                       "met": slowest is not None
                                       and slowest <= MAX_CBR_OVER_JPS}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--limit", type=int, default=None)
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    rows = []
    for map_name, scen_name in PAIRS:
        row = run_map(args.data / map_name, args.data / scen_name, args.limit, args.data)
        rows.append(row)
        hybrids = row["decided"]
        print(f"{row['map']}: share {_fmt(row['cbr_share'], 3)} "
              f"(landmarks {_fmt(row['cbr_share_landmarks'], 3)}), "
              f"CBR/A* {_fmt(row['cbr_over_astar_median'], 3)}, "
              f"CBR/jps {_fmt(row['cbr_over_jps_median'], 3)}, decided hybrid: thresholds/A* "
              f"{_fmt(hybrids['thresholds']['over_solver_median'], 3)}, learned/A* "
              f"{_fmt(hybrids['learned_astar']['over_solver_median'], 3)}, learned/jps "
              f"{_fmt(hybrids['learned_jps']['over_solver_median'], 3)}", flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    met = targets(rows)
    result = {"settings": {"delta": Settings().delta, "max_ratio": MAX_RATIO,
                           "limit": args.limit, "landmarks": LANDMARKS,
                           "thresholds": attrs.asdict(FIXED), "decided_ideal": "landmarks",
                           "learned": {"window": WINDOW, "revisit": REVISIT, "margin": MARGIN},
                           "tuned_on": sorted(TUNING)},
              "maps": rows, "targets": met}
    write_results(args.out / "casegraph_movingai.json", result)
    lines = [*table(rows), "", *speed_table(rows), "", "| target | measured | goal | met |",
             "|---|---|---|---|"]
    lines += [f"| {name} | {_fmt(entry['value'], 3)} | {entry['target']} "
              f"| {'yes' if entry['met'] else 'no'} |" for name, entry in met.items()]
    (args.out / "casegraph_movingai.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
