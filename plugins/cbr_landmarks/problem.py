"""The problem case: the landmarks and obstacles in the region in front of the robot (002
section 3.3, Figure 5), as a :class:`~cbr_landmarks.graph.LandmarkGraph`.

Each sighting gives a landmark's fuzzy distance and bearing from the robot; its place in the
robot's frame (x ahead, y to the left) is taken at the peaks, and it is known within the wider
side of the distance triangle plus the arc the wider side of the bearing triangle spans at that
distance. :meth:`LandmarkGraph.from_points` turns places and uncertainties into the fuzzy
distances and angles of every pair, angles measured against the robot's x axis as 002 defines
them. The obstacles are the linear obstacles the robot sees between two landmarks of the region.

The frame is the robot's: x along its heading. A learned case may be taken in the frame of the
robot's *course* instead, x pointing at its target (``course=True``): where the robot got into
trouble its heading is whatever the pilot's last swerve left, while the course is the direction
it came from to get there, the one it will face when the layout next comes into view.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Literal

import attrs
import numpy as np

from cbr_landmarks.graph import MAX_LANDMARKS, GraphError, LandmarkGraph
from cbrcore.options import option

if TYPE_CHECKING:
    from cbr_world2d.workload import Situation

_POSITIVE = attrs.validators.gt(0.0)


@attrs.frozen
class RegionOptions:
    """The region in front of the robot whose landmarks make the problem case."""

    shape: Literal["sector", "rectangle"] = option(
        "sector", "sector: within 'depth' metres and 'angle' degrees centred on the heading; "
        "rectangle: 'depth' metres ahead and 'width' metres across, centred on the heading.")
    depth: float = option(6.0, "How far ahead the region reaches, in metres (the camera's range).",
                          validator=_POSITIVE)
    angle: float = option(
        180.0, "The sector's opening in degrees.",
        validator=attrs.validators.and_(_POSITIVE, attrs.validators.le(360.0)))
    width: float = option(4.0, "The rectangle's width in metres.", validator=_POSITIVE)
    margin: float = option(
        1.0, "How far, in metres, beyond the far edge and the sides a landmark's measured "
        "place may lie and still count (a sector's sides open by the angle the margin spans "
        "at 'depth'): the camera measures a landmark at the edge of its range or field of "
        "view outside a region of the camera's size about half the time.",
        validator=attrs.validators.ge(0.0))


@attrs.frozen(eq=False)
class View:
    """The problem case and where its landmarks are: ``points`` ``(n, 2)`` in the graph's
    order, in the frame at ``frame`` ``(x, y, theta)`` of the world (the robot's position and
    the direction of its x axis)."""

    graph: LandmarkGraph
    points: np.ndarray
    frame: tuple[float, float, float]

    def world_points(self) -> np.ndarray:
        """The landmarks' places in the world's frame, ``(n, 2)``."""
        return to_world(self.points, self.frame)


def sub_view(view: View, keep: Sequence[int]) -> View:
    """``view`` reduced to the landmarks ``keep`` (indices into its graph)."""
    return View(view.graph.subgraph(keep), view.points[list(keep)], view.frame)


def in_region(points: np.ndarray, region: RegionOptions) -> np.ndarray:
    """Which of the ``points`` ``(n, 2)`` (robot frame) lie in ``region`` grown by its
    ``margin``, ``(n,)`` bool.

    The margin is where the camera's measurements err: beyond the far edge and beside the
    sides, never behind the robot. A sector reaches ``margin`` farther and its sides open by
    the angle the margin spans at its depth (a bearing errs by an angle, much the same near
    and far); a rectangle reaches ``margin`` farther and is ``margin`` wider on each side.
    """
    x, y = points[:, 0], points[:, 1]
    depth = region.depth + region.margin
    if region.shape == "rectangle":
        return (x >= 0.0) & (x <= depth) & (np.abs(y) <= 0.5 * region.width + region.margin)
    half = 0.5 * math.radians(region.angle) + region.margin / region.depth
    return (np.hypot(x, y) <= depth) & (np.abs(np.arctan2(y, x)) <= half + 1e-12)


def problem_view(situation: Situation, region: RegionOptions, course: bool = False
                 ) -> View | None:
    """The problem case of ``situation`` in the robot's frame (or its course's, see the module
    docstring), or None when fewer than two landmarks lie in the region. The nearest
    :data:`~cbr_landmarks.graph.MAX_LANDMARKS` are kept when more do."""
    if len(situation.sightings) < 2:
        return None
    pose = situation.pose
    from cbr_world2d.sensors import sighted_points

    points, uncertainty = sighted_points(situation.sightings)
    bad = ~(np.isfinite(points).all(axis=1) & np.isfinite(uncertainty))
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        sighting = situation.sightings[k]
        raise GraphError(f"the situation at t={situation.t:.1f} s: sightings[{k}] "
                         f"({sighting.id}): distance {list(sighting.distance.as_tuple())} and "
                         f"bearing {list(sighting.bearing.as_tuple())} must be finite numbers")
    theta = pose.theta
    if course:
        theta = math.atan2(situation.target[1] - pose.y, situation.target[0] - pose.x)
        turn = pose.theta - theta
        c, s = math.cos(turn), math.sin(turn)
        points = points @ np.array([[c, s], [-s, c]])
    inside = np.flatnonzero(in_region(points, region))
    if len(inside) < 2:
        return None
    inside = inside[np.argsort(np.hypot(*points[inside].T), kind="stable")][:MAX_LANDMARKS]
    ids = [situation.sightings[k].id for k in inside.tolist()]
    kept = set(ids)
    obstacles = [pair for pair in situation.obstacles if pair[0] in kept and pair[1] in kept]
    graph = LandmarkGraph.from_points(ids, points[inside], uncertainty[inside], obstacles,
                                      where=f"the situation at t={situation.t:.1f} s")
    return View(graph, points[inside], (pose.x, pose.y, theta))


def to_world(points: np.ndarray, pose: tuple[float, float, float]) -> np.ndarray:
    """``points`` ``(n, 2)`` in the frame of a robot at ``pose`` ``(x, y, theta)``, in the
    world's frame."""
    x, y, theta = pose
    c, s = math.cos(theta), math.sin(theta)
    return np.column_stack((x + c * points[:, 0] - s * points[:, 1],
                            y + s * points[:, 0] + c * points[:, 1]))
