"""cbrcore: case-based reasoning for mobile robot navigation.

The engine runs the cycle retrieve -> reuse -> revise (-> fallback solver) and learn = retain ->
forget, each phase a pluggy hook served by components that plugins register and a YAML file
selects.
"""

from cbrcore.engine import Engine, EngineStats
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Case, Match, Outcome, Proposal, Retrieval, Revision, Solution

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
