"""The closed loop in the 2D world: the ``trials`` workload consults the engine from inside a
running simulation and learns each decision when its action ends.

The world is scenario 2 of 002 (a V of two linear obstacles open towards the start, the target
behind its apex), where the potential field alone is trapped. A small CBR agent, test-only,
rescues the robot: consulted when the progress monitor reports it blocked, its solver diverts
it to a point beside the V, and its case base remembers where a diversion that was reached
began, so that a later trial blocked near there diverts from the case base.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any

import pytest
import yaml

import cbr_world2d
import cbrcore.builtins
from cbr_world2d.actions import REACHED, TRIAL_ENDED, ActionReport, Divert
from cbr_world2d.workload import Situation
from cbrcore import Case, Engine, Match, Outcome, Retrieval, Solution, hookimpl
from cbrcore.casebase.store import CaseStore
from cbrcore.config import parse_config
from cbrcore.context import Context
from cbrcore.errors import CbrError, PluginError
from cbrcore.plugins import Plugins, load_plugins
from cbrcore.registry import Registry
from cbrcore.run import run_workload

WORLDS = Path(cbr_world2d.__file__).parent / "worlds"
KIND = "divert"
NEAR = 1.0
"""How close, in metres, a stored diversion's start must be to be reused."""
ASIDE = (3.5, -1.0)
"""Where the solver diverts the robot: metres to its left and ahead, square to and along the
direction of its target."""


class NearHere:
    """Stored diversions that began within NEAR of the robot, nearest first."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_retrieve(self, problem: Situation, casebase: CaseStore) -> Retrieval:
        scored = []
        for case in casebase.cases(KIND):
            x, y = case.problem
            gap = math.dist((x, y), (problem.pose.x, problem.pose.y))
            if gap <= NEAR:
                scored.append(Match(case, 1.0 - gap / NEAR, {"distance": gap}))
        return Retrieval(tuple(sorted(scored, key=lambda m: -m.similarity)))


class DivertThere:
    """Divert to the stored point."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_reuse(self, retrieval: Retrieval) -> Solution:
        case = retrieval.matches[0].case
        return Solution(Divert(*case.solution), cases=(case.id,))


class Aside:
    """The model-based answer: the point ASIDE of the robot, out past the end of the obstacle
    in the way."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_solve(self, problem: Situation) -> Solution:
        pose, (tx, ty) = problem.pose, problem.target
        heading = math.atan2(ty - pose.y, tx - pose.x)
        left, ahead = ASIDE
        return Solution(Divert(pose.x + ahead * math.cos(heading) - left * math.sin(heading),
                               pose.y + ahead * math.sin(heading) + left * math.cos(heading)))


class RememberReached:
    """Remember a diversion that was reached, by where it began, unless one began near there."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_retain(self, problem: Situation, solution: Solution, outcome: Outcome,
                   casebase: CaseStore) -> None:
        here = (problem.pose.x, problem.pose.y)
        known = any(math.dist(here, c.problem) <= NEAR for c in casebase.cases(KIND))
        if outcome.success and not known:
            action = solution.value
            casebase.add(Case([round(v, 4) for v in here],
                              [round(action.x, 4), round(action.y, 4)], kind=KIND))


LEARNED: list[tuple[Situation, Outcome]] = []
"""What the ``record`` retainer saw."""


class Record:
    """Keep every learned situation and outcome in LEARNED."""

    def __init__(self, options: object, ctx: Context) -> None:
        LEARNED.clear()

    @hookimpl
    def cbr_retain(self, problem: Situation, outcome: Outcome) -> None:
        LEARNED.append((problem, outcome))


class Wrong:
    """A solver whose solution is no action of the 2D world."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_solve(self) -> Solution:
        return Solution((1.0, 2.0))


class Agent:
    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("retainer", "record", Record)
        registry.add("solver", "wrong", Wrong)
        registry.add("retriever", "near_here", NearHere)
        registry.add("reuser", "divert_there", DivertThere)
        registry.add("solver", "aside", Aside)
        registry.add("retainer", "remember_reached", RememberReached)


CONFIG = f"""\
seed: 3
casebase: memory
world: {{use: world2d_file, path: {WORLDS / 'scenario2.yaml'}}}
pilot: potential_field
workload:
  use: trials
  trials: [{{start: start, target: target}}]
  repeat: 2
  timeout: 90
  consult_on: [blocked]
