"""``landmark-scenarios``: 002 section 4, Figures 6 and 7.

In each of the two shipped scenario worlds (``scenario1.yaml``, ``scenario2.yaml``) the robot
drives from point A to the target the same number of times without CBR (``no-cbr``) and with the
CBR agent and its hand-made cases (``cbr-handmade``); trials differ by the sensor and odometry
noise of their seeds. The table is Figure 6 (mean time and distance of the trials that reached
the target) beside the paper's; the figure is Figure 7, one trial of each robot drawn over each
world (dashed: without CBR; solid: with it).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from cbr_landmarks.experiments.common import (
    PILOT,
    TIMEOUT,
    Driven,
    Progress,
    drive_job,
    robot_config,
)
from cbrcore.context import Context
from cbrcore.experiment import ExperimentResult, Size, spread
from cbrcore.tasks import task_runner

if TYPE_CHECKING:
    from matplotlib.figure import Figure

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
        # each robot in each world is a run of its own, handed to the run's task runner
        runs = self.tasks.map(drive_job, [
            (configs[f"{scenario}/{robot}"], out_dir.resolve() / scenario / robot)
            for scenario in SCENARIOS for robot in ROBOTS], progress=progress)
        driven: dict[str, dict[str, Driven]] = {}
        for (scenario, robot), run in zip(
                [(s, r) for s in SCENARIOS for r in ROBOTS], runs, strict=True):
            driven.setdefault(scenario, {})[robot] = run
        summary = {scenario: {robot: self._summary(driven[scenario][robot])
                              for robot in ROBOTS} for scenario in SCENARIOS}
        ratios = {scenario: self._ratios(summary[scenario]) for scenario in SCENARIOS}
        results = {"trials": trials, "timeout": TIMEOUT, "pilot": PILOT, "seed": self.seed,
                   "summary": summary, "cbr_over_no_cbr": ratios,
                   "paper": {s: {k: (None if v is None else list(v)) for k, v in p.items()}
                             for s, p in PAPER.items()},
                   "configs": configs}
        return ExperimentResult(results=results, table=self._table(summary, ratios, trials),
                                figures={"figure7": self._figure(driven)})

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

    @staticmethod
    def _figure(driven: dict[str, dict[str, Driven]]) -> Figure:
        from matplotlib.figure import Figure

        from cbr_world2d.plot import draw_world
        from cbr_world2d.worldfile import load_world

        figure = Figure(figsize=(12, 5.5))
        for k, scenario in enumerate(SCENARIOS):
            ax = figure.add_subplot(1, 2, k + 1)
            world = load_world(world_path(scenario))
            draw_world(ax, world)
            for robot, style in (("no-cbr", "--"), ("cbr-handmade", "-")):
                path = driven[scenario][robot].paths.get("trial_0")
                if path is not None:
                    ax.plot(path[:, 1], path[:, 2], style, color="black", linewidth=1.3,
                            label="without CBR" if robot == "no-cbr" else "with CBR")
            start, target = world.places["start"], world.places["target"]
            ax.plot(*target, marker="*", markersize=16, color="tab:red", linestyle="none")
            ax.annotate("A", start, textcoords="offset points", xytext=(-12, -12))
            ax.set_title(f"scenario {scenario[-1]}")
            ax.legend(loc="upper left", fontsize=8)
        figure.suptitle("002 Figure 7, rebuilt: the first trial of each robot")
        return figure
