"""``rupart-delivery``: RUPART's robot against the behavior sets a user would write instead.

A robot works days of message delivery (the ``delivery`` workload) on office floors it was not
tuned on (``world2d_generated`` kind ``office_floor``: the layout, doors, furniture and people
drawn from the seed; the floors of :data:`TUNING_SEEDS` were the only ones any choice was tuned
on, and the experiment's seeds start at its ``--seed``, 0 by default), six ways:

``fixed``
    004 Figure 4(a) (the open-area case) all day: no case memory.
``best-fixed``
    The best fixed behavior set built from Table 1's primitives, goToPos + avoidObstacle +
    avoidCollision, its parameters tuned on the tuning floors (:data:`BEST_FIXED`,
    ``benchmarks/rupart_tuning.py``): the baseline a user would write.
``potential-field``
    The landmark family's potential-field pilot all day.
``cbr``
    CBR behavior selection from the shipped case memory, without adaptation or learning.
``cbr-learning``
    CBR with adaptation by the stored strategies and learning: adapted cases retained, quality
    counters kept, low-quality learned cases forgotten.
``learned-weights``
    ``cbr-learning`` with the index weights learned from outcomes as well.

Every arm has the same goal manager, global map and routes, and on a seed the same floor and
the same messages day by day; each seed's days run in a row, the case base carrying over. The
results give per arm the figures of :data:`MEASURES` per day (mean ± sd over seeds), the
paired per-seed differences of every arm from ``best-fixed`` with 95% intervals, and the
learning arms' last day against their first. A second part runs ``best-fixed``, ``cbr`` and
``cbr-learning`` on the shipped floor with nobody in it and every door open.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from cbr_behaviors.casefiles import shipped_path
from cbr_experiments.experiment import ExperimentResult, Size, spread
from cbr_experiments.tasks import task_runner
from cbr_world2d.pilots.behaviors import OPEN_AREA
from cbrcore.config import parse_config
from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.plugins import current
from cbrcore.run import run_workload
from cbrcore.run_folder import fresh_files, remove

ARMS = ("fixed", "best-fixed", "potential-field", "cbr", "cbr-learning", "learned-weights")
LEARNING = ("cbr-learning", "learned-weights")
MEASURES = ("delivered", "missed", "unfinished", "collisions", "contacts", "busy_speed",
            "retrievals_per_minute", "median_install", "longest_stall", "door_wait")
"""The figures per arm, per day: messages delivered on time, deadlines missed, messages still
open at the day's end, collisions the robot drove into, all contacts, mean speed while busy,
retrievals per minute, median seconds a retrieved set stayed installed, the longest stall
(seconds within half a metre while busy, waits before shut doors apart) and the seconds waited
before shut doors."""
BASELINE = "best-fixed"

BEST_FIXED: list[Any] = [
    [["goToPos", "curr-goal", 50, 20], "high"],
    [["avoidObstacle", 50, "moderate"], "med"],
    [["avoidCollision", 20, "moderate"], "high"],
]
"""The best fixed set of goToPos + avoidObstacle + avoidCollision found on the tuning floors
(``python benchmarks/rupart_tuning.py``: every combination of goToPos speed, avoidObstacle
distance and speed and avoidCollision distance it lists, the sets with at most one collision
a day ranked by messages delivered with collisions as the tie-break), in centimetres."""
TUNING_SEEDS = range(100, 106)
"""The office floors every tuned choice (this set, the case memory's values, the trigger
thresholds, the index weights) was tuned on; the experiment reports on others."""


def arm_config(arm: str, seed: int, *, days: int, length: float,
               casebase: Path | None = None, world: dict[str, Any] | None = None,
               log: bool = False, memory: Path | None = None) -> dict[str, Any]:
    """The configuration of ``arm`` (one of :data:`ARMS`, or :data:`ADAPTING`) for one seed's
    days on ``world`` (default: the ``office_floor`` of the seed), its case base starting from
    ``memory`` (default: the shipped memory)."""
    config: dict[str, Any] = {
        "seed": seed,
        "world": world or {"use": "world2d_generated", "kind": "office_floor"},
        "pilot": {"use": "behaviors", "behaviors": OPEN_AREA},
        "workload": {"use": "delivery", "days": days, "length": length, "log": log},
    }
    if arm in ("fixed", "best-fixed", "potential-field"):
        config["workload"]["consult"] = False
        if arm == "best-fixed":
            config["pilot"]["behaviors"] = BEST_FIXED
        elif arm == "potential-field":
            config["pilot"] = "potential_field"
        return config
    initial = str(memory or shipped_path("yaml"))
    store: Any = {"use": "memory", "initial": initial}
    if casebase is not None:
        store = {"use": "sqlite", "path": str(casebase), "initial": initial}
    config.update({"casebase": store, "retrieve": "rupart", "reuse": "rupart"})
    if arm == "cbr":
        config["reuse"] = {"use": "rupart", "adapt": False}
        return config
    if arm == ADAPTING:
        return config
    # learning arms let what the robot has learned of each case choose among near matches
    config.update({"retain": ["rupart_cases"], "forget": ["rupart_quality"],
                   "retrieve": {"use": "rupart", "quality_band": QUALITY_BAND}})
    if arm == "cbr-learning":
        return config
    if arm == "learned-weights":
        config["retain"] = ["rupart_cases", "rupart_weights"]
        config["retrieve"]["learned_weights"] = True
        return config
    raise ValueError(f"unknown arm {arm!r}; expected one of {', '.join(ARMS)}")


ADAPTING = "cbr-adapting"
"""The ablation's arm: CBR with adaptation and nothing learned, so that a strategy's effect is
its own."""
QUALITY_BAND = 0.05
"""The learning arms' ``quality_band``: a case within this of the nearest is installed instead
when its spells with the nearest in its band went demonstrably better than the nearest's with
it (docs/rupart.md, "Which near match is installed")."""

EMPTY_FLOOR = {"use": "world2d_generated", "kind": "office", "people": 0, "objects": 0,
               "doors_open": True}
"""The shipped floor with nobody in it and every door open."""
EMPTY_ARMS = ("best-fixed", "cbr", "cbr-learning")

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
    parsed = parse_config(dict(config), plugins.registry)
    # an experiment run again into its folder starts each arm afresh
    remove(fresh_files(out_dir, parsed))
    with Engine(parsed, plugins=plugins, out_dir=out_dir) as engine:
        run_workload(engine, out_dir)
    with (out_dir / "days.csv").open(encoding="utf-8") as handle:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(handle)]


def interval(values: list[float]) -> dict[str, float | None]:
    """The mean of ``values`` with its 95% t-interval (None bounds for fewer than two)."""
    from scipy import stats

    array = np.asarray([v for v in values if math.isfinite(v)], dtype=float)
    if not len(array):
        return {"mean": None, "low": None, "high": None, "n": 0}
    mean = float(array.mean())
    if len(array) < 2:
        return {"mean": mean, "low": None, "high": None, "n": 1}
    half = float(stats.t.ppf(0.975, len(array) - 1) * array.std(ddof=1) / math.sqrt(len(array)))
    return {"mean": mean, "low": mean - half, "high": mean + half, "n": len(array)}


class DeliveryExperiment:
    """The six arms over seeds (see the module docstring)."""

    SIZES: ClassVar[dict[str, dict[str, float]]] = {
        "ci": {"seeds": 2, "days": 2, "length": 120.0, "ablation_seeds": 1},
        "full": {"seeds": 10, "days": 5, "length": 1800.0, "ablation_seeds": 10},
    }

    def __init__(self, options: object, ctx: Context) -> None:
        self.seed = ctx.seed
        self.tasks = task_runner(ctx)

    def run(self, size: Size, out_dir: Path, progress: Any) -> ExperimentResult:
        plan = self.SIZES[size]
        seeds = [self.seed + k for k in range(int(plan["seeds"]))]
        days, length = int(plan["days"]), float(plan["length"])
        jobs = [("floors", arm, seed) for seed in seeds for arm in ARMS]
        jobs += [("empty", arm, 0) for arm in EMPTY_ARMS]
        memories = ablation_memories(out_dir.resolve() / "memories")
        ablated = seeds[:int(plan["ablation_seeds"])]
        jobs += [("ablation", variant, seed) for seed in ablated for variant in memories]

        def config(part: str, arm: str, seed: int) -> dict[str, Any]:
            if part == "empty":
                return arm_config(arm, seed, days=1, length=length, world=EMPTY_FLOOR)
            if part == "ablation":
                return arm_config(ADAPTING, seed, days=1, length=length, memory=memories[arm])
            return arm_config(arm, seed, days=days, length=length)

        # every arm and seed is a run of its own: spread over processes, the results the same
        # as one after another (each run's randomness comes from its seed only)
        runs = self.tasks.map(run_job, [
            (config(*job), out_dir.resolve() / job[0] / job[1] / f"seed_{job[2]}")
            for job in jobs], progress=progress, processes=WORKERS)
        found = dict(zip(jobs, runs, strict=True))
        per_day = {arm: {seed: found["floors", arm, seed] for seed in seeds} for arm in ARMS}
        per_seed = {arm: [_mean_day(per_day[arm][s]) for s in seeds] for arm in ARMS}
        summary = {arm: {m: spread([s[m] for s in per_seed[arm] if math.isfinite(s[m])])
                         for m in MEASURES} for arm in ARMS}
        paired = {arm: {m: interval([a[m] - b[m] for a, b in zip(per_seed[arm],
                                                                    per_seed[BASELINE],
                                                                    strict=True)])
                        for m in ("delivered", "collisions")}
                  for arm in ARMS if arm != BASELINE}
        learning = {arm: {"first": spread([per_day[arm][s][0]["delivered"] for s in seeds]),
                          "last": spread([per_day[arm][s][-1]["delivered"] for s in seeds]),
                          "gain": interval([per_day[arm][s][-1]["delivered"]
                                            - per_day[arm][s][0]["delivered"] for s in seeds])}
                    for arm in LEARNING}
        empty = {arm: found["empty", arm, 0][0] for arm in EMPTY_ARMS}
        ablation = _ablation(found, list(memories), ablated)
        results = {"seeds": seeds, "days": days, "length": length, "summary": summary,
                   "paired": paired, "learning": learning, "empty": empty,
                   "ablation": ablation, "ablation_seeds": ablated,
                   "per_seed": per_seed,
                   "per_day": {arm: [[row["delivered"] for row in per_day[arm][s]]
                                     for s in seeds] for arm in ARMS},
                   "tuning_seeds": list(TUNING_SEEDS), "best_fixed": BEST_FIXED,
                   "configs": {arm: arm_config(arm, seeds[0], days=days, length=length)
                               for arm in ARMS}}
        return ExperimentResult(results=results, table=table(results))


ALL_STRATEGIES = "all strategies"


def ablation_memories(folder: Path) -> dict[str, Path]:
    """The shipped memory with every adaptation strategy, and without each in turn, written as
    case bases into ``folder``: variant name -> file."""
    from cbr_behaviors.casefiles import export, shipped_cases
    from cbr_behaviors.casetypes import Strategy

    cases = shipped_cases()
    names = [c.name for c in cases if isinstance(c, Strategy)]
    folder.mkdir(parents=True, exist_ok=True)
    variants = {ALL_STRATEGIES: shipped_path("yaml")}
    for name in names:
        variants[f"without {name}"] = export(folder / f"without-{name}.yaml",
                                             [c for c in cases if c.name != name])
    return variants


def _ablation(found: dict[tuple[str, str, int], list[dict[str, float]]], variants: list[str],
              seeds: list[int]) -> dict[str, Any]:
    """Per variant: delivered, collisions, busy speed and adapted cases a day (mean ± sd over
    the seeds), and the effect of the strategy left out, the full memory less the variant,
    paired per seed."""
    rows = {v: [found["ablation", v, s][0] for s in seeds] for v in variants}
    table: dict[str, Any] = {}
    for variant in variants:
        table[variant] = {m: spread([r[m] for r in rows[variant]])
                          for m in ("delivered", "collisions", "busy_speed", "adapted")}
        if variant != ALL_STRATEGIES:
            table[variant]["effect"] = interval([
                a["delivered"] - b["delivered"]
                for a, b in zip(rows[ALL_STRATEGIES], rows[variant], strict=True)])
    return table


def _mean_day(rows: list[dict[str, float]]) -> dict[str, float]:
    """One seed's figures per day, averaged over its days (the longest stall the longest of
    any day)."""
    figures = {}
    for m in MEASURES:
        values = [r[m] for r in rows if math.isfinite(r[m])]
        if m == "longest_stall":
            figures[m] = max(values, default=math.nan)
        else:
            figures[m] = float(np.mean(values)) if values else math.nan
    return figures


def _cell(s: dict[str, float | None], digits: int = 2) -> str:
    if s["mean"] is None or s["mean"] != s["mean"]:
        return "-"
    return f"{s['mean']:.{digits}f} ± {s['std']:.{digits}f}"


def _interval(s: dict[str, float | None]) -> str:
    if s["mean"] is None:
        return "-"
    if s["low"] is None:
        return f"{s['mean']:+.2f}"
    return f"{s['mean']:+.2f} [{s['low']:+.2f}, {s['high']:+.2f}]"


HEADERS = {"delivered": "delivered", "missed": "missed", "unfinished": "unfinished",
           "collisions": "collisions", "contacts": "contacts", "busy_speed": "busy m/s",
           "retrievals_per_minute": "retrievals/min", "median_install": "install s (median)",
           "longest_stall": "longest stall s", "door_wait": "door wait s"}


def table(results: dict[str, Any]) -> str:
    """The experiment's markdown tables."""
    seeds, days = results["seeds"], results["days"]
    lines = [f"RUPART delivery on office floors {seeds[0]} to {seeds[-1]} (held out; tuning "
             f"used floors {results['tuning_seeds'][0]} to {results['tuning_seeds'][-1]}), "
             f"{days} day(s) of {results['length']:.0f} s each; per day, mean ± sd over "
             "seeds.", "",
             "| arm | " + " | ".join(HEADERS[m] for m in MEASURES) + " |",
             "|---" * (len(MEASURES) + 1) + "|"]
    for arm in ARMS:
        s = results["summary"][arm]
        lines.append(f"| {arm} | " + " | ".join(
            _cell(s[m], 3 if m == "busy_speed" else 2) for m in MEASURES) + " |")
    lines += ["", f"Paired per-seed differences from {BASELINE} (mean [95% interval]):", "",
              "| arm | delivered | collisions |", "|---|---|---|"]
    for arm, p in results["paired"].items():
        lines.append(f"| {arm} | {_interval(p['delivered'])} | {_interval(p['collisions'])} |")
    lines += ["", "Learning: delivered on the first and the last day (mean ± sd over seeds) "
              "and the paired gain:", "", "| arm | first day | last day | gain |",
              "|---|---|---|---|"]
    for arm, s in results["learning"].items():
        lines.append(f"| {arm} | {_cell(s['first'])} | {_cell(s['last'])} | "
                     f"{_interval(s['gain'])} |")
    lines += ["", "The shipped floor (seed 0) with nobody in it and every door open, one day:",
              "", "| arm | messages | delivered | busy m/s |", "|---|---|---|---|"]
    for arm, row in results["empty"].items():
        lines.append(f"| {arm} | {row['messages']:.0f} | {row['delivered']:.0f} | "
                     f"{row['busy_speed']:.3f} |")
    ablated = results["ablation_seeds"]
    lines += ["", f"Adaptation strategies left out one at a time ({ADAPTING}: adaptation, "
              f"nothing learned; floors {ablated[0]} to {ablated[-1]}, the first day); the "
              "effect of a strategy is the full memory's deliveries less those without it, "
              "paired per floor:", "",
              "| memory | delivered | collisions | busy m/s | adapted | effect on delivered |",
              "|---|---|---|---|---|---|"]
    for variant, row in results["ablation"].items():
        effect = _interval(row["effect"]) if "effect" in row else "-"
        lines.append(f"| {variant} | {_cell(row['delivered'])} | {_cell(row['collisions'])} | "
                     f"{_cell(row['busy_speed'], 3)} | {_cell(row['adapted'], 1)} | {effect} |")
    return "\n".join(lines) + "\n"
