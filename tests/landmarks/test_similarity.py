"""The similarity of landmark graphs (cbr_landmarks.similarity) and its retrieval index
(cbr_landmarks.index): fuzzy overlaps against triangles worked by hand, the branch and bound
against the enumeration of every matching, 002's obstacle constraint (Figure 4), and the index's
search (with and without its prefilter) against the enumeration over a list of graphs."""

from __future__ import annotations

import itertools
import math
import re

import attrs
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_landmarks import index as index_module
from cbr_landmarks.graph import GraphError, LandmarkGraph
from cbr_landmarks.index import SituationIndex, prefilter_level, raised
from cbr_landmarks.kernels import height
from cbr_landmarks.similarity import (
    CONSTRAINT,
    MATCHING,
    NORMALISE,
    Matching,
    SimilarityOptions,
    allowed,
    case_similarity,
    exhaustive_similarity,
    flattened,
    landmark_similarities,
)
from cbr_world2d.fuzzy import Triangle, angle_overlap, overlap, overlap_arrays, unchecked
from cbrcore.errors import CbrError

MODES = [SimilarityOptions(matching=m, normalise=n, constraint=c)
         for m in MATCHING for n in NORMALISE for c in CONSTRAINT]
DEG = math.radians(1.0)


# --------------------------------------------------------------------------------------------
# fuzzy similarity worked by hand


HAND = [
    # (a, b, overlap): the height where a's falling edge meets b's rising edge
    ((0, 1, 2), (3, 4, 5), 0.0),  # disjoint
    ((0, 1, 2), (2, 3, 4), 0.0),  # touching at one point, membership 0 there
    ((1, 2, 3), (1, 2, 3), 1.0),  # identical
    ((0, 2, 4), (1, 2, 3), 1.0),  # nested, same peak
    ((0, 4, 8), (1, 2, 3), 0.6),  # nested: 3 - x = x / 4 at x = 2.4
    ((0, 2, 4), (2, 4, 6), 0.5),  # symmetric crossing at x = 3
    ((0, 1, 4), (2, 5, 6), 1 / 3),  # (4 - x) / 3 = (x - 2) / 3 at x = 3
    ((1, 1, 1), (0, 2, 4), 0.5),  # crisp inside b: b's membership at 1
    ((1, 1, 1), (1, 1, 1), 1.0),  # crisp, equal
    ((1, 1, 1), (2, 2, 2), 0.0),  # crisp, apart
    ((0, 1, 1), (1, 1, 2), 1.0),  # right-angled, same peak
]


@pytest.mark.parametrize(("a", "b", "expected"), HAND)
def test_overlap_worked_by_hand(a: tuple[float, ...], b: tuple[float, ...],
                                expected: float) -> None:
    for x, y in ((a, b), (b, a)):
        assert overlap(Triangle(*x), Triangle(*y)) == pytest.approx(expected, abs=1e-12)
        assert float(overlap_arrays(np.array([x], float), np.array([y], float))[0]
                     ) == pytest.approx(expected, abs=1e-12)
        assert height(*map(float, x), *map(float, y)) == pytest.approx(expected, abs=1e-12)


def test_angles_across_the_turn() -> None:
    # 179 and -179 degrees, 2 degrees either side: 2 degrees apart, crossing half way up
    a = Triangle(177 * DEG, 179 * DEG, 181 * DEG)
    b = Triangle(-181 * DEG, -179 * DEG, -177 * DEG)
    assert angle_overlap(a, b) == pytest.approx(0.5)
    assert angle_overlap(b, a) == pytest.approx(0.5)
    assert overlap(a, b) == 0.0  # compared without the turn they are 358 degrees apart
    rows = np.array([a.as_tuple()]), np.array([b.as_tuple()])
    assert float(overlap_arrays(*rows, angular=True)[0]) == pytest.approx(0.5)
    # the landmark similarity of two pairs whose distances match exactly and whose angles
    # are those two: (1 + 1/2) / 2
    graphs = [LandmarkGraph(("r", "x"), (), np.array([[[0, 0, 0], d], [d, [0, 0, 0]]]),
                            np.array([[[0, 0, 0], t.as_tuple()], [[0, 0, 0], [0, 0, 0]]]))
              for d, t in (([1.0, 2.0, 3.0], a), ([1.0, 2.0, 3.0], b))]
    assert landmark_similarities(*graphs, 0, 0)[1, 1] == pytest.approx(0.75)


