"""The quality test of a proposed grid path: the ``path_quality`` reviser.

Shared by every grid CBR family (the case graph, whole-path cases): a reused path is accepted
when it is valid on the robot's current map, joins start and goal, and is not much longer than
the ideal length between them (step 7 of the case graph planner; Kruusmaa's "if the proposed
path is not good enough" test). The ideal length is a lower bound of any path's length: a
straight-line distance, or the landmark bound of :mod:`cbr_pathquality.ideal`.

A reuser that guarantees its paths' quality (the case graph's ``experience_graph``: cost at most
epsilon · eps_E times the cheapest path's, by construction) states the factor in
``Solution.bound``: a field of cbrcore's envelope, because the proof comes from a sibling family
this one may not import. When that bound is at most ``max_ratio``, a valid path joining start and
goal is accepted without the comparison with the ideal length, which as a lower bound can only
be looser than the optimum the guarantee refers to.
"""

from __future__ import annotations

from typing import Literal

import attrs
import numpy as np

from cbr_grid.costs import path_length
from cbr_grid.distances import distance
from cbr_grid.grid import Grid
from cbr_grid.query import Cell, GridQuery
from cbr_pathquality.ideal import Landmarks
from cbrcore.context import Context
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Revision, Solution
from cbrcore.options import option


@attrs.frozen
class QualityOptions:
    max_ratio: float = option(
        1.5, "Largest accepted ratio of the path's length to the ideal length (step 7). A "
        "solution whose reuser guarantees a bound on its cost (Solution.bound: its cost is at "
        "most bound times the cheapest path's on the map, e.g. reuse 'experience_graph') is "
        "accepted, when valid and joining start and goal, if that bound is at most max_ratio: "
        "max_ratio is then the largest accepted ratio to the optimal cost (length on a "
        "risk-free map), held by proof; a larger bound is tested like any other path.",
        validator=attrs.validators.ge(1.0))
    ideal: Literal["euclidean", "manhattan", "octile", "chebyshev", "landmarks"] = option(
        "octile", "The ideal length between start and goal, a lower bound of any path's "
        "length: a straight-line distance (octile and Chebyshev are exact bounds on an "
        "8-connected grid, Euclidean too; Manhattan is not a lower bound), or 'landmarks', the "
        "much tighter bound from exact distances to a few landmark cells (for maps of rooms "
        "and walls; see cbr_pathquality.ideal).")
    landmarks: int = option(
        8, "How many landmarks the 'landmarks' bound uses. Their tables take 2 bytes per cell "
        "each and at most 512 MiB in all: a map of more than 33.5 million cells gets fewer "
        "(4 on an 8000 x 8000 map), never below one.",
        validator=attrs.validators.ge(1))


class QualityTest:
    """Step 7: accept a valid path whose length is within max_ratio of the ideal length, or
    whose cost its reuser guarantees to be within max_ratio of the optimum."""

    def __init__(self, options: QualityOptions, ctx: Context) -> None:
        self.options = options
        self.landmarks: Landmarks | None = None
        if options.ideal != "landmarks":
            self.distance = distance(options.ideal)

    def _ideal(self, grid: Grid, start: Cell, goal: Cell) -> float:
        if self.options.ideal == "landmarks":
            if self.landmarks is None:
                self.landmarks = Landmarks(grid, self.options.landmarks)
            return self.landmarks.bound(start, goal)
        return float(np.ravel(self.distance(start, goal))[0])

    @hookimpl
    def cbr_warm(self, ctx: Context) -> None:
        """Build the landmark tables of the world's map now: a cost of the map, which the
        first query's revision would otherwise be timed with."""
        if self.options.ideal == "landmarks" and isinstance(ctx.world, Grid):
            self.landmarks = Landmarks(ctx.world, self.options.landmarks)

    def guaranteed(self, solution: Solution) -> bool:
        """Whether the solution's reuser guarantees its cost within max_ratio of the optimum."""
        return (solution.bound is not None
                and 1.0 <= solution.bound <= self.options.max_ratio)

    @hookimpl
    def cbr_revise(self, problem: GridQuery, solution: Solution, ctx: Context) -> Revision:
        grid: Grid = ctx.world
        # one reason per cause, so that the run's fallback counts group them
        if grid.path_problems(solution.value):
            return Revision(False, "invalid on the current map")
        path = np.asarray(solution.value)
        if tuple(path[0]) != tuple(problem.start) or tuple(path[-1]) != tuple(problem.goal):
            return Revision(False, "does not connect start and goal")
        if self.guaranteed(solution):
            return Revision(True)
        ideal = self._ideal(grid, tuple(problem.start), tuple(problem.goal))
        ratio = path_length(path) / ideal if ideal > 0 else 1.0
        if ratio > self.options.max_ratio:
            return Revision(False, f"length ratio above {self.options.max_ratio}")
        return Revision(True)


