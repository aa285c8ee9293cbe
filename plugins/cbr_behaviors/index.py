"""The index of a behavior or plan case (004 Figure 5) and the distance retrieval ranks by.

An :class:`Index` describes the robot's situation by the fourteen features of :data:`FEATURES`,
each optional: a hand-made case leaves out what it does not care about, a query from the
simulation fills them all. Each feature has its own distance ``D_f`` in [0, 1]:

==========================================  ==================================================
feature                                     D_f
==========================================  ==================================================
sonar (16 ranges, m)                        RMS of the range differences / :data:`SONAR_MAX`
motors (v m/s, w rad/s)                     ``min(1, sqrt(((dv / TOP_SPEED)^2 + (dw /
                                            TOP_TURN_RATE)^2) / 2))``
map, behaviors, pending-goals (sets)        Jaccard distance ``1 - |A & B| / |A | B|``, 0 when
                                            both are empty
location, task-loc (x, y m)                 ``min(1, |a - b| / scale)``, scale
                                            :attr:`Scales.location`
task-urgency, goal-urgency, loc-conf,       ``|a - b|``
plan-conf, behav-conf (in [0, 1])
plan, goal (terms)                          positions compared in order: differing atoms count
                                            1, a variable (``?x``) on either side 0, each
                                            position only the longer term has 1; over the
                                            longer length (0 when both are empty)
==========================================  ==================================================

(``TOP_SPEED``, ``TOP_TURN_RATE`` of :mod:`cbr_world2d.pilots.behaviors`.) The terms are
compared the way unification walks them, but a variable binds nothing: ``?x`` matches a
different atom at each of its positions, so that the distance stays a sum over positions.

The overall distance is 004's weighted sum ``D = sum_f w_f D_f``, normalised over the features
both indices specify so that leaving a feature out neither helps nor hurts a case::

    D = sum_{f in both} w_f D_f / sum_{f in both} w_f

and ``D = 1`` when they share no specified feature or those weights sum to 0; the similarity
is ``1 - D``. Weights are non-negative, 1 unless given (:func:`weight_vector`).

:func:`feature_distances` and :func:`overall` compute this in plain Python, one pair at a time;
:class:`IndexTable` holds many cases as arrays and scores them all against a query in one
compiled pass (:mod:`cbr_behaviors.kernels`, imported when a table is first searched).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from numbers import Real
from typing import Any

import attrs
import numpy as np

from cbr_world2d.pilots.behaviors import TOP_SPEED, TOP_TURN_RATE
from cbrcore.documents import found
from cbrcore.errors import CbrError

FIGURE_5: tuple[str, ...] = (
    "sonar", "motors", "map", "location", "behaviors", "task-loc", "task-urgency", "plan",
    "goal", "goal-urgency", "pending-goals", "loc-conf", "plan-conf", "behav-conf",
)
"""The features of 004 Figure 5, in its order and spelling."""
SITUATION: tuple[str, ...] = (
    "front", "left", "right", "rear", "width", "person", "person-bearing", "closing", "door",
    "door-shut", "progress",
)
"""The features that tell the situations of an office floor apart, each a number in [0, 1]
(:mod:`cbr_behaviors.situation` computes them): the sonar's nearest reading ahead, left, right
and behind, the free width across the robot, the nearest person in view (distance, bearing,
closing speed), the doorway ahead on the route (distance, shut or open) and the progress made
along the route to the goal. Figure 5's raw sonar vector and map set cannot tell a person ahead
from a doorway or an empty hallway (one passing walker moves every range); these can."""
FEATURES: tuple[str, ...] = FIGURE_5 + SITUATION
"""The index's features: Figure 5's, then :data:`SITUATION`'s; the attributes of
:class:`Index` spell them with underscores."""
ATTRIBUTES: dict[str, str] = {f: f.replace("-", "_") for f in FEATURES}
"""Each feature's attribute name on :class:`Index`."""

SONAR_MAX = 5.0
"""Metres: the longest sonar range an index keeps; longer readings (no echo) count as this."""
SONAR_BEAMS = 16
"""Ranges in a sonar reading, in the order of :data:`cbr_world2d.sensors.PIONEER_SONAR_DEGREES`."""
NEAR = 3.0
"""Metres: how close a landmark or transient object must be to the robot to enter ``map``."""

