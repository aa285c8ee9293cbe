"""How good a behavior case has proved (004: "RUPART estimates the quality of a behavior case by
(1) how frequently it is retrieved and used, (2) how similar it is to other cases in the
memory, and (3) the average amount of time it stays active, once installed").

A case's counters live in its ``meta`` and are moved only by learn steps: ``retrieved`` (how
often it was among the matches), ``used`` (how often it was installed), ``good`` (how often
that spell went well: no collision, no impasse, progress toward the target) and ``active``
(seconds it stayed installed, summed). The paper names the three measures, not how they
combine; our reading, one number in [0, 1]::

    success    = (good + 1) / (used + 2)                 Laplace: an unused case scores 1/2
    use        = used / (retrieved + 1)                  retrieved but passed over scores low
    staying    = mean_active / (mean_active + STAY)      a spell of STAY seconds scores 1/2
    uniqueness = min(1, nearest / UNIQUE)                a near duplicate of another case
                                                         scores low
    quality    = success * (1 + use) / 2 * (1 + staying) / 2 * uniqueness

``nearest`` is the overall index distance to the nearest other case of the same kind. Success
dominates; use and staying at most halve it. Retrieval breaks near ties (distances within
:data:`TIE`) by quality, and forgetting drops the learned cases of lowest quality first.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import attrs

STAY = 10.0
"""Seconds: a case whose spells last this long on average scores 1/2 on staying; behaviors
replaced within a second or two never got to act."""
UNIQUE = 0.05
"""Index distance under which a case counts as a near duplicate of its nearest neighbour."""
TIE = 0.01
"""Distances closer than this are a tie, broken by quality."""
COUNTERS = ("retrieved", "used", "good")


def _count(meta: Mapping[str, Any], key: str) -> int:
    value = meta.get(key, 0)
    return value if isinstance(value, int) and not isinstance(value, bool) and value > 0 else 0


@attrs.frozen
class Quality:
    """A case's counters (see the module docstring)."""

    retrieved: int = 0
    used: int = 0
    good: int = 0
    active: float = 0.0

    @classmethod
    def of(cls, meta: Mapping[str, Any]) -> Quality:
        active = meta.get("active", 0.0)
        active = float(active) if isinstance(active, int | float) and active > 0 else 0.0
        return cls(*(_count(meta, key) for key in COUNTERS), active)

    def to_meta(self) -> dict[str, Any]:
        return {"retrieved": self.retrieved, "used": self.used, "good": self.good,
                "active": round(self.active, 3)}

    def score(self, nearest: float = 1.0) -> float:
        """The quality in [0, 1]; ``nearest`` the index distance to the nearest other case."""
        success = (self.good + 1) / (self.used + 2)
        use = min(1.0, self.used / (self.retrieved + 1))
        mean = self.active / self.used if self.used else 0.0
        staying = mean / (mean + STAY)
        uniqueness = min(1.0, max(nearest, 0.0) / UNIQUE)
        return success * (1.0 + use) / 2.0 * (1.0 + staying) / 2.0 * uniqueness
