"""The memory-lean building of the landmark bound and of the length maps it is made of.

``Landmarks`` keeps its tables in one float32 array and builds them from shortest path lengths
(``cost_map`` without factors); checked here against a plain Dijkstra over the 8 moves and the
farthest-first choice of landmarks, worked out independently of the compiled kernels.
"""

from __future__ import annotations

import heapq
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cbr_grid.grid import Grid
from cbr_pathquality.ideal import Landmarks
from cbr_solvers.aistar import cost_map

MOVES = [(1, 0, 1.0), (-1, 0, 1.0), (0, 1, 1.0), (0, -1, 1.0),
         (1, 1, math.sqrt(2)), (1, -1, math.sqrt(2)), (-1, 1, math.sqrt(2)),
         (-1, -1, math.sqrt(2))]


def lengths_from(passable: np.ndarray, corner_cutting: bool, source: tuple[int, int]) -> dict:
    """Shortest path lengths {(x, y): length} from ``source`` by a plain Dijkstra: a diagonal
    step needs both cells beside it free, or one of them with corner cutting."""
    h, w = passable.shape
    best = {source: 0.0}
    heap = [(0.0, source)]
    while heap:
        here, (x, y) = heapq.heappop(heap)
        if here > best[(x, y)]:
            continue
        for dx, dy, length in MOVES:
            nx, ny = x + dx, y + dy
            if not (0 <= nx < w and 0 <= ny < h and passable[ny, nx]):
                continue
            if dx and dy:
                beside = int(passable[y, nx]) + int(passable[ny, x])
                if beside < (1 if corner_cutting else 2):
                    continue
            if here + length < best.get((nx, ny), math.inf):
                best[(nx, ny)] = here + length
                heapq.heappush(heap, (here + length, (nx, ny)))
    return best


def as_map(lengths: dict, shape: tuple[int, int]) -> np.ndarray:
    table = np.full(shape, math.inf)
    for (x, y), length in lengths.items():
        table[y, x] = length
    return table


def farthest(nearest: np.ndarray) -> tuple[int, int]:
    """The reachable cell of greatest distance, the first in row-major order on a tie."""
    y, x = np.unravel_index(int(np.argmax(np.where(np.isfinite(nearest), nearest, -1.0))),
                            nearest.shape)
    return int(x), int(y)


maps = st.tuples(st.integers(1, 12), st.integers(1, 12), st.floats(0.0, 0.5),
                 st.integers(0, 2**31 - 1), st.booleans())


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(maps, st.integers(1, 4))
def test_the_tables_are_the_lengths_from_landmarks_chosen_farthest_first(
        spec: tuple[int, int, float, int, bool], count: int) -> None:
    h, w, density, seed, corner_cutting = spec
    rng = np.random.default_rng(seed)
    passable = rng.random((h, w)) >= density
    grid = Grid((~passable).astype(float), corner_cutting=corner_cutting)
    bound = Landmarks(grid, count)
    free = np.argwhere(passable)
    if not len(free):
        assert bound.tables.shape == (0, h, w)
        return
    assert bound.tables.dtype == np.float32
    assert bound.tables.shape == (count, h, w)
    nearest = as_map(lengths_from(passable, corner_cutting,
                                  (int(free[0][1]), int(free[0][0]))), (h, w))
    for k in range(count):
        landmark = farthest(nearest)
        expected = as_map(lengths_from(passable, corner_cutting, landmark), (h, w))
        np.testing.assert_allclose(bound.tables[k], expected, rtol=1e-6)
        # the first cell's lengths only pick the first landmark
        nearest = expected if k == 0 else np.minimum(nearest, expected)
    for _ in range(10):
        (y1, x1), (y2, x2) = free[rng.integers(len(free), size=2)]
        start, goal = (int(x1), int(y1)), (int(x2), int(y2))
        a, b = bound.tables[:, y1, x1].astype(float), bound.tables[:, y2, x2].astype(float)
        both = np.isfinite(a) & np.isfinite(b)
        dx, dy = abs(x1 - x2), abs(y1 - y2)
        octile = max(dx, dy) + (math.sqrt(2) - 1) * min(dx, dy)
        gaps = np.abs(a[both] - b[both])
        expected_bound = max(float(gaps.max(initial=0.0)), octile)
        # the bound takes the float32 rounding (a relative 1e-7 of the lengths) off the gap
        assert bound.bound(start, goal) == pytest.approx(expected_bound, rel=1e-6, abs=1e-5)
        assert bound.bound(start, goal) <= expected_bound + 1e-9


def test_the_tables_of_a_map_without_free_cells_are_empty() -> None:
    bound = Landmarks(Grid(np.ones((3, 5))), 8)
    assert bound.tables.shape == (0, 3, 5)
    assert bound.bound((0, 0), (4, 2)) == pytest.approx(4 + 2 * (math.sqrt(2) - 1))


@settings(max_examples=30, deadline=None)
@given(maps)
def test_lengths_without_factors_are_costs_with_factors_of_one(
        spec: tuple[int, int, float, int, bool]) -> None:
    h, w, density, seed, corner_cutting = spec
    rng = np.random.default_rng(seed)
    passable = rng.random((h, w)) >= density
    free = np.argwhere(passable)
    if not len(free):
        return
    source = (int(free[-1][1]), int(free[-1][0]))
    lengths = cost_map(None, passable, corner_cutting, [source])
    assert np.array_equal(lengths, cost_map(np.ones((h, w)), passable, corner_cutting, [source]))
    expected = as_map(lengths_from(passable, corner_cutting, source), (h, w))
    np.testing.assert_allclose(lengths, expected, rtol=1e-12)


def test_a_length_map_by_hand() -> None:
    # a wall at (1, 0) and (1, 1): from (0, 0) the way to (2, 0) runs down and round it
    passable = np.ones((3, 3), dtype=bool)
    passable[0:2, 1] = False
    root2 = math.sqrt(2)
    lengths = cost_map(None, passable, False, [(0, 0)])
    assert lengths[2].tolist() == pytest.approx([2.0, 3.0, 4.0])
    assert lengths[:, 2].tolist() == pytest.approx([6.0, 5.0, 4.0])
    # corner cutting lets (0, 1) step diagonally to (1, 2) past the wall's end
    cut = cost_map(None, passable, True, [(0, 0)])
    assert cut[2, 1] == pytest.approx(1 + root2)
    assert cut[1, 2] == pytest.approx(1 + 2 * root2)
