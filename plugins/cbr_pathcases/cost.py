"""The cost F(P) = f(l, r, g) of a traversed path (Kruusmaa & Svensson; survey eq. 4).

The papers name the three arguments and leave f open:

``l``
    the length of the path: its steps, 1 straight and sqrt(2) diagonal.
``r``
    the risk "calculated by gathering information during the path following process". Our
    reading: what following the path cost beyond its length. That is the time lost at the stops
    the robot made on it (each obstacle that stopped it costs the ``trips`` workload's
    ``collision_time``) plus the risk of the cells passed on the map the robot learned, as the
    grid's cost model weighs it (the path's cost less its length, so a path through cells where
    obstacles were met before is riskier). Which stops count is the retainer's choice: see
    :class:`cbr_pathcases.components.PathRetainer`.
``g``
    the ideal cost, "the cost of the shortest and easily traversable path from start to goal":
    the length of the shortest path between the path's ends on the robot's map, risk ignored.

``ratio`` (the default) is F = (l + w·r) / g: the travel cost relative to the ideal, 1 for a
shortest path followed without trouble. Dividing by g makes paths between different ends
comparable, which retrieval (candidates whose ends differ by up to delta), forgetting (ranking
the whole case base by cost) and the probabilistic selection all need. ``sum`` is the plain
F = l + w·r, in cells.
"""

from __future__ import annotations

from typing import Literal

import attrs
import numpy as np

from cbr_grid.costs import path_cost, path_length
from cbr_grid.distances import octile
from cbr_grid.grid import Grid

Combine = Literal["ratio", "sum"]


@attrs.frozen
class Measure:
    """What one traversal of a path showed: its length, the risk met, the ideal cost."""

    length: float
    risk: float
    ideal: float

    def cost(self, combine: Combine, risk_weight: float) -> float:
        """F(P) by the rule ``combine``: (l + w·r) / g, or l + w·r."""
        total = self.length + risk_weight * self.risk
        return total / self.ideal if combine == "ratio" else total


def ideal_length(grid: Grid, start: tuple[int, int], goal: tuple[int, int]) -> float:
    """The length of the shortest path from ``start`` to ``goal`` on ``grid``'s passable cells,
    risk ignored; the octile distance when there is none. At least 1, so that a ratio to it is
    defined for a path that returns to its start."""
    from cbr_solvers.search import astar  # compiled: loaded with the first retained path

    found = astar(np.ones(grid.passable.shape), grid.passable, grid.corner_cutting, start,
                  [goal])
    length = found.cost if found is not None else float(octile(start, goal))
    return max(float(length), 1.0)


def measure(grid: Grid, path: np.ndarray, lost: float = 0.0,
            ideal: float | None = None) -> Measure:
    """The measure of ``path`` on ``grid``, the robot's map after the trip: ``lost`` is the
    time lost at the stops made on it, ``ideal`` the ideal cost between its ends (None:
    :func:`ideal_length`)."""
    length = path_length(path)
    risky = max(path_cost(grid, path) - length, 0.0)
    if ideal is None:
        start, goal = (int(path[0, 0]), int(path[0, 1])), (int(path[-1, 0]), int(path[-1, 1]))
        ideal = ideal_length(grid, start, goal)
    return Measure(length, lost + risky, ideal)
