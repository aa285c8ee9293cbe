"""The ``trips`` workload, the true world it drives on, the simulated drive, the ``risk_map``
retainer that learns the robot's map in the learn step, and the ``path_quality`` metric
(:class:`cbr_pathquality.metric.PathQuality`) that rates proposals on the map they were planned on.

Hand-made cases use a 7x5 open map saved as .npy, where the straight path from (0, 2) to (6, 2)
costs 6 and the cheapest way around one blocked cell of row 2 costs 4 + 2·sqrt(2) ≈ 6.83: a cell
of row 2 with risk below 0.83 stays on the planned path.
"""

from __future__ import annotations

import csv
import itertools
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import attrs
import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_grid.costs import path_length
from cbr_grid.drive import DriveReport
from cbr_grid.generate import generate
from cbr_grid.grid import Grid
from cbr_grid.query import GridQuery
from cbr_grid.risk import LEARNED_RISK, risk_changes
from cbr_grid.trips import PLANNED_WORLD, Site, Trips, TripsOptions
from cbr_grid.true_world import Blocked
from cbr_solvers import AStar
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.errors import CbrError, ConfigError, PhaseError
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Outcome, Proposal, Solution
from cbrcore.plugins import Plugins, current
from cbrcore.registry import NoOptions, Registry
from cbrcore.run import run_workload
from repo_paths import DATA

OFFICE = {"use": "generated", "kind": "office", "width": 28, "height": 20}


