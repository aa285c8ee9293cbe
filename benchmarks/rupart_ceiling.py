"""How many messages can a delivery day hold? The best fixed set on each held-out floor as it
is; with its doors only: nobody walking, no transient objects and exact odometry, the doors
shut and open on their schedules; and cleared: every door open as well, so that nothing but the
route and the schedule of messages stands between the robot and its deliveries.

    python benchmarks/rupart_ceiling.py [--floors 0,1,...,9] [--days 5] [--length 1800]
                                        [--rate 30]

The cleared floor bounds what a controller built from the same behaviors can deliver on that
floor, and the floor with its doors only what one can deliver that has to wait at shut doors
as every arm does; the experiment's arms are read against them (docs/rupart.md, "How much room there
is"). The floors default to 0 to 9, which no tuning saw.

Writes ``rupart_ceiling.json`` and ``rupart_ceiling.md``.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
from docfigures.provenance import head, write_results

from cbr_behaviors.experiments.delivery import arm_config, run_job
from cbr_experiments.tasks import LocalTasks

ARM = "best-fixed"
KINDS: dict[str, dict[str, object]] = {
    "as is": {},
    "doors only": {"people": 0, "objects": 0},
    "cleared": {"people": 0, "objects": 0, "doors_open": True},
}
"""The floors: what each changes in the world's generator options (all but the first with
exact odometry as well)."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--floors", default=",".join(str(s) for s in range(10)))
    parser.add_argument("--days", type=int, default=5)
    parser.add_argument("--length", type=float, default=1800.0)
    parser.add_argument("--rate", type=float, default=None,
                        help="messages an hour (default: the delivery workload's)")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    floors = [int(s) for s in args.floors.split(",")]
    commit = head()
    kinds = tuple(KINDS)
    with tempfile.TemporaryDirectory() as scratch:
        jobs = []
        for kind in kinds:
            for seed in floors:
                config = arm_config(ARM, seed, days=args.days, length=args.length)
                if args.rate is not None:
                    config["workload"]["rate"] = args.rate
                if KINDS[kind]:
                    config["world"] = {**config["world"], **KINDS[kind]}
                    config["workload"]["odometry_noise"] = 0.0
                jobs.append((config, Path(scratch) / f"{kind}_{seed}".replace(" ", "_")))
        runs = list(LocalTasks().map(run_job, jobs, processes=2))
    per_floor = {kind: runs[k * len(floors):(k + 1) * len(floors)]
                 for k, kind in enumerate(kinds)}

    def mean(kind: str, key: str) -> float:
        return float(np.mean([np.mean([row[key] for row in rows]) for rows in per_floor[kind]]))

    table = {kind: {key: mean(kind, key) for key in ("delivered", "missed", "unfinished",
                                                     "busy_speed")} for kind in kinds}
    messages = table["as is"]["delivered"] + table["as is"]["missed"] + \
        table["as is"]["unfinished"]
    rate = "" if args.rate is None else f" --rate {args.rate:g}"
    record = {"command": f"python benchmarks/rupart_ceiling.py --floors {args.floors} "
              f"--days {args.days} --length {args.length:g}{rate}", "commit": commit,
              "arm": ARM, "floors": floors, "messages": messages, "table": table,
              "delivered": {kind: [[row["delivered"] for row in rows]
                                   for rows in per_floor[kind]] for kind in kinds}}
    args.out.mkdir(parents=True, exist_ok=True)
    write_results(args.out / "rupart_ceiling.json", record)
    lines = [f"`{ARM}` on floors {args.floors}, {args.days} day(s) of {args.length:.0f} s: "
             f"{messages:.2f} messages a day arrive.", "",
             "| floor | delivered | missed | unfinished | busy m/s |", "|---|---|---|---|---|"]
    lines += [f"| {kind} | {row['delivered']:.2f} | {row['missed']:.2f} | "
              f"{row['unfinished']:.2f} | {row['busy_speed']:.3f} |"
              for kind, row in table.items()]
    base = table["as is"]["delivered"]
    lines += [""] + [f"- {kind.capitalize()}: {table[kind]['delivered'] / messages:.0%} of the "
                     f"messages, {table[kind]['delivered'] / base:.2f} times what the best fixed "
                     "set delivers on the floor as it is." for kind in kinds[1:]]
    (args.out / "rupart_ceiling.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
