"""The ``rupart-delivery`` experiment and the ``delivery`` workload at the ``ci`` size.

Each arm's summary is checked against the per-day and per-message files its runs wrote: the
messages of a day are each delivered or missed once, a delivery is within its deadline, the
figures per seed are the days' and the spread over seeds is theirs.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

import cbr_behaviors
import cbr_grid
import cbr_solvers
import cbr_world2d
import cbrcore.builtins
from cbr_behaviors.experiments.delivery import ARMS, MEASURES
from cbrcore.experiment import run_experiment, spread
from cbrcore.plugins import Plugins, load_plugins, use_plugins


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


def test_every_message_is_delivered_or_missed_once_and_deliveries_meet_deadlines(
        experiment: tuple[Path, dict[str, Any]]) -> None:
    out, results = experiment
    for arm in ARMS:
        for seed in results["seeds"]:
            folder = out / arm / f"seed_{seed}"
            day = rows(folder / "days.csv")[0]
            messages = rows(folder / "deliveries.csv")
            assert len(messages) == int(day["messages"])
            assert len({m["id"] for m in messages}) == len(messages)
            delivered = [m for m in messages if m["missed"] == ""]
            assert len(delivered) == int(day["delivered"])
            assert len(messages) - len(delivered) == int(day["missed"])
            for m in delivered:
                assert float(m["arrives"]) <= float(m["delivered"]) <= float(m["deadline"])
                assert float(m["time"]) == pytest.approx(float(m["delivered"])
                                                         - float(m["arrives"]))
            assert int(day["collisions"]) <= int(day["contacts"])


def test_the_summary_is_the_spread_of_the_seeds_days(
        experiment: tuple[Path, dict[str, Any]]) -> None:
    out, results = experiment
    assert set(results["summary"]) == set(ARMS)
    for arm in ARMS:
        days = [rows(out / arm / f"seed_{seed}" / "days.csv")[0] for seed in results["seeds"]]
        for measure in ("delivered", "missed", "collisions", "contacts"):
            expected = spread([float(d[measure]) for d in days])
            assert results["summary"][arm][measure] == pytest.approx(expected)
        times = [float(d["mean_delivery_time"]) for d in days]
        assert results["summary"][arm]["mean_delivery_time"] == pytest.approx(
            spread([t for t in times if math.isfinite(t)]))
        assert set(results["summary"][arm]) == set(MEASURES)


def test_the_fixed_set_never_consults_and_the_cbr_arms_do(
        experiment: tuple[Path, dict[str, Any]]) -> None:
    out, results = experiment
    for arm in ARMS:
        for seed in results["seeds"]:
            consultations = int(rows(out / arm / f"seed_{seed}" / "days.csv")[0][
                "consultations"])
            assert (consultations == 0) == (arm == "fixed")
    for seed in results["seeds"]:
        assert int(rows(out / "cbr" / f"seed_{seed}" / "days.csv")[0]["adapted"]) == 0
