"""The ``landmark_detour`` solver: the Rescuer told about the linear obstacles in view.

002's Rescuer computes a diverting target when the robot is blocked; ours (the ``rescuer``
solver of the 2D world) knows only the sonar, which gets a robot past one linear obstacle but
leads it back into a dead end. This solver looks at the obstacles the robot sees between the
landmarks in the region around it and takes the chain of linear obstacles that blocks it (the
chain, obstacles joined end to end, with an obstacle nearest the robot, if that one is within
``reach``): the ends of the chain are the landmarks that only one of its obstacles reaches, and
a way round the chain passes beside an end. It proposes a point beside an end: ``clearance``
metres past it along the obstacle that reaches it, and ``aside`` metres across, on the outside
of the chain (away from the middle of the landmarks it joins: outside a V or a U, whose inside
is the trap), or, for a straight chain, on the side where the target lies; so that the way on
from the point passes round the end, not back in. It takes the end whose detour is the
shortest (robot to point to target, straight), or one drawn at random (``choice: random``, to
explore). With no chain blocking the robot it falls back on the sonar Rescuer.

A point past an end gets the robot out of a V, not out of every trap: from inside a U or a
room the point beside an end can leave the target behind the very walls the robot came from,
and heading for the target again leads back in. So by default (``way: round``) it first plans
the shortest way from the robot to the target round every known wall (each obstacle between
two landmarks in view, the walls of the robot's map and the arena's outline,
:func:`cbr_landmarks.reach.route`;
through a gap narrower than ``passage`` between two walls only when there is no other way)
and, when the straight way meets one,
leads the robot through the way's waypoints to the last, from which the target is in sight;
the diversion is given up after 1.5 times the time the way takes at the robot's top speed plus
30 s, as the reuser's are. Like the
Rescuer, it acts only when the robot is blocked (the situation's trigger is ``blocked``) and
proposes nothing otherwise.

It is the model-based answer the learning of :mod:`cbr_landmarks.components` starts from: a
situation where its diverting target got the robot out of trouble becomes a case, reused the
next time the layout comes into view, before the robot is in trouble.
"""

from __future__ import annotations

import math
from typing import Literal

import attrs
import numpy as np

from cbr_landmarks.problem import RegionOptions, problem_view
from cbr_landmarks.reach import (
    GIVE_UP_MARGIN,
    GIVE_UP_SLACK,
    PASSAGE,
    known_walls,
    route,
    sighted_places,
    walls_between,
)
from cbr_world2d.actions import Divert, GiveUp
from cbr_world2d.pilots.rescuer import Rescuer, RescuerOptions
from cbr_world2d.workload import Situation
from cbrcore.context import Context
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Solution
from cbrcore.options import option


@attrs.frozen
class DetourOptions:
    clearance: float = option(
        0.5, "How far past a chain's end landmark the diverting target lies, in metres (the "
        "robot's radius and the landmark's, and room to spare).",
        validator=attrs.validators.gt(0.0))
    aside: float = option(
        0.3, "How far across the obstacle's line, on the outside of the chain, the diverting "
        "target lies, in metres.", validator=attrs.validators.ge(0.0))
    choice: Literal["shortest", "random"] = option(
        "shortest", "Which end: the shortest detour to the target, or one at random.")
    region: RegionOptions = option(factory=RegionOptions,
                                   doc="The region in front of the robot it looks at.")
    reach: float = option(
        1.5, "A chain of linear obstacles blocks the robot when one of its obstacles is this "
        "close, in metres; farther ones are left to the sonar Rescuer.",
        validator=attrs.validators.gt(0.0))
    rescuer: RescuerOptions = option(
        factory=RescuerOptions, doc="The sonar Rescuer it falls back on with no obstacle in "
        "view.")
    passage: float = option(
        PASSAGE, "The narrowest gap between the ends of two walls (centre to centre of their "
        "landmarks), in metres, the way round leads the robot through when there is another "
        "way.", validator=attrs.validators.ge(0.0))
    way: Literal["round", "end"] = option(
        "round", "'round': lead the robot along the shortest way round the known walls to "
        "the first point from which the target is in sight, through the way's waypoints "
        "(past an end when there is no such way); 'end': straight for the point past an "
        "end.")


def chain_ends(n: int, obstacles: frozenset[tuple[int, int]]) -> list[tuple[int, int]]:
    """``(end, neighbour)`` for every landmark that exactly one obstacle reaches; when there
    is none (the obstacles close a ring), every landmark an obstacle reaches, with one
    neighbour."""
    neighbours: list[list[int]] = [[] for _ in range(n)]
    for i, j in sorted(obstacles):
        neighbours[i].append(j)
        neighbours[j].append(i)
    ends = [(i, near[0]) for i, near in enumerate(neighbours) if len(near) == 1]
    return ends or [(i, near[0]) for i, near in enumerate(neighbours) if near]


