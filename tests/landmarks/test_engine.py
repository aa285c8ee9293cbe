"""Landmark situations through the engine (``cbr_landmarks`` with ``cbrcore``'s Engine).

A situation the robot got out of with the ``landmark_detour`` solver's diverting target is
retained, and found again the next time the same layout is in view, its target laid where the
learned one was; reused cases are credited and blamed by how their target went, and forgotten
once they fail more than they help; the trials workload asks nothing while a diverting target
is set (002 section 3.3); and bad input (a malformed case in a case base, a NaN in a sighting)
stops a run with an error naming the case and the field, storing nothing.

Situations are observed without noise from the start of 002's scenario worlds, as the hand-made
cases are (:func:`cbr_landmarks.handmade.paper_case`). The shipped configs/landmarks.yaml is
run by tests/docs/test_repository.py.
"""

from __future__ import annotations

import csv
import itertools
import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import attrs
import numpy as np
import pytest
import yaml

import cbr_landmarks
import cbr_world2d
import cbrcore.builtins
from cbr_landmarks.case import SITUATION, LandmarkCase
from cbr_landmarks.experiments.common import robot_config
from cbr_landmarks.experiments.scenarios import world_path
from cbr_landmarks.handmade import shipped_path
from cbr_world2d.actions import GIVEN_UP, REACHED, TRIAL_ENDED, ActionReport, Divert
from cbr_world2d.fuzzy import unchecked
from cbr_world2d.robot import RobotState
from cbr_world2d.sensors import Camera, Sensors, Sighting
from cbr_world2d.workload import Situation, situation
from cbr_world2d.worldfile import load_world
from cbrcore.casebase.exchange import document_of, dump_document, read_document
from cbrcore.config import parse_config
from cbrcore.engine import Engine
from cbrcore.errors import CbrError
from cbrcore.model import Outcome, Proposal
from cbrcore.plugins import Plugins, load_plugins
from cbrcore.run import run_workload
from cbrcore.testing import CliResult


@pytest.fixture(scope="module")
def plugins() -> Plugins:
    return load_plugins(extra=[("core", cbrcore.builtins), ("world2d", cbr_world2d),
                               ("landmarks", cbr_landmarks)], entry_points=False, environ={})


def world_ref(scenario: str) -> dict[str, Any]:
    return {"use": "world2d_file", "path": str(world_path(scenario))}


def engine_for(plugins: Plugins, robot: str, scenario: str = "scenario2",
               out_dir: Path | None = None, workload: dict[str, Any] | None = None,
               **changes: Any) -> Engine:
    """An engine configured as the experiments configure ``robot`` in ``scenario``, its trials
    workload changed by ``workload`` (after the robot's own settings) and the configuration's
    top level by ``changes``."""
    trials = {"trials": [{"start": "start", "target": "target"}]}
    config = robot_config(robot, world_ref(scenario), trials, seed=0)
    if config.get("solver") == "landmark_detour":
        # the situations below are seen from the start, 5 m from the V: a chain that far
        # still counts as the one in the way
        config["solver"] = {"use": "landmark_detour", "reach": 10.0}
    config.update(changes)
    config["workload"] = {**config["workload"], **(workload or {})}
    return Engine(parse_config(config, plugins.registry), plugins=plugins, out_dir=out_dir)


def observe(scenario: str, trigger: str, turn: float = 0.0, t: float = 0.0) -> Situation:
    """What the robot sees, without noise, at the start of ``scenario`` facing its target
    turned by ``turn`` radians."""
    world = load_world(world_path(scenario))
    start, target = world.places["start"], world.places["target"]
    heading = math.atan2(target[1] - start[1], target[0] - start[0]) + turn
    sensors = Sensors(sonar=None, camera=Camera(fov=math.pi, noise=0.0))
    obs = sensors.observe(RobotState(start[0], start[1], heading), world, 0.0, False,
                          np.random.default_rng(0))
    return attrs.evolve(situation(world, 0, trigger, obs, target), t=t)


def report(reason: str, started: float = 0.0, trial_success: bool | None = None
           ) -> ActionReport:
    return ActionReport(reason, started, started + 20.0, 1.0, 0, trial_success)


