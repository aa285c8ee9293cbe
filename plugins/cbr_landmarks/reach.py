"""Whether a diverting target can be reached, as far as the robot knows (safe reuse).

A case's action carried onto the current landmarks can land where the robot should not go: a
case matched onto a layout of another shape or turn lays its target inside the dead end it was
meant to avoid. Before diverting, the reuser checks the target against the *known walls*, each
the segment between the places of two landmarks in view (:func:`sighted_places`,
:func:`walls_between`): the linear obstacles of the situation, and those the matched case says
stand between the landmarks it was matched with; and the walls of the robot's map, in view or
not, and the arena's outline (:func:`known_walls`). A target is

- **refused** when it lies inside a known obstacle chain (strictly inside the convex hull of
  the landmarks of a chain of two or more walls joined end to end: the inside of a V or a U,
  the trap) or within ``clearance`` of a known wall (no room for the robot);
- **reachable** when the straight way from the robot crosses no known wall (line of sight),
  or when the shortest way round the known walls is at most ``detour`` times the straight
  distance. The way round is planned on a visibility graph whose waypoints stand ``2 *
  clearance`` from each wall's ends, in eight directions, those within ``clearance`` of a wall
  left out. A gap narrower than ``passage`` between the ends of two walls, or between a wall's
  end and a landmark in view, or two landmarks, counts as a wall
  (the straight way through it is no line of sight) unless there is no other way: the
  potential-field pilot stops in front of a narrow gap, pushed back by both sides;
- **refused** otherwise (no way, or only a long one: the robot would rather be led by its
  navigation system than sent on a long detour on what it merely believes).

:func:`way` returns the way: its length (metres), which sets how long the diversion may take,
and, for a way round, the waypoints the robot is led through first (the pilot heads straight
for its target, so a way round is only taken by following it).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING

import attrs
import numpy as np

from cbr_landmarks.problem import to_world

if TYPE_CHECKING:
    from cbr_world2d.workload import Situation

Point = tuple[float, float]

_EPS = 1e-9

GIVE_UP_SLACK = 1.5
"""A diversion along a way is given up after this many times the time the way takes at the
robot's top speed, plus :data:`GIVE_UP_MARGIN` seconds (the pilot turns, swerves and slows):
the reuser's defaults, and the detour solver's way round."""
GIVE_UP_MARGIN = 30.0

PASSAGE = 1.5
"""The narrowest gap between two walls' ends, centre to centre of their landmarks, in metres,
that a way is planned through when there is another: 002's robot (0.2 m in radius) led by the
potential-field pilot with an influence of 0.5 m stops in front of a gap of 1.3 m between two
posts of 0.15 m and passes one of 1.35 m, head on."""

SAME_PLACE = 0.2
"""Metres within which a landmark in view and the end of a wall of the robot's map are the same
landmark (the map's walls and the sightings place it a little apart)."""


def sighted_places(problem: Situation) -> dict[str, Point]:
    """Where the landmarks ``problem`` sees stand, in the world's frame (the peaks of their
    sightings)."""
    if not problem.sightings:
        return {}
    from cbr_world2d.sensors import sighted_points

    points, _ = sighted_points(problem.sightings)
    pose = problem.pose
    world = to_world(points, (pose.x, pose.y, pose.theta))
    return {s.id: (float(world[k, 0]), float(world[k, 1]))
            for k, s in enumerate(problem.sightings)}


def walls_between(pairs: Iterable[tuple[str, str]], where: Mapping[str, Point]
                  ) -> tuple[np.ndarray, list[tuple[str, str]]]:
    """The walls between the landmark ``pairs`` whose two landmarks have a place in ``where``,
    ``(m, 2, 2)``, and their pairs (each once, in the order first given)."""
    kept: dict[tuple[str, str], None] = {}
    for a, b in pairs:
        if a in where and b in where and a != b:
            kept.setdefault((min(a, b), max(a, b)), None)
    chosen = list(kept)
    if not chosen:
        return np.empty((0, 2, 2)), []
    return np.array([[where[a], where[b]] for a, b in chosen], dtype=float), chosen


def chains(pairs: Sequence[tuple[str, str]]) -> list[list[int]]:
    """The walls of ``pairs`` (indices) grouped by obstacle chain: walls sharing a landmark."""
    parent = list(range(len(pairs)))

    def root(k: int) -> int:
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    first: dict[str, int] = {}
    for k, pair in enumerate(pairs):
        for landmark in pair:
            if landmark in first:
                parent[root(k)] = root(first[landmark])
            else:
                first[landmark] = k
    groups: dict[int, list[int]] = {}
    for k in range(len(pairs)):
        groups.setdefault(root(k), []).append(k)
    return list(groups.values())


def hull(points: np.ndarray) -> np.ndarray:
    """The convex hull of ``points`` ``(n, 2)``, counter-clockwise, without collinear points
    (fewer than three rows when the points are all on a line)."""
    ordered = sorted({(float(x), float(y)) for x, y in points})
    if len(ordered) < 3:
        return np.array(ordered, dtype=float).reshape(-1, 2)

    def cross(o: Point, a: Point, b: Point) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[Point] = []
    upper: list[Point] = []
    for p in ordered:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= _EPS:
            lower.pop()
        lower.append(p)
    for p in reversed(ordered):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= _EPS:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1], dtype=float)


