"""The RUPART index (004 Figure 5): reading it, each feature's distance worked by hand, the
normalised overall distance, the weights, and the compiled table against the plain Python
reference."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_behaviors.index import (
    ATTRIBUTES,
    FEATURES,
    SITUATION,
    Index,
    IndexDataError,
    IndexTable,
    Scales,
    feature_distances,
    overall,
    weight_vector,
)
from cbr_world2d.pilots.behaviors import TOP_SPEED, TOP_TURN_RATE
from cbrcore.errors import CbrError


def distance(feature: str, a: object, b: object, scales: Scales = Scales()) -> float:
    """D_f of two indices that specify only ``feature``, as ``a`` and ``b``."""
    attribute = ATTRIBUTES[feature]
    return feature_distances(Index(**{attribute: a}), Index(**{attribute: b}), scales)[feature]


@pytest.mark.parametrize(("feature", "a", "b", "expected"), [
    # 4 beams 4 m apart, 12 alike: RMS = sqrt(4 * 16 / 16) = 2 m; / 5 m = 0.4
    ("sonar", [1.0] * 4 + [2.0] * 12, [5.0] * 4 + [2.0] * 12, 0.4),
    # 7 m is past the 5 m kept: 1 m against 5 m on every beam, RMS 4 m, / 5 = 0.8
    ("sonar", 1.0, 7.0, 0.8),
    # dv = 0.2 = TOP_SPEED / 2, dw = TOP_TURN_RATE / 2: sqrt((0.25 + 0.25) / 2) = 0.5
    ("motors", [0.1, 0.0], [0.3, TOP_TURN_RATE / 2], 0.5),
    # dv = 2 TOP_SPEED: sqrt((4 + 0) / 2) = 1.41, clipped to 1
    ("motors", [-TOP_SPEED, 0.0], [TOP_SPEED, 0.0], 1.0),
    # {a, b, c} and {b, c, d}: 2 shared of 4 -> 1 - 2/4
    ("map", ["a", "b", "c"], ["b", "c", "d"], 0.5),
    ("behaviors", [], [], 0.0),
    ("pending-goals", ["r1"], [], 1.0),
    # (0, 0) to (3, 4): 5 m over the 10 m scale
    ("location", [0.0, 0.0], [3.0, 4.0], 0.5),
    # 50 m, clipped to 1
    ("task-loc", [0.0, 0.0], [30.0, 40.0], 1.0),
    ("loc-conf", 0.7, 0.2, 0.5),
    ("task-urgency", 0.0, 1.0, 1.0),
    # one atom of three differs
    ("goal", ["deliver", "room1", "high"], ["deliver", "room2", "high"], 1 / 3),
    # a variable matches any atom, on either side
    ("goal", ["deliver", "?place", "high"], ["deliver", "room2", "?p"], 0.0),
    # (a b) against (a c d e): b/c differ, d and e only in the longer: 3 of 4
    ("plan", ["a", "b"], ["a", "c", "d", "e"], 0.75),
    # (?x b) against (a c d e): the variable matches a, the rest as above: 3 of 4
    ("plan", ["?x", "b"], ["a", "c", "d", "e"], 0.75),
    ("plan", [], [], 0.0),
    ("plan", [], ["a"], 1.0),
])
def test_feature_distance_by_hand(feature: str, a: object, b: object, expected: float) -> None:
    assert distance(feature, a, b) == pytest.approx(expected, abs=1e-12)
    assert distance(feature, b, a) == pytest.approx(expected, abs=1e-12)


def test_location_scale() -> None:
    # 5 m over a 20 m scale
    assert distance("location", [0, 0], [3, 4], Scales(location=20.0)) == pytest.approx(0.25)
    with pytest.raises(IndexDataError, match="location"):
        Scales(location=0.0)


def test_overall_over_the_shared_features_only() -> None:
    query = Index(sonar=2.0, map={"a", "b"}, loc_conf=0.9)
    case = Index(map={"b", "c"}, loc_conf=0.5, plan=("hall",))
    per = feature_distances(query, case)
    # shared: map (1 of 3 names shared: 2/3) and loc-conf (0.4); sonar and plan left out
    assert per == pytest.approx({"map": 2 / 3, "loc-conf": 0.4})
    # (3 * 2/3 + 1 * 0.4) / (3 + 1) = 2.4 / 4
    assert overall(per, {"map": 3.0}) == pytest.approx(0.6)
    assert overall(per) == pytest.approx((2 / 3 + 0.4) / 2)
    # nothing shared, or weights summing to 0: as far as can be
    assert overall(feature_distances(Index(sonar=1.0), Index(map={"a"}))) == 1.0
    assert overall(per, {"map": 0.0, "loc-conf": 0.0}) == 1.0


@pytest.mark.parametrize(("weights", "feature", "problem"), [
    ({"map": -1.0}, "map", ">= 0"),
    ({"sonar": math.nan}, "sonar", "NaN"),
    ({"plan": math.inf}, "plan", "finite"),
    ({"goal": True}, "goal", "finite number"),
    ({"task_loc": 1.0}, "task_loc", "unknown feature"),
])
def test_weights_refused(weights: dict, feature: str, problem: str) -> None:
    with pytest.raises(IndexDataError, match=problem) as caught:
        weight_vector(weights, "rupart.yaml: weights")
    assert caught.value.where == "rupart.yaml: weights"
    assert caught.value.feature == feature
    assert isinstance(caught.value, CbrError)


def test_weight_vector() -> None:
    assert weight_vector(None).tolist() == [1.0] * len(FEATURES)
    vector = weight_vector({"map": 2.0, "plan-conf": 0.0})
    assert vector.tolist() == [2.0 if f == "map" else 0.0 if f == "plan-conf" else 1.0
                               for f in FEATURES]


@pytest.mark.parametrize(("data", "feature", "problem"), [
    ({"colour": "red"}, "colour", "unknown feature"),
    ({"sonar": [1.0] * 15}, "sonar", "15 numbers"),
    ({"sonar": -1.0}, "sonar", "range -1.0"),
    ({"motors": [0.1, math.nan]}, "motors", "NaN"),
    ({"map": "doorway"}, "map", "list of non-empty names"),
    ({"plan": ["hall", 3]}, "plan", "the item 3"),
    ({"loc-conf": 1.5}, "loc-conf", r"\[0, 1\]"),
    ({"location": [1.0]}, "location", r"\[x, y\]"),
    ({"goal-urgency": None}, "goal-urgency", "leave the feature out"),
])
def test_bad_index_data(data: dict, feature: str, problem: str) -> None:
    with pytest.raises(IndexDataError, match=problem) as caught:
        Index.from_data(data, "cases.sexp:12")
    assert caught.value.where == "cases.sexp:12"
    assert caught.value.feature == feature
    assert str(caught.value).startswith(f"cases.sexp:12: feature {feature!r}: ")


def test_data_round_trip() -> None:
    data = {"sonar": 2, "motors": [0.1, -0.2], "map": ["person", "door-3"],
            "task-loc": [4, 5], "plan": ["hall", "?x"], "pending-goals": [], "loc-conf": 1}
    index = Index.from_data(data, "here")
    assert index.sonar == (2.0,) * 16
    assert index.map == frozenset({"person", "door-3"})
    assert index.specified() == ("sonar", "motors", "map", "task-loc", "plan",
                                 "pending-goals", "loc-conf")
    assert index.to_data()["map"] == ["door-3", "person"]
    assert Index.from_data(index.to_data(), "again") == index


# --------------------------------------------------------------------------------------------
# the compiled table against the reference

NAMES = st.sampled_from(["a", "b", "c", "d", "?x", "person", *(f"n{i}" for i in range(70))])
ATOMS = st.sampled_from(["hall", "room1", "room2", "deliver", "?x", "?y", "high"])
UNIT = st.floats(0.0, 1.0)
COORD = st.floats(-40.0, 40.0)
VALUES = {
    "sonar": st.lists(st.floats(0.0, 6.0), min_size=16, max_size=16),
    "motors": st.tuples(st.floats(-1.0, 1.0), st.floats(-3.0, 3.0)),
    "map": st.frozensets(NAMES, max_size=6),
    "location": st.tuples(COORD, COORD),
    "behaviors": st.frozensets(NAMES, max_size=4),
    "task-loc": st.tuples(COORD, COORD),
    "task-urgency": UNIT,
    "plan": st.lists(ATOMS, max_size=5),
    "goal": st.lists(ATOMS, max_size=3),
    "goal-urgency": UNIT,
    "pending-goals": st.frozensets(NAMES, max_size=3),
    "loc-conf": UNIT,
    "plan-conf": UNIT,
    "behav-conf": UNIT,
    **{f: UNIT for f in SITUATION},
}


@st.composite
def indices(draw: st.DrawFn) -> Index:
    """An index specifying a random subset of the features."""
    chosen = draw(st.lists(st.sampled_from(FEATURES), unique=True))
    return Index(**{ATTRIBUTES[f]: draw(VALUES[f]) for f in chosen})


@given(st.lists(indices(), min_size=1, max_size=12), indices(),
       st.lists(st.sampled_from([0.0, 0.5, 1.0, 3.0]), min_size=len(FEATURES),
                max_size=len(FEATURES)),
       st.floats(1.0, 30.0))
@settings(max_examples=60, deadline=None)
def test_table_equals_reference(cases: list[Index], query: Index, weights: list[float],
                                scale: float) -> None:
    scales = Scales(location=scale)
    table = IndexTable.build(cases, scales)
    vector = np.array(weights)
    total, per_feature = table.distances(query, vector)
    for r, case in enumerate(cases):
        reference = feature_distances(query, case, scales)
        assert {FEATURES[f] for f in np.flatnonzero(~np.isnan(per_feature[r]))} == set(reference)
        for feature, value in reference.items():
            assert abs(per_feature[r, FEATURES.index(feature)] - value) <= 1e-9
        assert abs(total[r] - overall(reference, vector)) <= 1e-9
    # nearest: the brute-force order of the same totals, ties by row, over all or a subset
    k = min(3, len(cases))
    hits = table.nearest(query, vector, k)
    assert [h.row for h in hits] == sorted(range(len(cases)), key=lambda r: (total[r], r))[:k]
    assert [h.distance for h in hits] == [total[h.row] for h in hits]
    assert all(h.features == pytest.approx(feature_distances(query, cases[h.row], scales))
               for h in hits)
    subset = np.arange(len(cases))[::-2]
    found = table.nearest(query, vector, k, rows=subset)
    assert [h.row for h in found] == sorted(subset.tolist(), key=lambda r: (total[r], r))[:k]
    assert all(h.distance == total[h.row] and h.features == pytest.approx(
        feature_distances(query, cases[h.row], scales)) for h in found)


def test_nearest_order_and_ties() -> None:
    near = Index(loc_conf=0.5, map={"door"})
    cases = [Index(loc_conf=0.9), near, Index(loc_conf=0.6), near, Index(map={"wall"}),
             Index(sonar=1.0)]
    table = IndexTable.build(cases)
    query = Index(loc_conf=0.5, map={"door", "person"})
    hits = table.nearest(query, None, k=10)
    # loc-conf alone 0.1 (row 2); rows 1 and 3 tie at (map 1 - 1/2 + loc-conf 0) / 2 = 0.25,
    # by row; loc-conf 0.4 (row 0); row 4's map shares nothing and row 5 no feature: both 1
    assert [h.row for h in hits] == [2, 1, 3, 0, 4, 5]
    assert [h.distance for h in hits] == pytest.approx([0.1, 0.25, 0.25, 0.4, 1.0, 1.0])
    assert hits[1].features == pytest.approx({"map": 0.5, "loc-conf": 0.0})
    assert hits[-1].features == {}
    assert [h.row for h in table.nearest(query, None, k=2, rows=np.array([5, 3, 2]))] == [2, 3]
    assert table.nearest(query, None, k=0) == []
    with pytest.raises(ValueError, match="rows"):
        table.nearest(query, None, k=1, rows=np.array([6]))
