"""Plane geometry in numpy for what is checked once per world or per trial rather than every
step: distances from a point to segments, a point inside a polygon, segments meeting, simple
polygons, the wall between two landmarks' rims, and why a disc cannot stand at a point of a
world (:func:`free_point`).

The per-step kernels are compiled in :mod:`cbr_world2d.geometry`; these are not, so that
reading a world file does not import numba. Points are ``(x, y)`` in metres; segments are
``(n, 4)`` rows ``x0, y0, x1, y1``, discs ``(m, 3)`` rows ``x, y, radius``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from cbr_world2d.checks import point_text
from cbr_world2d.world import Landmark, Point, Wall, World

MIN_LENGTH = 1e-6
"""Walls, doors and polygon edges shorter than this (a micrometre) count as zero-length: the
geometry kernels divide by their lengths."""


def _orient(ox: np.ndarray, oy: np.ndarray, ax: np.ndarray, ay: np.ndarray, bx: np.ndarray,
            by: np.ndarray) -> np.ndarray:
    return np.sign((ax - ox) * (by - oy) - (ay - oy) * (bx - ox))


def _on_box(p: np.ndarray, qx: np.ndarray, qy: np.ndarray) -> np.ndarray:
    """Whether ``(qx, qy)``, collinear with segment ``p``, lies within its bounding box."""
    return ((np.minimum(p[:, 0], p[:, 2]) <= qx) & (qx <= np.maximum(p[:, 0], p[:, 2]))
            & (np.minimum(p[:, 1], p[:, 3]) <= qy) & (qy <= np.maximum(p[:, 1], p[:, 3])))


def segments_meet(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Whether the closed segments ``p[i]`` and ``q[i]`` (rows ``x0, y0, x1, y1``) share a
    point, touching included; exact orientation tests, vectorised over the rows."""
    d1 = _orient(q[:, 0], q[:, 1], q[:, 2], q[:, 3], p[:, 0], p[:, 1])
    d2 = _orient(q[:, 0], q[:, 1], q[:, 2], q[:, 3], p[:, 2], p[:, 3])
    d3 = _orient(p[:, 0], p[:, 1], p[:, 2], p[:, 3], q[:, 0], q[:, 1])
    d4 = _orient(p[:, 0], p[:, 1], p[:, 2], p[:, 3], q[:, 2], q[:, 3])
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)
    touch = (((d1 == 0) & _on_box(q, p[:, 0], p[:, 1])) | ((d2 == 0) & _on_box(q, p[:, 2], p[:, 3]))
             | ((d3 == 0) & _on_box(p, q[:, 0], q[:, 1]))
             | ((d4 == 0) & _on_box(p, q[:, 2], q[:, 3])))
    return proper | touch


def polygon_problem(vertices: np.ndarray) -> tuple[int | None, str] | None:
    """Why the vertices ``(k, 2)`` do not make a simple polygon, as ``(vertex index or None,
    message)``, or None when they do: fewer than three vertices, two consecutive ones the same,
    no area, or edges that cross, touch or fold back on each other."""
    k = len(vertices)
    if k < 3:
        return None, f"expected at least 3 vertices [x, y], got {k}"
    nxt = np.roll(vertices, -1, axis=0)
    lengths = np.hypot(*(nxt - vertices).T)
    if (short := np.flatnonzero(lengths < MIN_LENGTH)).size:
        i = int(short[0])
        return (i + 1) % k, (f"expected a vertex apart from vertex {i} "
                             f"{point_text(vertices[i])}, got "
                             f"{point_text(vertices[(i + 1) % k])}")
    edges = np.concatenate([vertices, nxt], axis=1)
    # consecutive edges share a vertex; they overlap only when they fold straight back
    before, after = vertices - np.roll(vertices, 1, axis=0), nxt - vertices
    cross = before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0]
    dot = (before * after).sum(axis=1)
    if (fold := np.flatnonzero((cross == 0) & (dot < 0))).size:
        i = int(fold[0])
        return i, f"expected a simple polygon, got edges {(i - 1) % k} and {i} folding back at " \
                  f"vertex {i} {point_text(vertices[i])}"
    i, j = np.triu_indices(k, 2)
    apart = ~((i == 0) & (j == k - 1))
    i, j = i[apart], j[apart]
    meet = segments_meet(edges[i], edges[j])
    if meet.any():
        first = int(np.flatnonzero(meet)[0])
        return None, f"expected a simple polygon, got edges {i[first]} and {j[first]} crossing " \
                     "or touching"
    # a simple polygon has an area; this catches what rounding let through the tests above
    area = 0.5 * float(np.sum(vertices[:, 0] * nxt[:, 1] - nxt[:, 0] * vertices[:, 1]))
    extent = float(np.ptp(vertices, axis=0).max())
    if abs(area) <= 1e-12 * extent * extent:
        return None, f"expected a polygon with an area, got area {area:.3g}"
    return None


def rim_wall(first: Landmark, second: Landmark) -> tuple[Point, Point] | None:
    """The segment joining the facing rim points of two landmarks, None when they overlap."""
    dx, dy = second.x - first.x, second.y - first.y
    gap = math.hypot(dx, dy)
    if gap - first.radius - second.radius < MIN_LENGTH:
        return None
    ux, uy = dx / gap, dy / gap
    return ((first.x + first.radius * ux, first.y + first.radius * uy),
            (second.x - second.radius * ux, second.y - second.radius * uy))


