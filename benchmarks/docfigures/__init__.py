"""Figures the docs quote from benchmarks and experiments, rendered from committed results.

A page marks each generated block::

    <!-- figures: NAME -->
    ...rendered text...
    <!-- /figures -->

and the block NAME is rendered from the results a full run wrote: a benchmark's
``benchmarks/results/<benchmark>.md`` / ``.json``, or an experiment's results kept in
``docs/figures/<experiment>.json`` (its ``results.json`` trimmed to what the pages use, with the
run's ``results.md`` table and the command that made it). ``benchmarks/figures.py`` is the
command line.

- ``results``: reading the results (tables, JSON, kept experiments); ``wording``: how the prose
  writes figures.
- ``solver_benchmarks``, ``case_benchmarks``, ``world2d_benchmarks``: the prose of the
  benchmarks page and of the pages that quote benchmarks.
- ``casegraph_experiments``, ``pathcases_experiments``, ``landmark_experiments``,
  ``rupart_experiments``, ``ros2005_baseline``: the experiments' pages; ``route_graph``: the
  route graph learned on the depot, for the grid page.
- ``layers``: the architecture page's picture of the layers, drawn from the import contract
  and the packages' imports.
- ``catalogue``: every block, its source and renderer; ``pages``: finding, checking and
  rewriting the blocks of the pages, and listing the results older than their source;
  ``provenance``: the command, commit and source hash every results file records; ``keep``:
  committing new results; ``cli``: the commands.
"""
