"""The ``landmark_detour`` solver: the Rescuer told about the linear obstacles in view.

002's Rescuer computes a diverting target when the robot is blocked; ours (the ``rescuer``
solver of the 2D world) knows only the sonar, which gets a robot past one linear obstacle but
leads it back into a dead end. This solver looks at the obstacles the robot sees between the
landmarks in the region in front of it: the ends of a chain of linear obstacles are the
landmarks that only one obstacle reaches, and a way round the chain passes beside an end. It
proposes a point beside an end: ``clearance`` metres past it along the obstacle that reaches it,
and ``aside`` metres across, on the side of that obstacle's line where the target lies, so that
the straight way on from the point to the target passes clear of the end. It takes the end whose
detour is the shortest (robot to point to target, straight), or one drawn at random (``choice:
random``, to explore). With no obstacle in view it falls back on the sonar Rescuer.
Like the Rescuer, it acts only when the robot is blocked (the situation's trigger is
``blocked``) and proposes nothing otherwise.

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
from cbr_world2d.actions import Divert
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
        0.3, "How far across the obstacle's line, toward the target's side, the diverting "
        "target lies, in metres.", validator=attrs.validators.ge(0.0))
    choice: Literal["shortest", "random"] = option(
        "shortest", "Which end: the shortest detour to the target, or one at random.")
    region: RegionOptions = option(factory=RegionOptions,
                                   doc="The region in front of the robot it looks at.")
    rescuer: RescuerOptions = option(
        factory=RescuerOptions, doc="The sonar Rescuer it falls back on with no obstacle in "
        "view.")


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
        view = problem_view(problem, o.region)
        ends = [] if view is None else chain_ends(view.graph.n, view.graph.obstacles)
        if view is None or not ends:
            point = Rescuer(o.rescuer, problem.target).escape(problem)
            return None if point is None else Solution(Divert(*point))
        pose = (problem.pose.x, problem.pose.y)
        world = view.world_points()
        target = np.asarray(problem.target, dtype=float)
        points = []
        for end, neighbour in ends:
            away = world[end] - world[neighbour]
            away = away / max(float(np.hypot(*away)), 1e-9)
            across = np.array([-away[1], away[0]])
            if float(np.dot(across, target - world[end])) < 0.0:
                across = -across
            points.append(world[end] + o.clearance * away + o.aside * across)
        if o.choice == "random":
            k = int(self.rng.integers(len(points)))
        else:
            tx, ty = problem.target
            k = int(np.argmin([math.hypot(p[0] - pose[0], p[1] - pose[1])
                               + math.hypot(tx - p[0], ty - p[1]) for p in points]))
        return Solution(Divert(float(points[k][0]), float(points[k][1])),
                        detail={"end": view.graph.ids[ends[k][0]]})
