"""Lower bounds of a path's length between two cells: the ideal length of the quality test.

The quality test (:mod:`cbr_pathquality.reviser`) compares a path's length with the ideal length
between its ends. A straight-line distance (octile by default) is a lower bound everywhere, but
a weak one where walls force detours: between two rooms of an office the best path is often
three times the octile distance, so a test against it rejects good paths and bad ones alike.

``landmarks`` is the tighter bound of the ALT technique (Goldberg & Harrelson, 2005): the exact
path lengths from a few landmark cells to every cell are computed once, and by the triangle
inequality |d(L, s) - d(L, g)| never exceeds d(s, g) for any landmark L. The landmarks are
picked farthest first (each the reachable cell farthest from those chosen), which spreads them
to the map's extremes, where the bound is tightest.

How tight it is, on the Moving AI maps of ``benchmarks/casegraph_movingai.py`` (the longer half
of each scenario file): with 8 landmarks the bound is within 3% of the optimal length for the
median query on every map (dao, city, maze, room, random), and at least 0.92 of it for nine
queries in ten on the dao and city maps; the 512x512 maze's worst tenth is the loosest (0.78),
and 16 and 32 landmarks raise it to 0.91 and 0.97 at about two and four times the building
time (0.6 and 1.2 s there). Against the octile distance, whose median is 0.11 of the optimum on that
maze and 0.5-0.7 on the 128x128 maze and the larger dao maps, a 1.5 test accepts CBR's path on
92% of that maze's queries instead of none, on 97% instead of 26% on the 128x128 maze and on 85%
instead of 37% on den520d.

The tables are built on the first map seen; they stay lower bounds when cells later become
obstacles, since blocking cells only lengthens paths.
"""

from __future__ import annotations

import numpy as np

from cbr_grid.distances import octile
from cbr_grid.grid import Grid
from cbr_grid.query import Cell


class Landmarks:
    """Landmark distance tables of a grid, and the lower bound they give.

    ``tables`` is one float32 array (count, height, width): 4 bytes per cell and landmark, 2 GB
    for 8 landmarks on an 8000 x 8000 map. Building them needs, besides, two float64 maps (the
    distances to the landmarks chosen so far, which picks the next, and the wavefront's own)
    and the wavefront's byte per cell: 17 bytes per cell.
    """

    def __init__(self, grid: Grid, count: int) -> None:
        from cbr_solvers.aistar import cost_map  # compiled: loaded when a bound is first needed

        passable = grid.passable
        first = int(np.argmax(passable))  # the first passable cell in row-major order
        if not passable.flat[first]:
            self.tables = np.zeros((0, *passable.shape), dtype=np.float32)
            return
        self.tables = np.empty((count, *passable.shape), dtype=np.float32)
        # the first landmark: the cell farthest from an arbitrary passable cell
        y, x = divmod(first, passable.shape[1])
        nearest = cost_map(None, passable, grid.corner_cutting, [(x, y)])
        for k in range(count):
            # Cells the first cell does not reach no landmark reaches: marked -1 once, they
            # stay below every distance in the minimum and are never picked.
            nearest[np.isinf(nearest)] = -1.0
            y, x = divmod(int(np.argmax(nearest)), passable.shape[1])
            table = cost_map(None, passable, grid.corner_cutting, [(x, y)])
            self.tables[k] = table
            if k == 0:
                nearest = table
            else:
                np.minimum(nearest, table, out=nearest)
            del table  # before the next wavefront allocates its own

    def bound(self, start: Cell, goal: Cell) -> float:
        """A lower bound of the length of any path from ``start`` to ``goal``."""
        a = self.tables[:, start[1], start[0]].astype(np.float64)
        b = self.tables[:, goal[1], goal[0]].astype(np.float64)
        both = np.isfinite(a) & np.isfinite(b)
        a, b = a[both], b[both]
        # the tables hold float32: take off their rounding, so the bound stays below the truth
        slack = np.abs(a - b) - (a + b) * 1e-7
        best = float(slack.max(initial=0.0))
        return max(best, float(np.ravel(octile(start, goal))[0]))
