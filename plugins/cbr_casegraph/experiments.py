"""Reproductions of section 6 of the case graph paper (Hodál & Dvořák, Figs. 2-5 and Table 1).

Four experiments, each run by ``cbr experiment NAME --size ci|full``:

``cbr-share``
    Section 6.2, Fig. 3: the share of random tasks planned by CBR against the coverage of the
    map by graph vertices.
``deviation-table``
    Section 6.4, Table 1 and Fig. 5: the hybrid planner, Dijkstra, A* and Ai* against the best
    of the four in path cost, length and turns.
``time-vs-map-size``
    Section 6.3, Fig. 4: CBR planning time with 1000, 2000 and 3000 vertices, and the
    alternative methods' times, on square maps of growing size.
``time-vs-vertices``
    Section 6.1, Fig. 2: CBR planning time against the vertex count, full against selective
    adaptation.

The paper does not describe its maps. All four use random obstacle maps (15% of the cells,
:func:`cbr_grid.generate.generate` ``"random"``) with smooth terrain risk (amount 0.5), so that a
path's cost (length times the risk factor, eq. 4) differs from its length as in the paper's
Table 1; random obstacles spread the tasks evenly, which matches the paper's "uniform coverage".
Graphs are grown by :func:`cbr_casegraph.build.grow` (Dijkstra paths of random tasks retained).
The quality test of step 7 is applied as the ``path_quality`` reviser applies it: a CBR path is
accepted when its length is at most 1.5 times the octile distance between start and goal.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from cbr_casegraph.build import SOLVERS, connected_cells, grow, random_task
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.planner import Failure, Plan, Settings, plan
from cbr_grid.costs import path_cost, path_length, turns
from cbr_grid.generate import generate
from cbr_grid.grid import Grid
from cbrcore.context import Context
from cbrcore.experiment import ExperimentResult, Size

if TYPE_CHECKING:
    from matplotlib.figure import Figure

Cell = tuple[int, int]
Progress = Callable[[int, int], None]

DENSITY = 0.15
TERRAIN = 0.5
MAX_RATIO = 1.5
"""The quality test's largest accepted ratio of path length to the octile distance."""

METHODS = ("dijkstra", "astar", "aistar")

REPEATS = 3
"""Runs per CBR query in the timing experiments: a query's time is the median of its runs, so
that one interruption by another process on a shared machine does not count."""

PAPER_SHARE = {6: 0.50, 10: 0.75, 15: 0.90}
"""Section 6.2: share of tasks planned by CBR at a coverage (percent of cells that are vertices)."""

PAPER_TABLE = {
    2000: {"CBR": (16.01, 18.09, 28.89), "Dijkstra": (0.00, 1.32, 13.92),
           "A*": (5.43, 0.30, 7.53), "Ai*": (11.10, 2.24, 13.01)},
    4000: {"CBR": (7.60, 9.59, 21.51), "Dijkstra": (0.00, 1.53, 14.46),
           "A*": (5.45, 0.38, 7.30), "Ai*": (11.37, 2.51, 13.42)},
    6000: {"CBR": (4.46, 6.47, 20.97), "Dijkstra": (0.00, 1.63, 15.25),
           "A*": (5.67, 0.27, 5.87), "Ai*": (11.22, 2.28, 15.92)},
    8000: {"CBR": (2.96, 4.53, 16.69), "Dijkstra": (0.00, 1.32, 14.87),
           "A*": (5.57, 0.40, 7.66), "Ai*": (11.06, 2.19, 12.91)},
}
"""Table 1: mean deviation (%) from the best cost, length and turns, by vertex count."""

LABELS = {"cbr": "CBR", "dijkstra": "Dijkstra", "astar": "A*", "aistar": "Ai*"}

TIE = 1e-9
"""Relative difference under which two values count as equal: optimal paths found by different
searches sum the same step costs in a different order."""


# -- shared pieces -------------------------------------------------------------------------


def make_map(size: int, seed: int) -> Grid:
    """The square test map of side ``size``: random obstacles with terrain risk."""
    return generate("random", size, size, seed, density=DENSITY, terrain=TERRAIN)


