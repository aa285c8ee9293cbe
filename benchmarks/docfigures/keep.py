"""Committing results for the pages: an experiment's run, and the baseline of 002's robot."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from .provenance import imported_units, stamped
from .results import KEPT, ROOT, FiguresError, load_json, read
from .ros2005_baseline import BASELINE, BASELINE_TIMEOUT, BASELINE_TRIALS


def keep_baseline() -> Path:
    """Run the baseline of the reproductions page (its ``baseline.py``: 100 trials per scenario
    of 002's robot without CBR) and commit every trial's summary for the page."""
    from cbr_world2d.navigator import NavigatorOptions
    from cbr_world2d.robot import ROS_2005
    from cbr_world2d.simulation import PilotRecipe, Trial, run_batch
    from cbr_world2d.worldfile import load_world

    scenarios = {}
    for name in ("scenario1", "scenario2"):
        world = load_world(ROOT / "plugins" / "cbr_world2d" / "worlds" / f"{name}.yaml")
        trial = Trial.facing(world.places["start"], world.places["target"],
                             timeout=BASELINE_TIMEOUT)
        results = run_batch(world, [trial] * BASELINE_TRIALS,
                            PilotRecipe.named("potential_field"), spec=ROS_2005,
                            navigation=NavigatorOptions(rescue="blocked"))
        scenarios[name] = {
            "landmarks": {mark.id: [mark.x, mark.y] for mark in world.landmarks},
            "trials": [result.summary() for result in results]}
    data = {"trials": BASELINE_TRIALS, "timeout": BASELINE_TIMEOUT, "scenarios": scenarios}
    return commit_kept(f"{BASELINE}.json",
                       stamped(data, "python benchmarks/figures.py --keep-baseline"))


def _curves_of(robots: Sequence[str]) -> Callable[[dict[str, Any]], dict[str, Any]]:
    """A trim keeping the learning curves of ``robots`` only, to four decimals."""
    def trim(results: dict[str, Any]) -> dict[str, Any]:
        curves = results["curves"]
        return {**results, "curves": {robot: [[round(cost, 4) for cost in seed]
                                              for seed in curves[robot]] for robot in robots}}
    return trim


#: what the pages do not quote of an experiment's results, left out of what is kept: the
#: per-trip curves of every robot would make the kept file a megabyte
TRIMS: dict[str, Callable[[dict[str, Any]], dict[str, Any]]] = {
    "path-cases-learning": _curves_of(("map-only", "cbr")),
}


def keep_experiment(name: str, run: Path) -> Path:
    """Commit the results of ``cbr experiment NAME`` written into ``run`` for the pages.

    They are stamped with the source of what the experiment's plugin package and its
    ``experiments`` modules import: ``cbr experiment`` loads every plugin, but runs one."""
    manifest = load_json(run / "manifest.json")
    results = load_json(run / "results.json")
    size = manifest.get("size")
    if manifest.get("experiment") != name:
        raise FiguresError(f"{run}: manifest.json is of experiment "
                           f"{manifest.get('experiment')!r}, not {name!r}")
    seed = manifest.get("seed")
    data = {"table": read(run / "results.md"),
            "results": TRIMS.get(name, lambda kept: kept)(results)}
    package = experiment_package(name)
    data = stamped(data, f"cbr experiment {name} --size {size} --seed {seed}",
                   unit_names=imported_units([package, f"{package}.experiments"]))
    # a run with another seed is kept beside seed 0's, for pages that quote both
    return commit_kept(f"{name}.json" if not seed else f"{name}-seed-{seed}.json", data)


def experiment_package(name: str) -> str:
    """The top-level package of the plugin that registers experiment ``name``."""
    from cbrcore.errors import CbrError
    from cbrcore.plugins import load_plugins

    try:
        component = load_plugins().registry.get("experiment", name)
    except CbrError as exc:
        raise FiguresError(f"experiment {name!r}: {exc}") from None
    return component.factory.__module__.partition(".")[0]


def commit_kept(file: str, data: dict[str, Any]) -> Path:
    """Write ``data`` into ``docs/figures/<file>``, where the pages' blocks read it."""
    KEPT.mkdir(exist_ok=True)
    target = KEPT / file
    target.write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    return target
