"""A case's action: a diverting target placed relative to the case's landmarks.

002's CBR agent asks the Rescuer for a diverting target and names a landmark ("the landmark l2
is set as the diverting target"). A robot cannot drive onto a landmark, and a learned target
need not lie on one, so the action places the target in the frame of two of the case's
landmarks: ``anchor``, where the frame starts, and ``base``, so that the frame's x axis points
from ``base`` to ``anchor``. The target lies ``along`` metres along that axis and ``aside``
metres to its left. "Beside l2, past the end of the obstacle from l1" is ``anchor: l2, base: l1,
along: 0.5, aside: 0``.

Reuse carries the action to the current situation through the matching: the case's ``anchor``
and ``base`` become the current landmarks they were matched with, and the same offsets are laid
out from them (metres, not a fraction of the landmarks' distance: the robot's size does not
scale with the layout). An action whose ``anchor`` or ``base`` is left unmatched cannot be
carried over.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import attrs
import numpy as np

from cbr_landmarks.graph import MAX_MEASURE, GraphError


@attrs.frozen
class DivertAction:
    """A diverting target ``along`` and ``aside`` metres from ``anchor`` in the frame whose x
    axis points from ``base`` to ``anchor``."""

    anchor: str
    base: str
    along: float
    aside: float = 0.0

    def point(self, places: Mapping[str, Sequence[float]]) -> tuple[float, float] | None:
        """The target among landmarks at ``places`` (id to ``(x, y)``), or None when
        ``anchor`` or ``base`` is not among them or they coincide."""
        if self.anchor not in places or self.base not in places:
            return None
        ax, ay = places[self.anchor]
        bx, by = places[self.base]
        length = math.hypot(ax - bx, ay - by)
        if length == 0.0:
            return None
        ux, uy = (ax - bx) / length, (ay - by) / length
        return (float(ax + self.along * ux - self.aside * uy),
                float(ay + self.along * uy + self.aside * ux))

    @classmethod
    def toward(cls, point: Sequence[float], places: Mapping[str, Sequence[float]],
               linked: Mapping[str, Sequence[str]] | None = None) -> DivertAction:
        """The action that puts the target at ``point`` among landmarks at ``places`` (at
        least two): anchored at the landmark nearest ``point``, its base the landmark an
        obstacle joins to the anchor (per ``linked``, id to ids) nearest the anchor, else the
        nearest other landmark."""
        ids = list(places)
        xy = np.array([places[i] for i in ids], dtype=float)
        px, py = float(point[0]), float(point[1])
        anchor = ids[int(np.argmin(np.hypot(xy[:, 0] - px, xy[:, 1] - py)))]
        ax, ay = places[anchor]
        others = [i for i in ids if i != anchor]
        joined = [i for i in others if linked is not None and i in linked.get(anchor, ())]
        pool = joined or others
        base = min(pool, key=lambda i: (math.hypot(places[i][0] - ax, places[i][1] - ay), i))
        bx, by = places[base]
        length = math.hypot(ax - bx, ay - by)
        if length == 0.0:
            raise ValueError(f"landmarks {anchor!r} and {base!r} stand at the same place")
        ux, uy = (ax - bx) / length, (ay - by) / length
        dx, dy = float(px - ax), float(py - ay)
        return cls(anchor, base, round(float(dx * ux + dy * uy), 4),
                   round(float(-dx * uy + dy * ux), 4))

    def to_data(self) -> dict[str, Any]:
        return {"anchor": self.anchor, "base": self.base, "along": self.along,
                "aside": self.aside}

    @classmethod
    def from_data(cls, data: Any, landmarks: Sequence[str], where: str) -> DivertAction:
        """The action stored as :meth:`to_data` wrote it, for a case of ``landmarks``."""
        if not isinstance(data, Mapping):
            raise GraphError(f"{where}: action: expected a mapping with anchor, base, along "
                             f"and aside, got {data!r}")
        for key in ("anchor", "base"):
            if data.get(key) not in landmarks:
                raise GraphError(f"{where}: action.{key}: {data.get(key)!r} is not one of the "
                                 f"case's landmarks {list(landmarks)}")
        if data["anchor"] == data["base"]:
            raise GraphError(f"{where}: action: anchor and base must be two landmarks, got "
                             f"{data['anchor']!r} twice")
        numbers = {}
        for key, default in (("along", None), ("aside", 0.0)):
            value = data.get(key, default)
            if isinstance(value, bool) or not isinstance(value, int | float) or \
                    not (math.isfinite(value) and abs(value) <= MAX_MEASURE):
                raise GraphError(f"{where}: action.{key}: expected a finite number of metres "
                                 f"within ±{MAX_MEASURE:g} (the limit), got {value!r}")
            numbers[key] = float(value)
        return cls(data["anchor"], data["base"], numbers["along"], numbers["aside"])
