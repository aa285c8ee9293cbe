"""A plugin's grid solver serves every slot that plans on a grid, through the solver protocol.

A test-only plugin registers ``bfs``, the breadth-first planner of the plugin guide (its solver
protocol section) recording each call. It is named by ``cbr plan --solver``, a reuser's
``connector`` and the trips workload's ``replanner``, and each of its paths is checked against a
brute-force count of the fewest moves on the mask it was given. The plugin's ``jumper`` returns a
path through walls, which is refused.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cbr_grid.grid import Grid
from cbr_grid.planning import Window
from cbr_grid.query import Cell
from cbrcore.engine import Engine
from cbrcore.hookspecs import hookimpl
from cbrcore.plugins import Plugins
from cbrcore.registry import Registry
from cbrcore.run import run_workload
from cbrcore.testing import CliResult
from repo_paths import ROOT

MOVES = [(dx, dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy]


class Call:
    """One call of the plugin's planner: what it was given and what it returned."""

    def __init__(self, grid: Grid, passable: np.ndarray, start: Cell, goals: np.ndarray,
                 window: Window | None, path: np.ndarray | None) -> None:
        self.grid, self.passable, self.start = grid, passable.copy(), start
        self.goals, self.window, self.path = goals, window, path


CALLS: list[Call] = []


GUIDE = ROOT / "docs" / "plugins-kinds.md"
EXAMPLE = re.compile(r"^```python\n(# cbr-gridbfs/src/cbr_gridbfs/__init__.py\n.*?)^```$",
                     re.S | re.M)


def guide_planner() -> type:
    """The breadth-first planner of the plugin guide's solver protocol section."""
    found = EXAMPLE.search(GUIDE.read_text(encoding="utf-8"))
    assert found is not None, "the guide's example planner is missing"
    namespace: dict[str, Any] = {}
    exec(compile(found[1], str(GUIDE), "exec"), namespace)
    return namespace["BreadthFirst"]


class BreadthFirst(guide_planner()):
    """The guide's planner, recording each call."""

    def plan(self, grid: Grid, passable: np.ndarray, start: Cell, goals: np.ndarray, *,
             window: Window | None = None, heading: int | None = None) -> np.ndarray | None:
        path = super().plan(grid, passable, start, goals, window=window, heading=heading)
        CALLS.append(Call(grid, passable, (int(start[0]), int(start[1])), goals, window, path))
        return path


def corner_allowed(grid: Grid, passable: np.ndarray, x: int, y: int, dx: int, dy: int) -> bool:
    """The grid's corner rule for a step from (x, y) by (dx, dy)."""
    if not (dx and dy):
        return True
    sides = (bool(passable[y, x + dx]), bool(passable[y + dy, x]))
    return any(sides) if grid.corner_cutting else all(sides)


class Jumper(BreadthFirst):
    """A wrong planner: straight from the start to the first goal, whatever lies between."""

    def plan(self, grid: Grid, passable: np.ndarray, start: Cell, goals: np.ndarray, *,
             window: Window | None = None, heading: int | None = None) -> np.ndarray | None:
        return np.array([start, np.asarray(goals).reshape(-1, 2)[0]], dtype=np.int64)


class BfsPlugin:
    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("solver", "bfs", BreadthFirst)
        registry.add("solver", "jumper", Jumper)


def fewest_moves(call: Call) -> float:
    """The fewest moves from the call's start to any of its goals inside its window, by
    relaxing every cell until nothing changes (independent of the queue above)."""
    grid, passable = call.grid, call.passable
    x0, y0, x1, y1 = call.window or (0, 0, grid.width - 1, grid.height - 1)
    inside = np.zeros_like(passable)
    inside[max(y0, 0):y1 + 1, max(x0, 0):x1 + 1] = True
    steps = np.full(passable.shape, np.inf)
    steps[call.start[1], call.start[0]] = 0
    changed = True
    while changed:
        changed = False
        for y, x in zip(*np.nonzero(passable & inside), strict=True):
            for dx, dy in MOVES:
                px, py = x - dx, y - dy
                if (0 <= px < grid.width and 0 <= py < grid.height
                        and corner_allowed(grid, passable, px, py, dx, dy)
                        and steps[py, px] + 1 < steps[y, x]):
                    steps[y, x] = steps[py, px] + 1
                    changed = True
    goals = np.asarray(call.goals).reshape(-1, 2)
    return float(steps[goals[:, 1], goals[:, 0]].min())


