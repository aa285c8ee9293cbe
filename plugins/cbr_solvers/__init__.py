"""Model-based path planners on grids: the ``dijkstra``, ``astar``, ``aistar``, ``jps``,
``genetic`` and ``randomized`` solvers.

Each answers a :class:`cbr_grid.query.GridQuery` on the run's grid world
(:class:`cbr_grid.grid.Grid`) with the compiled searches of :mod:`cbr_solvers.search`,
:mod:`cbr_solvers.aistar`, :mod:`cbr_solvers.jps`, :mod:`cbr_solvers.genetic` and
:mod:`cbr_solvers.randomized`, under the grid's step cost contract (its ``factor``, ``passable``
and ``corner_cutting``). The first four give a cheapest path (``jps``, jump point search, hands
a grid with unequal costs or corner cutting over to A*); ``genetic`` and ``randomized`` give
plausible ones that vary with their seed, so that a case base can gather alternative routes.

For a robot whose kinematic model (:mod:`cbr_kinematics.models`) limits its turns, ``dijkstra``,
``astar``, ``aistar`` and ``randomized`` plan with the edge-based searches of section 5 of the
case graph paper (:mod:`cbr_solvers.kinematic_search`); :mod:`cbr_solvers.graph_search` runs the
same search over a graph of directed edges and :mod:`cbr_solvers.manoeuvres` prices the turns
and manoeuvres of both.

Every solver warms up when the engine is built (``cbr_warm``): it plans once on a small grid
with the world's rules, so that its compiled kernels are ready before the first query is timed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl
from cbrcore.lazy import lazy_exports

if TYPE_CHECKING:
    import typer

    from cbr_solvers.grid_solvers import (
        KINEMATIC_MODULES,
        SEARCH_MODULES,
        AiStar,
        AStar,
        Dijkstra,
        Genetic,
        GeneticOptions,
        GridSolver,
        JumpPointSearch,
        JumpPointSearchOptions,
        Randomized,
        RandomizedOptions,
        load_search,
        warm_grid,
        warm_query,
    )
    from cbrcore.registry import Registry

__all__ = ["KINEMATIC_MODULES", "SEARCH_MODULES", "AStar", "AiStar", "Dijkstra", "Genetic",
           "GeneticOptions", "GridSolver", "JumpPointSearch", "JumpPointSearchOptions",
           "Randomized", "RandomizedOptions", "load_search", "warm_grid", "warm_query"]
"""What :mod:`cbr_solvers.grid_solvers` defines and this package exports: imported when first
asked for, so that loading the plugin (every start of ``cbr``) does not import the grid and
NumPy."""

_SOLVERS = "cbr_solvers.grid_solvers"


__getattr__ = lazy_exports("cbr_solvers", dict.fromkeys(__all__, _SOLVERS), globals())


@hookimpl
def cbr_register(registry: Registry) -> None:
    # named, not imported: the grid and NumPy load when a configuration uses a solver
    registry.add("solver", "dijkstra", f"{_SOLVERS}:Dijkstra")
    registry.add("solver", "astar", f"{_SOLVERS}:AStar")
    registry.add("solver", "aistar", f"{_SOLVERS}:AiStar")
    registry.add("solver", "jps", f"{_SOLVERS}:JumpPointSearch",
                 options=f"{_SOLVERS}:JumpPointSearchOptions")
    registry.add("solver", "genetic", f"{_SOLVERS}:Genetic", options=f"{_SOLVERS}:GeneticOptions")
    registry.add("solver", "randomized", f"{_SOLVERS}:Randomized",
                 options=f"{_SOLVERS}:RandomizedOptions")


@hookimpl
def cbr_cli(app: typer.Typer) -> None:
    """Add ``cbr plan`` and ``cbr map show``."""
    from cbr_solvers.cli import add_commands

    add_commands(app)
