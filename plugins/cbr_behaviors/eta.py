"""How long the robot will take from one point to another: the goal manager's estimate.

A straight line at a nominal speed misjudges both ways: a room across the hallway is a long way
round, and a robot that drives faster or slower than the nominal speed reaches its goals sooner
or later. :class:`RouteEta` takes the length of the route over the permanent map (shortest paths
on its raster, 8-connected, one field per place computed once) and the speed the robot has
really made while busy (:meth:`RouteEta.observe`, a running mean from a prior). Between two
points of which neither is a place it falls back to the straight line times
:data:`DETOUR`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from cbr_world2d.world import Point

DETOUR = 1.4
"""How much longer than the straight line a route is taken to be between two points of which
neither is a place."""
PRIOR_WEIGHT = 60.0
"""Seconds of driving the prior speed counts as in the running mean of the measured speed."""
SLOWEST = 0.1
"""m/s: the measured speed is taken to be at least this (a robot that waited all morning is not
taken to crawl all afternoon)."""


def route_fields(blocked: np.ndarray, cell: float, origin: Point,
                 points: Mapping[str, Point]) -> dict[str, np.ndarray]:
    """For each named point, the length in metres of the shortest 8-connected path over the
    free cells of ``blocked`` (rows y, columns x; cell ``(x, y)`` covers ``origin + [x, x + 1)
    cell``) from every cell to the point's cell (inf where none leads). A point on a blocked
    cell starts from the nearest free one."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    rows, cols = blocked.shape
    free = ~blocked
    ids = np.arange(rows * cols).reshape(rows, cols)
    heads, tails, lengths = [], [], []
    for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):
        y0, y1 = max(0, -dy), rows - max(0, dy)
        x0, x1 = max(0, -dx), cols - max(0, dx)
        a = free[y0:y1, x0:x1]
        b = free[y0 + dy:y1 + dy, x0 + dx:x1 + dx]
        ok = a & b
        if dx and dy:
            # no corner cutting: both cells beside the diagonal step are free
            ok &= free[y0 + dy:y1 + dy, x0:x1] & free[y0:y1, x0 + dx:x1 + dx]
        heads.append(ids[y0:y1, x0:x1][ok])
        tails.append(ids[y0 + dy:y1 + dy, x0 + dx:x1 + dx][ok])
        lengths.append(np.full(int(ok.sum()), cell * math.hypot(dx, dy)))
    head, tail, length = (np.concatenate(v) for v in (heads, tails, lengths))
    graph = coo_matrix((length, (head, tail)), shape=(rows * cols, rows * cols)).tocsr()
    free_y, free_x = np.nonzero(free)
    sources = []
    for x, y in points.values():
        cx, cy = (x - origin[0]) / cell - 0.5, (y - origin[1]) / cell - 0.5
        nearest = int(np.argmin((free_x - cx) ** 2 + (free_y - cy) ** 2))
        sources.append(int(ids[free_y[nearest], free_x[nearest]]))
    fields = dijkstra(graph, directed=False, indices=sources)
    return {name: fields[k].reshape(rows, cols) for k, name in enumerate(points)}


class RouteEta:
    """Seconds from ``a`` to ``b``: the route length over the measured speed (see the module
    docstring). ``fields`` are :func:`route_fields` of the places, ``speed`` the prior."""

    def __init__(self, fields: Mapping[str, np.ndarray], points: Mapping[str, Point],
                 cell: float, origin: Point, speed: float) -> None:
        self.fields = dict(fields)
        self.by_point = {tuple(p): name for name, p in points.items()}
        self.cell, self.origin = cell, origin
        self.prior = speed
        self._distance = 0.0
        self._time = 0.0

    @property
    def speed(self) -> float:
        """m/s: the running mean of the measured busy speed, the prior counting as
        :data:`PRIOR_WEIGHT` seconds of it, at least :data:`SLOWEST`."""
        mean = ((self.prior * PRIOR_WEIGHT + self._distance)
                / (PRIOR_WEIGHT + self._time))
        return max(SLOWEST, mean)

    def observe(self, distance: float, seconds: float) -> None:
        """The robot drove ``distance`` metres in ``seconds`` while busy."""
        self._distance += distance
        self._time += seconds

    def length(self, a: Point, b: Point) -> float:
        """Metres of route from ``a`` to ``b``."""
        for place, other in ((tuple(b), a), (tuple(a), b)):
            name = self.by_point.get(place)
            if name is None:
                continue
            field = self.fields[name]
            x = int((other[0] - self.origin[0]) // self.cell)
            y = int((other[1] - self.origin[1]) // self.cell)
            if 0 <= y < field.shape[0] and 0 <= x < field.shape[1]:
                value = float(field[y, x])
                if math.isfinite(value):
                    return max(value, math.dist(a, b))
            break
        return DETOUR * math.dist(a, b)

    def __call__(self, a: Point, b: Point) -> float:
        return self.length(a, b) / self.speed
