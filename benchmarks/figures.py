"""Figures the docs quote from benchmarks and experiments, rendered from committed results.

A page marks each generated block (``<!-- figures: NAME -->`` ... ``<!-- /figures -->``) and this
script renders the block NAME from the committed results of a benchmark or an experiment (the
``docfigures`` package beside it holds how). A rerun that commits new results changes the pages
only through ``--write``, so a page cannot quote a figure its results do not hold; and each
results file records the command, commit and source that made it, so ``--check`` tells one the
code has moved away from.

    python benchmarks/figures.py --check     # exit 1 naming each stale block, and each results
                                             # file older than its source, with its command
    python benchmarks/figures.py --write     # rewrite the blocks from the results, and the
                                             # picture of the layers from the code's imports
    python benchmarks/figures.py --list      # the blocks and where their figures come from
    python benchmarks/figures.py --keep-experiment NAME DIR   # commit DIR's results for NAME
    python benchmarks/figures.py --keep-baseline  # rerun the navigation system without CBR
    python benchmarks/figures.py --keep-route-graph  # relearn the depot's route graph
"""

from __future__ import annotations

import sys

from docfigures.cli import main  # run as a script, this folder is on the path

if __name__ == "__main__":
    sys.exit(main())
