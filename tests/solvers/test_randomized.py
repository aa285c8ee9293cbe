"""The ``randomized`` search and solver: A* on noisy cost factors, costed on the true ones.

The bound tested throughout: each cell's factor is scaled by a draw in [1, 1 + noise], so every
step's noisy cost lies between its true cost and 1 + noise times it. For the path P found and a
cheapest path O, true(P) <= noisy(P) (noise only raises costs) <= noisy(O) (P is the cheapest
under the noisy costs, A*'s heuristic being admissible for them) <= (1 + noise)·true(O).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_grid.costs import path_cost
from cbr_grid.grid import Grid
from cbr_grid.query import GridQuery
from cbr_solvers import Randomized, RandomizedOptions
from cbr_solvers.randomized import randomized
from cbr_solvers.search import dijkstra
from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.errors import ConfigError
from cbrcore.plugins import Plugins
from cbrcore.registry import Registry

from .test_solvers import check_path, grid_problems, reference_cost


def risky_grid() -> Grid:
    """12x9, two walls with gaps and a seeded risk field, without corner cutting."""
    risk = np.random.default_rng(5).uniform(0.0, 0.6, (9, 12))
    risk[0:6, 4] = 1.0
    risk[3:9, 8] = 1.0
    return Grid(risk, corner_cutting=False)


def test_the_path_is_valid_and_costed_on_the_true_factor() -> None:
    grid = risky_grid()
    start, goal = (0, 0), (11, 8)
    optimum = dijkstra(grid.factor, grid.passable, False, start, [goal]).cost

    for seed in range(10):
        found = randomized(grid.factor, grid.passable, False, start, [goal], noise=0.5, seed=seed)
        assert found is not None
        assert grid.path_problems(found.path) == []
        assert found.path[0].tolist() == list(start) and found.path[-1].tolist() == list(goal)
        assert found.cost == pytest.approx(path_cost(grid, found.path), rel=1e-12)
        assert optimum * (1 - 1e-12) <= found.cost <= 1.5 * optimum


def test_no_noise_gives_the_cheapest_cost() -> None:
    grid = risky_grid()
    for seed in (0, 7):
        found = randomized(grid.factor, grid.passable, False, (0, 8), [(11, 0)], noise=0.0,
                           seed=seed)
        optimum = dijkstra(grid.factor, grid.passable, False, (0, 8), [(11, 0)]).cost
        assert found.cost == pytest.approx(optimum, rel=1e-12)


def test_seeds_vary_the_path_and_a_seed_repeats_it() -> None:
    factor, passable = np.ones((10, 10)), np.ones((10, 10), dtype=bool)

    paths = {tuple(map(tuple, randomized(factor, passable, False, (0, 0), [(9, 5)],
                                         seed=seed).path.tolist())) for seed in range(8)}
    again = [randomized(factor, passable, False, (0, 0), [(9, 5)], seed=3) for _ in range(2)]

    assert len(paths) >= 2
    assert again[0] == again[1]


def test_a_window_limits_the_path_and_the_contract_matches_astar() -> None:
    grid = risky_grid()
    window = (0, 0, 7, 8)
    found = randomized(grid.factor, grid.passable, False, (0, 0), [(7, 8), (11, 8)], window,
                       noise=0.3, seed=2)
    check_path(found, grid.factor, grid.passable, False, (0, 0), [(7, 8)], window)
    assert randomized(grid.factor, grid.passable, False, (9, 0), [(7, 8)], window) is None
    assert randomized(grid.factor, grid.passable, False, (0, 0), [(11, 8)], window) is None
    assert randomized(grid.factor, ~grid.passable, False, (4, 0), [(0, 0)]) is None
    with pytest.raises(ValueError, match="start"):
        randomized(grid.factor, grid.passable, False, (12, 0), [(0, 0)])
    with pytest.raises(ValueError, match="goal"):
        randomized(grid.factor, grid.passable, False, (0, 0), [(0, 9)])
    with pytest.raises(ValueError, match=r"noise must be a finite number >= 0, got -0\.1"):
        randomized(grid.factor, grid.passable, False, (0, 0), [(1, 0)], noise=-0.1)
    with pytest.raises(ValueError, match=r"seed must be an integer >= 0, got 1\.5"):
        randomized(grid.factor, grid.passable, False, (0, 0), [(1, 0)], seed=1.5)


@settings(max_examples=150, deadline=None)
@given(grid_problems(), st.floats(0.0, 2.0), st.integers(0, 2**32 - 1))
def test_random_grids_keep_the_bound(problem: tuple, noise: float, seed: int) -> None:
    factor, passable, corner_cutting, start, goals, window = problem
    optimum = reference_cost(factor, passable, corner_cutting, start, goals, window)

    found = randomized(factor, passable, corner_cutting, start, goals, window, noise=noise,
                       seed=seed)

    if math.isinf(optimum):
        assert found is None
        return
    assert found is not None
    check_path(found, factor, passable, corner_cutting, start, goals, window)
    assert optimum * (1 - 1e-9) <= found.cost <= (1 + noise) * optimum * (1 + 1e-9)


def test_the_component_draws_per_query_or_uses_its_seed() -> None:
    grid = Grid(np.zeros((10, 10)))
    query = GridQuery((0, 0), (9, 5))

    def paths(options: RandomizedOptions, seed: int) -> list[list[list[int]]]:
        ctx = Context(registry=Registry(), seed=seed, world=grid)
        solver = Randomized(options, ctx)
        return [solver.cbr_solve(query, ctx).value for _ in range(6)]

    drawn = paths(RandomizedOptions(), 1)
    assert len({str(p) for p in drawn}) >= 2
    assert drawn == paths(RandomizedOptions(), 1)
    fixed = paths(RandomizedOptions(seed=4), 1)
    assert all(p == fixed[0] for p in fixed)


def test_the_solver_runs_in_an_engine(cbr_plugins: Callable[..., Plugins],
                                      cbr_engine: Callable[..., Engine]) -> None:
    cbr_plugins(entry_points=True, environ={"CBR_PLUGINS": "core,grid,solvers"})
    engine = cbr_engine({"world": {"use": "generated", "kind": "office", "width": 28,
                                   "height": 20},
                         "solver": {"use": "randomized", "noise": 0.5, "seed": 3}})
    world = engine.world
    free = np.argwhere(world.passable)
    start, goal = (int(free[0, 1]), int(free[0, 0])), (int(free[-1, 1]), int(free[-1, 0]))

    proposal = engine.solve(GridQuery(start, goal))

    assert proposal.source == "solver:randomized"
    solution = proposal.solution
    assert solution is not None and solution.detail["solver"] == "randomized"
    assert world.path_problems(solution.value) == []
    assert solution.value[0] == list(start) and solution.value[-1] == list(goal)
    optimum = dijkstra(world.factor, world.passable, world.corner_cutting, start, [goal]).cost
    assert optimum * (1 - 1e-12) <= solution.cost <= 1.5 * optimum
    with pytest.raises(ConfigError, match=r"solver\.noise: must be >= 0"):
        cbr_engine({"world": {"use": "generated", "kind": "office"},
                    "solver": {"use": "randomized", "noise": -1.0}})