TRIANGLES = st.lists(st.floats(-5.0, 5.0), min_size=3, max_size=3).map(sorted)


@given(TRIANGLES, TRIANGLES, st.booleans())
@settings(max_examples=150, deadline=None)
def test_scalar_array_and_kernel_overlaps_agree(a: list[float], b: list[float],
                                                angular: bool) -> None:
    ta, tb = Triangle(*a), Triangle(*b)
    scalar = angle_overlap(ta, tb) if angular else overlap(ta, tb)
    vector = float(overlap_arrays(np.array([a]), np.array([b]), angular=angular)[0])
    assert 0.0 <= scalar <= 1.0
    assert vector == pytest.approx(scalar, abs=1e-12)
    if not angular:
        assert height(*a, *b) == pytest.approx(scalar, abs=1e-12)


# --------------------------------------------------------------------------------------------
# graphs refused


def _data(n: int = 3) -> dict:
    ids = [f"l{k}" for k in range(n)]
    graph = LandmarkGraph.from_points(ids, np.arange(2 * n, dtype=float).reshape(n, 2) ** 1.5,
                                      np.full(n, 0.2), [("l0", "l1")])
    return graph.to_data()


@pytest.mark.parametrize(("change", "field"), [
    (lambda d: d.update(landmarks=["l0"], delta=[[[0, 0, 0]]], alpha=[[[0, 0, 0]]],
                        obstacles=[]), "landmarks"),
    (lambda d: d.update(obstacles=[["l0", "l9"]]), "obstacles[0]"),
    (lambda d: d["delta"][0].__setitem__(1, [3.0, 2.0, 1.0]), "delta[0][1]"),
    (lambda d: d["alpha"][1].__setitem__(0, [math.nan, 0.0, 1.0]), "alpha[1][0]"),
])
def test_bad_graph_data_names_the_field(change, field: str) -> None:
    data = _data()
    change(data)
    with pytest.raises(GraphError, match=rf"case 7: {re.escape(field)}"):
        LandmarkGraph.from_data(data, "case 7")


def test_bad_graph_constructor_names_the_field() -> None:
    good = _data()
    delta, alpha = np.array(good["delta"]), np.array(good["alpha"])
    ids = tuple(good["landmarks"])
    with pytest.raises(GraphError, match="g: landmarks"):
        LandmarkGraph(("l0",), (), np.zeros((1, 1, 3)), np.zeros((1, 1, 3)), "g")
    with pytest.raises(GraphError, match="g: obstacles"):
        LandmarkGraph(ids, {(0, 5)}, delta, alpha, "g")
    disorder = delta.copy()
    disorder[2, 1] = [1.0, 0.5, 2.0]
    with pytest.raises(GraphError, match=r"g: delta\[2\]\[1\]"):
        LandmarkGraph(ids, (), disorder, alpha, "g")
    nan = alpha.copy()
    nan[0, 2, 2] = math.nan
    with pytest.raises(GraphError, match=r"g: alpha\[0\]\[2\]"):
        LandmarkGraph(ids, (), delta, nan, "g")
    with pytest.raises(GraphError, match="g: obstacles: 'l9'"):
        LandmarkGraph.from_points(ids, np.ones((3, 2)) * [[0], [1], [2]], np.full(3, 0.1),
                                  [("l0", "l9")], "g")
    with pytest.raises(GraphError, match="g: landmarks"):
        LandmarkGraph.from_points(ids, np.full((3, 2), math.nan), np.full(3, 0.1), (), "g")
    assert issubclass(GraphError, CbrError)


