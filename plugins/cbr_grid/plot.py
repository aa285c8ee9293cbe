"""Pictures of grids: the map in grey levels, and a path over it with its start and goal."""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from cbr_grid.directions import STEPS
from cbr_grid.grid import Grid
from cbr_grid.query import Cell, path_array

_INCHES_PER_CELL = 0.12
_MIN_INCHES, _MAX_INCHES = 4.0, 12.0


def draw_grid(grid: Grid, path: ArrayLike | None = None, start: Cell | None = None,
              goal: Cell | None = None, **headings: ArrayLike | int | None) -> Figure:
    """A figure of ``grid``: free cells white, risk as grey levels, obstacles black.

    ``path`` (a sequence of (x, y) cells) is drawn as a line through the cell centres, ``start``
    as a green circle and ``goal`` as a red cross. Row 0 is at the top, as in a map file.
    ``headings`` are the keyword arguments of :func:`draw_on` that show how a robot of a
    kinematic model drives the path.
    """
    longest = max(grid.width, grid.height)
    inches = min(max(longest * _INCHES_PER_CELL, _MIN_INCHES), _MAX_INCHES)
    figure = Figure(figsize=(inches * grid.width / longest + 1, inches * grid.height / longest))
    draw_on(figure.add_subplot(), grid, path, start, goal, **headings)
    figure.tight_layout()
    return figure


def draw_on(axes: Axes, grid: Grid, path: ArrayLike | None = None, start: Cell | None = None,
            goal: Cell | None = None, *, heading: int | None = None,
            final_heading: int | None = None, reversing: ArrayLike | None = None,
            label: str = "path", legend: bool = True) -> None:
    """Draw ``grid`` and a path into ``axes``, as :func:`draw_grid` does.

    ``heading`` and ``final_heading`` (directions 0-7 of ``cbr_grid.directions``) are
    drawn as arrows at the start and the goal; ``reversing``, one flag per step of the path,
    draws the steps driven in reverse dashed, in orange.
    """
    axes.imshow(1.0 - grid.risk, cmap="gray", vmin=0.0, vmax=1.0, interpolation="nearest",
                origin="upper")
    if path is not None:
        cells = path_array(path)
        axes.plot(cells[:, 0], cells[:, 1], color="tab:blue", linewidth=1.5, label=label)
        if reversing is not None and np.any(reversing):
            back = np.flatnonzero(np.asarray(reversing, dtype=bool))
            for k, i in enumerate(back):
                axes.plot(cells[i:i + 2, 0], cells[i:i + 2, 1], color="tab:orange",
                          linewidth=2.0, linestyle="--", label="reversing" if k == 0 else None)
    for cell, direction, colour in ((start, heading, "tab:green"),
                                    (goal, final_heading, "tab:red")):
        if cell is not None and direction is not None:
            dx, dy = STEPS[direction % 8]
            # longer than a step and above the path, so the arrow shows beside the marker
            axes.annotate("", xy=(cell[0] + 1.8 * dx, cell[1] + 1.8 * dy), xytext=cell,
                          arrowprops={"arrowstyle": "-|>", "color": colour, "linewidth": 2.0,
                                      "mutation_scale": 14}, zorder=5)
    if start is not None:
        axes.plot(*start, marker="o", color="tab:green", markersize=7, linestyle="none",
                  label="start")
    if goal is not None:
        axes.plot(*goal, marker="X", color="tab:red", markersize=8, linestyle="none",
                  label="goal")
    if legend and (path is not None or start is not None or goal is not None):
        axes.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
    axes.set_xlim(-0.5, grid.width - 0.5)
    axes.set_ylim(grid.height - 0.5, -0.5)
    axes.set_xlabel("x")
    axes.set_ylabel("y")
    axes.set_xticks(np.unique(np.linspace(0, grid.width - 1, 5).round()))
    axes.set_yticks(np.unique(np.linspace(0, grid.height - 1, 5).round()))
