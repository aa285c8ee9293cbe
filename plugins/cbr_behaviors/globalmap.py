"""RUPART's global map (004): the permanent features of the world plus the transient objects the
sonar reports, rasterised for the grid planners.

004: "The map contains the permanent features of the world, and is augmented by transient
object the robot senses. There is a chance that a transient object is actually noise in its
sensor data. [...] RUPART automatically removes transient objects from the map after a given
period of time, unless the sensors reinforce their presence." and "The map-update subsystem
uses rough evidence grids".

*Permanent* are the world's walls, polygon edges and bounds (its ``static_segments``) and its
point obstacles and landmarks (``static_discs``); doors and movers are not: a shut door or a
person is what the sonar reports as a transient object.

*Transient objects* live on an evidence grid over the world's bounds, ``cell`` metres a side
(default 0.25 m: a person, 0.25 m in radius, covers a cell or two, and a 16 x 10 m office floor
is 64 x 40 cells). Each :meth:`GlobalMap.update` takes the sonar ranges at a pose. A beam's
echo (a range under the sonar's maximum) is *unexplained* when it is shorter by more than
``tolerance`` than the range the permanent map alone gives that beam, computed with the same
cone model as the sonar (:func:`cbr_world2d.geometry.ring_ranges`): a sonar reads the nearest
surface anywhere in its 30 degree cone, so an echo off a wall seen at a slant comes from well
off the beam's axis and is explained only by comparing ranges, not end points. Each
unexplained echo puts evidence at its end point on the beam's axis: the cell it falls in gains
1 (once per update, however many beams hit it) and records the time. A cell whose evidence
reaches ``confirm`` (default 2: one echo may be noise, two updates in a row seldom are) is an
*object*; a cell not sensed again for more than ``fade`` seconds loses its evidence, and an
object there is removed. Objects are counted in cells.

With ``clearing`` (the default) the sonar also removes what it sees through, the other half of
an evidence grid: no surface lies in a cone nearer than its reading, so every cell the cone's
rays cross short of the echo by ``tolerance`` and a cell (wholly nearer, then) loses its
evidence at once, up to the sonar's range when there is no echo. Without it a person walking a
hallway leaves a trail of objects that only time removes, and for ``fade`` seconds the
hallway looks blocked; a robot that sees the trail empty knows better. Cells out of the
sonar's sight still fade as 004 describes.

:meth:`GlobalMap.raster` rasterises the map for the grid planners of :mod:`cbr_grid`, inflated
by ``robot_radius``: a cell whose centre lies nearer than that to a permanent feature is
blocked (risk 1), so a path of free cell centres keeps the robot's disc clear; one that near
an object only is costly, not blocked (a step cost factor of ``transient_cost``, default 10),
since an object may be gone by the time the robot gets there, and the robot's behaviors avoid
what is still there, so a route goes round objects when it can and through them when it must
(``transient_cost`` infinite blocks them instead). :meth:`GlobalMap.route` plans on that
raster with a :class:`cbr_grid.planning.GridPlanner` (the caller takes it from the registry
with :func:`cbr_grid.planning.planner_of`) through given waypoints, and thins the path to
waypoints at most ``spacing`` metres of path apart, each in straight line of sight of the next
over cells no costlier than the path's own; a leg that crosses a doorway is replaced by three
waypoints on the doorway's axis (:data:`DOOR_APPROACH` before its centre, the centre, as far
after), so that the robot meets the gap square rather than at the slant a thinned path takes.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import attrs
import numpy as np

from cbr_grid.costs import CostModel
from cbr_grid.grid import Grid
from cbr_grid.planning import GridPlanner
from cbr_world2d.checks import non_negative, positive
from cbr_world2d.geometry import ring_ranges
from cbr_world2d.robot import PIONEER_2DX, Pose
from cbr_world2d.sensors import SonarRing
from cbr_world2d.world import Point, World

TRANSIENT_RISK = 0.5
"""The risk of a raster cell near a transient object only (see :meth:`GlobalMap.raster`)."""
PERSON_MARGIN = 0.6
"""Metres from a tracked person's centre within which an echo is taken to be that person (a
person's radius, 0.25 m, and the sonar cone's spread across a metre or two)."""
DOOR_MARGIN = 0.3
"""Metres from a doorway's line within which an echo is taken to be its door, shut."""
WALL_MARGIN = 0.35
"""Metres from a permanent wall within which an echo is taken to be the wall: the odometry
drifts by that much between localizations, and an echo of the wall then lands off it. (A cart
against a wall is not mapped; the robot's routes keep off walls anyway.)"""
DOOR_NEAR = 1.2
"""Metres: a doorway this near counts as ``door`` in the index's ``map`` feature, close
enough that passing it takes a doorway's behaviors."""
DOOR_APPROACH = 0.6
"""Metres before and after a doorway at which a route crossing it passes on the doorway's
axis (see :meth:`GlobalMap.route`): square to the door, the robot passes the jambs."""


