"""Pictures of grids: the map in grey levels, and a path over it with its start and goal.

A grid with a map frame is drawn in metres (axes "x [m]" and "y [m]", the map frame's y up, a
turned frame turned); a grid of cells only in cells, row 0 at the top as in a map file.

A map with unknown cells (a ROS map from SLAM is mostly unknown: Nav2's TurtleBot3 sandbox map
is 95 % unknown) is shown cropped to what it knows: the smallest box of cells holding every
cell that is not unknown and whatever is drawn on the map (path, start, goal), widened on each
side by :data:`CROP_MARGIN` of the box's longer side and at least :data:`CROP_MARGIN_CELLS`
cells, within the grid. The axes keep the map's coordinates (metres in the map frame).
"""

from __future__ import annotations

import math
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

CROP_MARGIN = 0.05
"""The margin around the known cells of a cropped picture, as a fraction of the longer side of
their box."""
CROP_MARGIN_CELLS = 2
"""The least margin, in cells, around the known cells of a cropped picture."""

Place = Callable[[np.ndarray], np.ndarray]
"""Where (n, 2) cell coordinates (fractional allowed) are drawn on the axes."""


def _image(grid: Grid) -> np.ndarray:
    """The map's RGB picture ``[y, x, channel]``: free white, risk grey, obstacles black,
    unknown cells in :data:`UNKNOWN_COLOUR`."""
    rgb = np.repeat((1.0 - grid.risk)[:, :, None], 3, axis=2)
    if grid.unknown is not None:
        rgb[grid.unknown] = UNKNOWN_COLOUR
    return rgb


def shown_cells(grid: Grid, drawn: ArrayLike | None = None) -> tuple[int, int, int, int]:
    """The cells a picture of ``grid`` shows, ``(x0, y0, x1, y1)`` with x0 <= x < x1 and
    y0 <= y < y1: the whole grid, or for a map with unknown cells the box of its known cells
    and the ``drawn`` (x, y) cells with the margin of the module docstring."""
    known = None if grid.unknown is None else ~grid.unknown
    if known is None or known.all() or not known.any():
        return 0, 0, grid.width, grid.height
    rows, columns = np.flatnonzero(known.any(axis=1)), np.flatnonzero(known.any(axis=0))
    x0, x1, y0, y1 = columns[0], columns[-1] + 1, rows[0], rows[-1] + 1
    if drawn is not None:
        cells = path_array(drawn)
        if len(cells):
            x0, y0 = min(x0, cells[:, 0].min()), min(y0, cells[:, 1].min())
            x1, y1 = max(x1, cells[:, 0].max() + 1), max(y1, cells[:, 1].max() + 1)
    margin = max(CROP_MARGIN_CELLS, math.ceil(CROP_MARGIN * max(x1 - x0, y1 - y0)))
    return (int(max(x0 - margin, 0)), int(max(y0 - margin, 0)),
            int(min(x1 + margin, grid.width)), int(min(y1 + margin, grid.height)))


def _draw_map(axes: Axes, grid: Grid, drawn: ArrayLike | None = None) -> Place:
    """Draw the map into ``axes``, set its limits (cropped to :func:`shown_cells`) and labels,
    and say where cells go."""
    picture = _image(grid)
    frame = grid.frame
    x0, y0, x1, y1 = shown_cells(grid, drawn)
    if frame is None:
        axes.imshow(picture, interpolation="nearest", origin="upper")
        axes.set_xlim(x0 - 0.5, x1 - 0.5)
        axes.set_ylim(y1 - 0.5, y0 - 0.5)
        axes.set_xlabel("x")
        axes.set_ylabel("y")
        axes.set_xticks(np.unique(np.linspace(x0, x1 - 1, 5).round()))
        axes.set_yticks(np.unique(np.linspace(y0, y1 - 1, 5).round()))
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
    # the outer corners of the shown cells, whose centres are half a cell in
    corners = frame.to_map([(x0 - 0.5, y0 - 0.5), (x1 - 0.5, y0 - 0.5), (x1 - 0.5, y1 - 0.5),
                            (x0 - 0.5, y1 - 0.5)], grid.height)
    axes.set_xlim(corners[:, 0].min(), corners[:, 0].max())
    axes.set_ylim(corners[:, 1].min(), corners[:, 1].max())
    axes.set_aspect("equal")
    axes.set_xlabel("x [m]")
    axes.set_ylabel("y [m]")
    return lambda cells: frame.to_map(cells, grid.height)


def _drawn(path: ArrayLike | None, start: Cell | None, goal: Cell | None) -> np.ndarray:
    """The (n, 2) cells a picture draws on the map: the path's, the start and the goal."""
    cells = [path_array(path)] if path is not None else []
    cells += [path_array([cell]) for cell in (start, goal) if cell is not None]
    return np.concatenate(cells) if cells else np.empty((0, 2), dtype=np.int64)


def draw_grid(grid: Grid, path: ArrayLike | None = None, start: Cell | None = None,
              goal: Cell | None = None, **headings: ArrayLike | int | None) -> Figure:
    """A figure of ``grid``: free cells white, risk as grey levels, obstacles black, unknown
    cells greyish blue; in metres when the grid has a map frame, else in cells; a map with
    unknown cells cropped to what it knows (see the module docstring).

    ``path`` (a sequence of (x, y) cells) is drawn as a line through the cell centres, ``start``
    as a green circle and ``goal`` as a red cross. Row 0 is at the top, as in a map file.
    ``headings`` are the keyword arguments of :func:`draw_on` that show how a robot of a
    kinematic model drives the path.
    """
    x0, y0, x1, y1 = shown_cells(grid, _drawn(path, start, goal))
    width, height = x1 - x0, y1 - y0
    longest = max(width, height)
    inches = min(max(longest * _INCHES_PER_CELL, _MIN_INCHES), _MAX_INCHES)
    figure = Figure(figsize=(inches * width / longest + 1, inches * height / longest))
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
    place = _draw_map(axes, grid, _drawn(path, start, goal))
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
