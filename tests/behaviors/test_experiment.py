"""The ``rupart-delivery`` experiment and the ``delivery`` workload at the ``ci`` size.

Each arm's summary is checked against the per-day and per-message files its runs wrote: the
messages of a day are each delivered, missed or unfinished once, a delivery is within its
deadline, the figures per seed are the days' means, the spread over seeds is theirs, the paired
intervals are worked from the per-seed figures, and the ablation's effects from its runs.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy import stats

import cbr_behaviors
import cbr_grid
import cbr_solvers
import cbr_world2d
import cbrcore.builtins
from cbr_behaviors.casefiles import read_cases, shipped_cases
from cbr_behaviors.casetypes import Strategy
from cbr_behaviors.experiments.delivery import (
    ALL_STRATEGIES,
    ARMS,
    BASELINE,
    EMPTY_ARMS,
    LEARNING,
    MEASURES,
    interval,
)
from cbr_experiments.experiment import run_experiment, spread
from cbrcore.plugins import Plugins, load_plugins, use_plugins

CONSULTING = ("cbr", "cbr-learning", "learned-weights")


@pytest.fixture(scope="module")
def plugins() -> Iterator[Plugins]:
    loaded = load_plugins(extra=[("core", cbrcore.builtins), ("grid", cbr_grid),
                                 ("solvers", cbr_solvers), ("world2d", cbr_world2d),
                                 ("rupart", cbr_behaviors)], entry_points=False, environ={})
    with use_plugins(loaded):
        yield loaded


@pytest.fixture(scope="module")
def experiment(plugins: Plugins, tmp_path_factory: pytest.TempPathFactory
               ) -> tuple[Path, dict[str, Any]]:
    out = tmp_path_factory.mktemp("rupart-delivery")
    run_experiment("rupart-delivery", plugins, size="ci", out_dir=out, seed=0)
    return out, json.loads((out / "results.json").read_text(encoding="utf-8"))


def rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def days_of(out: Path, arm: str, seed: int) -> list[dict[str, str]]:
    return rows(out / "floors" / arm / f"seed_{seed}" / "days.csv")


def test_every_message_is_delivered_missed_or_unfinished_once(
        experiment: tuple[Path, dict[str, Any]]) -> None:
    out, results = experiment
    for arm in ARMS:
        for seed in results["seeds"]:
            folder = out / "floors" / arm / f"seed_{seed}"
            days = days_of(out, arm, seed)
            assert len(days) == results["days"]
            messages = rows(folder / "deliveries.csv")
            for day in days:
                mine = [m for m in messages if m["day"] == day["day"]]
                assert len(mine) == int(day["messages"])
                assert len({m["id"] for m in mine}) == len(mine)
                delivered = [m for m in mine if m["missed"] == ""]
                unfinished = [m for m in mine if m["missed"] == "unfinished"]
                assert len(delivered) == int(day["delivered"])
                assert len(unfinished) == int(day["unfinished"])
                assert len(mine) - len(delivered) - len(unfinished) == int(day["missed"])
                for m in delivered:
                    assert float(m["arrives"]) <= float(m["delivered"]) <= float(m["deadline"])
                for m in unfinished:
                    # open at the day's end with time left: not a deadline missed
                    assert float(m["deadline"]) > results["length"] - 0.5
                assert int(day["collisions"]) <= int(day["contacts"])


def test_the_summary_is_the_spread_of_the_seeds_mean_days(
        experiment: tuple[Path, dict[str, Any]]) -> None:
    out, results = experiment
    assert set(results["summary"]) == set(ARMS)
    for arm in ARMS:
        assert set(results["summary"][arm]) == set(MEASURES)
        per_seed = []
        for seed in results["seeds"]:
            days = days_of(out, arm, seed)
            figures = {}
            for m in ("delivered", "missed", "unfinished", "collisions", "busy_speed"):
                values = [float(d[m]) for d in days if math.isfinite(float(d[m]))]
                figures[m] = float(np.mean(values)) if values else math.nan
            figures["longest_stall"] = max(float(d["longest_stall"]) for d in days)
            per_seed.append(figures)
        for m in ("delivered", "missed", "unfinished", "collisions", "longest_stall"):
            assert results["summary"][arm][m] == pytest.approx(
                spread([s[m] for s in per_seed]))


def test_the_paired_differences_and_the_learning_gain_are_worked_from_the_seeds(
        experiment: tuple[Path, dict[str, Any]]) -> None:
    out, results = experiment
    seeds = results["seeds"]

    def delivered(arm: str, seed: int) -> list[float]:
        return [float(d["delivered"]) for d in days_of(out, arm, seed)]

    for arm in ARMS:
        if arm == BASELINE:
            continue
        diffs = [np.mean(delivered(arm, s)) - np.mean(delivered(BASELINE, s)) for s in seeds]
        mean = float(np.mean(diffs))
        half = stats.t.ppf(0.975, len(diffs) - 1) * np.std(diffs, ddof=1) / math.sqrt(len(diffs))
        got = results["paired"][arm]["delivered"]
        assert got["mean"] == pytest.approx(mean)
        assert got["low"] == pytest.approx(mean - half)
        assert got["high"] == pytest.approx(mean + half)
    for arm in LEARNING:
        gains = [delivered(arm, s)[-1] - delivered(arm, s)[0] for s in seeds]
        assert results["learning"][arm]["gain"]["mean"] == pytest.approx(np.mean(gains))


def test_the_interval_is_the_t_interval() -> None:
    # 1, 2, 3, 2: mean 2, sd sqrt(2/3), n 4; t(0.975, 3) = 3.182446 (a table's value)
    got = interval([1.0, 2.0, 3.0, 2.0])
    half = 3.182446 * math.sqrt(2.0 / 3.0) / 2.0
    assert got["mean"] == pytest.approx(2.0)
    assert got["low"] == pytest.approx(2.0 - half) and got["high"] == pytest.approx(2.0 + half)
    assert interval([1.0])["low"] is None and interval([])["mean"] is None


def test_only_the_cbr_arms_consult_and_only_the_adapting_ones_adapt(
        experiment: tuple[Path, dict[str, Any]]) -> None:
    out, results = experiment
    for arm in ARMS:
        for seed in results["seeds"]:
            for day in days_of(out, arm, seed):
                assert (int(day["consultations"]) > 0) == (arm in CONSULTING)
                if arm == "cbr":
                    assert int(day["adapted"]) == 0
                if arm in CONSULTING:
                    assert float(day["retrievals_per_minute"]) == pytest.approx(
                        int(day["consultations"]) / (results["length"] / 60.0), abs=1e-3)


def test_the_ablation_leaves_out_each_strategy_once(
        experiment: tuple[Path, dict[str, Any]]) -> None:
    out, results = experiment
    strategies = [c.name for c in shipped_cases() if isinstance(c, Strategy)]
    ablation = results["ablation"]
    assert list(ablation) == [ALL_STRATEGIES, *(f"without {n}" for n in strategies)]
    for name in ablation:
        if name == ALL_STRATEGIES:
            continue
        kept = {c.name for c in read_cases(out / "memories" / f"{name.replace(' ', '-')}.yaml")
                if isinstance(c, Strategy)}
        assert name.removeprefix("without ") not in kept
        assert "effect" in ablation[name]
    assert set(results["empty"]) == set(EMPTY_ARMS)


def test_a_replayed_day_repeats_its_messages_and_its_noise(plugins: Plugins,
                                                           tmp_path: Path) -> None:
    """With ``replay`` a robot that learns nothing lives the same day twice, row for row; without
    it the second day brings other messages."""
    from cbr_behaviors.experiments.delivery import arm_config, run_arm

    def arrivals(replay: bool) -> tuple[list[dict[str, float]], list[list[str]]]:
        config = arm_config(BASELINE, 0, days=2, length=300.0)
        config["workload"]["replay"] = replay
        rows = run_arm(config, tmp_path / str(replay))
        with (tmp_path / str(replay) / "deliveries.csv").open(encoding="utf-8") as handle:
            messages = list(csv.DictReader(handle))
        return rows, [[m["arrives"] for m in messages if m["day"] == day] for day in ("0", "1")]

    (first, second), (monday, tuesday) = arrivals(True)
    assert monday and monday == tuesday
    assert {k: v for k, v in first.items() if k != "day"} == pytest.approx(
        {k: v for k, v in second.items() if k != "day"}, nan_ok=True)
    _, (monday, tuesday) = arrivals(False)
    assert monday != tuesday