def inside_chain(point: Point, walls: np.ndarray, pairs: Sequence[tuple[str, str]]) -> bool:
    """Whether ``point`` lies strictly inside the convex hull of a chain of two or more of
    ``walls``, the first ``len(pairs)`` of which stand between the landmark ``pairs``."""
    px, py = point
    for group in chains(pairs):
        if len(group) < 2:
            continue
        corners = hull(walls[group].reshape(-1, 2))
        if len(corners) < 3:
            continue
        edges = np.roll(corners, -1, axis=0) - corners
        to_point = np.array([px, py]) - corners
        if bool(np.all(edges[:, 0] * to_point[:, 1] - edges[:, 1] * to_point[:, 0] > _EPS)):
            return True
    return False


def distance_to_walls(points: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """The distance of each of ``points`` ``(n, 2)`` to the nearest of ``walls`` ``(m, 2, 2)``
    (infinite with no walls), ``(n,)``."""
    if len(walls) == 0:
        return np.full(len(points), np.inf)
    return _point_to_segments(points[:, None, :], walls[None, :, 0], walls[None, :, 1]
                              ).min(axis=1)


def _nearest_on_segments(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The point of each segment ``a``-``b`` nearest ``points`` ``(..., 2)`` (broadcast)."""
    ab = b - a
    length2 = np.maximum((ab * ab).sum(axis=-1), _EPS)
    t = np.clip(((points - a) * ab).sum(axis=-1) / length2, 0.0, 1.0)
    return a + t[..., None] * ab


def _point_to_segments(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The distance from ``points`` ``(..., 2)`` to the segments ``a``-``b`` (broadcast)."""
    return np.hypot(*np.moveaxis(points - _nearest_on_segments(points, a, b), -1, 0))


def crossing(starts: np.ndarray, ends: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Whether each way from ``starts[k]`` to ``ends[k]`` (``(n, 2)`` each) meets one of
    ``walls`` ``(m, 2, 2)``, ``(n,)`` bool: crosses it, touches it (through a wall's end
    too, where two walls meet and a way through the corner would slip between them) or runs
    along it."""
    if len(walls) == 0 or len(starts) == 0:
        return np.zeros(len(starts), dtype=bool)
    p, r = starts[:, None, :], (ends - starts)[:, None, :]
    q, s = walls[None, :, 0, :], (walls[:, 1] - walls[:, 0])[None, :, :]

    def cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

    denominator = cross(r, s)
    qp = q - p
    with np.errstate(divide="ignore", invalid="ignore"):
        t = cross(qp, s) / denominator
        u = cross(qp, r) / denominator
    inner = (np.abs(denominator) > _EPS) & (t >= 0.0) & (t <= 1.0) & (u >= 0.0) & (u <= 1.0)
    # touching and running along: an end of one within reach of the other
    e, f = starts[:, None, :], ends[:, None, :]
    near = np.minimum.reduce([
        _point_to_segments(e, q, q + s), _point_to_segments(f, q, q + s),
        _point_to_segments(q, e, f), _point_to_segments(q + s, e, f)]) <= 1e-7
    return (inner | near).any(axis=1)


def waypoints(walls: np.ndarray, clearance: float) -> np.ndarray:
    """Points round the ends of ``walls``: ``2 * clearance`` from each end in eight directions,
    those within ``clearance`` of a wall left out, ``(k, 2)``."""
    if len(walls) == 0:
        return np.empty((0, 2))
    ends = np.unique(walls.reshape(-1, 2).round(9), axis=0)
    angles = np.arange(8) * (math.pi / 4)
    ring = 2.0 * clearance * np.column_stack((np.cos(angles), np.sin(angles)))
    points = (ends[:, None, :] + ring[None, :, :]).reshape(-1, 2)
    return points[distance_to_walls(points, walls) >= clearance - _EPS]


def _round_the_ends(nodes: np.ndarray, i: np.ndarray, j: np.ndarray, walls: np.ndarray,
                    clearance: float) -> np.ndarray:
    """Whether each leg ``nodes[i]``-``nodes[j]`` passes every wall's end at least
    ``clearance`` off, ``(len(i),)`` bool. A leg that crosses no wall comes nearest a wall at
    one of the two's ends, and the waypoints keep ``clearance`` from every wall already: what
    is left is a leg cutting round the end of a wall, where a robot would graze the landmark
    there and its pilot slide back along the wall. An end within ``clearance`` of the start or
    the goal (nodes 0 and 1: a robot blocked at a corner) does not count against the legs
    from or to it."""
    if len(walls) == 0 or len(i) == 0:
        return np.ones(len(i), dtype=bool)
    ends = np.unique(walls.reshape(-1, 2).round(9), axis=0)
    gap = _point_to_segments(ends[None, :, :], nodes[i][:, None, :], nodes[j][:, None, :])
    near = [np.hypot(*(ends - nodes[k]).T) < clearance for k in (0, 1)]
    excused = (((i == 0) | (j == 0))[:, None] & near[0][None, :]) | \
        (((i == 1) | (j == 1))[:, None] & near[1][None, :])
    return ((gap >= clearance - _EPS) | excused).all(axis=1)


def narrow_gaps(walls: np.ndarray, passage: float, posts: np.ndarray | None = None
                ) -> np.ndarray:
    """The gaps narrower than ``passage`` between an end of one of ``walls`` ``(m, 2, 2)`` or
    one of the ``posts`` ``(k, 2)`` (landmarks no known wall reaches, which stand in the way
    as well) and another wall or post, each as the segment from the end to the nearest point
    of the other, ``(g, 2, 2)``. Joined walls meet in no gap, and a post within
    :data:`SAME_PLACE` of a wall's end is that end."""
    walls = walls.reshape(-1, 2, 2)
    if posts is not None and len(posts):
        posts = np.asarray(posts, dtype=float).reshape(-1, 2)
        if len(walls):
            ends = walls.reshape(-1, 2)
            apart = np.hypot(*(posts[:, None, :] - ends[None, :, :]).transpose(2, 0, 1))
            posts = posts[apart.min(axis=1) > SAME_PLACE]
        walls = np.concatenate((walls, np.stack((posts, posts), axis=1)))
    if len(walls) < 2 or passage <= 0.0:
        return np.empty((0, 2, 2))
    points = walls.reshape(-1, 2)
    owner = np.repeat(np.arange(len(walls)), 2)
    nearest = _nearest_on_segments(points[:, None, :], walls[None, :, 0], walls[None, :, 1])
    apart = np.hypot(*np.moveaxis(points[:, None, :] - nearest, -1, 0))
    narrow = (owner[:, None] != np.arange(len(walls))[None, :]) & (apart > _EPS) & \
        (apart < passage)
    k, w = np.nonzero(narrow)
    if not len(k):
        return np.empty((0, 2, 2))
    gaps = np.stack((points[k], nearest[k, w]), axis=1).round(9)
    flip = (gaps[:, 0, 0] > gaps[:, 1, 0]) | ((gaps[:, 0, 0] == gaps[:, 1, 0])
                                            & (gaps[:, 0, 1] > gaps[:, 1, 1]))
    gaps[flip] = gaps[flip, ::-1]
    return np.unique(gaps, axis=0)


def outline(bounds: tuple[float, float, float, float] | None) -> np.ndarray:
    """The four sides of the arena ``bounds`` ``(xmin, ymin, xmax, ymax)`` as walls ``(4, 2,
    2)``; none without bounds."""
    if bounds is None:
        return np.empty((0, 2, 2))
    x0, y0, x1, y1 = bounds
    corners = np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)], dtype=float)
    return np.stack((corners, np.roll(corners, -1, axis=0)), axis=1)


