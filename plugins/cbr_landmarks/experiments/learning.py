"""``landmark-learning``: learning situations across environments (002 sections 1 and 5).

002's stated goal is to "learn the different situations a robot encounters as it navigates
through *several* environments" and reuse them in unknown ones. For each seed, the robots of
:data:`~cbr_landmarks.experiments.common.ROBOTS` drive from start to target through a sequence
of seeded worlds like 002's scenarios (:func:`cbr_world2d.generate.scenario`: a V or a U open
towards the start, or a wall, across the way, of drawn size, place and turn, with free landmarks
around): first the *training* worlds, then *unseen* ones. The learning robot keeps one case base
across the whole sequence (and goes on learning in the unseen worlds, as a robot would); the
hand-made robot has 002's two cases; the others have none. The learning curves are success,
time and distance against trials; the table compares the robots on the unseen worlds, with the
difference between the learning robot and the robot without CBR over seeds.

The robots are those of the scenarios (002's robot, the same pilot), with a camera that sees all
round (002's Vision agent pans to keep landmarks in view): a robot trapped in a dead end still
sees the landmarks at its mouth, behind it. The detour solver and the retainer look all round
(:data:`AROUND`); the retriever looks at the region in front, as 002's agent does, and measures
angles against the robot's course (x toward the target), as the learned cases are taken, so a
learned dead end matches where the target lies behind it again. Cases are compared with
:data:`SIMILARITY`: normalised by the case's landmarks (a case matches when the view holds its
layout, whatever else is in view) and with obstacles required both ways (a dead end matches
only where its linear obstacles are seen).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from cbr_landmarks.experiments.common import (
    ROBOTS,
    TIMEOUT,
    Progress,
    drive,
    robot_config,
)
from cbrcore.context import Context
from cbrcore.experiment import ExperimentResult, Size, spread
from cbrcore.tasks import task_runner

if TYPE_CHECKING:
    from matplotlib.figure import Figure

SIMILARITY = {"normalise": "case", "constraint": "both"}
"""How the learning experiment compares situations (see the module docstring)."""

AROUND = {"angle": 360.0}
"""The region of the detour solver and the retainer: all round the robot."""


def learning_config(robot: str, world_seed: int, trials: int, seed: int,
                    casebase: Path | None) -> dict[str, Any]:
    """The configuration of ``robot`` driving ``trials`` times from start to target in the
    scenario world of ``world_seed``."""
    world = {"use": "world2d_generated", "kind": "scenario", "seed": world_seed}
    workload = {"trials": [{"start": "start", "target": "target"}], "repeat": trials,
                "camera": {"fov": 360.0}}
    config = robot_config(robot, world, workload, seed, casebase)
    if robot == "cbr-learning":
        config["retrieve"] = {"use": "landmarks", "similarity": SIMILARITY, "course": True}
        config["retain"] = [{"use": "landmark_trouble", "region": AROUND,
                             "similarity": SIMILARITY}]
    if config.get("solver") == "landmark_detour":
        config["solver"] = {"use": "landmark_detour", "region": AROUND}
    return config


def drive_worlds(job: tuple[str, int, int, int, Path]) -> dict[str, Any]:
    """One robot of one seed through its worlds, given as (robot, seed, worlds, trials per
    world, output folder): per trial its success, time, distance and the cases stored after."""
    robot, seed, count, trials, out_dir = job
    casebase = out_dir / f"seed{seed}" / f"{robot}.sqlite"
    casebase.parent.mkdir(parents=True, exist_ok=True)
    record: dict[str, Any] = {"seed": seed, "success": [], "time": [], "distance": [],
                              "cases": []}
    for w in range(count):
        world_seed = count * seed + w
        config = learning_config(robot, world_seed, trials, seed + w, casebase)
        run = drive(config, out_dir / f"seed{seed}" / robot / f"world{world_seed}")
        for row in run.rows:
            record["success"].append(row["success"])
            record["time"].append(row["time"])
            record["distance"].append(row["distance"])
            record["cases"].append(run.cases)
    return record


class Learning:
    """Success, time and distance of the four robots as they drive through worlds."""

    SCALE: ClassVar[dict[str, tuple[int, int, int, int]]] = {"ci": (1, 3, 3, 1),
                                                             "full": (4, 9, 9, 2)}
    """Seeds, training worlds, unseen worlds and trials per world."""

    def __init__(self, options: object, ctx: Context) -> None:
        self.seed = ctx.seed
        self.tasks = task_runner(ctx)

    def run(self, size: Size, out_dir: Path, progress: Progress) -> ExperimentResult:
        import matplotlib

        matplotlib.use("Agg")
        seeds, train, test, trials = self.SCALE[size]
        # a robot's worlds follow one another (its case base carries over); robots and seeds
        # are independent, each a task of the run's task runner
        jobs = [(robot, self.seed + k, train + test, trials, out_dir.resolve())
                for k in range(seeds) for robot in ROBOTS]
        runs: dict[str, list[dict[str, Any]]] = {robot: [] for robot in ROBOTS}
        for (robot, *_), record in zip(jobs, self.tasks.map(drive_worlds, jobs,
                                                            progress=progress), strict=True):
            runs[robot].append(record)
        unseen = train * trials
        summary = {robot: self._summary(runs[robot], unseen, trials) for robot in ROBOTS}
        gain = self._gain(runs, unseen)
        results = {"seeds": [self.seed + k for k in range(seeds)], "training_worlds": train,
                   "unseen_worlds": test, "trials_per_world": trials, "timeout": TIMEOUT,
                   "summary": summary, "learning_over_no_cbr": gain,
                   "configs": {robot: learning_config(robot, 0, trials, self.seed,
                                                      Path("casebase.sqlite"))
                               for robot in ROBOTS},
                   "curves": runs}
        return ExperimentResult(
            results=results, table=self._table(summary, gain, seeds, train, test, trials),
            figures={"learning_curves": self._curves(runs, unseen)})

    @staticmethod
    def _phase(record: dict[str, Any], start: int) -> dict[str, float | None]:
        """Success rate, mean time and distance of the trials that reached the target (None
        when none did), and mean time of all trials, from trial ``start`` on."""
        success = np.asarray(record["success"][start:], dtype=bool)
        time = np.asarray(record["time"][start:], dtype=float)
        distance = np.asarray(record["distance"][start:], dtype=float)
        return {"success": float(success.mean()),
                "time": float(time[success].mean()) if success.any() else None,
                "distance": float(distance[success].mean()) if success.any() else None,
                "time_all": float(time.mean())}

    def _summary(self, records: list[dict[str, Any]], unseen: int, trials: int
                 ) -> dict[str, Any]:
        """Per phase, the spread over seeds: the unseen worlds, their first trials alone (what
        the robot brought from other worlds, before it drove this one) and the training."""
        def part(record: dict[str, Any], rows: slice) -> dict[str, Any]:
            return {k: v[rows] if isinstance(v, list) else v for k, v in record.items()}

        phases = {
            "unseen": [self._phase(r, unseen) for r in records],
            "unseen_first_trials": [self._phase(part(r, slice(unseen, None, trials)), 0)
                                    for r in records],
            "training": [self._phase(part(r, slice(0, unseen)), 0) for r in records],
        }
        keys = ("success", "time", "distance", "time_all")
        summary: dict[str, Any] = {
            name: {k: spread([p[k] for p in phase if p[k] is not None]) for k in keys}
            for name, phase in phases.items()}
        summary["cases_at_end"] = spread([float(r["cases"][-1]) for r in records])
        return summary

    def _gain(self, runs: dict[str, list[dict[str, Any]]], unseen: int) -> dict[str, Any]:
        pairs = list(zip(runs["cbr-learning"], runs["no-cbr"], strict=True))
        learned = [self._phase(a, unseen) for a, _ in pairs]
        base = [self._phase(b, unseen) for _, b in pairs]
        return {"success": spread([a["success"] - b["success"]
                                   for a, b in zip(learned, base, strict=True)]),
                "time_all": spread([a["time_all"] - b["time_all"]
                                    for a, b in zip(learned, base, strict=True)])}

    @staticmethod
    def _table(summary: dict[str, Any], gain: dict[str, Any], seeds: int, train: int,
               test: int, trials: int) -> str:
        def cell(stats: dict[str, float | None], scale: float = 1.0, digits: int = 1) -> str:
            mean, std = stats["mean"], stats["std"]
            if mean is None or std is None:
                return "-"
            return f"{mean * scale:.{digits}f} ± {std * scale:.{digits}f}"

        lines = [f"{seeds} seeds; each robot drives {trials} trials from start to target in each "
                 f"of {train} training worlds, then in {test} unseen worlds (timeout "
                 f"{TIMEOUT:.0f} s). "
                 "Unseen worlds: mean ± standard deviation over seeds; time and distance of "
                 "the trials that reached their target, 'time, all' counting a failed trial "
                 "at the timeout.", "",
                 "| robot | success (%) | time (s) | distance (m) | time, all (s) | "
                 "cases at the end |", "|---|---|---|---|---|---|"]
        for robot, s in summary.items():
            u = s["unseen"]
            lines.append(f"| {robot} | {cell(u['success'], 100.0)} | {cell(u['time'])} | "
                         f"{cell(u['distance'], digits=2)} | {cell(u['time_all'])} | "
                         f"{cell(s['cases_at_end'], digits=0)} |")
        lines += ["", "The first trial in each unseen world alone (what a robot brings from the "
                  "worlds it has driven before):", "",
                  "| robot | success (%) | time, all (s) |", "|---|---|---|"]
        for robot, s in summary.items():
            f = s["unseen_first_trials"]
            lines.append(f"| {robot} | {cell(f['success'], 100.0)} | {cell(f['time_all'])} |")
        lines += ["", "Learning from an empty case base against no CBR, on the unseen worlds: "
                  f"success {cell(gain['success'], 100.0)} points, time (all trials) "
                  f"{cell(gain['time_all'])} s (mean ± standard deviation over seeds)."]
        return "\n".join(lines)

    @staticmethod
    def _curves(runs: dict[str, list[dict[str, Any]]], unseen: int) -> Figure:
        from matplotlib.figure import Figure

        figure = Figure(figsize=(13, 4.2))
        axes = [figure.add_subplot(1, 3, k + 1) for k in range(3)]
        window = 5
        for robot, records in runs.items():
            n = min(len(r["success"]) for r in records)
            for ax, key in zip(axes, ("success", "time", "distance"), strict=True):
                values = np.mean([np.asarray(r[key][:n], dtype=float) for r in records],
                                 axis=0)
                kernel = np.ones(min(window, n)) / min(window, n)
                smooth = np.convolve(values, kernel, mode="valid")
                ax.plot(np.arange(len(smooth)) + len(kernel), smooth, label=robot)
        for ax, label in zip(axes, ("success rate", "time (s)", "distance (m)"), strict=True):
            ax.axvline(unseen + 0.5, color="0.5", linestyle=":")
            ax.set_xlabel("trial")
            ax.set_ylabel(f"{label}, mean of the last {window} trials")
        axes[0].legend(fontsize=8)
        figure.suptitle("Learning across worlds: training worlds, then unseen ones (dotted)")
        return figure
