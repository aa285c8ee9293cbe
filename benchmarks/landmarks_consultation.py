"""When the landmark agent is consulted, and whether the situation it is asked about holds the
landmarks that triggered it: the ``trials`` workload's triggers and the region's margin.

Four measures:

- **The region's edge** (``corridor``): a dead-end corridor open towards the start
  (:data:`CORRIDOR`), the learning robot of ``landmark-learning`` drives it once and learns the
  dead end; then, at the first pose on the straight way to the target from which the camera
  (360 degrees, 6 m) sees every landmark of the learned case, the camera's noise is drawn
  ``--draws`` times, and for each region margin the share of draws in which the learned case
  passes the threshold (and in which all its landmarks lie in the region) is counted.
- **Flicker** (``flicker``): 002's scenario 2 driven by the robot without CBR (trapped in the
  V until the timeout), ``--flicker-trials`` trials: how often a landmark comes back into the
  camera's view (180 degrees, as the reproduction's), and after how long out of it (the view is
  a function of the true pose, recomputed from the recorded paths).
- **002's scenarios** (``scenarios``): the ``cbr-handmade`` robot of ``landmark-scenarios``,
  ``--trials`` trials per scenario, under three consultation settings (:data:`SETTINGS`):
  consultations per trial, retrievals over the threshold after point A (the hand-made cases
  describe point A only, so every later one is a false match), diverting targets set from them,
  trials that reached the target, mean time and distance.
- **The corridor, driven** (``corridor_driven``): the learning robot drives the corridor
  ``--corridor-trials`` times keeping its case base, under the same settings (and consulted
  when blocked): trials that reached the target, consultations per trial, and in the trials
  after the first, those diverted from the case base and their mean time.

    python benchmarks/landmarks_consultation.py [--trials 100] [--draws 500]
        [--flicker-trials 10] [--corridor-trials 10] [--seed 0] [--out benchmarks/results]

Writes ``landmarks_consultation.json`` and ``landmarks_consultation.md``.
"""

from __future__ import annotations

import argparse
import csv
import math
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from docfigures.provenance import head, script_command, write_results

from cbr_landmarks.case import LandmarkCase
from cbr_landmarks.experiments.common import drive, robot_config
from cbr_landmarks.experiments.learning import AROUND, SIMILARITY
from cbr_landmarks.experiments.scenarios import world_path
from cbr_landmarks.handmade import CAMERA_FOV
from cbr_landmarks.problem import RegionOptions, problem_view
from cbr_landmarks.similarity import SimilarityOptions, case_similarity
from cbr_world2d.robot import Pose
from cbr_world2d.sensors import Camera
from cbr_world2d.workload import Situation
from cbr_world2d.worldfile import load_world
from cbrcore.config import parse_config
from cbrcore.engine import Engine
from cbrcore.plugins import current
from cbrcore.run import run_workload

CORRIDOR = """\
# a dead-end corridor 3 m deep and 1.6 m wide, open towards the start, the target beyond it
name: corridor
bounds: [0.0, 0.0, 16.0, 10.0]
landmarks:
  - {id: c1, at: [7.0, 5.8], radius: 0.15}
  - {id: c2, at: [10.0, 5.8], radius: 0.15}
  - {id: c3, at: [10.0, 4.2], radius: 0.15}
  - {id: c4, at: [7.0, 4.2], radius: 0.15}
  - {id: f1, at: [3.0, 8.5], radius: 0.15}
  - {id: f2, at: [12.5, 1.5], radius: 0.15}
walls:
  - {between: [c1, c2]}
  - {between: [c2, c3]}
  - {between: [c3, c4]}
places:
  start: [1.0, 5.0]
  target: [13.5, 5.0]
"""
"""The corridor world: its far landmarks c2 and c3 come into view at the camera's range as
the robot drives towards the target, while c1 and c4 are already in view."""

THRESHOLD = 0.75
MARGINS = (0.0, 0.5, 1.0)

SETTINGS: dict[str, tuple[dict[str, Any], dict[str, Any]]] = {
    "landmarks, no hysteresis, no margin": (
        {"consult_on": ["landmarks"], "settle": 0.0, "absence": 0.0}, {"margin": 0.0}),
    "landmarks, defaults": ({"consult_on": ["landmarks"]}, {}),
    "landmarks, heading, period, defaults": (
        {"consult_on": ["landmarks", "heading", "period"]}, {}),
}
"""The trials workload's options and the retriever's region of each setting compared: the
landmark trigger as it was before hysteresis and margin, as the reproduction consults today,
and with the heading and period triggers of the workload's defaults."""


def learning_robot(world: dict[str, Any], trials: int, seed: int, casebase: Path,
                   workload: dict[str, Any], region: dict[str, Any]) -> dict[str, Any]:
    """The configuration of ``landmark-learning``'s learning robot (360 degree camera, cases
    compared with the experiment's options, angles against the course), also consulted when
    blocked, under ``workload`` and the retriever's ``region``."""
    config = robot_config("cbr-learning", world, {
        "trials": [{"start": "start", "target": "target"}], "repeat": trials,
        "camera": {"fov": 360.0}}, seed, casebase)
    config["workload"].update(workload)
    config["workload"]["consult_on"] = sorted(set(config["workload"]["consult_on"])
                                              | {"blocked"})
    config["retrieve"] = {"use": "landmarks", "similarity": SIMILARITY, "course": True,
                          "region": region, "threshold": THRESHOLD}
    config["retain"] = [{"use": "landmark_trouble", "region": AROUND, "similarity": SIMILARITY}]
    config["solver"] = {"use": "landmark_detour", "region": AROUND}
    return config


