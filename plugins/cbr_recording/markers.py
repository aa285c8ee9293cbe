"""What a family draws in a recording: :class:`Marker`, a plain description of one
``visualization_msgs/msg/Marker`` that the recorder turns into the message.

A family describes its world (walls, doors, people, case-graph segments) as markers without
knowing the message's layout or importing the ROS libraries; only the recorder does.
"""

from __future__ import annotations

from typing import Literal

import attrs
import numpy as np

Kind = Literal["arrow", "cube", "sphere", "cylinder", "line_strip", "line_list", "cube_list",
               "sphere_list", "points", "text"]

KINDS: dict[str, int] = {"arrow": 0, "cube": 1, "sphere": 2, "cylinder": 3, "line_strip": 4,
                         "line_list": 5, "cube_list": 6, "sphere_list": 7, "points": 8,
                         "text": 9}
"""Each kind's ``type`` constant of ``visualization_msgs/msg/Marker``."""

Color = tuple[float, float, float, float]


def _points(value: object) -> np.ndarray:
    """``value`` as an (n, 3) float array; (n, 2) points lie at z = 0."""
    points = np.asarray(value, dtype=np.float64)
    if points.size == 0:
        return np.zeros((0, 3))
    points = np.atleast_2d(points)
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise ValueError(f"marker points must be an (n, 2) or (n, 3) array, got shape "
                         f"{points.shape}")
    if points.shape[1] == 2:
        points = np.column_stack((points, np.zeros(len(points))))
    return points


@attrs.frozen
class Marker:
    """One marker: ``kind`` drawn in ``frame`` at ``pose`` (x, y, yaw), its ``points`` (an
    (n, 2) or (n, 3) array of metres, for the list kinds), ``scale`` (metres: a line's width,
    a shape's size), one ``color`` (r, g, b, a in [0, 1]) or one per point in ``colors`` and,
    for ``text``, its ``text``. ``ns`` and ``id`` name it: a marker with the same pair replaces
    the earlier one. ``lifetime`` seconds after which a viewer drops it (0: never).
    """

    ns: str
    id: int
    kind: Kind
    points: np.ndarray = attrs.field(factory=lambda: np.zeros((0, 3)), converter=_points,
                                     eq=False)
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    scale: tuple[float, float, float] = (0.05, 0.05, 0.05)
    color: Color = (1.0, 1.0, 1.0, 1.0)
    colors: np.ndarray | None = attrs.field(default=None, eq=False)
    text: str = ""
    frame: str = "map"
    lifetime: float = 0.0


@attrs.frozen
class Clear:
    """Remove every marker of the topic drawn so far (``DELETEALL``) before those that follow
    in the same array: a family redrawing a changing set (the obstacles a trip met, the
    targets) sends it first."""