def _map_info(side: int, seed: int) -> dict[str, Any]:
    return {"kind": "random", "width": side, "height": side, "density": DENSITY,
            "terrain": TERRAIN, "seed": seed}


def octile(a: Sequence[int], b: Sequence[int]) -> float:
    dx, dy = abs(a[0] - b[0]), abs(a[1] - b[1])
    return max(dx, dy) + (math.sqrt(2) - 1) * min(dx, dy)


def accepted(path: np.ndarray, start: Cell, goal: Cell, max_ratio: float = MAX_RATIO) -> bool:
    """Step 7, as the ``path_quality`` reviser decides it."""
    ideal = octile(start, goal)
    return ideal == 0 or path_length(path) / ideal <= max_ratio


def outcome(result: Plan | Failure, start: Cell, goal: Cell) -> str:
    """Why a CBR attempt ended: ``cbr`` when it gave an accepted path, else the failure's kind."""
    if isinstance(result, Plan):
        return "cbr" if accepted(result.path, start, goal) else "rejected by quality"
    if result.reason.startswith("start and goal within delta"):
        return "within delta"
    if result.reason.startswith("no case meets"):
        return "no case near"
    if result.reason.startswith("no local path"):
        return "no local path"
    return "graph not connected"


def timed(call: Callable[[], Any]) -> tuple[Any, float]:
    began = time.perf_counter()
    result = call()
    return result, time.perf_counter() - began


def median_of_runs(call: Callable[[], Any], repeats: int = REPEATS) -> float:
    return float(np.median([timed(call)[1] for _ in range(repeats)]))


def solve(method: str, grid: Grid, start: Cell, goal: Cell) -> Any:
    return SOLVERS[method](grid.factor, grid.passable, grid.corner_cutting, start, [goal])


def warm_up(grid: Grid, cells: np.ndarray, rng: np.random.Generator) -> None:
    """Compile the searches before anything is timed (they are just-in-time compiled)."""
    start, goal = random_task(cells, rng)
    for method in METHODS:
        solve(method, grid, start, goal)


