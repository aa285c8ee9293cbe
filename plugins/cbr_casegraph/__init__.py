"""Grid path planning with a case graph of reusable path segments (Hodál & Dvořák).

A traversed path is cut at its turns and at its crossings with stored paths into straight
segments, the cases, which form one graph (:mod:`cbr_casegraph.graph`). Retrieval takes the
segments near start and goal, reuse joins start and goal to them by local searches and finds the
best path through the graph (:mod:`cbr_casegraph.planner`; for a robot with kinematic
constraints :mod:`cbr_casegraph.kinematic`) or, as reuser ``experience_graph``,
an experience-graph search on the map drawn along the segments, whose paths cost at most a stated
factor above the optimum (:mod:`cbr_casegraph.experience`); retention adds the new segments
(:mod:`cbr_casegraph.retention`) and forgetting keeps the graph small
(:mod:`cbr_casegraph.forgetting`); the components of each phase are in
:mod:`cbr_casegraph.components`. Revision is the
``path_quality`` reviser (:mod:`cbr_pathquality.reviser`), shared with the other grid CBR
families.
The reproductions of the papers' experiments are in :mod:`cbr_casegraph.experiments`.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl

if TYPE_CHECKING:
    from cbrcore.casebase.formats import DocumentFormat
    from cbrcore.casebase.store import CaseStore
    from cbrcore.context import Context
    from cbrcore.registry import Registry

_COMPONENTS = "cbr_casegraph.components"

EXPERIMENTS = {
    "cbr-share": ("cbr_casegraph.experiments.share", "Share",
                  "Fig. 3: share of random tasks planned by CBR against coverage."),
    "deviation-table": ("cbr_casegraph.experiments.deviation", "DeviationTable",
                        "Table 1: deviation of CBR, Dijkstra, A* and Ai* from the best cost, "
                        "length and turns."),
    "time-vs-map-size": ("cbr_casegraph.experiments.timing", "TimeVsMapSize",
                         "Fig. 4: planning times of CBR and Dijkstra, A*, Ai* against the map "
                         "size."),
    "time-vs-vertices": ("cbr_casegraph.experiments.timing", "TimeVsVertices",
                         "Fig. 2: CBR planning time against the vertex count, full and selective "
                         "adaptation."),
    "fleet": ("cbr_casegraph.experiments.fleet", "Fleet",
              "N robots learning into one case base at once, against one case base each: CBR "
              "share, throughput and integrity."),
}
"""The reproductions: name, module and class in :mod:`cbr_casegraph.experiments`, one-line
summary."""


def _experiment(module: str, cls: str) -> Callable[[object, Context], object]:
    def build(options: object, ctx: Context) -> object:
        # numba and the planner load when an experiment runs, not at every start of ``cbr``
        return getattr(importlib.import_module(module), cls)(options, ctx)

    return build


@hookimpl
def cbr_check_casebase(casebase: CaseStore) -> list[str]:
    """The case graph's invariants (:mod:`cbr_casegraph.invariants`)."""
    from cbr_casegraph.invariants import graph_problems

    return graph_problems(casebase)


@hookimpl
def cbr_casebase_formats() -> list[DocumentFormat]:
    """A case graph is written and read as a Nav2 route graph (:mod:`cbr_casegraph.route_graph`)."""
    from cbr_casegraph.route_graph import ROUTE_GRAPH

    return [ROUTE_GRAPH]


@hookimpl
def cbr_register(registry: Registry) -> None:
    # named, not imported: the components load with the grid when a configuration uses them
    registry.add("retriever", "casegraph", f"{_COMPONENTS}:CaseGraphRetriever",
                 options=f"{_COMPONENTS}:RetrieveOptions")
    registry.add("reuser", "casegraph", f"{_COMPONENTS}:CaseGraphReuser",
                 options=f"{_COMPONENTS}:ReuseOptions")
    registry.add("reuser", "experience_graph",
                 "cbr_casegraph.experience_reuser:ExperienceGraphReuser",
                 options="cbr_casegraph.experience_reuser:ExperienceOptions")
    registry.add("retainer", "casegraph", f"{_COMPONENTS}:CaseGraphRetainer",
                 options=f"{_COMPONENTS}:RetainOptions")
    registry.add("forgetter", "redundant_vertices", f"{_COMPONENTS}:RedundantVertices")
    registry.add("forgetter", "risky_segments", f"{_COMPONENTS}:RiskySegments",
                 options=f"{_COMPONENTS}:RiskyOptions")
    registry.add("forgetter", "vertex_limit", f"{_COMPONENTS}:VertexLimit",
                 options=f"{_COMPONENTS}:LimitOptions")
    for name, (module, cls, doc) in EXPERIMENTS.items():
        registry.add("experiment", name, _experiment(module, cls), doc=doc)