SETS: tuple[str, ...] = ("map", "behaviors", "pending-goals")
"""The features that are sets of names (Jaccard distance)."""
TERMS: tuple[str, ...] = ("plan", "goal")
"""The features that are terms (structural distance with variables)."""
POINTS: tuple[str, ...] = ("location", "task-loc")
"""The features that are points (straight-line distance over :attr:`Scales.location`)."""
FRACTIONS: tuple[str, ...] = ("task-urgency", "goal-urgency", "loc-conf", "plan-conf",
                              "behav-conf", *SITUATION)
"""The features that are numbers in [0, 1] (absolute difference)."""

VARIABLE_CODE = -1
"""A variable's code in the terms of an :class:`IndexTable`: it matches any atom."""
UNKNOWN_CODE = -2
"""The code of a query's atom no case of an :class:`IndexTable` has: it matches no atom of a
case (but a variable)."""

Weights = Mapping[str, float]
"""Feature name (as in :data:`FEATURES`) -> weight >= 0; features left out weigh 1."""


class IndexDataError(CbrError):
    """An index, a feature of one or a weight that cannot be used; the message names where it
    came from, the feature and what was expected."""

    def __init__(self, where: str, feature: str | None, problem: str) -> None:
        self.where = where
        self.feature = feature
        self.problem = problem
        about = f"feature {feature!r}: " if feature is not None else ""
        super().__init__(f"{where}: {about}{problem}")


def is_variable(atom: str) -> bool:
    """Whether a term's atom is a variable (starts with ``?``), which matches any atom."""
    return atom.startswith("?")


# --------------------------------------------------------------------------------------------
# reading plain data


def _number(value: Any, where: str, feature: str, expected: str) -> float:
    """``value`` as a float, refusing what is not a real number (booleans included) and NaN."""
    if isinstance(value, bool) or not isinstance(value, Real):
        raise IndexDataError(where, feature, f"expected {expected}, got {value!r}")
    try:
        number = float(value)
    except OverflowError:  # an integer past the largest float
        raise IndexDataError(where, feature, f"expected {expected}, got "
                                             f"{found(value, setting=True)}") from None
    if math.isnan(number):
        raise IndexDataError(where, feature, f"expected {expected}, got NaN")
    return number


def _finite(value: Any, where: str, feature: str, expected: str) -> float:
    number = _number(value, where, feature, expected)
    if math.isinf(number):
        raise IndexDataError(where, feature, f"expected {expected}, got {number!r}")
    return number


def _numbers(value: Any, count: int, where: str, feature: str, expected: str) -> list[Any]:
    """``value`` as a list of ``count`` items (not yet checked), refusing strings and
    mappings."""
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, Sequence | np.ndarray):
        raise IndexDataError(where, feature, f"expected {expected}, got {value!r}")
    items = list(value)
    if len(items) != count:
        raise IndexDataError(where, feature,
                             f"expected {expected}, got {len(items)} numbers: {value!r}")
    return items


def _names(value: Any, where: str, feature: str, expected: str) -> list[str]:
    """``value`` as a list of non-empty strings, refusing a lone string (it would be read as
    its letters) and mappings."""
    if isinstance(value, str | bytes | Mapping) or not isinstance(value, Iterable):
        raise IndexDataError(where, feature, f"expected {expected}, got {value!r}")
    items = list(value)
    for item in items:
        if not isinstance(item, str) or not item:
            raise IndexDataError(where, feature,
                                 f"expected {expected}, got the item {item!r} in {value!r}")
    return items


def _sonar(value: Any, where: str) -> tuple[float, ...]:
    expected = (f"{SONAR_BEAMS} ranges >= 0 in metres (or one range for all beams), longer "
                f"than {SONAR_MAX} m counted as {SONAR_MAX}")
    if isinstance(value, Real) and not isinstance(value, bool):
        value = [value] * SONAR_BEAMS
    ranges = [_number(v, where, "sonar", expected)
              for v in _numbers(value, SONAR_BEAMS, where, "sonar", expected)]
    for r in ranges:
        if r < 0.0:
            raise IndexDataError(where, "sonar", f"expected {expected}, got the range {r!r}")
    return tuple(min(r, SONAR_MAX) for r in ranges)


def _motors(value: Any, where: str) -> tuple[float, float]:
    expected = "[v, w]: a speed in m/s and a turn rate in rad/s, finite"
    v, w = (_finite(x, where, "motors", expected)
            for x in _numbers(value, 2, where, "motors", expected))
    return v, w


