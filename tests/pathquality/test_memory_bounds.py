"""The memory-lean building of the landmark bound and of the length maps it is made of.

``Landmarks`` keeps its tables as 16-bit counts of a unit, rounded down, built from shortest
path lengths (``cost_map`` without factors); checked here against a plain Dijkstra over the 8
moves and the farthest-first choice of landmarks, worked out independently of the compiled
kernels, and its bound against the exact shortest lengths between every pair of cells.
"""

from __future__ import annotations

import heapq
import math
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cbr_grid.grid import Grid
from cbr_pathquality import ideal
from cbr_pathquality.ideal import TABLE_BYTES, UNREACHED, Landmarks, landmark_count, table_unit
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
units = st.sampled_from([None, 0.25, 1.0, 4.0])
"""The tables' unit: the map's own (None), or a coarser one forced, to exercise the rounding."""


def quantised_farthest(tables: np.ndarray) -> tuple[int, int]:
    """The reached cell whose least table entry is greatest, the first in row-major order on a
    tie: the farthest-first rule on the tables as stored."""
    nearest = tables.min(axis=0).astype(np.int64)
    nearest[nearest == UNREACHED] = -1
    y, x = np.unravel_index(int(np.argmax(nearest)), nearest.shape)
    return int(x), int(y)


def random_map(spec: tuple[int, int, float, int, bool]) -> tuple[np.ndarray, Grid]:
    """The passable cells and the grid of a map drawn from ``maps``."""
    h, w, density, seed, corner_cutting = spec
    passable = np.random.default_rng(seed).random((h, w)) >= density
    return passable, Grid((~passable).astype(float), corner_cutting=corner_cutting)


def build(grid: Grid, count: int, unit: float | None) -> Landmarks:
    if unit is None:
        return Landmarks(grid, count)
    with mock.patch.object(ideal, "table_unit", lambda farthest: unit):
        return Landmarks(grid, count)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(maps, st.integers(1, 4), units)
def test_the_tables_are_the_lengths_from_landmarks_chosen_farthest_first_rounded_down(
        spec: tuple[int, int, float, int, bool], count: int, unit: float | None) -> None:
    passable, grid = random_map(spec)
    h, w, corner_cutting = *passable.shape, grid.corner_cutting
    bound = build(grid, count, unit)
    free = np.argwhere(passable)
    if not len(free):
        assert bound.tables.shape == (0, h, w)
        return
    assert bound.tables.dtype == np.uint16
    assert bound.tables.shape == (count, h, w)
    reach = as_map(lengths_from(passable, corner_cutting, (int(free[0][1]), int(free[0][0]))),
                   (h, w))
    landmark = farthest(reach)
    if unit is None:
        assert bound.unit == table_unit(float(reach[landmark[1], landmark[0]]))
        assert 2 * reach[np.isfinite(reach)].max() / bound.unit <= UNREACHED - 1
    for k in range(count):
        if k:
            landmark = quantised_farthest(bound.tables[:k])
        assert bound.cells[k] == landmark
        exact = as_map(lengths_from(passable, corner_cutting, landmark), (h, w))
        table = bound.tables[k].astype(float)
        reached = np.isfinite(exact)
        assert np.array_equal(table == UNREACHED, ~reached)
        # rounded down in units: u t <= d < u (t + 1), up to the float sums' last bits
        assert np.all(table[reached] * bound.unit <= exact[reached] * (1 + 1e-12))
        assert np.all((table[reached] + 1) * bound.unit > exact[reached] * (1 - 1e-12))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(maps, st.integers(1, 4), units)
def test_the_bound_never_exceeds_the_shortest_length_and_loses_under_two_units(
        spec: tuple[int, int, float, int, bool], count: int, unit: float | None) -> None:
    passable, grid = random_map(spec)
    h, w, corner_cutting = *passable.shape, grid.corner_cutting
    bound = build(grid, count, unit)
    free = [(int(x), int(y)) for y, x in np.argwhere(passable)]
    from_landmarks = [as_map(lengths_from(passable, corner_cutting, cell), (h, w))
                      for cell in bound.cells]
    for start in free[:: max(1, len(free) // 8)]:
        lengths = lengths_from(passable, corner_cutting, start)
        for goal in free:
            dx, dy = abs(start[0] - goal[0]), abs(start[1] - goal[1])
            octile = max(dx, dy) + (math.sqrt(2) - 1) * min(dx, dy)
            found = bound.bound(start, goal)
            if goal in lengths:  # admissible: never above the shortest length
                assert found <= lengths[goal] + 1e-12
            # as tight as the exact ALT bound, but for the rounding down
            gaps = [abs(d[start[1], start[0]] - d[goal[1], goal[0]]) for d in from_landmarks
                    if np.isfinite(d[start[1], start[0]]) and np.isfinite(d[goal[1], goal[0]])]
            assert found >= max(max(gaps, default=0.0) - 2 * bound.unit, octile) - 1e-9


def test_very_large_maps_get_fewer_landmarks_within_the_tables_budget() -> None:
    assert landmark_count(8, 4000 * 4000) == 8
    assert landmark_count(8, 8000 * 8000) == 4
    assert landmark_count(8, 10**12) == 1
    assert landmark_count(8, 8000 * 8000) * 2 * 8000 * 8000 <= TABLE_BYTES
    with mock.patch.object(ideal, "TABLE_BYTES", 2 * 2 * 30):  # two tables of 30 cells
        bound = Landmarks(Grid(np.zeros((5, 6))), 8)
    assert bound.tables.shape == (2, 5, 6)
    assert bound.cells == [(5, 4), (0, 0)]


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
