"""Pictures of grids: the map in grey levels, and a path over it with its start and goal.

A grid with a map frame is drawn in metres (axes "x [m]" and "y [m]", the map frame's y up, a
turned frame turned); a grid of cells only in cells, row 0 at the top as in a map file.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from matplotlib.transforms import Affine2D
from numpy.typing import ArrayLike

from cbr_grid.directions import STEPS
from cbr_grid.grid import Grid
from cbr_grid.query import Cell, path_array

_INCHES_PER_CELL = 0.12
_MIN_INCHES, _MAX_INCHES = 4.0, 12.0
UNKNOWN_COLOUR = (0.55, 0.66, 0.82)
"""The colour of unknown cells: a greyish blue, apart from the grey levels of risk."""

Place = Callable[[np.ndarray], np.ndarray]
"""Where (n, 2) cell coordinates (fractional allowed) are drawn on the axes."""


def _image(grid: Grid) -> np.ndarray:
    """The map's RGB picture ``[y, x, channel]``: free white, risk grey, obstacles black,
    unknown cells in :data:`UNKNOWN_COLOUR`."""
    rgb = np.repeat((1.0 - grid.risk)[:, :, None], 3, axis=2)
    if grid.unknown is not None:
        rgb[grid.unknown] = UNKNOWN_COLOUR
    return rgb


def _draw_map(axes: Axes, grid: Grid) -> Place:
    """Draw the map into ``axes``, set its limits and labels, and say where cells go."""
    picture = _image(grid)
    frame = grid.frame
    if frame is None:
        axes.imshow(picture, interpolation="nearest", origin="upper")
        axes.set_xlim(-0.5, grid.width - 0.5)
        axes.set_ylim(grid.height - 0.5, -0.5)
        axes.set_xlabel("x")
        axes.set_ylabel("y")
        axes.set_xticks(np.unique(np.linspace(0, grid.width - 1, 5).round()))
        axes.set_yticks(np.unique(np.linspace(0, grid.height - 1, 5).round()))
        return lambda cells: cells
    width, height = grid.width * frame.resolution, grid.height * frame.resolution
    if frame.yaw == 0:
        axes.imshow(picture, interpolation="nearest", origin="upper",
                    extent=(frame.x, frame.x + width, frame.y, frame.y + height))
    else:
        # drawn along the image's own axes, then turned about its lower-left corner
        image = axes.imshow(picture, interpolation="nearest", origin="upper",
                            extent=(0.0, width, 0.0, height))
        image.set_transform(Affine2D().rotate(frame.yaw).translate(frame.x, frame.y)
                            + axes.transData)
    corners = frame.corners(grid.width, grid.height)
    axes.set_xlim(corners[:, 0].min(), corners[:, 0].max())
    axes.set_ylim(corners[:, 1].min(), corners[:, 1].max())
    axes.set_aspect("equal")
    axes.set_xlabel("x [m]")
    axes.set_ylabel("y [m]")
    return lambda cells: frame.to_map(cells, grid.height)


def draw_grid(grid: Grid, path: ArrayLike | None = None, start: Cell | None = None,
              goal: Cell | None = None, **headings: ArrayLike | int | None) -> Figure:
    """A figure of ``grid``: free cells white, risk as grey levels, obstacles black, unknown
    cells greyish blue; in metres when the grid has a map frame, else in cells.

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
    place = _draw_map(axes, grid)
    if path is not None:
        cells = place(path_array(path).astype(np.float64))
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
            tail, tip = place(np.array([cell, (cell[0] + 1.8 * dx, cell[1] + 1.8 * dy)],
                                       dtype=np.float64))
            axes.annotate("", xy=tuple(tip), xytext=tuple(tail),
                          arrowprops={"arrowstyle": "-|>", "color": colour, "linewidth": 2.0,
                                      "mutation_scale": 14}, zorder=5)
    for cell, marker, colour, size, name in ((start, "o", "tab:green", 7, "start"),
                                             (goal, "X", "tab:red", 8, "goal")):
        if cell is not None:
            (x, y), = place(np.array([cell], dtype=np.float64))
            axes.plot(x, y, marker=marker, color=colour, markersize=size, linestyle="none",
                      label=name)
    unknown = grid.unknown is not None and bool(grid.unknown.any())
    if legend and (path is not None or start is not None or goal is not None or unknown):
        handles, _ = axes.get_legend_handles_labels()
        if unknown:
            handles.append(Patch(facecolor=UNKNOWN_COLOUR, edgecolor="none", label="unknown"))
        axes.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                    fontsize="small")
