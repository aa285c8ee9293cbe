"""The case graph's similarity radius δr (eq. 12) against CBR's cost deviation from the optimum.

The setting of ``cbr experiment deviation-table`` (:mod:`cbr_casegraph.experiments.radius`):
at δr = 0 the figures are the experiment's own CBR cost column; each δr grows its own graph.
Dijkstra's cost is the optimum, so a method's deviation from the best of the experiment's four
methods (A* and Ai* are optimal too) is its deviation from Dijkstra's cost.

    python benchmarks/casegraph_similarity_radius.py [--size ci|full] [--radii 0 1 2]
                                                     [--seed 0] [--scheduler local|ADDRESS]
                                                     [--workers N] [--out benchmarks/results]

Each radius is a task of its own: ``--scheduler`` runs them on Dask distributed, as
``cbr experiment --scheduler`` does, with the same figures. Writes
``casegraph_similarity_radius.json`` and ``.md``. ``--size full`` takes about two minutes
serially.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from docfigures.provenance import script_command, write_results

from cbr_casegraph.experiments.common import MAX_RATIO, map_info
from cbr_casegraph.experiments.deviation import DeviationTable
from cbr_casegraph.experiments.radius import RadiusTask, radius_rows
from cbr_casegraph.planner import Settings
from cbr_experiments.tasks import open_tasks
from cbrcore.errors import CbrError

RESULTS = Path(__file__).resolve().parent / "results"


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


def run(size: str, radii: list[int], seed: int, scheduler: str | None = None,
        workers: int | None = None) -> dict[str, Any]:
    side, counts, tasks = DeviationTable.SCALE[size]
    jobs = [RadiusTask(side, counts, tasks, radius, seed) for radius in radii]
    with open_tasks(scheduler, workers=workers) as runner:
        rows = [row for found in runner.map(radius_rows, jobs) for row in found]
    return {"size": size, "seed": seed, "map": map_info(side, seed), "max_ratio": MAX_RATIO,
            "delta": Settings().delta, "tasks": tasks, "rows": rows}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", choices=sorted(DeviationTable.SCALE), default="full")
    parser.add_argument("--radii", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--scheduler", help="local, or the address of a Dask scheduler")
    parser.add_argument("--workers", type=int, help="with --scheduler local: worker processes")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    if any(radius < 0 for radius in args.radii):
        parser.error("--radii: a similarity radius is a cell distance, 0 or more")
    try:
        result = run(args.size, args.radii, args.seed, args.scheduler, args.workers)
    except CbrError as exc:
        parser.error(str(exc))
    args.out.mkdir(parents=True, exist_ok=True)
    write_results(args.out / "casegraph_similarity_radius.json", result,
                  command=script_command(__file__, argv))
    (args.out / "casegraph_similarity_radius.md").write_text(markdown(result) + "\n",
                                                             encoding="utf-8")
    print(markdown(result))
    return result


if __name__ == "__main__":
    main()
