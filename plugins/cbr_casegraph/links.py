"""The temporary edges of a query made outside the compiled kernel (steps 3-4 of
:mod:`cbr_casegraph.planner`): from a terminal to the cells, within N(terminal, delta), of each
case near it.

The Dijkstra connector of a holonomic robot makes them inside :mod:`cbr_casegraph.query`. Here
are the two others: one search per case for a connector that searches once per case
(:func:`searched`), and one edge-based sweep per terminal for a robot with kinematic constraints
(:func:`swept`). Both take the cases as their end cells and the window of the local search as
plain values.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import attrs
import numpy as np

from cbr_casegraph.geometry import segments_cells, square
from cbr_grid.grid import Grid
from cbr_grid.planning import Window
from cbr_kinematics.models import Kinematics
from cbr_solvers.kinematic_search import Sweep, sweep

Cell = tuple[int, int]
Connect = Callable[[Grid, Cell, np.ndarray, Window], Any]
"""A connector's local search: ``connect(grid, start, goals, window)``, a path to one of
``goals`` inside ``window`` with its ``path`` and ``cost``, or None."""


@attrs.frozen
class Link:
    """A temporary edge between a terminal and a case's cell, driven in ``direction`` at the
    cell, with its cost and its cells (from the terminal, or towards it) on demand."""

    target: Cell
    direction: int
    cost: float
    trace: Callable[[], np.ndarray]


def searched(grid: Grid, cell: Cell, ends: tuple[np.ndarray, np.ndarray], delta: int,
             radius: int, search: Connect
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Temporary edges by one search per case (the case from ``ends[0][k]`` to
    ``ends[1][k]``), from ``cell`` to the case's cells inside N(cell, delta), each search kept
    within N(cell, radius): (target cells, costs, path offsets, the paths' cells from
    ``cell``)."""
    cells, offsets = segments_cells(*ends)
    near = np.abs(cells - np.asarray(cell)).max(axis=1) <= delta
    box = square(cell, radius, grid.width, grid.height)
    paths: list[np.ndarray] = []
    costs: list[float] = []
    for k in range(len(offsets) - 1):
        goals = cells[offsets[k]:offsets[k + 1]][near[offsets[k]:offsets[k + 1]]]
        result = search(grid, cell, goals, box)
        if result is not None:
            paths.append(np.asarray(result.path, dtype=np.int64).reshape(-1, 2))
            costs.append(float(result.cost))
    bounds = np.zeros(len(paths) + 1, dtype=np.int64)
    np.cumsum([len(p) for p in paths], out=bounds[1:])
    joined = np.concatenate(paths) if paths else np.zeros((0, 2), dtype=np.int64)
    targets = np.array([p[-1] for p in paths], dtype=np.int64).reshape(-1, 2)
    return targets, np.array(costs, dtype=np.float64), bounds, joined


def swept(grid: Grid, cell: Cell, ends: tuple[np.ndarray, np.ndarray], delta: int, radius: int,
          kinematics: Kinematics, heading: int | None, reverse: bool) -> list[Link]:
    """The temporary edges of one terminal for a robot of ``kinematics``: for each case and
    each direction, one to the case's cheapest cell within N(cell, delta) that the robot
    reaches from ``cell`` facing ``heading`` in that direction (``reverse``: from which it
    reaches ``cell`` able to drive on in ``heading``), by one sweep within N(cell, radius)."""
    cells, offsets = segments_cells(*ends)
    found = sweep(grid.factor, grid.passable, grid.corner_cutting, cell,
                  square(cell, radius, grid.width, grid.height), kinematics=kinematics,
                  heading=heading, reverse=reverse)
    x0, y0, x1, y1 = found.window
    near = (np.abs(cells - np.asarray(cell)).max(axis=1) <= delta) & (
        (cells >= (x0, y0)) & (cells <= (x1, y1))).all(axis=1)
    near &= (cells != np.asarray(cell)).any(axis=1)
    costs = np.full((len(cells), 8), np.inf)
    costs[near] = found.cost[cells[near, 1] - y0, cells[near, 0] - x0]
    best_of: dict[tuple[Cell, int], float] = {}
    for lo, hi in zip(offsets[:-1].tolist(), offsets[1:].tolist(), strict=True):
        if hi == lo:
            continue
        best = np.argmin(costs[lo:hi], axis=0) + lo
        for direction in np.flatnonzero(np.isfinite(costs[best, np.arange(8)])).tolist():
            k = int(best[direction])
            best_of[(int(cells[k, 0]), int(cells[k, 1])), direction] = float(costs[k, direction])
    return [Link(target, direction, cost, _trace(found, target, direction))
            for (target, direction), cost in best_of.items()]


def _trace(found: Sweep, target: Cell, direction: int) -> Callable[[], np.ndarray]:
    """The cells of the swept path to ``target`` arriving in ``direction``, when asked."""
    return lambda: found.path(target, direction)
