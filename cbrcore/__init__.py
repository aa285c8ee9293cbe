"""cbrcore: case-based reasoning for mobile robot navigation.

The engine runs the cycle retrieve -> reuse -> revise (-> fallback solver) and learn = retain ->
forget, each phase a pluggy hook served by components that plugins register and a YAML file
selects.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from cbrcore.hookspecs import hookimpl

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


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'cbrcore' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value
