"""Section 6.4, Table 1 and Fig. 5 of the case graph paper: the hybrid planner, Dijkstra, A* and
Ai* against the best of the four in path cost, length and turns
(``cbr experiment deviation-table``)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from cbr_casegraph.build import grow, random_task
from cbr_casegraph.experiments.common import (
    LABELS,
    MAX_RATIO,
    METHODS,
    Cell,
    GridExperiment,
    Progress,
    chunked,
    fmt,
    map_info,
    new_figure,
    outcome,
    solve,
)
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.planner import Plan, Settings, plan
from cbr_experiments.experiment import ExperimentResult, Size
from cbr_grid.costs import path_cost, path_length, turns

if TYPE_CHECKING:
    from matplotlib.figure import Figure

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

CHUNK = 100
"""Tasks per chunk spread over processes: each measures four planners, so fewer than the
cbr-share experiment's queries make a task of the same weight."""

TIE = 1e-9
"""Relative difference under which two values count as equal: optimal paths found by different
searches sum the same step costs in a different order."""


def deviations(values: dict[str, float]) -> dict[str, float]:
    """Each method's deviation (%) from the best (least) value.

    A best value of 0 (a straight path has no turns) would leave the ratio undefined: it is
    then taken relative to 1, so one extra turn counts 100%.
    """
    best = min(values.values())
    scale = 1.0 if best == 0 else best
    return {name: 0.0 if value - best <= TIE * scale else (value - best) / scale * 100
            for name, value in values.items()}


def measure_chunk(job: tuple[CaseGraph, Settings, list[tuple[Cell, Cell]]]
                  ) -> list[tuple[bool, dict[str, dict[str, float]]]]:
    """Per task of a chunk: whether CBR planned it, and each method's deviation from the best
    cost, length and turns."""
    graph, settings, tasks = job
    grid = graph.grid
    measured = []
    for start, goal in tasks:
        paths = {m: solve(m, grid, start, goal).path for m in METHODS}
        result = plan(graph, start, goal, settings)
        by_cbr = isinstance(result, Plan) and outcome(result, start, goal) == "cbr"
        # the hybrid planner falls back to its alternative method, Dijkstra
        paths["cbr"] = result.path if isinstance(result, Plan) and by_cbr else (
            paths["dijkstra"])
        values = {
            "cost": {m: path_cost(grid, p) for m, p in paths.items()},
            "length": {m: path_length(p) for m, p in paths.items()},
            "turns": {m: float(turns(p)) for m, p in paths.items()},
        }
        measured.append((by_cbr, {parameter: deviations(found)
                                  for parameter, found in values.items()}))
    return measured


class DeviationTable(GridExperiment):
    """Table 1: deviation of CBR (with Dijkstra fallback), Dijkstra, A* and Ai* from the best."""

    SCALE: ClassVar[dict[str, Any]] = {"ci": (64, (200, 400), 60),
                                       "full": (200, (2000, 4000, 6000, 8000), 1000)}
    PARAMETERS = ("cost", "length", "turns")

    def run(self, size: Size, out_dir: Path, progress: Progress) -> ExperimentResult:
        side, counts, tasks = self.SCALE[size]
        grid, cells = self.prepare(side)
        graph = CaseGraph(grid)
        settings = Settings()
        rows: list[dict[str, Any]] = []
        levels: list[int] = []

        def jobs() -> Iterator[tuple[CaseGraph, Settings, list[tuple[Cell, Cell]]]]:
            # drawn here in the order of a serial run; the graph grows on while the tasks of
            # the count before are measured
            for vertices in counts:
                grow(graph, vertices, self.rng, cells=cells)
                rows.append({"vertices": graph.vertex_count, "target_vertices": vertices,
                             "coverage": graph.coverage(), "tasks": tasks})
                drawn = [random_task(cells, self.rng) for _ in range(tasks)]
                for frozen, chunk in chunked(graph, drawn, CHUNK):
                    levels.append(len(rows) - 1)
                    yield frozen, settings, chunk

        results = self.tasks.map(measure_chunk, jobs(), progress=progress)
        measured: list[list[tuple[bool, dict[str, dict[str, float]]]]] = [[] for _ in counts]
        for level, chunk_result in zip(levels, results, strict=True):
            measured[level].extend(chunk_result)
        for row, level in zip(rows, measured, strict=True):
            # summed here, task by task, so that the sums do not depend on the chunks
            sums = {(m, p): 0.0 for m in ("cbr", *METHODS) for p in self.PARAMETERS}
            alone: list[float] = []
            for by_cbr, found in level:
                for parameter, values in found.items():
                    for method, deviation in values.items():
                        sums[method, parameter] += deviation
                if by_cbr:
                    alone.append(found["cost"]["cbr"])
            planned = sum(by_cbr for by_cbr, _ in level)
            row.update({
                "cbr_share": planned / tasks,
                "cbr_only_cost_deviation": float(np.mean(alone)) if alone else None,
                "deviation": {LABELS[m]: {p: sums[m, p] / tasks for p in self.PARAMETERS}
                              for m in ("cbr", *METHODS)}})
        return ExperimentResult(
            results={"map": map_info(side, self.seed), "delta": settings.delta,
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
                         f"| {fmt(row['cbr_only_cost_deviation'])} |")
        return "\n".join(lines)

    def _figure(self, rows: list[dict[str, Any]]) -> Figure:
        figure, axes = new_figure()
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