def test_bad_options_and_thresholds() -> None:
    with pytest.raises(ValueError, match="normalise"):
        SimilarityOptions(normalise="mean")
    with pytest.raises(ValueError, match="constraint"):
        SimilarityOptions(constraint="all")
    graph = _graph([(0, 0), (1, 0), (0, 2)])
    for bad in (-0.1, math.nan, math.inf):
        with pytest.raises(ValueError, match="threshold"):
            case_similarity(graph, graph, threshold=bad)
        with pytest.raises(ValueError, match="threshold"):
            SituationIndex.build([graph]).search(graph, bad)
    with pytest.raises(ValueError, match="limit"):
        SituationIndex.build([graph]).search(graph, 0.5, limit=-1)


# --------------------------------------------------------------------------------------------
# the branch and bound against the enumeration


def _graph(points: list[tuple[float, float]], uncertainty: float | list[float] = 0.2,
           obstacles: list[tuple[int, int]] = ()) -> LandmarkGraph:
    ids = [f"l{k}" for k in range(len(points))]
    return LandmarkGraph.from_points(ids, np.array(points, dtype=float),
                                     np.broadcast_to(uncertainty, len(points)),
                                     [(ids[u], ids[v]) for u, v in obstacles])


@st.composite
def graphs(draw: st.DrawFn, most: int = 6) -> LandmarkGraph:
    n = draw(st.integers(2, most))
    points = draw(st.lists(st.tuples(st.floats(-3, 3), st.floats(-3, 3)), min_size=n,
                           max_size=n))
    uncertainty = draw(st.lists(st.floats(0.02, 0.8), min_size=n, max_size=n))
    pairs = [(u, v) for u in range(n) for v in range(u + 1, n)]
    obstacles = draw(st.lists(st.sampled_from(pairs), max_size=3, unique=True))
    return _graph(points, uncertainty, obstacles)


@st.composite
def graph_pairs(draw: st.DrawFn) -> tuple[LandmarkGraph, LandmarkGraph]:
    a = draw(graphs())
    choice = draw(st.sampled_from(["any", "near", "equal"]))
    if choice == "any":
        return a, draw(graphs())
    if choice == "equal":
        # paper matching compares equal counts only
        return a, draw(graphs().filter(lambda b: b.n == a.n))
    # a near copy of a, some landmarks dropped or added, so that high similarities (and
    # their pruning) are exercised
    seed = draw(st.integers(0, 2 ** 16))
    return a, _near(a, np.random.default_rng(seed))


def _near(graph: LandmarkGraph, rng: np.random.Generator) -> LandmarkGraph:
    delta = graph.delta + rng.normal(0.0, 0.05, graph.delta.shape[:2])[..., None]
    alpha = graph.alpha + rng.normal(0.0, 0.03, graph.alpha.shape[:2])[..., None]
    delta = np.maximum(delta, 0.0)
    keep = sorted(rng.choice(graph.n, max(2, graph.n - int(rng.integers(0, 2))), replace=False))
    order = rng.permutation(len(keep))
    keep = [keep[k] for k in order]
    index = np.ix_(keep, keep)
    obstacles = {(min(keep.index(u), keep.index(v)), max(keep.index(u), keep.index(v)))
                 for u, v in graph.obstacles if u in keep and v in keep}
    return LandmarkGraph(tuple(graph.ids[k] for k in keep), obstacles, delta[index],
                         alpha[index])


def _normaliser(a: LandmarkGraph, b: LandmarkGraph, normalise: str) -> int:
    return {"larger": max(a.n, b.n), "case": b.n, "problem": a.n}[normalise] - 1


