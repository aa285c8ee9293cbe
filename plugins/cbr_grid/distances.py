"""Distances between grid cells: Euclidean, Manhattan, octile and Chebyshev.

Each function takes two arrays of (x, y) cells of broadcastable shapes ``(..., 2)`` and returns
the float64 distances of shape ``(...)`` (a 0-d array for two single cells):

- ``euclidean``, eq. (1): sqrt(dx² + dy²), mostly an estimate;
- ``manhattan``, eq. (2): dx + dy, for interior environments with orthogonal moves;
- ``octile``, eq. (3): (sqrt(2) - 1)·min(dx, dy) + max(dx, dy), the length of a shortest
  8-connected path on a free grid;
- ``chebyshev``, eq. (10) of the case graph paper: max(dx, dy), the number of 8-connected steps.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from cbrcore.errors import CbrError

Distance = Callable[[ArrayLike, ArrayLike], np.ndarray]
"""A distance function over arrays of cells."""

DistanceName = Literal["euclidean", "manhattan", "octile", "chebyshev"]
"""The name of a distance, as an option of a configuration takes it."""


def _deltas(a: ArrayLike, b: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    diff = np.abs(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64))
    if diff.ndim == 0 or diff.shape[-1] != 2:
        raise ValueError(f"cells must be (x, y) pairs in the last axis, got shape {diff.shape}")
    return diff[..., 0], diff[..., 1]


def euclidean(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """Eq. (1): the straight-line distance."""
    dx, dy = _deltas(a, b)
    return np.hypot(dx, dy)


def manhattan(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """Eq. (2): the distance with horizontal and vertical moves only."""
    dx, dy = _deltas(a, b)
    return dx + dy


def octile(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """Eq. (3): the length of a shortest 8-connected path with no obstacles in the way."""
    dx, dy = _deltas(a, b)
    return (math.sqrt(2) - 1) * np.minimum(dx, dy) + np.maximum(dx, dy)


def chebyshev(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """Eq. (10): the larger coordinate difference (the number of 8-connected steps)."""
    dx, dy = _deltas(a, b)
    return np.maximum(dx, dy)


DISTANCES: dict[str, Distance] = {
    "euclidean": euclidean,
    "manhattan": manhattan,
    "octile": octile,
    "chebyshev": chebyshev,
}
"""Every distance by the name a configuration uses for it."""


def distance(name: str) -> Distance:
    """The distance called ``name``; the error lists the known names."""
    try:
        return DISTANCES[name]
    except KeyError:
        raise CbrError(f"unknown distance {name!r}; known: {', '.join(DISTANCES)}") from None
