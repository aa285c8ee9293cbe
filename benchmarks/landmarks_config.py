"""Does the shipped landmark configuration hold on worlds it was not made for?
``configs/landmarks.yaml`` (002's CBR agent with its hand-made cases, learning as it goes) runs
unchanged but for the world on generated scenario worlds of every shape
(``world2d_generated``, kind ``scenario``), each world a run of its own with a fresh case base,
the trials repeated as the configuration says.

    python benchmarks/landmarks_config.py [--seeds 200,...,253] [--looked-at 200,...,241]
                                          [--repeat 10]

The seeds default to 200 to 253, nine worlds of each shape; those of ``--looked-at`` (200 to
241) were looked at while the configuration and the family's defaults were chosen, the others
are held out.

Writes ``landmarks_config.json`` and ``landmarks_config.md`` (per world its shape, the trials
that reached the target and their times).
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import tempfile
from pathlib import Path

import yaml
from docfigures.provenance import head, write_results

from cbr_world2d.generate import SCENES

CONFIG = Path(__file__).resolve().parent.parent / "configs" / "landmarks.yaml"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default=",".join(str(s) for s in range(200, 254)))
    parser.add_argument("--looked-at", default=",".join(str(s) for s in range(200, 242)))
    parser.add_argument("--repeat", type=int, default=10)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    looked_at = {int(s) for s in args.looked_at.split(",") if s}
    commit = head()
    shipped = yaml.safe_load(CONFIG.read_text(encoding="utf-8"))
    worlds = []
    with tempfile.TemporaryDirectory() as scratch:
        for seed in seeds:
            config = {**shipped, "world": {"use": "world2d_generated", "kind": "scenario",
                                           "seed": seed},
                      "workload": {**shipped["workload"], "repeat": args.repeat,
                                   "trajectories": False}}
            # the initial case base is named relative to the configuration's folder
            config["casebase"] = {**shipped["casebase"], "initial": str(
                (CONFIG.parent / shipped["casebase"]["initial"]).resolve())}
            path = Path(scratch) / f"world_{seed}.yaml"
            path.write_text(yaml.safe_dump(config), encoding="utf-8")
            out = Path(scratch) / f"run_{seed}"
            subprocess.run(["cbr", "run", str(path), "--out", str(out)], check=True,
                           capture_output=True)
            with (out / "trials.csv").open(encoding="utf-8") as handle:
                rows = list(csv.DictReader(handle))
            worlds.append({"seed": seed, "shape": SCENES[seed % len(SCENES)],
                           "held_out": seed not in looked_at,
                           "reached": sum(row["success"] == "True" for row in rows),
                           "trials": len(rows),
                           "times": [float(row["time"]) for row in rows]})
    reached = sum(w["reached"] for w in worlds)
    trials = sum(w["trials"] for w in worlds)
    record = {"command": f"python benchmarks/landmarks_config.py --seeds {args.seeds} "
              f"--looked-at {args.looked_at} --repeat {args.repeat}", "commit": commit,
              "worlds": worlds}
    args.out.mkdir(parents=True, exist_ok=True)
    write_results(args.out / "landmarks_config.json", record)
    lines = ["`configs/landmarks.yaml` on generated scenario worlds, unchanged but for the "
             f"world: {reached} of {trials} trials reached the target.", "",
             "| world seed | shape | held out | reached | time of each trial (s) |",
             "|---|---|---|---|---|"]
    lines += [f"| {w['seed']} | {w['shape']} | {'yes' if w['held_out'] else 'no'} | "
              f"{w['reached']} of {w['trials']} | "
              + ", ".join(f"{t:.0f}" for t in w["times"]) + " |" for w in worlds]
    (args.out / "landmarks_config.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
