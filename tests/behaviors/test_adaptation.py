"""Adapting behavior cases with the strategies of the case memory (``cbr_behaviors.adaptation``).

Every expected number is worked by hand in the comments, from the named levels of
:mod:`cbr_world2d.pilots.behaviors` (speeds: slow 10, moderate 20, fast 40 cm/s; turn rates:
slow 25, fast 100 deg/s; priorities: med 0.6, high 1.0) and the per-feature distances of
:mod:`cbr_behaviors.index` (sonar: RMS of the range differences / 5 m; map: Jaccard).
"""

from __future__ import annotations

import numpy as np
import pytest

from cbr_behaviors.adaptation import Edit, adapt, adapt_case, applicable, merge_weights
from cbr_behaviors.casetypes import BehaviorCase, Change, Strategy
from cbr_behaviors.index import FEATURES, Index, Scales, feature_distances
from cbr_behaviors.memory import CaseMemory
from cbrcore.casebase.memory import MemoryStore

SLOW = Strategy("slow-when-closer", "behavior", "alter", "sonar", "closer", 0.05,
                [Change(("moveForward", "goToPos", "avoidObstacle"), "speed", -1.5)])
FASTER = Strategy("speed-up-when-farther", "behavior", "alter", "sonar", "farther", 0.05,
                  [Change(("moveForward", "goToPos"), "speed", 1.0)])
WIDEN = Strategy("widen-when-crowded", "behavior", "alter", "map", "closer", 0.3,
                 [Change(("avoidObstacle", "avoidCollision"), "distance", 1.0)])
CALM = Strategy("calm", "behavior", "alter", "sonar", "any", 0.1,
                [Change(("avoidCollision",), "priority", -1.0)])
MERGE = Strategy("merge-mismatch", "behavior", "merge", high=0.6, low=0.2)
STRATEGIES = [SLOW, FASTER, WIDEN, CALM, MERGE]

CASE = BehaviorCase("hallway", Index(sonar=2.0, map=["sign_1"]), [
    [["moveForward", "slow"], "med"],
    [["avoidObstacle", 100, "moderate"], "med"],
    [["avoidCollision", 40, "fast"], "high"],
    [["goToPos", "curr-goal", "fast", 20], "high"],
])


def test_alter_scales_the_targeted_arguments_by_the_distance() -> None:
    # sonar 1 m against 2 m on every beam: D = 1 / 5 = 0.2, the query's objects closer;
    # map {sign_1, object} against {sign_1}: D = 1 - 1/2 = 0.5, more near the robot (closer)
    query = Index(sonar=1.0, map=["sign_1", "object"])
    per_feature = feature_distances(query, CASE.index)
    assert per_feature == {"sonar": 0.2, "map": 0.5}
    # fits: widen 0.5 - 0.3 = 0.2, slow 0.2 - 0.05 = 0.15, calm 0.2 - 0.1 = 0.1; faster does
    # not hold (closer, not farther), merge neither (no feature at 0.6 or more)
    ranked = applicable(STRATEGIES, "behavior", per_feature, query, CASE.index)
    assert [s.name for s in ranked] == ["widen-when-crowded", "slow-when-closer", "calm"]
    adapted = adapt(CASE, query, per_feature, STRATEGIES)
    # widen: distances x (1 + 0.5) -> 150, 60; slow: speeds x (1 - 1.5 * 0.2) = x 0.7 ->
    # slow 10 -> 7, moderate 20 -> 14, fast 40 -> 28; calm: priority x (1 - 0.2) -> 0.8
    assert adapted.case.items() == [
        [["moveForward", 7.0], "med"],
        [["avoidObstacle", 150.0, 14.0], "med"],
        [["avoidCollision", 60.0, "fast"], 0.8],
        [["goToPos", "curr-goal", 28.0, 20], "high"],
    ]
    assert adapted.case.name == "hallway-adapted"
    assert (adapted.case.index, adapted.case.origin) == (query, "adapted")
    assert adapted.edits[:2] == (
        Edit("widen-when-crowded", 1, "avoidObstacle", "distance", 100, 150.0),
        Edit("widen-when-crowded", 2, "avoidCollision", "distance", 40, 60.0))
    assert adapted.edits[-1] == Edit("calm", 2, "avoidCollision", "priority", "high", 0.8)
    assert len(adapted.edits) == 6


def test_alter_keeps_within_the_valid_ranges() -> None:
    # sonar 3 m against 2 m: D = 0.2, farther: speeds x 1.2 -> slow 10 -> 12, but fast 40 ->
    # 48 is past the top of the scale and stays fast; calm holds either way
    query = Index(sonar=3.0, map=["sign_1"])
    adapted = adapt(CASE, query, feature_distances(query, CASE.index), STRATEGIES)
    assert adapted.case.items()[0] == [["moveForward", 12.0], "med"]
    assert adapted.case.items()[3] == [["goToPos", "curr-goal", "fast", 20], "high"]
    assert [(e.strategy, e.argument) for e in adapted.edits] == [
        ("speed-up-when-farther", "velocity"), ("calm", "priority")]
    # distances x (1 + 9 * 0.5) = x 5.5: 100 -> 550, cut to the sonar's reach of 500 cm;
    # priorities x (1 - 2 * 0.5) = 0, kept at the least say, 0.05
    wide = Strategy("wide", "behavior", "alter", "map", "any", 0.0,
                    [Change("*", "distance", 9.0), Change(("moveForward",), "priority", -2.0)])
    adapted = adapt(CASE, query, {"map": 0.5}, [wide])
    assert adapted.case.items()[1][0] == ["avoidObstacle", 500.0, "moderate"]
    assert adapted.case.items()[2][0] == ["avoidCollision", 220.0, "fast"]
    assert adapted.case.items()[0][1] == 0.05


