"""``rupart-delivery``: the evaluation 004 announces and never reports.

On the office floor (``world2d_generated`` kind ``office``: hallways, rooms, doors on
schedules, people walking and carts standing for a while) a robot works simulated days of
message delivery (the ``delivery`` workload), four ways:

``fixed``
    One fixed hand-made behavior set all day, 004 Figure 4(a) (the open-area case): no case
    memory; goals, routes and the global map as for the others.
``cbr``
    CBR behavior selection from the shipped case memory, without adaptation or learning.
``adaptive``
    CBR with adaptation by the stored strategies and learning: adapted cases retained, quality
    counters kept, low-quality learned cases forgotten.
``learned-weights``
    ``adaptive`` with the index weights learned from outcomes as well.

Each runs ``days`` days per seed (the case base carrying over between the days of a seed), on
the floor of that seed; the table gives deliveries made, deadlines missed, collisions and mean
delivery time per day, mean ± sd over seeds, and the ratios of ``adaptive`` to ``fixed``.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any, ClassVar

from cbr_behaviors.casefiles import shipped_path
from cbr_world2d.pilots.behaviors import OPEN_AREA
from cbrcore.config import parse_config
from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.experiment import ExperimentResult, Size, spread
from cbrcore.plugins import current
from cbrcore.run import run_workload
from cbrcore.tasks import task_runner

ARMS = ("fixed", "cbr", "adaptive", "learned-weights")
MEASURES = ("delivered", "missed", "collisions", "contacts", "mean_delivery_time")


def arm_config(arm: str, seed: int, *, days: int, length: float,
               casebase: Path | None = None) -> dict[str, Any]:
    """The configuration of ``arm`` (one of :data:`ARMS`) for one seed's days."""
    config: dict[str, Any] = {
        "seed": seed, "world": {"use": "world2d_generated", "kind": "office"},
        "pilot": {"use": "behaviors", "behaviors": OPEN_AREA},
        "workload": {"use": "delivery", "days": days, "length": length},
    }
    if arm == "fixed":
        config["workload"]["consult"] = False
        return config
    store: Any = {"use": "memory", "initial": str(shipped_path("yaml"))}
    if casebase is not None:
        store = {"use": "sqlite", "path": str(casebase), "initial": str(shipped_path("yaml"))}
    config.update({"casebase": store, "retrieve": "rupart", "reuse": "rupart"})
    if arm == "cbr":
        config["reuse"] = {"use": "rupart", "adapt": False}
        return config
    config.update({"retain": ["rupart_cases"], "forget": ["rupart_quality"]})
    if arm == "adaptive":
        return config
    if arm == "learned-weights":
        config["retain"] = ["rupart_cases", "rupart_weights"]
        config["retrieve"] = {"use": "rupart", "learned_weights": True}
        return config
    raise ValueError(f"unknown arm {arm!r}; expected one of {', '.join(ARMS)}")


WORKERS = 2
"""Processes the experiment's runs are spread over without a scheduler (at most the machine's
cores; a Dask cluster uses its own workers)."""


def run_job(job: tuple[dict[str, Any], Path]) -> list[dict[str, float]]:
    """:func:`run_arm` with its arguments in one picklable tuple, as a task."""
    config, out_dir = job
    return run_arm(config, out_dir)


def run_arm(config: dict[str, Any], out_dir: Path) -> list[dict[str, float]]:
    """Run ``config`` with the engine, its files in ``out_dir``; the rows of days.csv."""
    plugins = current()
    with Engine(parse_config(dict(config), plugins.registry), plugins=plugins,
                out_dir=out_dir) as engine:
        run_workload(engine, out_dir)
    with (out_dir / "days.csv").open(encoding="utf-8") as handle:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(handle)]


class DeliveryExperiment:
    """The four arms over seeds (see the module docstring)."""

    SIZES: ClassVar[dict[str, dict[str, float]]] = {
        "ci": {"seeds": 2, "days": 1, "length": 150.0},
        "full": {"seeds": 5, "days": 2, "length": 1800.0},
    }

    def __init__(self, options: object, ctx: Context) -> None:
        self.seed = ctx.seed
        self.tasks = task_runner(ctx)

    def run(self, size: Size, out_dir: Path, progress: Any) -> ExperimentResult:
        plan = self.SIZES[size]
        seeds = [self.seed + k for k in range(int(plan["seeds"]))]
        days, length = int(plan["days"]), float(plan["length"])
        jobs = [(arm, seed) for seed in seeds for arm in ARMS]
        # every arm and seed is a run of its own: spread over processes, the results the same
        # as one after another (each run's randomness comes from its seed only)
        runs = self.tasks.map(run_job, [
            (arm_config(arm, seed, days=days, length=length),
             out_dir.resolve() / arm / f"seed_{seed}") for arm, seed in jobs],
            progress=progress, processes=WORKERS)
        found = dict(zip(jobs, runs, strict=True))
        per_seed = {arm: [_per_day(found[arm, seed]) for seed in seeds] for arm in ARMS}
        # a seed that delivered nothing has no delivery time: the spread is over the others
        summary = {arm: {m: spread([s[m] for s in per_seed[arm] if math.isfinite(s[m])])
                         for m in MEASURES} for arm in ARMS}
        results = {"seeds": seeds, "days": days, "length": length, "summary": summary,
                   "per_seed": per_seed, "configs": {arm: arm_config(arm, seeds[0], days=days,
                                                                     length=length)
                                                     for arm in ARMS}}
        return ExperimentResult(results=results, table=_table(summary, len(seeds), days,
                                                              length))


def _per_day(rows: list[dict[str, float]]) -> dict[str, float]:
    """One seed's figures per day, averaged over its days (mean delivery time weighted by the
    deliveries)."""
    days = len(rows)
    delivered = sum(r["delivered"] for r in rows)
    timed = sum(r["mean_delivery_time"] * r["delivered"] for r in rows if r["delivered"])
    return {"delivered": delivered / days, "missed": sum(r["missed"] for r in rows) / days,
            "collisions": sum(r["collisions"] for r in rows) / days,
            "contacts": sum(r["contacts"] for r in rows) / days,
            "mean_delivery_time": timed / delivered if delivered else float("nan")}


def _cell(s: dict[str, float | None]) -> str:
    if s["mean"] is None or s["mean"] != s["mean"]:
        return "-"
    return f"{s['mean']:.2f} ± {s['std']:.2f}"


def _table(summary: dict[str, Any], seeds: int, days: int, length: float) -> str:
    lines = [f"RUPART delivery: {seeds} seeds, {days} day(s) of {length:.0f} s each; per day, "
             "mean ± sd over seeds.", "",
             "| arm | delivered | deadlines missed | collisions | contacts | "
             "mean delivery time (s) |", "|---|---|---|---|---|---|"]
    for arm in ARMS:
        s = summary[arm]
        lines.append(f"| {arm} | " + " | ".join(_cell(s[m]) for m in MEASURES) + " |")
    return "\n".join(lines) + "\n"
