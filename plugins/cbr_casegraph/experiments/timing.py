"""The planning-time reproductions of the case graph paper: section 6.3, Fig. 4, times against
the map size (``cbr experiment time-vs-map-size``), and section 6.1, Fig. 2, times against the
vertex count (``cbr experiment time-vs-vertices``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from cbr_casegraph.build import grow
from cbr_casegraph.experiments.common import (
    DENSITY,
    LABELS,
    METHODS,
    REPEATS,
    TERRAIN,
    Cell,
    GridExperiment,
    Progress,
    cbr_tasks,
    fmt,
    map_info,
    median_ms,
    median_of_runs,
    new_figure,
    outcome,
    region_mask,
    solve,
    timed,
)
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.planner import Settings, plan
from cbr_experiments.experiment import ExperimentResult, Size
from cbr_grid.distances import octile

# -- section 6.3: times against map size ------------------------------------------------------

MAX_COVERAGE = 0.5
"""The largest share of a map's reachable cells a test graph may take as vertices: beyond it
the graph is no longer a network of paths but fills the map (and growing it stalls)."""


class TimeVsMapSize(GridExperiment):
    """Fig. 4: CBR (1000/2000/3000 vertices) and Dijkstra, A*, Ai* planning times by map size."""

    SCALE: ClassVar[dict[str, Any]] = {"ci": ((50, 100, 200), 10),
             "full": ((*range(50, 601, 50), 1000), 20)}
    GRAPHS = (1000, 2000, 3000)

    def run(self, size: Size, out_dir: Path, progress: Progress) -> ExperimentResult:
        sides, per_graph = self.SCALE[size]
        settings = Settings()
        rows: list[dict[str, Any]] = []
        progress(0, len(sides))
        for step, side in enumerate(sides):
            grid, cells = self.prepare(side)
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
            row["octile_median"] = (float(np.median([float(octile(s, g)) for s, g in queries]))
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
            cbr = " | ".join(fmt(row["cbr_ms"][str(v)], 3) for v in self.GRAPHS)
            lines.append(f"| {row['size']}x{row['size']} | {cbr} | {fmt(row['dijkstra_ms'], 3)} "
                         f"| {fmt(row['astar_ms'], 3)} | {fmt(row['aistar_ms'], 3)} "
                         f"| {sum(row['tasks'].values())} | {fmt(row['octile_median'], 1)} |")
        lines.append("")
        lines.append("The paper gives Fig. 4 only as a plot (600x600 at most): CBR times nearly "
                     "flat in the map size and set by the vertex count, the alternative methods' "
                     "times growing steeply.")
        figure, axes = new_figure()
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


class TimeVsVertices(GridExperiment):
    """Fig. 2: CBR planning time against the vertex count, full and selective adaptation."""

    SCALE: ClassVar[dict[str, Any]] = {"ci": (64, (200, 400, 600), 30),
             "full": (200, (500, 1000, 2000, 3000, 4000, 6000, 8000), 200)}

    def run(self, size: Size, out_dir: Path, progress: Progress) -> ExperimentResult:
        side, counts, per_graph = self.SCALE[size]
        grid, cells = self.prepare(side)
        region = region_mask(grid, cells)
        graph = CaseGraph(grid)
        modes = {"full": Settings(), "selective": Settings(selective=True)}
        rows: list[dict[str, Any]] = []
        progress(0, len(counts))
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
                         f"| {fmt(row['full_ms'], 3)} | {fmt(row['selective_ms'], 3)} "
                         f"| {fmt(ratio)} | {row['selective_planned']} |")
        lines.append("")
        lines.append("The paper gives Fig. 2 only as a plot: CBR time growing with the vertex "
                     "count, selective adaptation below full adaptation.")
        figure, axes = new_figure()
        for name in modes:
            axes.plot([r["vertices"] for r in rows], [r[f"{name}_ms"] or np.nan for r in rows],
                      "o-", label=f"{name} adaptation")
        axes.set(xlabel="vertices of the case graph", ylabel="median CBR planning time (ms)",
                 title=f"CBR planning times (Fig. 2), {side}x{side} map")
        axes.grid(True, alpha=0.3)
        axes.legend()
        return ExperimentResult(
            results={"map": map_info(side, self.seed), "delta": Settings().delta,
                     "rows": rows},
            table="\n".join(lines), figures={"time_vs_vertices": figure})
