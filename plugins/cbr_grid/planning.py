"""The solver protocol: what every slot that plans on a grid asks of a solver component.

The simulated robot replans around the obstacles it meets, but the grid family plans nothing
itself: searches live with the solvers, a layer above it. So every option that names a grid
planner (the ``trips`` workload's ``replanner``, the ``casegraph`` and ``path_cases`` reusers'
``connector``, ``cbr plan --solver``) takes a solver component by name from the registry and
calls it through :class:`GridPlanner`, which the built-in grid solvers implement and a
plugin's solver may implement too (see "The solver protocol" in docs/plugins-kinds.md).
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import attrs
import numpy as np

from cbr_grid.costs import path_cost
from cbr_grid.grid import Grid
from cbr_grid.query import Cell
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.registry import Component, Registry, UnknownComponent

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
        """A path ((n, 2) cells, 8-neighbour moves under ``grid``'s corner rule) from
        ``start`` (its first row) to one of ``goals`` ((k, 2) cells; its last row), the
        nearest on ``grid``'s step costs for the built-in searches, through the cells
        ``passable`` allows, inside ``window`` when given (which may reach beyond the grid),
        leaving ``start`` facing ``heading`` when the planner is constrained; None when there
        is none."""
        ...


def plans_on_grids(component: Component) -> bool:
    """Whether a registered solver's factory is a class with :class:`GridPlanner`'s members
    (known without building it, so that an error can list the names that fit)."""
    factory = component.factory
    return (isinstance(factory, type) and callable(getattr(factory, "plan", None))
            and hasattr(factory, "constrained"))


def grid_planners(registry: Registry) -> str:
    """The registered solvers that plan on grids, sorted, each with the plugin that supplies
    it; "none" without one."""
    return ", ".join(f"{c.name} (plugin {c.plugin})" for c in registry
                     if c.kind == "solver" and plans_on_grids(c)) or "none"


def planner_problem(registry: Registry, name: str) -> str | None:
    """What is wrong with naming ``name`` where a grid planner is wanted, listing the names that
    fit; None when ``name`` is a registered grid planner. The ``fits`` of the options that name
    one (see :func:`cbrcore.options.reference`)."""
    try:
        component = registry.get("solver", name)
    except UnknownComponent:
        what = "is no registered solver"
    else:
        if plans_on_grids(component):
            return None
        what = (f"is a solver of plugin {component.plugin!r} that does not plan on a given "
                f"passable mask (the solver protocol, cbr_grid.planning.GridPlanner)")
    return f"{name!r} {what}; the grid planners registered: {grid_planners(registry)}"


def planner_of(name: str, ctx: Context, where: str, options: object = None) -> GridPlanner:
    """The solver component ``name`` built from the registry with ``options`` (None: its
    defaults), checked to plan on grids, its every path checked (:class:`CheckedPlanner`); the
    error names ``where`` and the names that fit."""
    problem = planner_problem(ctx.registry, name)
    if problem is not None:
        raise CbrError(f"{where}: {problem}")
    planner = ctx.registry.create("solver", name, options, ctx)
    if not isinstance(planner, GridPlanner):
        raise CbrError(f"{where}: solver {name!r} built a {type(planner).__name__}, which lacks "
                       f"the plan method or constrained property of the solver protocol "
                       f"(cbr_grid.planning.GridPlanner); the grid planners registered: "
                       f"{grid_planners(ctx.registry)}")
    return CheckedPlanner(planner, f"{where}: solver {name!r}")


class CheckedPlanner:
    """A :class:`GridPlanner` whose every path is checked against the protocol, so that a
    plugin's wrong path is an error naming it rather than a robot driving through a wall."""

    def __init__(self, planner: GridPlanner, who: str) -> None:
        self.planner = planner
        self.who = who

    @property
    def constrained(self) -> bool:
        return self.planner.constrained

    def plan(self, grid: Grid, passable: np.ndarray, start: Cell, goals: np.ndarray, *,
             window: Window | None = None, heading: int | None = None) -> np.ndarray | None:
        path = self.planner.plan(grid, passable, start, goals, window=window, heading=heading)
        if path is None:
            return None
        try:
            cells = np.asarray(path, dtype=np.int64).reshape(-1, 2)
        except (TypeError, ValueError):
            raise CbrError(f"{self.who} returned a {type(path).__name__}, not an (n, 2) array "
                           f"of cells") from None
        problems = path_problems(grid, passable, cells, start, goals, window)
        if problems:
            raise CbrError(f"{self.who} returned an invalid path from {tuple(start)}: "
                           f"{'; '.join(problems)}")
        return cells


def path_problems(grid: Grid, passable: np.ndarray, cells: np.ndarray, start: Cell,
                  goals: np.ndarray, window: Window | None = None) -> list[str]:
    """What makes ``cells`` not a path the solver protocol allows: from ``start`` to one of
    ``goals``, inside ``window`` when given, by moves to 8-neighbour cells ``passable`` allows
    under ``grid``'s corner rule; empty if it is one."""
    if len(cells) == 0:
        return ["the path has no cells (no path is None)"]
    problems = []
    if tuple(cells[0].tolist()) != tuple(int(v) for v in start):
        problems.append(f"it starts at {tuple(cells[0].tolist())}, not at the start")
    if not (np.asarray(goals).reshape(-1, 2) == cells[-1]).all(axis=1).any():
        problems.append(f"it ends at {tuple(cells[-1].tolist())}, which is no goal")
    x0, y0, x1, y1 = window or (0, 0, grid.width - 1, grid.height - 1)
    x0, y0 = max(x0, 0), max(y0, 0)
    x1, y1 = min(x1, grid.width - 1), min(y1, grid.height - 1)
    x, y = cells[:, 0], cells[:, 1]
    outside = (x < x0) | (x > x1) | (y < y0) | (y > y1)
    if outside.any():
        first = int(np.argmax(outside))
        problems.append(f"cell {first}, {tuple(cells[first].tolist())}, is outside the "
                        f"{'window' if window else 'grid'}")
        return problems
    blocked = ~passable[y, x]
    if blocked.any():
        first = int(np.argmax(blocked))
        problems.append(f"cell {first}, {tuple(cells[first].tolist())}, is not passable")
    steps = np.diff(cells, axis=0)
    jumps = np.abs(steps).max(axis=1, initial=0) != 1
    if jumps.any():
        first = int(np.argmax(jumps))
        problems.append(f"step {first}, from {tuple(cells[first].tolist())} to "
                        f"{tuple(cells[first + 1].tolist())}, is no move to an 8-neighbour")
        return problems
    diagonal = np.flatnonzero((steps != 0).all(axis=1))
    sides = np.stack([passable[y[diagonal], x[diagonal] + steps[diagonal, 0]],
                      passable[y[diagonal] + steps[diagonal, 1], x[diagonal]]])
    cut = ~(sides.any(axis=0) if grid.corner_cutting else sides.all(axis=0))
    if cut.any():
        first = int(diagonal[np.argmax(cut)])
        problems.append(f"step {first}, from {tuple(cells[first].tolist())}, cuts a blocked "
                        f"corner")
    return problems


@attrs.frozen
class Planned:
    """A path a :class:`GridPlanner` planned ((n, 2) cells) and its cost on the grid's step
    costs (:func:`cbr_grid.costs.path_cost`)."""

    path: np.ndarray
    cost: float


def plan_with(planner: GridPlanner, grid: Grid, start: Cell, goals: np.ndarray,
              window: Window | None = None, *, heading: int | None = None) -> Planned | None:
    """``planner``'s path on ``grid`` through its passable cells, priced; None without one."""
    path = planner.plan(grid, grid.passable, start, goals, window=window, heading=heading)
    if path is None:
        return None
    cells = np.asarray(path, dtype=np.int64).reshape(-1, 2)
    return Planned(cells, path_cost(grid, cells))
