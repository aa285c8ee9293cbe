"""Grid path planning with a case graph of reusable path segments (Hodál & Dvořák).

A traversed path is cut at its turns and at its crossings with stored paths into straight
segments, the cases, which form one graph (:mod:`cbr_casegraph.graph`). Retrieval takes the
segments near start and goal, reuse joins start and goal to them by local searches and finds the
best path through the graph (:mod:`cbr_casegraph.planner`), revision checks its length against
the ideal, retention adds the new segments and forgetting keeps the graph small
(:mod:`cbr_casegraph.components`). The reproductions of the papers' experiments are in
:mod:`cbr_casegraph.experiments`.
"""

from __future__ import annotations

from cbr_casegraph.components import (
    CaseGraphRetainer,
    CaseGraphRetriever,
    CaseGraphReuser,
    LimitOptions,
    PathQuality,
    QualityOptions,
    RedundantVertices,
    RetainOptions,
    RetrieveOptions,
    ReuseOptions,
    RiskyOptions,
    RiskySegments,
    VertexLimit,
)
from cbr_casegraph.experiments import DeviationTable, Share, TimeVsMapSize, TimeVsVertices
from cbrcore.hookspecs import hookimpl
from cbrcore.registry import Registry


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("retriever", "casegraph", CaseGraphRetriever, options=RetrieveOptions)
    registry.add("reuser", "casegraph", CaseGraphReuser, options=ReuseOptions)
    registry.add("reviser", "path_quality", PathQuality, options=QualityOptions)
    registry.add("retainer", "casegraph", CaseGraphRetainer, options=RetainOptions)
    registry.add("forgetter", "redundant_vertices", RedundantVertices)
    registry.add("forgetter", "risky_segments", RiskySegments, options=RiskyOptions)
    registry.add("forgetter", "vertex_limit", VertexLimit, options=LimitOptions)
    registry.add("experiment", "cbr-share", Share)
    registry.add("experiment", "deviation-table", DeviationTable)
    registry.add("experiment", "time-vs-map-size", TimeVsMapSize)
    registry.add("experiment", "time-vs-vertices", TimeVsVertices)