def _decisions(out: Path) -> list[dict[str, str]]:
    with (out / "results.csv").open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def region_edge(corridor: Path, draws: int, seed: int) -> dict[str, Any]:
    """The share of noise draws in which the learned corridor case passes the threshold, by
    region margin, at the pose where its last landmarks come into view."""
    world_spec = {"use": "world2d_file", "path": str(corridor)}
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder)
        config = learning_robot(world_spec, 1, seed, out / "cases.sqlite", {}, {})
        plugins = current()
        with Engine(parse_config(config, plugins.registry), plugins=plugins,
                    out_dir=out) as engine:
            run_workload(engine, out)
            cases = [LandmarkCase.from_case(c)
                     for c in engine.casebase.cases("landmark_situation")]
    if not cases:
        raise RuntimeError("the learning robot learned no case in the corridor")
    case = max(cases, key=lambda c: c.graph.n)
    world = load_world(corridor)
    camera = Camera(fov=2.0 * math.pi, max_range=6.0)
    ids = tuple(mark.id for mark in world.landmarks)
    segments = world.segments_at(0.0)
    target = world.places["target"]
    start = world.places["start"]
    x = start[0]
    while True:  # 1 cm steps along the straight way
        pose = Pose(x, start[1], 0.0)
        seen = {ids[int(i)] for i in camera.view(pose, world.landmark_array, segments)[:, 0]}
        if set(case.graph.ids) <= seen:
            break
        x += 0.01
    options = SimilarityOptions(**SIMILARITY)
    by_margin = {}
    for margin in MARGINS:
        region = RegionOptions(margin=margin)
        rng = np.random.default_rng(seed)
        passed = whole = 0
        for _ in range(draws):
            sightings = camera.see(pose, world.landmark_array, ids, segments, rng)
            problem = Situation(0, 0.0, "landmarks", pose, target, sightings,
                                world.obstacles_between([s.id for s in sightings]),
                                np.zeros(0), np.zeros(0), False, 1.0)
            view = problem_view(problem, region, course=True)
            if view is None:
                continue
            whole += set(case.graph.ids) <= set(view.graph.ids)
            passed += case_similarity(view.graph, case.graph, options, THRESHOLD) is not None
        by_margin[f"{margin:g}"] = {"passes": passed / draws, "all_in_region": whole / draws}
    return {"case_landmarks": list(case.graph.ids), "pose_x": round(x, 2), "draws": draws,
            "threshold": THRESHOLD, "by_margin": by_margin}


def flicker(trials: int, seed: int) -> dict[str, Any]:
    """How often and after how long a landmark comes back into view of the robot without CBR
    trapped in scenario 2."""
    world_spec = {"use": "world2d_file", "path": str(world_path("scenario2"))}
    config = robot_config("no-cbr", world_spec, {
        "trials": [{"start": "start", "target": "target"}], "repeat": trials,
        "trajectories": True}, seed)
    with tempfile.TemporaryDirectory() as folder:
        driven = drive(config, Path(folder))
    world = load_world(world_path("scenario2"))
    camera = Camera(fov=math.radians(CAMERA_FOV), max_range=6.0)
    segments = world.segments_at(0.0)
    gaps = []
    for path in driven.paths.values():
        last: dict[int, float] = {}
        before: set[int] = set()
        for t, x, y, theta in path:
            seen = {int(i) for i in camera.view(Pose(x, y, theta), world.landmark_array,
                                                segments)[:, 0]}
            gaps += [t - last[i] for i in seen - before if i in last]
            last.update(dict.fromkeys(seen, t))
            before = seen
    values = np.array(gaps)
    return {"trials": trials, "reached": sum(r["success"] for r in driven.rows),
            "returns_per_trial": len(values) / trials,
            "share_back_within_s": {f"{s:g}": float(np.mean(values <= s + 1e-9))
                                    for s in (1, 5, 10, 20, 30, 60)}}


