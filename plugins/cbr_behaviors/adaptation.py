"""Adapting a retrieved behavior case with the adaptation strategies of the case memory (004,
"Adaptation and Learning of Behavior Cases").

Strategies (:class:`~cbr_behaviors.casetypes.Strategy`) are indexed by the kind of case they adapt
and by the per-feature distances ``D_f`` the retrieval reports between the query and the case
(:mod:`cbr_behaviors.index`). :func:`applicable` finds those that hold for a retrieval and
ranks them by how well their index matches the distance profile, by their *fit*:

- an ``alter`` strategy holds when both sides specify its feature, ``D_f >= min`` and its sense
  holds: for ``sonar``, ``closer`` when the query's mean range is shorter than the case's
  (``farther``: longer); for ``map``, ``closer`` when the query has more names near the robot
  than the case (``farther``: fewer); for ``closing``, ``closer`` when the person closes in
  faster; for the other distances of :data:`~cbr_behaviors.casetypes.SENSED` (the sectors, the
  width, the person, the doorway), ``closer`` when the query's is shorter; ``any`` always.
  Its fit is ``D_f - min``, how far past its threshold the situation lies;
- a ``merge`` strategy holds when some shared features match very badly (``D_f >= high``) and
  the other shared features, there being at least one, match well on average (their mean
  ``D_f <= low``). Its fit is the mean ``D_f`` of the bad features less the mean of the others,
  the contrast it answers.

Ties keep the memory's order. Then (:func:`adapt`):

1. every holding alter strategy, best first, applies its changes: for each behavior a
   :class:`~cbr_behaviors.casetypes.Change` names, each argument of the target kind (speed,
   distance, turn_rate, by :data:`cbr_world2d.pilots.behaviors.BEHAVIORS`' signatures) or the
   priority becomes ``old * (1 + scale * D_f)``. Symbolic values are resolved first (``slow``:
   10 cm/s, ``moderate`` turning: 50 deg/s, ``med``: 0.6) and the result is written as a number
   in the case's units (cm, cm/s, deg/s), clipped to :data:`LIMITS`, rounded to
   :data:`DECIMALS` places; a value the change leaves equal keeps its written form;
2. the best holding merge strategy, given a second case (the caller retrieves it with weight
   on the badly matching features only, :func:`merge_weights`), merges the second case's
   behaviors in: behaviors both sets have (same name and argument count, paired in order of
   appearance) get each argument averaged (numbers, named levels resolved first; positions
   coordinate by coordinate; directions as angles, by their circular mean) and their priorities
   averaged; values written alike stay as written, and a symbolic value facing a number
   (``curr-goal`` against a point) keeps the retrieved case's; the second case's other
   behaviors are appended.

The result is a new behavior case (origin ``adapted``, the query's index, a derived name; an
adapted meta-plan becomes a plain behavior case, specific to the situation it was adapted for)
with the edits (:class:`Edit`) that made it.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import attrs
import numpy as np

from cbr_behaviors.casetypes import BEHAVIOR, SENSED, BehaviorCase, Item, Strategy, params_of
from cbr_behaviors.index import FEATURES, SONAR_MAX, Index, Scales, overall
from cbr_world2d.pilots.behaviors import (
    LENGTH_UNITS,
    PRIORITIES,
    SPEEDS,
    TOP_SPEED,
    TOP_TURN_RATE,
    TURN_RATES,
)

if TYPE_CHECKING:
    from cbr_behaviors.memory import CaseMemory, Found

CM = LENGTH_UNITS["cm"]
"""Metres per centimetre, the length unit of a case's behaviors."""

LIMITS: dict[str, tuple[float, float]] = {
    "speed": (0.0, TOP_SPEED / CM),
    "turn_rate": (0.0, math.degrees(TOP_TURN_RATE)),
    "distance": (1.0, SONAR_MAX / CM),
    "priority": (0.05, 1.0),
}
"""The range an altered value is clipped to, in the case's units: speeds from standing still
to ``fast`` (cm/s) and turn rates up to ``fast`` (deg/s), the top of the named scale; distances
from 1 cm to the sonar's reach (an obstacle farther off is never seen); priorities in (0, 1],
kept at 0.05 or more so that an alter leaves a behavior a small say instead of removing it."""
DECIMALS: dict[str, int] = {"speed": 2, "turn_rate": 2, "distance": 2, "priority": 3,
                            "position": 2, "direction": 2, "angle": 2}
