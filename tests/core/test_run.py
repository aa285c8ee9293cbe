"""Runs and experiments: ``cbrcore.run.run_workload`` and
``cbr_experiments.experiment.run_experiment``.

The toy composition ``TOY_CONFIG`` (seed 3, 30 queries drawn from 0..7, radius 1, tolerance 0,
capacity 6) is run and its files are checked against each other and against expectations that
follow from the toy domain's rules: with tolerance 0 only an exact neighbour is accepted, so every
answer executed is correct.
"""

from __future__ import annotations

import collections
import csv
import json
import platform
import statistics
from collections.abc import Callable, Mapping
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from matplotlib.figure import Figure

import cbr_observers
import cbr_stores
import cbrcore.builtins
import toy_domain
from cbr_experiments.experiment import ExperimentResult, Size, run_experiment
from cbrcore import Engine, Outcome, Proposal, hookimpl
from cbrcore.config import parse_config
from cbrcore.context import Context
from cbrcore.errors import ConfigError, PluginError
from cbrcore.plugins import Plugins, load_plugins
from cbrcore.registry import Registry
from cbrcore.run import PHASES, run_workload

COLUMNS = ["query", "q_x", "source", "fallback_reason", "retrieved", "best_similarity",
           "solution_cost", "success", "outcome_cost", "ms_retrieve", "ms_reuse", "ms_revise",
           "ms_solve", "ms_retain", "ms_forget", "ms_learn", "abs_error"]
REJECTED = "revision rejected: error 1 above 0.0"
TABLE = "| measure | paper | ours |\n|---|---|---|\n| share | 0.5 | 0.5 |\n\n"


class Drifting:
    """A metric whose column changes name after the first query."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    def measure(self, problem: int, proposal: Proposal, outcome: Outcome,
                ctx: Context) -> Mapping[str, float]:
        return {"first" if ctx.step == 0 else "later": 1.0}


class Stumbles(toy_domain.Squares):
    """The squares workload, failing to carry out the third query."""

    def execute(self, problem: int, proposal: Proposal, ctx: Context) -> Outcome:
        if ctx.step == 2:
            raise ValueError("the simulator crashed")
        return super().execute(problem, proposal, ctx)


class Reproduces:
    """An experiment returning a table, a seeded draw and one figure, reporting its progress."""

    def __init__(self, options: object, ctx: Context) -> None:
        self.ctx = ctx

    def run(self, size: Size, out_dir: Path, progress: Callable[[int, int], None]
            ) -> ExperimentResult:
        progress(1, 2)
        figure = Figure()
        figure.add_subplot().plot([0, 1, 2], [0, 1, 4])
        progress(2, 2)
        draw = int(self.ctx.rng.integers(1_000_000))
        return ExperimentResult({"size": size, "draw": draw, "out": str(out_dir)}, TABLE,
                                {"curve": figure})


class ReturnsADict(Reproduces):
    """An experiment returning plain data instead of an ExperimentResult."""

    def run(self, size: Size, out_dir: Path, progress: Callable[[int, int], None]) -> Any:
        return {"share": 0.5}


class Crashes(Reproduces):
    """An experiment that raises."""

    def run(self, size: Size, out_dir: Path, progress: Callable[[int, int], None]) -> Any:
        raise ZeroDivisionError("no queries")


class RunComponents:
    """The test-only components of this module, registered as plugin ``runs``."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("metric", "drifting", Drifting)
        registry.add("workload", "stumbles", Stumbles, options=toy_domain.SquaresOptions)
        registry.add("experiment", "reproduces", Reproduces)
        registry.add("experiment", "returns_a_dict", ReturnsADict)
        registry.add("experiment", "crashes", Crashes)


@pytest.fixture
def plugins() -> Plugins:
    return load_plugins(extra=[("toy", toy_domain), ("core", cbrcore.builtins),
                               ("stores", cbr_stores),
                               ("observers", cbr_observers), ("runs", RunComponents())],
                        entry_points=False, environ={})


def engine_for(plugins: Plugins, config: str | dict[str, Any], out_dir: Path) -> Engine:
    data = yaml.safe_load(config) if isinstance(config, str) else config
    return Engine(parse_config(data, plugins.registry), plugins=plugins, out_dir=out_dir)