def blocking_chain(obstacles: frozenset[tuple[int, int]], places: np.ndarray, robot: np.ndarray,
                   reach: float) -> frozenset[tuple[int, int]]:
    """The obstacles of the chain (obstacles joined end to end) that holds the obstacle nearest
    ``robot``, when that one is within ``reach``; none otherwise. ``places`` ``(n, 2)`` are the
    landmarks' places."""
    pairs = sorted(obstacles)
    a, b = places[[i for i, _ in pairs]], places[[j for _, j in pairs]]
    edge = b - a
    t = np.clip(np.einsum("ij,ij->i", robot - a, edge)
                / np.maximum(np.einsum("ij,ij->i", edge, edge), 1e-12), 0.0, 1.0)
    gap = np.hypot(*(a + t[:, None] * edge - robot).T)
    nearest = int(np.argmin(gap))
    if gap[nearest] > reach:
        return frozenset()
    # scipy loads here, not with the module: the command line builds every plugin's registry
    from scipy.sparse import coo_array
    from scipy.sparse.csgraph import connected_components

    ends = np.array(pairs).T
    size = int(ends.max()) + 1
    graph = coo_array((np.ones(len(pairs)), (ends[0], ends[1])), shape=(size, size))
    _, label = connected_components(graph, directed=False)
    chain = label[pairs[nearest][0]]
    return frozenset(p for p in pairs if label[p[0]] == chain)


class LandmarkDetour:
    """Divert past an end of the chain of linear obstacles in view."""

    def __init__(self, options: DetourOptions, ctx: Context) -> None:
        self.options = options
        self.rng = ctx.spawn_rng()

    @hookimpl
    def cbr_solve(self, problem: Situation) -> Solution | None:
        if problem.trigger != "blocked":
            return None
        o = self.options
        pose = (problem.pose.x, problem.pose.y)
        if o.way == "round":
            found = self._round(problem, pose)
            if found is not None:
                return found
        view = problem_view(problem, o.region)
        if view is None or not view.graph.obstacles:
            return self._escape(problem)
        world = view.world_points()
        chain = blocking_chain(view.graph.obstacles, world, np.array(pose), o.reach)
        ends = chain_ends(view.graph.n, chain)
        if not ends:
            return self._escape(problem)
        target = np.asarray(problem.target, dtype=float)
        joined = sorted({k for pair in chain for k in pair})
        middle = world[joined].mean(axis=0)
        points, names = [], []
        for end, neighbour in ends:
            away = world[end] - world[neighbour]
            away = away / max(float(np.hypot(*away)), 1e-9)
            across = np.array([-away[1], away[0]])
            inward = float(np.dot(across, middle - world[end]))
            if abs(inward) > 1e-6 * o.clearance:
                side = -inward
            else:
                side = float(np.dot(across, target - world[end]))
            if side < 0.0:
                across = -across
            points.append(world[end] + o.clearance * away + o.aside * across)
            names.append(view.graph.ids[end])
        if o.choice == "random":
            k = int(self.rng.integers(len(points)))
        else:
            tx, ty = problem.target
            k = int(np.argmin([math.hypot(p[0] - pose[0], p[1] - pose[1])
                               + math.hypot(tx - p[0], ty - p[1]) for p in points]))
        return Solution(Divert(float(points[k][0]), float(points[k][1])),
                        detail={"end": names[k]})

    def _round(self, problem: Situation, pose: tuple[float, float]) -> Solution | None:
        """A diversion along the shortest way round the known walls (every obstacle between
        two landmarks in view, and every wall of the robot's map) to the target: through its
        waypoints to the last, from which the target is in sight; None when the way has no
        waypoint or there is none."""
        places = sighted_places(problem)
        seen, _ = walls_between(problem.obstacles, places)
        walls = np.concatenate((seen, known_walls(problem)))
        posts = np.array(list(places.values()), dtype=float).reshape(-1, 2)
        found = route(pose, problem.target, walls, self.options.clearance, self.options.passage,
                      posts)
        if found is None or not found[1]:
            return None
        length, via = found
        *before, last = via
        metres = length - math.dist(last, problem.target)
        give_up = GiveUp(round(metres, 4), GIVE_UP_SLACK, GIVE_UP_MARGIN)
        return Solution(Divert(*last, give_up=give_up, via=tuple(before)),
                        detail={"way": "round", "waypoints": len(via)})

    def _escape(self, problem: Situation) -> Solution | None:
        point = Rescuer(self.options.rescuer, problem.target).escape(problem)
        return None if point is None else Solution(Divert(*point))