def assert_fewest_moves(calls: list[Call]) -> None:
    """Every path is valid on the mask it was planned on and has the fewest moves."""
    for call in calls:
        best = fewest_moves(call)
        if call.path is None:
            assert best == np.inf
            continue
        on_mask = Grid(np.where(call.passable, call.grid.risk, 1.0),
                       corner_cutting=call.grid.corner_cutting)
        assert on_mask.path_problems(call.path) == []
        assert tuple(call.path[0]) == call.start
        assert len(call.path) - 1 == best


@pytest.fixture(autouse=True)
def with_bfs(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    CALLS.clear()
    return cbr_plugins(("bfs", BfsPlugin()), entry_points=True, environ={})


@pytest.fixture
def small_map(tmp_path: Path) -> Path:
    rows = ["........", "..@@@@..", ".....@..", "..@..@..", "..@....."]
    path = tmp_path / "small.map"
    path.write_text("type octile\nheight 5\nwidth 8\nmap\n" + "\n".join(rows) + "\n",
                    encoding="ascii")
    return path


def test_cbr_plan_plans_with_a_plugins_solver(invoke_cbr: Callable[..., CliResult],
                                              small_map: Path) -> None:
    result = invoke_cbr("plan", str(small_map), "--start", "3,2", "--goal", "7,0", "--solver",
                     "bfs", "--json")

    assert result.exit_code == 0, result.stderr
    record = json.loads(result.stdout)
    assert len(CALLS) == 1
    assert record["solver"] == "bfs"
    assert record["path"] == CALLS[0].path.tolist()
    assert record["expanded"] is None
    assert_fewest_moves(CALLS)


def test_a_plugins_wrong_path_is_an_error_naming_the_solver(
        invoke_cbr: Callable[..., CliResult], small_map: Path) -> None:
    result = invoke_cbr("plan", str(small_map), "--start", "3,2", "--goal", "7,0", "--solver",
                     "jumper")

    assert result.exit_code == 2
    assert result.stdout == ""
    assert ("--solver: solver 'jumper' returned an invalid path from (3, 2): step 0, from "
            "(3, 2) to (7, 0), is no move to an 8-neighbour") in result.stderr
    assert "Traceback" not in result.stderr


def office(reuse: dict[str, Any], replanner: str = "astar") -> dict[str, Any]:
    """Trips on a small office with unknown obstacles to drive around."""
    return {"seed": 5, "world": {"use": "generated", "kind": "office", "width": 28,
                                 "height": 20},
            "workload": {"use": "trips", "count": 25, "unknown_static": 12,
                         "replanner": replanner},
            "retrieve": {"use": reuse["use"]}, "reuse": reuse, "solver": "astar",
            "retain": ["risk_map", reuse["use"]]}


@pytest.mark.parametrize("config", [
    pytest.param(office({"use": "path_cases", "connector": "bfs"}), id="path_cases connector"),
    pytest.param(office({"use": "casegraph", "connector": "bfs"}), id="casegraph connector"),
    pytest.param(office({"use": "casegraph", "connector": "dijkstra"}, replanner="bfs"),
                 id="trips replanner"),
])
def test_a_plugins_solver_serves_the_connector_and_replanner_slots(
        cbr_engine: Callable[..., Engine], tmp_path: Path, config: dict[str, Any]) -> None:
    engine = cbr_engine(config, out_dir=tmp_path)

    run_workload(engine, tmp_path)

    assert CALLS, "the plugin's solver was never called"
    assert any(call.path is not None for call in CALLS)
    assert_fewest_moves(CALLS[:30])
