"""``landmark-learning``: learning situations across environments (002 sections 1 and 5).

002's stated goal is to "learn the different situations a robot encounters as it navigates
through *several* environments" and reuse them in unknown ones. For each seed, the robots of
:data:`LEARNING_ROBOTS` drive from start to target through a sequence of seeded worlds like
002's scenarios (:func:`cbr_world2d.generate.scenario`), of every shape in
:data:`~cbr_world2d.generate.SCENES` (a V, a U, a wall, a dead-end corridor, a wall with a gap,
a room round the start): first the *training* worlds, then *unseen* ones, each phase going
round the shapes in turn. World ``w`` of seed ``k`` is generated from seed ``count * k + w``
(``count`` the worlds per seed, a multiple of the six shapes), so its shape is the ``w % 6``-th.
The learning robot keeps one case base across the whole sequence (and goes on learning in the
unseen worlds, as a robot would); the others have none.

A robot drives several trials in each world. The first trial in an unseen world measures
*transfer*: what the robot brings from the worlds it drove before. The later ones measure
*repetition*: what it learned in this world on the trials before. The table reports both per
robot and per shape, and the learning curves draw them apart, a panel per shape.

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

from cbr_experiments.experiment import ExperimentResult, Size, spread
from cbr_experiments.tasks import task_runner
from cbr_landmarks.experiments.common import TIMEOUT, Progress, drive, robot_config
from cbr_stores.components import SQLITE_FILE
from cbr_world2d.generate import SCENES
from cbrcore.context import Context
from cbrcore.run_folder import remove

if TYPE_CHECKING:
    from matplotlib.figure import Figure

LEARNING_ROBOTS = ("no-cbr", "detour", "cbr-learning")
"""The robots compared: without CBR, the detour solver alone, and the CBR agent learning from
an empty case base (002's hand-made cases are measured in ``landmark-scenarios``: made for its
two layouts, they match none of these at the threshold)."""

SIMILARITY = {"normalise": "case", "constraint": "both"}
"""How the learning experiment compares situations (see the module docstring)."""

AROUND = {"angle": 360.0}
"""The region of the detour solver and the retainer: all round the robot."""

PHASES = ("transfer", "repetition")
"""The unseen worlds' trials, apart: the first in each world, and the later ones."""


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
    world, output folder): per trial its world, the world's shape, its repetition in the world
    (0 the first), success, time, distance and the cases stored after."""
    robot, seed, count, trials, out_dir = job
    casebase = out_dir / f"seed{seed}" / f"{robot}.sqlite"
    casebase.parent.mkdir(parents=True, exist_ok=True)
    # kept across this robot's worlds, not across runs of the experiment
    remove(SQLITE_FILE.files(casebase))
    keys = ("world", "shape", "repetition", "success", "time", "distance", "cases")
    record: dict[str, Any] = {"seed": seed, **{key: [] for key in keys}}
    for w in range(count):
        world_seed = count * seed + w
        config = learning_config(robot, world_seed, trials, seed + w, casebase)
        run = drive(config, out_dir / f"seed{seed}" / robot / f"world{world_seed}")
        for k, row in enumerate(run.rows):
            record["world"].append(w)
            record["shape"].append(SCENES[world_seed % len(SCENES)])
            record["repetition"].append(k)
            record["success"].append(row["success"])
            record["time"].append(row["time"])
            record["distance"].append(row["distance"])
            record["cases"].append(run.cases)
    return record


def measures(record: dict[str, Any], keep: np.ndarray) -> dict[str, float | None]:
    """Success rate, mean time and distance of the trials that reached the target (None when
    none did), and mean time of all trials (a failed one at the timeout), over the trials of
    ``record`` that ``keep`` marks; None throughout when it marks none."""
    if not keep.any():
        return {"success": None, "time": None, "distance": None, "time_all": None}
    success = np.asarray(record["success"], dtype=bool)[keep]
    time = np.asarray(record["time"], dtype=float)[keep]
    distance = np.asarray(record["distance"], dtype=float)[keep]
    return {"success": float(success.mean()),
            "time": float(time[success].mean()) if success.any() else None,
            "distance": float(distance[success].mean()) if success.any() else None,
            "time_all": float(time.mean())}


def selection(record: dict[str, Any], unseen_from: int, phase: str,
              shape: str | None = None) -> np.ndarray:
    """The trials of ``record`` in ``phase`` (``training``, ``unseen``, ``transfer``,
    ``repetition``), of worlds of ``shape`` when given."""
    world = np.asarray(record["world"])
    repetition = np.asarray(record["repetition"])
    keep = world < unseen_from if phase == "training" else world >= unseen_from
    if phase == "transfer":
        keep &= repetition == 0
    elif phase == "repetition":
        keep &= repetition > 0
    if shape is not None:
        keep &= np.asarray(record["shape"]) == shape
    return keep


KEYS = ("success", "time", "distance", "time_all")


def over_seeds(records: list[dict[str, Any]], unseen_from: int, phase: str,
               shape: str | None = None) -> dict[str, Any]:
    """Each measure's spread over seeds (the seeds where it is defined)."""
    per_seed = [measures(r, selection(r, unseen_from, phase, shape)) for r in records]
    return {k: spread([p[k] for p in per_seed if p[k] is not None]) for k in KEYS}


