"""Grid path planning with whole traversed paths as cases (Kruusmaa & Svensson; Šeda & Dvořák).

A case is a path the robot drove, stored with its cost F(l, r, g) (:mod:`cbr_pathcases.cost`).
Retrieval takes the stored paths whose ends lie near the new start and goal and chooses one with
a probability that falls with its cost, or none, to explore (:mod:`cbr_pathcases.selection`);
reuse extends it to the new start and goal by a grid search; the ``path_quality`` reviser
(:mod:`cbr_pathquality.reviser`) revises it; retention keeps a driven path unless a similar one
(by the Hausdorff distance, :mod:`cbr_pathcases.hausdorff`) costs no more, and learns the cost of
the path it reused (:mod:`cbr_pathcases.components`); forgetting keeps the case base within a
capacity by one of the papers' strategies (:mod:`cbr_pathcases.forgetting`). The learning
experiment is in :mod:`cbr_pathcases.experiments`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl

if TYPE_CHECKING:
    from cbrcore.casebase.store import CaseStore
    from cbrcore.context import Context
    from cbrcore.registry import Registry

CAPACITY_FORGETTERS = {
    "worst_paths": "WorstPaths",
    "average_paths": "AveragePaths",
    "best_paths": "BestPaths",
    "least_recent_paths": "LeastRecentPaths",
    "least_used_paths": "LeastUsedPaths",
    "oldest_paths": "OldestPaths",
    "newest_paths": "NewestPaths",
}
"""Each capacity strategy's forgetter name and its class in :mod:`cbr_pathcases.forgetting`."""

_COMPONENTS = "cbr_pathcases.components"
_FORGETTING = "cbr_pathcases.forgetting"


def _learning(options: object, ctx: Context) -> object:
    # the engine, numba and matplotlib load when the experiment runs, not at every start of cbr
    from cbr_pathcases.experiments import Learning

    return Learning(options, ctx)


@hookimpl
def cbr_check_casebase(casebase: CaseStore) -> list[str]:
    """The invariants of the whole-path cases (:func:`cbr_pathcases.base.path_problems`)."""
    from cbr_pathcases.base import path_problems

    return path_problems(casebase)


@hookimpl
def cbr_register(registry: Registry) -> None:
    # named, not imported: the components load with the grid when a configuration uses them
    registry.add("retriever", "path_cases", f"{_COMPONENTS}:PathRetriever",
                 options=f"{_COMPONENTS}:RetrieveOptions")
    registry.add("reuser", "path_cases", f"{_COMPONENTS}:PathReuser",
                 options=f"{_COMPONENTS}:ReuseOptions")
    registry.add("retainer", "path_cases", f"{_COMPONENTS}:PathRetainer",
                 options=f"{_COMPONENTS}:RetainOptions")
    for name, strategy in CAPACITY_FORGETTERS.items():
        registry.add("forgetter", name, f"{_FORGETTING}:{strategy}",
                     options=f"{_FORGETTING}:CapacityOptions")
    registry.add("forgetter", "near_duplicate_paths", f"{_FORGETTING}:NearDuplicatePaths",
                 options=f"{_FORGETTING}:NearDuplicateOptions")
    registry.add("experiment", "path-cases-learning", _learning,
                 doc="Travel cost of whole-path cases against map-only planning as the robot "
                 "learns, and the forgetting strategies at a fixed capacity.")