def read_rows(out_dir: Path) -> list[dict[str, str]]:
    with (out_dir / "results.csv").open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def read_json(path: Path) -> Any:
    return json.loads(path.read_text(encoding="utf-8"))


@pytest.fixture
def toy_run(plugins: Plugins, tmp_path: Path) -> tuple[Path, dict[str, Any], list[tuple[int, int]]]:
    """One run of TOY_CONFIG from a file with an override: its folder, summary and progress."""
    config = tmp_path / "toy.yaml"
    config.write_text(toy_domain.TOY_CONFIG, encoding="utf-8")
    out_dir = tmp_path / "out"
    progress: list[tuple[int, int]] = []
    overrides = ["observers=[{use: trace, file: trace.jsonl}]"]
    with Engine.from_yaml(config, overrides=overrides, plugins=plugins,
                          out_dir=out_dir) as engine:
        summary = run_workload(engine, out_dir, overrides=overrides,
                               progress=lambda done, total: progress.append((done, total)))
    return out_dir, summary, progress


def test_results_have_one_row_per_query_with_the_documented_columns(
        toy_run: tuple[Path, dict[str, Any], list[tuple[int, int]]]) -> None:
    """30 rows with the columns in order; the queries are the seeded draws of the workload."""
    out_dir, _, progress = toy_run
    rows = read_rows(out_dir)
    assert list(rows[0]) == COLUMNS
    assert [int(r["query"]) for r in rows] == list(range(30))
    expected = np.random.default_rng(3).integers(0, 8, size=30)
    assert [int(r["q_x"]) for r in rows] == [int(x) for x in expected]
    # the total is told before the first query, so a display shows it from the start
    assert progress == [(done, 30) for done in range(31)]


def test_rows_follow_the_toy_rules(
        toy_run: tuple[Path, dict[str, Any], list[tuple[int, int]]]) -> None:
    """With tolerance 0 only an exact neighbour (similarity 1) answers, always correctly; the
    solver answers when nothing is within radius 1 or the neighbour at distance 1 is rejected.
    Phase time columns are filled exactly for the phases that ran."""
    out_dir, _, _ = toy_run
    seen: set[str] = set()
    for row in read_rows(out_dir):
        assert (row["success"], row["outcome_cost"], row["abs_error"]) == ("True", "0.0", "0.0")
        if row["source"] == "casebase":
            assert row["q_x"] in seen
            assert (row["fallback_reason"], row["best_similarity"]) == ("", "1.0")
            assert (row["solution_cost"], row["ms_solve"]) == ("", "")
            assert row["ms_reuse"] and row["ms_revise"]
        elif row["fallback_reason"] == "no usable retrieval":
            assert row["source"] == "solver:compute"
            assert (row["retrieved"], row["best_similarity"]) == ("0", "")
            assert (row["ms_reuse"], row["ms_revise"]) == ("", "")
        else:
            assert (row["source"], row["fallback_reason"]) == ("solver:compute", REJECTED)
            assert int(row["retrieved"]) >= 1 and row["best_similarity"] == "0.5"
        assert row["ms_retrieve"] and row["ms_retain"] and row["ms_forget"]
        # the whole learn step holds its retain and forget phases (4 decimals are written)
        learn = float(row["ms_learn"])
        assert learn >= float(row["ms_retain"]) + float(row["ms_forget"]) - 2e-4
        seen.add(row["q_x"])


def test_the_summary_agrees_with_the_rows(
        toy_run: tuple[Path, dict[str, Any], list[tuple[int, int]]]) -> None:
    """Counts, CBR share, success rate, reasons, medians and metric means recomputed from the
    CSV equal summary.json and the returned summary."""
    out_dir, returned, _ = toy_run
    summary = read_json(out_dir / "summary.json")
    assert summary == json.loads(json.dumps(returned))
    rows = read_rows(out_dir)
    sources = collections.Counter(r["source"] for r in rows)
    assert summary["queries"] == summary["learned"] == len(rows) == 30
    assert summary["from_casebase"] == sources["casebase"]
    assert summary["from_solver"] == sources["solver:compute"]
    assert summary["unsolved"] == sources["none"] == 0
    assert summary["from_casebase"] > 0 and summary["from_solver"] > 0
    assert summary["cbr_share"] == pytest.approx(sources["casebase"] / 30)
    assert summary["success_rate"] == sum(r["success"] == "True" for r in rows) / 30 == 1.0
    assert summary["fallback_reasons"] == collections.Counter(
        r["fallback_reason"] for r in rows if r["source"] != "casebase")
    assert summary["mean_outcome_cost"] == 0.0
    assert summary["metric_means"] == {"abs_error": 0.0}
    medians = {phase: statistics.median(float(r[f"ms_{phase}"]) for r in rows
                                        if r[f"ms_{phase}"])
               for phase in PHASES if any(r[f"ms_{phase}"] for r in rows)}
    assert summary["median_ms"] == pytest.approx(medians)
    assert set(medians) == set(PHASES)