def _sim(a: LandmarkGraph, b: LandmarkGraph, ra: int, rb: int, i: int, j: int) -> float:
    """002 section 3.1 from the scalar fuzzy overlaps: sim(l_A, l_B) given the references."""
    return 0.5 * (overlap(unchecked(*a.delta[ra, i]), unchecked(*b.delta[rb, j]))
                  + angle_overlap(unchecked(*a.alpha[ra, i]), unchecked(*b.alpha[rb, j])))


def _keeps(a: LandmarkGraph, b: LandmarkGraph, pairs: list[tuple[int, int]],
           constraint: str) -> bool:
    """002 Figure 4 over every two matched pairs: an obstacle between l_i and l_j of A needs
    one between their matches in B ('both': and the other way)."""
    in_a = {frozenset(o) for o in a.obstacles}
    in_b = {frozenset(o) for o in b.obstacles}
    for (i, k), (j, m) in itertools.combinations(pairs, 2):
        seen, stored = frozenset((i, j)) in in_a, frozenset((k, m)) in in_b
        if constraint != "none" and seen and not stored:
            return False
        if constraint == "both" and stored and not seen:
            return False
    return True


def brute_force(a: LandmarkGraph, b: LandmarkGraph, matching: str,
                constraint: str) -> float | None:
    """The best summed similarity (divide by N for the score) over every matching, written
    from 002's formulas independently of the package: every injection of the smaller graph's
    landmarks into the larger's (a bijection when the counts are equal; 'paper' takes equal
    counts only), every matched pair as the reference pair, the sum over the other matched
    pairs; matchings that break the constraint do not count. None when no matching is left."""
    if matching == "paper" and a.n != b.n:
        return None
    small, large = (a, b) if a.n <= b.n else (b, a)
    table = {(ra, rb, i, j): _sim(a, b, ra, rb, i, j)
             for ra in range(a.n) for rb in range(b.n) for i in range(a.n) for j in range(b.n)}
    best = None
    for images in itertools.permutations(range(large.n), small.n):
        pairs = [(u, x) if small is a else (x, u) for u, x in enumerate(images)]
        if not _keeps(a, b, pairs, constraint):
            continue
        for ra, rb in pairs:
            total = sum(table[ra, rb, i, j] for i, j in pairs if i != ra)
            best = total if best is None else max(best, total)
    return best


def _check_matching(a: LandmarkGraph, b: LandmarkGraph, found: Matching,
                    options: SimilarityOptions) -> None:
    """The matching sends ra to rb, matches every landmark of the smaller graph injectively
    (a bijection in paper matching), keeps the constraint and scores what is reported."""
    ra, rb = found.reference
    assert len(found.mapping) == a.n and found.mapping[ra] == rb
    pairs = [(i, j) for i, j in enumerate(found.mapping) if j >= 0]
    images = [j for _, j in pairs]
    assert len(images) == len(set(images)) and all(0 <= j < b.n for j in images)
    assert len(pairs) == min(a.n, b.n)
    if options.matching == "paper":
        assert a.n == b.n
    assert _keeps(a, b, pairs, options.constraint)
    assert allowed(a, b, dict(pairs), options.constraint)
    score = sum(_sim(a, b, ra, rb, i, j) for i, j in pairs if i != ra)
    assert found.similarity == pytest.approx(score / _normaliser(a, b, options.normalise),
                                             abs=1e-9)
    assert 0.0 <= found.similarity <= 1.0


