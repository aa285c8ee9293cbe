"""The learning experiment of whole-path cases: ``cbr experiment path-cases-learning``.

Kruusmaa & Svensson's claim, as the survey (section 3.1) and Šeda & Dvořák (section 4) report
it: a robot that keeps the paths it drove, with their costs, takes "those routes that have been
followed successfully" more and more, and so travels more cheaply than a planner that knows only
the map, in a world whose obstacles come and go.

The world is an office floor (``floor.grid`` beside this module, 44x27 cells): four rooms A-D,
each with a door onto a central corridor and one onto a ring corridor around the floor, and a
crossing of the central corridors. The robot's map shows every door open and every corridor
clear; in the true world three sites are blocked during a trip with their own probabilities
(:data:`SITES`): room A's central door is often shut, the crossing is often crowded, room D's
central door is seldom shut. The robot travels between the four rooms' :data:`PLACES`, start and
goal drawn at random. Each time an obstacle stops it, it loses ``collision_time`` steps and
replans around what it saw (the ``trips`` workload); its travel cost is the time the trip took
(driven length plus the time lost at stops) divided by the shortest path's length on the map,
so 1 is a shortest trip without trouble.

The robots, each driven on the same trips in the same worlds for one seed:

``map-only``
    A* on the map, from scratch on every trip: the map-only planner.
``map-learning``
    A* on a map whose cell risks learn from the trips (the ``risk_map`` retainer's ``hit_risk``):
    another way to learn, shown for comparison.
``cbr``
    whole-path cases: retrieval with probabilistic selection, the randomized search as the
    fallback and explorer (as Kruusmaa's probabilistic map-based planner), retention by the
    Hausdorff distance, ample capacity. The map does not learn: all it learns is in its cases.

and, at a fixed capacity of :data:`CAPACITY` paths, the CBR robot with each forgetting strategy
of :mod:`cbr_pathcases.forgetting`. Every robot repeats over several seeds; the tables give the
mean and the spread (standard deviation, minimum and maximum) over seeds of each robot's mean
travel cost over the last half of its trips.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from cbr_experiments.experiment import ExperimentResult, Size, spread
from cbr_experiments.tasks import task_runner
from cbr_grid.drive import DriveReport
from cbr_grid.formats import load_text
from cbr_grid.grid import Grid
from cbr_pathcases.cost import ideal_length
from cbr_pathcases.forgetting import CAPACITY_STRATEGIES
from cbrcore.config import parse_config
from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.plugins import current

if TYPE_CHECKING:
    from matplotlib.figure import Figure

Progress = Callable[[int, int], None]

PLACES: dict[str, tuple[int, int]] = {"A": (15, 7), "B": (28, 7), "C": (15, 19), "D": (28, 19)}
"""The places the robot travels between: one in each room."""

SITES: dict[str, tuple[list[tuple[int, int]], float]] = {
    "door of room A, often shut": ([(20, 7), (20, 8)], 0.9),
    "crowded crossing": ([(21, 12), (22, 12), (21, 13), (22, 13)], 0.7),
    "door of room D, seldom shut": ([(23, 18), (23, 19)], 0.1),
}
"""Where the true world differs from the map: cells blocked together, and how often."""

COLLISION_TIME = 10.0
"""Steps lost each time an obstacle stops the robot."""

CAPACITY = 6
"""The capacity at which the forgetting strategies are compared: half the 12 ordered pairs of
places, so a strategy must choose which routes to keep."""

AMPLE = 200
"""The capacity of the unconstrained CBR robot: more than its trips ever store."""

LEARNING_RISK = 0.5
"""The ``map-learning`` robot's hit_risk: a cell met twice becomes an obstacle on its map."""

WINDOW = 20
"""Trips per point of the learning curves (a moving mean)."""

ROBOTS = ("map-only", "map-learning", "cbr")


def floor() -> Grid:
    """The office floor of the experiment."""
    with resources.as_file(resources.files("cbr_pathcases") / "floor.grid") as path:
        return load_text(path)


