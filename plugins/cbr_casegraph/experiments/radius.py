"""The similarity radius δr (eq. 12) against CBR's cost deviation, one radius a task.

The setting of ``cbr experiment deviation-table``: its map, its graphs (grown step by step to
its vertex counts from Dijkstra paths of random tasks) and its random tasks, drawn from the same
seeded generator in the same order, so that at δr = 0 the figures are the experiment's own CBR
cost column. Only the growth differs: each δr grows its own graph with
``CaseGraph.add_path(path, similarity_delta=δr)``. ``benchmarks/casegraph_similarity_radius.py``
runs one task per radius, on a Dask cluster when asked.
"""

from __future__ import annotations

from typing import Any

import attrs
import numpy as np

from cbr_casegraph.build import connected_cells, grow, random_task
from cbr_casegraph.experiments.common import make_map, outcome, solve, warm_up
from cbr_casegraph.experiments.deviation import deviations
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.planner import Plan, Settings, plan
from cbr_grid.costs import path_cost


@attrs.frozen
class RadiusTask:
    """One radius of the sweep: the deviation table's scale and seed, and δr."""

    side: int
    counts: tuple[int, ...]
    tasks: int
    radius: int
    seed: int


def experiment_rng(seed: int) -> np.random.Generator:
    """The generator ``cbr experiment`` hands an experiment for ``--seed seed``."""
    return np.random.default_rng(seed).spawn(1)[0]


def radius_rows(task: RadiusTask) -> list[dict[str, Any]]:
    """One row per vertex count: CBR's share and mean cost deviation with ``task.radius``.

    The hybrid planner (CBR, Dijkstra where CBR fails or its path is rejected by the quality
    test) against Dijkstra, whose cost is the optimum.
    """
    rng = experiment_rng(task.seed)
    grid = make_map(task.side, task.seed)
    cells = connected_cells(grid, rng)
    warm_up(grid, cells, rng)
    graph = CaseGraph(grid)
    settings = Settings()
    rows = []
    for vertices in task.counts:
        paths = grow(graph, vertices, rng, cells=cells, similarity_delta=task.radius)
        hybrid: list[float] = []
        alone: list[float] = []
        for _ in range(task.tasks):
            start, goal = random_task(cells, rng)
            optimal = solve("dijkstra", grid, start, goal).path
            result = plan(graph, start, goal, settings)
            by_cbr = isinstance(result, Plan) and outcome(result, start, goal) == "cbr"
            path = result.path if isinstance(result, Plan) and by_cbr else optimal
            deviation = deviations({"cbr": path_cost(grid, path),
                                    "dijkstra": path_cost(grid, optimal)})["cbr"]
            hybrid.append(deviation)
            if by_cbr:
                alone.append(deviation)
        rows.append({"radius": task.radius, "target_vertices": vertices,
                     "vertices": graph.vertex_count, "coverage": graph.coverage(),
                     "paths_retained": paths, "tasks": task.tasks,
                     "cbr_share": len(alone) / task.tasks,
                     "cost_deviation": float(np.mean(hybrid)),
                     "cbr_only_cost_deviation": float(np.mean(alone)) if alone else None})
    return rows
