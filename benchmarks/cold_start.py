"""What a first run costs: ``cbr run`` with an empty kernel cache (cold) beside the same run with
the cache filled (warm).

Each repeat runs the configuration cold, in a fresh ``CBR_CACHE_DIR``, then warm, in the cache
folder that cold run filled, each as its own ``python -m cbrcore run`` process into a fresh
output folder. It reports the median wall time of both, their ratio, the median time from the
process's start to the compile notice on stderr (the cold runs' first line), and checks that
the warm runs write no notice.

    python benchmarks/cold_start.py [--config configs/hybrid_grid.yaml] [--count 20]
                                    [--repeats 3] [--out benchmarks/results]

Writes ``cold_start.json`` and ``cold_start.md`` into the output folder.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from docfigures.provenance import head, write_results

ROOT = Path(__file__).resolve().parents[1]
NOTICE = "cbr: compiling the kernels"


def _run(config: Path, count: int, cache: Path, out: Path) -> dict[str, Any]:
    """One ``cbr run`` process: its wall time, its processor time (user and system: on a busy
    machine the steadier figure), when its compile notice came (None: none did)."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["CBR_CACHE_DIR"] = str(cache)
    command = [sys.executable, "-m", "cbrcore", "run", str(config), "--set",
               f"workload.count={count}", "--out", str(out)]
    notice: list[float] = []
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    process = subprocess.Popen(command, cwd=ROOT, env=env, stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True)

    def read() -> None:
        assert process.stderr is not None
        for line in process.stderr:
            if line.startswith(NOTICE) and not notice:
                notice.append(time.perf_counter() - started)

    reader = threading.Thread(target=read)
    reader.start()
    code = process.wait()
    seconds = time.perf_counter() - started
    reader.join()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if code != 0:
        raise SystemExit(f"{' '.join(command)} exited with {code}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"seconds": seconds, "cpu_seconds": cpu,
            "notice_seconds": notice[0] if notice else None}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, default=ROOT / "configs" / "hybrid_grid.yaml")
    parser.add_argument("--count", type=int, default=20, help="queries of the workload")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args()
    cold: list[dict[str, Any]] = []
    warm: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as scratch:
        for repeat in range(args.repeats):
            cache = Path(scratch) / f"cache{repeat}"
            cold.append(_run(args.config, args.count, cache, Path(scratch) / f"cold{repeat}"))
            warm.append(_run(args.config, args.count, cache, Path(scratch) / f"warm{repeat}"))
            print(f"repeat {repeat + 1}/{args.repeats}: cold {cold[-1]['seconds']:.1f} s, "
                  f"warm {warm[-1]['seconds']:.1f} s", file=sys.stderr)
    cold_median = statistics.median(r["seconds"] for r in cold)
    warm_median = statistics.median(r["seconds"] for r in warm)
    cold_cpu = statistics.median(r["cpu_seconds"] for r in cold)
    warm_cpu = statistics.median(r["cpu_seconds"] for r in warm)
    notices = [r["notice_seconds"] for r in cold if r["notice_seconds"] is not None]
    result = {
        "commit": head(),
        "config": str(args.config.resolve().relative_to(ROOT)),
        "queries": args.count,
        "repeats": args.repeats,
        "cores": os.cpu_count(),
        "load_average": os.getloadavg()[0],
        "cold_seconds": [r["seconds"] for r in cold],
        "warm_seconds": [r["seconds"] for r in warm],
        "cold_median_seconds": cold_median,
        "warm_median_seconds": warm_median,
        "cold_over_warm": cold_median / warm_median,
        "cold_cpu_seconds": [r["cpu_seconds"] for r in cold],
        "warm_cpu_seconds": [r["cpu_seconds"] for r in warm],
        "cold_median_cpu_seconds": cold_cpu,
        "warm_median_cpu_seconds": warm_cpu,
        "notice_median_seconds": statistics.median(notices) if notices else None,
        "cold_runs_with_notice": len(notices),
        "warm_runs_with_notice": sum(r["notice_seconds"] is not None for r in warm),
    }
    args.out.mkdir(parents=True, exist_ok=True)
    # a first run's start-up is in other processes, which load cbrcore and every plugin
    write_results(args.out / "cold_start.json", result, unit_names=("cbrcore", "plugins"))
    notice = result["notice_median_seconds"]
    lines = [
        "# Cold start: the first run's kernel compilation",
        "",
        f"`cbr run {result['config']} --set workload.count={args.count}`, {args.repeats} repeats, "
        f"{result['cores']} cores (load average {result['load_average']:.1f} at the end), "
        f"commit `{result['commit'][:12]}`.",
        "",
        "| cache | median wall s | median processor s | runs, wall (s) |",
        "|---|---|---|---|",
        f"| cold (empty) | {cold_median:.1f} | {cold_cpu:.1f} | "
        f"{', '.join(f'{s:.1f}' for s in result['cold_seconds'])} |",
        f"| warm | {warm_median:.1f} | {warm_cpu:.1f} | "
        f"{', '.join(f'{s:.1f}' for s in result['warm_seconds'])} |",
        "",
        f"Cold / warm: {result['cold_over_warm']:.1f}x wall, {cold_cpu / warm_cpu:.1f}x "
        "processor time. The compile notice came "
        + (f"{notice:.2f} s after the process started (median)" if notice is not None
           else "in no cold run")
        + f"; warm runs that wrote it: {result['warm_runs_with_notice']}.",
        "",
    ]
    (args.out / "cold_start.md").write_text("\n".join(lines), encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