# --- free points ---------------------------------------------------------------------------------

def segment_distances(x: float, y: float, segments: np.ndarray) -> np.ndarray:
    """The distance from ``(x, y)`` to each segment of ``segments`` ``(n, 4)``, ``(n,)``."""
    a = segments[:, :2]
    d = segments[:, 2:] - a
    p = np.array([x, y], dtype=float)
    length2 = (d * d).sum(axis=1)
    u = np.clip(((p - a) * d).sum(axis=1) / np.where(length2 > 0, length2, 1.0), 0.0, 1.0)
    return np.hypot(*(a + u[:, None] * d - p).T)


def inside_polygon(x: float, y: float, polygon: np.ndarray) -> bool:
    """Whether ``(x, y)`` lies inside the polygon of vertices ``(k, 2)`` (even-odd rule: a ray
    from the point toward +x crosses its edges an odd number of times)."""
    xi, yi = polygon[:, 0], polygon[:, 1]
    xj, yj = np.roll(xi, 1), np.roll(yi, 1)
    spans = (yi > y) != (yj > y)
    # a horizontal edge spans nothing, so its division by zero is never counted
    with np.errstate(divide="ignore", invalid="ignore"):
        crossing = xi + (y - yi) * (xj - xi) / (yj - yi)
    return bool(np.count_nonzero(spans & (x < crossing)) % 2)


def _rows(items: Sequence[Sequence[float]], width: int) -> np.ndarray:
    return np.asarray(items, dtype=float).reshape(-1, width)


def _nearest(gaps: np.ndarray, radius: float) -> int | None:
    """The index of the first gap not above ``radius``, None when every gap is larger."""
    hit = np.flatnonzero(gaps <= radius)
    return int(hit[np.argmin(gaps[hit])]) if hit.size else None


def _phrase(gap: float, radius: float, label: str, solid: bool) -> str:
    if gap <= 0:
        return f"is {'inside' if solid else 'on'} {label}"
    return f"is {gap:.3g} m from {label}, within the radius {radius:g}"


def free_point(world: World, x: float, y: float, radius: float = 0.0,
               t: float | None = None) -> str | None:
    """Why a disc of ``radius`` at ``(x, y)`` cannot stand in ``world``, or None when it can.

    The reason is a phrase to follow the point (``"is inside polygon 2"``, ``"is 0.05 m from
    landmark 'l1', within the radius 0.2"``) naming the first thing in the way: the bounds,
    a polygon, a wall, a door (shut or open: it may shut), a point obstacle, a landmark, and,
    when ``t`` is given, a mover present at ``t``. Touching counts as in the way.
    """
    if not (math.isfinite(x) and math.isfinite(y)):
        return "is not a finite point"
    if not (math.isfinite(radius) and radius >= 0):
        raise ValueError(f"expected a non-negative radius, got {radius!r}")
    if not world.inside(x, y):
        return f"is outside the bounds {point_text(world.bounds)}"
    xmin, ymin, xmax, ymax = world.bounds
    edge = min(x - xmin, xmax - x, y - ymin, ymax - y)
    if edge <= radius:
        return _phrase(edge, radius, f"the edge of the bounds {point_text(world.bounds)}", False)
    for k, polygon in enumerate(world.polygons):
        vertices = _rows(polygon, 2)
        if inside_polygon(x, y, vertices):
            return f"is inside polygon {k}"
        gap = float(segment_distances(x, y, np.concatenate(
            [vertices, np.roll(vertices, -1, axis=0)], axis=1)).min())
        if gap <= radius:
            return _phrase(gap, radius, f"polygon {k}", False)
    checks: list[tuple[np.ndarray, Callable[[int], str], bool]] = [
        (segment_distances(x, y, _rows([(*w.a, *w.b) for w in world.walls], 4)),
         lambda i: _wall_label(world.walls[i], i), False),
        (segment_distances(x, y, world.door_segments),
         lambda i: f"door {world.doors[i].name or i}", False),
        (_disc_gaps(x, y, _rows(world.points, 3)), lambda i: f"point obstacle {i}", True),
        (_disc_gaps(x, y, world.landmark_array),
         lambda i: f"landmark {world.landmarks[i].id!r}", True)]
    if t is not None:
        present = [m for m in world.movers if m.present(t)]
        where = [m.position(t) for m in present]
        checks.append((_disc_gaps(x, y, _rows([(*p, m.radius) for p, m in zip(
            where, present, strict=True)], 3)),
            lambda i: f"a {present[i].kind} at {point_text(where[i])} at t = {t:g}", True))
    for gaps, label, solid in checks:
        hit = _nearest(gaps, radius)
        if hit is not None:
            return _phrase(float(gaps[hit]), radius, label(hit), solid)
    return None


def _disc_gaps(x: float, y: float, discs: np.ndarray) -> np.ndarray:
    return np.hypot(discs[:, 0] - x, discs[:, 1] - y) - discs[:, 2]


def _wall_label(wall: Wall, index: int) -> str:
    if wall.between is not None:
        return f"wall {index} (between {wall.between[0]!r} and {wall.between[1]!r})"
    return f"wall {index} from {point_text(wall.a)} to {point_text(wall.b)}"
