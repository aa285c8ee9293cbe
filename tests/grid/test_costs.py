"""The grid cost model: the step cost contract, the paper's path costs, and path metrics."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_grid import grid as grid_module
from cbr_grid.costs import (
    PATH_COSTS,
    CostModel,
    path_cost,
    path_length,
    path_metrics,
    risk_max,
    risk_sum,
    step_costs,
    turning_points,
    turns,
    uniform_factor,
)
from cbr_grid.distances import octile
from cbr_grid.grid import Grid
from cbrcore.errors import CbrError

SQRT2 = math.sqrt(2)


def risky_grid(weight: float = 1.0) -> Grid:
    """A 3x3 grid with risks 0.2, 0.4, 0.6 on (0, 0), (1, 1), (2, 1) and on (0, 0), (1, 0),
    (2, 0): the cells of the two 3-cell paths below."""
    risk = np.zeros((3, 3))
    risk[0, 0], risk[1, 1], risk[1, 2] = 0.2, 0.4, 0.6
    risk[0, 1], risk[0, 2] = 0.4, 0.6
    return Grid(risk, cost_model=CostModel(risk_weight=weight))


TURNING = [(0, 0), (1, 1), (2, 1)]  # a diagonal step, then an orthogonal one
STRAIGHT = [(0, 0), (1, 0), (2, 0)]  # one linear segment of two steps


def test_factor_is_one_plus_weighted_risk() -> None:
    grid = risky_grid(weight=2.0)
    assert grid.factor.dtype == np.float64
    assert grid.factor.shape == (3, 3)
    assert grid.factor[1, 2] == pytest.approx(2.2)
    assert grid.factor[2, 2] == 1.0
    assert np.all(Grid(np.zeros((4, 5))).factor == 1.0)


@pytest.mark.parametrize("weight", [-1.0, float("inf"), float("nan"), True, "1"])
def test_cost_model_refuses_bad_weight(weight: object) -> None:
    with pytest.raises(ValueError, match="risk_weight' must be a finite number >= 0"):
        CostModel(risk_weight=weight)  # type: ignore[arg-type]


def test_step_costs_follow_the_contract() -> None:
    # factors 1.2, 1.4, 1.6: sqrt(2) * (1.2 + 1.4) / 2, then 1 * (1.4 + 1.6) / 2
    costs = step_costs(risky_grid(), TURNING)
    assert costs == pytest.approx([1.3 * SQRT2, 1.5])


def test_turning_path_costs_by_hand() -> None:
    # segments: (0,0)-(1,1) l = sqrt2, r = 0.1 + 0.2 = 0.3, max 0.4;
    #           (1,1)-(2,1) l = 1,     r = 0.2 + 0.3 = 0.5, max 0.6
    grid = risky_grid()
    assert path_cost(grid, TURNING) == pytest.approx(1.3 * SQRT2 + 1.5)
    assert path_cost(grid, TURNING, "length_x_risk") == pytest.approx(0.3 * SQRT2 + 0.5)
    assert path_cost(grid, TURNING, "length_x_max_risk") == pytest.approx(0.4 * SQRT2 + 0.6)
    assert path_cost(grid, TURNING, "risk_sum") == pytest.approx(0.8)
    assert path_cost(grid, TURNING, "length_plus_risk") == pytest.approx(SQRT2 + 1 + 0.8)


def test_straight_path_costs_by_hand() -> None:
    # one segment: l = 2, r = 0.1 + 0.4 + 0.3 = 0.8, max 0.6
    grid = risky_grid()
    assert path_cost(grid, STRAIGHT, "length_x_risk") == pytest.approx(1.6)
    assert path_cost(grid, STRAIGHT, "length_x_max_risk") == pytest.approx(1.2)
    assert path_cost(grid, STRAIGHT, "risk_sum") == pytest.approx(0.8)
    assert path_cost(grid, STRAIGHT, "length_plus_risk") == pytest.approx(2.8)
    # on an orthogonal run the contract cost is the weighted sum of length and eq. (5) risk
    assert path_cost(grid, STRAIGHT) == pytest.approx(1.3 + 1.5)


def test_risk_metrics_by_hand() -> None:
    grid = risky_grid()
    assert risk_sum(grid, TURNING) == pytest.approx(0.1 + 0.4 + 0.3)
    assert risk_max(grid, TURNING) == pytest.approx(0.6)
    assert risk_sum(grid, [(1, 1)]) == pytest.approx(0.4)


def test_turns_by_hand() -> None:
    # east, east, south-east, south-east, south, west: three changes of direction
    path = [(0, 0), (1, 0), (2, 0), (3, 1), (4, 2), (4, 3), (3, 3)]
    assert turns(path) == 3
    assert turning_points(path).tolist() == [0, 2, 4, 5, 6]
    assert turns([(0, 0), (1, 0), (0, 0)]) == 1  # turning back is a turn
    assert turns([(0, 0), (1, 0), (1, 0), (2, 0)]) == 0  # a repeated cell is no turn
    assert turns([(5, 5)]) == 0
    assert turning_points([(5, 5)]).tolist() == [0]
    assert turns([(0, 0), (3, 3), (5, 5)]) == 0  # a polyline of turning points


def test_length_by_hand() -> None:
    assert path_length(TURNING) == pytest.approx(SQRT2 + 1)
    assert path_length([(0, 0), (3, 4)]) == 5.0
    assert path_length([(2, 2)]) == 0.0


def test_path_metrics() -> None:
    metrics = path_metrics(risky_grid(), TURNING)
    assert metrics == pytest.approx({"length": SQRT2 + 1, "cost": 1.3 * SQRT2 + 1.5,
                                     "risk_sum": 0.8, "risk_max": 0.6, "turns": 1.0})


def test_single_cell_path_costs_nothing() -> None:
    grid = risky_grid()
    for model in PATH_COSTS:
        assert path_cost(grid, [(1, 1)], model) == 0.0


def test_bad_paths_and_models_are_refused() -> None:
    grid = risky_grid()
    with pytest.raises(CbrError, match="unknown path cost 'fuel'; known: factor, "):
        path_cost(grid, TURNING, "fuel")
    with pytest.raises(CbrError, match="at least one cell"):
        path_cost(grid, [])
    with pytest.raises(CbrError, match=r"path step 0 from \(0, 0\) to \(2, 0\) is not a move"):
        path_cost(grid, [(0, 0), (2, 0)])
    with pytest.raises(CbrError, match=r"path cell 1 \(-1, 0\) is outside the 3x3 grid"):
        step_costs(grid, [(0, 0), (-1, 0)])


STEPS = [(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if (dx, dy) != (0, 0)]


@settings(deadline=None)
@given(st.lists(st.sampled_from(STEPS), min_size=1, max_size=40),
       st.floats(0, 10))
def test_risk_free_cost_is_octile_length(steps: list[tuple[int, int]], weight: float) -> None:
    path = np.concatenate(([[0, 0]], np.cumsum(steps, axis=0))) + 40
    grid = Grid(np.zeros((81, 81)), cost_model=CostModel(risk_weight=weight))
    expected = float(octile(path[:-1], path[1:]).sum())
    assert path_cost(grid, path) == pytest.approx(expected)
    assert path_length(path) == pytest.approx(expected)


@settings(deadline=None)
@given(st.integers(0, 20), st.integers(0, 20))
def test_risk_free_shortest_path_cost_is_octile_distance(dx: int, dy: int) -> None:
    # diagonal steps first, then straight ones: a shortest 8-connected path
    diagonal = min(dx, dy)
    steps = [(1, 1)] * diagonal + [(1, 0)] * (dx - diagonal) + [(0, 1)] * (dy - diagonal)
    path = np.concatenate(([[0, 0]], np.cumsum(np.reshape(steps, (-1, 2)), axis=0)))
    grid = Grid(np.zeros((21, 21)))
    assert path_cost(grid, path) == pytest.approx(float(octile((0, 0), (dx, dy))))


@settings(deadline=None)
@given(st.lists(st.sampled_from(STEPS), min_size=1, max_size=20),
       st.integers(0, 2**32 - 1))
def test_cost_grows_with_risk(steps: list[tuple[int, int]], seed: int) -> None:
    # up to 20 steps from the centre of a 41x41 grid stay on it
    path = np.concatenate(([[0, 0]], np.cumsum(steps, axis=0))) + 20
    risky = Grid(np.random.default_rng(seed).uniform(0, 0.99, (41, 41)))
    assert path_cost(risky, path) >= path_length(path) - 1e-9
    heavier = Grid(risky.risk, cost_model=CostModel(risk_weight=2.0))
    assert path_cost(heavier, path) >= path_cost(risky, path) - 1e-9


def test_a_large_grid_whose_passable_cells_share_a_factor_holds_it_once(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(grid_module, "UNIFORM_FACTOR_CELLS", 10)
    risk = np.zeros((4, 5))
    risk[1, 1:4] = 1.0
    free = Grid(risk, cost_model=CostModel(risk_weight=3.0))
    assert free.factor.shape == (4, 5) and free.factor.strides == (0, 0)
    assert not free.factor.flags.writeable
    assert uniform_factor(free.factor) == 1.0
    # obstacles hold the passable cells' value; no planner reads it
    assert np.all(free.factor == 1.0)
    # one risk on every passable cell: the cost model's factor of it, computed as for an array
    risk[risk == 0] = 0.3
    hazy = Grid(risk, cost_model=CostModel(risk_weight=3.0))
    assert uniform_factor(hazy.factor) == float(1.0 + 3.0 * np.float64(0.3))
    assert step_costs(hazy, STRAIGHT).tolist() == pytest.approx([1.9, 1.9])
    # several factors, a grid of few cells or no passable cell: a full array, as before
    risk[0, 0] = 0.5
    for kept in (Grid(risk), Grid(np.ones((4, 5)))):
        assert kept.factor.strides == (40, 8) and uniform_factor(kept.factor) is None
    monkeypatch.setattr(grid_module, "UNIFORM_FACTOR_CELLS", 20)
    assert uniform_factor(Grid(np.zeros((4, 5))).factor) is None
    assert uniform_factor(np.ones((4, 5))) is None