@given(graph_pairs())
@settings(max_examples=60, deadline=None)
def test_branch_and_bound_equals_the_brute_force(pair: tuple[LandmarkGraph, LandmarkGraph]
                                                 ) -> None:
    a, b = pair
    for matching in MATCHING:
        for constraint in CONSTRAINT:
            # the normalisation divides the same best sum, so one enumeration serves the three
            best_sum = brute_force(a, b, matching, constraint)
            exhaustive = exhaustive_similarity(
                a, b, SimilarityOptions(matching=matching, constraint=constraint))
            for normalise in NORMALISE:
                options = SimilarityOptions(matching=matching, normalise=normalise,
                                            constraint=constraint)
                found = case_similarity(a, b, options)
                if best_sum is None:
                    assert found is None and exhaustive is None
                    continue
                expected = best_sum / _normaliser(a, b, normalise)
                assert found is not None and exhaustive is not None
                assert found.similarity == pytest.approx(expected, abs=1e-9)
                assert exhaustive.similarity * _normaliser(a, b, "case") == pytest.approx(
                    best_sum, abs=1e-9)
                assert found.nodes <= exhaustive.nodes
                _check_matching(a, b, found, options)
                # a threshold at the similarity keeps it, one above it finds nothing
                kept = case_similarity(a, b, options,
                                       threshold=max(0.0, found.similarity - 1e-9))
                assert kept is not None
                assert kept.similarity == pytest.approx(found.similarity, abs=1e-9)
                assert case_similarity(a, b, options, threshold=found.similarity + 1e-6) is None


def _random_pair(rng: np.random.Generator, n: int) -> tuple[LandmarkGraph, LandmarkGraph]:
    pairs = [(u, v) for u in range(n) for v in range(u + 1, n)]

    def one() -> LandmarkGraph:
        chosen = rng.choice(len(pairs), int(rng.integers(0, min(3, len(pairs)) + 1)),
                            replace=False)
        return _graph(rng.uniform(-3, 3, (n, 2)).tolist(), rng.uniform(0.05, 0.6, n).tolist(),
                      [pairs[k] for k in chosen])
    return one(), one()


def test_no_valid_matching_scores_nothing() -> None:
    # equal counts drawn at random, obstacles included: where the constraint breaks every
    # bijection (002 Figure 4 read strictly) there is no similarity in either matching, and
    # the index finds nothing, at any threshold
    rng = np.random.default_rng(5)
    none = 0
    for draw in range(150):
        a, b = _random_pair(rng, int(rng.integers(2, 7)))
        if brute_force(a, b, "paper", "problem") is not None:
            continue
        none += 1
        for matching in MATCHING:
            options = SimilarityOptions(matching=matching)
            assert case_similarity(a, b, options) is None, draw
            assert exhaustive_similarity(a, b, options) is None
            assert SituationIndex.build([b]).search(a, 0.0, options) == []
    assert none >= 10  # such pairs are common: 002's constraint rules many out


def test_paper_matching_needs_equal_counts() -> None:
    a = _graph([(0, 0), (1, 0), (0, 2)], 0.3)
    b = _graph([(0, 0), (1, 0), (0, 2), (2, 2)], 0.3)
    paper = SimilarityOptions(matching="paper")
    assert case_similarity(a, b, paper) is None and case_similarity(b, a, paper) is None
    assert SituationIndex.build([b]).search(a, 0.0, paper) == []
    assert case_similarity(a, a, paper).similarity == 1.0


def test_extra_landmarks_in_view_cost_nothing() -> None:
    # the case is the view's first three landmarks: by the case's count the view holds it
    # whole; by the larger count one extra landmark caps it at 2/3
    view = _graph([(0, 0), (1, 0), (0, 2), (2, 2)], 0.3, [(0, 1)])
    case = _graph([(0, 0), (1, 0), (0, 2)], 0.3, [(0, 1)])
    found = case_similarity(view, case)
    assert found is not None and found.similarity == 1.0
    assert found.mapping == (0, 1, 2, -1)
    assert case_similarity(view, case, SimilarityOptions(normalise="larger")
                           ).similarity == pytest.approx(2 / 3)
    # the case's landmarks missing from view count 0
    assert case_similarity(case, view).similarity == pytest.approx(2 / 3)


