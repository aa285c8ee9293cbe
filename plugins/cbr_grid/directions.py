"""The eight directions of grid moves, δ in {0..7}, as the nonholonomic planner numbers them
(section 5 of the case graph paper).

They go round the compass counter-clockwise from east, so opposite directions differ by 4:
δ(i, j) = (δ(j, i) + 4) mod 8, and the turn between two directions a and b is
alpha = |a - b| in 45-degree steps, a turn of at most 45 degrees being alpha in {0, 1, 7}. Cells are
(x, y) = (column, row) with rows counted downwards, so north is the step (0, -1): up on a drawn
map.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

NAMES = ("E", "NE", "N", "NW", "W", "SW", "S", "SE")
"""The name of each direction, by its number."""

STEPS = np.array([[1, 0], [1, -1], [0, -1], [-1, -1], [-1, 0], [-1, 1], [0, 1], [1, 1]],
                 dtype=np.int64)
"""The step (dx, dy) of each direction, by its number."""

# direction number of the step (dx, dy), indexed [dy + 1, dx + 1]; -1 for no step
_OF_STEP = np.full((3, 3), -1, dtype=np.int64)
_OF_STEP[STEPS[:, 1] + 1, STEPS[:, 0] + 1] = np.arange(8)


def parse(value: str | int) -> int:
    """The direction named or numbered by ``value`` (``"NE"``, ``"ne"``, ``1`` or ``"1"``).

    ValueError names the accepted values.
    """
    text = str(value).strip()
    if text.upper() in NAMES:
        return NAMES.index(text.upper())
    if text.lstrip("-").isdigit() and 0 <= int(text) < 8:
        return int(text)
    raise ValueError(f"expected a direction {', '.join(NAMES)} or a number 0-7 (0 = E, "
                     f"counter-clockwise), got {value!r}")


def check_heading(value: object, name: str = "heading") -> None:
    """ValueError unless ``value`` is a direction 0-7 or None (any heading)."""
    if value is not None and (isinstance(value, bool) or value not in range(8)):
        raise ValueError(f"{name} must be a direction 0-7 or None, got {value!r}")


def of_steps(path: ArrayLike) -> np.ndarray:
    """The direction of each step of a path of (x, y) cells; ValueError for a step that is not
    a move to an 8-neighbour."""
    cells = np.asarray(path, dtype=np.int64).reshape(-1, 2)
    steps = np.diff(cells, axis=0)
    bad = np.abs(steps).max(axis=1, initial=0) != 1
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"step {i} from {tuple(cells[i].tolist())} to "
                         f"{tuple(cells[i + 1].tolist())} is not a move to an 8-neighbour")
    return _OF_STEP[steps[:, 1] + 1, steps[:, 0] + 1]


def between(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """The direction from each cell of ``a`` to the matching cell of ``b`` (arrays of (x, y)
    rows); ValueError unless every pair lies on one of the 8 grid directions."""
    diff = np.asarray(b, dtype=np.int64).reshape(-1, 2) - np.asarray(a, dtype=np.int64).reshape(
        -1, 2)
    dx, dy = np.abs(diff[:, 0]), np.abs(diff[:, 1])
    bad = ((dx == 0) & (dy == 0)) | ((dx != 0) & (dy != 0) & (dx != dy))
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"pair {i}: the offset {tuple(diff[i].tolist())} is not along one of "
                         "the 8 grid directions")
    return _OF_STEP[np.sign(diff[:, 1]) + 1, np.sign(diff[:, 0]) + 1]


def reversing(directions: ArrayLike) -> np.ndarray:
    """Which steps of a path, given by their directions, the robot drives in reverse.

    The robot starts driving forward; each cusp, a step straight back along the step before it
    (the out-and-back of a manoeuvre), changes gear.
    """
    d = np.asarray(directions, dtype=np.int64)
    cusps = np.zeros(len(d), dtype=bool)
    cusps[1:] = d[1:] == (d[:-1] + 4) % 8
    return (np.cumsum(cusps) % 2).astype(bool)


def facing(directions: ArrayLike) -> np.ndarray:
    """The way the robot faces after each step of a path, given by their directions: its
    direction of motion, turned round while it reverses (:func:`reversing`)."""
    d = np.asarray(directions, dtype=np.int64)
    return (d + 4 * reversing(d)) % 8