def _point(feature: str) -> Callable[[Any, str], tuple[float, float]]:
    def parse(value: Any, where: str) -> tuple[float, float]:
        expected = "[x, y] in metres, finite"
        x, y = (_finite(c, where, feature, expected)
                for c in _numbers(value, 2, where, feature, expected))
        return x, y
    return parse


def _fraction(feature: str) -> Callable[[Any, str], float]:
    def parse(value: Any, where: str) -> float:
        expected = "a number in [0, 1]"
        number = _number(value, where, feature, expected)
        if not 0.0 <= number <= 1.0:
            raise IndexDataError(where, feature, f"expected {expected}, got {number!r}")
        return number
    return parse


def _set(feature: str) -> Callable[[Any, str], frozenset[str]]:
    def parse(value: Any, where: str) -> frozenset[str]:
        return frozenset(_names(value, where, feature, "a list of non-empty names"))
    return parse


def _term(feature: str) -> Callable[[Any, str], tuple[str, ...]]:
    def parse(value: Any, where: str) -> tuple[str, ...]:
        return tuple(_names(value, where, feature,
                            "a list of non-empty atoms (variables start with '?')"))
    return parse


_PARSERS: dict[str, Callable[[Any, str], Any]] = {
    "sonar": _sonar,
    "motors": _motors,
    **{f: _point(f) for f in POINTS},
    **{f: _fraction(f) for f in FRACTIONS},
    **{f: _set(f) for f in SETS},
    **{f: _term(f) for f in TERMS},
}


def _converter(feature: str) -> Callable[[Any], Any]:
    """The attrs converter of ``feature``: None stays None (unspecified), anything else is read
    as plain data, so that an :class:`Index` built in Python is checked as one read from a
    file."""
    parse = _PARSERS[feature]

    def convert(value: Any) -> Any:
        return None if value is None else parse(value, "Index")
    return convert


def _field(feature: str) -> Any:
    return attrs.field(default=None, converter=_converter(feature), kw_only=True)


@attrs.frozen
class Index:
    """The retrieval index of a case or a query: 004 Figure 5's features, each None when
    unspecified. Built from plain data (:meth:`from_data`) or from Python values, which are
    checked and normalised alike (sonar: one number stands for all 16 beams, ranges over
    :data:`SONAR_MAX` are cut to it; lists become tuples, name lists frozensets)."""

    sonar: tuple[float, ...] | None = _field("sonar")
    """16 ranges in metres, in [0, :data:`SONAR_MAX`]."""
    motors: tuple[float, float] | None = _field("motors")
    """(speed m/s, turn rate rad/s)."""
    map: frozenset[str] | None = _field("map")
    """Ids of map landmarks and kinds of transient objects within :data:`NEAR` of the robot."""
    location: tuple[float, float] | None = _field("location")
    """The estimated position (x, y) in metres."""
    behaviors: frozenset[str] | None = _field("behaviors")
    """Names of the active behaviors."""
    task_loc: tuple[float, float] | None = _field("task-loc")
    """The current goal location (x, y) in metres."""
    task_urgency: float | None = _field("task-urgency")
    plan: tuple[str, ...] | None = _field("plan")
    """The plan's steps (place names), a term."""
    goal: tuple[str, ...] | None = _field("goal")
    """The current message goal, a term such as ``("deliver", place, priority)``."""
    goal_urgency: float | None = _field("goal-urgency")
    pending_goals: frozenset[str] | None = _field("pending-goals")
    """The places of the pending messages."""
    loc_conf: float | None = _field("loc-conf")
    plan_conf: float | None = _field("plan-conf")
    behav_conf: float | None = _field("behav-conf")
    front: float | None = _field("front")
    """The nearest sonar reading within 15 degrees of the heading, over :data:`SONAR_MAX`."""
    left: float | None = _field("left")
    """The nearest reading 15 to 150 degrees to the left, over :data:`SONAR_MAX`."""
    right: float | None = _field("right")
    """The nearest reading 15 to 150 degrees to the right, over :data:`SONAR_MAX`."""
    rear: float | None = _field("rear")
    """The nearest reading more than 150 degrees off the heading, over :data:`SONAR_MAX`."""
    width: float | None = _field("width")
    """The free width across the robot (both side readings and its diameter), over 4 m."""
    person: float | None = _field("person")
    """The distance to the nearest person in view, over 5 m (1: none within 5 m)."""
    person_bearing: float | None = _field("person-bearing")
    """That person's bearing off the heading, over pi (0 straight ahead; 1 behind or none)."""
    closing: float | None = _field("closing")
    """How fast that person and the robot close in, over 1.5 m/s (0 parting or none)."""
    door: float | None = _field("door")
    """The distance to the next doorway the route passes, over 5 m (1: none within 5 m)."""
    door_shut: float | None = _field("door-shut")
    """1 when that doorway's door is shut, 0 when open or with no doorway ahead."""
    progress: float | None = _field("progress")
    """The part of the route to the current goal already driven (0 at its start, 1 there)."""

    def value(self, feature: str) -> Any:
        """The value of ``feature`` (named as in :data:`FEATURES`), None when unspecified."""
        return getattr(self, ATTRIBUTES[feature])

    def specified(self) -> tuple[str, ...]:
        """The features this index specifies, in :data:`FEATURES` order."""
        return tuple(f for f in FEATURES if self.value(f) is not None)

    @classmethod
    def from_data(cls, data: Mapping[str, Any], where: str) -> Index:
        """The index written as ``data``: feature name (as in :data:`FEATURES`) -> plain value
        (numbers, lists of numbers or of strings); ``where`` names the source in errors."""
        if not isinstance(data, Mapping):
            raise IndexDataError(where, None,
                                 f"expected a mapping of feature -> value, got {data!r}")
        values: dict[str, Any] = {}
        for feature, value in data.items():
            if feature not in _PARSERS:
                raise IndexDataError(where, str(feature),
                                     f"unknown feature; expected one of {', '.join(FEATURES)}")
            if value is None:
                raise IndexDataError(where, feature,
                                     "expected a value (leave the feature out to leave it "
                                     "unspecified), got None")
            values[ATTRIBUTES[feature]] = _PARSERS[feature](value, where)
        return cls(**values)

    def to_data(self) -> dict[str, Any]:
        """The specified features as plain data :meth:`from_data` reads back to this index:
        sequences as lists, sets as sorted lists."""
        data: dict[str, Any] = {}
        for feature in FEATURES:
            value = self.value(feature)
            if value is None:
                continue
            if isinstance(value, frozenset):
                data[feature] = sorted(value)
            elif isinstance(value, tuple):
                data[feature] = list(value)
            else:
                data[feature] = value
        return data


