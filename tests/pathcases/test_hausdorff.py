"""Hausdorff distances between paths: hand-worked values, a brute-force reference, scipy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.distance import directed_hausdorff

from cbr_pathcases.hausdorff import METRICS, hausdorff

SQRT2 = math.sqrt(2.0)


def brute(a: np.ndarray, b: np.ndarray, distance: str) -> float:
    """D(a, b) from the full matrix of cell distances, each metric written from its definition."""
    diff = np.abs(a[:, None, :] - b[None, :, :]).astype(np.float64)
    dx, dy = diff[..., 0], diff[..., 1]
    matrix = {
        "euclidean": np.hypot(dx, dy),
        "manhattan": dx + dy,
        "octile": (SQRT2 - 1.0) * np.minimum(dx, dy) + np.maximum(dx, dy),
        "chebyshev": np.maximum(dx, dy),
    }[distance]
    return float(matrix.min(axis=1).max())


def stack(paths: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The stored-path layout: cells concatenated and the (k + 1,) offsets."""
    offsets = np.concatenate([[0], np.cumsum([len(p) for p in paths])]).astype(np.int64)
    cells = np.concatenate(paths) if paths else np.empty((0, 2), dtype=np.int64)
    return cells, offsets


def one(a: list[tuple[int, int]], b: list[tuple[int, int]], distance: str) -> tuple[float, float]:
    """(D(a, b), D(b, a)) through :func:`hausdorff` with b the only stored path."""
    forward, backward = hausdorff(np.array(a), np.array(b), [0, len(b)], distance=distance)
    return float(forward[0]), float(backward[0])


# Paths of random, not necessarily adjacent cells in a small area, so that cells repeat and tie.
cell = st.tuples(st.integers(-12, 12), st.integers(-12, 12))
paths = st.lists(cell, min_size=1, max_size=25).map(lambda c: np.array(c, dtype=np.int64))
metrics = st.sampled_from(sorted(METRICS))


P1 = [(0, 0), (1, 0), (2, 0)]
P2 = [(0, 1), (1, 1), (2, 1), (3, 1)]


@pytest.mark.parametrize(("distance", "back"), [
    ("euclidean", SQRT2),  # (3, 1) to (2, 0)
    ("manhattan", 2.0),
    ("octile", SQRT2),
    ("chebyshev", 1.0),
])
def test_hand_worked_parallel_paths(distance: str, back: float) -> None:
    """Every cell of P1 has a P2 cell just above it; (3, 1) of P2 is one diagonal step off."""
    assert one(P1, P2, distance) == pytest.approx((1.0, back), rel=1e-12)


@pytest.mark.parametrize(("distance", "back"), [
    ("euclidean", 2 * SQRT2),  # (3, 3) to (1, 1)
    ("manhattan", 4.0),
    ("octile", 2 * SQRT2),
    ("chebyshev", 2.0),
])
def test_sub_path_is_directed(distance: str, back: float) -> None:
    """A sub-path lies on the whole path (0), the whole path's tail does not lie on the sub-path."""
    sub = [(0, 0), (1, 1)]
    whole = [(0, 0), (1, 1), (2, 2), (3, 3)]
    assert one(sub, whole, distance) == pytest.approx((0.0, back), rel=1e-12)


@pytest.mark.parametrize(("distance", "near", "far"), [
    ("euclidean", 3.0, math.sqrt(13.0)),  # (2, 3) to (5, 3) and to (0, 0)
    ("manhattan", 3.0, 5.0),
    ("octile", 3.0, 2 * SQRT2 + 1.0),
    ("chebyshev", 3.0, 3.0),
])
def test_single_cell_path(distance: str, near: float, far: float) -> None:
    """One cell against itself is 0 both ways; against two cells it is their nearest / farthest."""
    forward, backward = hausdorff([(2, 3)], np.array([(2, 3), (0, 0), (5, 3)]), [0, 1, 3],
                                  distance=distance)
    np.testing.assert_allclose(forward, [0.0, near], rtol=1e-12)
    np.testing.assert_allclose(backward, [0.0, far], rtol=1e-12)


@settings(max_examples=60, deadline=None)
@given(path=paths, stored=st.lists(paths, max_size=5), distance=metrics)
def test_matches_brute_force(path: np.ndarray, stored: list[np.ndarray], distance: str) -> None:
    """Both directions against every stored path at once equal the full-matrix reference."""
    forward, backward = hausdorff(path, *stack(stored), distance=distance)
    assert forward.dtype == backward.dtype == np.float64
    assert forward.shape == backward.shape == (len(stored),)
    np.testing.assert_allclose(forward, [brute(path, p, distance) for p in stored], rtol=1e-12)
    np.testing.assert_allclose(backward, [brute(p, path, distance) for p in stored], rtol=1e-12)


