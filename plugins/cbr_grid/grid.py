"""A rectangular grid of cells carrying a risk each, and the rules for moving on it.

Cells are (x, y) = (column, row); arrays are indexed ``[y, x]``. A cell's risk lies in [0, 1]:
0 is free space, values in between a known hazard (terrain quality, past collisions), 1 an
obstacle. A robot moves to any of its 8 neighbours per step. A diagonal step passes the two
orthogonal cells beside it; by default both must be passable (the Moving AI rule, no corner
cutting). With ``corner_cutting`` a diagonal step may pass one blocked orthogonal cell, but it
never squeezes between two, since a robot cannot pass through the shared corner of two obstacles.

A grid read from a ROS map knows where it lies in metres (``frame``, a
:class:`~cbr_grid.frame.MapFrame`) and which of its cells the map left unknown (``unknown``);
both are None for grids that are cells only, and a changed map (``attrs.evolve``) keeps them.
"""

from __future__ import annotations

import attrs
import numpy as np
from numpy.typing import ArrayLike

from cbr_grid.costs import CostModel, broadcast_factor
from cbr_grid.frame import MapFrame, in_metres
from cbr_grid.occupancy import OCCUPIED, UNKNOWN, occupancy_risk, unknown_risk
from cbr_grid.query import Cell, path_array
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.fingerprint import WorldFingerprint, fingerprint

ALLOW_IN_YAML = "allow_unknown: true"
"""How messages about unknown cells spell the setting that lets a planner cross them."""
_LISTED = 5
"""How many offending cells or steps a problem message lists before summarising the rest."""
UNIFORM_FACTOR_CELLS = 1 << 22
"""Grids of more cells than this (2048 x 2048) whose passable cells all have one cost factor
hold it once (:func:`cbr_grid.costs.broadcast_factor`) instead of 8 bytes a cell. Smaller grids
keep a full array, the layout the compiled kernels are warmed up with."""


def _risk_array(value: ArrayLike) -> np.ndarray:
    """A private, read-only float64 copy of ``value`` after checking it is a valid risk map."""
    try:
        risk = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CbrError(f"grid risk must be an array of numbers: {exc}") from exc
    if risk.ndim != 2:
        raise CbrError(f"grid risk must be 2-D (height, width), got shape {risk.shape}")
    if risk.size == 0:
        raise CbrError(f"grid risk must have at least one cell, got shape {risk.shape}")
    # min and max find any bad value (NaN fails both tests) without a mask the size of the map
    if not (risk.min() >= 0 and risk.max() <= 1):
        bad = ~np.isfinite(risk) | (risk < 0) | (risk > 1)
        y, x = (int(i) for i in np.argwhere(bad)[0])
        raise CbrError(f"grid risk must be finite and within [0, 1]; {int(bad.sum())} cell(s) "
                       f"are not, the first is ({x}, {y}) with {float(risk[y, x])!r}")
    risk.setflags(write=False)
    return risk


def _mask(value: ArrayLike | None) -> np.ndarray | None:
    """A private, read-only boolean copy of ``value``, or None."""
    if value is None:
        return None
    mask = np.array(value)
    if mask.dtype != bool:
        raise CbrError(f"the unknown cells must be a boolean mask, got an array of {mask.dtype}")
    mask.setflags(write=False)
    return mask


def _same_shape(grid: Grid, _: attrs.Attribute, mask: np.ndarray | None) -> None:
    if mask is not None and mask.shape != grid.risk.shape:
        raise CbrError(f"the unknown cells' mask has shape {mask.shape}, the risk "
                       f"{grid.risk.shape}")


def _listing(items: list[str]) -> str:
    shown = ", ".join(items[:_LISTED])
    return shown if len(items) <= _LISTED else f"{shown} and {len(items) - _LISTED} more"


