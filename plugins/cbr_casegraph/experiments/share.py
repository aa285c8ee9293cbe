"""Section 6.2, Fig. 3 of the case graph paper: the share of random tasks planned by CBR against
the coverage of the map by graph vertices (``cbr experiment cbr-share``)."""

from __future__ import annotations

import copy
from collections.abc import Iterator
from pathlib import Path
from typing import Any, ClassVar

from cbr_casegraph.build import grow, random_task
from cbr_casegraph.experiments.common import (
    CHUNK,
    MAX_RATIO,
    Cell,
    GridExperiment,
    Progress,
    map_info,
    median_ms,
    new_figure,
    outcome,
    timed,
)
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.planner import Settings, plan
from cbr_experiments.experiment import ExperimentResult, Size

PAPER_SHARE = {6: 0.50, 10: 0.75, 15: 0.90}
"""Section 6.2: share of tasks planned by CBR at a coverage (percent of cells that are vertices)."""


Chunk = tuple[int, CaseGraph, Settings, list[tuple[Cell, Cell]]]
"""A task: the index of its coverage, the graph grown to it, the planner's settings and a chunk
of that coverage's queries."""


def plan_chunk(job: Chunk) -> tuple[int, list[tuple[str, float]]]:
    """Plan each query of a chunk on its graph: the chunk's coverage, and per query how the
    attempt ended and how long it took."""
    level, graph, settings, tasks = job
    planned = []
    for start, goal in tasks:
        result, took = timed(lambda s=start, g=goal: plan(graph, s, g, settings))
        planned.append((outcome(result, start, goal), took))
    return level, planned


def coverage_first(job: Chunk) -> float:
    """Chunks of larger coverages start first: their graphs are larger and planning on them
    is slower (about four times from 2% to 20%), so what is left for the end is short."""
    return job[0]


class Share(GridExperiment):
    """Fig. 3: share of random tasks planned by CBR against the map's coverage by vertices."""

    SCALE: ClassVar[dict[str, Any]] = {"ci": (64, (5, 10, 15), 200),
                                       "full": (200, (2, 4, 6, 8, 10, 12, 15, 20), 10000)}

    def run(self, size: Size, out_dir: Path, progress: Progress) -> ExperimentResult:
        side, coverages, queries = self.SCALE[size]
        grid, cells = self.prepare(side)
        graph = CaseGraph(grid)
        settings = Settings()
        rows: list[dict[str, Any]] = []

        def jobs() -> Iterator[Chunk]:
            # drawn here, in the order of a serial run, and read by the runner as it submits:
            # the graph grows for the next coverage while the queries of this one are planned
            paths = 0
            for level, percent in enumerate(coverages):
                paths += grow(graph, round(percent / 100 * grid.passable.size), self.rng,
                              cells=cells)
                rows.append({"coverage_percent": percent,
                             "measured_coverage": graph.coverage(),
                             "vertices": graph.vertex_count, "edges": graph.edge_count,
                             "paths_retained": paths, "queries": queries})
                tasks = [random_task(cells, self.rng) for _ in range(queries)]
                # one copy of the graph as it is now, sent once to each worker (not with each
                # chunk) and planned on there while the graph here grows on
                frozen = self.tasks.share(copy.deepcopy(graph))
                for first in range(0, queries, CHUNK):
                    yield level, frozen, settings, tasks[first:first + CHUNK]

        planned: list[list[tuple[str, float]]] = [[] for _ in coverages]
        # results come in the order of the chunks, so each coverage's outcomes keep theirs
        for level, chunk_result in self.tasks.map(plan_chunk, jobs(), progress=progress,
                                                  priority=coverage_first):
            planned[level].extend(chunk_result)
        for row, outcomes in zip(rows, planned, strict=True):
            counts: dict[str, int] = {}
            for kind, _ in outcomes:
                counts[kind] = counts.get(kind, 0) + 1
            row.update({"share": counts.get("cbr", 0) / queries, "outcomes": counts,
                        "median_plan_ms": median_ms([took for _, took in outcomes])})
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
        figure, axes = new_figure()
        axes.plot([r["measured_coverage"] * 100 for r in rows], [r["share"] for r in rows],
                  "o-", label=f"ours ({side}x{side}, {queries} tasks each)")
        axes.plot(list(PAPER_SHARE), list(PAPER_SHARE.values()), "s", color="black",
                  label="paper (section 6.2)")
        axes.set(xlabel="coverage: vertices / cells (%)", ylabel="share planned by CBR",
                 ylim=(0, 1), title="Frequency of CBR method choice (Fig. 3)")
        axes.grid(True, alpha=0.3)
        axes.legend()
        return ExperimentResult(
            results={"map": map_info(side, self.seed), "delta": settings.delta,
                     "max_ratio": MAX_RATIO, "rows": rows},
            table="\n".join(table), figures={"cbr_share": figure})
