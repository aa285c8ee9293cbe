"""Straight grid segments: the cells they cover and the cutting of a path into them.

A case of the case graph is a straight segment between two cells a and b in one of the 8 grid
directions: ``b - a`` is (k·dx, k·dy) with dx, dy in {-1, 0, 1}. Its cells are a + i·(dx, dy)
for i = 0 .. k, so two of its cells that are 8-neighbours are consecutive along it, and a cell's
position on it is its Chebyshev distance from a.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def direction(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """The unit step (dx, dy) from a towards b."""
    return np.sign(np.asarray(b, dtype=np.int64) - np.asarray(a, dtype=np.int64))


def is_straight(a: ArrayLike, b: ArrayLike) -> bool:
    """Whether a and b are distinct and lie on one of the 8 grid directions."""
    dx, dy = np.abs(np.asarray(b, dtype=np.int64) - np.asarray(a, dtype=np.int64))
    return bool((dx or dy) and (dx == 0 or dy == 0 or dx == dy))


def segment_cells(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """The (k+1, 2) cells of the straight segment from a to b, a first."""
    a = np.asarray(a, dtype=np.int64)
    steps = int(np.abs(np.asarray(b, dtype=np.int64) - a).max())
    return a + np.arange(steps + 1)[:, None] * direction(a, b)


def segments_cells(starts: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The cells of many straight segments at once.

    Returns the concatenated cells (segment after segment, each from its start) and the offset
    of each segment's first cell in them (length n + 1, the last being the total).
    """
    starts = np.asarray(starts, dtype=np.int64).reshape(-1, 2)
    ends = np.asarray(ends, dtype=np.int64).reshape(-1, 2)
    counts = np.abs(ends - starts).max(axis=1) + 1
    offsets = np.zeros(len(counts) + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    owner = np.repeat(np.arange(len(counts)), counts)
    position = np.arange(offsets[-1]) - offsets[owner]
    cells = starts[owner] + position[:, None] * np.sign(ends - starts)[owner]
    return cells, offsets


def square(cell: tuple[int, int], radius: int, width: int, height: int
           ) -> tuple[int, int, int, int]:
    """The square N(cell, radius) clipped to a map of ``width`` x ``height`` cells: (x0, y0,
    x1, y1), inclusive."""
    x, y = cell
    return (max(x - radius, 0), max(y - radius, 0), min(x + radius, width - 1),
            min(y + radius, height - 1))
