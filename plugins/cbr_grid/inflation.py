"""Inflating obstacles by a robot's radius, by the conventions of Nav2's costmap inflation layer.

A planner on a grid plans for the robot's centre. Nav2 (``nav2_costmap_2d``, the inflation
layer) makes the robot's size part of the map: with d the Euclidean distance from a cell's
centre to the centre of the nearest obstacle cell,

- an obstacle cell costs ``LETHAL`` (254);
- a cell with d <= ``robot_radius`` (the inscribed radius) costs ``INSCRIBED`` (253): the
  robot's centre there means a collision;
- a cell with ``robot_radius`` < d <= ``inflation_radius`` costs
  ``int((INSCRIBED - 1) * exp(-cost_scaling_factor * (d - robot_radius)))``, a cost that decays
  away from obstacles (truncated to an integer, as Nav2's unsigned char is);
- farther cells cost 0 (Nav2 reaches to the inflation radius rounded up to whole cells; here
  the radius is exact).

A distance within a billionth of a cell of a radius counts as within it, so that a radius of a
whole number of cells (0.3 m on 0.1 m cells) reaches the cells that far, whatever the rounding of
3 x 0.1.

Distances and radii are in metres on a grid with a map frame, in cells otherwise. On the grid,
lethal and inscribed cells become obstacles (risk 1) and a decaying cost c the risk c / 254,
kept only where it exceeds the cell's own risk. The obstacles inflated are the known cells of
risk 1: as Nav2's inflation layer (``inflate_unknown`` false, its default) inflates lethal cells
and not unknown ones, unknown cells are never inflated, even where ``allow_unknown`` false makes
them obstacles themselves.
"""

from __future__ import annotations

import math

import attrs
import numpy as np

from cbr_grid.grid import Grid
from cbr_grid.occupancy import LETHAL
from cbrcore.options import option

INSCRIBED = 253
"""Nav2's cost of a cell within the inscribed radius of an obstacle."""
_SLACK = 1e-9
"""How far, in cells, beyond a radius a distance still counts as within it."""


def _non_negative(_: object, attribute: attrs.Attribute, value: float) -> None:
    if not (math.isfinite(value) and value >= 0):
        raise ValueError(f"'{attribute.name}' must be a finite number >= 0, got {value!r}")


def _beyond_robot(instance: Inflation, attribute: attrs.Attribute, value: float | None) -> None:
    if value is not None and not (math.isfinite(value) and value >= instance.robot_radius):
        raise ValueError(f"'{attribute.name}' must be at least robot_radius "
                         f"({instance.robot_radius!r}), got {value!r}")


@attrs.frozen
class Inflation:
    """How far obstacles are inflated: Nav2's inflation layer parameters."""

    robot_radius: float = option(
        doc="The robot's inscribed radius (metres on a map with a frame, else cells): cells "
        "this close to an obstacle become obstacles.", validator=_non_negative)
    inflation_radius: float | None = option(
        None, "How far from obstacles the decaying cost reaches (at least robot_radius); null "
        "inflates the inscribed radius only.", validator=_beyond_robot)
    cost_scaling_factor: float = option(
        3.0, "How fast the cost decays beyond robot_radius, per metre (or cell); Nav2's "
        "default parameters use 3.0.", validator=_non_negative)

    @property
    def reach(self) -> float:
        """The distance beyond which a cell's cost is 0."""
        return self.robot_radius if self.inflation_radius is None else self.inflation_radius


def _known_obstacles(grid: Grid) -> np.ndarray:
    """The obstacle cells ``[y, x]`` the map knows: blocked and not unknown."""
    blocked = ~grid.passable
    return blocked if grid.unknown is None else blocked & ~grid.unknown


def obstacle_distance(grid: Grid) -> np.ndarray:
    """Per cell ``[y, x]``, the Euclidean distance from its centre to the nearest known
    obstacle cell's centre (unknown cells are none): metres with a map frame, cells otherwise;
    infinite without obstacles."""
    blocked = _known_obstacles(grid)
    if not blocked.any():
        return np.full(grid.risk.shape, np.inf)
    # scipy loads on first use: the command line imports every plugin to list its components
    from scipy import ndimage

    # in cells first, then scaled, as Nav2 does (distance * resolution)
    cells = ndimage.distance_transform_edt(~blocked)
    return cells if grid.frame is None else cells * grid.frame.resolution


def costs(grid: Grid, inflation: Inflation) -> np.ndarray:
    """Nav2's inflation costs ``[y, x]`` (uint8, 0 to 254) of ``grid``'s known obstacles."""
    if not _known_obstacles(grid).any():
        return np.zeros(grid.risk.shape, dtype=np.uint8)
    distance = obstacle_distance(grid)
    slack = _SLACK * (1.0 if grid.frame is None else grid.frame.resolution)
    decay = (INSCRIBED - 1) * np.exp(-inflation.cost_scaling_factor
                                     * (distance - inflation.robot_radius))
    cost = np.where(distance <= inflation.reach + slack, np.floor(decay), 0.0)
    cost[distance <= inflation.robot_radius + slack] = INSCRIBED
    cost[distance == 0] = LETHAL
    return cost.astype(np.uint8)


def inflate(grid: Grid, inflation: Inflation) -> Grid:
    """``grid`` with its obstacles inflated (see the module docstring); frame, unknown cells,
    corner rule and cost model kept."""
    cost = costs(grid, inflation)
    added = np.where(cost >= INSCRIBED, 1.0, cost / LETHAL)
    return attrs.evolve(grid, risk=np.maximum(grid.risk, added))
