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

**Compact tables.** A table holds each length as a 16-bit count of a unit ``u``, rounded down:
``t = floor(d~ / u)``, where ``d~`` is the length the float64 wavefront computed. ``u`` is the
smallest power of two (in cells) for which twice the greatest length from the first passable
cell fits 65534 units; no length from a landmark exceeds that (both ends lie within that
length of the first cell), and 65535 marks a cell the landmarks do not reach. On the Moving AI
maps ``u`` is 1/64 of a cell (den520d, Berlin_1_256), 1/32 (random512-10-0, 8room_000) or 1/4
(maze512-1-0, whose paths are longest); on an 8000 x 8000 map of random obstacles 1/2.

*Why the bound stays below the truth.* The wavefront adds step lengths along a real path, and
rounding is monotone, so ``d~`` lies within a relative ``delta`` of the exact length ``d``,
``delta = n * 2**-52`` for a map of ``n`` cells (a shortest path has fewer steps than the map
has cells, each addition errs by at most 2**-53 of the sum). From ``u*t <= d~ < u*(t + 1)``:
``d_g - d_s >= d~_g (1 - delta) - d~_s (1 + 2 delta) > u (t_g - t_s - 1) - 2 delta u (t_g +
t_s + 2)``, and by the triangle inequality ``d(s, g) >= |d_g - d_s|``. The bound is therefore
``u * max over landmarks of (|t_s - t_g| - 1 - 2 delta (t_s + t_g + 2))``, and at least the
octile distance; it falls short of the float64 ALT bound by less than two units.
``tests/pathquality/test_memory_bounds.py`` checks it against exact Dijkstra lengths on random
grids.

**Fewer landmarks on very large maps.** The tables take at most :data:`TABLE_BYTES` (512 MiB):
2 bytes per cell and landmark, so the count asked for is lowered to what fits on maps of more
than 33.5 million cells (4 landmarks on an 8000 x 8000 map), never below one. Building them
needs, besides, the wavefront's float64 lengths and byte per cell for one landmark at a time
(9 bytes per cell); the next landmark is picked from the tables a band of rows at a time.

How tight it is, on the Moving AI maps of ``benchmarks/casegraph_movingai.py`` (the longer half
of each scenario file): with 8 landmarks the bound is within 3% of the optimal length for the
median query on every map (dao, city, maze, room, random), and at least 0.92 of it for nine
queries in ten on the dao and city maps; the 512x512 maze's worst tenth is the loosest (0.78),
and 16 and 32 landmarks raise it to 0.91 and 0.97 at about two and four times the building
time (0.6 and 1.2 s there). The 16-bit tables change these ratios by at most 0.0001 (median
and tenth percentile on den520d, Berlin_1_256, maze512-1-0, random512-10-0, 8room_000). With
the 4 landmarks a map of 8000 x 8000 cells gets, the median on those maps is 0.96 (the maze) to
0.996 of the optimum and the tenth percentile 0.59 (the maze) to 0.98. Against the
octile distance, whose median is 0.11 of the optimum on that maze and 0.5-0.7 on the 128x128
maze and the larger dao maps, a 1.5 test accepts CBR's path on 92% of that maze's queries
instead of none, on 97% instead of 26% on the 128x128 maze and on 85% instead of 37% on den520d.

The tables are built on the first map seen; they stay lower bounds when cells later become
obstacles, since blocking cells only lengthens paths.
"""

from __future__ import annotations

import math

import numpy as np

from cbr_grid.distances import octile
from cbr_grid.grid import Grid
from cbr_grid.query import Cell

UNREACHED = int(np.iinfo(np.uint16).max)
"""The table entry of a cell the landmarks do not reach."""
TABLE_BYTES = 1 << 29
"""The most bytes the landmark tables of one map take (512 MiB); see :func:`landmark_count`."""
BAND = 256
"""Rows of a table converted or compared at a time, so that no temporary spans the map."""


def landmark_count(requested: int, cells: int) -> int:
    """How many landmarks a map of ``cells`` cells gets when ``requested`` are asked for: as
    many as fit :data:`TABLE_BYTES` at 2 bytes per cell each, at least one."""
    return max(1, min(requested, TABLE_BYTES // (2 * cells)))


def table_unit(farthest: float) -> float:
    """The tables' unit in cells: the smallest power of two in which twice ``farthest`` (the
    greatest length from the first passable cell) counts at most 65534, with a margin for the
    wavefront's rounding."""
    needed = 2.0 * farthest * (1.0 + 2.0**-20) / (UNREACHED - 1)
    return 2.0 ** math.ceil(math.log2(needed)) if needed > 0.0 else 1.0


