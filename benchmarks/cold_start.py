"""What a first run costs: ``cbr run`` with an empty kernel cache (cold) beside the same run with
the cache filled (warm), for this checkout and for a baseline commit side by side.

The baseline is checked out into a temporary ``git worktree``. Each repeat runs the
configuration cold, in a fresh ``CBR_CACHE_DIR``, then warm, in the cache folder that cold run
filled, for both checkouts, each as its own ``python -m cbrcore run`` process (with that
checkout first on ``PYTHONPATH``) into a fresh output folder; which checkout goes first
alternates from one repeat to the next, so both see the same machine. It reports the median
wall and processor time of each, the median over repeats of this checkout's time over the
baseline's (the figure to trust on a busy machine), the median time from the process's start to
the compile notice on stderr (the cold runs' first line), and checks that warm runs write no
notice. A checkout whose Python files are edited is reported as such (an edited kernel module turns
a warm cache cold).

    python benchmarks/cold_start.py [--baseline e717407] [--config configs/hybrid_grid.yaml]
                                    [--count 20] [--repeats 3] [--out benchmarks/results]

``--baseline none`` measures this checkout alone. Writes ``cold_start.json`` and
``cold_start.md`` into the output folder.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from docfigures.provenance import write_results

ROOT = Path(__file__).resolve().parents[1]
NOTICE = "cbr: compiling the kernels"
ORIGINAL = "e717407"
"""The last commit before the first run's compile was announced and cut down."""