def outcome(reason: str, started: float = 0.0, trial_success: bool | None = None) -> Outcome:
    success = reason == REACHED if trial_success is None else trial_success
    return Outcome(success, cost=20.0, report=report(reason, started, trial_success))


def learn_a_detour(engine: Engine, turn: float = 0.0) -> Proposal:
    """Block the robot at scenario 2's start, divert it with the solver and learn that the
    diversion got it out; the solver's proposal."""
    blocked = observe("scenario2", "blocked", turn)
    proposal = engine.solve(blocked)
    assert proposal.source == "solver:landmark_detour"
    assert isinstance(proposal.solution.value, Divert)
    engine.learn(blocked, proposal, outcome(REACHED))
    return proposal


def cases(engine: Engine) -> list[LandmarkCase]:
    assert engine.casebase is not None
    return [LandmarkCase.from_case(c) for c in engine.casebase.cases(SITUATION)]


def at(divert: Any) -> tuple[float, float]:
    assert isinstance(divert, Divert)
    return divert.x, divert.y


# --- retain, then retrieve and reuse ---------------------------------------------------------


@pytest.mark.parametrize("turn", [0.0, -0.3], ids=["facing the target", "swerved"])
def test_a_retained_situation_is_found_again_and_its_target_laid_where_it_was(
        plugins: Plugins, turn: float) -> None:
    with engine_for(plugins, "cbr-learning") as engine:
        learned = learn_a_detour(engine, turn)
        (case,) = cases(engine)
        assert (case.sign, case.origin) == ("negative", "learned")
        assert set(case.graph.ids) == {"l1", "l2", "l3"}
        # the robot comes back facing its target: the case was taken in the frame of its
        # course (x toward the target), the heading it has now, whatever it swerved to then
        again = engine.solve(observe("scenario2", "landmarks", t=5.0))
        assert again.source == "casebase"
        (match, *_) = again.retrieval.matches
        assert match.case.id == case.id
        assert match.similarity == pytest.approx(1.0, abs=1e-6)
        assert again.solution.cases == (case.id,)
        # the action keeps its offsets from the landmarks to 0.1 mm (DivertAction.toward)
        assert math.dist(at(again.solution.value), at(learned.solution.value)) < 1.5e-4


def test_the_same_situation_is_not_stored_twice(plugins: Plugins) -> None:
    with engine_for(plugins, "cbr-learning") as engine:
        proposal = learn_a_detour(engine)
        # the solver's diversion in the same layout learned again (another trial, say)
        for turn in (0.0, -0.3):
            engine.learn(observe("scenario2", "blocked", turn, t=40.0), proposal,
                         outcome(REACHED, 40.0))
        assert len(cases(engine)) == 1
        # blocked there once more: the case base answers now
        assert engine.solve(observe("scenario2", "blocked", t=80.0)).source == "casebase"


def test_a_diversion_that_did_not_get_the_robot_out_is_not_learned(plugins: Plugins) -> None:
    with engine_for(plugins, "cbr-learning") as engine:
        blocked = observe("scenario2", "blocked")
        proposal = engine.solve(blocked)
        engine.learn(blocked, proposal, outcome(GIVEN_UP))
        assert cases(engine) == []


def test_a_learned_case_is_plain_data_a_case_base_can_export(plugins: Plugins) -> None:
    with engine_for(plugins, "cbr-learning") as engine:
        learn_a_detour(engine)
        (stored,) = engine.casebase.cases(SITUATION)
        assert all(type(stored.solution[k]) is float for k in ("along", "aside"))
        dump_document(document_of(engine.casebase), "yaml")


# --- credit, blame and forgetting ------------------------------------------------------------


def reuse_once(engine: Engine, reason: str, t: float, trial_success: bool | None = None,
               trial: int = 1) -> int:
    """Consult on the landmarks in view in trial ``trial``, carry the reused case's target out
    with ``reason``; the reused case's id."""
    problem = attrs.evolve(observe("scenario2", "landmarks", t=t), trial=trial)
    proposal = engine.solve(problem)
    assert proposal.source == "casebase"
    engine.learn(problem, proposal, outcome(reason, t, trial_success))
    (case_id,) = proposal.solution.cases
    return case_id


