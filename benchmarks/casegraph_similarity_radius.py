"""The case graph's similarity radius δr (eq. 12) against CBR's cost deviation from the optimum.

The setting of ``cbr experiment deviation-table``: its map, its graphs (grown step by step to
its vertex counts from Dijkstra paths of random tasks) and its random tasks, drawn from the same
seeded generator in the same order, so that at δr = 0 the figures are the experiment's own CBR
cost column. Only the growth differs: each δr grows its own graph with
``CaseGraph.add_path(path, similarity_delta=δr)``. Each task is planned by the hybrid planner
(CBR, Dijkstra where CBR fails or its path is rejected by the quality test) and by Dijkstra.
Dijkstra's cost is the optimum, so a method's deviation from the best of the experiment's four
methods (A* and Ai* are optimal too) is its deviation from Dijkstra's cost.

    python benchmarks/casegraph_similarity_radius.py [--size ci|full] [--radii 0 1 2]
                                                     [--seed 0] [--out benchmarks/results]

Writes ``casegraph_similarity_radius.json`` and ``.md``. ``--size full`` takes about two minutes.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from cbr_casegraph.build import connected_cells, grow, random_task
from cbr_casegraph.experiments.common import (
    MAX_RATIO,
    make_map,
    map_info,
    outcome,
    solve,
    warm_up,
)
from cbr_casegraph.experiments.deviation import DeviationTable, deviations
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.planner import Plan, Settings, plan
from cbr_grid.costs import path_cost

RESULTS = Path(__file__).resolve().parent / "results"


def experiment_rng(seed: int) -> np.random.Generator:
    """The generator ``cbr experiment`` hands an experiment for ``--seed seed``."""
    return np.random.default_rng(seed).spawn(1)[0]


def radius_rows(side: int, counts: tuple[int, ...], tasks: int, radius: int, seed: int
                ) -> list[dict[str, Any]]:
    """One row per vertex count: CBR's share and mean cost deviation with ``radius``."""
    rng = experiment_rng(seed)
    grid = make_map(side, seed)
    cells = connected_cells(grid, rng)
    warm_up(grid, cells, rng)
    graph = CaseGraph(grid)
    settings = Settings()
    rows = []
    for vertices in counts:
        paths = grow(graph, vertices, rng, cells=cells, similarity_delta=radius)
        hybrid: list[float] = []
        alone: list[float] = []
        for _ in range(tasks):
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
        rows.append({"radius": radius, "target_vertices": vertices,
                     "vertices": graph.vertex_count, "coverage": graph.coverage(),
                     "paths_retained": paths, "tasks": tasks,
                     "cbr_share": len(alone) / tasks,
                     "cost_deviation": float(np.mean(hybrid)),
                     "cbr_only_cost_deviation": float(np.mean(alone)) if alone else None})
    return rows


def markdown(result: dict[str, Any]) -> str:
    """The table of ``result``: one row per radius and vertex count."""
    lines = ["| δr | vertices (coverage) | CBR share | CBR cost deviation (%) "
             "| on the tasks CBR planned (%) |", "|---|---|---|---|---|"]
    for row in result["rows"]:
        alone = row["cbr_only_cost_deviation"]
        lines.append(f"| {row['radius']} | {row['vertices']} ({row['coverage'] * 100:.1f}%) "
                     f"| {row['cbr_share']:.3f} | {row['cost_deviation']:.2f} "
                     f"| {'-' if alone is None else f'{alone:.2f}'} |")
    return "\n".join(lines)


def run(size: str, radii: list[int], seed: int) -> dict[str, Any]:
    side, counts, tasks = DeviationTable.SCALE[size]
    rows = [row for radius in radii for row in radius_rows(side, counts, tasks, radius, seed)]
    return {"size": size, "seed": seed, "map": map_info(side, seed), "max_ratio": MAX_RATIO,
            "delta": Settings().delta, "tasks": tasks, "rows": rows}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", choices=sorted(DeviationTable.SCALE), default="full")
    parser.add_argument("--radii", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    if any(radius < 0 for radius in args.radii):
        parser.error("--radii: a similarity radius is a cell distance, 0 or more")
    result = run(args.size, args.radii, args.seed)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "casegraph_similarity_radius.json").write_text(
        json.dumps(result, indent=2) + "\n", encoding="utf-8")
    (args.out / "casegraph_similarity_radius.md").write_text(markdown(result) + "\n",
                                                             encoding="utf-8")
    print(markdown(result))
    return result


if __name__ == "__main__":
    main()