def test_no_stored_paths_gives_empty_arrays() -> None:
    forward, backward = hausdorff([(0, 0)], np.empty((0, 2), dtype=np.int64), [0])
    assert forward.shape == backward.shape == (0,)


def test_long_spatially_coherent_paths() -> None:
    """Long grid walks (the case the scan orderings favour) still match the brute force."""
    rng = np.random.default_rng(7)
    steps = rng.integers(-1, 2, size=(6, 300, 2))
    walks = list(np.cumsum(steps, axis=1))
    for distance in METRICS:
        forward, backward = hausdorff(walks[0], *stack(walks[1:]), distance=distance)
        np.testing.assert_allclose(forward, [brute(walks[0], w, distance) for w in walks[1:]],
                                   rtol=1e-12)
        np.testing.assert_allclose(backward, [brute(w, walks[0], distance) for w in walks[1:]],
                                   rtol=1e-12)


@settings(max_examples=60, deadline=None)
@given(path=paths, stored=st.lists(paths, min_size=1, max_size=4))
def test_euclidean_forward_matches_scipy(path: np.ndarray, stored: list[np.ndarray]) -> None:
    forward, _ = hausdorff(path, *stack(stored))
    expected = [directed_hausdorff(path.astype(float), p.astype(float))[0] for p in stored]
    np.testing.assert_allclose(forward, expected, rtol=1e-12)


@settings(max_examples=60, deadline=None)
@given(path=paths, stored=st.lists(paths, min_size=1, max_size=5), distance=metrics,
       data=st.data())
def test_limit_keeps_entries_within_it_exact(path: np.ndarray, stored: list[np.ndarray],
                                             distance: str, data: st.DataObject) -> None:
    """Entries up to the limit are exact (also at equality); the others are inf."""
    truth = np.array([[brute(path, p, distance), brute(p, path, distance)] for p in stored])
    limit = data.draw(st.one_of(st.floats(-1.0, 40.0), st.sampled_from(sorted(truth.ravel()))))
    forward, backward = hausdorff(path, *stack(stored), distance=distance, limit=limit)
    got = np.stack([forward, backward], axis=1)
    within = truth <= limit
    np.testing.assert_allclose(got[within], truth[within], rtol=1e-12)
    assert np.isinf(got[~within]).all()


def test_limit_far_apart_and_near_paths() -> None:
    """A path whose bounding box is 10 away is inf both ways under a limit of 5; a near one is
    exact: (0, 0) is 2 from (1, 1), which is 1 from (1, 0)."""
    forward, backward = hausdorff([(0, 0), (1, 0)], np.array([(11, 0), (12, 0), (1, 1)]),
                                  [0, 2, 3], distance="manhattan", limit=5.0)
    np.testing.assert_array_equal(forward, [math.inf, 2.0])
    np.testing.assert_array_equal(backward, [math.inf, 1.0])


GOOD = {"path": [(0, 0)], "cells": np.array([(1, 1), (2, 2)]), "offsets": [0, 1, 2]}


@pytest.mark.parametrize(("change", "message"), [
    ({"distance": "cosine"}, "distance must be one of 'euclidean'"),
    ({"limit": math.nan}, "limit must be a number"),
    ({"path": np.empty((0, 2), dtype=np.int64)}, r"path must be an \(n, 2\) array .* n >= 1"),
    ({"path": [0, 0]}, r"path must be an \(n, 2\) array"),
    ({"path": [(0.5, 0.0)]}, "path must hold integer cells"),
    ({"cells": np.array([(1, 1, 1), (2, 2, 2)])}, r"cells must be an \(n, 2\) array"),
    ({"offsets": [[0, 1, 2]]}, "offsets must be a 1-d integer array"),
    ({"offsets": [0.0, 1.0, 2.0]}, "offsets must be a 1-d integer array"),
    ({"offsets": [1, 2]}, r"offsets must start at 0 and end at len\(cells\) = 2"),
    ({"offsets": [0, 1]}, r"offsets must start at 0 and end at len\(cells\) = 2"),
    ({"offsets": [0, 2, 1, 2]}, "offsets must be non-decreasing"),
    ({"offsets": [0, 1, 1, 2]}, "stored path 1 is empty"),
])
def test_bad_input_raises(change: dict[str, object], message: str) -> None:
    arguments = {**GOOD, **change}
    with pytest.raises(ValueError, match=message):
        hausdorff(arguments.pop("path"), arguments.pop("cells"), arguments.pop("offsets"),
                  **arguments)