@attrs.frozen
class Scales:
    """The lengths that turn a feature's raw difference into a distance in [0, 1]."""

    location: float = attrs.field(default=10.0)
    """Metres at which two locations (or task locations) are as far apart as counts."""

    @location.validator
    def _check(self, _attribute: attrs.Attribute, value: float) -> None:
        if isinstance(value, bool) or not isinstance(value, Real) or not 0.0 < value < math.inf:
            raise IndexDataError("Scales", "location",
                                 f"expected a finite length > 0 in metres, got {value!r}")


def weight_vector(mapping: Weights | None = None, where: str = "weights") -> np.ndarray:
    """The weights of ``mapping`` as an array over :data:`FEATURES` (features left out weigh
    1; None gives all 1); a name not in :data:`FEATURES` or a weight that is not a finite
    number >= 0 raises :class:`IndexDataError` naming ``where``."""
    vector = np.ones(len(FEATURES))
    if mapping is None:
        return vector
    if not isinstance(mapping, Mapping):
        raise IndexDataError(where, None,
                             f"expected a mapping of feature -> weight, got {mapping!r}")
    expected = "a weight: a finite number >= 0"
    for feature, weight in mapping.items():
        if feature not in _PARSERS:
            raise IndexDataError(where, str(feature),
                                 f"unknown feature; expected one of {', '.join(FEATURES)}")
        w = _finite(weight, where, feature, expected)
        if w < 0.0:
            raise IndexDataError(where, feature, f"expected {expected}, got {w!r}")
        vector[FEATURES.index(feature)] = w
    return vector


def _as_vector(weights: Weights | np.ndarray | None, where: str) -> np.ndarray:
    """``weights`` as an array over :data:`FEATURES`: a mapping through
    :func:`weight_vector`, an array checked for its shape and values."""
    if weights is None or isinstance(weights, Mapping):
        return weight_vector(weights, where)
    vector = np.asarray(weights, dtype=np.float64)
    if vector.shape != (len(FEATURES),):
        raise IndexDataError(where, None, f"expected {len(FEATURES)} weights in FEATURES "
                                          f"order, got an array of shape {vector.shape}")
    bad = np.flatnonzero(~(np.isfinite(vector) & (vector >= 0.0)))
    if bad.size:
        f = int(bad[0])
        raise IndexDataError(where, FEATURES[f], "expected a weight: a finite number >= 0, "
                                                 f"got {vector[f]!r}")
    return vector