"""Decimal places an adapted value of each kind keeps (hundredths of cm, cm/s or degrees)."""
NUMERIC = ("speed", "turn_rate", "distance", "angle")
"""Argument kinds averaged as plain numbers when merging."""


@attrs.frozen
class Edit:
    """One change adaptation made to a behavior set: ``strategy`` changed ``argument`` (a
    keyword of the behavior's signature, ``"priority"``, or ``"item"`` for a behavior a merge
    appended) of item ``item`` (its position in the adapted set), named ``behavior``, from
    ``old`` to ``new``."""

    strategy: str
    item: int
    behavior: str
    argument: str
    old: Any
    new: Any

    def to_data(self) -> dict[str, Any]:
        return {"strategy": self.strategy, "item": self.item, "behavior": self.behavior,
                "argument": self.argument, "old": _plain(self.old), "new": _plain(self.new)}


@attrs.frozen
class Adaptation:
    """An adapted behavior case and the edits that made it from the retrieved one."""

    case: BehaviorCase
    edits: tuple[Edit, ...]


def _plain(value: Any) -> Any:
    return [_plain(v) for v in value] if isinstance(value, tuple | list) else value


# --- which strategies hold ----------------------------------------------------------------------


def _senses(feature: str, query: Index, case: Index) -> str | None:
    """``closer`` or ``farther``: where the query's objects are against the case's, None when
    alike or not told."""
    if feature == "sonar" and query.sonar is not None and case.sonar is not None:
        q, c = float(np.mean(query.sonar)), float(np.mean(case.sonar))
    elif feature == "map" and query.map is not None and case.map is not None:
        # more names near the robot is more around it: closer
        q, c = -len(query.map), -len(case.map)
    elif feature == "closing" and query.closing is not None and case.closing is not None:
        # closing in faster brings the person closer
        q, c = -query.closing, -case.closing
    elif feature in SENSED and query.value(feature) is not None \
            and case.value(feature) is not None:
        q, c = query.value(feature), case.value(feature)
    else:
        return None
    return "closer" if q < c else "farther" if q > c else None


def _known(per_feature: Mapping[str, float]) -> dict[str, float]:
    return {f: float(d) for f, d in per_feature.items() if d is not None and not math.isnan(d)}


def _merge_split(strategy: Strategy, known: Mapping[str, float]
                 ) -> tuple[list[str], list[str]]:
    bad = [f for f, d in known.items() if d >= strategy.high]
    return bad, [f for f in known if f not in bad]


def fit(strategy: Strategy, per_feature: Mapping[str, float], query: Index,
        case: Index) -> float | None:
    """How well ``strategy``'s index matches the distance profile ``per_feature`` (see the
    module docstring); None when it does not hold."""
    known = _known(per_feature)
    if strategy.kind == "alter":
        assert strategy.feature is not None
        distance = known.get(strategy.feature)
        if distance is None or distance < strategy.min:
            return None
        if strategy.sense != "any" and _senses(strategy.feature, query, case) != strategy.sense:
            return None
        return distance - strategy.min
    bad, good = _merge_split(strategy, known)
    if not bad or not good:
        return None
    others = sum(known[f] for f in good) / len(good)
    if others > strategy.low:
        return None
    return sum(known[f] for f in bad) / len(bad) - others


def applicable(strategies: Sequence[Strategy], kind: str, per_feature: Mapping[str, float],
               query: Index, case: Index) -> list[Strategy]:
    """The strategies adapting ``kind`` (``behavior`` or ``plan``) that hold for a case whose
    index ``case`` lies at the per-feature distances ``per_feature`` from ``query``, best
    fitting first (ties in the given order)."""
    scored = []
    for order, strategy in enumerate(strategies):
        if strategy.adapts != kind:
            continue
        score = fit(strategy, per_feature, query, case)
        if score is not None:
            scored.append((-score, order, strategy))
    return [s for _, _, s in sorted(scored, key=lambda t: (t[0], t[1]))]


