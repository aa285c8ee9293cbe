"""The ``path_quality`` metric: a proposed path's length, turns and cost against the optimum."""

from __future__ import annotations

from collections.abc import Mapping

import attrs
import numpy as np

from cbr_grid.costs import path_cost, path_length, turns
from cbr_grid.grid import grid_world
from cbr_grid.query import GridQuery
from cbr_grid.trips import PLANNED_WORLD
from cbrcore.context import Context
from cbrcore.model import Outcome, Proposal
from cbrcore.options import option


@attrs.frozen
class PathQualityOptions:
    optimal: bool = option(
        True, "Add optimal_cost (A* on the map the proposal was planned on) and deviation; "
        "false leaves out both columns, and the search, on big maps.")


class PathQuality:
    """Per query: the proposed path's length, turns and cost, against the optimal cost.

    Columns ``length``, ``turns``, ``cost`` and, with ``optimal``, ``optimal_cost`` and
    ``deviation`` (cost / optimal_cost - 1); NaN where there is no path. Costs are taken on the
    map the proposal was planned on: the ``trips`` workload records it before the learn step
    may change the run's world, other workloads leave the world as it is.
    """

    def __init__(self, options: PathQualityOptions, ctx: Context) -> None:
        grid_world(ctx, "metric 'path_quality'")
        self.optimal = options.optimal

    def measure(self, problem: GridQuery, proposal: Proposal, outcome: Outcome,
                ctx: Context) -> Mapping[str, float]:
        grid = (ctx.stash[PLANNED_WORLD] if PLANNED_WORLD in ctx.stash
                else grid_world(ctx, "metric 'path_quality'"))
        nan = float("nan")
        row = {"length": nan, "turns": nan, "cost": nan}
        if proposal.solution is not None:
            path = proposal.solution.value
            row = {"length": path_length(path), "turns": float(turns(path)),
                   "cost": path_cost(grid, path)}
        if self.optimal:
            # numba loads with the first measure, not with every start of ``cbr``
            from cbr_solvers.search import astar

            optimal = nan
            if grid.in_bounds(problem.start) and grid.in_bounds(problem.goal):
                best = astar(grid.factor, grid.passable, grid.corner_cutting, problem.start,
                             np.array([problem.goal]))
                optimal = nan if best is None else path_cost(grid, best.path)
            row["optimal_cost"] = optimal
            row["deviation"] = row["cost"] / optimal - 1 if optimal > 0 else nan
        return row