@attrs.frozen
class MapChange:
    """How many object cells one update added to the map and removed from it."""

    added: int
    removed: int


def _off_segments(x: np.ndarray, y: np.ndarray, segments: np.ndarray,
                  margin: float) -> np.ndarray:
    """Whether each point ``(x, y)`` lies farther than ``margin`` from every segment of
    ``segments`` ``(k, 4)``."""
    if not len(segments):
        return np.ones(x.shape, dtype=bool)
    ax, ay, bx, by = (segments[:, i][None, :] for i in range(4))
    dx, dy = bx - ax, by - ay
    length = np.maximum(dx * dx + dy * dy, 1e-12)
    u = np.clip(((x[:, None] - ax) * dx + (y[:, None] - ay) * dy) / length, 0.0, 1.0)
    gap = np.hypot(x[:, None] - ax - u * dx, y[:, None] - ay - u * dy)
    return (gap > margin).all(axis=1)


def _shape(bounds: tuple[float, float, float, float], cell: float) -> tuple[int, int]:
    """Columns and rows of a grid of ``cell`` covering ``bounds`` (a last partial cell
    included; the small allowance keeps a whole number of cells from growing one)."""
    xmin, ymin, xmax, ymax = bounds
    return (max(1, math.ceil((xmax - xmin) / cell - 1e-9)),
            max(1, math.ceil((ymax - ymin) / cell - 1e-9)))


class _Raster:
    """Marks the cells of a grid of ``cell`` over ``bounds`` whose centres lie nearer than
    ``reach`` to a shape, each shape looked at only over its bounding box."""

    def __init__(self, bounds: tuple[float, float, float, float], cell: float,
                 reach: float) -> None:
        self.xmin, self.ymin = bounds[0], bounds[1]
        self.cell = cell
        self.reach = reach
        self.nx, self.ny = _shape(bounds, cell)
        self.xs = self.xmin + (np.arange(self.nx) + 0.5) * cell
        self.ys = self.ymin + (np.arange(self.ny) + 0.5) * cell
        self.blocked = np.zeros((self.ny, self.nx), dtype=bool)

    def _box(self, x0: float, y0: float, x1: float, y1: float,
             ) -> tuple[slice, slice, np.ndarray, np.ndarray] | None:
        r, c = self.reach, self.cell
        i0 = max(0, math.floor((x0 - r - self.xmin) / c))
        i1 = min(self.nx - 1, math.floor((x1 + r - self.xmin) / c))
        j0 = max(0, math.floor((y0 - r - self.ymin) / c))
        j1 = min(self.ny - 1, math.floor((y1 + r - self.ymin) / c))
        if i0 > i1 or j0 > j1:
            return None
        rows, cols = slice(j0, j1 + 1), slice(i0, i1 + 1)
        return rows, cols, self.xs[cols][None, :], self.ys[rows][:, None]

    def segment(self, x0: float, y0: float, x1: float, y1: float) -> None:
        box = self._box(min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1))
        if box is None:
            return
        rows, cols, px, py = box
        ex, ey = x1 - x0, y1 - y0
        length2 = ex * ex + ey * ey
        s = 0.0 if length2 == 0.0 else np.clip(((px - x0) * ex + (py - y0) * ey) / length2,
                                                0.0, 1.0)
        distance = np.hypot(px - (x0 + s * ex), py - (y0 + s * ey))
        self.blocked[rows, cols] |= distance < self.reach

    def disc(self, x: float, y: float, radius: float) -> None:
        box = self._box(x - radius, y - radius, x + radius, y + radius)
        if box is None:
            return
        rows, cols, px, py = box
        self.blocked[rows, cols] |= np.hypot(px - x, py - y) - radius < self.reach

    def square(self, x: float, y: float, half: float) -> None:
        box = self._box(x - half, y - half, x + half, y + half)
        if box is None:
            return
        rows, cols, px, py = box
        dx = np.maximum(np.abs(px - x) - half, 0.0)
        dy = np.maximum(np.abs(py - y) - half, 0.0)
        self.blocked[rows, cols] |= np.hypot(dx, dy) < self.reach