def merge_weights(per_feature: Mapping[str, float], strategy: Strategy,
                  weights: np.ndarray) -> np.ndarray:
    """The weights of the second retrieval of a merge: ``weights`` (over
    :data:`~cbr_behaviors.index.FEATURES`) on the features matching very badly (``D_f >=
    strategy.high``), 0 on all others."""
    bad, _ = _merge_split(strategy, _known(per_feature))
    out = np.zeros(len(FEATURES))
    for feature in bad:
        k = FEATURES.index(feature)
        out[k] = weights[k]
    return out


# --- values in the case's units ----------------------------------------------------------------


def resolve(kind: str, value: Any) -> Any:
    """An argument (or, kind ``priority``, a priority) as a number in the case's units: named
    speeds in cm/s, named turn rates in deg/s, named priorities as numbers; anything else as
    written."""
    if isinstance(value, str):
        if kind == "speed" and value in SPEEDS:
            return SPEEDS[value] / CM
        if kind == "turn_rate" and value in TURN_RATES:
            return math.degrees(TURN_RATES[value])
        if kind == "priority" and value in PRIORITIES:
            return PRIORITIES[value]
    return value


def _number(kind: str, value: float) -> float:
    low, high = LIMITS.get(kind, (-math.inf, math.inf))
    rounded = round(min(max(value, low), high), DECIMALS[kind])
    # rounding may not leave the range, or a priority would reach 0
    return min(max(rounded, low), high)


def _scaled(kind: str, value: Any, factor: float) -> Any:
    old = resolve(kind, value)
    if isinstance(old, bool) or not isinstance(old, int | float):
        return value
    new = _number(kind, old * factor)
    return value if new == old else new


def _mean_angle(a: float, b: float) -> float | None:
    x = math.cos(math.radians(a)) + math.cos(math.radians(b))
    y = math.sin(math.radians(a)) + math.sin(math.radians(b))
    if math.hypot(x, y) < 1e-9:  # opposite directions have no mean
        return None
    return math.degrees(math.atan2(y, x))


def _averaged(kind: str, a: Any, b: Any) -> Any:
    """``a`` and ``b`` (arguments of ``kind``, or priorities) averaged; ``a`` when they are
    alike or cannot be averaged."""
    if a == b:
        return a
    x, y = resolve(kind, a), resolve(kind, b)
    if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in (x, y)):
        if kind == "position" and all(isinstance(v, Sequence) and not isinstance(v, str)
                                      for v in (x, y)):
            return tuple(_number(kind, (p + q) / 2.0) for p, q in zip(x, y, strict=True))
        return a
    if kind == "direction":
        mean = _mean_angle(x, y)
        return a if mean is None else _number(kind, mean)
    if kind in (*NUMERIC, "priority"):
        return _number(kind, (x + y) / 2.0)
    return a


# --- alter and merge -----------------------------------------------------------------------------


def _signature(item: Item) -> tuple[tuple[str, str], ...]:
    call = item[0]
    params = params_of(call[0], len(call) - 1)
    assert params is not None, "a behavior case's items are checked when it is built"
    return params


def _alter(items: list[Item], strategy: Strategy, distance: float, edits: list[Edit]) -> None:
    for change in strategy.changes:
        factor = 1.0 + change.scale * distance
        for k, item in enumerate(items):
            call, priority = item
            name = call[0]
            if not change.applies_to(name):
                continue
            if change.target == "priority":
                new = _scaled("priority", priority, factor)
                if new != priority:
                    edits.append(Edit(strategy.name, k, name, "priority", priority, new))
                    items[k] = (call, new)
                continue
            args = list(call[1:])
            for j, (keyword, kind) in enumerate(_signature(item)):
                if kind != change.target:
                    continue
                new = _scaled(kind, args[j], factor)
                if new != args[j]:
                    edits.append(Edit(strategy.name, k, name, keyword, args[j], new))
                    args[j] = new
            items[k] = ((name, *args), priority)