def cbr_tasks(graph: CaseGraph, region: np.ndarray, rng: np.random.Generator, count: int,
              settings: Settings, min_span: float = 0.0) -> list[tuple[Cell, Cell]]:
    """Tasks "set so that a CBR path lies between them" (section 6.3).

    Start and goal lie within delta / 2 of two random graph vertices, on reachable cells,
    farther than delta and at least ``min_span`` (octile) apart, and CBR plans an accepted path
    between them. Fewer than ``count`` are returned only when 50 times as many draws found no
    more.
    """
    vertices = graph.vertices()
    height, width = region.shape
    reach = max(settings.delta // 2, 1)
    tasks: list[tuple[Cell, Cell]] = []
    for _ in range(50 * count):
        if len(tasks) == count or len(vertices) < 2:
            break
        ends = vertices[rng.choice(len(vertices), size=2, replace=False)]
        ends = ends + rng.integers(-reach, reach + 1, size=(2, 2))
        ends[:, 0] = np.clip(ends[:, 0], 0, width - 1)
        ends[:, 1] = np.clip(ends[:, 1], 0, height - 1)
        if not region[ends[:, 1], ends[:, 0]].all():
            continue
        start = (int(ends[0, 0]), int(ends[0, 1]))
        goal = (int(ends[1, 0]), int(ends[1, 1]))
        if octile(start, goal) < min_span:
            continue
        if outcome(plan(graph, start, goal, settings), start, goal) == "cbr":
            tasks.append((start, goal))
    return tasks


def region_mask(grid: Grid, cells: np.ndarray) -> np.ndarray:
    mask = np.zeros(grid.passable.shape, dtype=bool)
    mask[cells[:, 1], cells[:, 0]] = True
    return mask


def median_ms(seconds: Sequence[float]) -> float | None:
    return float(np.median(seconds) * 1000) if len(seconds) else None


def _fmt(value: float | None, digits: int = 2) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def _new_figure() -> tuple[Figure, Any]:
    # imported here: loading the plugin for any other command should not load matplotlib
    from matplotlib.figure import Figure

    figure = Figure(figsize=(6, 4))
    return figure, figure.add_subplot()


class _Experiment:
    """Keeps the run's seed: every map and task draw derives from it."""

    def __init__(self, options: object, ctx: Context) -> None:
        self.seed = ctx.seed
        self.rng = ctx.spawn_rng()

    def _setup(self, size: int) -> tuple[Grid, np.ndarray]:
        import matplotlib

        # the experiments draw into files only; no display is needed or wanted
        matplotlib.use("Agg")
        grid = make_map(size, self.seed)
        cells = connected_cells(grid, self.rng)
        warm_up(grid, cells, self.rng)
        return grid, cells


# -- section 6.2: share of CBR -----------------------------------------------------------------


class Share(_Experiment):
    """Fig. 3: share of random tasks planned by CBR against the map's coverage by vertices."""

    SCALE: ClassVar[dict[str, Any]] = {"ci": (64, (5, 10, 15), 200),
                                       "full": (200, (2, 4, 6, 8, 10, 12, 15, 20), 10000)}

    def run(self, size: Size, out_dir: Path, progress: Progress) -> ExperimentResult:
        side, coverages, queries = self.SCALE[size]
        grid, cells = self._setup(side)
        graph = CaseGraph(grid)
        settings = Settings()
        rows: list[dict[str, Any]] = []
        paths = 0
        for step, percent in enumerate(coverages):
            paths += grow(graph, round(percent / 100 * grid.passable.size), self.rng,
                          cells=cells)
            counts: dict[str, int] = {}
            seconds: list[float] = []
            for _ in range(queries):
                start, goal = random_task(cells, self.rng)
                result, took = timed(lambda s=start, g=goal: plan(graph, s, g, settings))
                seconds.append(took)
                kind = outcome(result, start, goal)
                counts[kind] = counts.get(kind, 0) + 1
            rows.append({"coverage_percent": percent, "measured_coverage": graph.coverage(),
                         "vertices": graph.vertex_count, "edges": graph.edge_count,
                         "paths_retained": paths, "queries": queries,
                         "share": counts.get("cbr", 0) / queries, "outcomes": counts,
                         "median_plan_ms": median_ms(seconds)})
            progress(step + 1, len(coverages))
        table = ["| coverage (% of cells) | vertices | paths retained | CBR share (ours) "
                 "| CBR share (paper) | within delta | no case near | no local path "
                 "| not connected | rejected by quality |",
                 "|---|---|---|---|---|---|---|---|---|---|"]
        for row in rows:
            paper = PAPER_SHARE.get(row["coverage_percent"])
            counts = row["outcomes"]
            table.append(
                f"| {row['measured_coverage'] * 100:.1f} | {row['vertices']} "
                f"| {row['paths_retained']} | {row['share']:.3f} "
                f"| {'' if paper is None else f'{paper:.2f}'} "
                f"| {counts.get('within delta', 0) / queries:.3f} "
                f"| {counts.get('no case near', 0) / queries:.3f} "
                f"| {counts.get('no local path', 0) / queries:.3f} "
                f"| {counts.get('graph not connected', 0) / queries:.3f} "
                f"| {counts.get('rejected by quality', 0) / queries:.3f} |")
        figure, axes = _new_figure()
        axes.plot([r["measured_coverage"] * 100 for r in rows], [r["share"] for r in rows],
                  "o-", label=f"ours ({side}x{side}, {queries} tasks each)")
        axes.plot(list(PAPER_SHARE), list(PAPER_SHARE.values()), "s", color="black",
                  label="paper (section 6.2)")
        axes.set(xlabel="coverage: vertices / cells (%)", ylabel="share planned by CBR",
                 ylim=(0, 1), title="Frequency of CBR method choice (Fig. 3)")
        axes.grid(True, alpha=0.3)
        axes.legend()
        return ExperimentResult(
            results={"map": _map_info(side, self.seed), "delta": settings.delta,
                     "max_ratio": MAX_RATIO, "rows": rows},
            table="\n".join(table), figures={"cbr_share": figure})



# -- section 6.4: Table 1 ---------------------------------------------------------------------


def deviations(values: dict[str, float]) -> dict[str, float]:
    """Each method's deviation (%) from the best (least) value.

    A best value of 0 (a straight path has no turns) would leave the ratio undefined: it is
    then taken relative to 1, so one extra turn counts 100%.
    """
    best = min(values.values())
    scale = 1.0 if best == 0 else best
    return {name: 0.0 if value - best <= TIE * scale else (value - best) / scale * 100
            for name, value in values.items()}


class DeviationTable(_Experiment):
    """Table 1: deviation of CBR (with Dijkstra fallback), Dijkstra, A* and Ai* from the best."""

    SCALE: ClassVar[dict[str, Any]] = {"ci": (64, (200, 400), 60),
                                       "full": (200, (2000, 4000, 6000, 8000), 1000)}
    PARAMETERS = ("cost", "length", "turns")

    def run(self, size: Size, out_dir: Path, progress: Progress) -> ExperimentResult:
        side, counts, tasks = self.SCALE[size]
        grid, cells = self._setup(side)
        graph = CaseGraph(grid)
        settings = Settings()
        rows: list[dict[str, Any]] = []
        for step, vertices in enumerate(counts):
            grow(graph, vertices, self.rng, cells=cells)
            sums = {(m, p): 0.0 for m in ("cbr", *METHODS) for p in self.PARAMETERS}
            alone: list[float] = []
            planned = 0
            for _ in range(tasks):
                start, goal = random_task(cells, self.rng)
                paths = {m: solve(m, grid, start, goal).path for m in METHODS}
                result = plan(graph, start, goal, settings)
                by_cbr = isinstance(result, Plan) and outcome(result, start, goal) == "cbr"
                # the hybrid planner falls back to its alternative method, Dijkstra
                paths["cbr"] = result.path if isinstance(result, Plan) and by_cbr else (
                    paths["dijkstra"])
                planned += by_cbr
                measured = {
                    "cost": {m: path_cost(grid, p) for m, p in paths.items()},
                    "length": {m: path_length(p) for m, p in paths.items()},
                    "turns": {m: float(turns(p)) for m, p in paths.items()},
                }
                for parameter, values in measured.items():
                    for method, deviation in deviations(values).items():
                        sums[method, parameter] += deviation
                if by_cbr:
                    alone.append(deviations(measured["cost"])["cbr"])
            rows.append({
                "vertices": graph.vertex_count, "target_vertices": vertices,
                "coverage": graph.coverage(), "tasks": tasks, "cbr_share": planned / tasks,
                "cbr_only_cost_deviation": float(np.mean(alone)) if alone else None,
                "deviation": {LABELS[m]: {p: sums[m, p] / tasks for p in self.PARAMETERS}
                              for m in ("cbr", *METHODS)}})
            progress(step + 1, len(counts))
        return ExperimentResult(
            results={"map": _map_info(side, self.seed), "delta": settings.delta,
                     "max_ratio": MAX_RATIO, "fallback": "dijkstra", "rows": rows},
            table=self._table(rows), figures={"deviation_cost": self._figure(rows)})

    def _table(self, rows: list[dict[str, Any]]) -> str:
        lines = ["| vertices (coverage) | method | cost: ours | cost: paper | length: ours "
                 "| length: paper | turns: ours | turns: paper |",
                 "|---|---|---|---|---|---|---|---|"]
        for row in rows:
            paper = PAPER_TABLE.get(row["target_vertices"], {})
            for method, ours in row["deviation"].items():
                theirs = paper.get(method)
                cells = [f"{ours[p]:.2f} | {'' if theirs is None else f'{theirs[k]:.2f}'}"
                         for k, p in enumerate(self.PARAMETERS)]
                lines.append(f"| {row['vertices']} ({row['coverage'] * 100:.1f}%) | {method} "
                             f"| {' | '.join(cells)} |")
        lines.append("")
        lines.append("| vertices | CBR share | CBR cost deviation on the tasks CBR planned |")
        lines.append("|---|---|---|")
        for row in rows:
            lines.append(f"| {row['vertices']} | {row['cbr_share']:.3f} "
                         f"| {_fmt(row['cbr_only_cost_deviation'])} |")
        return "\n".join(lines)

    def _figure(self, rows: list[dict[str, Any]]) -> Figure:
        figure, axes = _new_figure()
        coverage = [row["coverage"] * 100 for row in rows]
        # the paper's coverage: its vertex counts on its 200x200 map
        paper_coverage = [v / 40000 * 100 for v in PAPER_TABLE]
        for k, method in enumerate(LABELS.values()):
            axes.plot(coverage, [row["deviation"][method]["cost"] for row in rows], "o-",
                      color=f"C{k}", label=f"{method} (ours)")
            axes.plot(paper_coverage, [PAPER_TABLE[v][method][0] for v in PAPER_TABLE], "x--",
                      color=f"C{k}", alpha=0.6, label=f"{method} (paper)")
        axes.plot(coverage, [row["cbr_only_cost_deviation"] for row in rows], "^:",
                  color="C0", label="CBR, its own paths only (ours)")
        axes.set(xlabel="coverage: vertices / cells (%)", ylabel="mean cost deviation (%)",
                 title="Relative deviations from the best costs (Fig. 5)")
        axes.grid(True, alpha=0.3)
        axes.legend(fontsize="small", ncol=2)
        return figure


# -- section 6.3: times against map size ------------------------------------------------------

MAX_COVERAGE = 0.5
"""The largest share of a map's reachable cells a test graph may take as vertices: beyond it
the graph is no longer a network of paths but fills the map (and growing it stalls)."""


class TimeVsMapSize(_Experiment):
    """Fig. 4: CBR (1000/2000/3000 vertices) and Dijkstra, A*, Ai* planning times by map size."""

    SCALE: ClassVar[dict[str, Any]] = {"ci": ((50, 100, 200), 10),
             "full": ((*range(50, 601, 50), 1000), 20)}
    GRAPHS = (1000, 2000, 3000)

    def run(self, size: Size, out_dir: Path, progress: Progress) -> ExperimentResult:
        sides, per_graph = self.SCALE[size]
        settings = Settings()
        rows: list[dict[str, Any]] = []
        for step, side in enumerate(sides):
            grid, cells = self._setup(side)
            region = region_mask(grid, cells)
            graph = CaseGraph(grid)
            row: dict[str, Any] = {"size": side, "cbr_ms": {}, "tasks": {}}
            queries: list[tuple[Cell, Cell]] = []
            for vertices in self.GRAPHS:
                row["cbr_ms"][str(vertices)] = None
                row["tasks"][str(vertices)] = 0
                if vertices > MAX_COVERAGE * len(cells):
                    continue
                try:
                    grow(graph, vertices, self.rng, cells=cells)
                except ValueError:
                    # the map is saturated below this count: no such graph on this map
                    continue
                # tasks across a third of the map at least, so that the alternative methods'
                # times show what a map of this size costs them, as in Fig. 4
                tasks = cbr_tasks(graph, region, self.rng, per_graph, settings, side / 3)
                seconds = [median_of_runs(lambda s=s, g=g, c=graph: plan(c, s, g, settings))
                           for s, g in tasks]
                row["cbr_ms"][str(vertices)] = median_ms(seconds)
                row["tasks"][str(vertices)] = len(tasks)
                queries.extend(tasks)
            row["octile_median"] = (float(np.median([octile(s, g) for s, g in queries]))
                                    if queries else None)
            for method in METHODS:
                row[f"{method}_ms"] = median_ms(
                    [timed(lambda s=s, g=g, m=method, w=grid: solve(m, w, s, g))[1]
                     for s, g in queries])
            rows.append(row)
            progress(step + 1, len(sides))
        lines = ["| map | CBR 1000 ms | CBR 2000 ms | CBR 3000 ms | Dijkstra ms | A* ms "
                 "| Ai* ms | tasks | median octile distance |",
                 "|---|---|---|---|---|---|---|---|---|"]
        for row in rows:
            cbr = " | ".join(_fmt(row["cbr_ms"][str(v)], 3) for v in self.GRAPHS)
            lines.append(f"| {row['size']}x{row['size']} | {cbr} | {_fmt(row['dijkstra_ms'], 3)} "
                         f"| {_fmt(row['astar_ms'], 3)} | {_fmt(row['aistar_ms'], 3)} "
                         f"| {sum(row['tasks'].values())} | {_fmt(row['octile_median'], 1)} |")
        lines.append("")
        lines.append("The paper gives Fig. 4 only as a plot (600x600 at most): CBR times nearly "
                     "flat in the map size and set by the vertex count, the alternative methods' "
                     "times growing steeply.")
        figure, axes = _new_figure()
        x = [row["size"] for row in rows]
        for vertices in self.GRAPHS:
            axes.plot(x, [row["cbr_ms"][str(vertices)] or np.nan for row in rows], "o-",
                      label=f"CBR, {vertices} vertices")
        for method in METHODS:
            axes.plot(x, [row[f"{method}_ms"] or np.nan for row in rows], "s--",
                      label=LABELS[method])
        axes.set(xlabel="map side (cells)", ylabel="median planning time (ms)", yscale="log",
                 title="Planning times (Fig. 4)")
        axes.grid(True, which="both", alpha=0.3)
        axes.legend(fontsize="small")
        return ExperimentResult(
            results={"map": {"kind": "random", "sides": list(sides), "density": DENSITY,
                             "terrain": TERRAIN, "seed": self.seed},
                     "delta": settings.delta, "max_coverage": MAX_COVERAGE,
                     "repeats": REPEATS, "rows": rows},
            table="\n".join(lines), figures={"time_vs_map_size": figure})


# -- section 6.1: times against vertex count ----------------------------------------------------


class TimeVsVertices(_Experiment):
    """Fig. 2: CBR planning time against the vertex count, full and selective adaptation."""

    SCALE: ClassVar[dict[str, Any]] = {"ci": (64, (200, 400, 600), 30),
             "full": (200, (500, 1000, 2000, 3000, 4000, 6000, 8000), 200)}

    def run(self, size: Size, out_dir: Path, progress: Progress) -> ExperimentResult:
        side, counts, per_graph = self.SCALE[size]
        grid, cells = self._setup(side)
        region = region_mask(grid, cells)
        graph = CaseGraph(grid)
        modes = {"full": Settings(), "selective": Settings(selective=True)}
        rows: list[dict[str, Any]] = []
        for step, vertices in enumerate(counts):
            grow(graph, vertices, self.rng, cells=cells)
            tasks = cbr_tasks(graph, region, self.rng, per_graph, modes["full"])
            row: dict[str, Any] = {"vertices": graph.vertex_count, "edges": graph.edge_count,
                                   "tasks": len(tasks)}
            for name, settings in modes.items():
                seconds: list[float] = []
                planned = 0
                for s, g in tasks:
                    seconds.append(
                        median_of_runs(lambda s=s, g=g, c=settings: plan(graph, s, g, c)))
                    planned += outcome(plan(graph, s, g, settings), s, g) == "cbr"
                row[f"{name}_ms"] = median_ms(seconds)
                row[f"{name}_planned"] = planned
            rows.append(row)
            progress(step + 1, len(counts))
        lines = ["| vertices | edges | tasks | full adaptation ms | selective adaptation ms "
                 "| selective / full | selective planned |", "|---|---|---|---|---|---|---|"]
        for row in rows:
            ratio = (row["selective_ms"] / row["full_ms"]
                     if row["full_ms"] and row["selective_ms"] else None)
            lines.append(f"| {row['vertices']} | {row['edges']} | {row['tasks']} "
                         f"| {_fmt(row['full_ms'], 3)} | {_fmt(row['selective_ms'], 3)} "
                         f"| {_fmt(ratio)} | {row['selective_planned']} |")
        lines.append("")
        lines.append("The paper gives Fig. 2 only as a plot: CBR time growing with the vertex "
                     "count, selective adaptation below full adaptation.")
        figure, axes = _new_figure()
        for name in modes:
            axes.plot([r["vertices"] for r in rows], [r[f"{name}_ms"] or np.nan for r in rows],
                      "o-", label=f"{name} adaptation")
        axes.set(xlabel="vertices of the case graph", ylabel="median CBR planning time (ms)",
                 title=f"CBR planning times (Fig. 2), {side}x{side} map")
        axes.grid(True, alpha=0.3)
        axes.legend()
        return ExperimentResult(
            results={"map": _map_info(side, self.seed), "delta": Settings().delta,
                     "rows": rows},
            table="\n".join(lines), figures={"time_vs_vertices": figure})