def known_walls(problem: Situation) -> np.ndarray:
    """The walls the robot knows besides the obstacles in view: those of its map, in view or
    not, and the arena's outline, ``(m, 2, 2)``."""
    return np.concatenate((np.array(problem.walls, dtype=float).reshape(-1, 2, 2),
                           outline(problem.bounds)))


def route(start: Point, goal: Point, walls: np.ndarray, clearance: float,
          passage: float = 0.0, posts: np.ndarray | None = None
          ) -> tuple[float, tuple[Point, ...]] | None:
    """The shortest way from ``start`` to ``goal`` that meets none of ``walls``, through the
    :func:`waypoints`: its length and the waypoints it passes between them; None when there
    is none. A gap narrower than ``passage`` between two walls' ends or ``posts``
    (:func:`narrow_gaps`) is passed only when there is no other way, and then head on, through
    a waypoint ``2 * clearance`` before its middle and one as far beyond: the potential-field
    pilot is pushed back by both sides of a narrow gap and stops in front of it unless it
    meets it square."""
    gaps = narrow_gaps(walls, passage, posts)
    found = _shortest(start, goal, walls, clearance, gaps)
    if found is None and len(gaps):
        found = _shortest(start, goal, walls, clearance, gaps, through=True)
    return found


def _gates(gaps: np.ndarray, walls: np.ndarray, clearance: float) -> np.ndarray:
    """For each of ``gaps``, the points ``2 * clearance`` before and beyond its middle, square
    to it, ``(g, 2, 2)``; a gap with either point within ``clearance`` of one of ``walls`` has
    none (NaN)."""
    middle = gaps.mean(axis=1)
    along = gaps[:, 1] - gaps[:, 0]
    square = np.column_stack((-along[:, 1], along[:, 0])) / np.maximum(
        np.hypot(*along.T), _EPS)[:, None]
    gates = np.stack((middle - 2.0 * clearance * square, middle + 2.0 * clearance * square),
                     axis=1)
    tight = distance_to_walls(gates.reshape(-1, 2), walls).reshape(-1, 2).min(axis=1) < \
        clearance - _EPS
    gates[tight] = np.nan
    return gates