@pytest.mark.parametrize(("reason", "trial_success", "helped", "failed"), [
    (REACHED, None, 1, 0),
    (GIVEN_UP, None, 0, 1),
    (TRIAL_ENDED, True, 1, 0),
    (TRIAL_ENDED, False, 0, 1),
])
def test_a_reused_case_is_credited_when_its_target_was_reached_and_blamed_when_given_up(
        plugins: Plugins, reason: str, trial_success: bool | None, helped: int,
        failed: int) -> None:
    with engine_for(plugins, "cbr-learning", forget=[]) as engine:
        learn_a_detour(engine)
        case_id = reuse_once(engine, reason, 10.0, trial_success)
        (case,) = cases(engine)
        assert (case.id, case.helped, case.failed) == (case_id, helped, failed)
        assert engine.casebase.get(case_id).uses == 1


def test_trouble_soon_after_a_reached_target_blames_the_case(plugins: Plugins) -> None:
    with engine_for(plugins, "cbr-learning", forget=[]) as engine:
        learn_a_detour(engine)
        reuse_once(engine, REACHED, 10.0)  # reached at 30 s
        blocked = attrs.evolve(observe("scenario2", "blocked", t=45.0), trial=1)  # within 30 s
        proposal = engine.solve(blocked)
        engine.learn(blocked, proposal, Outcome(False, cost=1.0))  # no report: no credit
        (case,) = cases(engine)
        assert (case.helped, case.failed) == (1, 1)


@pytest.mark.parametrize("history", [
    [GIVEN_UP],
    [GIVEN_UP, GIVEN_UP],
    [REACHED, GIVEN_UP, GIVEN_UP],
    [REACHED, REACHED, GIVEN_UP, GIVEN_UP],
    [GIVEN_UP, REACHED, GIVEN_UP, REACHED, GIVEN_UP],
    [GIVEN_UP, REACHED, GIVEN_UP, GIVEN_UP],
])
def test_a_case_that_failed_twice_and_more_often_than_it_helped_is_forgotten(
        plugins: Plugins, history: list[str]) -> None:
    with engine_for(plugins, "cbr-learning") as engine:
        learn_a_detour(engine)
        helped = failed = 0
        for k, reason in enumerate(history):
            # a case is reused once a trial: each reuse in a trial of its own
            reuse_once(engine, reason, 10.0, trial=k + 1)
            helped += reason == REACHED
            failed += reason == GIVEN_UP
            stored = cases(engine)
            assert (len(stored) == 1) == (not (failed >= 2 and failed > helped)), (k, stored)
            if stored:
                assert (stored[0].helped, stored[0].failed) == (helped, failed)
            else:
                break


# --- the inhibition window -------------------------------------------------------------------


@pytest.fixture(scope="module")
def inhibited_run(plugins: Plugins, tmp_path_factory: pytest.TempPathFactory
                  ) -> list[dict[str, str]]:
    out = tmp_path_factory.mktemp("inhibition")
    # consulted on landmarks and every 2 s besides, so that a consultation left out is seen
    with engine_for(plugins, "cbr-handmade", "scenario1", out,
                    workload={"consult_on": ["landmarks", "period"], "period": 2,
                              "repeat": 1, "trajectories": False}) as engine:
        run_workload(engine, out)
    with (out / "results.csv").open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def test_no_consultation_while_a_diverting_target_is_set(
        inhibited_run: list[dict[str, str]]) -> None:
    rows = inhibited_run
    diverted = [r for r in rows if r["source"] == "casebase"]
    # at point A the robot retrieves the case of l1, l2 and the obstacle (002 section 4)
    assert diverted and float(diverted[0]["q_t"]) == 0.0
    assert diverted[0]["q_trigger"] == "landmarks"
    times = [float(r["q_t"]) for r in rows]
    for divert in diverted:
        start = float(divert["q_t"])
        end = start + float(divert["outcome_cost"])
        assert divert["success"] == "True"  # the target was reached
        inside = [t for t in times if start < t < end - 1e-9]
        assert inside == [], (start, end, inside)
    # and the agent is consulted again once the first target is reached: at the step it is
    # restored, or at the next period at the latest
    first_end = float(diverted[0]["q_t"]) + float(diverted[0]["outcome_cost"])
    assert first_end > 10.0  # long enough that the period would have consulted meanwhile
    after = [t for t in times if t >= first_end - 1e-9]
    assert after and after[0] <= first_end + 2.0 + 1e-9
    # outside the windows the period trigger keeps consulting: no gap longer than 2 s
    windows = [(float(d["q_t"]), float(d["q_t"]) + float(d["outcome_cost"]))
               for d in diverted]
    for earlier, later in itertools.pairwise(times):
        if not any(a <= earlier and later <= b + 2.0 + 1e-9 for a, b in windows):
            assert later - earlier <= 2.0 + 1e-9, (earlier, later)