class Landmarks:
    """Landmark distance tables of a grid, and the lower bound they give.

    ``tables`` is one uint16 array (count, height, width) of lengths in units of ``unit`` cells,
    rounded down (:data:`UNREACHED` where no landmark reaches): 2 bytes per cell and landmark,
    the count lowered by :func:`landmark_count` on very large maps. ``cells`` lists the
    landmarks (x, y) in the order chosen; ``slack`` is twice the relative rounding error of the
    wavefront's lengths (``delta`` of the module docstring).
    """

    def __init__(self, grid: Grid, count: int) -> None:
        from cbr_solvers.aistar import cost_map  # compiled: loaded when a bound is first needed

        passable = grid.passable
        height, width = passable.shape
        self.slack = passable.size * 2.0**-51
        self.unit = 1.0
        self.cells: list[Cell] = []
        first = int(np.argmax(passable))  # the first passable cell in row-major order
        if not passable.flat[first]:
            self.tables = np.zeros((0, height, width), dtype=np.uint16)
            return
        # the first landmark: the cell farthest from an arbitrary passable cell
        y, x = divmod(first, width)
        reach = cost_map(None, passable, grid.corner_cutting, [(x, y)])
        # Cells the first cell does not reach no landmark reaches: marked -1, never picked.
        reach[np.isinf(reach)] = -1.0
        chosen = int(np.argmax(reach))
        self.unit = table_unit(float(reach.flat[chosen]))
        del reach  # before the first landmark's wavefront allocates its own
        self.tables = np.empty((landmark_count(count, passable.size), height, width),
                               dtype=np.uint16)
        for k in range(len(self.tables)):
            y, x = divmod(chosen, width)
            self.cells.append((x, y))
            self._fill(self.tables[k], cost_map(None, passable, grid.corner_cutting, [(x, y)]))
            if k + 1 < len(self.tables):
                chosen = self._farthest(k + 1)

    def _fill(self, table: np.ndarray, lengths: np.ndarray) -> None:
        """Write ``lengths`` (float64, inf where unreached) into ``table`` in units, rounded
        down, a band of rows at a time."""
        for top in range(0, len(table), BAND):
            units = np.floor(lengths[top:top + BAND] / self.unit)
            # the unit leaves finite lengths below UNREACHED; infinite ones become it
            np.minimum(units, UNREACHED, out=units)
            table[top:top + BAND] = units

    def _farthest(self, count: int) -> int:
        """The flat index of the reached cell whose least length to the first ``count``
        landmarks is greatest, the first in row-major order on a tie."""
        best, where = -2, 0
        width = self.tables.shape[2]
        for top in range(0, self.tables.shape[1], BAND):
            nearest = np.min(self.tables[:count, top:top + BAND], axis=0).astype(np.int32)
            nearest[nearest == UNREACHED] = -1  # unreached cells (obstacles too) are never picked
            i = int(np.argmax(nearest))
            if int(nearest.flat[i]) > best:
                best, where = int(nearest.flat[i]), top * width + i
        return where

    def bound(self, start: Cell, goal: Cell) -> float:
        """A lower bound of the length of any path from ``start`` to ``goal``."""
        a = self.tables[:, start[1], start[0]].astype(np.int64)
        b = self.tables[:, goal[1], goal[0]].astype(np.int64)
        both = (a != UNREACHED) & (b != UNREACHED)
        a, b = a[both], b[both]
        # a unit lost to the rounding down, and the wavefront's rounding (module docstring)
        gap = np.abs(a - b) - 1.0 - self.slack * (a + b + 2)
        best = self.unit * float(gap.max(initial=0.0))
        return max(best, float(np.ravel(octile(start, goal))[0]))
