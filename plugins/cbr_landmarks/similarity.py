"""How similar a stored case is to the current situation: 002 sections 3.1 and 3.2.

The current situation ``A`` (the problem) and a stored case ``B`` are landmark graphs
(:class:`~cbr_landmarks.graph.LandmarkGraph`). Given a reference landmark ``ra`` of ``A`` and
``rb`` of ``B``, two other landmarks ``i`` of ``A`` and ``j`` of ``B`` are as similar as their
places seen from the references (002 section 3.1)::

    sim(i, j | ra, rb) = (overlap(deltaA[ra, i], deltaB[rb, j])
                          + angle_overlap(alphaA[ra, i], alphaB[rb, j])) / 2

with the fuzzy overlaps of :mod:`cbr_world2d.fuzzy`. A matching maps ``ra`` to ``rb`` and
every other landmark of the smaller graph injectively to one of the larger (any when the counts
are equal), so that ``min(n_A, n_B) - 1`` landmarks are matched besides the references: with
``matching: paper`` the counts must be equal and the matching is a bijection (002 section 3.2);
with ``partial`` (the default) a view with more landmarks than the case is matched by its best
sub-situation of the case's size. A matching's score is the sum of its matched landmarks'
similarities over ``N`` (:class:`SimilarityOptions`' ``normalise``: the case's count less one
by default, so that landmarks in view beyond the case's cost nothing; with equal counts every
choice is 002's mean over the ``n - 1`` landmarks besides the reference). The obstacle
constraint of 002 (Figure 4) is hard: a matching that sends an obstacle of ``A`` between two
matched landmarks onto a pair of ``B`` without one is not a matching at all. The similarity of
the two graphs is the best score over every reference pair and matching; two graphs with no
matching (unequal counts in ``paper``, or the constraint broken by every one) have none.

:func:`case_similarity` finds it with 002's branch and bound in a numba kernel
(:mod:`cbr_landmarks.kernels`, compiled when first used);
:func:`exhaustive_similarity` enumerates every matching in plain Python, as the reference the
kernel is tested against.
"""

from __future__ import annotations

import itertools
import math
from typing import Literal

import attrs
import numpy as np

from cbr_landmarks.graph import LandmarkGraph
from cbr_world2d.fuzzy import overlap_arrays
from cbrcore.options import option

MATCHING = ("partial", "paper")
NORMALISE = ("larger", "case", "problem")
CONSTRAINT = ("problem", "both", "none")


@attrs.frozen
class SimilarityOptions:
    """How two landmark graphs are compared."""

    matching: Literal["partial", "paper"] = option(
        "partial", "Which landmark matchings count: 'paper', 002's, equal landmark counts and "
        "bijections; 'partial', every landmark of the smaller graph matched to one of the "
        "larger (a view with more landmarks than the case is matched by its best "
        "sub-situation of the case's size). Either way the obstacle constraint holds for every "
        "matched pair, and graphs with no matching have no similarity.",
        validator=attrs.validators.in_(MATCHING))
    normalise: Literal["larger", "case", "problem"] = option(
        "case", "What the summed similarity of the matched landmarks is divided by: 'case', "
        "the stored case's landmark count less one (landmarks in view beyond the case's cost "
        "nothing, those of the case not in view count 0); 'larger', the larger count less "
        "one; 'problem', the current situation's count less one. With equal counts all are "
        "002's mean over the landmarks besides the reference.",
        validator=attrs.validators.in_(NORMALISE))
    constraint: Literal["problem", "both", "none"] = option(
        "problem", "The obstacle constraint (002 Figure 4): 'problem', every obstacle of the "
        "current situation between two matched landmarks must match an obstacle of the case; "
        "'both', and every obstacle of the case between two matched landmarks must match one "
        "of the situation; 'none', obstacles are not compared.",
        validator=attrs.validators.in_(CONSTRAINT))
    prefilter: bool = option(
        True, "Let the retrieval index skip, before the branch and bound, the cases that "
        "cannot reach a threshold over 1/2 (exact: the same cases are found either way).",
        validator=attrs.validators.instance_of(bool))


@attrs.frozen
class Matching:
    """The best matching found between the current situation ``A`` and a case ``B``."""

    similarity: float
    reference: tuple[int, int]
    """The reference landmarks ``(ra, rb)``, indices into ``A`` and ``B``."""
    mapping: tuple[int, ...]
    """For each landmark of ``A``, the index of its match in ``B`` or -1 (left out, as one
    beyond ``B``'s count); ``mapping[ra] == rb``."""
    nodes: int
    """Search nodes expanded: partial matchings of the branch and bound, or the complete
    matchings :func:`exhaustive_similarity` enumerated."""


def normaliser(n_a: int, n_b: int, normalise: str) -> int:
    """The ``N`` a matching's summed similarity is divided by."""
    if normalise == "case":
        return n_b - 1
    if normalise == "problem":
        return n_a - 1
    return max(n_a, n_b) - 1