def test_the_manifest_records_what_repeats_the_run(
        plugins: Plugins, toy_run: tuple[Path, dict[str, Any], list[tuple[int, int]]]) -> None:
    """Resolved configuration (defaults written out, override applied), seed, versions, plugins
    and overrides."""
    out_dir, _, _ = toy_run
    manifest = read_json(out_dir / "manifest.json")
    config_file = out_dir.parent.resolve() / "toy.yaml"
    assert manifest["config"] == {
        "seed": 3,
        "casebase": {"use": "memory", "initial": None, "worlds": "one"},
        "retrieve": {"use": "nearest", "radius": 1},
        "reuse": {"use": "tangent"},
        "revise": {"use": "tolerance", "tolerance": 0.0},
        "solver": {"use": "compute"},
        "workload": {"use": "squares", "count": 30, "high": 8},
        "retain": [{"use": "keep"}],
        "forget": [{"use": "capacity", "limit": 6}],
        "observers": [{"use": "trace", "file": "trace.jsonl"}],  # in the run folder
        "metrics": [{"use": "abs_error"}],
    }
    assert manifest["config_file"] == str(config_file)
    assert manifest["seed"] == 3
    assert manifest["python"] == platform.python_version()
    assert manifest["cbrcore"] == metadata.version("cbrcore")
    assert manifest["packages"]["numpy"] == np.__version__
    assert manifest["packages"]["pluggy"] == metadata.version("pluggy")
    assert manifest["plugins"] == [{"name": p.name, "distribution": p.distribution,
                                    "version": p.version} for p in plugins.loaded]
    assert [p["name"] for p in manifest["plugins"]] == [
        "toy", "core", "stores", "observers", "runs"]
    assert manifest["overrides"] == ["observers=[{use: trace, file: trace.jsonl}]"]


def test_a_metric_with_inconsistent_columns_is_a_plugin_error(plugins: Plugins,
                                                              tmp_path: Path) -> None:
    """The second query's columns differ from the first's: the run stops with a PluginError, and
    the row already written stays in results.csv."""
    config = toy_domain.TOY_CONFIG.replace("metrics: [abs_error]", "metrics: [drifting]")
    with engine_for(plugins, config, tmp_path) as engine, pytest.raises(PluginError) as caught:
        run_workload(engine, tmp_path)
    assert str(caught.value).startswith("query 1: the workload's describe() or a metric gave "
                                        "columns [")
    assert "'later'" in str(caught.value) and "'first'" in str(caught.value)
    assert [r["query"] for r in read_rows(tmp_path)] == ["0"]


def test_a_workload_failing_to_execute_is_a_plugin_error(plugins: Plugins,
                                                         tmp_path: Path) -> None:
    config = toy_domain.TOY_CONFIG.replace("use: squares", "use: stumbles")
    with engine_for(plugins, config, tmp_path) as engine, pytest.raises(PluginError) as caught:
        run_workload(engine, tmp_path)
    assert str(caught.value) == ("workload 'stumbles' failed to execute query 2: ValueError: "
                                 "the simulator crashed")
    assert isinstance(caught.value.__cause__, ValueError)
    assert len(read_rows(tmp_path)) == 2


def test_a_run_without_a_workload_is_a_config_error(plugins: Plugins, tmp_path: Path) -> None:
    """Nothing to run: a ConfigError naming the slot, raised before any output is written."""
    out_dir = tmp_path / "out"
    with engine_for(plugins, "solver: compute\n", out_dir) as engine, \
            pytest.raises(ConfigError) as caught:
        run_workload(engine, out_dir)
    (problem,) = caught.value.problems
    assert problem.startswith("workload: required to run")
    assert list(out_dir.iterdir()) == []


