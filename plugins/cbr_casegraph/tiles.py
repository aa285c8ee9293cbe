"""The case graph's two cell layers, kept in tiles made on demand.

For each cell of the map the case graph needs the vertex on it and the edge whose interior covers
it (-1 where none). Two int32 arrays over the whole map would cost 8 bytes per map cell, 512 MB
at 8000 x 8000, though a case graph covers a small share of a large map. :class:`CellTiles`
keeps them in tiles of 8 x 8 cells (both layers: 512 bytes) made the first time a cell of theirs
is set, found through a directory of one int32 per tile (1/16 byte per map cell). A cell in no
tile reads -1. The tiles' array grows by doubling up to the directory's number of tiles, so a
graph covering the whole map costs 8 bytes per cell, as the whole-map layers did. Tiles are
never given back: a case graph forgets edges where it learns others.

The compiled kernels read and write the same arrays through :mod:`cbr_casegraph.tile_kernels`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

SHIFT = 3
"""A tile is 2^SHIFT cells on a side."""
SIZE = 1 << SHIFT
MASK = SIZE - 1
VERTEX = 0
OWNER = 1
"""The layers: the vertex on each cell, the edge whose interior covers it."""


class CellTiles:
    """The vertex and owner layers over a map of ``shape`` (rows, columns), in tiles.

    ``directory[ty, tx]`` is the number of the tile holding cells x in 8·tx .. 8·tx + 7 and
    y in 8·ty .. 8·ty + 7, or -1; ``tiles[t, layer, y & 7, x & 7]`` is the cell's value.
    """

    def __init__(self, shape: tuple[int, int]) -> None:
        self.shape = shape
        h, w = shape
        self.directory = np.full(((h + MASK) >> SHIFT, (w + MASK) >> SHIFT), -1, dtype=np.int32)
        self.tiles = np.full((0, 2, SIZE, SIZE), -1, dtype=np.int32)
        self.count = 0

    @property
    def size(self) -> int:
        """The cells of the map."""
        return self.shape[0] * self.shape[1]

    @property
    def nbytes(self) -> int:
        """The bytes the directory and the tiles (made and spare) hold."""
        return int(self.directory.nbytes + self.tiles.nbytes)

    def get(self, layer: int, xs: ArrayLike, ys: ArrayLike) -> np.ndarray:
        """The layer's values at the cells (xs, ys), -1 outside every tile."""
        xs, ys = np.asarray(xs, dtype=np.int64), np.asarray(ys, dtype=np.int64)
        tile = self.directory[ys >> SHIFT, xs >> SHIFT]
        values = np.full(tile.shape, -1, dtype=np.int32)
        have = tile >= 0
        values[have] = self.tiles[tile[have], layer, ys[have] & MASK, xs[have] & MASK]
        return values

    def value(self, layer: int, x: int, y: int) -> int:
        """The layer's value at the cell (x, y)."""
        tile = self.directory[y >> SHIFT, x >> SHIFT]
        return -1 if tile < 0 else int(self.tiles[tile, layer, y & MASK, x & MASK])

    def set(self, layer: int, xs: ArrayLike, ys: ArrayLike, values: ArrayLike) -> None:
        """Set the layer at the cells (xs, ys), making their tiles if needed."""
        xs, ys = np.asarray(xs, dtype=np.int64), np.asarray(ys, dtype=np.int64)
        self.allocate(xs, ys)
        self.tiles[self.directory[ys >> SHIFT, xs >> SHIFT], layer, ys & MASK, xs & MASK] = values

    def allocate(self, xs: ArrayLike, ys: ArrayLike) -> None:
        """Make the tiles of the cells (xs, ys) that have none, so that a kernel can set them."""
        xs, ys = np.asarray(xs, dtype=np.int64), np.asarray(ys, dtype=np.int64)
        flat = self.directory.reshape(-1)
        keys = (ys >> SHIFT) * self.directory.shape[1] + (xs >> SHIFT)
        missing = np.unique(keys[flat[keys] < 0])
        if len(missing) == 0:
            return
        needed = self.count + len(missing)
        if needed > len(self.tiles):
            # doubling, but never past the directory's tiles: a graph covering the whole map
            # costs what two whole-map layers would
            room = min(max(needed, 2 * len(self.tiles), 16), self.directory.size)
            bigger = np.full((room, 2, SIZE, SIZE), -1, dtype=np.int32)
            bigger[:self.count] = self.tiles[:self.count]
            self.tiles = bigger
        flat[missing] = np.arange(self.count, needed, dtype=np.int32)
        self.count = needed

    def window(self, layer: int, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
        """The layer over the cells [x0, x1] x [y0, y1] (inclusive), rows first."""
        ys, xs = np.mgrid[y0:y1 + 1, x0:x1 + 1]
        return self.get(layer, xs, ys)

    def dense(self, layer: int) -> np.ndarray:
        """The layer over the whole map as one (rows, columns) array: a copy, for inspection."""
        h, w = self.shape
        return self.window(layer, 0, 0, w - 1, h - 1)
