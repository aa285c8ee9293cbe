"""The fleet experiment at a scale between its ci and full sizes: one fleet size, a given map side
and number of trips, for measuring throughput and integrity without the hours a full run takes.

    python benchmarks/fleet_scale.py --side 100 --robots 1,2 --trips 1000 --out runs/fleet-1-2
    python benchmarks/fleet_scale.py --side 100 --robots 8 --trips 10000 --out runs/fleet-8

Writes the experiment's ``results.json`` and ``results.md`` into ``--out``; the table is printed.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from cbr_casegraph.experiments.fleet import Fleet, Scale
from cbrcore.context import Context
from cbrcore.plugins import current


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--side", type=int, default=100, help="side of the office, in cells")
    parser.add_argument("--robots", default="1,2", help="fleet sizes, comma-separated")
    parser.add_argument("--trips", type=int, default=1000, help="trips each fleet drives in all")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    plugins = current()
    fleet = Fleet(None, Context(registry=plugins.registry, seed=args.seed))
    robots = tuple(int(n) for n in args.robots.split(","))
    fleet.SCALES = {"full": Scale(args.side, robots, args.trips)}
    args.out.mkdir(parents=True, exist_ok=True)
    result = fleet.run("full", args.out, lambda done, total: print(f"{done}/{total}", flush=True))
    (args.out / "results.json").write_text(json.dumps(result.results, indent=2) + "\n",
                                           encoding="utf-8")
    (args.out / "results.md").write_text(result.table, encoding="utf-8")
    print(result.table)


if __name__ == "__main__":
    main()