def scenarios(trials: int, seed: int) -> dict[str, Any]:
    """The hand-made robot in 002's scenarios under each setting."""
    result: dict[str, Any] = {}
    for name, (workload, region) in SETTINGS.items():
        for scenario in ("scenario1", "scenario2"):
            world = {"use": "world2d_file", "path": str(world_path(scenario))}
            config = robot_config("cbr-handmade", world, {
                "trials": [{"start": "start", "target": "target"}], "repeat": trials}, seed)
            config["workload"].update(workload)
            config["retrieve"] = {"use": "landmarks", "region": region}
            with tempfile.TemporaryDirectory() as folder:
                driven = drive(config, Path(folder))
                decisions = _decisions(Path(folder))
            later = [d for d in decisions if float(d["q_t"]) > 0.0]
            reached = [r for r in driven.rows if r["success"]]
            result.setdefault(name, {})[scenario] = {
                "trials": trials, "reached": len(reached),
                "consultations_per_trial": len(decisions) / trials,
                "false_matches": sum(int(d["retrieved"]) > 0 for d in later),
                "false_diverts": sum(d["source"] == "casebase" for d in later),
                "time": float(np.mean([r["time"] for r in reached])) if reached else None,
                "distance_cm": (100.0 * float(np.mean([r["distance"] for r in reached]))
                                if reached else None),
                "triggers": {k: sum(d["q_trigger"] == k for d in decisions)
                             for k in sorted({d["q_trigger"] for d in decisions})}}
    return result


def corridor_driven(corridor: Path, trials: int, seed: int) -> dict[str, Any]:
    """The learning robot driving the corridor ``trials`` times under each setting."""
    world = {"use": "world2d_file", "path": str(corridor)}
    result = {}
    for name, (workload, region) in SETTINGS.items():
        with tempfile.TemporaryDirectory() as folder:
            out = Path(folder)
            driven = drive(learning_robot(world, trials, seed, out / "cases.sqlite",
                                          workload, region), out)
            decisions = _decisions(out)
        later = driven.rows[1:]
        reached = [r for r in later if r["success"]]
        result[name] = {
            "trials": trials, "reached": sum(r["success"] for r in driven.rows),
            "consultations_per_trial": len(decisions) / trials,
            "later_diverted_from_cases": len({d["q_trial"] for d in decisions
                                              if d["source"] == "casebase"
                                              and d["q_trial"] != "0"}),
            "later_time": float(np.mean([r["time"] for r in reached])) if reached else None}
    return result


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trials", type=int, default=100,
                        help="trials per scenario and setting (100)")
    parser.add_argument("--draws", type=int, default=500, help="noise draws (500)")
    parser.add_argument("--flicker-trials", type=int, default=10,
                        help="trials of the trapped robot (10)")
    parser.add_argument("--corridor-trials", type=int, default=10,
                        help="trials in the corridor per setting (10)")
    parser.add_argument("--seed", type=int, default=0, help="seed of every run (0)")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args(argv)
    began = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        corridor = Path(folder) / "corridor.yaml"
        corridor.write_text(CORRIDOR, encoding="utf-8")
        result: dict[str, Any] = {
            "commit": head(),
            "seed": args.seed,
            "corridor": region_edge(corridor, args.draws, args.seed),
            "flicker": flicker(args.flicker_trials, args.seed),
            "scenarios": scenarios(args.trials, args.seed),
            "corridor_driven": corridor_driven(corridor, args.corridor_trials, args.seed)}
    result["elapsed_s"] = time.perf_counter() - began
    args.out.mkdir(parents=True, exist_ok=True)
    write_results(args.out / "landmarks_consultation.json", result,
                  command=script_command(__file__, argv))
    text = report(result)
    (args.out / "landmarks_consultation.md").write_text(text + "\n")
    print(text)
    return result


def _num(value: float | None, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def report(result: dict[str, Any]) -> str:
    """The markdown of ``result``."""
    edge = result["corridor"]
    lines = [f"The learned corridor case ({', '.join(edge['case_landmarks'])}) at x = "
             f"{edge['pose_x']} m, where its last landmarks come into view, {edge['draws']} "
             f"noise draws, threshold {edge['threshold']}:", "",
             "| region margin (m) | case passes | all its landmarks in the region |",
             "|---|---|---|"]
    lines += [f"| {m} | {v['passes']:.0%} | {v['all_in_region']:.0%} |"
              for m, v in edge["by_margin"].items()]
    back = result["flicker"]
    lines += ["", f"Scenario 2 without CBR ({back['trials']} trials, {back['reached']} reached):"
              f" a landmark comes back into view {back['returns_per_trial']:.1f} times a "
              "trial; back within " + ", ".join(
                  f"{s} s: {v:.0%}" for s, v in back["share_back_within_s"].items()) + ".", "",
              "| setting | scenario | reached | consultations a trial | false matches | "
              "diverted by them | time (s) | distance (cm) |", "|---|---|---|---|---|---|---|---|"]
    for name, by_scenario in result["scenarios"].items():
        for scenario, row in by_scenario.items():
            lines.append(
                f"| {name} | {scenario[-1]} | {row['reached']} of {row['trials']} | "
                f"{row['consultations_per_trial']:.2f} | {row['false_matches']} | "
                f"{row['false_diverts']} | {_num(row['time'])} | {_num(row['distance_cm'])} |")
    lines += ["", "| setting | corridor: reached | consultations a trial | later trials "
              "diverted from cases | later time (s) |", "|---|---|---|---|---|"]
    for name, row in result["corridor_driven"].items():
        lines.append(f"| {name} | {row['reached']} of {row['trials']} | "
                     f"{row['consultations_per_trial']:.2f} | "
                     f"{row['later_diverted_from_cases']} of {row['trials'] - 1} | "
                     f"{_num(row['later_time'], 1)} |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
