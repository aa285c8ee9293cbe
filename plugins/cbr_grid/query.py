"""A path planning query on a grid and the path that answers it."""

from __future__ import annotations

import attrs
import numpy as np

Cell = tuple[int, int]
"""A cell as (x, y): column, row."""


@attrs.frozen
class GridQuery:
    """Plan a path from ``start`` to ``goal`` (cells as (x, y))."""

    start: Cell
    goal: Cell


def path_array(cells: object) -> np.ndarray:
    """A path as an (n, 2) int array of (x, y) rows."""
    array = np.asarray(cells, dtype=np.int64)
    return array.reshape(-1, 2)