def _workload(count: int, seed: int) -> dict[str, Any]:
    return {"use": "trips", "count": count, "seed": seed, "collision_time": COLLISION_TIME,
            "places": [list(p) for p in PLACES.values()],
            "sites": [{"cells": [list(c) for c in cells], "appear": appear}
                      for cells, appear in SITES.values()]}


def robot_config(robot: str, world: Path, count: int, seed: int) -> dict[str, Any]:
    """The configuration of ``robot``: one of :data:`ROBOTS` or a forgetting strategy's name
    (the CBR robot at :data:`CAPACITY`)."""
    base = {"seed": seed, "world": {"use": "map_file", "path": str(world)},
            "casebase": "memory"}
    if robot == "map-only":
        return {**base, "solver": "astar", "workload": _workload(count, seed)}
    if robot == "map-learning":
        return {**base, "solver": "astar", "workload": _workload(count, seed),
                "retain": [{"use": "risk_map", "hit_risk": LEARNING_RISK, "pass_relief": 0.0}]}
    if robot != "cbr" and robot not in CAPACITY_STRATEGIES:
        raise ValueError(f"unknown robot {robot!r}")
    forget = ({"use": "worst_paths", "capacity": AMPLE} if robot == "cbr"
              else {"use": robot, "capacity": CAPACITY})
    return {**base, "workload": _workload(count, seed),
            "retrieve": {"use": "path_cases", "delta": 3.0},
            "reuse": "path_cases",
            "revise": {"use": "path_quality", "ideal": "landmarks", "max_ratio": 3.0},
            "solver": {"use": "randomized", "noise": 1.0},
            "retain": ["path_cases"], "forget": [forget]}


def drive(config: Mapping[str, Any], ideal: Mapping[tuple[Any, Any], float]
          ) -> dict[str, list[Any]]:
    """Drive the trips of ``config``; per trip its relative travel cost, travel time, stops,
    where its path came from, and the number of stored paths after it."""
    plugins = current()
    record: dict[str, list[Any]] = {"cost": [], "time": [], "stops": [], "from_casebase": [],
                                    "cases": [], "pair": []}
    with Engine(parse_config(config, plugins.registry), plugins=plugins) as engine:
        for problem in engine.workload.queries(engine.ctx):
            proposal = engine.solve(problem)
            outcome = engine.workload.execute(problem, proposal, engine.ctx)
            engine.learn(problem, proposal, outcome)
            report: DriveReport = outcome.report
            record["cost"].append(report.travel_time / ideal[problem.start, problem.goal])
            record["time"].append(report.travel_time)
            record["stops"].append(report.replans)
            record["from_casebase"].append(proposal.from_casebase)
            record["cases"].append(engine.casebase.count())
            record["pair"].append(pair(problem.start, problem.goal))
            if not outcome.success:
                raise RuntimeError(f"a trip from {problem.start} to {problem.goal} failed: "
                                   f"{report.failure}")
    return record


def drive_job(job: tuple[dict[str, Any], dict[tuple[Any, Any], float]]
              ) -> dict[str, list[Any]]:
    """:func:`drive` with its arguments in one picklable tuple, as a task."""
    config, ideal = job
    return drive(config, ideal)


def pair(start: tuple[int, int], goal: tuple[int, int]) -> str:
    """The names of the places a trip joins, in alphabetical order: ``"AC"`` both ways."""
    names = {cell: name for name, cell in PLACES.items()}
    return "".join(sorted(names[start] + names[goal]))


def moving_mean(values: np.ndarray, window: int) -> np.ndarray:
    """The mean of each run of ``window`` consecutive values (fewer at the start)."""
    sums = np.cumsum(np.concatenate(([0.0], values)))
    ends = np.arange(1, len(values) + 1)
    starts = np.maximum(ends - window, 0)
    return (sums[ends] - sums[starts]) / (ends - starts)


