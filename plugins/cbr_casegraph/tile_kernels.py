"""The case graph's cell tiles (:mod:`cbr_casegraph.tiles`) as the compiled kernels read and
write them: a directory lookup, then the cell in its tile."""

from __future__ import annotations

import numpy as np

from cbr_casegraph.tiles import MASK, SHIFT
from cbr_kernels import njit


@njit(inline="always")
def cell_value(directory: np.ndarray, tiles: np.ndarray, layer: int, x: int, y: int) -> int:
    """The layer's value at (x, y), -1 outside every tile. (x, y) must lie in the directory's
    span: the map, rounded up to whole tiles."""
    tile = directory[y >> SHIFT, x >> SHIFT]
    if tile < 0:
        return -1
    return tiles[tile, layer, y & MASK, x & MASK]


@njit(inline="always")
def set_cell(directory: np.ndarray, tiles: np.ndarray, layer: int, x: int, y: int,
             value: int) -> None:
    """Set the layer at (x, y), whose tile must exist."""
    tiles[directory[y >> SHIFT, x >> SHIFT], layer, y & MASK, x & MASK] = value
