"""A path planning query on a grid, and paths as arrays of cells."""

from __future__ import annotations

import attrs
import numpy as np

Cell = tuple[int, int]
"""A cell as (x, y): column, row."""


@attrs.frozen
class GridQuery:
    """Plan a path from ``start`` to ``goal`` (cells as (x, y)).

    ``heading`` is the direction the robot faces at the start and ``final_heading`` the one in
    which it must be able to drive on from the goal, each 0-7 counter-clockwise from east
    (``cbr_grid.directions``) or None for any; only planners for a constrained kinematic
    model heed them.
    """

    start: Cell
    goal: Cell
    heading: int | None = attrs.field(default=None, validator=attrs.validators.optional(
        attrs.validators.in_(range(8))))
    final_heading: int | None = attrs.field(default=None, validator=attrs.validators.optional(
        attrs.validators.in_(range(8))))


def path_array(cells: object) -> np.ndarray:
    """A path as an (n, 2) int array of (x, y) rows."""
    array = np.asarray(cells, dtype=np.int64)
    return array.reshape(-1, 2)


def without_loops(path: object) -> np.ndarray:
    """The path with every loop cut out: each cell visited once, in order.

    When a cell comes back, everything driven since its first visit is dropped, so the result
    is still a connected path of the same steps and never costs more.
    """
    cells = path_array(path)
    flat = cells[:, 0] * (int(cells[:, 1].max(initial=0)) + 1) + cells[:, 1]
    if len(np.unique(flat)) == len(flat):  # the common case, found without a Python loop
        return cells
    seen: dict[tuple[int, int], int] = {}
    kept: list[tuple[int, int]] = []
    for x, y in cells.tolist():
        cell = (x, y)
        if cell in seen:
            cut = seen[cell] + 1
            for dropped in kept[cut:]:
                del seen[dropped]
            del kept[cut:]
        else:
            seen[cell] = len(kept)
            kept.append(cell)
    return np.array(kept, dtype=np.int64).reshape(-1, 2)
