"""Scenario 2 off the paper's pose: the robustness table of ``landmark-scenarios``.

002's CBR agent is shown one pose: point A, facing the target, with a camera that sees the
three landmarks of the V. Here the robot starts at point A turned by each of :data:`HEADINGS`
from facing the target, with cameras of each of :data:`CAMERAS`, with the hand-made cases
(``cbr-handmade``) and without CBR (``no-cbr``). The robot without CBR never consults its
camera, so one run per heading serves every camera.

A camera narrower than 002's half-plane pans over it (002's Vision agent turns the camera
to look for landmarks, :func:`camera_options`), and the robot with the hand-made cases
remembers the landmarks it saw (the workload's ``memory``), so its situation holds the
landmarks of the whole sweep.

Each cell also reports how well the hand-made cases match what the robot sees at point A: a
*probe* run of the same configuration, seed and camera with the retriever's threshold at 0,
no reuser (so it is never diverted) and a timeout of the camera's first sweep (one step for a
camera that does not pan) consults the engine as landmarks come into view at point A, and its
``results.csv`` holds the best similarity of a stored case to each view (0 when fewer than two
landmarks are in the region in front, or none is in view).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from cbr_landmarks.experiments.common import Driven, robot_config
from cbr_landmarks.handmade import CAMERA_FOV
from cbr_world2d.worldfile import load_world

HEADINGS = (-30.0, -15.0, 0.0, 15.0, 30.0)
"""Start headings, degrees counter-clockwise from facing the target (the paper's pose)."""

CAMERAS = (60.0, 120.0, 180.0, 360.0)
"""Camera fields of view, degrees (the ``trials`` workload's default is 60; 002's robot sees
the half-plane in front, 180)."""

STEP = 0.1
"""The ``trials`` workload's step, seconds: the probe's timeout for a camera that does not pan,
so that it consults once."""

Job = tuple[str, dict[str, Any], Path]
"""A run: its name in the results (``HEADING/CAMERA/ROBOT``), configuration and folder."""


def facing(world_file: Path) -> float:
    """The heading, degrees, from the world's ``start`` to its ``target``."""
    world = load_world(world_file)
    (sx, sy), (tx, ty) = world.places["start"], world.places["target"]
    return math.degrees(math.atan2(ty - sy, tx - sx))


def camera_options(fov: float) -> dict[str, float]:
    """The camera of a cell: ``fov`` degrees wide, panning (002's Vision agent) so that its
    sweep covers the half-plane in front that 002's robot sees, when it is narrower."""
    pan = max(0.0, 0.5 * (CAMERA_FOV - fov))
    return {"fov": fov, "pan": pan} if pan > 0.0 else {"fov": fov}


def cell_name(heading: float, camera: float, robot: str) -> str:
    return f"{heading:+.0f}/{camera:.0f}/{robot}"


def probe_config(config: dict[str, Any]) -> dict[str, Any]:
    """``config`` made to look at point A for the camera's first sweep (:func:`probe_time`),
    to return every case however little it matches, and never to divert the robot."""
    retrieve = config["retrieve"]
    retrieve = {"use": retrieve} if isinstance(retrieve, str) else dict(retrieve)
    probe = {k: v for k, v in config.items() if k != "reuse"}
    workload = config["workload"]
    return {**probe, "retrieve": {**retrieve, "threshold": 0.0},
            "workload": {**workload, "timeout": probe_time(workload.get("camera", {})),
                         "trajectories": False}}


def probe_time(camera: dict[str, float]) -> float:
    """Seconds the probe looks: one step for a camera that does not pan; for one that does, a
    whole sweep, the time a landmark takes to come into view (the workload's ``settle``) and
    a step, so that every landmark the sweep shows has consulted."""
    from cbr_world2d.workload import CameraOptions, TrialsOptions

    pan = camera.get("pan", 0.0)
    if pan <= 0.0:
        return STEP
    rate = camera.get("pan_rate", CameraOptions().pan_rate)
    return round(4.0 * pan / rate + TrialsOptions().settle + STEP, 6)


def jobs(world_file: Path, seed: int, trials: int, out_dir: Path) -> list[Job]:
    """The runs of the table: per heading one without CBR, and per heading and camera one with
    the hand-made cases and its probe."""
    world = {"use": "world2d_file", "path": str(world_file)}
    ahead = facing(world_file)
    found: list[Job] = []
    for heading in HEADINGS:
        entry = {"start": "start", "target": "target", "heading": round(ahead + heading, 6)}
        workload: dict[str, Any] = {"trials": [entry], "repeat": trials}
        name = cell_name(heading, 0.0, "no-cbr")
        found.append((name, robot_config("no-cbr", world, workload, seed), out_dir / name))
        for camera in CAMERAS:
            seen = {**workload, "camera": camera_options(camera)}
            config = robot_config("cbr-handmade", world, seen, seed)
            name = cell_name(heading, camera, "cbr-handmade")
            found.append((name, config, out_dir / name))
            name = cell_name(heading, camera, "probe")
            found.append((name, probe_config(config), out_dir / name))
    return found


def threshold_of(runs: list[Job]) -> float:
    """The retriever's threshold in the runs with CBR (the table reports it beside the
    similarities)."""
    from cbr_landmarks.components import RetrieveOptions

    retrieve = next(config["retrieve"] for name, config, _ in runs
                    if name.endswith("/cbr-handmade"))
    if isinstance(retrieve, dict) and "threshold" in retrieve:
        return float(retrieve["threshold"])
    return RetrieveOptions().threshold


def start_similarities(probe: Driven) -> list[float]:
    """Per trial of a probe run, the best similarity at point A (0: nothing retrieved)."""
    best = [0.0] * len(probe.rows)
    for decision in probe.decisions:
        if math.isfinite(decision["similarity"]):
            best[decision["trial"]] = max(best[decision["trial"]], decision["similarity"])
    return best


def quartiles(values: list[float]) -> dict[str, float]:
    """Median, quartiles and extremes of ``values``."""
    q = np.percentile(np.asarray(values, dtype=float), [0, 25, 50, 75, 100])
    return {"min": float(q[0]), "q1": float(q[1]), "median": float(q[2]), "q3": float(q[3]),
            "max": float(q[4])}


def summary(runs: dict[str, Driven], trials: int, threshold: float) -> dict[str, Any]:
    """The table's data: per heading and camera, the trials that reached the target with and
    without CBR and the best similarities at the start."""
    cells = []
    for heading in HEADINGS:
        alone = runs[cell_name(heading, 0.0, "no-cbr")].rows
        for camera in CAMERAS:
            agent = runs[cell_name(heading, camera, "cbr-handmade")].rows
            best = start_similarities(runs[cell_name(heading, camera, "probe")])
            cells.append({
                "heading": heading, "camera": camera,
                "cbr": {"reached": sum(r["success"] for r in agent), "trials": len(agent)},
                "no_cbr": {"reached": sum(r["success"] for r in alone), "trials": len(alone)},
                "similarity": quartiles(best), "similarities": best,
                "over_threshold": sum(b >= threshold for b in best)})
    return {"trials": trials, "threshold": threshold, "headings": list(HEADINGS),
            "cameras": list(CAMERAS), "cells": cells}


def table(robustness: dict[str, Any]) -> str:
    """The robustness table in markdown: rows by start heading, columns by camera."""
    cameras = robustness["cameras"]
    cells = {(c["heading"], c["camera"]): c for c in robustness["cells"]}
    lines = ["| start heading | " + " | ".join(f"{c:.0f}° camera" for c in cameras)
             + " | without CBR |", "|---" * (len(cameras) + 2) + "|"]
    for heading in robustness["headings"]:
        row = []
        for camera in cameras:
            c = cells[(heading, camera)]
            s = c["similarity"]
            row.append(f"{c['cbr']['reached']} of {c['cbr']['trials']}; {s['median']:.2f} "
                       f"({s['q1']:.2f}-{s['q3']:.2f})")
        alone = cells[(heading, cameras[0])]["no_cbr"]
        lines.append(f"| {heading:+.0f}° | " + " | ".join(row)
                     + f" | {alone['reached']} of {alone['trials']} |")
    return "\n".join(lines)