def _shortest(start: Point, goal: Point, walls: np.ndarray, clearance: float,
              gaps: np.ndarray, *, through: bool = False
              ) -> tuple[float, tuple[Point, ...]] | None:
    """:func:`route` with the ``gaps`` closed, or (``through``) passed only from one of their
    gate points (:func:`_gates`) to the other."""
    closed = np.concatenate((walls, gaps.reshape(-1, 2, 2)))
    nodes = np.vstack((np.array([start, goal], dtype=float), waypoints(closed, clearance)))
    pairs = 0
    if through:
        gates = _gates(gaps, walls, clearance)
        gates = gates[~np.isnan(gates).any(axis=(1, 2))]
        pairs = len(gates)
        nodes = np.vstack((nodes, gates.reshape(-1, 2)))
    n = len(nodes)
    i, j = np.triu_indices(n, 1)
    free = ~crossing(nodes[i], nodes[j], closed) & _round_the_ends(nodes, i, j, closed,
                                                                  clearance)
    if pairs:
        # a gate's two points, across its gap: only the real walls stand between them
        first = n - 2 * pairs + 2 * np.arange(pairs)
        own = np.isin(i, first) & (j == i + 1)
        free[own] = ~crossing(nodes[i[own]], nodes[j[own]], walls)
    lengths = np.hypot(*(nodes[j] - nodes[i]).T)
    graph: list[list[tuple[int, float]]] = [[] for _ in range(n)]
    for a, b, length in zip(i[free].tolist(), j[free].tolist(), lengths[free].tolist(),
                            strict=True):
        graph[a].append((b, length))
        graph[b].append((a, length))
    best = [math.inf] * n
    came = [-1] * n
    best[0] = 0.0
    queue = [(0.0, 0)]
    while queue:
        so_far, node = heapq.heappop(queue)
        if node == 1:
            via: list[Point] = []
            k = came[1]
            while k > 0:
                via.append((float(nodes[k, 0]), float(nodes[k, 1])))
                k = came[k]
            return so_far, tuple(reversed(via))
        if so_far > best[node]:
            continue
        for nxt, length in graph[node]:
            if so_far + length < best[nxt]:
                best[nxt], came[nxt] = so_far + length, node
                heapq.heappush(queue, (best[nxt], nxt))
    return None


