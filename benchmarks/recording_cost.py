"""What recording a run costs: the same runs with and without ``--record``, side by side.

Runs, alternating in one process, the main job (1,000 grid trips of
``configs/hybrid_grid.yaml``) and a 30-minute delivery day (``configs/rupart.yaml`` with
``workload.length=1800``), the two the 10% target is set on, and the landmark trials of
``configs/landmarks.yaml`` (10 trials), each once with the ``record`` observer and once
without, from an empty output folder each time. The ratio of the median wall times is the
recording's cost; the difference of medians divided by the trips or the simulated steps is its
cost per trip and per step. The recordings' sizes and message counts come from the last
recorded repeat.

    python benchmarks/recording_cost.py [--repeats 5] [--trips 1000] [--day 1800]
                                        [--out benchmarks/results]

Writes ``recording_cost.json`` and ``recording_cost.md`` into the output folder.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from docfigures.provenance import write_results

from cbr_recording.info import contents
from cbrcore.config import load_config
from cbrcore.engine import Engine
from cbrcore.plugins import current
from cbrcore.run import run_workload

ROOT = Path(__file__).resolve().parents[1]
TARGET = 0.10
"""The most a recording may add to a run's time."""


def _run(config: Path, overrides: list[str], out_dir: Path, record: Path | None) -> float:
    observers = [] if record is None else [{"use": "record", "file": str(record)}]
    checked = load_config(config, current().registry, overrides, observers)
    with Engine(checked, out_dir=out_dir) as engine:
        started = time.perf_counter()
        run_workload(engine, out_dir)
    return time.perf_counter() - started


def _side_by_side(config: Path, overrides: list[str], repeats: int, folder: Path
                  ) -> tuple[dict[str, list[float]], Path]:
    seconds: dict[str, list[float]] = {"off": [], "on": []}
    record = folder / "missing.mcap"
    for repeat in range(repeats):
        # alternate the order so drift on a noisy machine hits both sides alike
        for side in (("off", "on") if repeat % 2 == 0 else ("on", "off")):
            out = folder / f"{side}{repeat}"
            record = folder / f"{side}{repeat}.mcap"
            seconds[side].append(_run(config, overrides, out,
                                      record if side == "on" else None))
    return seconds, folder / f"on{repeats - 1}.mcap"


def _measure(name: str, config: Path, overrides: list[str], repeats: int, units: int,
             unit: str, *, targeted: bool = True) -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        _run(config, overrides, folder / "warm", None)  # compiles and caches kernels
        seconds, recording = _side_by_side(config, overrides, repeats, folder)
        found = contents(recording)
        size = recording.stat().st_size
    off, on = statistics.median(seconds["off"]), statistics.median(seconds["on"])
    return {"name": name, "targeted": targeted,
            "config": str(config.relative_to(ROOT)), "overrides": overrides,
            "seconds_off": seconds["off"], "seconds_on": seconds["on"],
            "median_off": off, "median_on": on, "ratio": on / off,
            f"overhead_us_per_{unit}": (on - off) / units * 1e6, "unit": unit,
            "units": units, "bytes": size, "bytes_per_" + unit: size / units,
            "messages": sum(t.count for t in found.topics),
            "topics": {t.name: t.count for t in found.topics}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--trips", type=int, default=1000)
    parser.add_argument("--day", type=float, default=1800.0,
                        help="The delivery day's length in simulated seconds.")
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    args = parser.parse_args()
    runs = [
        _measure("grid trips", ROOT / "configs/hybrid_grid.yaml",
                 [f"workload.count={args.trips}"], args.repeats, args.trips, "trip"),
        # 0.1 s a step: the delivery workload's simulation step
        _measure("delivery day", ROOT / "configs/rupart.yaml",
                 [f"workload.length={args.day:g}"], args.repeats, round(args.day / 0.1),
                 "step"),
        _measure("landmark trials", ROOT / "configs/landmarks.yaml", ["workload.repeat=10"],
                 args.repeats, 10, "trial", targeted=False),
    ]
    result = {"repeats": args.repeats, "target": TARGET, "runs": runs,
              "met": all(run["ratio"] <= 1 + TARGET for run in runs if run["targeted"])}
    args.out.mkdir(parents=True, exist_ok=True)
    write_results(args.out / "recording_cost.json", result)
    lines = ["| run | median s, off | median s, recorded | ratio | overhead | file | messages |",
             "|---|---|---|---|---|---|---|"]
    # the target's runs first; the landmark trials are shown beside them, outside it
    for run in runs:
        unit = run["unit"]
        lines.append(
            f"| {run['name']} ({run['units']} {unit}s){'' if run['targeted'] else ', no target'}"
            f" | {run['median_off']:.2f} | "
            f"{run['median_on']:.2f} | {run['ratio']:.3f} | "
            f"{run[f'overhead_us_per_{unit}']:.1f} µs a {unit} | "
            f"{run['bytes'] / 1e6:.1f} MB ({run['bytes_per_' + unit]:.0f} B a {unit}) | "
            f"{run['messages']} |")
    table = "\n".join(lines)
    (args.out / "recording_cost.md").write_text(table + "\n", encoding="utf-8")
    print(table)


if __name__ == "__main__":
    main()