def test_the_constraint_is_hard_for_matched_pairs() -> None:
    # a 5-landmark view whose obstacle l0-l1 the case has between l2 and l3 instead: leaving
    # l1 out of the identity would have lost only a quarter of the score; now every landmark
    # is matched and the obstacle must land on l2-l3
    places = [(0, 0), (1, 0), (0, 2), (2, 2), (-1, 1)]
    view = _graph(places, 0.1, [(0, 1)])
    case = _graph(places, 0.1, [(2, 3)])
    assert case_similarity(view, case, SimilarityOptions(constraint="none")).similarity == 1.0
    held = case_similarity(view, case)
    best = brute_force(view, case, "partial", "problem")
    assert held is not None and held.similarity == pytest.approx(best / 4)
    assert {held.mapping[0], held.mapping[1]} == {2, 3}
    assert held.similarity < 0.75
    # a sixth landmark in view beyond the case's count may be the one left out, obstacle and all
    wider = _graph([*places, (3, 0)], 0.1, [(2, 3), (4, 5)])
    found = case_similarity(wider, case)
    assert found is not None and found.similarity == 1.0 and found.mapping[5] == -1


def test_counts_the_enumerated_matchings() -> None:
    # 3 and 4 landmarks: for each of the 12 reference pairs, the injections of the other 2
    # landmarks into the other 3: 3 * 2
    a = _graph([(0, 0), (1, 0), (0, 2)])
    b = _graph([(0, 0), (1, 0), (0, 2), (2, 2)])
    assert exhaustive_similarity(a, b).nodes == 12 * 6
    # 4 into 3: each reference pair matches 2 of the other 3 into the other 2: 3 * 2
    assert exhaustive_similarity(b, a).nodes == 12 * 6


# --------------------------------------------------------------------------------------------
# 002's constraint and the identity


def test_figure_4_an_obstacle_must_match_an_obstacle() -> None:
    # A: l0, l1, l2 with an obstacle between l1 and l2; B: the same places, no obstacle
    places = [(0.0, 0.0), (2.0, 1.0), (2.0, -1.0)]
    a = _graph(places, 0.1, [(1, 2)])
    b = _graph(places, 0.1)
    free = case_similarity(a, b, SimilarityOptions(constraint="none"))
    assert free is not None and free.similarity == 1.0
    assert free.mapping == (0, 1, 2)
    # every bijection maps l1, l2 onto two landmarks of B, none joined: no matching at all
    for matching in MATCHING:
        for constraint in ("problem", "both"):
            options = SimilarityOptions(matching=matching, constraint=constraint)
            assert case_similarity(a, b, options) is None
            assert exhaustive_similarity(a, b, options) is None
    # "problem" constrains only A's obstacles: B's obstacle with none in A is allowed
    assert case_similarity(b, a, SimilarityOptions(constraint="problem")).similarity == 1.0
    assert case_similarity(b, a, SimilarityOptions(constraint="both")) is None
    # with a fourth landmark in view beyond the case's count, l1 or l2 may be left out
    c = _graph([*places, (4.0, 0.0)], 0.1, [(1, 2)])
    found = case_similarity(c, b)
    assert found is not None and 0.0 < found.similarity < 1.0
    assert -1 in found.mapping[1:3]


@given(graphs(most=8))
@settings(max_examples=60, deadline=None)
def test_a_graph_matches_itself_with_the_identity(graph: LandmarkGraph) -> None:
    for options in MODES:
        found = case_similarity(graph, graph, options)
        assert found is not None and found.similarity == 1.0
        ra, rb = found.reference
        assert ra == rb
        assert found.mapping == tuple(range(graph.n))


# --------------------------------------------------------------------------------------------
# the index


def _random_query(rng: np.random.Generator, n: int) -> LandmarkGraph:
    """``n`` landmarks drawn in a 6 m square, each with its own uncertainty."""
    return _graph(rng.uniform(-3, 3, (n, 2)).tolist(), rng.uniform(0.05, 0.6, n).tolist())