def in_sight(start: Point, goal: Point, walls: np.ndarray, passage: float = 0.0,
             posts: np.ndarray | None = None) -> bool:
    """Whether the straight way from ``start`` to ``goal`` meets none of ``walls`` and no gap
    narrower than ``passage`` between them and the ``posts`` (:func:`narrow_gaps`)."""
    closed = np.concatenate((walls.reshape(-1, 2, 2), narrow_gaps(walls, passage, posts)))
    return not crossing(np.array([start], dtype=float), np.array([goal], dtype=float),
                        closed)[0]


@attrs.frozen
class Way:
    """How the robot gets to a diverting target: ``metres`` to drive, ``how`` (``line of
    sight`` or ``route``) and the waypoints ``via`` to pass first; a refused target has
    ``metres`` None and ``how`` says why."""

    metres: float | None
    how: str
    via: tuple[Point, ...] = ()


def way(start: Point, target: Point, walls: np.ndarray, pairs: Sequence[tuple[str, str]],
        clearance: float, detour: float, passage: float = 0.0,
        posts: np.ndarray | None = None) -> Way:
    """How the robot at ``start`` gets to ``target`` round the known ``walls`` and between the
    ``posts`` (the landmarks in view), or why it is refused (see the module docstring). The
    first ``len(pairs)`` walls stand between those landmark ``pairs`` (which make the obstacle
    chains); any others (the walls of the robot's map) are in no chain."""
    if inside_chain(target, walls, pairs):
        return Way(None, "inside a known obstacle chain")
    goal = np.array([target], dtype=float)
    if distance_to_walls(goal, walls)[0] < clearance:
        return Way(None, f"within {clearance:g} m of a known wall")
    straight = math.dist(start, target)
    if in_sight(start, target, walls, passage, posts):
        return Way(straight, "line of sight")
    found = route(start, target, walls, clearance, passage, posts)
    if found is None:
        return Way(None, "no way round the known walls")
    length, via = found
    if length > detour * straight:
        return Way(None, f"the way round the known walls is over {detour:g} times the "
                   "straight one")
    return Way(length, "route", via)
