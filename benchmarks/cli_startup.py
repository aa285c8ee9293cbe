"""How long the ``cbr`` command line takes to start: ``cbr --help`` and a TAB completion.

Each is run ``--repeats`` times in a fresh subprocess (``python -m cbrcore``, so no launcher
script is timed), with the median wall time reported next to the median of ``python -c pass``
and their ratio to it: the ratio is what to compare across machines and loads. The completion
request is the one bash makes for ``cbr run x.yaml --set retrieve=`` + TAB (``_CBR_COMPLETE`` with
``COMP_WORDS`` and ``COMP_CWORD``), which loads every plugin to list the retrievers. Compiled
bytecode goes to a scratch folder (``PYTHONPYCACHEPREFIX``), written by one unmeasured warm-up
run, so the times are those of an installed package rather than of compiling its sources.

    python benchmarks/cli_startup.py [--repeats 15] [--out benchmarks/results]

Writes ``cli_startup.json`` and ``cli_startup.md`` into the output folder.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from docfigures.provenance import head, write_results

ROOT = Path(__file__).resolve().parents[1]
COMPLETE_LINE = "cbr run x.yaml --set retrieve="
BASH_WORDS = ["cbr", "run", "x.yaml", "--set", "retrieve", "="]
"""The line as bash hands it over: split at the ``=`` too, the cursor on the ``=``."""

CASES: dict[str, tuple[list[str], dict[str, str]]] = {
    "python -c pass": (["-c", "pass"], {}),
    "cbr --help": (["-m", "cbrcore", "--help"], {}),
    f"completion: {COMPLETE_LINE}": (
        ["-m", "cbrcore"],
        {"_CBR_COMPLETE": "complete_bash", "COMP_WORDS": "\n".join(BASH_WORDS),
         "COMP_CWORD": str(len(BASH_WORDS) - 1)}),
}
"""Each case: the interpreter's arguments and the environment added for it."""


def _time(args: list[str], env: dict[str, str], *, prints: bool = False) -> float:
    started = time.perf_counter()
    done = subprocess.run([sys.executable, *args], env=env, capture_output=True, check=False)
    elapsed = time.perf_counter() - started
    if done.returncode != 0 or (prints and not done.stdout.strip()):
        raise SystemExit(f"{args} exited with {done.returncode} and printed "
                         f"{len(done.stdout)} bytes: {done.stderr.decode()[-2000:]}")
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args()
    commit = head()
    with tempfile.TemporaryDirectory() as cache:
        base = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        base["PYTHONPYCACHEPREFIX"] = cache
        base["PYTHONPATH"] = os.pathsep.join(
            [str(ROOT), str(ROOT / "plugins"), *filter(None, [os.environ.get("PYTHONPATH")])])
        runs: dict[str, list[float]] = {name: [] for name in CASES}
        for argv, extra in CASES.values():
            # the warm-up writes the bytecode, and checks that the command answers
            _time(argv, {**base, **extra}, prints=argv[0] == "-m")
        # interleaved, so a change of load on the machine touches every case alike
        for _ in range(args.repeats):
            for name, (argv, extra) in CASES.items():
                runs[name].append(_time(argv, {**base, **extra}))
    medians = {name: statistics.median(times) for name, times in runs.items()}
    bare = medians["python -c pass"]
    result = {
        "command": f"python benchmarks/cli_startup.py --repeats {args.repeats}",
        "commit": commit,
        "python": sys.version.split()[0],
        "repeats": args.repeats,
        "cases": [{"case": name, "median_s": round(median, 4),
                   "ratio_to_python": round(median / bare, 2),
                   "runs_s": [round(t, 4) for t in runs[name]]}
                  for name, median in medians.items()],
    }
    args.out.mkdir(parents=True, exist_ok=True)
    # the command line's start-up is in other processes, which load cbrcore and every plugin
    write_results(args.out / "cli_startup.json", result, unit_names=("cbrcore", "plugins"))
    rows = [f"| {c['case']} | {c['median_s']:.3f} | {c['ratio_to_python']:.1f} |"
            for c in result["cases"]]
    table = "\n".join([
        f"Start-up of the `cbr` command line, median of {args.repeats} runs in fresh "
        f"processes (commit `{commit[:12]}`, Python {result['python']}).",
        "",
        "| case | median (s) | ratio to `python -c pass` |",
        "|---|---:|---:|",
        *rows,
    ])
    (args.out / "cli_startup.md").write_text(table + "\n")
    print(table)


if __name__ == "__main__":
    main()