def _store(rng: np.random.Generator, query: LandmarkGraph) -> list[LandmarkGraph]:
    """Random graphs of 2 to 5 landmarks and near copies of ``query``."""
    stored = []
    for k in range(24):
        if k % 3 == 0:
            stored.append(_near(query, rng))
        else:
            n = int(rng.integers(2, 6))
            pairs = [(u, v) for u in range(n) for v in range(u + 1, n) if rng.random() < 0.3]
            stored.append(_graph(rng.uniform(-3, 3, (n, 2)).tolist(),
                                 rng.uniform(0.05, 0.6, n).tolist(), pairs))
    return stored


@pytest.mark.parametrize("threshold", [0.3, 0.8])
@pytest.mark.parametrize("prefilter", [True, False])
@pytest.mark.parametrize("matching", MATCHING)
def test_search_equals_the_brute_force(threshold: float, prefilter: bool, matching: str
                                       ) -> None:
    rng = np.random.default_rng(11)
    for trial in range(3):
        query = _graph(rng.uniform(-3, 3, (4, 2)).tolist(), rng.uniform(0.1, 0.5, 4).tolist(),
                       [(0, 1)] if trial else [])
        stored = _store(rng, query)
        index = SituationIndex.build(stored)
        assert len(index) == len(stored)
        options = SimilarityOptions(matching=matching, prefilter=prefilter)
        expected = []
        for row, graph in enumerate(stored):
            best = brute_force(query, graph, matching, options.constraint)
            if best is not None and best / _normaliser(query, graph, "case") >= threshold:
                expected.append((row, best / _normaliser(query, graph, "case")))
        expected.sort(key=lambda hit: (-hit[1], hit[0]))
        found = index.search(query, threshold, options)
        assert [f.row for f in found] == [row for row, _ in expected]
        for f, (_, similarity) in zip(found, expected, strict=True):
            assert f.matching.similarity == pytest.approx(similarity, abs=1e-9)
            _check_matching(query, stored[f.row], f.matching, options)
        assert threshold == 0.3 or expected  # the near copies are found at 0.8
        assert index.search(query, threshold, options, limit=2) == found[:2]
        assert index.search(query, threshold, options, limit=0) == []


@given(st.integers(0, 2 ** 16), st.floats(0.5, 1.0), st.sampled_from(MODES),
       st.integers(2, 8))
@settings(max_examples=60, deadline=None)
def test_the_prefilter_changes_nothing(seed: int, threshold: float,
                                       options: SimilarityOptions, n: int) -> None:
    rng = np.random.default_rng(seed)
    query = _random_query(rng, n)
    # near copies score near 1, where the cuts are narrow
    index = SituationIndex.build(_store(rng, query) + [_near(query, rng) for _ in range(4)])
    with_it = index.search(query, threshold, options)
    without = index.search(query, threshold, attrs.evolve(options, prefilter=False))
    assert [f.row for f in with_it] == [f.row for f in without]
    for x, y in zip(with_it, without, strict=True):
        assert x.matching.similarity == pytest.approx(y.matching.similarity, abs=1e-12)


@given(st.integers(0, 2 ** 16), st.sampled_from([0.6, 0.75, 0.8, 0.9]),
       st.sampled_from(MODES), st.integers(1, 4), st.integers(2, 6))
@settings(max_examples=40, deadline=None)
def test_the_best_few_are_the_first_of_all(seed: int, threshold: float,
                                           options: SimilarityOptions, limit: int,
                                           n: int) -> None:
    # a search for the best few looks at stricter thresholds first: exact copies of the query
    # reach them, near copies may not
    rng = np.random.default_rng(seed)
    query = _random_query(rng, n)
    stored = _store(rng, query) + [query] * int(rng.integers(0, 4))
    index = SituationIndex.build(stored)
    every = index.search(query, threshold, options)
    best = index.search(query, threshold, options, limit=limit)
    assert [f.row for f in best] == [f.row for f in every[:limit]]
    for x, y in zip(best, every, strict=False):
        assert x.matching.similarity == pytest.approx(y.matching.similarity, abs=1e-12)
        _check_matching(query, stored[x.row], x.matching, options)