def test_nothing_holding_leaves_the_case_as_it_is() -> None:
    adapted = adapt(CASE, CASE.index, {"sonar": 0.0, "map": 0.0}, STRATEGIES)
    assert adapted.case is CASE and adapted.edits == ()
    plan_only = [Strategy("p", "plan", "alter", "sonar", "any", 0.0,
                          [Change("*", "speed", 1.0)])]
    assert applicable(plan_only, "behavior", {"sonar": 0.5}, CASE.index, CASE.index) == []


@pytest.mark.parametrize(("per_feature", "holds"), [
    ({"sonar": 0.7, "map": 0.1, "loc-conf": 0.2}, True),     # others' mean 0.15 <= 0.2
    ({"sonar": 0.7, "map": 0.3, "loc-conf": 0.2}, False),    # others' mean 0.25 > 0.2
    ({"sonar": 0.7}, False),                                  # no feature matches well
    ({"sonar": 0.5, "map": 0.0}, False),                      # none matches very badly
])
def test_merge_holds_on_very_bad_and_good_features(per_feature: dict[str, float],
                                                   holds: bool) -> None:
    found = applicable([MERGE], "behavior", per_feature, CASE.index, CASE.index)
    assert found == ([MERGE] if holds else [])


def test_merge_weights_keep_only_the_badly_matching_features() -> None:
    weights = np.arange(1.0, len(FEATURES) + 1.0)
    focus = merge_weights({"sonar": 0.7, "map": 0.1, "loc-conf": 0.9}, MERGE, weights)
    expected = np.zeros(len(FEATURES))
    for feature in ("sonar", "loc-conf"):
        expected[FEATURES.index(feature)] = weights[FEATURES.index(feature)]
    assert np.array_equal(focus, expected)


RETRIEVED = BehaviorCase("a", Index(sonar=1.0, map=[], loc_conf=0.9), [
    [["moveForward", "slow"], "med"],
    [["avoidCollision", 40, "fast"], "high"],
    [["goToPos", "curr-goal", "moderate", 20], "high"],
    [["goStraight", "slow", 170], "med"],
    [["enterDoorway", [300, 100], "curr-head"], "med"],
])
SECOND = BehaviorCase("b", Index(sonar=4.0, loc_conf=0.1), [
    [["moveForward", 30], "high"],
    [["avoidCollision", 60, "slow"], "med"],
    [["goToPos", [300, 100], "moderate", 40], "high"],
    [["goStraight", "slow", -170], "med"],
    [["enterDoorway", [100, 300], "curr-head"], "med"],
    [["stop"], "low"],
])
MERGED = [
    [["moveForward", 20.0], 0.8],                        # (10 + 30) / 2; (0.6 + 1.0) / 2
    [["avoidCollision", 50.0, 62.5], 0.8],               # (40 + 60) / 2; (100 + 25) / 2
    [["goToPos", "curr-goal", "moderate", 30.0], "high"],  # curr-goal stays; (20 + 40) / 2
    [["goStraight", "slow", 180.0], "med"],              # 170 and -170 meet behind, not at 0
    [["enterDoorway", [200.0, 200.0], "curr-head"], "med"],
    [["stop"], "low"],                                   # appended
]


def test_merge_averages_shared_behaviors_and_appends_the_rest() -> None:
    # sonar 4 m against 1 m: D = 3 / 5 = 0.6, very bad; map and loc-conf match exactly
    query = Index(sonar=4.0, map=[], loc_conf=0.9)
    per_feature = feature_distances(query, RETRIEVED.index)
    assert per_feature == {"sonar": 0.6, "map": 0.0, "loc-conf": 0.0}
    adapted = adapt(RETRIEVED, query, per_feature, [MERGE], SECOND)
    assert adapted.case.items() == MERGED
    assert adapted.case.name == "a+b"
    assert adapted.edits[-1] == Edit("merge-mismatch", 5, "stop", "item", None,
                                     (("stop",), "low"))
    # without a second case there is nothing to merge
    assert adapt(RETRIEVED, query, per_feature, [MERGE]).edits == ()


def test_adapt_case_retrieves_the_second_case_for_the_bad_features() -> None:
    store = MemoryStore()
    decoy = BehaviorCase("c", Index(sonar=2.5, map=[], loc_conf=0.9), [[["stop"], "high"]])
    for case in (RETRIEVED, SECOND, decoy, MERGE):
        store.add(case.to_case())
    memory = CaseMemory.load(store)
    query = Index(sonar=4.0, map=[], loc_conf=0.9)
    per_feature = feature_distances(query, RETRIEVED.index)
    # weighed on sonar alone, b (D 0) is nearer than c (D 1.5 / 5 = 0.3), though c matches
    # loc-conf and b does not
    adapted, changes, second = adapt_case(RETRIEVED, per_feature, query, memory,
                                          np.ones(len(FEATURES)), Scales(), exclude=(1,))
    assert second is not None and second.stored == SECOND
    assert adapted is not None and adapted.items() == MERGED
    assert changes[0] == {"strategy": "merge-mismatch", "item": 0, "behavior": "moveForward",
                          "argument": "velocity", "old": "slow", "new": 20.0}