def test_a_second_run_continues_from_the_sqlite_case_base(plugins: Plugins,
                                                          tmp_path: Path) -> None:
    """Two runs of the same seed into one folder share casebase.sqlite: the second starts with
    the cases the first kept, so it answers some queries from the case base the first time it
    sees them and its CBR share is higher. Its rows follow the first run's in results.csv,
    numbered on, and its summary says where it started."""
    config = toy_domain.TOY_CONFIG.replace("casebase: memory", "casebase: sqlite")
    kept, shares, summaries = [], [], []
    for _ in range(2):
        with engine_for(plugins, config, tmp_path) as engine:
            kept.append(engine.casebase.count(toy_domain.KIND))
            summaries.append(run_workload(engine, tmp_path))
            shares.append(summaries[-1]["cbr_share"])
            assert engine.casebase.count(toy_domain.KIND) == 6
    assert kept == [0, 6]
    assert shares[1] > shares[0]
    every = read_rows(tmp_path)
    assert [int(row["query"]) for row in every] == list(range(60))
    rows = [every[:30], every[30:]]
    assert [(s["first_query"], s["earlier_queries"], s["cases_at_start"], s["queries"])
            for s in summaries] == [(0, 0, 0, 30), (30, 30, 6, 30)]
    for run, expect_carried in zip(rows, (False, True), strict=True):
        seen: set[str] = set()
        carried = False
        for row in run:
            if row["source"] == "casebase" and row["q_x"] not in seen:
                carried = True
            seen.add(row["q_x"])
        assert carried is expect_carried
    assert (tmp_path / "casebase.sqlite").is_file()


# --- experiments ------------------------------------------------------------------------------


def test_an_experiment_writes_results_table_figures_and_manifest(plugins: Plugins,
                                                                 tmp_path: Path) -> None:
    """results.json holds the results, results.md the table, one PNG per figure, and the
    manifest names the experiment, size and seed; the experiment's generator is seeded."""
    progress: list[tuple[int, int]] = []
    out_dir = tmp_path / "exp"
    written = run_experiment("reproduces", plugins, size="ci", out_dir=out_dir, seed=5,
                             progress=lambda done, total: progress.append((done, total)))
    assert written == [out_dir / name for name in
                       ("results.json", "results.md", "manifest.json", "curve.png")]
    draw = int(np.random.default_rng(5).integers(1_000_000))
    assert read_json(out_dir / "results.json") == {"size": "ci", "draw": draw,
                                                   "out": str(out_dir)}
    assert (out_dir / "results.md").read_text(encoding="utf-8") == TABLE.rstrip() + "\n"
    assert (out_dir / "curve.png").read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
    manifest = read_json(out_dir / "manifest.json")
    assert (manifest["experiment"], manifest["size"], manifest["seed"]) == ("reproduces", "ci", 5)
    assert manifest["config"] is None
    assert manifest["cbrcore"] == metadata.version("cbrcore")
    assert [p["name"] for p in manifest["plugins"]] == [
        "toy", "core", "stores", "observers", "runs"]
    assert progress == [(1, 2), (2, 2)]


def test_an_experiment_must_return_an_experiment_result(plugins: Plugins,
                                                        tmp_path: Path) -> None:
    with pytest.raises(PluginError) as caught:
        run_experiment("returns_a_dict", plugins, size="ci", out_dir=tmp_path)
    assert str(caught.value) == ("experiment 'returns_a_dict' returned dict, expected "
                                 "ExperimentResult")
    assert not (tmp_path / "results.json").exists()


def test_an_experiment_that_raises_is_named_with_its_plugin(plugins: Plugins,
                                                            tmp_path: Path) -> None:
    with pytest.raises(PluginError) as caught:
        run_experiment("crashes", plugins, size="full", out_dir=tmp_path)
    assert str(caught.value) == ("experiment 'crashes' (plugin 'runs') failed: "
                                 "ZeroDivisionError: no queries")
    assert isinstance(caught.value.__cause__, ZeroDivisionError)