@attrs.frozen(eq=False, repr=False)
class Grid:
    """A rectangular grid world: per-cell risk (1 = obstacle) and the corner cutting rule.

    ``risk`` is copied and made read-only: a changed map is a new grid (``attrs.evolve``), so
    the derived ``passable`` and ``factor`` arrays can be computed once. ``frame`` places the
    grid in a metric map frame; ``unknown`` marks (True) the cells the map does not know,
    whatever risk they were given; ``name`` says where the map came from.
    """

    risk: np.ndarray = attrs.field(converter=_risk_array)
    corner_cutting: bool = attrs.field(default=False,
                                       validator=attrs.validators.instance_of(bool))
    cost_model: CostModel = attrs.field(factory=CostModel,
                                        validator=attrs.validators.instance_of(CostModel))
    frame: MapFrame | None = attrs.field(
        default=None, validator=attrs.validators.optional(attrs.validators.instance_of(MapFrame)))
    unknown: np.ndarray | None = attrs.field(default=None, converter=_mask,
                                             validator=_same_shape)
    name: str = attrs.field(default="", validator=attrs.validators.instance_of(str))
    """Where the map came from, for people (``office 100x100, seed 7``); no part of the map."""
    passable: np.ndarray = attrs.field(init=False)
    """Boolean mask (height, width): True where risk < 1."""
    factor: np.ndarray = attrs.field(init=False)
    """The cost model's per-cell step cost factor (see :mod:`cbr_grid.costs`). On a grid of more
    than :data:`UNIFORM_FACTOR_CELLS` cells whose passable cells share one factor (a map of free
    cells and obstacles), that one value broadcast over every cell, obstacles included."""

    @passable.default
    def _passable(self) -> np.ndarray:
        mask = self.risk < 1
        mask.setflags(write=False)
        return mask

    @factor.default
    def _factor(self) -> np.ndarray:
        if self.risk.size > UNIFORM_FACTOR_CELLS:
            # reductions with a mask, so that no temporary the size of the map is made
            least = float(np.min(self.risk, where=self.passable, initial=np.inf))
            if least < np.inf and least == float(np.max(self.risk, where=self.passable,
                                                        initial=-np.inf)):
                value = float(self.cost_model.factor(np.full(1, least))[0])
                return broadcast_factor(value, self.risk.shape)
        values = self.cost_model.factor(self.risk)
        values.setflags(write=False)
        return values

    @classmethod
    def from_array(cls, array: ArrayLike, *, frame: MapFrame | None = None,
                   allow_unknown: bool = True, corner_cutting: bool = False,
                   cost_model: CostModel | None = None) -> Grid:
        """A grid of an in-memory map ``[y, x]``, row 0 at the top, read by its dtype:

        - booleans: True is an obstacle (risk 1), False free (risk 0);
        - floats: risk values in [0, 1]; NaN marks an unknown cell;
        - int8, the dtype of a ROS ``OccupancyGrid``'s data: -1 unknown and 0 to 100 the
          occupancy, read as Nav2's costmap static layer reads it
          (:func:`~cbr_grid.occupancy.occupancy_risk`: 100 an obstacle, v below it the cost
          ``int(v / 100 * 254)``). An ``OccupancyGrid`` lists its rows bottom first: flip it
          (``data[::-1]``) first.

        Other integer dtypes are refused: an array of 0 and 1 for free and wall, the commonest
        hand-made map, would read as 0 % and 1 % occupancy, all free.

        Unknown cells are marked in ``unknown``; ``allow_unknown`` (Nav2's planners' option and
        default) lets a planner cross them at the highest cost short of an obstacle, False
        makes them obstacles (:func:`~cbr_grid.occupancy.unknown_risk`).
        """
        values = np.asarray(array)
        if values.dtype == bool:
            # The risk converter copies the booleans into float64 itself: no second copy.
            risk, unknown = values, None
        elif values.dtype == np.int8:
            bad = (values < UNKNOWN) | (values > OCCUPIED)
            if bad.any():
                y, x = (int(i) for i in np.argwhere(bad)[0])
                raise CbrError(f"occupancy values must be -1 (unknown) or 0 to 100; "
                               f"{int(bad.sum())} cell(s) are not, the first is ({x}, {y}) "
                               f"with {int(values[y, x])}")
            risk, unknown = occupancy_risk(values, allow_unknown=allow_unknown)
        elif np.issubdtype(values.dtype, np.floating):
            unknown = np.isnan(values)
            risk = np.where(unknown, unknown_risk(allow_unknown), values)
        elif np.issubdtype(values.dtype, np.integer):
            raise CbrError(f"an array of {values.dtype} is ambiguous: expected booleans (True "
                           "an obstacle, e.g. array == 1 for a map of 0 free and 1 wall), "
                           "int8 occupancy values as a ROS OccupancyGrid holds them (-1 unknown, "
                           "0 to 100 percent) or floats (risk in [0, 1])")
        else:
            raise CbrError(f"expected a boolean, int8 (ROS occupancy) or float array, got "
                           f"{values.dtype}")
        if unknown is not None and not unknown.any():
            unknown = None
        return cls(risk, corner_cutting=corner_cutting,
                   cost_model=CostModel() if cost_model is None else cost_model, frame=frame,
                   unknown=unknown)

    def known_passable(self) -> np.ndarray:
        """Boolean mask (height, width): the passable cells the map knows. Unknown space a
        planner may cross (``allow_unknown``) is passable but no place to send a robot to."""
        return self.passable if self.unknown is None else self.passable & ~self.unknown

    @property
    def width(self) -> int:
        """Number of columns (x runs over 0 .. width-1)."""
        return int(self.risk.shape[1])

    @property
    def height(self) -> int:
        """Number of rows (y runs over 0 .. height-1)."""
        return int(self.risk.shape[0])

    def __repr__(self) -> str:
        where = "" if self.frame is None else f", frame={self.frame!r}"
        unknown = "" if self.unknown is None else f", {int(self.unknown.sum())} unknown"
        return (f"Grid({self.width}x{self.height}, {int(self.passable.sum())} passable"
                f"{unknown}, corner_cutting={self.corner_cutting}, "
                f"cost_model={self.cost_model!r}{where})")

    def _frame(self, what: str) -> MapFrame:
        if self.frame is None:
            raise CbrError(f"{what} needs a grid with a map frame; this grid has cells only")
        return self.frame

    def to_map(self, cells: ArrayLike) -> np.ndarray:
        """The (n, 2) map-frame points, in metres, of the centres of ``cells`` (x, y)."""
        return self._frame("converting cells to metres").to_map(cells, self.height)

    def to_cells(self, points: ArrayLike) -> np.ndarray:
        """The (n, 2) cells (x, y) holding the map-frame ``points`` (metres); they may lie off
        the grid (see :meth:`inside`)."""
        return self._frame("converting metres to cells").to_cells(points, self.height)

    def inside(self, cells: ArrayLike) -> np.ndarray:
        """Boolean array, one entry per (x, y) row of ``cells``: is the cell on the grid."""
        xy = path_array(cells)
        return ((xy[:, 0] >= 0) & (xy[:, 0] < self.width)
                & (xy[:, 1] >= 0) & (xy[:, 1] < self.height))

    def in_bounds(self, cell: Cell) -> bool:
        """Whether ``cell`` (x, y) lies on the grid."""
        return bool(self.inside(cell)[0])

    def blocked_reason(self, cell: Cell, allow: str = ALLOW_IN_YAML) -> str:
        """Why the robot cannot stand on ``cell``, a blocked cell of the grid: ``on an
        obstacle``, or for a cell the map does not know the words that tell how to cross
        unknown space, ``allow`` the setting that allows it as the caller spells it."""
        x, y = cell
        if self.unknown is not None and self.unknown[y, x]:
            return (f"on an unknown cell (lethal as unknown space is not allowed; {allow} "
                    "lets a planner cross it)")
        return "on an obstacle"

    def check_cell(self, cell: object, what: str, *, allow: str = ALLOW_IN_YAML) -> Cell:
        """``cell`` as an (x, y) tuple of ints, or a CbrError saying why ``what`` can't be there
        (``allow`` as in :meth:`blocked_reason`)."""
        try:
            xy = np.asarray(cell)
            # integers past 64 bits make an array of objects: on no grid, but integers still
            ok = xy.shape == (2,) and (np.issubdtype(xy.dtype, np.integer) or (
                xy.dtype == object and all(type(v) is int for v in xy)))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise CbrError(f"{what} must be a cell (x, y) of two integers, got {cell!r}")
        x, y = int(xy[0]), int(xy[1])
        if not (0 <= x < self.width and 0 <= y < self.height):
            raise CbrError(f"{what} ({x}, {y}) is outside the {self.width}x{self.height} grid "
                           f"(x in 0..{self.width - 1}, y in 0..{self.height - 1})")
        if not self.passable[y, x]:
            raise CbrError(f"{what} ({x}, {y}) is {self.blocked_reason((x, y), allow)}")
        return x, y

    def check_point(self, point: tuple[float, float], what: str, *,
                    allow: str = ALLOW_IN_YAML) -> Cell:
        """The cell (x, y) holding the map-frame ``point`` (metres), or a CbrError quoting the
        point as written and the cell it falls in, unless that cell is on the grid and free
        (``allow`` as in :meth:`blocked_reason`)."""
        frame = self._frame(f"{what} in metres")
        (left, right), (bottom, top) = frame.extent(self.width, self.height)
        outside = (f"outside the {self.width}x{self.height} grid, which covers "
                   f"{frame.spans(self.width, self.height)}")
        # farther off the grid than 2^52 cells, a cell would not fit an integer of 64 bits
        reach = 2.0**52 * frame.resolution
        if not (left - reach <= point[0] <= right + reach
                and bottom - reach <= point[1] <= top + reach):
            raise CbrError(f"{what} ({point[0]:g}, {point[1]:g}) m is {outside}")
        x, y = (int(v) for v in frame.to_cells(point, self.height)[0])
        said = f"{what} {in_metres(point, (x, y))} is"
        if not self.in_bounds((x, y)):
            raise CbrError(f"{said} {outside}")
        if not self.passable[y, x]:
            raise CbrError(f"{said} {self.blocked_reason((x, y), allow)}")
        return x, y

    def step_allowed(self, a: ArrayLike, b: ArrayLike) -> np.ndarray:
        """Boolean array: may the robot step from each cell of ``a`` to the matching cell of ``b``.

        A step is allowed when both cells are on the grid and passable, they are 8-neighbours,
        and a diagonal step respects the corner cutting rule of the module docstring.
        """
        src, dst = path_array(a), path_array(b)
        delta = dst - src
        ok = (self.inside(src) & self.inside(dst)
              & (np.abs(delta).max(axis=1) == 1))
        # clip so that rows already refused can still be indexed without wrapping around
        sx, sy = np.clip(src[:, 0], 0, self.width - 1), np.clip(src[:, 1], 0, self.height - 1)
        dx, dy = np.clip(dst[:, 0], 0, self.width - 1), np.clip(dst[:, 1], 0, self.height - 1)
        ok &= self.passable[sy, sx] & self.passable[dy, dx]
        # the orthogonal cells a diagonal step passes: (x + dx, y) and (x, y + dy)
        side_a = self.passable[sy, dx]
        side_b = self.passable[dy, sx]
        corners = (side_a | side_b) if self.corner_cutting else (side_a & side_b)
        diagonal = np.abs(delta).sum(axis=1) == 2
        return ok & (~diagonal | corners)

    def changed_cells(self, other: Grid) -> np.ndarray:
        """The (k, 2) cells whose risk differs in ``other``, a grid of the same size, in
        row-major order."""
        ys, xs = np.nonzero(self.risk != other.risk)
        return np.column_stack((xs, ys))

    def path_problems(self, path: ArrayLike) -> list[str]:
        """What makes ``path`` (a sequence of (x, y) cells) not a valid path; empty if valid."""
        cells = path_array(path)
        if len(cells) == 0:
            return ["the path has no cells"]
        problems: list[str] = []
        outside = ~self.inside(cells)
        if outside.any():
            listed = [f"{i}: ({x}, {y})" for i, (x, y) in zip(
                np.flatnonzero(outside), cells[outside].tolist(), strict=True)]
            problems.append(f"cells outside the {self.width}x{self.height} grid at "
                            f"{_listing(listed)}")
        inner = cells[~outside]
        blocked = np.zeros(len(cells), dtype=bool)
        blocked[~outside] = ~self.passable[inner[:, 1], inner[:, 0]]
        if blocked.any():
            listed = [f"{i}: ({x}, {y})" for i, (x, y) in zip(
                np.flatnonzero(blocked), cells[blocked].tolist(), strict=True)]
            problems.append(f"cells on obstacles at {_listing(listed)}")
        steps = np.diff(cells, axis=0)
        jumps = np.abs(steps).max(axis=1, initial=0) != 1
        if jumps.any():
            listed = [f"{i}: ({cells[i][0]}, {cells[i][1]}) to ({cells[i + 1][0]}, "
                      f"{cells[i + 1][1]})" for i in np.flatnonzero(jumps).tolist()]
            problems.append(f"steps that are not moves to an 8-neighbour cell at "
                            f"{_listing(listed)}")
        # corner cutting is judged only on steps whose cells are otherwise fine
        fine = ~jumps & ~(outside | blocked)[:-1] & ~(outside | blocked)[1:]
        cut = fine & ~self.step_allowed(cells[:-1], cells[1:])
        if cut.any():
            listed = [f"{i}: ({cells[i][0]}, {cells[i][1]}) to ({cells[i + 1][0]}, "
                      f"{cells[i + 1][1]})" for i in np.flatnonzero(cut).tolist()]
            rule = ("between two blocked cells" if self.corner_cutting
                    else "past a blocked corner")
            problems.append(f"diagonal steps {rule} at {_listing(listed)}")
        return problems


def grid_fingerprint(grid: Grid) -> WorldFingerprint:
    """The fingerprint of the map a grid family's cases name cells of: its risks, its unknown
    cells, its corner rule and its metric frame (not its name or cost model), described by its
    name and size."""
    size = f"{grid.width}x{grid.height}"
    return fingerprint("cbr_grid.Grid", {
        "risk": grid.risk, "unknown": grid.unknown, "corner_cutting": grid.corner_cutting,
        "frame": grid.frame}, grid.name or f"{size} grid")


def grid_world(ctx: Context, what: str) -> Grid:
    """The run's world, checked to be a grid; ``what`` names the component in the error."""
    if not isinstance(ctx.world, Grid):
        raise CbrError(f"{what} needs a grid world; the configured world is "
                       f"{type(ctx.world).__name__}")
    return ctx.world
