"""``landmark-scenarios``: 002 section 4, Figures 6 and 7.

In each of the two shipped scenario worlds (``scenario1.yaml``, ``scenario2.yaml``) the robot
drives from point A to the target the same number of times without CBR (``no-cbr``) and with the
CBR agent and its hand-made cases (``cbr-handmade``); trials differ by the sensor and odometry
noise of their seeds. The table is Figure 6 (mean time and distance of the trials that reached
the target) beside the paper's; the figure is Figure 7 (:mod:`.figure7`): every trial of each
robot drawn over each world (dashed: without CBR; solid: with it), with the points A, B and C,
the consultations, retrievals and diverting targets.

The second table (:mod:`.robustness`) takes scenario 2 off the paper's pose: start headings
turned up to 30 degrees from facing the target and cameras of 60 to 360 degrees, with the
success of each robot and the best similarity of a hand-made case at the start.
"""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path
from typing import Any, ClassVar

from cbr_experiments.experiment import ExperimentResult, Size, spread
from cbr_experiments.tasks import task_runner
from cbr_landmarks.experiments import robustness
from cbr_landmarks.experiments.common import (
    PILOT,
    TIMEOUT,
    Driven,
    Progress,
    drive_job,
    robot_config,
)
from cbr_landmarks.experiments.figure7 import figure7
from cbr_world2d.worldfile import load_world
from cbrcore.context import Context

SCENARIOS = ("scenario1", "scenario2")
ROBOTS = ("no-cbr", "cbr-handmade")

PAPER: dict[str, dict[str, tuple[float, float] | None]] = {
    "scenario1": {"no-cbr": (162.36, 802.13), "cbr-handmade": (147.87, 648.13),
                  "optimal": (107.0, 539.82)},
    "scenario2": {"no-cbr": None, "cbr-handmade": (205.03, 921.51),
                  "optimal": (173.69, 868.46)},
}
"""002 Figure 6 (mean time in s, mean distance in cm; None: no trial finished) and the optimal
time and distance of section 4."""


def world_path(scenario: str) -> Path:
    return Path(str(resources.files("cbr_world2d") / "worlds" / f"{scenario}.yaml"))