def landmark_similarities(a: LandmarkGraph, b: LandmarkGraph, ra: int, rb: int) -> np.ndarray:
    """``sim(i, j | ra, rb)`` for every landmark ``i`` of ``a`` and ``j`` of ``b``, ``(n_A,
    n_B)``; row ``ra`` and column ``rb`` hold 0 (the references are matched to each other)."""
    delta = overlap_arrays(a.delta[ra][:, None, :], b.delta[rb][None, :, :])
    alpha = overlap_arrays(a.alpha[ra][:, None, :], b.alpha[rb][None, :, :], angular=True)
    similar = 0.5 * (delta + alpha)
    similar[ra, :] = 0.0
    similar[:, rb] = 0.0
    return similar


# --------------------------------------------------------------------------------------------
# the exhaustive reference


def allowed(a: LandmarkGraph, b: LandmarkGraph, mapping: dict[int, int], constraint: str) -> bool:
    """Whether ``mapping`` (landmarks of ``a`` to landmarks of ``b``, the reference pair
    included) keeps the obstacle ``constraint`` (:class:`SimilarityOptions`)."""
    if constraint == "none":
        return True
    for u, v in a.obstacles:
        if u in mapping and v in mapping:
            x, y = mapping[u], mapping[v]
            if (min(x, y), max(x, y)) not in b.obstacles:
                return False
    if constraint == "both":
        inverse = {x: u for u, x in mapping.items()}
        for x, y in b.obstacles:
            if x in inverse and y in inverse:
                u, v = inverse[x], inverse[y]
                if (min(u, v), max(u, v)) not in a.obstacles:
                    return False
    return True


def exhaustive_similarity(a: LandmarkGraph, b: LandmarkGraph,
                          options: SimilarityOptions = SimilarityOptions()) -> Matching | None:
    """The similarity of case ``b`` to the situation ``a`` found by enumerating every
    reference pair and every matching of ``options.matching``: the reference
    :func:`case_similarity` is tested against (the matchings grow factorially with the
    landmarks); None when there is no matching. ``nodes`` counts the matchings enumerated.
    Ties keep the first found: reference pairs in row order, then itertools' order."""
    if options.matching == "paper" and a.n != b.n:
        return None
    n = normaliser(a.n, b.n, options.normalise)
    k = min(a.n, b.n) - 1
    best = -1.0
    found: tuple[tuple[int, int], dict[int, int]] = ((0, 0), {})
    enumerated = 0
    for ra, rb in itertools.product(range(a.n), range(b.n)):
        similar = landmark_similarities(a, b, ra, rb).tolist()
        others_a = [i for i in range(a.n) if i != ra]
        others_b = [j for j in range(b.n) if j != rb]
        for chosen in itertools.combinations(others_a, k):
            for images in itertools.permutations(others_b, k):
                enumerated += 1
                score = sum(similar[i][j] for i, j in zip(chosen, images, strict=True)) / n
                # the constraint only matters for a matching that would be the best
                if score <= best:
                    continue
                mapping = dict(zip(chosen, images, strict=True))
                mapping[ra] = rb
                if allowed(a, b, mapping, options.constraint):
                    best, found = score, ((ra, rb), mapping)
    if best < 0.0:
        return None
    reference, mapping = found
    return Matching(best, reference, tuple(mapping.get(i, -1) for i in range(a.n)), enumerated)


def flattened(graph: LandmarkGraph) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A graph as the kernels read it: ``delta`` and ``alpha`` ``(n * n, 3)`` and the
    adjacency as int64 bitmasks."""
    n = graph.n
    return (np.ascontiguousarray(graph.delta.reshape(n * n, 3)),
            np.ascontiguousarray(graph.alpha.reshape(n * n, 3)),
            graph.adjacency().astype(np.int64))


def check_threshold(threshold: float) -> float:
    """``threshold`` as a float; ValueError unless it is a finite number >= 0."""
    threshold = float(threshold)
    if not (math.isfinite(threshold) and threshold >= 0.0):
        raise ValueError(f"a similarity threshold is a number >= 0, got {threshold!r}")
    return threshold


def case_similarity(a: LandmarkGraph, b: LandmarkGraph,
                    options: SimilarityOptions = SimilarityOptions(),
                    threshold: float = 0.0) -> Matching | None:
    """The similarity of case ``b`` to the situation ``a`` and the best matching, by 002's
    branch and bound; None when no matching reaches ``threshold`` (or there is none)."""
    from cbr_landmarks.kernels import match_rows

    threshold = check_threshold(threshold)
    da, aa, adj_a = flattened(a)
    db, ab, adj_b = flattened(b)
    one = np.zeros(1, dtype=np.int64)
    similarity = np.empty(1)
    reference = np.empty((1, 2), dtype=np.int64)
    mapping = np.full((1, a.n), -1, dtype=np.int64)
    nodes = np.empty(1, dtype=np.int64)
    match_rows(da, aa, adj_a, a.n, one, np.ones((1, a.n, b.n), dtype=np.bool_),
               np.ones(1), 0, np.array([b.n]), one, one, db, ab, adj_b,
               MATCHING.index(options.matching), NORMALISE.index(options.normalise),
               CONSTRAINT.index(options.constraint),
               threshold, similarity, reference, mapping, nodes)
    if similarity[0] < 0.0:
        return None
    return Matching(float(similarity[0]), (int(reference[0, 0]), int(reference[0, 1])),
                    tuple(mapping[0].tolist()), int(nodes[0]))