def test_the_best_few_across_landmark_counts() -> None:
    # the smallest stored graphs are searched first: exact copies of pairs of the query
    # score 1 there, and whole copies of the query, searched after them, tie with them; the
    # best are the lowest rows of either count
    rng = np.random.default_rng(5)
    query = _graph(rng.uniform(-3, 3, (4, 2)).tolist(), rng.uniform(0.1, 0.4, 4).tolist())
    stored = [_near(query, rng) for _ in range(12)]
    stored += [_graph(rng.uniform(-3, 3, (2, 2)).tolist(), 0.3) for _ in range(6)]
    pairs = [query.subgraph([0, 2]), query.subgraph([3, 1]), query.subgraph([1, 2])]
    for row, graph in ((4, query), (7, pairs[0]), (9, query), (13, pairs[1]),
                       (16, pairs[2])):
        stored.insert(row, graph)
    index = SituationIndex.build(stored)
    options = SimilarityOptions()
    every = index.search(query, 0.8, attrs.evolve(options, prefilter=False))
    assert [f.row for f in every[:5]] == [4, 7, 9, 13, 16]
    assert {f.matching.similarity for f in every[:5]} == {1.0}
    for limit in range(1, 8):
        best = index.search(query, 0.8, options, limit=limit)
        assert [(f.row, f.matching.similarity) for f in best] == [
            (f.row, f.matching.similarity) for f in every[:limit]]


@given(st.integers(0, 2 ** 16), st.floats(0.55, 1.0), st.sampled_from(MODES),
       st.integers(2, 8))
@settings(max_examples=40, deadline=None)
def test_both_pair_layouts_give_the_same_candidates(seed: int, threshold: float,
                                                    options: SimilarityOptions, n: int) -> None:
    # the prefilter goes through the stored pairs of all counts together or count by count
    # (index.TOGETHER): the reference pairs it hands on, and their bounds, are the same
    rng = np.random.default_rng(seed)
    query = _random_query(rng, n)
    index = SituationIndex.build(_store(rng, query) + [_near(query, rng) for _ in range(4)])
    flat = flattened(query)
    found = []
    for share in (0.0, 2.0):
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(index_module, "TOGETHER", share)
            classes = index_module._classes(n, threshold, options)
            found.append(index._candidates(flat, n, threshold, options, classes))
    (rows, references, bounds, _), (rows2, references2, bounds2, _) = found
    np.testing.assert_array_equal(rows, rows2)
    np.testing.assert_array_equal(references, references2)
    np.testing.assert_allclose(bounds, bounds2, rtol=0, atol=1e-12)


def test_stricter_thresholds() -> None:
    assert raised(0.8) == pytest.approx([0.98, 0.95])
    assert raised(0.5) == [] and raised(1.0) == []


@pytest.mark.parametrize("threshold", [0.51, 0.6, 0.75, 0.8, 0.9, 1.0])
def test_prefilter_level_stays_under_the_bound(threshold: float) -> None:
    # sigma = (1 + level) / 2 must stay under the threshold for the bound to rule anything out
    level = prefilter_level(threshold)
    assert 0.0 <= level < 2 * threshold - 1


def test_empty_index_and_unreachable_threshold() -> None:
    graph = _graph([(0, 0), (1, 0), (0, 2)])
    assert SituationIndex.build([]).search(graph, 0.8) == []
    assert len(SituationIndex.build([])) == 0
    index = SituationIndex.build([graph, _graph([(0, 0), (3, 1)])])
    assert index.search(graph, 1.5) == []
    exact = index.search(graph, 1.0)
    assert [f.row for f in exact] == [0] and exact[0].matching.similarity == 1.0