# --------------------------------------------------------------------------------------------
# the distances, one pair at a time


def jaccard(a: frozenset[str], b: frozenset[str]) -> float:
    """``1 - |a & b| / |a | b|``; 0 when both are empty."""
    union = len(a | b)
    return 0.0 if union == 0 else 1.0 - len(a & b) / union


def term_distance(a: Sequence[str], b: Sequence[str]) -> float:
    """The structural distance of two terms (module docstring): differing atoms in the same
    position and positions only the longer term has count 1, variables match anything; over
    the longer length."""
    longest = max(len(a), len(b))
    if longest == 0:
        return 0.0
    differing = sum(1 for x, y in zip(a, b, strict=False)
                    if x != y and not is_variable(x) and not is_variable(y))
    return (differing + longest - min(len(a), len(b))) / longest


def _distance(feature: str, a: Any, b: Any, scales: Scales) -> float:
    if feature == "sonar":
        squares = sum((x - y) ** 2 for x, y in zip(a, b, strict=True))
        return math.sqrt(squares / SONAR_BEAMS) / SONAR_MAX
    if feature == "motors":
        dv = (a[0] - b[0]) / TOP_SPEED
        dw = (a[1] - b[1]) / TOP_TURN_RATE
        return min(1.0, math.sqrt((dv * dv + dw * dw) / 2.0))
    if feature in POINTS:
        return min(1.0, math.hypot(a[0] - b[0], a[1] - b[1]) / scales.location)
    if feature in SETS:
        return jaccard(a, b)
    if feature in TERMS:
        return term_distance(a, b)
    return abs(a - b)


def feature_distances(query: Index, case: Index,
                      scales: Scales = Scales()) -> dict[str, float]:
    """``D_f`` for each feature both ``query`` and ``case`` specify, in :data:`FEATURES`
    order."""
    out: dict[str, float] = {}
    for feature in FEATURES:
        a = query.value(feature)
        b = case.value(feature)
        if a is not None and b is not None:
            out[feature] = _distance(feature, a, b, scales)
    return out


def overall(per_feature: Mapping[str, float],
            weights: Weights | np.ndarray | None = None) -> float:
    """The overall distance ``D`` from the per-feature distances of the features both sides
    specify (as :func:`feature_distances` gives them): their weighted mean, 1 when there are
    none or their weights sum to 0. ``weights`` is a mapping as :func:`weight_vector` reads,
    or its array."""
    vector = _as_vector(weights, "weights")
    total = 0.0
    weight = 0.0
    for feature, distance in per_feature.items():
        w = float(vector[FEATURES.index(feature)])
        total += w * distance
        weight += w
    return 1.0 if weight <= 0.0 else total / weight


# --------------------------------------------------------------------------------------------
# many cases at once


@attrs.frozen
class Hit:
    """A case :meth:`IndexTable.nearest` found."""

    row: int
    """The case's position in the sequence the table was built from."""
    distance: float
    """The overall distance ``D`` to the query."""
    features: dict[str, float]
    """``D_f`` of each feature both the query and the case specify, in :data:`FEATURES`
    order."""


def _vocabulary(indices: Sequence[Index], features: Sequence[str]) -> dict[str, int]:
    """Every name the ``features`` of ``indices`` hold, numbered in sorted order (a term's
    variables are coded apart, but in a set ``?x`` is a name like any other)."""
    names: set[str] = set()
    for index in indices:
        for feature in features:
            value = index.value(feature)
            if value is not None:
                names.update(a for a in value if feature in SETS or not is_variable(a))
    return {name: code for code, name in enumerate(sorted(names))}


