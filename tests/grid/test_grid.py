"""The grid world: the Grid class, its movement rules, and the cell distances."""

from __future__ import annotations

import math

import attrs
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_grid.distances import DISTANCES, chebyshev, distance, euclidean, manhattan, octile
from cbr_grid.grid import Grid
from cbrcore.errors import CbrError

# 4 wide, 3 high; row y is written on line y. Cell (1, 1) is an obstacle.
RISK = np.array([
    [0.0, 0.0, 0.5, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 0.0, 0.25],
])


def test_grid_shape_and_masks() -> None:
    grid = Grid(RISK)
    assert (grid.width, grid.height) == (4, 3)
    assert grid.passable.dtype == bool
    assert not grid.passable[1, 1] and grid.passable[0, 2]
    assert grid.corner_cutting is False
    assert "4x3" in repr(grid)


def test_grid_copies_risk_and_keeps_it_read_only() -> None:
    source = RISK.copy()
    grid = Grid(source)
    source[0, 0] = 1.0
    assert grid.risk[0, 0] == 0.0
    with pytest.raises(ValueError, match="read-only"):
        grid.risk[0, 0] = 0.5


@pytest.mark.parametrize(("risk", "message"), [
    (np.zeros(4), r"2-D \(height, width\), got shape \(4,\)"),
    (np.zeros((0, 3)), "at least one cell"),
    ([[0.0, float("nan")]], r"finite and within \[0, 1\]; 1 cell\(s\) .* \(1, 0\)"),
    ([[0.0, 0.0], [1.5, -1.0]], r"2 cell\(s\) are not, the first is \(0, 1\) with 1.5"),
    ([["a"]], "array of numbers"),
])
def test_grid_refuses_bad_risk(risk: object, message: str) -> None:
    with pytest.raises(CbrError, match=message):
        Grid(risk)  # type: ignore[arg-type]


def test_evolved_grid_recomputes_its_masks() -> None:
    grid = attrs.evolve(Grid(RISK), risk=np.zeros((3, 4)))
    assert grid.passable.all()
    assert np.all(grid.factor == 1.0)


def test_in_bounds() -> None:
    grid = Grid(RISK)
    assert grid.in_bounds((0, 0)) and grid.in_bounds((3, 2))
    assert not grid.in_bounds((4, 0)) and not grid.in_bounds((0, 3))
    assert not grid.in_bounds((-1, 0))
    assert grid.inside([(0, 0), (4, 2), (3, -1)]).tolist() == [True, False, False]


def test_check_cell() -> None:
    grid = Grid(RISK)
    assert grid.check_cell((2, 0), "start") == (2, 0)
    assert grid.check_cell(np.array([3, 2]), "goal") == (3, 2)
    with pytest.raises(CbrError, match=r"start \(4, 1\) is outside the 4x3 grid"):
        grid.check_cell((4, 1), "start")
    with pytest.raises(CbrError, match=r"goal \(1, 1\) is on an obstacle"):
        grid.check_cell((1, 1), "goal")
    with pytest.raises(CbrError, match=r"start must be a cell \(x, y\) of two integers"):
        grid.check_cell((1.5, 0), "start")
    with pytest.raises(CbrError, match="start must be a cell"):
        grid.check_cell((1, 2, 3), "start")


def test_valid_path_has_no_problems() -> None:
    grid = Grid(RISK)
    assert grid.path_problems([(0, 0), (0, 1), (0, 2), (1, 2), (2, 2), (3, 1), (2, 0)]) == []
    assert grid.path_problems([(2, 0)]) == []


def test_path_problems_name_each_fault() -> None:
    grid = Grid(RISK)
    assert grid.path_problems([]) == ["the path has no cells"]
    assert grid.path_problems([(0, 0), (1, 1), (2, 2)]) == [
        "cells on obstacles at 1: (1, 1)"]
    assert grid.path_problems([(3, 2), (4, 2)]) == ["cells outside the 4x3 grid at 1: (4, 2)"]
    assert grid.path_problems([(0, 0), (2, 0), (2, 0)]) == [
        "steps that are not moves to an 8-neighbour cell at 0: (0, 0) to (2, 0), "
        "1: (2, 0) to (2, 0)"]


