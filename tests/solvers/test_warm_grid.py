"""The warm-up grid: one builder, ``cbr_solvers.warm_grid``, for the solvers and the families."""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType
from typing import Any

import numpy as np
import pytest

import cbr_casegraph.components
import cbr_pathcases.components
from cbr_grid.costs import CostModel
from cbr_grid.grid import Grid
from cbr_solvers import warm_grid, warm_query
from cbrcore import Engine


def test_the_warm_grid_has_the_worlds_rules_and_a_wall_across_the_middle() -> None:
    world = Grid(np.zeros((3, 3)), corner_cutting=True, cost_model=CostModel(risk_weight=2.0))
    walled = warm_grid(world, 6)
    # column 6 // 2 = 3 blocked on rows 1 to 4, open at the top and bottom rows
    assert np.argwhere(~walled.passable)[:, ::-1].tolist() == [[3, 1], [3, 2], [3, 3], [3, 4]]
    assert walled.corner_cutting and walled.cost_model == world.cost_model
    query = warm_query(walled)
    assert (query.start, query.goal) == ((0, 3), (5, 3))  # on either side of the wall
    free = warm_grid(world, 24, wall=False)
    assert free.passable.shape == (24, 24) and free.passable.all()
    assert free.corner_cutting and free.cost_model == world.cost_model


# the case graph's retriever, reuser and retainer warm up; of the path cases the reuser and the
# retainer
@pytest.mark.parametrize(("family", "config", "size", "warming"), [
    (cbr_casegraph.components, {"retrieve": "casegraph", "reuse": "casegraph",
                                "retain": ["casegraph"]}, 24, 3),
    (cbr_pathcases.components, {"retrieve": "path_cases", "reuse": "path_cases",
                                "retain": ["path_cases"]}, 8, 2),
])
def test_the_families_warm_up_on_the_solvers_warm_grid(
        monkeypatch: pytest.MonkeyPatch, family: ModuleType, config: dict[str, Any], size: int,
        warming: int, cbr_engine: Callable[..., Engine]) -> None:
    built: list[Grid] = []

    def recorded(world: Grid, *args: Any, **kwargs: Any) -> Grid:
        grid = warm_grid(world, *args, **kwargs)
        built.append(grid)
        return grid

    monkeypatch.setattr(family, "warm_grid", recorded)
    world = Grid(np.zeros((30, 30)), corner_cutting=True, cost_model=CostModel(risk_weight=3.0))
    engine = cbr_engine({**config, "solver": "astar"}, world=world)
    # every warming component built its grid there: free (the families' warm-up paths run
    # anywhere on it), with the world's rules
    assert len(built) == warming
    for grid in built:
        assert grid.passable.shape == (size, size) and grid.passable.all()
        assert grid.corner_cutting and grid.cost_model == world.cost_model
    assert engine.casebase.count() == 0  # the warm-ups learned into case bases of their own
