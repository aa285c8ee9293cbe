"""The case graph's edges priced on the map.

Each edge carries its cost under the grid's step cost contract (``cbr_grid.costs``) and the
mean risk of its cells. The cost is infinite while a cell of the edge is an obstacle on the
current map, which keeps the edge out of every search until the map clears or the edge is
forgotten. When the map changes, only the edges through the changed cells are priced again.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from cbr_casegraph.index import SegmentIndex
from cbr_grid.grid import Grid


def segment_costs(grid: Grid, starts: ArrayLike, ends: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Cost and mean cell risk of straight segments on ``grid``.

    The cost is the sum of the step costs of the segment's cells under the grid's cost contract,
    infinite when a cell is an obstacle or a diagonal step would cut a blocked corner
    (:func:`cbr_casegraph.search.run_costs`).
    """
    # compiled: imported here so that loading the plugin does not load numba
    from cbr_casegraph.search import run_costs, run_risks

    starts = np.ascontiguousarray(np.asarray(starts, dtype=np.int64).reshape(-1, 2))
    ends = np.ascontiguousarray(np.asarray(ends, dtype=np.int64).reshape(-1, 2))
    if len(starts) == 0:
        return np.zeros(0), np.zeros(0)
    return (run_costs(grid.factor, grid.passable, grid.corner_cutting, starts, ends),
            run_risks(grid.risk, starts, ends))


def reprice(index: SegmentIndex, grid: Grid, edges: np.ndarray) -> np.ndarray:
    """Price ``edges`` on ``grid``; returns those whose cost or risk changed."""
    if len(edges) == 0:
        return edges
    cost, risk = segment_costs(grid, *index.ends(edges))
    return edges[index.price(edges, cost, risk)]


def edges_through(index: SegmentIndex, cells: ArrayLike) -> np.ndarray:
    """The edges whose price a change of ``cells`` can change, ascending."""
    touched: set[int] = set()
    h, w = index.shape
    for x, y in np.asarray(cells, dtype=np.int64).reshape(-1, 2).tolist():
        # a diagonal step passing beside a cell has its ends on the cell's orthogonal
        # neighbours: the corner rule makes the cell's change theirs too
        for cx, cy in ((x, y), (x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)):
            if 0 <= cx < w and 0 <= cy < h:
                touched.update(index.edges_at((cx, cy)))
    return np.asarray(sorted(touched), dtype=np.int64)