def _merge(items: list[Item], second: Sequence[Item], strategy: Strategy,
           edits: list[Edit]) -> None:
    unused = list(range(len(second)))
    for k, item in enumerate(items):
        call, priority = item
        key = (call[0], len(call))
        partner = next((i for i in unused if (second[i][0][0], len(second[i][0])) == key),
                       None)
        if partner is None:
            continue
        unused.remove(partner)
        other_call, other_priority = second[partner]
        args = list(call[1:])
        for j, (keyword, kind) in enumerate(_signature(item)):
            new = _averaged(kind, args[j], other_call[j + 1])
            if new != args[j]:
                edits.append(Edit(strategy.name, k, call[0], keyword, args[j], new))
                args[j] = new
        new_priority = _averaged("priority", priority, other_priority)
        if new_priority != priority:
            edits.append(Edit(strategy.name, k, call[0], "priority", priority, new_priority))
        items[k] = ((call[0], *args), new_priority)
    for i in unused:
        edits.append(Edit(strategy.name, len(items), second[i][0][0], "item", None, second[i]))
        items.append(second[i])


def adapt(case: BehaviorCase, query: Index, per_feature: Mapping[str, float],
          strategies: Sequence[Strategy], second: BehaviorCase | None = None) -> Adaptation:
    """``case``, retrieved for ``query`` at the per-feature distances ``per_feature``, adapted
    by the behavior strategies of ``strategies`` that hold (module docstring); a merge needs
    ``second``, the case retrieved for the badly matching features. When nothing changes,
    ``case`` itself with no edits."""
    ranked = applicable(strategies, "behavior", per_feature, query, case.index)
    items = list(case.behaviors)
    edits: list[Edit] = []
    for strategy in ranked:
        if strategy.kind == "alter":
            assert strategy.feature is not None
            _alter(items, strategy, float(per_feature[strategy.feature]), edits)
    altered = bool(edits)
    merge = next((s for s in ranked if s.kind == "merge"), None)
    merged = merge is not None and second is not None
    if merge is not None and second is not None:
        _merge(items, second.behaviors, merge, edits)
    if not edits:
        return Adaptation(case, ())
    name = case.name + (f"+{second.name}" if merged and second is not None else "")
    name += "-adapted" if altered else ""
    return Adaptation(BehaviorCase(name, query, tuple(items), False, "adapted"), tuple(edits))


def adapt_case(case: BehaviorCase, per_feature: Mapping[str, float], query: Index,
               memory: CaseMemory, weights: np.ndarray, scales: Scales,
               exclude: Collection[int] = ()
               ) -> tuple[BehaviorCase | None, list[dict[str, Any]], Found | None]:
    """:func:`adapt` with the strategies of ``memory``, retrieving the second case of a merge
    from it (behavior cases only, not ``exclude``, under :func:`merge_weights`) when a merge
    strategy holds and a case matches the bad features better than ``case`` does. Returns the
    adapted case (None when nothing changed), its edits as plain data and the second case
    when one was merged."""
    ranked = applicable(memory.strategies, "behavior", per_feature, query, case.index)
    merge = next((s for s in ranked if s.kind == "merge"), None)
    second: Found | None = None
    if merge is not None:
        focus = merge_weights(per_feature, merge, weights)
        bad = {f: d for f, d in _known(per_feature).items() if d >= merge.high}
        found = memory.nearest(query, focus, (BEHAVIOR,), 1, scales, exclude=exclude)
        if found and found[0].distance < overall(bad, focus):
            second = found[0]
    other = second.stored if second is not None else None
    adaptation = adapt(case, query, per_feature, ranked,
                       other if isinstance(other, BehaviorCase) else None)
    if not adaptation.edits:
        return None, [], None
    if merge is not None and not any(e.strategy == merge.name for e in adaptation.edits):
        second = None  # the two sets were alike: nothing of the second case went in
    return adaptation.case, [e.to_data() for e in adaptation.edits], second