class Learning:
    """Success, time and distance of the robots as they drive through worlds of every shape."""

    SCALE: ClassVar[dict[str, tuple[int, int, int, int]]] = {"ci": (1, 1, 1, 2),
                                                             "full": (4, 2, 2, 3)}
    """Seeds, training worlds and unseen worlds of each shape, and trials per world."""

    def __init__(self, options: object, ctx: Context) -> None:
        self.seed = ctx.seed
        self.tasks = task_runner(ctx)

    def run(self, size: Size, out_dir: Path, progress: Progress) -> ExperimentResult:
        import matplotlib

        matplotlib.use("Agg")
        seeds, train, test, trials = self.SCALE[size]
        shapes = len(SCENES)
        count = (train + test) * shapes
        # a robot's worlds follow one another (its case base carries over); robots and seeds
        # are independent, each a task of the run's task runner
        jobs = [(robot, self.seed + k, count, trials, out_dir.resolve())
                for k in range(seeds) for robot in LEARNING_ROBOTS]
        runs: dict[str, list[dict[str, Any]]] = {robot: [] for robot in LEARNING_ROBOTS}
        for (robot, *_), record in zip(jobs, self.tasks.map(drive_worlds, jobs,
                                                            progress=progress), strict=True):
            runs[robot].append(record)
        unseen_from = train * shapes
        summary = {robot: self._summary(runs[robot], unseen_from)
                   for robot in LEARNING_ROBOTS}
        by_shape = {shape: {robot: {phase: over_seeds(runs[robot], unseen_from, phase, shape)
                                    for phase in PHASES}
                            for robot in LEARNING_ROBOTS} for shape in SCENES}
        gains = {other: self._gain(runs, other, unseen_from) for other in ("no-cbr", "detour")}
        results = {"seeds": [self.seed + k for k in range(seeds)], "shapes": list(SCENES),
                   "training_worlds_per_shape": train, "unseen_worlds_per_shape": test,
                   "trials_per_world": trials, "timeout": TIMEOUT, "summary": summary,
                   "by_shape": by_shape, "learning_over": gains,
                   "configs": {robot: learning_config(robot, 0, trials, self.seed,
                                                      Path("casebase.sqlite"))
                               for robot in LEARNING_ROBOTS},
                   "curves": runs}
        return ExperimentResult(
            results=results, table=learning_table(results),
            figures={"learning_curves": self._curves(runs, unseen_from, trials)})

    @staticmethod
    def _summary(records: list[dict[str, Any]], unseen_from: int) -> dict[str, Any]:
        """Per phase, the spread over seeds; and the cases stored at the end."""
        summary: dict[str, Any] = {
            phase: over_seeds(records, unseen_from, phase)
            for phase in ("unseen", *PHASES, "training")}
        summary["cases_at_end"] = spread([float(r["cases"][-1]) for r in records])
        return summary

    @staticmethod
    def _gain(runs: dict[str, list[dict[str, Any]]], other: str, unseen_from: int
              ) -> dict[str, Any]:
        """The learning robot less ``other`` on the unseen worlds, per seed, spread over seeds:
        success and time of all trials, of the transfer trials apart."""
        gain: dict[str, Any] = {}
        for phase in ("unseen", "transfer"):
            pairs = [(measures(a, selection(a, unseen_from, phase)),
                      measures(b, selection(b, unseen_from, phase)))
                     for a, b in zip(runs["cbr-learning"], runs[other], strict=True)]
            gain[phase] = {k: spread([a[k] - b[k] for a, b in pairs])
                           for k in ("success", "time_all")}
        return gain

    @staticmethod
    def _curves(runs: dict[str, list[dict[str, Any]]], unseen_from: int, trials: int
                ) -> Figure:
        """A panel per shape: the time of each world's first trial (transfer, solid) and the
        mean of its later trials (repetition, dashed), mean over seeds, world by world."""
        from matplotlib.figure import Figure

        figure = Figure(figsize=(14, 8))
        columns = 3
        rows = -(-len(SCENES) // columns)
        colours = dict(zip(LEARNING_ROBOTS, ("tab:gray", "tab:orange", "tab:blue"),
                           strict=True))
        for n, shape in enumerate(SCENES):
            ax = figure.add_subplot(rows, columns, n + 1)
            for robot, records in runs.items():
                worlds = sorted({w for w, s in zip(records[0]["world"], records[0]["shape"],
                                                   strict=True) if s == shape})
                x = np.arange(1, len(worlds) + 1)
                for phase, style in (("transfer", "o-"), ("repetition", "s--")):
                    if phase == "repetition" and trials < 2:
                        continue
                    y = [np.mean([np.mean(np.asarray(r["time"])[
                        (np.asarray(r["world"]) == w) & ((np.asarray(r["repetition"]) == 0)
                                                         == (phase == "transfer"))])
                        for r in records]) for w in worlds]
                    ax.plot(x, y, style, color=colours[robot], markersize=4,
                            label=f"{robot}, {phase}")
                trained = sum(w < unseen_from for w in worlds)
            ax.axvline(trained + 0.5, color="0.5", linestyle=":")
            ax.axhline(TIMEOUT, color="0.8", linewidth=0.8)
            ax.set_title(f"{shape}: training worlds, then unseen (after the dotted line)",
                         fontsize=9)
            ax.set_xlabel(f"world of shape {shape}, in the order driven")
            ax.set_ylabel("time (s; a failure at the timeout)")
            ax.set_xticks(np.arange(1, len(worlds) + 1))
        figure.axes[0].legend(fontsize=7)
        figure.suptitle("Learning across worlds, per shape: the first trial in a world "
                        "(transfer, solid) and the later ones (repetition, dashed)")
        figure.tight_layout()
        return figure


def _cell(stats: dict[str, float | None], scale: float = 1.0, digits: int = 1) -> str:
    mean, std = stats["mean"], stats["std"]
    if mean is None or std is None:
        return "-"
    return f"{mean * scale:.{digits}f} ± {std * scale:.{digits}f}"


def _mean(stats: dict[str, float | None], scale: float = 1.0, digits: int = 1) -> str:
    return "-" if stats["mean"] is None else f"{stats['mean'] * scale:.{digits}f}"


def learning_table(results: dict[str, Any]) -> str:
    """The experiment's tables in markdown, from its results: the robots on the unseen worlds,
    transfer and repetition apart; then per shape."""
    summary = results["summary"]
    seeds, trials = len(results["seeds"]), results["trials_per_world"]
    shapes = results["shapes"]
    lines = [f"{seeds} seeds; each robot drives {trials} trials from start to target in each "
             f"of {results['training_worlds_per_shape']} training worlds of each shape "
             f"({', '.join(shapes)}), then in {results['unseen_worlds_per_shape']} unseen "
             f"worlds of each (timeout {results['timeout']:.0f} s). Unseen worlds: mean ± "
             "standard deviation over seeds; time and distance of the trials that reached the "
             "target, 'time, all' counting a failed trial at the timeout. Transfer: the first "
             "trial in each unseen world; repetition: the later ones.", "",
             "| robot | trials | success (%) | time (s) | distance (m) | time, all (s) | "
             "cases at the end |", "|---|---|---|---|---|---|---|"]
    for robot, s in summary.items():
        for phase in ("unseen", *PHASES):
            u = s[phase]
            lines.append(f"| {robot} | {phase} | {_cell(u['success'], 100.0)} | "
                         f"{_cell(u['time'])} | {_cell(u['distance'], digits=2)} | "
                         f"{_cell(u['time_all'])} | "
                         f"{_cell(s['cases_at_end'], digits=0) if phase == 'unseen' else ''} |")
    lines += ["", "Per shape, on the unseen worlds (means over seeds): success (%), time (s) "
              "and distance (m) of the trials that reached the target, transfer | repetition.",
              "", "| shape | robot | success | time | distance |", "|---|---|---|---|---|"]
    for shape in shapes:
        for robot, phases in results["by_shape"][shape].items():
            t, r = phases["transfer"], phases["repetition"]
            lines.append(f"| {shape} | {robot} | {_mean(t['success'], 100.0, 0)} \\| "
                         f"{_mean(r['success'], 100.0, 0)} | {_mean(t['time'], digits=0)} \\| "
                         f"{_mean(r['time'], digits=0)} | {_mean(t['distance'], digits=2)} \\| "
                         f"{_mean(r['distance'], digits=2)} |")
    lines.append("")
    for other, label in (("no-cbr", "no CBR"), ("detour", "the detour solver alone")):
        g = results["learning_over"][other]
        lines.append(f"Learning against {label}, on the unseen worlds: success "
                     f"{_cell(g['unseen']['success'], 100.0)} points, time (all trials) "
                     f"{_cell(g['unseen']['time_all'])} s; on the transfer trials alone "
                     f"{_cell(g['transfer']['success'], 100.0)} points and "
                     f"{_cell(g['transfer']['time_all'])} s.")
    return "\n".join(lines)