def _arrays(n: int, words: int, longest: int) -> dict[str, np.ndarray]:
    """Zeroed arrays of the layout of :class:`IndexTable` for ``n`` cases, ``words`` bitset
    words and terms of ``longest`` atoms."""
    return {"specified": np.zeros((len(FEATURES), n), dtype=np.bool_),
            "sonar": np.zeros((SONAR_BEAMS, n)),
            "motors": np.zeros((2, n)),
            "points": np.zeros((len(POINTS), 2, n)),
            "fractions": np.zeros((len(FRACTIONS), n)),
            "bits": np.zeros((len(SETS), words, n), dtype=np.uint64),
            "sizes": np.zeros((len(SETS), n), dtype=np.int64),
            "terms": np.zeros((len(TERMS), max(1, longest), n), dtype=np.int32),
            "lengths": np.zeros((len(TERMS), n), dtype=np.int64)}


def _longest(indices: Iterable[Index]) -> int:
    return max([len(i.value(f)) for i in indices for f in TERMS if i.value(f) is not None],
               default=0)


def _encode(index: Index, arrays: Mapping[str, np.ndarray], r: int, names: Mapping[str, int],
            atoms: Mapping[str, int]) -> None:
    """Writes ``index`` into column ``r`` of ``arrays`` (laid out as :class:`IndexTable`'s):
    its sets' names as bits of their codes in ``names`` (names it lacks only counted in the
    size), its terms' atoms as their codes in ``atoms`` (variables :data:`VARIABLE_CODE`,
    atoms it lacks :data:`UNKNOWN_CODE`)."""
    for f, feature in enumerate(FEATURES):
        arrays["specified"][f, r] = index.value(feature) is not None
    if index.sonar is not None:
        arrays["sonar"][:, r] = index.sonar
    if index.motors is not None:
        arrays["motors"][:, r] = index.motors
    for s, feature in enumerate(POINTS):
        value = index.value(feature)
        if value is not None:
            arrays["points"][s, :, r] = value
    for s, feature in enumerate(FRACTIONS):
        value = index.value(feature)
        if value is not None:
            arrays["fractions"][s, r] = value
    for s, feature in enumerate(SETS):
        value = index.value(feature)
        if value is not None:
            words = arrays["bits"][s, :, r]  # a view: the bits go into the table
            for name in value:
                code = names.get(name)
                if code is not None:
                    words[code >> 6] |= np.uint64(1) << np.uint64(code & 63)
            arrays["sizes"][s, r] = len(value)
    for s, feature in enumerate(TERMS):
        value = index.value(feature)
        if value is not None:
            arrays["terms"][s, :len(value), r] = [
                VARIABLE_CODE if is_variable(atom) else atoms.get(atom, UNKNOWN_CODE)
                for atom in value]
            arrays["lengths"][s, r] = len(value)