@attrs.define(on_setattr=attrs.setters.NO_OP)
class GlobalMap:
    """The global map of ``world`` (see the module docstring).

    ``cell``: the evidence grid's cell, metres. ``confirm``: the evidence that makes a cell an
    object. ``fade``: seconds an object stays without being sensed again (default 30 s: long
    enough to remember a cart the robot passed while it plans around it, short enough that
    what the robot left behind clears within a walk along an office's hallway).
    ``tolerance``: metres an echo must fall short of the permanent map's range to be
    unexplained (default 0.3 m: far above the sonar's 1 cm noise, while a person half a metre
    before a wall still shows).
    ``robot_radius``: the inflation of the raster. ``plan_cell``: the raster cell of
    :meth:`route` (default 0.2 m: a 1 m door keeps two or three free cells across once
    inflated by the Pioneer's 0.25 m). ``spacing``: the most path length between two of a
    route's waypoints. ``snap``: how far a route's start, goal or waypoint lying on a blocked
    raster cell moves to the nearest free one. ``near``: the radius of :meth:`objects_near`
    (the index's ``NEAR``, 3 m). ``transient_cost``: the step cost factor of raster cells
    near an object only (at least 1; infinite blocks them). ``clearing``: whether the sonar
    removes the objects it sees through. ``sonar``: the sonar's model (its range, cone and
    mount radius; its beams' headings come with each update).
    """

    world: World
    cell: float = attrs.field(default=0.25, validator=positive)
    confirm: int = attrs.field(default=2, validator=attrs.validators.ge(1))
    fade: float = attrs.field(default=30.0, validator=non_negative)
    tolerance: float = attrs.field(default=0.3, validator=non_negative)
    robot_radius: float = attrs.field(default=PIONEER_2DX.radius, validator=non_negative)
    plan_cell: float = attrs.field(default=0.2, validator=positive)
    spacing: float = attrs.field(default=1.0, validator=positive)
    snap: float = attrs.field(default=0.5, validator=non_negative)
    near: float = attrs.field(default=3.0, validator=non_negative)
    transient_cost: float = attrs.field(default=10.0, validator=attrs.validators.ge(1.0))
    clearing: bool = True
    sonar: SonarRing = attrs.field(factory=SonarRing)
    _evidence: np.ndarray = attrs.field(init=False, repr=False)
    _seen: np.ndarray = attrs.field(init=False, repr=False)
    _objects: np.ndarray = attrs.field(init=False, repr=False)
    _offsets: np.ndarray = attrs.field(init=False, repr=False)
    _steps: np.ndarray = attrs.field(init=False, repr=False)
    _doors: np.ndarray = attrs.field(init=False, repr=False)
    _t: float = attrs.field(default=-math.inf, init=False)
    _version: int = attrs.field(default=0, init=False)
    _permanent: dict[float, np.ndarray] = attrs.field(factory=dict, init=False, repr=False)
    _rasters: dict[float, tuple[int, Grid]] = attrs.field(factory=dict, init=False,
                                                          repr=False)

    def __attrs_post_init__(self) -> None:
        nx, ny = _shape(self.world.bounds, self.cell)
        self._evidence = np.zeros((ny, nx), dtype=np.int64)
        self._seen = np.full((ny, nx), -math.inf)
        self._objects = np.zeros((ny, nx), dtype=bool)
        # the rays across each beam's cone, by the sonar ring's own rule
        ring = self.sonar
        self._offsets = (np.zeros(1) if ring.rays_per_beam == 1 else
                         np.linspace(-ring.beam_width / 2, ring.beam_width / 2,
                                     ring.rays_per_beam))
        # distances from the centre at which clearing samples each ray
        self._steps = np.arange(ring.mount_radius, ring.mount_radius + ring.max_range,
                                self.cell / 2)
        self._doors = np.array([[*d.a, *d.b] for d in self.world.doors],
                               dtype=float).reshape(-1, 4)

    # --- transient objects ----------------------------------------------------------------

    def update(self, pose: Pose, sonar: Sequence[float] | np.ndarray,
               sonar_angles: Sequence[float] | np.ndarray, t: float,
               people: np.ndarray | None = None) -> MapChange:
        """Add the unexplained echoes of ``sonar`` (ranges from the rim, at ``sonar_angles``
        relative to the heading) seen from ``pose`` at time ``t``, fade what was not seen again
        and clear what the sonar sees through; the object cells added and removed. ``people``
        ``(k, 2)`` are where the robot's person tracker sees people now: an echo within
        :data:`PERSON_MARGIN` of one is that person, who will have walked on by the next look,
        not a transient object for the map to keep and route round. Times must not go
        backwards."""
        if t < self._t:
            raise ValueError(f"the map was updated at t={self._t}; t={t} goes back in time")
        self._t = t
        ranges = np.asarray(sonar, dtype=np.float64)
        angles = np.ascontiguousarray(sonar_angles, dtype=np.float64)
        if ranges.shape != angles.shape or ranges.ndim != 1:
            raise ValueError(f"expected one range per sonar angle, got {ranges.shape} ranges "
                             f"and {angles.shape} angles")
        ring = self.sonar
        x, y, theta = float(pose.x), float(pose.y), float(pose.theta)
        expected = ring_ranges(x, y, theta, angles, self._offsets, ring.max_range,
                               ring.mount_radius, self.world.static_segments,
                               self.world.static_discs)
        echo = (ranges < ring.max_range) & (ranges < expected - self.tolerance)
        if echo.any():
            reach = ring.mount_radius + ranges
            hx, hy = x + reach * np.cos(theta + angles), y + reach * np.sin(theta + angles)
            # a shut door is part of the building, not a transient object; so is a wall the
            # odometry's drift shows a little nearer than the map has it
            echo &= _off_segments(hx, hy, self._doors, DOOR_MARGIN)
            echo &= _off_segments(hx, hy, self.world.static_segments, WALL_MARGIN)
            if people is not None and len(people):
                gap = np.hypot(hx[:, None] - people[None, :, 0],
                               hy[:, None] - people[None, :, 1])
                echo &= ~(gap <= PERSON_MARGIN).any(axis=1)
        # fade before adding, so that a sighting long after the last is new evidence again
        self._evidence[t - self._seen > self.fade] = 0
        if self.clearing:
            # every ray of a cone: the cells it crosses short of the echo by the tolerance and a
            # cell (so that no part of them reaches the echo), at half-cell steps
            rays = (theta + angles[:, None] + self._offsets[None, :]).reshape(-1)
            limit = np.repeat(ring.mount_radius + ranges - self.tolerance - self.cell,
                              self._offsets.size)
            steps = self._steps
            free = steps[None, :] < limit[:, None]
            along = np.broadcast_to(steps[None, :], free.shape)[free]
            heading = np.broadcast_to(rays[:, None], free.shape)[free]
            self._evidence.flat[self._cells(x + along * np.cos(heading),
                                            y + along * np.sin(heading), distinct=False)] = 0
        if echo.any():
            reach = ring.mount_radius + ranges[echo]
            heading = theta + angles[echo]
            flat = self._cells(x + reach * np.cos(heading), y + reach * np.sin(heading))
            self._evidence.flat[flat] += 1
            self._seen.flat[flat] = t
        objects = self._evidence >= self.confirm
        added = int(np.count_nonzero(objects & ~self._objects))
        removed = int(np.count_nonzero(self._objects & ~objects))
        self._objects = objects
        if added or removed:
            self._version += 1
        return MapChange(added, removed)

    def _cells(self, px: np.ndarray, py: np.ndarray, distinct: bool = True) -> np.ndarray:
        """The flat indices of the evidence cells holding the points ``px, py``, each once
        when ``distinct`` (points outside the bounds left out)."""
        ny, nx = self._evidence.shape
        i = np.floor((px - self.world.bounds[0]) / self.cell)
        j = np.floor((py - self.world.bounds[1]) / self.cell)
        inside = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
        flat = j[inside].astype(np.int64) * nx + i[inside].astype(np.int64)
        return np.unique(flat) if distinct else flat

    def object_points(self) -> np.ndarray:
        """The centres of the object cells, ``(k, 2)`` rows ``x, y`` in row-major order."""
        rows, cols = np.nonzero(self._objects)
        xmin, ymin = self.world.bounds[0], self.world.bounds[1]
        return np.column_stack((xmin + (cols + 0.5) * self.cell,
                                ymin + (rows + 0.5) * self.cell))

    def objects_near(self, point: Point, radius: float | None = None) -> list[str]:
        """What the map holds near ``point``, by kind, as the index's ``map`` feature names it:
        ``"landmark"`` if a landmark's centre lies within ``radius`` (default ``near``),
        ``"door"`` if a doorway's centre lies within :data:`DOOR_NEAR` (a doorway is part of
        the building; whether its door is open is not), then ``"object"`` if an object cell's
        centre lies within ``radius``. Kinds rather than ids, so that a case written for one
        floor (or learned on it) matches on another."""
        reach = self.near if radius is None else radius
        px, py = point
        names = []
        if any(math.hypot(m.x - px, m.y - py) <= reach for m in self.world.landmarks):
            names.append("landmark")
        if any(math.hypot((d.a[0] + d.b[0]) / 2 - px, (d.a[1] + d.b[1]) / 2 - py) <= DOOR_NEAR
               for d in self.world.doors):
            names.append("door")
        centres = self.object_points()
        if len(centres) and (np.hypot(centres[:, 0] - px, centres[:, 1] - py) <= reach).any():
            names.append("object")
        return names

    # --- the raster and routes ------------------------------------------------------------

    def permanent(self, cell: float) -> np.ndarray:
        """The cells of a raster at ``cell`` metres (rows y, columns x, as :meth:`raster`)
        whose centres lie nearer than ``robot_radius`` to a permanent feature; doors are not
        permanent."""
        if cell not in self._permanent:
            raster = _Raster(self.world.bounds, cell, self.robot_radius)
            for row in self.world.static_segments.tolist():
                raster.segment(*row)
            for row in self.world.static_discs.tolist():
                raster.disc(*row)
            self._permanent[cell] = raster.blocked
        return self._permanent[cell]

    def raster(self, cell: float) -> Grid:
        """The map rasterised at ``cell`` metres for the grid planners. A cell whose centre
        lies nearer than ``robot_radius`` to a permanent feature is blocked (risk 1); one that
        lies that near an object cell only (a square) has risk :data:`TRANSIENT_RISK`, which
        the grid's cost model makes a step cost factor of ``transient_cost`` (risk 1 when
        that is infinite); the rest is free. Cell ``(x, y)`` covers ``[xmin + x cell, xmin +
        (x + 1) cell)`` and likewise in y. The grid is made again only when the objects
        changed."""
        if not (math.isfinite(cell) and cell > 0.0):
            raise ValueError(f"cell must be a finite number > 0, not {cell!r}")
        cached = self._rasters.get(cell)
        if cached is not None and cached[0] == self._version:
            return cached[1]
        permanent = self.permanent(cell)
        transient = _Raster(self.world.bounds, cell, self.robot_radius)
        for x, y in self.object_points().tolist():
            transient.square(x, y, self.cell / 2)
        soft = math.isfinite(self.transient_cost)
        risk = np.where(transient.blocked, TRANSIENT_RISK if soft else 1.0, 0.0)
        risk[permanent] = 1.0
        # factor = 1 + weight * risk, so that a cell of TRANSIENT_RISK costs transient_cost
        weight = (self.transient_cost - 1.0) / TRANSIENT_RISK if soft else 1.0
        grid = Grid(risk, cost_model=CostModel(risk_weight=weight))
        self._rasters[cell] = (self._version, grid)
        return grid

    def _centre(self, cell: np.ndarray) -> np.ndarray:
        """World points of raster cells ``(n, 2)`` of ``plan_cell``."""
        origin = np.array(self.world.bounds[:2])
        return origin + (np.asarray(cell, dtype=np.float64) + 0.5) * self.plan_cell

    def _snapped(self, grid: Grid, point: Point) -> tuple[int, int] | None:
        """The raster cell of ``point``, or the free cell whose centre is nearest within
        ``snap`` when that one is blocked; None outside the bounds or with none."""
        if not self.world.inside(*point):
            return None
        c = self.plan_cell
        x = min(math.floor((point[0] - self.world.bounds[0]) / c), grid.width - 1)
        y = min(math.floor((point[1] - self.world.bounds[1]) / c), grid.height - 1)
        if grid.passable[y, x]:
            return x, y
        k = math.ceil(self.snap / c) + 1
        x0, x1 = max(0, x - k), min(grid.width - 1, x + k)
        y0, y1 = max(0, y - k), min(grid.height - 1, y + k)
        cols, rows = np.meshgrid(np.arange(x0, x1 + 1), np.arange(y0, y1 + 1))
        centres = self._centre(np.stack((cols, rows), axis=-1))
        distance = np.hypot(centres[..., 0] - point[0], centres[..., 1] - point[1])
        distance[~grid.passable[y0:y1 + 1, x0:x1 + 1] | (distance > self.snap)] = math.inf
        best = np.unravel_index(int(np.argmin(distance)), distance.shape)
        if not math.isfinite(distance[best]):
            return None
        return int(cols[best]), int(rows[best])

    def _clear(self, grid: Grid, a: np.ndarray, b: np.ndarray, risk: float) -> bool:
        """Whether the straight line from ``a`` to ``b`` (world points) crosses only cells of
        at most ``risk``, sampled at a quarter cell."""
        steps = math.ceil(math.dist(a, b) / (self.plan_cell / 4)) + 1
        u = np.linspace(0.0, 1.0, steps)[:, None]
        points = a + u * (b - a)
        cells = np.floor((points - np.array(self.world.bounds[:2])) / self.plan_cell)
        cols = np.clip(cells[:, 0].astype(np.int64), 0, grid.width - 1)
        rows = np.clip(cells[:, 1].astype(np.int64), 0, grid.height - 1)
        return bool((grid.risk[rows, cols] <= risk).all())

    def _thinned(self, grid: Grid, path: np.ndarray) -> list[Point]:
        """The waypoints of a cell path: from each kept one, the farthest cell within
        ``spacing`` of path length that it sees in a straight line over cells no riskier than
        the path's cells between them."""
        points = self._centre(path)
        risks = grid.risk[path[:, 1], path[:, 0]]
        arc = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))))
        keep, i, n = [0], 0, len(points)
        while i < n - 1:
            j = i + 1
            while (j + 1 < n and arc[j + 1] - arc[i] <= self.spacing + 1e-9
                   and self._clear(grid, points[i], points[j + 1],
                                   float(risks[i:j + 2].max()))):
                j += 1
            keep.append(j)
            i = j
        return [(float(points[k, 0]), float(points[k, 1])) for k in keep]

    def route(self, planner: GridPlanner, start: Point, goal: Point,
              via: Sequence[Point] = ()) -> list[Point] | None:
        """A route from ``start`` to ``goal`` through the points ``via`` in order, planned by
        ``planner`` on :meth:`raster` at ``plan_cell``: raster cell centres, each leg thinned
        to waypoints at most ``spacing`` of path apart and in sight of each other, the cells
        of ``start``, ``via`` and ``goal`` always among them. None when a point lies outside
        the world or on blocked cells beyond ``snap``, or a leg has no path."""
        route = self._cells_route(planner, start, goal, via)
        return None if route is None else self._through_doors(route)

    def _through_doors(self, route: list[Point]) -> list[Point]:
        """``route`` with each doorway it crosses passed square: the waypoints
        :data:`DOOR_APPROACH` before the doorway's centre, the centre and as far after it,
        in place of the leg that crossed it."""
        out = [route[0]]
        for a, b in itertools.pairwise(route):
            for door in self.world.doors:
                crossing = _door_crossing(a, b, door.a, door.b)
                if crossing is not None:
                    # waypoints already at the doorway would lead the robot back and forth
                    centre = crossing[1]
                    if len(out) > 1 and math.dist(out[-1], centre) < DOOR_APPROACH:
                        out.pop()
                    out += crossing
                    break
            if math.dist(out[-1], b) > 1e-9 and (b == route[-1] or math.dist(
                    b, out[-2] if len(out) > 1 else out[-1]) >= DOOR_APPROACH):
                out.append(b)
        return out

    def _cells_route(self, planner: GridPlanner, start: Point, goal: Point,
                     via: Sequence[Point]) -> list[Point] | None:
        grid = self.raster(self.plan_cell)
        snapped = [self._snapped(grid, p) for p in (start, *via, goal)]
        cells = [c for c in snapped if c is not None]
        if len(cells) < len(snapped):
            return None
        route: list[Point] = []
        for a, b in itertools.pairwise(cells):
            if a == b:
                leg = np.array([a], dtype=np.int64)
            else:
                found = planner.plan(grid, grid.passable, a, np.array([b], dtype=np.int64))
                if found is None:
                    return None
                leg = found
            waypoints = self._thinned(grid, leg)
            route.extend(waypoints if not route else waypoints[1:])
        return route

    def route_length(self, planner: GridPlanner, start: Point, goal: Point,
                     via: Sequence[Point] = ()) -> float:
        """The length in metres of :meth:`route` along its waypoints; infinite when there is
        no route."""
        route = self.route(planner, start, goal, via)
        if route is None:
            return math.inf
        return float(sum(math.dist(a, b) for a, b in itertools.pairwise(route)))


def _door_crossing(a: Point, b: Point, d0: Point, d1: Point) -> list[Point] | None:
    """The waypoints that pass the doorway ``d0``-``d1`` square when the leg ``a``-``b``
    crosses it (before, centre, after, in the leg's direction), else None."""
    ex, ey = d1[0] - d0[0], d1[1] - d0[1]
    sx, sy = b[0] - a[0], b[1] - a[1]
    denominator = sx * ey - sy * ex
    if denominator == 0.0:
        return None
    u = ((d0[0] - a[0]) * ey - (d0[1] - a[1]) * ex) / denominator
    v = ((d0[0] - a[0]) * sy - (d0[1] - a[1]) * sx) / denominator
    if not (0.0 <= u <= 1.0 and 0.0 <= v <= 1.0):
        return None
    length = math.hypot(ex, ey)
    nx, ny = -ey / length, ex / length
    if nx * sx + ny * sy < 0.0:
        nx, ny = -nx, -ny
    cx, cy = (d0[0] + d1[0]) / 2, (d0[1] + d1[1]) / 2
    return [(cx - DOOR_APPROACH * nx, cy - DOOR_APPROACH * ny), (cx, cy),
            (cx + DOOR_APPROACH * nx, cy + DOOR_APPROACH * ny)]
