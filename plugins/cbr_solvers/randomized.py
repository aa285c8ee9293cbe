"""A randomised map-based search: A* on the grid's cost factor perturbed by per-cell noise.

Kruusmaa's case-based planner falls back on a probabilistic search of the map that gives a
different plausible path each time it is asked, so that the case base gathers alternative routes
between the same places rather than one route over and over. Here each query multiplies the cost
factor of every cell of the search area by its own factor drawn uniformly from [1, 1 + noise] and
runs A* (:func:`cbr_solvers.search.astar`) on the result: the path is the cheapest under the
noisy costs, so near-cheapest under the true ones, and it changes with the draw.

**Bound.** Every noisy step cost is at least the true one and at most 1 + noise times it (a step
averages the factors of its two cells, each scaled by at most 1 + noise). Let P be the path found
and O a cheapest path under the true costs. Then true(P) <= noisy(P) <= noisy(O) <= (1 + noise)
· true(O): the path found costs at most 1 + noise times the optimum, and noise 0 gives the
optimum itself. The returned cost is the path's cost under the true factor, never the noisy one.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import attrs
import numpy as np

from cbr_grid.search_base import checked_arguments
from cbr_kinematics.models import Kinematics
from cbr_solvers.genetic import _cost
from cbr_solvers.kinematic_search import KinematicPath
from cbr_solvers.kinematic_search import astar as kinematic_astar
from cbr_solvers.search import SearchResult, astar


def randomized(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
               start: Sequence[int], goals: object, window: Sequence[int] | None = None, *,
               noise: float = 1.0, seed: int = 0, kinematics: Kinematics | None = None,
               heading: int | None = None, final_heading: int | None = None
               ) -> SearchResult | KinematicPath | None:
    """A near-cheapest path from ``start`` to the nearest of ``goals``, different per ``seed``.

    Arguments, result and errors as for :func:`cbr_solvers.search.astar`; ``cost`` is the path's
    cost under ``factor``, at most 1 + ``noise`` times the optimum. ``noise`` (a finite number
    >= 0) widens the uniform draw [1, 1 + noise] of each cell's cost multiplier; ``seed`` (an
    integer >= 0) fixes the draw. Only the cells of ``window`` are drawn and searched, so a call
    costs in proportion to the window rather than to the grid. With ``kinematics`` the search is
    the modified A* of :mod:`cbr_solvers.kinematic_search` from ``heading`` to ``final_heading``
    (and the bound holds among the paths that robot can drive).
    """
    if isinstance(noise, bool) or not isinstance(noise, int | float) or not (
            math.isfinite(noise) and noise >= 0):
        raise ValueError(f"noise must be a finite number >= 0, got {noise!r}")
    if isinstance(seed, bool) or not (isinstance(seed, int | np.integer) and seed >= 0):
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    factor, passable, (sx, sy), targets, (x0, y0, x1, y1) = checked_arguments(
        factor, passable, start, goals, window)
    inside = ((targets >= (x0, y0)) & (targets <= (x1, y1))).all(axis=1)
    if not (x0 <= sx <= x1 and y0 <= sy <= y1) or not inside.any():
        return None
    # searched on the window cut out, so the noise drawn and the arrays made are the window's
    region = factor[y0:y1 + 1, x0:x1 + 1]
    noisy = region * np.random.default_rng(int(seed)).uniform(1.0, 1.0 + noise, region.shape)
    args = (noisy, passable[y0:y1 + 1, x0:x1 + 1], corner_cutting, (sx - x0, sy - y0),
            targets[inside] - (x0, y0))
    if kinematics is None:
        found = astar(*args)
        if found is None:
            return None
        path = found.path + np.array([x0, y0])
        return SearchResult(path, _cost(factor, path), found.expanded)
    constrained = kinematic_astar(*args, kinematics=kinematics, heading=heading,
                                  final_heading=final_heading)
    if constrained is None:
        return None
    path = constrained.path + np.array([x0, y0])
    return attrs.evolve(constrained, path=path, cost=_cost(factor, path))