@attrs.frozen(eq=False)
class IndexTable:
    """Many cases' indices as arrays, scored against a query in one compiled pass.

    Case ``r`` (its position in the sequence :meth:`build` was given) is column ``r`` of
    every array, which are feature-major so that the pass reads each feature's values of all
    the cases in a row: ``specified`` ``(F, N)`` the features it specifies, ``sonar``
    ``(16, N)``, ``motors`` ``(2, N)``, ``points`` ``(2, 2, N)`` (:data:`POINTS`, x and y),
    ``fractions`` ``(16, N)`` (:data:`FRACTIONS`); its sets (:data:`SETS`) as bitsets over
    ``names`` (bit ``c % 64`` of word ``c // 64`` for the name of code ``c``) in ``bits``
    ``(3, W, N)``, with their sizes in ``sizes`` ``(3, N)``; its terms (:data:`TERMS`) as
    codes of ``atoms`` (variables -1), padded, in ``terms`` ``(2, L, N)``, with their lengths
    in ``lengths`` ``(2, N)``. Unspecified features hold zeros. A query's names and atoms no
    case has count in its sets' sizes and terms' lengths but never meet a case's.
    """

    scales: Scales
    names: dict[str, int]
    atoms: dict[str, int]
    specified: np.ndarray
    sonar: np.ndarray
    motors: np.ndarray
    points: np.ndarray
    fractions: np.ndarray
    bits: np.ndarray
    sizes: np.ndarray
    terms: np.ndarray
    lengths: np.ndarray

    @classmethod
    def build(cls, indices: Sequence[Index], scales: Scales = Scales()) -> IndexTable:
        """The table of ``indices``; results name them by their position in the sequence."""
        for r, index in enumerate(indices):
            if not isinstance(index, Index):
                raise TypeError(f"expected Index values, got {type(index).__name__} at {r}")
        names = _vocabulary(indices, SETS)
        atoms = _vocabulary(indices, TERMS)
        arrays = _arrays(len(indices), max(1, (len(names) + 63) // 64), _longest(indices))
        for r, index in enumerate(indices):
            _encode(index, arrays, r, names, atoms)
        return cls(scales, names, atoms, **arrays)

    def __len__(self) -> int:
        return self.specified.shape[1]

    def _query(self, query: Index) -> dict[str, np.ndarray]:
        """``query``'s arrays: those of a table of it alone over this table's names and
        atoms."""
        if not isinstance(query, Index):
            raise TypeError(f"expected an Index as the query, got {type(query).__name__}")
        q = _arrays(1, self.bits.shape[1], _longest((query,)))
        _encode(query, q, 0, self.names, self.atoms)
        return q

    def _score(self, q: dict[str, np.ndarray], weights: np.ndarray, rows: np.ndarray | None,
               k: int, detail: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The kernel's pass (:func:`cbr_behaviors.kernels.score`) with the query's arrays
        ``q`` over the cases ``rows`` (all when None): totals ``(n,)``, per-feature distances
        ``(F, n)`` if ``detail`` (else ``(F, 0)``) and the positions of the best ``k``."""
        from cbr_behaviors import kernels

        n = len(self) if rows is None else rows.shape[0]
        total = np.empty(n)
        per_feature = np.empty((len(FEATURES), n)) if detail else None
        best = np.empty(k, dtype=np.int64)
        found = kernels.score(
            n, rows, self.specified, self.sonar, self.motors, self.points, self.fractions,
            self.bits, self.sizes, self.terms, self.lengths, q["specified"][:, 0],
            q["sonar"][:, 0], q["motors"][:, 0], q["points"][..., 0], q["fractions"][:, 0],
            q["bits"][..., 0], q["sizes"][:, 0], q["terms"][..., 0], q["lengths"][:, 0],
            weights, float(self.scales.location), TOP_SPEED, TOP_TURN_RATE, k, total,
            per_feature, best)
        if per_feature is None:
            per_feature = np.empty((len(FEATURES), 0))
        return total, per_feature, best[:found]

    def distances(self, query: Index, weights: Weights | np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
        """The overall distance of every case to ``query`` ``(N,)`` and the per-feature ones
        ``(N, F)``, NaN where the case or the query leaves the feature out. ``weights`` as
        :func:`overall` takes them."""
        # rows given, as for the hits of nearest, so that the kernel is compiled for one
        # type fewer
        total, per_feature, _ = self._score(self._query(query),
                                            _as_vector(weights, "weights"),
                                            np.arange(len(self)), 0, True)
        return total, per_feature.T

    def nearest(self, query: Index, weights: Weights | np.ndarray | None = None, k: int = 1,
                rows: np.ndarray | None = None) -> list[Hit]:
        """The ``k`` cases nearest ``query`` (fewer when there are fewer), best first, ties
        by row; only the cases ``rows`` (row numbers) when given. ``weights`` as
        :func:`overall` takes them."""
        if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 0:
            raise ValueError(f"k must be an int >= 0, got {k!r}")
        if rows is not None:
            rows = np.asarray(rows)
            if rows.ndim != 1 or (rows.size and rows.dtype.kind not in "iu"):
                raise ValueError("rows must be a 1-D array of row numbers")
            rows = rows.astype(np.int64)
            if rows.size and (rows.min() < 0 or rows.max() >= len(self)):
                raise ValueError(f"rows must lie in [0, {len(self)}), got "
                                 f"{int(rows.min())} to {int(rows.max())}")
        q = self._query(query)
        vector = _as_vector(weights, "weights")
        if rows is None:
            # every case without the per-feature distances, then the same pass over the hits
            # for theirs
            _, _, best = self._score(q, vector, None, int(k), False)
            total, per_feature, _ = self._score(q, vector, best, 0, True)
            hits = best
        else:
            # a subset in one pass with them: the kernel is compiled for rows and detail
            # together only, as the pass over the hits needs it anyway
            total, per_feature, best = self._score(q, vector, rows, int(k), True)
            total = total[best]
            per_feature = per_feature[:, best]
            hits = rows[best]
        return [Hit(row, distance,
                    {FEATURES[f]: float(per_feature[f, i])
                     for f in np.flatnonzero(~np.isnan(per_feature[:, i]))})
                for i, (row, distance) in enumerate(zip(hits.tolist(), total.tolist(),
                                                        strict=True))]
