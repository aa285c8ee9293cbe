"""The quality of a proposed grid path: the ``path_quality`` reviser that every grid CBR family
(the case graph, whole-path cases) revises with, the ideal length it measures a path against
(:mod:`cbr_pathquality.ideal`), and the ``path_quality`` metric that rates a proposal against
the optimum (:mod:`cbr_pathquality.metric`)."""

from __future__ import annotations

from cbr_pathquality.metric import PathQuality, PathQualityOptions
from cbr_pathquality.reviser import QualityOptions, QualityTest
from cbrcore.hookspecs import hookimpl
from cbrcore.registry import Registry


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("reviser", "path_quality", QualityTest, options=QualityOptions)
    registry.add("metric", "path_quality", PathQuality, options=PathQualityOptions)
