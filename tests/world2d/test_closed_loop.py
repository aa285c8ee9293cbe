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
import re
from pathlib import Path
from typing import Any

import pytest
import yaml

import cbr_world2d
import cbrcore.builtins
from cbr_world2d.actions import REACHED, TRIAL_ENDED, ActionReport, Divert
from cbr_world2d.workload import Situation
from cbr_world2d.worldfile import load_world
from cbrcore import Case, Engine, Match, Outcome, Retrieval, Solution, hookimpl
from cbrcore.casebase.store import CaseStore
from cbrcore.config import parse_config
from cbrcore.context import Context
from cbrcore.errors import CbrError, PluginError
from cbrcore.plugins import Plugins, load_plugins
from cbrcore.registry import Registry
from cbrcore.run import run_workload
from repo_paths import ROOT

WORLDS = Path(cbr_world2d.__file__).parent / "worlds"
PAGE = ROOT / "docs" / "world2d-engine.md"
"""The 2D world page, whose section on a family's components shows this agent's run."""
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
                    consult_on=["blocked", "landmarks", "heading", "period"],
                    period=5.0) as engine:
        run_workload(engine, tmp_path)
    decisions = rows(tmp_path / "results.csv")
    assert {d["q_trigger"] for d in decisions} >= {"blocked", "landmarks", "heading", "period"}
    # the rescuer solver answers a blocked robot only; a decision without an action reaches
    # the retainers too, at once, as no action
    acted = [d for d in decisions if d["source"] != "none"]
    assert {d["q_trigger"] for d in acted} == {"blocked"}
    assert len(LEARNED) == len(decisions)
    assert sum(o.report.reason != "no_action" for _, o in LEARNED) == len(acted) >= 2
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


# --- the 2D world page shows this run ----------------------------------------------------------


def _shown_files() -> dict[str, list[str]]:
    """The CSV files the page shows of this run: each file's name and the lines shown of it."""
    blocks = re.findall(r"^```text\n(trials\.csv\n.*?)^```$", PAGE.read_text(encoding="utf-8"),
                        re.S | re.M)
    assert len(blocks) == 1, "one text block on the page shows trials.csv and results.csv"
    files = {}
    for part in blocks[0].strip().split("\n\n"):
        name, *lines = part.splitlines()
        files[name] = lines
    return files


def _as_shown(actual: list[str], shown: list[str]) -> list[str]:
    """``actual``'s lines cut where the page cuts its lines short with ``...``."""
    return [line[:len(cut) - len("...")] + "..." if cut.endswith(",...") else line
            for line, cut in zip(actual, shown, strict=True)]


def test_the_2d_world_page_shows_the_rows_of_this_run(
        run: tuple[Path, dict[str, Any], list[Case]]) -> None:
    out, _, _ = run
    shown = _shown_files()
    assert set(shown) == {"trials.csv", "results.csv"}
    for name, lines in shown.items():
        actual = (out / name).read_text(encoding="utf-8").splitlines()
        assert len(actual) == len(lines), f"the page shows every line of {name}"
        assert _as_shown(actual, lines) == lines


def test_the_2d_world_page_quotes_where_and_when_the_robot_is_diverted(
        run: tuple[Path, dict[str, Any], list[Case]]) -> None:
    """'in the first trial the robot is blocked in the V at t = 20.6 s, the solver diverts it to
    (3.98, 7.53), beyond `l1`'s end of the V'"""
    out, _, cases = run
    first, second = (next(d for d in rows(out / "results.csv") if d["q_trial"] == trial)
                     for trial in ("0", "1"))
    # the diversion the robot was sent to and reached, as the case base keeps it
    x, y = cases[0].solution
    # ASIDE of the pose the page's results.csv gives, towards the target (8, 4): the same point
    pose = float(first["q_x"]), float(first["q_y"])
    heading = math.atan2(4.0 - pose[1], 8.0 - pose[0])
    left, ahead = ASIDE
    assert math.dist((x, y), (pose[0] + ahead * math.cos(heading) - left * math.sin(heading),
                              pose[1] + ahead * math.sin(heading) + left * math.cos(heading))
                     ) < 0.01
    text = " ".join(PAGE.read_text(encoding="utf-8").split())
    assert (f"blocked in the V at t = {float(first['q_t']):.1f} s, the solver diverts it to "
            f"({x:.2f}, {y:.2f}), beyond `l1`'s end of the V") in text
    world = load_world(WORLDS / "scenario2.yaml")
    marks = {mark.id: (mark.x, mark.y) for mark in world.landmarks}
    # beyond l1's end: nearer l1 than any other landmark, and farther from the apex l2 than l1
    assert min(marks, key=lambda k: math.dist((x, y), marks[k])) == "l1"
    assert math.dist((x, y), marks["l2"]) > math.dist(marks["l1"], marks["l2"])
    assert "the second trial is blocked at the same spot" in text
    assert math.dist(pose, (float(second["q_x"]), float(second["q_y"]))) <= NEAR


def test_the_2d_world_page_states_the_configuration_of_this_run() -> None:
    text = " ".join(PAGE.read_text(encoding="utf-8").split())
    config = yaml.safe_load(CONFIG)
    workload = config["workload"]
    for setting in (f"casebase: {config['casebase']}", f"repeat: {workload['repeat']}",
                    f"timeout: {workload['timeout']}",
                    f"consult_on: [{', '.join(workload['consult_on'])}]",
                    f"seed: {config['seed']}", f"retrieve: {config['retrieve']}",
                    f"reuse: {config['reuse']}", f"solver: {config['solver']}",
                    f"retain: [{', '.join(config['retain'])}]"):
        assert f"`{setting}`" in text, setting
