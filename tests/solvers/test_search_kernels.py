"""The cell search kernel's fast paths: move masks, uniform step counting, tie-breaking, held
successors and remembered grids, each checked against facts found another way."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra as scipy_dijkstra

from cbr_grid.grid import Grid
from cbr_grid.search_base import DX, DY, LEAVING, CellWorkspace, cell_moves, move_masks
from cbr_solvers import search as search_module
from cbr_solvers.aistar import aistar
from cbr_solvers.search import astar, dijkstra, grid_moves, grid_profile, least_factor

SQRT2 = math.sqrt(2.0)


def scipy_costs(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
                start: tuple[int, int], window: tuple[int, int, int, int] | None = None
                ) -> np.ndarray:
    """The cheapest cost from ``start`` to every cell, by scipy over the steps Grid allows
    (between cells of ``window``, when given)."""
    grid = Grid(np.where(passable, 0.0, 1.0), corner_cutting=corner_cutting)
    h, w = passable.shape
    ys, xs = np.mgrid[0:h, 0:w]
    src, dst, cost = [], [], []
    for dx, dy in ((dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy):
        a = np.column_stack((xs.ravel(), ys.ravel()))
        b = a + np.array([dx, dy])
        ok = grid.step_allowed(a, b)
        if window is not None:
            x0, y0, x1, y1 = window
            for cells in (a, b):
                ok &= ((cells[:, 0] >= x0) & (cells[:, 0] <= x1) & (cells[:, 1] >= y0)
                       & (cells[:, 1] <= y1))
        a, b = a[ok], b[ok]
        length = SQRT2 if dx and dy else 1.0
        src.append(a[:, 1] * w + a[:, 0])
        dst.append(b[:, 1] * w + b[:, 0])
        cost.append(length * (factor[a[:, 1], a[:, 0]] + factor[b[:, 1], b[:, 0]]) / 2)
    graph = coo_matrix((np.concatenate(cost), (np.concatenate(src), np.concatenate(dst))),
                       shape=(h * w, h * w)).tocsr()
    return scipy_dijkstra(graph, indices=start[1] * w + start[0]).reshape(h, w)


def frozen(array: np.ndarray) -> np.ndarray:
    array = np.array(array)
    array.setflags(write=False)
    return array


@st.composite
def maps(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, bool]:
    h, w = draw(st.integers(2, 9)), draw(st.integers(2, 9))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    passable = rng.random((h, w)) > draw(st.sampled_from([0.0, 0.2, 0.4]))
    uniform = draw(st.booleans())
    factor = np.full((h, w), draw(st.sampled_from([1.0, 2.5]))) if uniform else \
        1.0 + rng.integers(0, 3, (h, w)) * 0.5
    return factor, passable, draw(st.booleans())


def test_move_masks_match_the_grid_rule() -> None:
    rng = np.random.default_rng(3)
    passable = rng.random((13, 11)) > 0.3
    for corner_cutting in (False, True):
        grid = Grid(np.where(passable, 0.0, 1.0), corner_cutting=corner_cutting)
        masks = move_masks(passable, corner_cutting)
        for y in range(13):
            for x in range(11):
                allowed = grid.step_allowed([(x, y)] * 8, list(zip(x + DX, y + DY, strict=True)))
                expected = sum(1 << d for d in range(8) if allowed[d])
                assert masks[y * 11 + x] == expected
                if passable[y, x]:  # a search never expands a blocked cell
                    assert cell_moves(passable, corner_cutting, x, y) == expected


def test_leaving_bits_name_the_moves_off_each_side() -> None:
    for side, (axis, sign) in enumerate(((DX, -1), (DX, 1), (DY, -1), (DY, 1))):
        assert LEAVING[side] == sum(1 << d for d in range(8) if axis[d] == sign)


@settings(max_examples=60, deadline=None)
@given(maps(), st.data())
def test_searches_agree_with_scipy(drawn: tuple[np.ndarray, np.ndarray, bool],
                                   data: st.DataObject) -> None:
    factor, passable, corner_cutting = drawn
    h, w = passable.shape
    start = (data.draw(st.integers(0, w - 1)), data.draw(st.integers(0, h - 1)))
    goals = data.draw(st.lists(st.tuples(st.integers(0, w - 1), st.integers(0, h - 1)),
                               min_size=1, max_size=3))
    costs = scipy_costs(factor, passable, corner_cutting, start)
    expected = min(costs[y, x] if passable[y, x] else math.inf for x, y in goals)
    if not passable[start[1], start[0]]:
        expected = math.inf
    for arrays in ((factor, passable), (frozen(factor), frozen(passable))):
        for search in (astar, dijkstra, aistar):
            found = search(*arrays, corner_cutting, start, goals)
            if math.isinf(expected):
                assert found is None
            else:
                assert found is not None
                assert math.isclose(found.cost, expected, rel_tol=1e-12, abs_tol=1e-12)
                assert tuple(found.path[-1]) in {tuple(g) for g in goals}
                grid = Grid(np.where(passable, 0.0, 1.0), corner_cutting=corner_cutting)
                assert grid.path_problems(found.path) == []


def test_uniform_costs_scale_with_the_factor() -> None:
    passable = np.ones((6, 9), dtype=bool)
    passable[1:5, 4] = False
    for value in (1.0, 0.25, 3.0):
        factor = np.full(passable.shape, value)
        expected = scipy_costs(factor, passable, False, (0, 3))[2, 8]
        for search in (astar, dijkstra):
            found = search(factor, passable, False, (0, 3), [(8, 2)])
            assert found is not None and math.isclose(found.cost, expected, rel_tol=1e-12)


def test_a_star_on_open_ground_expands_only_its_path() -> None:
    # Every cell of a diagonal-then-straight run has the same f: the tie rule and the held
    # successor take A* down one path, expanding nothing else.
    passable = np.ones((40, 60), dtype=bool)
    found = astar(np.ones((40, 60)), passable, False, (0, 0), [(59, 25)])
    assert found is not None
    assert math.isclose(found.cost, 34 + 25 * SQRT2, rel_tol=1e-12)
    assert found.expanded == len(found.path) == 60


def test_windows_clip_remembered_masks() -> None:
    rng = np.random.default_rng(5)
    passable = frozen(rng.random((30, 30)) > 0.2)
    factor = frozen(np.ones((30, 30)))
    search_module._MASKS.clear()
    assert dijkstra(factor, passable, False, (0, 0), [(0, 0)]) is not None
    assert [entry[1].shape for entry in search_module._MASKS.values()] == [(900,)]
    window = (5, 4, 20, 22)
    free = [(x, y) for y in range(4, 23) for x in range(5, 21) if passable[y, x]]
    start = free[0]
    costs = scipy_costs(np.ones((30, 30)), passable, False, start, window)
    for goal in free[::7]:
        for search in (astar, dijkstra):
            found = search(factor, passable, False, start, [goal], window)
            expected = costs[goal[1], goal[0]]
            if math.isinf(expected):
                assert found is None
            else:
                assert found is not None and math.isclose(found.cost, expected, rel_tol=1e-12)
                assert all(5 <= x <= 20 and 4 <= y <= 22 for x, y in found.path.tolist())


def test_the_workspace_holds_ten_bytes_a_cell_and_clears_what_it_used() -> None:
    workspace = CellWorkspace()
    stamp, dist, parent, generation = workspace.take(1000)
    assert stamp.nbytes + dist.nbytes + parent.nbytes == 10 * 1000
    assert generation == 2 and workspace.take(10)[3] == 4
    stamp[:] = 7
    workspace.generation, workspace.used = np.iinfo(np.uint8).max - 5, 10
    assert workspace.take(20)[3] == np.iinfo(np.uint8).max - 3  # settled at max - 2
    stamp, _, _, generation = workspace.take(10)
    # the stamps of the windows used since the last clearing, and only those, are cleared
    assert generation == 2 and not stamp[:20].any() and (stamp[20:] == 7).all()


def test_masks_of_a_grid_that_is_gone_are_dropped() -> None:
    search_module._MASKS.clear()
    for _ in range(3):
        grid = Grid(np.zeros((20, 20)))
        assert astar(grid.factor, grid.passable, False, (0, 0), [(19, 19)]) is not None
        del grid
    assert len(search_module._MASKS) == 1


def test_least_factor_of_grids_and_windows() -> None:
    risk = np.full((70, 70), 0.5)
    risk[3, 4], risk[60, 60], risk[0, 0] = 0.2, 0.1, 1.0
    grid = Grid(risk)
    assert least_factor(grid.factor, grid.passable) == 1.1  # 1 + risk, the default model
    assert least_factor(grid.factor, grid.passable, (0, 0, 10, 10)) == 1.2
    assert least_factor(grid.factor, np.zeros((70, 70), dtype=bool)) == math.inf
    bad = np.array(grid.factor)
    bad[5, 5] = math.nan
    with pytest.raises(ValueError, match="finite and positive"):
        least_factor(bad, grid.passable, (0, 0, 9, 9))


def test_the_whole_grid_profile_and_move_masks_are_the_ones_astar_keeps() -> None:
    risk = np.full((40, 50), 0.5)
    risk[3, 4], risk[30, 30], risk[0, 0] = 0.2, 0.9, 1.0
    grid = Grid(risk)
    assert grid_profile(grid.factor, grid.passable) == (1.2, 1.9)
    uniform = Grid(np.where(risk == 1.0, 1.0, 0.0))
    assert grid_profile(uniform.factor, uniform.passable) == (1.0, 1.0)
    masks = grid_moves(grid.passable, False)
    assert np.array_equal(masks, move_masks(grid.passable, False))
    astar(grid.factor, grid.passable, False, (1, 1), [(45, 35)])
    assert grid_moves(grid.passable, False) is masks  # built once, shared with A*
    # a grid that can still be written keeps no masks: each cell's moves are worked out
    assert len(grid_moves(np.ones((5, 5), dtype=bool), False)) == 0