def test_no_corner_cutting_by_default() -> None:
    # (0, 0) -> (1, 1) is blocked anyway; (2, 1) -> (1, 2) passes (1, 1): a blocked corner
    grid = Grid(RISK)
    assert grid.path_problems([(2, 1), (1, 2)]) == [
        "diagonal steps past a blocked corner at 0: (2, 1) to (1, 2)"]
    assert grid.path_problems([(0, 1), (1, 0)]) == [
        "diagonal steps past a blocked corner at 0: (0, 1) to (1, 0)"]


def test_corner_cutting_passes_one_blocked_cell_never_two() -> None:
    risk = np.zeros((2, 2))
    risk[0, 1] = 1.0
    cutting = Grid(risk, corner_cutting=True)
    assert cutting.path_problems([(0, 0), (1, 1)]) == []
    assert Grid(risk).path_problems([(0, 0), (1, 1)]) != []
    risk[1, 0] = 1.0
    assert Grid(risk, corner_cutting=True).path_problems([(0, 0), (1, 1)]) == [
        "diagonal steps between two blocked cells at 0: (0, 0) to (1, 1)"]


def test_step_allowed_is_vectorised() -> None:
    grid = Grid(RISK)
    src = [(0, 0), (0, 0), (0, 0), (2, 1), (3, 2)]
    dst = [(1, 0), (1, 1), (2, 0), (3, 2), (4, 2)]
    assert grid.step_allowed(src, dst).tolist() == [True, False, False, True, False]


def test_many_problems_are_summarised() -> None:
    grid = Grid(np.ones((1, 8)))
    (problem,) = grid.path_problems([(x, 0) for x in range(8)])
    assert problem.endswith("4: (4, 0) and 3 more")


# --- distances: one worked example each, from (1, 2) to (4, 6): dx = 3, dy = 4


def test_distances_worked_by_hand() -> None:
    a, b = (1, 2), (4, 6)
    assert float(euclidean(a, b)) == 5.0
    assert float(manhattan(a, b)) == 7.0
    assert float(octile(a, b)) == pytest.approx(3 * math.sqrt(2) + 1)
    assert float(chebyshev(a, b)) == 4.0


def test_distances_broadcast_over_arrays() -> None:
    cells = np.array([[0, 0], [3, 4], [1, 1]])
    assert euclidean(cells, (0, 0)).tolist() == [0.0, 5.0, math.sqrt(2)]
    assert chebyshev(cells[:, None], cells[None]).shape == (3, 3)


def test_distance_lookup() -> None:
    assert set(DISTANCES) == {"euclidean", "manhattan", "octile", "chebyshev"}
    assert distance("octile") is octile
    with pytest.raises(CbrError, match="unknown distance 'hamming'; known: euclidean, "
                                       "manhattan, octile, chebyshev"):
        distance("hamming")


def test_distance_refuses_non_pairs() -> None:
    with pytest.raises(ValueError, match="last axis"):
        euclidean((1, 2, 3), (0, 0, 0))


coord = st.integers(-50, 50)
cell = st.tuples(coord, coord)


@settings(deadline=None)
@given(cell, cell, cell)
def test_distance_metric_axioms(a: tuple[int, int], b: tuple[int, int],
                                c: tuple[int, int]) -> None:
    for fn in DISTANCES.values():
        ab, ba = float(fn(a, b)), float(fn(b, a))
        assert ab >= 0
        assert (ab == 0) == (a == b)
        assert ab == ba
        assert ab <= float(fn(a, c)) + float(fn(c, b)) + 1e-9


@settings(deadline=None)
@given(cell, cell)
def test_distance_ordering(a: tuple[int, int], b: tuple[int, int]) -> None:
    cheb, euc = float(chebyshev(a, b)), float(euclidean(a, b))
    octi, manh = float(octile(a, b)), float(manhattan(a, b))
    assert cheb <= euc + 1e-9
    assert euc <= octi + 1e-9
    assert octi <= manh + 1e-9
    assert manh <= 2 * cheb
    assert octi <= math.sqrt(2) * cheb + 1e-9
