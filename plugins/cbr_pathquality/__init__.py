"""The quality of a proposed grid path: the ``path_quality`` reviser that every grid CBR family
(the case graph, whole-path cases) revises with, the ideal length it measures a path against
(:mod:`cbr_pathquality.ideal`), and the ``path_quality`` metric that rates a proposal against
the optimum (:mod:`cbr_pathquality.metric`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl

if TYPE_CHECKING:
    from cbrcore.registry import Registry


@hookimpl
def cbr_register(registry: Registry) -> None:
    # named, not imported: the components load with the grid when a configuration uses them
    registry.add("reviser", "path_quality", "cbr_pathquality.reviser:QualityTest",
                 options="cbr_pathquality.reviser:QualityOptions")
    registry.add("metric", "path_quality", "cbr_pathquality.metric:PathQuality",
                 options="cbr_pathquality.metric:PathQualityOptions")