# --- bad input -------------------------------------------------------------------------------


@pytest.fixture
def installed(cbr_plugins: Callable[..., Plugins]) -> Iterator[Plugins]:
    yield cbr_plugins(entry_points=True)


def test_a_case_base_with_a_one_landmark_case_stops_the_run_naming_the_case(
        installed: Plugins, invoke_cbr: Callable[..., CliResult], tmp_path: Path) -> None:
    document = yaml.safe_load(shipped_path().read_text(encoding="utf-8"))
    bad = document["cases"][1]
    bad["id"] = 7
    bad["problem"].update(landmarks=["l3"], obstacles=[], delta=[[[0.0, 0.0, 0.0]]],
                          alpha=[[[0.0, 0.0, 0.0]]])
    bad["solution"] = None
    bad["meta"]["sign"] = "positive"
    casebase = tmp_path / "cases.yaml"
    casebase.write_text(yaml.safe_dump(document), encoding="utf-8")
    read_document(casebase)  # a well-formed document of the case base: the case is what's wrong
    config = robot_config("cbr-handmade", world_ref("scenario1"),
                          {"trials": [{"start": "start", "target": "target"}], "timeout": 30},
                          seed=0)
    config["casebase"] = {"use": "memory", "initial": str(casebase)}
    path = tmp_path / "run.yaml"
    path.write_text(yaml.safe_dump(config), encoding="utf-8")
    result = invoke_cbr("run", str(path), "--out", str(tmp_path / "out"))
    assert result.exit_code == 2, result
    output = result.stdout + result.stderr
    assert "landmark_situation case 7: landmarks: a case needs at least two landmarks" in output
    assert "Traceback" not in output


def with_nan(problem: Situation, corner: int) -> Situation:
    """``problem`` with corner ``corner`` of its first sighting's distance (0-2) or bearing
    (3-5) made NaN."""
    first = problem.sightings[0]
    values = [*first.distance.as_tuple(), *first.bearing.as_tuple()]
    values[corner] = math.nan
    broken = Sighting(first.id, unchecked(*values[:3]), unchecked(*values[3:]))
    return attrs.evolve(problem, sightings=(broken, *problem.sightings[1:]))


CORNERS = [pytest.param(0, id="distance low"),
           pytest.param(1, id="distance peak"),
           pytest.param(2, id="distance high"),
           pytest.param(3, id="bearing low"),
           pytest.param(4, id="bearing peak"),
           pytest.param(5, id="bearing high")]


@pytest.mark.parametrize("corner", CORNERS)
def test_a_nan_in_a_sighting_stops_retrieval_and_learning_storing_nothing(
        plugins: Plugins, corner: int) -> None:
    with engine_for(plugins, "cbr-learning") as engine:
        proposal = learn_a_detour(engine)
        before = engine.casebase.count(SITUATION)
        revision = engine.casebase.revision
        with pytest.raises(CbrError, match=r"sightings\[\d+\] \(\w+\): .*finite"):
            engine.solve(with_nan(observe("scenario2", "landmarks", t=3.0), corner))
        # the solver's diversion learned in a situation with the NaN
        blocked = with_nan(observe("scenario2", "blocked", turn=-0.3, t=5.0), corner)
        with pytest.raises(CbrError, match=r"sightings\[\d+\] \(\w+\): .*finite"):
            engine.learn(blocked, proposal, outcome(REACHED, 5.0))
        assert engine.casebase.count(SITUATION) == before == 1
        assert engine.casebase.revision == revision
