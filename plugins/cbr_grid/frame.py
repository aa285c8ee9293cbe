"""Where a grid lies in the world: the metric map frame of a ROS map_server map.

A ROS map gives ``resolution`` (metres per cell) and ``origin`` ``[x, y, yaw]``: the pose, in the
map frame, of the image's lower-left pixel corner, the image turned counter-clockwise by ``yaw``
about that corner. The grid's row y = 0 is the image's *top* row, so map-frame y grows as the
row number falls: the cell (x, y) of a grid ``height`` rows high is the image pixel (x, height -
1 - y) counted from the lower left, and its centre lies ``(x + 0.5, height - y - 0.5)`` cells
from the origin along the image's own axes.

Nav2 and most ROS tools read ``yaw`` but ignore it (their costmaps are axis-aligned with the map
frame); here it is honoured by the conversions and the pictures, so a map turned on purpose
stays where it is.
"""

from __future__ import annotations

import math

import attrs
import numpy as np
from numpy.typing import ArrayLike

from cbrcore.errors import CbrError


def _finite(_: object, attribute: attrs.Attribute, value: float) -> None:
    if not math.isfinite(value):
        raise CbrError(f"the map frame's {attribute.name} must be a finite number, got {value!r}")


def _positive(_: object, attribute: attrs.Attribute, value: float) -> None:
    if not (math.isfinite(value) and value > 0):
        raise CbrError(f"the map frame's {attribute.name} must be a positive number of metres "
                       f"per cell, got {value!r}")


def in_metres(point: ArrayLike, cell: ArrayLike) -> str:
    """A map-frame ``point`` as messages write it, in metres with the grid cell it falls in
    (or the cell whose centre it is) in brackets: ``(2, 3.5) m [cell 40, 236]``."""
    (px, py), (x, y) = point, cell
    return f"({px:g}, {py:g}) m [cell {x}, {y}]"


def _points(value: ArrayLike, what: str) -> np.ndarray:
    """``value`` as an (n, 2) float array: one point, or a sequence of points."""
    try:
        points = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CbrError(f"{what} must be numbers (x, y), got {value!r}") from exc
    if points.ndim == 1:
        points = points[None, :]
    if points.ndim != 2 or points.shape[1] != 2:
        raise CbrError(f"{what} must be a point (x, y) or a sequence of them, got shape "
                       f"{np.shape(value)}")
    if not np.isfinite(points).all():
        raise CbrError(f"{what} must be finite numbers, got {value!r}")
    return points


@attrs.frozen
class MapFrame:
    """A grid's place in the metric map frame, as ROS map_server describes it.

    ``resolution`` is the side of a cell in metres; ``x``, ``y`` and ``yaw`` (radians,
    counter-clockwise) are ROS's ``origin``: the pose of the image's lower-left corner.
    """

    resolution: float = attrs.field(converter=float, validator=_positive)
    x: float = attrs.field(default=0.0, converter=float, validator=_finite)
    y: float = attrs.field(default=0.0, converter=float, validator=_finite)
    yaw: float = attrs.field(default=0.0, converter=float, validator=_finite)

    @property
    def origin(self) -> tuple[float, float, float]:
        """``[x, y, yaw]`` as a ROS map YAML writes it."""
        return self.x, self.y, self.yaw

    def _axes(self) -> tuple[float, float]:
        return math.cos(self.yaw), math.sin(self.yaw)

    def to_map(self, cells: ArrayLike, height: int) -> np.ndarray:
        """The map-frame points (metres), (n, 2), at the centres of ``cells`` (x, y) of a grid
        ``height`` rows high. Fractional cells are allowed: (x, y) + (0.5, 0.5) is a corner."""
        return self.centres(_points(cells, "cells"), height)

    def centres(self, xy: np.ndarray, height: int) -> np.ndarray:
        """:meth:`to_map` of an (n, 2) float array already checked (a path's own cells),
        without the checks, which cost more than the conversion on a short path."""
        # along the image's axes, in metres from its lower-left corner
        u = (xy[:, 0] + 0.5) * self.resolution
        v = (height - xy[:, 1] - 0.5) * self.resolution
        c, s = self._axes()
        return np.column_stack((self.x + c * u - s * v, self.y + s * u + c * v))

    def to_cells(self, points: ArrayLike, height: int) -> np.ndarray:
        """The (n, 2) integer cells (x, y) of a grid ``height`` rows high holding the map-frame
        ``points``; a point on a border between cells belongs to the cell right of it or above
        it along the image's axes (with yaw 0: the larger map x, the larger map y, so the
        smaller row y). Cells may lie off the grid."""
        xy = _points(points, "points")
        c, s = self._axes()
        dx, dy = xy[:, 0] - self.x, xy[:, 1] - self.y
        u = (c * dx + s * dy) / self.resolution
        v = (-s * dx + c * dy) / self.resolution
        return np.column_stack((np.floor(u), height - 1 - np.floor(v))).astype(np.int64)

    def corners(self, width: int, height: int) -> np.ndarray:
        """The map-frame points of the grid's four outer corners: lower left, lower right, upper
        right, upper left (as seen in the image)."""
        local = np.array([[0.0, 0.0], [width, 0.0], [width, height], [0.0, height]])
        local *= self.resolution
        c, s = self._axes()
        return np.column_stack((self.x + c * local[:, 0] - s * local[:, 1],
                                self.y + s * local[:, 0] + c * local[:, 1]))

    def extent(self, width: int, height: int) -> tuple[tuple[float, float], tuple[float, float]]:
        """The smallest ranges of map-frame x and y, each (from, to) in metres, that hold the
        whole grid of ``width`` by ``height`` cells."""
        corners = self.corners(width, height)
        (left, bottom), (right, top) = corners.min(0), corners.max(0)
        return (float(left), float(right)), (float(bottom), float(top))

    def spans(self, width: int, height: int) -> str:
        """The grid's extent in words: ``x 0 to 30.2 m and y 0 to 15.35 m``."""
        (left, right), (bottom, top) = self.extent(width, height)
        return f"x {left:g} to {right:g} m and y {bottom:g} to {top:g} m"
