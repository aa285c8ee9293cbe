"""cbrcore: case-based reasoning for mobile robot navigation.

The engine runs the cycle retrieve -> reuse -> revise (-> fallback solver) and learn = retain ->
forget, each phase a pluggy hook served by components that plugins register and a YAML file
selects.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl
from cbrcore.lazy import lazy_exports

if TYPE_CHECKING:
    from cbrcore.engine import Engine, EngineStats
    from cbrcore.model import Case, Match, Outcome, Proposal, Retrieval, Revision, Solution

_LAZY = {"Engine": "cbrcore.engine", "EngineStats": "cbrcore.engine",
         **dict.fromkeys(["Case", "Match", "Outcome", "Proposal", "Retrieval", "Revision",
                          "Solution"], "cbrcore.model")}
"""Where each name exported here is defined: imported when first asked for, so that a plugin
importing ``hookimpl`` and the command line do not import the engine and NumPy with it."""

__all__ = [
    "Case",
    "Engine",
    "EngineStats",
    "Match",
    "Outcome",
    "Proposal",
    "Retrieval",
    "Revision",
    "Solution",
    "hookimpl",
]


__getattr__ = lazy_exports("cbrcore", _LAZY, globals())
