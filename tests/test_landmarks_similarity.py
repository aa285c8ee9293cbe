"""The similarity of landmark graphs (cbr_landmarks.similarity) and its retrieval index
(cbr_landmarks.index): fuzzy overlaps against triangles worked by hand, the branch and bound
against the enumeration of every matching, 002's obstacle constraint (Figure 4), and the index's
search (with and without its prefilter) against the enumeration over a list of graphs."""

from __future__ import annotations

import math
import re

import attrs
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_landmarks.graph import GraphError, LandmarkGraph
from cbr_landmarks.index import SituationIndex, prefilter_level
from cbr_landmarks.kernels import height
from cbr_landmarks.similarity import (
    CONSTRAINT,
    NORMALISE,
    Matching,
    SimilarityOptions,
    allowed,
    case_similarity,
    exhaustive_similarity,
    landmark_similarities,
)
from cbr_world2d.fuzzy import Triangle, angle_overlap, overlap, overlap_arrays
from cbrcore.errors import CbrError

MODES = [SimilarityOptions(normalise=n, constraint=c) for n in NORMALISE for c in CONSTRAINT]
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
    if draw(st.booleans()):
        return a, draw(graphs())
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


def _check_matching(a: LandmarkGraph, b: LandmarkGraph, found: Matching,
                    options: SimilarityOptions) -> None:
    """The matching is a partial injection sending ra to rb, keeps the constraint and scores
    what is reported."""
    ra, rb = found.reference
    assert len(found.mapping) == a.n and found.mapping[ra] == rb
    images = [j for j in found.mapping if j >= 0]
    assert len(images) == len(set(images)) and all(0 <= j < b.n for j in images)
    mapping = {i: j for i, j in enumerate(found.mapping) if j >= 0}
    assert allowed(a, b, mapping, options.constraint)
    similar = landmark_similarities(a, b, ra, rb)
    n = _normaliser(a, b, options.normalise)
    score = sum(similar[i, j] for i, j in mapping.items() if i != ra) / n
    assert found.similarity == pytest.approx(score, abs=1e-9)
    assert 0.0 <= found.similarity <= 1.0


def _normaliser(a: LandmarkGraph, b: LandmarkGraph, normalise: str) -> int:
    return {"larger": max(a.n, b.n), "case": b.n, "problem": a.n}[normalise] - 1


@given(graph_pairs())
@settings(max_examples=50, deadline=None)
def test_branch_and_bound_equals_the_enumeration(pair: tuple[LandmarkGraph, LandmarkGraph]
                                                 ) -> None:
    a, b = pair
    for constraint in CONSTRAINT:
        # the normalisation divides the same best sum (test_normalisations_divide_the_sum), so
        # one enumeration per constraint serves the three
        exhaustive = exhaustive_similarity(a, b, SimilarityOptions(constraint=constraint))
        best_sum = exhaustive.similarity * _normaliser(a, b, "larger")
        _check_matching(a, b, exhaustive, SimilarityOptions(constraint=constraint))
        for normalise in NORMALISE:
            options = SimilarityOptions(normalise=normalise, constraint=constraint)
            found = case_similarity(a, b, options)
            assert found is not None
            assert found.similarity == pytest.approx(best_sum / _normaliser(a, b, normalise),
                                                     abs=1e-9)
            assert found.nodes <= exhaustive.nodes
            _check_matching(a, b, found, options)
            # a threshold at the similarity keeps it, one above it finds nothing
            kept = case_similarity(a, b, options, threshold=max(0.0, found.similarity - 1e-9))
            assert kept is not None
            assert kept.similarity == pytest.approx(found.similarity, abs=1e-9)
            assert case_similarity(a, b, options, threshold=found.similarity + 1e-6) is None


def test_normalisations_divide_the_sum() -> None:
    # unequal counts: the best sum over the larger count, the case's or the problem's less one
    a = _graph([(0, 0), (1, 0), (0, 2)], 0.3)
    b = _graph([(0, 0), (1.1, 0), (0, 2.1), (2, 2), (-1, 1)], 0.3)
    sums = {}
    for options in MODES:
        for x, y in ((a, b), (b, a)):
            found = exhaustive_similarity(x, y, options)
            _check_matching(x, y, found, options)
            sums.setdefault((options.constraint, x.n), set()).add(
                round(found.similarity * _normaliser(x, y, options.normalise), 9))
    assert all(len(values) == 1 for values in sums.values())
    # with equal counts every normalisation is 002's mean over the n - 1 landmarks
    c = _near(a, np.random.default_rng(3))
    if c.n == a.n:
        values = {exhaustive_similarity(a, c, SimilarityOptions(normalise=n)).similarity
                  for n in NORMALISE}
        assert len(values) == 1


def test_counts_the_enumerated_matchings() -> None:
    # 3 and 4 landmarks: for each of the 12 reference pairs, partial injections of 2 landmarks
    # into 3: 1 + 2 * 3 + 3 * 2 = 13
    a = _graph([(0, 0), (1, 0), (0, 2)])
    b = _graph([(0, 0), (1, 0), (0, 2), (2, 2)])
    assert exhaustive_similarity(a, b).nodes == 12 * 13


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
    for constraint in ("problem", "both"):
        held = case_similarity(a, b, SimilarityOptions(constraint=constraint))
        assert held is not None and held.similarity < 1.0
        assert not (held.mapping[1] == 1 and held.mapping[2] == 2)
        assert held.similarity == pytest.approx(
            exhaustive_similarity(a, b, SimilarityOptions(constraint=constraint)).similarity)
    # "problem" constrains only A's obstacles: B's obstacle with none in A is allowed
    assert case_similarity(b, a, SimilarityOptions(constraint="problem")).similarity == 1.0
    assert case_similarity(b, a, SimilarityOptions(constraint="both")).similarity < 1.0


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
def test_search_equals_the_enumeration(threshold: float, prefilter: bool) -> None:
    rng = np.random.default_rng(11)
    for trial in range(3):
        query = _graph(rng.uniform(-3, 3, (4, 2)).tolist(), rng.uniform(0.1, 0.5, 4).tolist(),
                       [(0, 1)] if trial else [])
        stored = _store(rng, query)
        index = SituationIndex.build(stored)
        assert len(index) == len(stored)
        options = SimilarityOptions(prefilter=prefilter)
        expected = []
        for row, graph in enumerate(stored):
            similarity = exhaustive_similarity(query, graph, options).similarity
            if similarity >= threshold:
                expected.append((row, similarity))
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
    query = _graph(rng.uniform(-3, 3, (n, 2)).tolist(), rng.uniform(0.05, 0.6, n).tolist())
    index = SituationIndex.build(_store(rng, query))
    with_it = index.search(query, threshold, options)
    without = index.search(query, threshold, attrs.evolve(options, prefilter=False))
    assert [f.row for f in with_it] == [f.row for f in without]
    for x, y in zip(with_it, without, strict=True):
        assert x.matching.similarity == pytest.approx(y.matching.similarity, abs=1e-12)


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
