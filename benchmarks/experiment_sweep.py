"""A whole experiment, serially and on a Dask LocalCluster: the speed-up and identical results.

Target: the full ``cbr-share`` experiment (section 6.2 of the case graph paper: a 200x200 map,
graphs grown to eight coverages, 10,000 queries planned at each) on a LocalCluster finishes at
least 1.7x faster than serially on a 2-core machine, with identical results.

Both runs are made in this one process, one after the other (``--order`` says which first), each
writing the experiment's files into its own folder: the serial one with no task runner given (as
``cbr experiment cbr-share --size full``), the other with a LocalCluster of ``--workers``
processes of one thread each (as ``--scheduler local``). A run's time includes everything
``cbr experiment`` would do, the cluster's start and shutdown included; the cluster's start alone
is given too, and so is each run's CPU time over all its processes, which shows what the cluster
costs beyond the serial run's work even where other work on the machine makes wall times
unreliable. The two results.json are then compared key by key: equal except for the fields
that hold measured times (:data:`TIMED`), which no two runs share.

    python benchmarks/experiment_sweep.py [--experiment cbr-share] [--size full] [--seed 0]
                                          [--workers N] [--order serial-first|dask-first]
                                          [--out benchmarks/results]

Writes ``experiment_sweep.json`` and ``experiment_sweep.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import tempfile
import time
from pathlib import Path
from typing import Any

from docfigures.provenance import write_results

from cbr_experiments.experiment import run_experiment
from cbr_experiments.tasks import TaskRunner, open_tasks
from cbrcore.plugins import current

TIMED = frozenset({"median_plan_ms"})
"""Keys of results.json that hold measured wall times."""


def untimed(value: Any) -> Any:
    """``value`` without the keys of :data:`TIMED`, at any depth."""
    if isinstance(value, dict):
        return {k: untimed(v) for k, v in value.items() if k not in TIMED}
    if isinstance(value, list):
        return [untimed(v) for v in value]
    return value


def differences(a: Any, b: Any, where: str = "") -> list[str]:
    """Where ``a`` and ``b`` differ, as JSON paths (empty when equal)."""
    if isinstance(a, dict) and isinstance(b, dict):
        found = [f"{where}.{k}: only in one" for k in a.keys() ^ b.keys()]
        for key in a.keys() & b.keys():
            found += differences(a[key], b[key], f"{where}.{key}")
        return found
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for k, (x, y) in enumerate(zip(a, b, strict=True))
                for d in differences(x, y, f"{where}[{k}]")]
    return [] if a == b else [f"{where}: {a!r} != {b!r}"]


def cpu_seconds() -> float:
    """CPU time of this process and of its children that have ended (a LocalCluster's workers,
    once it is shut down): unlike wall time, what other work on the machine barely changes."""
    own, children = (resource.getrusage(who) for who in (resource.RUSAGE_SELF,
                                                          resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def timed_run(name: str, size: str, seed: int, out_dir: Path, tasks: TaskRunner | None
              ) -> tuple[float, dict[str, Any]]:
    began = time.perf_counter()
    run_experiment(name, current(), size=size, out_dir=out_dir, seed=seed,  # type: ignore[arg-type]
                   tasks=tasks)
    seconds = time.perf_counter() - began
    return seconds, json.loads((out_dir / "results.json").read_text(encoding="utf-8"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--experiment", default="cbr-share")
    parser.add_argument("--size", choices=("ci", "full"), default="full")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--order", choices=("serial-first", "dask-first"),
                        default="serial-first")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    name, size, seed = args.experiment, args.size, args.seed
    timings: dict[str, float] = {}
    cpu_used: dict[str, float] = {}
    results: dict[str, dict[str, Any]] = {}
    # the machine may be shared: its load says how far the wall times can be trusted
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as scratch:
        def serial() -> None:
            cpu = cpu_seconds()
            timings["serial"], results["serial"] = timed_run(
                name, size, seed, Path(scratch) / "serial", None)
            cpu_used["serial"] = cpu_seconds() - cpu

        def dask() -> None:
            cpu = cpu_seconds()
            began = time.perf_counter()
            with open_tasks("local", workers=args.workers) as tasks:
                timings["cluster_start"] = time.perf_counter() - began
                _, results["dask"] = timed_run(name, size, seed, Path(scratch) / "dask", tasks)
            timings["dask"] = time.perf_counter() - began
            cpu_used["dask"] = cpu_seconds() - cpu

        for step in ((serial, dask) if args.order == "serial-first" else (dask, serial)):
            step()
    load_after = os.getloadavg()[0]
    found = differences(untimed(results["serial"]), untimed(results["dask"]))
    speedup = timings["serial"] / timings["dask"]
    report = {
        "experiment": name, "size": size, "seed": seed, "workers": args.workers,
        "cores": os.cpu_count(), "machine": platform.machine(), "python": platform.python_version(),
        "order": args.order, "serial_seconds": timings["serial"],
        "dask_seconds": timings["dask"], "cluster_start_seconds": timings["cluster_start"],
        "serial_cpu_seconds": cpu_used["serial"], "dask_cpu_seconds": cpu_used["dask"],
        "load_average_before": load_before, "load_average_after": load_after,
        "speedup": speedup, "target_speedup": 1.7, "identical": not found,
        "differences": found[:20], "timed_fields_ignored": sorted(TIMED),
    }
    args.out.mkdir(parents=True, exist_ok=True)
    write_results(args.out / "experiment_sweep.json", report)
    lines = [
        f"`{name}` at size {size}, seed {seed}, on {os.cpu_count()} cores: serially, and on a "
        f"Dask LocalCluster of {args.workers} worker processes (one thread each; its start and "
        "shutdown included).", "",
        "| run | seconds | CPU seconds (all processes) |", "|---|---|---|",
        f"| serial | {timings['serial']:.1f} | {cpu_used['serial']:.1f} |",
        f"| LocalCluster, {args.workers} workers | {timings['dask']:.1f} "
        f"| {cpu_used['dask']:.1f} |",
        f"| of which the cluster's start | {timings['cluster_start']:.1f} | |", "",
        f"Load average (1 min) before and after: {load_before:.1f}, {load_after:.1f}.", "",
        f"Speed-up: **{speedup:.2f}x** (target: at least 1.7x). Results identical "
        f"(results.json but for the measured times {', '.join(sorted(TIMED))}): "
        f"**{'yes' if not found else 'no'}**.",
    ]
    if found:
        lines += ["", "First differences:", ""] + [f"- `{d}`" for d in found[:20]]
    (args.out / "experiment_sweep.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