retrieve: near_here
reuse: divert_there
solver: aside
retain: [remember_reached]
"""


@pytest.fixture(scope="module")
def plugins() -> Plugins:
    return load_plugins(extra=[("core", cbrcore.builtins), ("world2d", cbr_world2d),
                               ("agent", Agent())], entry_points=False, environ={})


def engine_for(plugins: Plugins, out_dir: Path | None, config: dict[str, Any] | None = None,
               **changes: Any) -> Engine:
    data = {**yaml.safe_load(CONFIG), **(config or {})}
    data["workload"].update(changes)
    return Engine(parse_config(data, plugins.registry), plugins=plugins, out_dir=out_dir)


def rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


@pytest.fixture(scope="module")
def run(plugins: Plugins, tmp_path_factory: pytest.TempPathFactory
        ) -> tuple[Path, dict[str, Any], list[Case]]:
    out = tmp_path_factory.mktemp("run")
    with engine_for(plugins, out) as engine:
        summary = run_workload(engine, out)
        cases = list(engine.casebase.cases(KIND))
    return out, summary, cases


def test_the_agent_is_consulted_when_blocked_and_its_diversion_gets_the_robot_out(
        run: tuple[Path, dict[str, Any], list[Case]]) -> None:
    out, _, _ = run
    decisions = rows(out / "results.csv")
    trials = rows(out / "trials.csv")
    assert [t["success"] for t in trials] == ["True", "True"]
    first = [d for d in decisions if d["q_trial"] == "0"]
    assert first[0]["source"] == "solver:aside"
    assert first[0]["q_trigger"] == "blocked"
    assert first[0]["success"] == "True"


def test_the_second_trial_diverts_from_the_case_base(
        run: tuple[Path, dict[str, Any], list[Case]]) -> None:
    out, _, cases = run
    decisions = rows(out / "results.csv")
    second = [d for d in decisions if d["q_trial"] == "1"]
    assert second and second[0]["source"] == "casebase"
    assert second[0]["success"] == "True"
    assert len(cases) >= 1
    # the case remembers where the first trial's reached diversion began
    first = next(d for d in decisions if d["q_trial"] == "0" and d["success"] == "True")
    assert math.dist(cases[0].problem, (float(first["q_x"]), float(first["q_y"]))) < 1e-3


def test_every_consultation_is_learned_once_with_what_its_action_did(
        plugins: Plugins, tmp_path: Path) -> None:
    with engine_for(plugins, tmp_path, {"retain": ["record"], "solver": "rescuer"}, repeat=1,
                    consult_on=["blocked", "landmarks", "period"], period=5.0) as engine:
        run_workload(engine, tmp_path)
    decisions = rows(tmp_path / "results.csv")
    assert {d["q_trigger"] for d in decisions} >= {"blocked", "landmarks", "period"}
    # the rescuer solver answers a blocked robot only; a decision without an action has
    # nothing to retain
    acted = [d for d in decisions if d["source"] != "none"]
    assert {d["q_trigger"] for d in acted} == {"blocked"}
    assert len(LEARNED) == len(acted) >= 2
    for problem, outcome in LEARNED:
        report = outcome.report
        assert isinstance(report, ActionReport)
        assert report.started == pytest.approx(problem.t)
        assert report.ended >= report.started
        assert outcome.success == (report.reason == REACHED)
        assert outcome.cost == pytest.approx(report.ended - report.started, abs=1e-3)
        assert (report.trial_success is None) == (report.reason != TRIAL_ENDED)
    json.dumps([problem.to_json() for problem, _ in LEARNED])  # plain data a case can hold
    sightings = [s for problem, _ in LEARNED for s in problem.to_json()["sightings"]]
    assert sightings and {s["id"] for s in sightings} <= {"l1", "l2", "l3"}


def test_a_solution_that_is_not_an_action_is_refused(plugins: Plugins, tmp_path: Path) -> None:
    with (engine_for(plugins, tmp_path, {"solver": "wrong"}) as engine,
          pytest.raises(PluginError, match="a tuple, expected an action of the 2D world")):
        run_workload(engine, tmp_path)


def test_trials_need_a_pilot(plugins: Plugins) -> None:
    data = yaml.safe_load(CONFIG)
    del data["pilot"]
    with pytest.raises(CbrError, match="name one in the configuration's 'pilot' slot"):
        Engine(parse_config(data, plugins.registry), plugins=plugins)


def test_a_start_inside_an_obstacle_is_named(plugins: Plugins) -> None:
    with pytest.raises(CbrError, match=r"workload\.trials\.0\.start 6,4 .*l2"):
        engine_for(plugins, None, trials=[{"start": "6,4", "target": "target"}])
