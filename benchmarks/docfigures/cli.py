"""Figures the docs quote from benchmarks and experiments, rendered from committed results.

The command line of ``benchmarks/figures.py``: check, write or list the pages' blocks, or commit
new results for them.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from . import layers
from .catalogue import BLOCKS
from .keep import keep_baseline, keep_experiment
from .pages import check, stale_results, used, write
from .results import ROOT, FiguresError
from .route_graph import keep_route_graph


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--check", action="store_true",
                      help="fail when a block differs from its results, or a results file "
                           "from its source")
    mode.add_argument("--write", action="store_true",
                      help="rewrite the stale blocks, and the architecture page's picture of "
                           "the layers when the code's imports changed")
    mode.add_argument("--list", action="store_true", help="list the blocks and their sources")
    mode.add_argument("--keep-experiment", nargs=2, metavar=("NAME", "DIR"),
                      help="commit the results an experiment wrote into DIR")
    mode.add_argument("--keep-baseline", action="store_true",
                      help="rerun the reproductions page's baseline (002 without CBR) and "
                           "commit its trials")
    mode.add_argument("--keep-route-graph", action="store_true",
                      help="rerun configs/ros_depot_route.yaml, commit its exported route graph "
                           "and draw it over the depot")
    args = parser.parse_args(argv)
    try:
        if args.keep_baseline:
            print(keep_baseline().relative_to(ROOT))
            return 0
        if args.keep_route_graph:
            print(keep_route_graph().relative_to(ROOT))
            return 0
        if args.keep_experiment:
            name, run = args.keep_experiment
            print(keep_experiment(name, Path(run)).relative_to(ROOT))
            return 0
        if args.list:
            found = used()
            for name, block in BLOCKS.items():
                where = ", ".join(found.get(name, ["(no page)"]))
                print(f"{name}: {block.source.relative_to(ROOT)} -> {where}")
            return 0
        # the house first: a block reads what it keeps
        lines = [*layers.write(), *write()] if args.write else [*layers.check(), *check()]
        stale = stale_results() if args.check else []
    except FiguresError as exc:
        print(f"figures: {exc}", file=sys.stderr)
        return 1
    for line in lines:
        print(line, file=sys.stderr if args.check else sys.stdout)
    if lines and args.check:
        print("figures: run `python benchmarks/figures.py --write` after committing new results",
              file=sys.stderr)
    for line in stale:
        print(line, file=sys.stderr)
    if stale:
        print(f"figures: {len(stale)} results files are older than their source: rerun each "
              "command, then `python benchmarks/figures.py --write`", file=sys.stderr)
    return 1 if args.check and (lines or stale) else 0
