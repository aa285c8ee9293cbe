"""Model-based path planners on grids: the ``dijkstra``, ``astar`` and ``aistar`` solvers.

Each answers a :class:`cbr_grid.query.GridQuery` on the run's grid world
(:class:`cbr_grid.grid.Grid`) with the compiled searches of :mod:`cbr_solvers.search` and
:mod:`cbr_solvers.aistar`, under the grid's step cost contract (its ``factor``, ``passable`` and
``corner_cutting``).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

import typer

from cbr_grid.grid import Grid
from cbr_grid.query import GridQuery
from cbr_solvers.cli import add_commands
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Solution
from cbrcore.registry import Registry

SEARCH_MODULES = {"dijkstra": "search", "astar": "search", "aistar": "aistar"}
"""Each grid search by name, and the module of cbr_solvers that holds its function."""


def load_search(name: str) -> Callable[..., Any]:
    """The search function ``name``; numba loads with it, not with every start of ``cbr``."""
    return getattr(importlib.import_module(f"cbr_solvers.{SEARCH_MODULES[name]}"), name)


class GridSolver:
    """Plan the cheapest path of a grid query by a compiled grid search."""

    name = ""

    def __init__(self, options: object, ctx: Context) -> None:
        if not isinstance(ctx.world, Grid):
            raise CbrError(f"solver {self.name!r} plans on a grid world; the configured world is "
                           f"{type(ctx.world).__name__}")
        self.search = load_search(self.name)

    @hookimpl
    def cbr_solve(self, problem: GridQuery, ctx: Context) -> Solution | None:
        grid: Grid = ctx.world
        start = grid.check_cell(problem.start, "start")
        goal = grid.check_cell(problem.goal, "goal")
        result = self.search(grid.factor, grid.passable, grid.corner_cutting, start, [goal])
        if result is None:
            return None
        return Solution(result.path.tolist(), cost=result.cost,
                        detail={"expanded": result.expanded, "solver": self.name})


class Dijkstra(GridSolver):
    """The cheapest path by Dijkstra's algorithm (compiled, binary heap)."""

    name = "dijkstra"


class AStar(GridSolver):
    """The cheapest path by A* with the octile distance times the smallest cost factor."""

    name = "astar"


class AiStar(GridSolver):
    """The cheapest path by Ai*: A* guided by an integer distance map from the goal."""

    name = "aistar"


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("solver", "dijkstra", Dijkstra)
    registry.add("solver", "astar", AStar)
    registry.add("solver", "aistar", AiStar)


@hookimpl
def cbr_cli(app: typer.Typer) -> None:
    """Add ``cbr plan`` and ``cbr map show``."""
    add_commands(app)
