"""The whole-path learning experiment (``cbr_pathcases.experiments``) at size ci, through the CLI.

It checks that the experiment wrote its files, that every number is a possible one (a trip
never takes less than the shortest path on the map, shares are shares, capacities hold), that
every robot drove the same trips, and the paper's claim at this size: the case-based robot's
travel cost over the last half of its trips is below the map-only planner's, seed by seed.
The full-size figures are discussed in docs/pathcases.md.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cbr_experiments.experiment import spread
from cbr_grid.formats import load_text
from cbr_pathcases.experiments import CAPACITY, PLACES, SITES, floor, moving_mean
from cbr_pathcases.forgetting import CAPACITY_STRATEGIES
from cbr_solvers.search import astar
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(autouse=True)
def _installed(cbr_plugins: Callable[..., Plugins]) -> None:
    cbr_plugins(entry_points=True)


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, Any]]:
    from cbrcore.cli import main

    out = tmp_path_factory.mktemp("learning")
    assert main(["experiment", "path-cases-learning", "--size", "ci", "--out", str(out)]) == 0
    return out, json.loads((out / "results.json").read_text(encoding="utf-8"))


def test_the_experiment_writes_its_files(results: tuple[Path, dict[str, Any]]) -> None:
    out, _ = results
    for name in ("results.json", "results.md", "manifest.json", "floor.grid"):
        assert (out / name).stat().st_size > 0
    for figure in ("learning_curve", "forgetting", "floor"):
        assert (out / f"{figure}.png").read_bytes()[:8] == PNG
    assert "paper" in (out / "results.md").read_text(encoding="utf-8")
    # the map written beside the results is the one the robots drove on
    assert np.array_equal(load_text(out / "floor.grid").risk, floor().risk)


def test_every_robot_and_strategy_ran_every_seed(results: tuple[Path, dict[str, Any]]) -> None:
    _, data = results
    robots = {"map-only", "map-learning", "cbr", *CAPACITY_STRATEGIES}
    assert set(data["summary"]) == set(data["curves"]) == set(data["configs"]) == robots
    for curves in data["curves"].values():
        assert len(curves) == len(data["seeds"])
        assert all(len(curve) == data["trips"] for curve in curves)


def test_no_trip_beats_the_shortest_path_on_the_map(results: tuple[Path, dict[str, Any]]
                                                    ) -> None:
    # the true world only adds obstacles to the map, so a driven path is one on the map too
    _, data = results
    for curves in data["curves"].values():
        assert np.min(curves) >= 1 - 1e-9


def test_the_numbers_are_possible(results: tuple[Path, dict[str, Any]]) -> None:
    _, data = results
    for robot, summary in data["summary"].items():
        share = summary["last_half_cbr_share"]
        assert 0 <= share["min"] <= share["max"] <= 1
        if robot in ("map-only", "map-learning"):
            assert share["max"] == 0 and summary["final_cases"]["max"] == 0
        elif robot in CAPACITY_STRATEGIES:
            assert summary["final_cases"]["max"] <= CAPACITY
        # the summary's last-half cost is the curves' own
        half = data["trips"] // 2
        means = [float(np.mean(curve[half:])) for curve in data["curves"][robot]]
        assert summary["last_half_cost"]["mean"] == pytest.approx(np.mean(means))
        assert set(summary["last_half_cost_by_pair"]) <= {"AB", "AC", "AD", "BC", "BD", "CD"}
        assert min(summary["last_half_cost_by_pair"].values()) >= 1 - 1e-9
    # obstacles missing from the map do stop the map-only planner
    assert data["summary"]["map-only"]["last_half_stops"]["mean"] > 0


def test_the_case_based_robot_travels_below_the_map_only_planner(
        results: tuple[Path, dict[str, Any]]) -> None:
    _, data = results
    half = data["trips"] // 2
    for cbr, planner in zip(data["curves"]["cbr"], data["curves"]["map-only"], strict=True):
        assert np.mean(cbr[half:]) < np.mean(planner[half:])
    assert data["cbr_over_map_only"]["max"] < 1


def test_the_world_is_the_one_described() -> None:
    grid = floor()
    assert (grid.width, grid.height) == (44, 27)
    cells = [cell for cells, _ in SITES.values() for cell in cells]
    assert len(set(cells)) == len(cells)
    assert all(grid.passable[y, x] for x, y in [*cells, *PLACES.values()])
    # with every site blocked, every place still reaches every other: trips never fail
    passable = grid.passable.copy()
    for x, y in cells:
        passable[y, x] = False
    for a in PLACES.values():
        for b in PLACES.values():
            if a != b:
                assert astar(grid.factor, passable, False, a, [b]) is not None


def test_moving_mean_and_spread_by_hand() -> None:
    assert moving_mean(np.array([1.0, 3.0, 5.0, 7.0]), 2).tolist() == [1.0, 2.0, 4.0, 6.0]
    assert spread([1.0, 3.0]) == {"mean": 2.0, "std": pytest.approx(2 ** 0.5), "min": 1.0,
                                  "max": 3.0}
    assert spread([4.0])["std"] == 0.0


def test_the_experiment_is_listed(invoke_cbr: Callable[..., CliResult]) -> None:
    result = invoke_cbr("experiment", "--list")
    assert result.exit_code == 0
    assert "path-cases-learning" in result.stdout