class Scenarios:
    """Figure 6 and Figure 7 of 002, rebuilt."""

    TRIALS: ClassVar[dict[str, int]] = {"ci": 4, "full": 100}
    """Trials per robot and scenario (002: 100)."""

    ROBUST_TRIALS: ClassVar[dict[str, int]] = {"ci": 2, "full": 30}
    """Trials per cell of the robustness table."""

    def __init__(self, options: object, ctx: Context) -> None:
        self.seed = ctx.seed
        self.tasks = task_runner(ctx)

    def run(self, size: Size, out_dir: Path, progress: Progress) -> ExperimentResult:
        import matplotlib

        matplotlib.use("Agg")
        trials = self.TRIALS[size]
        configs: dict[str, dict[str, Any]] = {}
        workload = {"trials": [{"start": "start", "target": "target"}], "repeat": trials,
                    "trajectories": True}
        for scenario in SCENARIOS:
            world = {"use": "world2d_file", "path": str(world_path(scenario))}
            for robot in ROBOTS:
                configs[f"{scenario}/{robot}"] = robot_config(robot, world, workload, self.seed)
        out = out_dir.resolve()
        figure_jobs = [(configs[f"{scenario}/{robot}"], out / scenario / robot)
                       for scenario in SCENARIOS for robot in ROBOTS]
        robust_jobs = robustness.jobs(world_path("scenario2"), self.seed,
                                      self.ROBUST_TRIALS[size], out / "robustness")
        # each robot in each world, and each cell of the robustness table, is a run of its
        # own, handed to the run's task runner
        runs = list(self.tasks.map(drive_job,
                                   figure_jobs + [(c, d) for _, c, d in robust_jobs],
                                   progress=progress))
        driven: dict[str, dict[str, Driven]] = {}
        for (scenario, robot), run in zip(
                [(s, r) for s in SCENARIOS for r in ROBOTS], runs[:len(figure_jobs)],
                strict=True):
            driven.setdefault(scenario, {})[robot] = run
        robust = robustness.summary(
            {name: run for (name, _, _), run in zip(robust_jobs, runs[len(figure_jobs):],
                                                    strict=True)},
            self.ROBUST_TRIALS[size], robustness.threshold_of(robust_jobs))
        summary = {scenario: {robot: self._summary(driven[scenario][robot])
                              for robot in ROBOTS} for scenario in SCENARIOS}
        ratios = {scenario: self._ratios(summary[scenario]) for scenario in SCENARIOS}
        results = {"trials": trials, "timeout": TIMEOUT, "pilot": PILOT, "seed": self.seed,
                   "summary": summary, "cbr_over_no_cbr": ratios,
                   "paper": {s: {k: (None if v is None else list(v)) for k, v in p.items()}
                             for s, p in PAPER.items()},
                   "robustness": robust,
                   "figure7": {s: {r: self._marks(driven[s][r]) for r in ROBOTS}
                               for s in SCENARIOS},
                   "configs": configs}
        table = (self._table(summary, ratios, trials) + "\n\n" + self._robust_lead(robust)
                 + "\n\n" + robustness.table(robust))
        worlds = {scenario: load_world(world_path(scenario)) for scenario in SCENARIOS}
        return ExperimentResult(results=results, table=table,
                                figures={"figure7": figure7(worlds, driven)})

    @staticmethod
    def _marks(run: Driven) -> dict[str, Any]:
        """What Figure 7 marks of a run: where the agent was consulted, retrieved a case and
        was sent (the diverting targets), per consultation."""
        return {"consultations": [{k: d[k] for k in ("trial", "t", "x", "y", "source")}
                                  for d in run.decisions],
                "diverting_targets": [[d["trial"], d["divert_x"], d["divert_y"]]
                                      for d in run.decisions
                                      if math.isfinite(d["divert_x"])]}

    @staticmethod
    def _robust_lead(robust: dict[str, Any]) -> str:
        return (f"Scenario 2 off the paper's pose: {robust['trials']} trials per cell. Rows: the "
                "start heading, turned from facing the target; columns: the camera's field of "
                "view. A cell: the trials with the hand-made cases that reached the target; "
                "the best similarity of a hand-made case to the view at point A, median "
                f"(quartiles; the threshold is {robust['threshold']:.2f}). Without CBR the "
                "camera is never consulted: one run per heading.")

    @staticmethod
    def _summary(run: Driven) -> dict[str, Any]:
        reached = [r for r in run.rows if r["success"]]
        return {"trials": len(run.rows), "reached": len(reached),
                "time": spread([r["time"] for r in reached]),
                "distance_cm": spread([100.0 * r["distance"] for r in reached]),
                "collisions": sum(r["collisions"] for r in run.rows)}

    @staticmethod
    def _ratios(summary: dict[str, Any]) -> dict[str, float | None]:
        base, cbr = summary["no-cbr"], summary["cbr-handmade"]
        if not (base["reached"] and cbr["reached"]):
            return {"time": None, "distance": None}
        return {"time": cbr["time"]["mean"] / base["time"]["mean"],
                "distance": cbr["distance_cm"]["mean"] / base["distance_cm"]["mean"]}

    @staticmethod
    def _table(summary: dict[str, Any], ratios: dict[str, Any], trials: int) -> str:
        lines = [f"002 Figure 6, rebuilt: {trials} trials per robot and scenario, timeout "
                 f"{TIMEOUT:.0f} s; mean over the trials that reached the target "
                 "(minimum-maximum in brackets).", "",
                 "| scenario | robot | reached | time (s) | distance (cm) | 002: time (s) | "
                 "002: distance (cm) |", "|---|---|---|---|---|---|---|"]
        for scenario in SCENARIOS:
            for robot in ROBOTS:
                s = summary[scenario][robot]
                paper = PAPER[scenario][robot]
                if s["reached"]:
                    time = (f"{s['time']['mean']:.2f} ({s['time']['min']:.1f}-"
                            f"{s['time']['max']:.1f})")
                    distance = (f"{s['distance_cm']['mean']:.2f} ({s['distance_cm']['min']:.1f}"
                                f"-{s['distance_cm']['max']:.1f})")
                else:
                    time = distance = "-"
                lines.append(f"| {scenario[-1]} | {robot} | {s['reached']} of {s['trials']} | "
                             f"{time} | {distance} | "
                             f"{'-' if paper is None else f'{paper[0]:.2f}'} | "
                             f"{'-' if paper is None else f'{paper[1]:.2f}'} |")
            optimal = PAPER[scenario]["optimal"]
            assert optimal is not None
            lines.append(f"| {scenario[-1]} | optimal (002) | | | | {optimal[0]:.2f} | "
                         f"{optimal[1]:.2f} |")
        r = ratios["scenario1"]
        if r["time"] is not None:
            lines += ["", f"Scenario 1, CBR over no CBR: time {r['time']:.3f}, distance "
                          f"{r['distance']:.3f} (002: 0.911 and 0.808)."]
        return "\n".join(lines)