class Learning:
    """Travel costs of the CBR robot against map-only planning, and forgetting at a capacity."""

    SCALE: ClassVar[dict[str, tuple[int, int]]] = {"ci": (2, 80), "full": (10, 400)}
    """Seeds and trips per robot and seed."""

    def __init__(self, options: object, ctx: Context) -> None:
        self.seed = ctx.seed
        self.tasks = task_runner(ctx)

    def run(self, size: Size, out_dir: Path, progress: Progress) -> ExperimentResult:
        import matplotlib

        # the experiment draws into files only; no display is needed or wanted
        matplotlib.use("Agg")
        seeds, trips = self.SCALE[size]
        grid = floor()
        world = out_dir / "floor.grid"
        world.write_text((resources.files("cbr_pathcases") / "floor.grid").read_text())
        ideal = {(a, b): ideal_length(grid, a, b) for a in PLACES.values()
                 for b in PLACES.values() if a != b}
        robots = (*ROBOTS, *CAPACITY_STRATEGIES)
        # every robot and seed drives on its own: the runs go to the run's task runner
        jobs = [(robot_config(robot, world.resolve(), trips, self.seed + k), ideal)
                for robot in robots for k in range(seeds)]
        driven = iter(self.tasks.map(drive_job, jobs, progress=progress))
        runs = {robot: [next(driven) for _ in range(seeds)] for robot in robots}
        half = trips // 2
        summary = {robot: self._summary(runs[robot], half) for robot in robots}
        paired = [float(np.mean(c["cost"][half:]) / np.mean(m["cost"][half:]))
                  for c, m in zip(runs["cbr"], runs["map-only"], strict=True)]
        results = {
            "world": {"map": "floor.grid", "width": grid.width, "height": grid.height,
                      "places": {name: list(cell) for name, cell in PLACES.items()},
                      "sites": {name: {"cells": [list(c) for c in cells], "appear": appear}
                                for name, (cells, appear) in SITES.items()},
                      "collision_time": COLLISION_TIME},
            "seeds": [self.seed + k for k in range(seeds)], "trips": trips,
            "capacity": CAPACITY, "ample_capacity": AMPLE,
            "configs": {robot: robot_config(robot, Path("floor.grid"), trips, self.seed)
                        for robot in robots},
            "summary": summary,
            "cbr_over_map_only": spread(paired),
            "curves": {robot: [r["cost"] for r in runs[robot]] for robot in robots},
        }
        return ExperimentResult(
            results=results, table=self._table(summary, paired, seeds, trips),
            figures={"learning_curve": self._curves(runs, trips),
                     "forgetting": self._forgetting(summary),
                     "floor": self._floor(grid)})

    @staticmethod
    def _summary(runs: list[dict[str, list[Any]]], half: int) -> dict[str, Any]:
        return {
            "first_half_cost": spread([float(np.mean(r["cost"][:half])) for r in runs]),
            "last_half_cost": spread([float(np.mean(r["cost"][half:])) for r in runs]),
            "last_half_stops": spread([float(np.mean(r["stops"][half:])) for r in runs]),
            "last_half_cbr_share": spread([float(np.mean(r["from_casebase"][half:]))
                                           for r in runs]),
            "final_cases": spread([float(r["cases"][-1]) for r in runs]),
            # pooled over seeds: a seed's last half may hold few trips of one pair
            "last_half_cost_by_pair": {
                key: float(np.mean([c for r in runs for c, k in zip(
                    r["cost"][half:], r["pair"][half:], strict=True) if k == key]))
                for key in sorted({k for r in runs for k in r["pair"][half:]})},
        }

    @staticmethod
    def _table(summary: Mapping[str, Any], paired: list[float], seeds: int, trips: int) -> str:
        def cell(stats: Mapping[str, float]) -> str:
            return (f"{stats['mean']:.3f} ± {stats['std']:.3f} "
                    f"({stats['min']:.3f}-{stats['max']:.3f})")

        lines = [f"Mean travel cost (travel time / shortest length on the map) over {seeds} "
                 f"seeds, {trips} trips each: mean ± standard deviation (min-max) over seeds.",
                 "", "| robot | first half | last half | stops per trip, last half "
                 "| CBR share, last half | paths stored at the end |",
                 "|---|---|---|---|---|---|"]
        for robot, stats in summary.items():
            label = robot if robot in ROBOTS else f"cbr, {robot} (capacity {CAPACITY})"
            lines.append(f"| {label} | {cell(stats['first_half_cost'])} "
                         f"| {cell(stats['last_half_cost'])} "
                         f"| {stats['last_half_stops']['mean']:.2f} "
                         f"| {stats['last_half_cbr_share']['mean']:.2f} "
                         f"| {stats['final_cases']['mean']:.1f} |")
        pairs = list(summary["cbr"]["last_half_cost_by_pair"])
        lines += ["", "Mean travel cost by the pair of places, last half, over all seeds' trips:",
                  "", f"| robot | {' | '.join(pairs)} |", f"|---|{'---|' * len(pairs)}"]
        for robot in ROBOTS:
            by_pair = summary[robot]["last_half_cost_by_pair"]
            lines.append(f"| {robot} | "
                         + " | ".join(f"{by_pair.get(key, float('nan')):.2f}" for key in pairs)
                         + " |")
        ratio = spread(paired)
        lines += ["", f"CBR over map-only, last half, paired by seed: {cell(ratio)}.", "",
                  "The paper (Kruusmaa & Svensson, as the survey reports it) gives no numbers: "
                  "the claim is that the case-based robot's travel cost falls below the "
                  "map-only planner's as it learns which routes were followed successfully."]
        return "\n".join(lines)

    @staticmethod
    def _curves(runs: Mapping[str, list[dict[str, list[Any]]]], trips: int) -> Figure:
        from matplotlib.figure import Figure

        figure = Figure(figsize=(7, 4))
        axes = figure.add_subplot()
        x = np.arange(1, trips + 1)
        for k, robot in enumerate(ROBOTS):
            curves = np.array([moving_mean(np.asarray(r["cost"]), WINDOW) for r in runs[robot]])
            axes.plot(x, curves.mean(axis=0), color=f"C{k}", label=robot)
            axes.fill_between(x, curves.min(axis=0), curves.max(axis=0), color=f"C{k}",
                              alpha=0.2)
        axes.set(xlabel="trip", ylabel=f"travel cost, mean of {WINDOW} trips",
                 title="Travel cost as the robots learn (band: min-max over seeds)")
        axes.grid(True, alpha=0.3)
        axes.legend()
        return figure

    @staticmethod
    def _forgetting(summary: Mapping[str, Any]) -> Figure:
        from matplotlib.figure import Figure

        figure = Figure(figsize=(7, 4))
        axes = figure.add_subplot()
        names = list(CAPACITY_STRATEGIES)
        stats = [summary[name]["last_half_cost"] for name in names]
        axes.bar(range(len(names)), [s["mean"] for s in stats],
                 yerr=[s["std"] for s in stats], capsize=4, color="C2")
        for k, robot in enumerate(("map-only", "cbr")):
            level = summary[robot]["last_half_cost"]["mean"]
            axes.axhline(level, color=f"C{2 * k}", linestyle="--",
                         label=f"{robot}" + ("" if robot != "cbr" else f" (capacity {AMPLE})"))
        axes.set_xticks(range(len(names)), [n.replace("_paths", "") for n in names],
                        rotation=30)
        axes.set(ylabel="travel cost, last half of the trips",
                 title=f"Forgetting strategies at a capacity of {CAPACITY} paths")
        axes.grid(True, axis="y", alpha=0.3)
        axes.legend()
        return figure

    @staticmethod
    def _floor(grid: Grid) -> Figure:
        from cbr_grid.plot import draw_grid

        figure = draw_grid(grid)
        axes = figure.axes[0]
        for k, (name, (cells, appear)) in enumerate(SITES.items()):
            xs, ys = zip(*cells, strict=True)
            axes.plot(xs, ys, "s", color=f"C{k + 1}", markersize=7,
                      label=f"{name} (p = {appear})")
        for name, (x, y) in PLACES.items():
            axes.plot(x, y, "o", color="C0", markersize=8)
            axes.annotate(name, (x, y), textcoords="offset points", xytext=(6, 4))
        axes.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")
        return figure
