"""What the grid family asks of a planner it gets from the registry.

The simulated robot replans around the obstacles it meets, but the grid family plans nothing
itself: searches live with the solvers, a layer above it. So the ``trips`` workload takes a
solver component by name from the registry (its ``replanner``) and calls it through this
protocol, which the grid solvers implement.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from cbr_grid.grid import Grid
from cbr_grid.query import Cell
from cbrcore.context import Context
from cbrcore.errors import CbrError

Window = tuple[int, int, int, int]
"""A box of cells (x0, y0, x1, y1), bounds included, that a search stays inside."""


@runtime_checkable
class GridPlanner(Protocol):
    """A planner of paths on a grid's costs and a given passable mask."""

    @property
    def constrained(self) -> bool:
        """True for a robot whose kinematic model limits its turns: its paths depend on the
        heading it starts with, and it plans to one goal without a window."""
        ...

    def plan(self, grid: Grid, passable: np.ndarray, start: Cell, goals: np.ndarray, *,
             window: Window | None = None, heading: int | None = None) -> np.ndarray | None:
        """The cheapest path ((n, 2) cells) from ``start`` to the nearest of ``goals`` on
        ``grid``'s step costs through the cells ``passable`` allows, inside ``window`` when
        given, leaving ``start`` facing ``heading`` when the planner is constrained; None when
        there is none."""
        ...


def planner_of(name: str, ctx: Context, where: str) -> GridPlanner:
    """The solver component ``name`` built from the registry, checked to plan on grids."""
    planner = ctx.registry.create("solver", name, None, ctx)
    if not isinstance(planner, GridPlanner):
        raise CbrError(f"{where}: solver {name!r} is a {type(planner).__name__}, which cannot "
                       f"plan on a given passable mask (cbr_grid.planning.GridPlanner)")
    return planner
