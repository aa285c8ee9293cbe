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

from cbr_pathcases.base import path_problems
from cbr_pathcases.components import (
    PathRetainer,
    PathRetriever,
    PathReuser,
    RetainOptions,
    RetrieveOptions,
    ReuseOptions,
)
from cbr_pathcases.forgetting import (
    CAPACITY_STRATEGIES,
    CapacityOptions,
    NearDuplicateOptions,
    NearDuplicatePaths,
)
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.hookspecs import hookimpl
from cbrcore.registry import Registry


def _learning(options: object, ctx: Context) -> object:
    # the engine, numba and matplotlib load when the experiment runs, not at every start of cbr
    from cbr_pathcases.experiments import Learning

    return Learning(options, ctx)


@hookimpl
def cbr_check_casebase(casebase: CaseStore) -> list[str]:
    """The invariants of the whole-path cases (:func:`cbr_pathcases.base.path_problems`)."""
    return path_problems(casebase)


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("retriever", "path_cases", PathRetriever, options=RetrieveOptions)
    registry.add("reuser", "path_cases", PathReuser, options=ReuseOptions)
    registry.add("retainer", "path_cases", PathRetainer, options=RetainOptions)
    for name, strategy in CAPACITY_STRATEGIES.items():
        registry.add("forgetter", name, strategy, options=CapacityOptions)
    registry.add("forgetter", "near_duplicate_paths", NearDuplicatePaths,
                 options=NearDuplicateOptions)
    registry.add("experiment", "path-cases-learning", _learning,
                 doc="Travel cost of whole-path cases against map-only planning as the robot "
                 "learns, and the forgetting strategies at a fixed capacity.")
