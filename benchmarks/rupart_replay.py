"""Does the RUPART robot get better at a day it has lived before? ``cbr-learning`` replays one
day (``delivery`` option ``replay``: the same messages and sensor noise every day) five times on
each floor, the case base carrying over, so that from day to day only what it learned changes.

    python benchmarks/rupart_replay.py [--floors 0,1,...,9] [--days 5] [--length 1800]

The floors default to 0 to 9, which no tuning saw (the tuning floors are 100 to 105).

Writes ``rupart_replay.json`` and ``rupart_replay.md`` (per floor the deliveries of each day, and
the last day against the first with its paired 95% interval).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from docfigures.provenance import head, write_results

from cbr_behaviors.experiments.delivery import arm_config, interval, run_job
from cbr_experiments.tasks import LocalTasks

ARM = "cbr-learning"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--floors", default=",".join(str(s) for s in range(10)))
    parser.add_argument("--days", type=int, default=5)
    parser.add_argument("--length", type=float, default=1800.0)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    floors = [int(s) for s in args.floors.split(",")]
    # the commit that runs, read before the runs: one made meanwhile did not
    commit = head()
    with tempfile.TemporaryDirectory() as scratch:
        jobs = []
        for seed in floors:
            config = arm_config(ARM, seed, days=args.days, length=args.length)
            config["workload"]["replay"] = True
            jobs.append((config, Path(scratch) / f"floor_{seed}"))
        runs = list(LocalTasks().map(run_job, jobs, processes=2))
    per_day = [[row["delivered"] for row in rows] for rows in runs]
    gain = interval([days[-1] - days[0] for days in per_day])
    record = {"command": f"python benchmarks/rupart_replay.py --floors {args.floors} "
              f"--days {args.days} --length {args.length:g}", "commit": commit, "arm": ARM,
              "floors": floors, "delivered": per_day, "gain": gain}
    args.out.mkdir(parents=True, exist_ok=True)
    write_results(args.out / "rupart_replay.json", record)
    lines = [f"`{ARM}` living one day {args.days} times on each floor (`replay`), "
             f"{args.length:.0f} s a day: messages delivered on time.", "",
             "| floor | " + " | ".join(f"day {d + 1}" for d in range(args.days)) + " |",
             "|---|" + "---|" * args.days]
    lines += [f"| {seed} | " + " | ".join(f"{v:.0f}" for v in days) + " |"
              for seed, days in zip(floors, per_day, strict=True)]
    lines += ["", f"Last day against the first: {gain['mean']:+.2f} a day, 95% interval "
              f"[{gain['low']:+.2f}, {gain['high']:+.2f}] over {gain['n']} floors."]
    (args.out / "rupart_replay.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