@pytest.fixture(autouse=True)
def grid_plugins(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    return cbr_plugins(entry_points=True,
                       environ={"CBR_PLUGINS": "core,stores,grid,solvers,pathquality"})


def config(workload: dict[str, Any], **slots: Any) -> dict[str, Any]:
    """Trips on the office; the run learns its map with ``risk_map`` unless ``retain`` says
    otherwise."""
    return {"seed": 11, "world": OFFICE, "solver": "astar",
            "workload": {"use": "trips", **workload}, "retain": ["risk_map"], **slots}


def drive(engine: Engine) -> list[tuple[GridQuery, Grid, Proposal, Outcome]]:
    """Run the engine's trips as ``run_workload`` does, keeping each map the trip planned on."""
    trips = []
    for problem in engine.workload.queries(engine.ctx):
        planned_on = engine.ctx.world
        proposal = engine.solve(problem)
        outcome = engine.workload.execute(problem, proposal, engine.ctx)
        engine.learn(problem, proposal, outcome)
        trips.append((problem, planned_on, proposal, outcome))
    return trips


def true_grid(workload: Trips, outcome: Outcome) -> Grid:
    """The true world of one trip: the configured map with its unknown obstacles blocked."""
    true, blocked = workload.true_world, outcome.report.blocked
    risk = workload.configured.risk.copy()
    sites = [cell for i in blocked.sites for cell in true.sites[i].tolist()]
    for x, y in [*true.static.tolist(), *blocked.dynamic.tolist(), *sites]:
        risk[y, x] = 1.0
    return Grid(risk, corner_cutting=workload.configured.corner_cutting)


def learned(engine: Engine, problem: GridQuery, proposal: Proposal,
            outcome: Outcome) -> list[list[Any]]:
    """Take the learn step; the cells whose risk it changed in the run's world, as [x, y, new
    risk] in row-major order."""
    before = engine.ctx.world.risk
    engine.learn(problem, proposal, outcome)
    after = engine.ctx.world.risk
    return [[int(x), int(y), float(after[y, x])] for y, x in np.argwhere(after != before)]


def learn_map(ctx: Context, outcome: Outcome) -> None:
    """Learn the map of a bare context from one trip as ``risk_map`` does (its default
    hit_risk 0.5 and pass_relief 0.05), for tests that drive a workload without an engine."""
    if outcome.report is None:
        return
    risk = ctx.world.risk.copy()
    for x, y, value in risk_changes(ctx.world, outcome.report, 0.5, 0.05):
        risk[y, x] = value
    ctx.world = attrs.evolve(ctx.world, risk=risk)


def test_a_known_world_is_driven_as_planned(cbr_engine: Callable[..., Engine]) -> None:
    engine = cbr_engine(config({"count": 25, "min_distance": 5}))
    world = engine.ctx.world

    trips = drive(engine)

    assert len(trips) == 25
    for problem, _, proposal, outcome in trips:
        assert max(abs(a - b) for a, b in zip(problem.start, problem.goal, strict=True)) >= 5
        assert outcome.success
        assert outcome.solution.value == proposal.solution.value
        assert outcome.cost == pytest.approx(proposal.solution.cost)
        assert len(outcome.report.met) == outcome.report.replans == 0
        assert risk_changes(world, outcome.report, 0.5, 0.05) == []
    assert engine.ctx.world is world
    assert engine.casebase.get_meta(LEARNED_RISK, {}) == {}


def test_unknown_obstacles_are_met_learned_and_driven_around(
        cbr_engine: Callable[..., Engine]) -> None:
    engine = cbr_engine(config({"count": 40, "unknown_static": 25},
                               retain=[{"use": "risk_map", "hit_risk": 0.3}]))
    workload = engine.workload
    unknown = {tuple(cell) for cell in workload.true_world.static.tolist()}

    trips = drive(engine)

    assert sum(len(o.report.met) for *_, o in trips) > 0
    for problem, planned_on, _, outcome in trips:
        driven = outcome.solution.value
        assert driven[0] == list(problem.start)
        assert true_grid(workload, outcome).path_problems(driven) == []
        assert outcome.success == (driven[-1] == list(problem.goal))
        assert outcome.report.replans >= (len(outcome.report.met) > 0)
        risen = [(x, y, risk) for x, y, risk in risk_changes(planned_on, outcome.report, 0.3, 0.05)
                 if risk > planned_on.risk[y, x]]
        assert len(risen) == len(outcome.report.met)
        for x, y, risk in risen:
            assert (x, y) in unknown
            assert risk == pytest.approx(min(1.0, planned_on.risk[y, x] + 0.3))
    assert any(o.success and o.report.met for *_, o in trips)


@pytest.fixture
def corridor(tmp_path: Path) -> Path:
    risk = np.zeros((5, 7))
    risk[2, 5] = 0.08
    path = tmp_path / "corridor.npy"
    np.save(path, risk)
    return path


@pytest.mark.parametrize("hit_risk", [0.4, 0.6])
def test_a_cell_met_twice_adds_up_and_passed_cells_are_relieved(
        hit_risk: float, corridor: Path, cbr_engine: Callable[..., Engine]) -> None:
    engine = cbr_engine({"world": {"use": "map_file", "path": str(corridor)}, "solver": "astar",
                         "workload": {"use": "trips"},
                         "retain": [{"use": "risk_map", "hit_risk": hit_risk}]})
    engine.workload.true_world.place([(3, 2)], [])
    problem = GridQuery((0, 2), (6, 2))
    true = Grid(np.where(np.arange(7) == 3, 1.0, 0.0) * (np.arange(5)[:, None] == 2))

    outcomes, changes = [], []
    for _ in range(2):
        proposal = engine.solve(problem)
        assert [3, 2] in proposal.solution.value
        outcome = engine.workload.execute(problem, proposal, engine.ctx)
        outcomes.append(outcome)
        changes.append(learned(engine, problem, proposal, outcome))

    first, second = changes
    for outcome in outcomes:
        assert outcome.success
        assert len(outcome.report.met) == outcome.report.replans == 1
        assert true.path_problems(outcome.solution.value) == []
        assert [5, 2] in outcome.solution.value
    assert first == [[3, 2, hit_risk], [5, 2, pytest.approx(0.03)]]
    assert second == [[3, 2, min(1.0, 2 * hit_risk)], [5, 2, 0.0]]
    assert engine.ctx.world.risk[2, 3] == min(1.0, 2 * hit_risk)
    assert engine.ctx.world.passable[2, 3] == (2 * hit_risk < 1)
    assert engine.ctx.world.risk.sum() == min(1.0, 2 * hit_risk)


def test_an_unreachable_goal_fails_the_trip(corridor: Path,
                                            cbr_engine: Callable[..., Engine]) -> None:
    engine = cbr_engine({"world": {"use": "map_file", "path": str(corridor)}, "solver": "astar",
                         "workload": {"use": "trips"},
                         "retain": [{"use": "risk_map", "pass_relief": 0.0}]})
    engine.workload.true_world.place([(3, y) for y in range(5)], [])
    problem = GridQuery((0, 2), (6, 2))
    proposal = engine.solve(problem)

    outcome = engine.workload.execute(problem, proposal, engine.ctx)

    assert not outcome.success
    assert outcome.report.failure == "no path around" and not outcome.report.reached
    assert len(outcome.report.met) == 5
    assert outcome.solution.value[0] == [0, 2] and outcome.solution.value[-1][0] == 2
    changes = learned(engine, problem, proposal, outcome)
    assert sorted(c[:2] for c in changes) == [[3, y] for y in range(5)]
    assert engine.workload.execute(problem, Proposal(None, "none"), engine.ctx) == Outcome(False)


def test_a_bad_proposal_or_placement_is_refused(corridor: Path,
                                                cbr_engine: Callable[..., Engine]) -> None:
    engine = cbr_engine({"world": {"use": "map_file", "path": str(corridor)}, "solver": "astar",
                         "workload": {"use": "trips"}})
    problem = GridQuery((0, 2), (6, 2))
    jump = Proposal(Solution([[0, 2], [2, 2], [6, 2]]), "solver:astar")
    elsewhere = Proposal(Solution([[0, 2], [1, 2]]), "solver:astar")
    with pytest.raises(CbrError, match="not a move to an 8-neighbour"):
        engine.workload.execute(problem, jump, engine.ctx)
    with pytest.raises(CbrError, match=r"not from the trip's start \(0, 2\) to its goal"):
        engine.workload.execute(problem, elsewhere, engine.ctx)
    with pytest.raises(CbrError, match="distinct"):
        engine.workload.true_world.place([(1, 1)], [(1, 1)])
    with pytest.raises(CbrError, match="outside"):
        engine.workload.true_world.place([(9, 1)], [])
    with pytest.raises(CbrError, match="leave fewer than 2"):
        cbr_engine({"world": {"use": "map_file", "path": str(corridor)},
                    "workload": {"use": "trips", "unknown_static": 30, "unknown_dynamic": 4}})
    far = cbr_engine({"world": {"use": "map_file", "path": str(corridor)},
                      "workload": {"use": "trips", "min_distance": 7}})
    with pytest.raises(CbrError, match="at least min_distance 7 apart"):
        next(iter(far.workload.queries(far.ctx)))
    with pytest.raises(ConfigError, match="appear"):
        cbr_engine({"world": {"use": "map_file", "path": str(corridor)},
                    "workload": {"use": "trips", "appear": 1.5}})


def results(out_dir: Path) -> list[dict[str, str]]:
    with (out_dir / "results.csv").open(newline="", encoding="utf-8") as handle:
        return [{k: v for k, v in row.items() if not k.startswith("ms_")}
                for row in csv.DictReader(handle)]


def test_a_seed_repeats_the_run_and_path_quality_rates_the_planned_map(
        tmp_path: Path, cbr_engine: Callable[..., Engine]) -> None:
    data = config({"count": 30, "unknown_static": 15, "unknown_dynamic": 10, "appear": 0.5},
                  metrics=["path_quality"])
    run_workload(cbr_engine(data), tmp_path / "a")
    run_workload(cbr_engine(data), tmp_path / "b")
    other = cbr_engine({**data, "seed": 12})
    run_workload(other, tmp_path / "c")

    rows = results(tmp_path / "a")
    assert rows == results(tmp_path / "b")
    assert rows != results(tmp_path / "c")
    for row in rows:
        # A* plans the cheapest path on the map it plans on, which the metric measures against
        assert float(row["cost"]) == pytest.approx(float(row["optimal_cost"]))
        assert float(row["deviation"]) == pytest.approx(0.0, abs=1e-9)
        assert float(row["length"]) >= max(abs(int(row["q_start_x"]) - int(row["q_goal_x"])),
                                           abs(int(row["q_start_y"]) - int(row["q_goal_y"])))
        assert float(row["turns"]) >= 0
    assert any(float(r["outcome_cost"]) > float(r["solution_cost"]) for r in rows)


def test_path_quality_without_a_path_or_the_optimal_reference(
        corridor: Path, cbr_engine: Callable[..., Engine]) -> None:
    engine = cbr_engine({"world": {"use": "map_file", "path": str(corridor)},
                         "metrics": ["path_quality", {"use": "path_quality", "optimal": False}]})
    full, short = engine.metrics
    problem = GridQuery((0, 2), (6, 2))
    none = Proposal(None, "none")
    row = full.measure(problem, none, Outcome(False), engine.ctx)
    assert set(row) == {"length", "turns", "cost", "optimal_cost", "deviation"}
    assert math.isnan(row["cost"]) and math.isnan(row["deviation"])
    assert row["optimal_cost"] == pytest.approx(6.08)
    detour = Proposal(Solution([[0, 2], [1, 2], [2, 2], [3, 1], [4, 2], [5, 2], [6, 2]]), "x")
    row = short.measure(problem, detour, Outcome(True), engine.ctx)
    assert row == {"length": pytest.approx(4 + 2 * math.sqrt(2)), "turns": 3.0,
                   "cost": pytest.approx(4.08 + 2 * math.sqrt(2))}


def test_risk_map_keeps_what_the_robot_learned_for_the_next_run(
        tmp_path: Path, cbr_engine: Callable[..., Engine]) -> None:
    store = tmp_path / "cases.sqlite"
    data = config({"count": 30, "unknown_static": 20, "unknown_dynamic": 5},
                  casebase={"use": "sqlite", "path": str(store)}, retain=["risk_map"])
    first = cbr_engine(data)
    configured = first.world.risk
    drive(first)
    learned = first.casebase.get_meta(LEARNED_RISK)
    final = first.ctx.world.risk
    first.close()

    assert learned
    changed = np.argwhere(final != configured)
    assert sorted(learned) == sorted(f"{x},{y}" for y, x in changed)
    assert all(final[y, x] == learned[f"{x},{y}"] for y, x in changed)
    second = cbr_engine(data)
    assert np.array_equal(second.ctx.world.risk, final)
    assert np.array_equal(second.world.risk, configured)
    assert np.array_equal(second.workload.true_world.static, first.workload.true_world.static)
    second.close()

    smaller = {**data, "world": {**OFFICE, "width": 10, "height": 10}}
    with pytest.raises(CbrError, match=rf"case base {store} holds the cases of another world: "
                                       r"it records the world office 28x20.*office 10x10"):
        cbr_engine(smaller)
    # let carry over, a learned cell off the smaller map is still an error
    with pytest.raises(CbrError, match=rf"case base {store}: learned cell \(\d+, \d+\) is "
                                       r"outside the 10x10 world"):
        cbr_engine({**smaller, "casebase": {**data["casebase"], "worlds": "any"}})


def test_risk_map_drops_cells_back_at_their_configured_risk(
        corridor: Path, cbr_engine: Callable[..., Engine]) -> None:
    # a rise and a relief of the same size cancel out: the first trip meets (3, 2) and passes
    # (5, 2) (configured 0.08), the second passes (3, 2) and meets (5, 2), which leaves both
    # cells at their configured risk and out of the stored mapping
    engine = cbr_engine({"world": {"use": "map_file", "path": str(corridor)}, "solver": "astar",
                         "workload": {"use": "trips"},
                         "retain": [{"use": "risk_map", "hit_risk": 0.05, "pass_relief": 0.05}]})
    problem = GridQuery((0, 2), (6, 2))
    for blocked, stored in [((3, 2), {"3,2": 0.05, "5,2": 0.03}), ((5, 2), {})]:
        engine.workload.true_world.place([blocked], [])
        proposal = engine.solve(problem)
        outcome = engine.workload.execute(problem, proposal, engine.ctx)
        assert outcome.report.met == (blocked,)
        engine.learn(problem, proposal, outcome)
        assert engine.casebase.get_meta(LEARNED_RISK) == stored
    assert np.array_equal(engine.ctx.world.risk, engine.world.risk)


def small_grids() -> st.SearchStrategy[tuple[Grid, int, int, int]]:
    def build(width: int, height: int, blocked: list[bool], corner_cutting: bool,
              static: int, dynamic: int, seed: int) -> tuple[Grid, int, int, int]:
        risk = np.array(blocked[:width * height], dtype=float).reshape(height, width)
        free = int((risk < 1).sum())
        static, dynamic = min(static, max(free - 2, 0)), min(dynamic, max(free - 2 - static, 0))
        return Grid(risk, corner_cutting=corner_cutting), static, dynamic, seed

    return st.integers(3, 9).flatmap(lambda w: st.integers(3, 9).flatmap(lambda h: st.builds(
        build, st.just(w), st.just(h),
        st.lists(st.sampled_from([False, False, False, True]), min_size=w * h, max_size=w * h),
        st.booleans(), st.integers(0, 8), st.integers(0, 8), st.integers(0, 2**16))))


@settings(max_examples=60, deadline=None)
@given(small_grids())
def test_a_driven_path_is_valid_on_the_true_world(case: tuple[Grid, int, int, int]) -> None:
    grid, static, dynamic, seed = case
    if int(grid.passable.sum()) < 2:
        return
    # the replanner is the registry's astar
    ctx = Context(registry=current().registry, seed=seed, world=grid)
    workload = Trips(TripsOptions(count=8, unknown_static=static, unknown_dynamic=dynamic,
                                  replan_window=2), ctx)
    solver = AStar(NoOptions(), ctx)
    for problem in workload.queries(ctx):
        solution = solver.cbr_solve(problem, ctx)
        outcome = workload.execute(problem, Proposal(solution, "solver:astar"), ctx)
        learn_map(ctx, outcome)
        if solution is None:
            assert not outcome.success
            continue
        driven = outcome.solution.value
        assert true_grid(workload, outcome).path_problems(driven) == []
        assert driven[0] == list(problem.start)
        assert outcome.success == (driven[-1] == list(problem.goal))
        assert outcome.success == outcome.report.reached
        assert outcome.success or outcome.report.failure


def test_a_seed_gives_the_same_world_and_trips_as_before_sites_and_places() -> None:
    # recorded with the workload as it was before places, sites and collision_time were added
    ctx = Context(registry=current().registry, seed=11, world=generate("office", 28, 20, 11))
    workload = Trips(TripsOptions(count=3, unknown_static=3, unknown_dynamic=4), ctx)
    solver = AStar(NoOptions(), ctx)

    trips = []
    for problem in workload.queries(ctx):
        outcome = workload.execute(problem, Proposal(solver.cbr_solve(problem, ctx), "a*"), ctx)
        learn_map(ctx, outcome)
        trips.append((problem, outcome))

    assert workload.true_world.static.tolist() == [[26, 11], [11, 18], [13, 18]]
    assert workload.true_world.dynamic.tolist() == [[21, 11], [7, 14], [14, 14], [23, 0]]
    assert [(p.start, p.goal) for p, _ in trips] == [((22, 0), (26, 8)), ((22, 12), (23, 7)),
                                                      ((14, 16), (2, 0))]
    assert [o.report.blocked.dynamic.tolist() for _, o in trips] == [
        [[21, 11], [7, 14], [14, 14], [23, 0]], [[14, 14], [23, 0]], []]
    assert all(o.report.blocked.sites == () for _, o in trips)


@pytest.fixture
def walled(tmp_path: Path) -> Path:
    """An open 8x6 map but for one obstacle at (1, 1)."""
    risk = np.zeros((6, 8))
    risk[1, 1] = 1.0
    path = tmp_path / "walled.npy"
    np.save(path, risk)
    return path


def map_config(path: Path, **workload: Any) -> dict[str, Any]:
    return {"seed": 5, "world": {"use": "map_file", "path": str(path)}, "solver": "astar",
            "workload": {"use": "trips", **workload}, "retain": ["risk_map"]}


def test_trips_go_between_the_places(walled: Path, cbr_engine: Callable[..., Engine]) -> None:
    places = [(0, 0), (7, 5), (3, 2)]
    engine = cbr_engine(map_config(walled, count=80, places=[list(p) for p in places],
                                   unknown_static=12, min_distance=7))
    unknown = {tuple(c) for c in engine.workload.true_world.static.tolist()}

    trips = drive(engine)

    assert not unknown & set(places)
    pairs = [(problem.start, problem.goal) for problem, *_ in trips]
    assert all(start in places and goal in places and start != goal for start, goal in pairs)
    assert set(pairs) == set(itertools.permutations(places, 2))


@pytest.mark.parametrize(("places", "sites", "message"), [
    ([[0, 0], [8, 1]], [], r"places\[1\] \(8, 1\) is outside the 8x6 grid"),
    ([[0, 0], [1, 1]], [], r"places\[1\] \(1, 1\) is on an obstacle"),
    ([[0, 0], [2, 2], [0, 0]], [], r"places\[2\] \(0, 0\) repeats an earlier place"),
    ([[0, 0]], [], "places must hold at least 2 distinct cells for a trip's start and goal, "
                   "got 1"),
    ([[0, 0], [2, 2]], [{"cells": [[3, 3], [2, 2]], "appear": 0.5}],
     r"places\[1\] \(2, 2\) is on an unknown obstacle or a site"),
    (None, [{"cells": [[3, 3], [8, 3]], "appear": 0.5}],
     r"sites\[0\] cell \(8, 3\) is outside the 8x6 grid"),
    (None, [{"cells": [[3, 3]], "appear": 0.5}, {"cells": [[1, 1]], "appear": 0.5}],
     r"sites\[1\] cell \(1, 1\) is on an obstacle"),
    (None, [{"cells": [[3, 3], [3, 4]], "appear": 0.5}, {"cells": [[3, 4]], "appear": 0.5}],
     r"cell \(3, 4\) holds two unknown obstacles or sites"),
])
def test_bad_places_and_sites_are_refused(places: Any, sites: Any, message: str, walled: Path,
                                          cbr_engine: Callable[..., Engine]) -> None:
    with pytest.raises(CbrError, match=rf"workload 'trips': {message}"):
        cbr_engine(map_config(walled, places=places, sites=sites))


ROS_MAP = DATA / "ros" / "map_circular.yaml"


def test_places_and_sites_in_metres_are_the_cells_they_fall_in(
        cbr_engine: Callable[..., Engine]) -> None:
    # map_circular's origin is (-10, -10) m with 0.05 m cells and 384 rows: the point (x, y) m
    # falls in cell (floor((x + 10) / 0.05), 383 - floor((y + 10) / 0.05))
    metres = map_config(ROS_MAP, count=20, frame="map", places=[[-1.5, 0.5], [1.5, -0.5]],
                        sites=[{"cells": [[0.5, 1.5]], "appear": 0.5}], unknown_static=5)
    cells = map_config(ROS_MAP, count=20, places=[[170, 173], [230, 193]],
                       sites=[{"cells": [[210, 153]], "appear": 0.5}], unknown_static=5)
    by_metres, by_cells = cbr_engine(metres), cbr_engine(cells)
    assert by_metres.workload.places.tolist() == [[170, 173], [230, 193]]
    assert [s.tolist() for s in by_metres.workload.true_world.sites] == [[[210, 153]]]
    assert ([(q.start, q.goal) for q in by_metres.workload.queries(by_metres.ctx)]
            == [(q.start, q.goal) for q in by_cells.workload.queries(by_cells.ctx)])


DEPOT = DATA / "ros" / "depot.yaml"


@pytest.mark.parametrize(("map_file", "workload", "message"), [
    # depot: origin (0, 0), 0.05 m cells, 604x307: (-1, 2) m is column floor(-20) = -20 and row
    # 306 - floor(40) = 266
    (DEPOT, {"places": [[2, 2], [-1, 2]]},
     r"places\[1\] \(-1, 2\) m \[cell -20, 266\] is outside the 604x307 grid, which "
     r"covers x 0 to 30\.2 m and y 0 to 15\.35 m"),
    # the centre of cell (150, 75), a leg of a shelf: x 150.5 cells, y 307 - 75 - 0.5 cells
    (DEPOT, {"places": [[2, 2], [20, 3.5]],
             "sites": [{"cells": [[2.5, 2], [7.525, 11.575]], "appear": 0.5}]},
     r"sites\[0\]\.cells\[1\] \(7\.525, 11\.575\) m \[cell 150, 75\] is on an "
     r"obstacle"),
    # map_circular: origin (-10, -10) m, 384 rows; (0, 8) m is column 200, row 383 - 360 = 23,
    # in the unknown space around the mapped room (lethal without allow_unknown)
    (ROS_MAP, {"places": [[0, 8], [0, 0]], "world": {"allow_unknown": False}},
     r"places\[0\] \(0, 8\) m \[cell 200, 23\] is on an unknown cell \(lethal as unknown "
     r"space is not allowed; allow_unknown: true lets a planner cross it\)"),
])
def test_bad_places_in_metres_are_quoted_as_written_with_their_cell(
        map_file: Path, workload: dict[str, Any], message: str,
        cbr_engine: Callable[..., Engine]) -> None:
    config = map_config(map_file, frame="map",
                        **{key: value for key, value in workload.items() if key != "world"})
    config["world"] |= workload.get("world", {})
    with pytest.raises(CbrError, match=rf"^workload 'trips': {message}$"):
        cbr_engine(config)


def test_a_cell_of_unknown_space_says_how_to_cross_it(cbr_engine: Callable[..., Engine]) -> None:
    # map_circular's cell (0, 0), its top-left corner, is unknown: crossable by default, as in
    # Nav2's planners, lethal without allow_unknown
    config = map_config(ROS_MAP, places=[[0, 0], [200, 183]])
    config["world"]["allow_unknown"] = False
    with pytest.raises(CbrError, match=r"workload 'trips': places\[0\] \(0, 0\) is on an "
                                       r"unknown cell \(lethal as unknown space is not allowed; "
                                       r"allow_unknown: true lets"):
        cbr_engine(config)
    config["world"]["allow_unknown"] = True
    assert cbr_engine(config).workload.places.tolist() == [[0, 0], [200, 183]]


def test_random_trips_and_obstacles_keep_to_the_cells_the_map_knows(
        cbr_engine: Callable[..., Engine]) -> None:
    # map_circular is mostly unknown space, crossable by default: random trips and random
    # unknown obstacles are drawn from its known free cells only
    engine = cbr_engine(map_config(ROS_MAP, count=6, unknown_static=20, unknown_dynamic=5,
                                   min_distance=20))
    known = ~engine.ctx.world.unknown & engine.ctx.world.passable
    for x, y in [*engine.workload.true_world.static.tolist(),
                 *engine.workload.true_world.dynamic.tolist()]:
        assert known[y, x]
    trips = drive(engine)
    assert len(trips) == 6
    for problem, *_ in trips:
        for x, y in (problem.start, problem.goal):
            assert known[y, x]


def test_places_in_metres_need_a_map_frame_and_cells_whole_numbers(
        walled: Path, cbr_engine: Callable[..., Engine]) -> None:
    with pytest.raises(CbrError, match=r"workload 'trips': places are in metres \(frame: map\), "
                                       r"but the map has no metric frame"):
        cbr_engine(map_config(walled, frame="map", places=[[0, 0], [2, 2]]))
    with pytest.raises(CbrError, match=r"workload 'trips': places\[1\] \(2.5, 2\): expected a "
                                       r"cell of two whole numbers; for points in metres set "
                                       r"frame: map"):
        cbr_engine(map_config(walled, places=[[0, 0], [2.5, 2]]))


def test_sites_are_read_from_yaml_and_checked(walled: Path,
                                              cbr_engine: Callable[..., Engine]) -> None:
    data = yaml.safe_load(f"""
        world: {{use: map_file, path: {walled}}}
        workload:
          use: trips
          sites: [{{cells: [[3, 4], [3, 5]], appear: 0.8}}]
    """)
    engine = cbr_engine(data)
    assert engine.workload.options.sites == [Site(cells=[(3, 4), (3, 5)], appear=0.8)]
    assert [cells.tolist() for cells in engine.workload.true_world.sites] == [[[3, 4], [3, 5]]]
    for site, problem in [({"cells": [], "appear": 0.5},
                           r"workload\.sites\.0\.cells: must hold at least one cell"),
                          ({"cells": [[3, 4]], "appear": 1.5},
                           r"workload\.sites\.0\.appear: must be <= 1"),
                          # cells are numbers, whole ones with frame: cell (checked below)
                          ({"cells": [[3, "a"]], "appear": 0.5},
                           r"workload\.sites\.0\.cells\.0\.1: expected a number, got 'a'"),
                          ({"cells": [[3, 4.5]], "appear": 0.5},
                           r"workload 'trips': sites\[0\]\.cells\[0\] \(3, 4\.5\): expected a "
                           r"cell of two whole numbers"),
                          ({"cells": [[3, 4]]}, r"workload\.sites\.0\.appear: required"),
                          (0.3, r"workload\.sites\.0: expected a mapping with keys cells, "
                                r"appear, got 0\.3")]:
        data["workload"]["sites"] = [site]
        with pytest.raises(CbrError, match=problem):
            cbr_engine(data)


def test_a_site_blocks_all_its_cells_together_as_often_as_it_appears(
        walled: Path, cbr_engine: Callable[..., Engine]) -> None:
    door = [[4, 1], [4, 2], [4, 3], [4, 4]]
    engine = cbr_engine(map_config(walled, count=40, sites=[
        {"cells": door, "appear": 1.0}, {"cells": [[6, 0], [6, 1]], "appear": 0.0}]))
    workload = engine.workload

    trips = drive(engine)

    for _, _, _, outcome in trips:
        assert outcome.report.blocked.sites == (0,)
        true = workload.true_world.passable(outcome.report.blocked)
        assert not true[[y for _, y in door], [x for x, _ in door]].any()
        assert true[[0, 1], [6, 6]].all()
        assert true_grid(workload, outcome).path_problems(outcome.solution.value) == []
        assert not {tuple(c) for c in door} & {tuple(c) for c in outcome.solution.value}
    assert any(o.report.met for *_, o in trips)


def test_sites_appear_independently_with_their_own_probability(
        corridor: Path, cbr_engine: Callable[..., Engine]) -> None:
    engine = cbr_engine({"world": {"use": "map_file", "path": str(corridor)},
                         "workload": {"use": "trips", "sites": [
                             {"cells": [[5, 4]], "appear": 0.3},
                             {"cells": [[6, 4], [6, 3]], "appear": 0.6}]},
                         "retain": [{"use": "risk_map", "pass_relief": 0.0}]})
    problem = GridQuery((0, 0), (1, 0))
    proposal = Proposal(Solution([[0, 0], [1, 0]]), "fixed")
    n = 4000

    drawn = np.zeros((n, 2), dtype=bool)
    for i in range(n):
        outcome = engine.workload.execute(problem, proposal, engine.ctx)
        present = list(outcome.report.blocked.sites)
        drawn[i, present] = True

    # each frequency within 5 binomial standard deviations of its probability
    for frequency, p in [(drawn[:, 0].mean(), 0.3), (drawn[:, 1].mean(), 0.6),
                         (drawn.all(axis=1).mean(), 0.3 * 0.6)]:
        assert abs(frequency - p) < 5 * math.sqrt(p * (1 - p) / n)


def test_travel_time_adds_the_time_lost_at_each_obstacle_met(
        corridor: Path, cbr_engine: Callable[..., Engine]) -> None:
    engine = cbr_engine({"world": {"use": "map_file", "path": str(corridor)}, "solver": "astar",
                         "workload": {"use": "trips", "collision_time": 2.5}})
    engine.workload.true_world.place([(3, 2)], [])
    problem = GridQuery((0, 2), (6, 2))

    outcome = engine.workload.execute(problem, engine.solve(problem), engine.ctx)

    # stopped at (2, 2) by (3, 2), the robot rejoins its path at (4, 2) by the cheapest way
    # without cutting the obstacle's corners: one row up or down, 3 steps across and back
    around = [[[2, row], [3, row], [4, row]] for row in (1, 3)]
    assert outcome.solution.value in [[[0, 2], [1, 2], [2, 2], *cells, [4, 2], [5, 2], [6, 2]]
                                      for cells in around]
    assert len(outcome.report.met) == 1
    assert outcome.report.travel_time == pytest.approx(8 + 2.5)


def test_meeting_one_cell_of_a_blocked_site_shows_the_whole_site(
        corridor: Path, cbr_engine: Callable[..., Engine]) -> None:
    # a door two cells wide across rows 2-3 of column 3: met at (3, 2), it is seen shut whole,
    # so the robot stops once and goes round through row 1 or row 4 without trying (3, 3)
    engine = cbr_engine({"world": {"use": "map_file", "path": str(corridor)}, "solver": "astar",
                         "workload": {"use": "trips", "collision_time": 2.5, "sites": [
                             {"cells": [[3, 2], [3, 3]], "appear": 1.0}]}})
    problem = GridQuery((0, 2), (6, 2))

    outcome = engine.workload.execute(problem, engine.solve(problem), engine.ctx)

    assert outcome.success
    assert len(outcome.report.met) == 2
    assert outcome.report.replans == 1
    assert outcome.report.stops == ((2, 2),)
    driven = outcome.solution.value
    assert [3, 2] not in driven and [3, 3] not in driven
    assert outcome.report.travel_time == pytest.approx(path_length(driven) + 2.5)


def test_the_workload_seed_gives_the_same_trips_whatever_the_other_components(
        walled: Path, cbr_engine: Callable[..., Engine],
        cbr_plugins: Callable[..., Plugins]) -> None:
    cbr_plugins(entry_points=True)
    sites = [{"cells": [[4, 2], [4, 3]], "appear": 0.5}]
    config = map_config(walled, count=30, places=[[0, 0], [7, 5], [6, 0]], sites=sites,
                        unknown_dynamic=3, seed=3)
    unseeded = {**config, "workload": {**config["workload"], "seed": None}}
    plain = cbr_engine(config)
    # a reviser and a retriever built before the workload take generators from the run's seed
    extra = {"retrieve": {"use": "path_cases", "explore": 0.5}, "reuse": "path_cases",
             "retain": ["risk_map", "path_cases"], "casebase": "memory"}
    learning = cbr_engine({**config, **extra})

    def trips(engine: Engine) -> list[Any]:
        return [(problem.start, problem.goal, outcome.report.blocked.dynamic.tolist(),
                 list(outcome.report.blocked.sites)) for problem, _, _, outcome in drive(engine)]

    assert (plain.workload.true_world.dynamic.tolist()
            == learning.workload.true_world.dynamic.tolist())
    assert trips(plain) == trips(learning)
    # without it the retriever's generator, spawned first, shifts the workload's
    assert trips(cbr_engine(unseeded)) != trips(cbr_engine({**unseeded, **extra}))


def test_the_trip_seed_changes_the_trips_not_the_true_world(
        walled: Path, cbr_engine: Callable[..., Engine],
        cbr_plugins: Callable[..., Plugins]) -> None:
    """Robots of one office, each with its own trip_seed: the same unknown obstacles, other
    trips; a trip_seed equal to the seed is the seed's own trips."""
    cbr_plugins(entry_points=True)
    config = map_config(walled, count=12, unknown_static=3, unknown_dynamic=3, seed=3)

    def with_trips(trip_seed: int | None) -> Engine:
        return cbr_engine({**config, "workload": {**config["workload"], "trip_seed": trip_seed}})

    def trips(engine: Engine) -> list[Any]:
        return [(problem.start, problem.goal) for problem, _, _, _ in drive(engine)]

    engines = {seed: with_trips(seed) for seed in (None, 3, 4, 5)}
    worlds = {seed: (engine.workload.true_world.static.tolist(),
                     engine.workload.true_world.dynamic.tolist())
              for seed, engine in engines.items()}
    assert len({repr(world) for world in worlds.values()}) == 1
    found = {seed: trips(engine) for seed, engine in engines.items()}
    assert found[None] == found[3]
    assert len({repr(found[seed]) for seed in (3, 4, 5)}) == 3
    assert trips(with_trips(4)) == found[4]


# --- what one trip changes, and learning in the learn step --------------------------------------


def test_risk_changes_of_a_hand_worked_trip() -> None:
    # on a 5x3 map the robot drives along row 1, is stopped at (2, 1) by a door of (3, 1) and
    # (3, 0), seen whole, and goes round through row 2 to (4, 1)
    risk = np.zeros((3, 5))
    risk[1, 1], risk[2, 2], risk[1, 4], risk[0, 3] = 0.2, 0.03, 0.05, 0.9
    grid = Grid(risk)
    driven = np.array([[0, 1], [1, 1], [2, 1], [2, 2], [3, 2], [4, 2], [4, 1]])
    report = DriveReport(driven, met=((3, 1), (3, 0)), stops=((2, 1),),
                         blocked=Blocked(np.zeros((0, 2), dtype=np.int64), (0,)),
                         travel_time=path_length(driven) + 5.0)

    # passed cells lose 0.05 (floored at 0, exactly 0 when the relief cancels the risk), met
    # cells gain 0.5 (capped at 1); cells left where they were are not listed; row-major order
    assert risk_changes(grid, report, 0.5, 0.05) == [
        [3, 0, 1.0], [1, 1, 0.15], [3, 1, 0.5], [4, 1, 0.0], [2, 2, 0.0]]
    assert risk_changes(grid, report, 0.25, 0.0) == [[3, 0, 1.0], [3, 1, 0.25]]
    assert risk_changes(grid, report, 0.0, 0.0) == []
    assert np.array_equal(grid.risk, risk)  # a pure function: the grid is left as it was
    # a cell passed twice is relieved once
    twice = attrs.evolve(report, driven=np.concatenate((driven, driven[::-1])))
    assert risk_changes(grid, twice, 0.5, 0.05) == risk_changes(grid, report, 0.5, 0.05)
    # a relief of 0 leaves an unrounded configured risk alone
    odd = Grid(np.full((3, 5), 0.1 + 0.2))
    assert risk_changes(odd, attrs.evolve(report, met=()), 0.5, 0.0) == []


def test_without_risk_map_a_run_does_not_learn_its_map(
        corridor: Path, cbr_engine: Callable[..., Engine]) -> None:
    engine = cbr_engine({"world": {"use": "map_file", "path": str(corridor)}, "solver": "astar",
                         "workload": {"use": "trips"}})
    engine.workload.true_world.place([(3, 2)], [])
    problem = GridQuery((0, 2), (6, 2))
    world = engine.ctx.world

    for _ in range(2):
        proposal = engine.solve(problem)
        outcome = engine.workload.execute(problem, proposal, engine.ctx)
        assert outcome.report.met == ((3, 2),)
        assert engine.ctx.stash[PLANNED_WORLD] is world
        engine.learn(problem, proposal, outcome)
        assert engine.ctx.world is world
    assert engine.casebase.get_meta(LEARNED_RISK, None) is None


class FailingForget:
    """A test plugin: its forgetter ``fail_when_armed`` raises while ``armed`` is set, so the
    learn step it runs in rolls back."""

    def __init__(self) -> None:
        self.armed = False

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("forgetter", "fail_when_armed", lambda options, ctx: _ArmedForgetter(self),
                     doc="Raises while the test arms it.")


class _ArmedForgetter:
    def __init__(self, plugin: FailingForget) -> None:
        self.plugin = plugin

    @hookimpl
    def cbr_forget(self, casebase: CaseStore) -> None:
        if self.plugin.armed:
            raise RuntimeError("forgetting failed")


def test_a_learn_step_that_rolls_back_leaves_the_learned_map_as_it_was(
        corridor: Path, tmp_path: Path, cbr_engine: Callable[..., Engine],
        cbr_plugins: Callable[..., Plugins]) -> None:
    failing = FailingForget()
    cbr_plugins(("failing", failing), entry_points=True,
                environ={"CBR_PLUGINS": "core,stores,grid,solvers,failing"})
    engine = cbr_engine({"world": {"use": "map_file", "path": str(corridor)}, "solver": "astar",
                         "workload": {"use": "trips"},
                         "casebase": {"use": "sqlite", "path": str(tmp_path / "cases.sqlite")},
                         "retain": [{"use": "risk_map", "hit_risk": 0.3}],
                         "forget": ["fail_when_armed"]})
    engine.workload.true_world.place([(3, 2)], [])
    problem = GridQuery((0, 2), (6, 2))

    def trip() -> tuple[Proposal, Outcome]:
        proposal = engine.solve(problem)
        return proposal, engine.workload.execute(problem, proposal, engine.ctx)

    proposal, outcome = trip()
    engine.learn(problem, proposal, outcome)
    stored = {"3,2": 0.3, "5,2": 0.03}
    assert engine.casebase.get_meta(LEARNED_RISK) == stored
    learned_map = engine.ctx.world
    assert learned_map.risk[2, 3] == 0.3

    failing.armed = True
    proposal, outcome = trip()
    assert outcome.report.met == ((3, 2),)  # the step would raise (3, 2) to 0.6
    with pytest.raises(PhaseError, match="phase 'forget'"):
        engine.learn(problem, proposal, outcome)
    # the learned map is loaded anew from what the case base holds: the map before the step
    assert np.array_equal(engine.ctx.world.risk, learned_map.risk)
    assert engine.casebase.get_meta(LEARNED_RISK) == stored

    failing.armed = False
    again, outcome = trip()
    planned_on = engine.ctx.stash[PLANNED_WORLD]
    assert np.array_equal(planned_on.risk, learned_map.risk)  # planned on the unchanged map
    assert again.solution.value == proposal.solution.value
    engine.learn(problem, again, outcome)
    assert engine.ctx.world.risk[2, 3] == pytest.approx(0.6)  # one more hit, not two
    assert engine.casebase.get_meta(LEARNED_RISK) == {"3,2": pytest.approx(0.6), "5,2": 0.0}


def test_what_another_process_learned_reaches_the_planners_at_the_next_query(
        corridor: Path, tmp_path: Path, cbr_engine: Callable[..., Engine]) -> None:
    shared = {"use": "sqlite", "path": str(tmp_path / "shared.sqlite")}
    robots = [cbr_engine({"world": {"use": "map_file", "path": str(corridor)}, "solver": "astar",
                          "workload": {"use": "trips"}, "casebase": shared,
                          "retain": [{"use": "risk_map", "hit_risk": 1.0, "pass_relief": 0.0}]})
              for _ in range(2)]
    first, second = robots
    first.workload.true_world.place([(3, 2)], [])
    problem = GridQuery((0, 2), (6, 2))
    assert [3, 2] in second.solve(problem).solution.value
    proposal = first.solve(problem)
    first.learn(problem, proposal, first.workload.execute(problem, proposal, first.ctx))
    assert first.ctx.world.risk[2, 3] == 1.0  # the first robot met it: an obstacle now

    replanned = second.solve(problem)  # the second never met it, but shares the case base

    assert second.ctx.world.risk[2, 3] == 1.0
    assert [3, 2] not in replanned.solution.value
    assert second.ctx.mirror.reloads == 1
