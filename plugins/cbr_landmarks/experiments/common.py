"""What the landmark experiments share: the robots compared, their configurations, and running
one robot's trials through the engine.

Every robot is 002's navigation system, the potential-field pilot (with :data:`PILOT`'s
parameters), the progress monitor and a Rescuer, with 002's robot and a camera that sees the
half-plane in front, and the ``divert_target`` metric records where each answer diverts the
robot. They differ in who diverts a blocked robot and in what the engine knows
(:data:`ROBOTS`):

``no-cbr``
    002's navigation system without CBR: its own Rescuer diverts the robot when it is blocked
    (``navigation.rescue: blocked``); the engine is never consulted.
``cbr-handmade``
    The same navigation system with 002's CBR agent added: consulted when landmarks come into
    view, it retrieves from the hand-made cases (:mod:`cbr_landmarks.handmade`) with 002's
    matching (``matching: paper``: equal landmark counts, bijections, the obstacle constraint),
    angles against its course toward the target (``course: true``: at 002's point A the robot
    faces the target, and off that pose the cases, taken facing it, keep their angles), and
    asks the Rescuer for a diverting target when a case matches (002 section 3.3). It
    remembers the landmarks it saw for :data:`MEMORY` seconds (the workload's ``memory``), so
    a camera that pans shows it the layout of its whole sweep.
``detour``
    The engine diverts a blocked (or oscillating) robot with the ``landmark_detour`` solver
    alone, the Rescuer told about the linear obstacles in view; no case base. It separates what
    learning adds from what the better solver does.
``cbr-learning``
    The CBR agent learning from an empty case base: consulted when landmarks come into view
    and when the robot is blocked or oscillating; the ``landmark_detour`` solver answers when
    no case matches, the ``landmark_trouble`` retainer keeps the situations it got the robot
    out of, and the ``unhelpful_situations`` forgetter drops cases that did not help. The
    reuser leads the robot round the walls it knows to a learned target (``follow``): the
    solver's targets it learns from were reached by a way round, and sent straight at one the
    robot meets the walls it went round (on the unseen worlds 68.8% of the trials reached the
    target so, against 88.2% led round, before the detour solver knew the walls of the robot's
    map).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import attrs
import numpy as np

from cbr_landmarks.handmade import CAMERA_FOV, shipped_path
from cbrcore.config import parse_config
from cbrcore.engine import Engine
from cbrcore.plugins import current
from cbrcore.run import run_workload
from cbrcore.run_folder import fresh_files, remove

Progress = Callable[[int, int], None]

PILOT: dict[str, Any] = {"use": "potential_field", "influence": 0.5, "repulsion": 0.02}
"""The pilot of the experiments. 002 gives no parameters of its potential field. An influence
distance of 0.5 m and a gain of 0.02 (the ``potential_field`` defaults, 1.0 m and 0.05, are set
for a Pioneer 2 DX at 0.4 m/s) let 002's slow robot pass closer to what it avoids: the CBR
robot's way round l2 in scenario 1 is 583 cm instead of about 604 cm with the defaults, and the
robot without CBR is still trapped in scenario 2."""

TIMEOUT = 400.0
"""Seconds after which a trial has failed: 002 gives none ("a given time"); 400 s is 2.3 times
the optimal time of scenario 2, 4 times that of scenario 1."""

MEMORY = 10.0
"""Seconds the CBR agent of the hand-made cases remembers a landmark out of view (the
``trials`` workload's ``memory``): over twice the 4 s sweep of a 60 degree camera panning over
the half-plane in front, so a situation holds every landmark of that half-plane."""

ROBOTS = ("no-cbr", "cbr-handmade", "detour", "cbr-learning")


def robot_config(robot: str, world: Mapping[str, Any], workload: Mapping[str, Any], seed: int,
                 casebase: Path | None = None) -> dict[str, Any]:
    """The configuration of ``robot`` (one of :data:`ROBOTS`) driving the trials ``workload``
    (the ``trials`` workload's options besides those every robot shares) in ``world``;
    ``casebase`` is the learning robot's SQLite file (default: memory, empty)."""
    trials = {"use": "trials", "robot": "ros2005", "timeout": TIMEOUT,
              "camera": {"fov": CAMERA_FOV}, **workload}
    rescuing = {**trials, "navigation": {**trials.get("navigation", {}), "rescue": "blocked"}}
    config: dict[str, Any] = {"seed": seed, "world": dict(world), "pilot": dict(PILOT),
                              "casebase": "memory", "metrics": ["divert_target"]}
    if robot == "no-cbr":
        return {**config, "workload": {**rescuing, "consult_on": []}}
    if robot == "cbr-handmade":
        return {**config, "workload": {**rescuing, "consult_on": ["landmarks"],
                                       "memory": {"seconds": MEMORY}},
                "casebase": {"use": "memory", "initial": str(shipped_path())},
                "retrieve": {"use": "landmarks", "similarity": {"matching": "paper"},
                             "course": True},
                "reuse": "landmarks"}
    if robot == "detour":
        return {**config, "workload": {**trials, "consult_on": ["blocked"]},
                "solver": "landmark_detour"}
    if robot == "cbr-learning":
        store: Any = ("memory" if casebase is None
                      else {"use": "sqlite", "path": str(casebase.resolve())})
        return {**config, "workload": {**trials, "consult_on": ["landmarks", "blocked"]},
                "casebase": store, "retrieve": "landmarks",
                "reuse": {"use": "landmarks", "follow": True},
                "solver": "landmark_detour", "retain": ["landmark_trouble"],
                "forget": ["unhelpful_situations"]}
    raise ValueError(f"unknown robot {robot!r}; expected one of {', '.join(ROBOTS)}")


@attrs.frozen(eq=False)
class Driven:
    """One robot's trials: a row per trial (``success``, ``time`` in s, ``distance`` in m,
    ``collisions``, ``consultations``), the true paths when asked, the landmark cases stored
    at the end, and a row per consultation (:func:`consultations`)."""

    rows: list[dict[str, Any]]
    paths: Mapping[str, np.ndarray]
    cases: int
    decisions: list[dict[str, Any]] = attrs.field(factory=list)


def _number(text: str | None) -> float:
    return float(text) if text not in (None, "") else math.nan


def consultations(path: Path) -> list[dict[str, Any]]:
    """The consultations of a run's ``results.csv``, in the order they were learned: the
    ``trial``, the time ``t``, the ``trigger``, where the robot believed it was (``x``, ``y``),
    the answer's ``source`` (``casebase``, ``solver:NAME`` or ``none``), the best similarity
    retrieved (NaN: none) and the diverting target asked for (``divert_x``, ``divert_y``; NaN:
    none)."""
    if not path.exists():
        return []
    with path.open(encoding="utf-8") as handle:
        return [{"trial": int(row["q_trial"]), "t": float(row["q_t"]),
                 "trigger": row["q_trigger"], "x": float(row["q_x"]), "y": float(row["q_y"]),
                 "source": row["source"], "similarity": _number(row["best_similarity"]),
                 "divert_x": _number(row.get("divert_x")),
                 "divert_y": _number(row.get("divert_y"))}
                for row in csv.DictReader(handle)]


def drive(config: Mapping[str, Any], out_dir: Path) -> Driven:
    """Run ``config``'s trials with the engine, its files in ``out_dir``."""
    plugins = current()
    parsed = parse_config(dict(config), plugins.registry)
    # an experiment run again into its folder starts each run afresh: the results it reads
    # back are this run's
    remove(fresh_files(out_dir, parsed))
    with Engine(parsed, plugins=plugins, out_dir=out_dir) as engine:
        run_workload(engine, out_dir)
        cases = engine.casebase.count("landmark_situation") if engine.casebase else 0
    with (out_dir / "trials.csv").open(encoding="utf-8") as handle:
        rows = [{"success": row["success"] == "True", "time": float(row["time"]),
                 "distance": float(row["distance"]), "collisions": int(row["collisions"]),
                 "consultations": int(row["consultations"])}
                for row in csv.DictReader(handle)]
    paths: dict[str, np.ndarray] = {}
    if (out_dir / "trajectories.npz").exists():
        with np.load(out_dir / "trajectories.npz") as saved:
            paths = {name: saved[name] for name in saved.files}
    return Driven(rows, paths, cases, consultations(out_dir / "results.csv"))


def drive_job(job: tuple[Mapping[str, Any], Path]) -> Driven:
    """:func:`drive` with its arguments in one picklable tuple, as a task."""
    config, out_dir = job
    return drive(config, out_dir)
