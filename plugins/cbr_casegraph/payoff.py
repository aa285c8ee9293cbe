"""Whether the case graph can pay off for a query: the hybrid's choice between CBR and A*.

A CBR query of the case graph costs a nearly constant time (two local sweeps of
N(., delta + margin) and a search of the case graph, whose vertices are far fewer than the
map's cells), while A* costs in proportion to the cells it settles, which a query's start and
goal bound from both sides: A* settles at least the cells of one path, more than the Chebyshev
distance between them, and at most the passable cells of the map. Where A* will settle few
cells, a CBR attempt costs more than A* itself, and a failed one (no case near, or a path the
quality test rejects) is paid on top of the A* that plans the query after it. So CBR is tried
only where A* may be expensive:

- the map has at least ``min_cells`` passable cells (on a smaller map A* settles fewer cells
  than that whatever the query), and
- start and goal are at least ``min_distance`` apart (Chebyshev).

The thresholds are in cells, the unit of A*'s work, so they move little with the machine; what
moves them is the ratio of A*'s cost per settled cell to a CBR query's cost. Both are off by
default (the papers' hybrid tries the case graph on every query); :data:`MEASURED` gives the
values measured on the Moving AI benchmark (``benchmarks/casegraph_movingai.py``).
"""

from __future__ import annotations

import attrs
import numpy as np

from cbr_grid.grid import Grid
from cbr_grid.query import Cell

SMALL_MAP = "A* is cheaper here: the map is small"
SHORT_QUERY = "A* is cheaper here: start and goal are near"
"""The reasons for leaving a query to A*, as the engine counts them."""


@attrs.frozen
class Payoff:
    """The thresholds of the choice; a query passing both is tried by CBR."""

    min_cells: int = 0
    min_distance: int = 0

    def reason(self, passable_cells: int, start: Cell, goal: Cell) -> str | None:
        """Why A* should plan this query instead of CBR, or None to try CBR."""
        if passable_cells < self.min_cells:
            return SMALL_MAP
        if max(abs(start[0] - goal[0]), abs(start[1] - goal[1])) < self.min_distance:
            return SHORT_QUERY
        return None


MEASURED = Payoff(min_cells=20000, min_distance=64)
"""Thresholds that, with the landmark quality test (``revise: path_quality`` with ``ideal:
landmarks``), keep the hybrid's median time within the target of 1.1 times A*'s on every Moving
AI map of the benchmark, while CBR still saves time where A* is slow (the rendered figures are on
the benchmarks page): the small maps (32x32 to 161x63, the smaller dao maps) leave every query
to A*, the large ones their short queries. With the octile test no threshold of this kind helps
on a maze, where the test rejects every path (the optimum itself is several times the octile
distance) and every attempt is lost."""


class PassableCells:
    """The number of passable cells of the latest map asked about, counted once per map."""

    def __init__(self) -> None:
        self._grid: Grid | None = None
        self._count = 0

    def of(self, grid: Grid) -> int:
        if grid is not self._grid:
            self._grid, self._count = grid, int(np.count_nonzero(grid.passable))
        return self._count
