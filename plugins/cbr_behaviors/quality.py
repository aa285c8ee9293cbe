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
dominates; use and staying at most halve it. Forgetting drops the learned cases of lowest
quality first.

Retrieval does not rank by this score: a smoothed score puts a case used once, and well, above
one that went well nine times in ten, and a near match installed on such luck is as often worse
as better. Nor does it compare two cases' whole records: each was gathered in the situations
where that case was the nearest, and a case for crowded hallways goes badly more often than one
for clear ones because its situations are harder. A case therefore also keeps, under
:data:`RIVALS`, its record *against* each rival: the spells it was installed while the rival
matched within the retrieval's band (:func:`against`). Among cases whose distances lie within a
band of the nearest one's, a case takes the nearest one's place only when its record against the
nearest shows it better than the nearest's record against it (:func:`better`): it was installed
with the nearest in its band at least :data:`EVIDENCE` times, and the lower bound of Newcombe's
interval for the difference of the two success rates (built from each rate's Wilson score
interval at :data:`Z`) lies above 0::

    p = good / used                                       each case's success rate
    l, u = (p + z²/2n -+ z sqrt(p(1 - p)/n + z²/4n²)) / (1 + z²/n)     Wilson, n = used
    margin = (p_c - p_n) - sqrt((p_c - l_c)² + (u_n - p_n)²)            c: challenger,
                                                                        n: nearest

A nearest case never installed with the challenger in its band has no record against it to be
beaten: what has not been tried there is tried before experience overrides it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import attrs

STAY = 10.0
"""Seconds: a case whose spells last this long on average scores 1/2 on staying; behaviors
replaced within a second or two never got to act."""
UNIQUE = 0.05
"""Index distance under which a case counts as a near duplicate of its nearest neighbour."""
TIE = 0.01
"""Distances closer than this are a tie, broken by the cases' records (:func:`better`)."""
EVIDENCE = 3
"""Uses a case needs before its record may take retrieval from a nearer case."""
Z = 1.645
"""The normal quantile of the Wilson bounds: a one-sided 95% level, so that a case displaces a
nearer one only when the difference in their success rates would arise by chance less than one
time in twenty."""
COUNTERS = ("retrieved", "used", "good")
RIVALS = "rivals"
"""The meta key of a case's records against its rivals: rival case id (as text) -> ``[used,
good]``."""


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


def against(meta: Mapping[str, Any], rival: int | None) -> Quality:
    """The record (``used`` and ``good``) of the case of ``meta`` in the spells it was
    installed while the case ``rival`` matched within the band; none when malformed."""
    records = meta.get(RIVALS)
    entry = records.get(str(rival)) if isinstance(records, Mapping) else None
    if not isinstance(entry, list | tuple) or len(entry) != 2:
        return Quality()
    used, good = (_count({"n": n}, "n") for n in entry)
    return Quality(used=used, good=min(good, used))


def with_rivals(meta: Mapping[str, Any], rivals: Iterable[int], good: bool
                ) -> dict[str, list[int]]:
    """The records against rivals of the case of ``meta`` after one more spell, ``good`` or
    not, installed while ``rivals`` matched within the band."""
    records = meta.get(RIVALS)
    out = {key: [q.used, q.good] for key in (records if isinstance(records, Mapping) else ())
           if (q := against(meta, key)).used}
    for rival in rivals:
        q = against(meta, rival)
        out[str(rival)] = [q.used + 1, q.good + bool(good)]
    return out


def wilson(good: int, used: int, z: float = Z) -> tuple[float, float]:
    """The Wilson score interval of the success rate ``good / used``; ``(0, 1)`` when unused."""
    if used <= 0:
        return 0.0, 1.0
    p = good / used
    z2 = z * z
    centre = (p + z2 / (2 * used)) / (1 + z2 / used)
    half = z * math.sqrt(p * (1 - p) / used + z2 / (4 * used * used)) / (1 + z2 / used)
    return max(0.0, centre - half), min(1.0, centre + half)


def margin(challenger: Quality, nearest: Quality, z: float = Z) -> float:
    """Newcombe's lower bound for how much more often ``challenger``'s spells go well than
    ``nearest``'s (module docstring); above 0 when the records show it better."""
    # an unused case's rate is unknown: 1/2 in the middle of its interval (0, 1)
    p_c = challenger.good / challenger.used if challenger.used else 0.5
    p_n = nearest.good / nearest.used if nearest.used else 0.5
    low_c, _ = wilson(challenger.good, challenger.used, z)
    _, high_n = wilson(nearest.good, nearest.used, z)
    return (p_c - p_n) - math.hypot(p_c - low_c, high_n - p_n)


def better(challenger: Quality, nearest: Quality) -> bool:
    """Whether ``challenger``'s record shows it better than ``nearest``'s: used at least
    :data:`EVIDENCE` times, ``nearest`` used at all, and :func:`margin` above 0."""
    return (challenger.used >= EVIDENCE and nearest.used > 0
            and margin(challenger, nearest) > 0.0)


def failing(record: Quality) -> bool:
    """Whether ``record`` shows a case going badly more often than well: used at least
    :data:`EVIDENCE` times, fewer than half of them well. Only such a case's adapted variant
    is retained after one good spell: of a case that mostly goes well, one good spell of a
    variant is what the case itself would mostly have done, no sign that the variant is
    better."""
    return record.used >= EVIDENCE and 2 * record.good < record.used