def _run(checkout: Path, config: Path, count: int, cache: Path, out: Path) -> dict[str, Any]:
    """One ``cbr run`` process of ``checkout``: its wall time, its processor time (user and
    system: on a busy machine the steadier figure), when its compile notice came (None: none
    did)."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["CBR_CACHE_DIR"] = str(cache)
    env["PYTHONPATH"] = os.pathsep.join([str(checkout), str(checkout / "plugins")])
    command = [sys.executable, "-m", "cbrcore", "run", str(config), "--set",
               f"workload.count={count}", "--out", str(out)]
    notice: list[float] = []
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    process = subprocess.Popen(command, cwd=checkout, env=env, stdout=subprocess.DEVNULL,
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
        raise SystemExit(f"{' '.join(command)} (in {checkout}) exited with {code}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"seconds": seconds, "cpu_seconds": cpu,
            "notice_seconds": notice[0] if notice else None}


def _commit(checkout: Path, name: str = "HEAD") -> str:
    return subprocess.run(["git", "rev-parse", name], capture_output=True, text=True,
                          cwd=checkout, check=True).stdout.strip()


def _edited(checkout: Path) -> bool:
    """Whether tracked Python files differ from the commit: the runs then measure no commit
    (and an edited kernel module turns a warm cache cold)."""
    return bool(subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--",
                                "*.py"],
                               capture_output=True, text=True, cwd=checkout,
                               check=True).stdout.strip())


@contextlib.contextmanager
def _worktree(commit: str, scratch: Path) -> Iterator[Path]:
    """``commit`` checked out in a temporary worktree of this repository."""
    folder = scratch / "baseline"
    subprocess.run(["git", "worktree", "add", "--detach", str(folder), commit], cwd=ROOT,
                   check=True, capture_output=True)
    try:
        yield folder
    finally:
        subprocess.run(["git", "worktree", "remove", "--force", str(folder)], cwd=ROOT,
                       check=False, capture_output=True)


def _summary(runs: list[dict[str, Any]]) -> dict[str, Any]:
    notices = [r["notice_seconds"] for r in runs if r["notice_seconds"] is not None]
    return {
        "seconds": [r["seconds"] for r in runs],
        "cpu_seconds": [r["cpu_seconds"] for r in runs],
        "median_seconds": statistics.median(r["seconds"] for r in runs),
        "median_cpu_seconds": statistics.median(r["cpu_seconds"] for r in runs),
        "notice_median_seconds": statistics.median(notices) if notices else None,
        "runs_with_notice": len(notices),
    }


def _measure(checkouts: dict[str, Path], config: Path, count: int, repeats: int,
             scratch: Path) -> dict[str, dict[str, list[dict[str, Any]]]]:
    runs: dict[str, dict[str, list[dict[str, Any]]]] = {
        name: {"cold": [], "warm": []} for name in checkouts}
    names = list(checkouts)
    for repeat in range(repeats):
        order = names if repeat % 2 == 0 else names[::-1]
        for name in order:
            cache = scratch / f"{name}-cache{repeat}"
            for kind in ("cold", "warm"):
                runs[name][kind].append(_run(checkouts[name], config, count, cache,
                                             scratch / f"{name}-{kind}{repeat}"))
        print(f"repeat {repeat + 1}/{repeats}: " + "; ".join(
            f"{name} cold {runs[name]['cold'][-1]['seconds']:.1f} s, "
            f"warm {runs[name]['warm'][-1]['seconds']:.1f} s" for name in order),
            file=sys.stderr)
    return runs


def _ratio(runs: dict[str, dict[str, list[dict[str, Any]]]], kind: str, key: str) -> float:
    """The median over repeats of this checkout's figure over the baseline's."""
    return statistics.median(now[key] / then[key] for now, then in
                             zip(runs["current"][kind], runs["baseline"][kind], strict=True))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default=ORIGINAL,
                        help="the commit to compare with ('none': this checkout alone)")
    parser.add_argument("--config", type=Path, default=ROOT / "configs" / "hybrid_grid.yaml")
    parser.add_argument("--count", type=int, default=20, help="queries of the workload")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args()
    config = args.config.resolve().relative_to(ROOT)
    edited = _edited(ROOT)
    if edited:
        print("warning: this checkout has uncommitted changes; the results say so",
              file=sys.stderr)
    with tempfile.TemporaryDirectory() as folder, contextlib.ExitStack() as stack:
        scratch = Path(folder)
        checkouts = {"current": ROOT}
        if args.baseline != "none":
            checkouts["baseline"] = stack.enter_context(_worktree(args.baseline, scratch))
        runs = _measure(checkouts, config, args.count, args.repeats, scratch)
        commits = {name: _commit(path) for name, path in checkouts.items()}
    result: dict[str, Any] = {
        "commit": commits["current"],
        "uncommitted_changes": edited or _edited(ROOT),
        "baseline_commit": commits.get("baseline"),
        "config": str(config),
        "queries": args.count,
        "repeats": args.repeats,
        "cores": os.cpu_count(),
        "load_average": os.getloadavg()[0],
    }
    for name in checkouts:
        for kind in ("cold", "warm"):
            result[f"{name}_{kind}"] = _summary(runs[name][kind])
    now_cold, now_warm = result["current_cold"], result["current_warm"]
    result["cold_over_warm"] = now_cold["median_seconds"] / now_warm["median_seconds"]
    if "baseline" in checkouts:
        result["cold_over_baseline"] = _ratio(runs, "cold", "seconds")
        result["cold_cpu_over_baseline"] = _ratio(runs, "cold", "cpu_seconds")
        result["warm_over_baseline"] = _ratio(runs, "warm", "seconds")
    args.out.mkdir(parents=True, exist_ok=True)
    # a first run's start-up is in other processes, which load cbrcore and every plugin
    result = write_results(args.out / "cold_start.json", result, unit_names=("cbrcore", "plugins"))
    (args.out / "cold_start.md").write_text(_markdown(result, list(checkouts)),
                                            encoding="utf-8")
    print(_markdown(result, list(checkouts)))


def _markdown(result: dict[str, Any], names: list[str]) -> str:
    label = {"current": f"`{result['commit'][:12]}`",
             "baseline": f"`{(result['baseline_commit'] or '')[:12]}` (baseline)"}
    lines = [
        "# Cold start: the first run's kernel compilation",
        "",
        f"`cbr run {result['config']} --set workload.count={result['queries']}`, "
        f"{result['repeats']} repeats, {result['cores']} cores (load average "
        f"{result['load_average']:.1f} at the end), commit `{result['commit'][:12]}`"
        + (" with uncommitted changes" if result["uncommitted_changes"] else "")
        + (f" beside `{result['baseline_commit'][:12]}`" if result["baseline_commit"] else "")
        + ".",
        "",
        "| commit | cache | median wall s | median processor s | runs, wall (s) |",
        "|---|---|---|---|---|",
    ]
    for name in names:
        for kind in ("cold", "warm"):
            summary = result[f"{name}_{kind}"]
            lines.append(
                f"| {label[name]} | {'cold (empty)' if kind == 'cold' else 'warm'} | "
                f"{summary['median_seconds']:.1f} | {summary['median_cpu_seconds']:.1f} | "
                f"{', '.join(f'{s:.1f}' for s in summary['seconds'])} |")
    now_cold, now_warm = result["current_cold"], result["current_warm"]
    notice = now_cold["notice_median_seconds"]
    lines += [
        "",
        f"Cold / warm: {result['cold_over_warm']:.1f}x wall, "
        f"{now_cold['median_cpu_seconds'] / now_warm['median_cpu_seconds']:.1f}x processor "
        "time. The compile notice came "
        + (f"{notice:.2f} s after the process started (median)" if notice is not None
           else "in no cold run")
        + f"; warm runs that wrote it: {now_warm['runs_with_notice']}.",
    ]
    if "cold_over_baseline" in result:
        lines += [
            "",
            f"Against the baseline (median over repeats of the ratio, runs side by side): "
            f"cold {result['cold_over_baseline']:.2f}x wall, "
            f"{result['cold_cpu_over_baseline']:.2f}x processor time; "
            f"warm {result['warm_over_baseline']:.2f}x wall.",
        ]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
