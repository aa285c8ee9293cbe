"""The ``cbr`` command line end to end: runs, validation, errors, experiments, references.

The toy domain answers a query x with x². With the toy composition (``radius: 1``,
``tolerance: 0``, ``limit: 6``) the case base answers x exactly when x itself is stored: the
tangent from a neighbour x0 = x ± 1 is off by (x - x0)² = 1 and is rejected. ``expected_rows``
replays that rule over the queries a run recorded to predict every row independently.
"""

from __future__ import annotations

import csv
import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator
from importlib import metadata
from pathlib import Path
from typing import Any

import pytest
import typer
from matplotlib.figure import Figure

import toy_domain
from cbr_experiments.experiment import ExperimentResult, Size
from cbrcore import hookimpl
from cbrcore.cli.completion import split_option_value
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.plugins import Plugins
from cbrcore.reference import config_reference
from cbrcore.registry import Registry
from cbrcore.testing import CliResult
from conftest import installed_plugins
from repo_paths import ROOT

Cli = Callable[..., CliResult]
REJECTED = "revision rejected: error 1 above 0.0"
UNUSABLE = "no usable retrieval"


def expected_rows(xs: list[int], *, limit: int = 6) -> list[dict[str, str]]:
    """The source, fallback reason, retrieved count and best similarity of each toy query.

    A stored x answers from the case base and gains a use; otherwise x is computed and stored,
    and beyond ``limit`` cases the least used, then oldest, is forgotten.
    """
    stored: dict[int, list[int]] = {}  # x -> [uses, step stored]
    rows = []
    for step, x in enumerate(xs):
        near = [x0 for x0 in stored if abs(x0 - x) <= 1]
        if x in stored:
            row = {"source": "casebase", "fallback_reason": "", "best_similarity": "1.0"}
            stored[x][0] += 1
        else:
            row = {"source": "solver:compute", "fallback_reason": REJECTED if near else UNUSABLE,
                   "best_similarity": "0.5" if near else ""}
            stored[x] = [0, step]
        rows.append({**row, "retrieved": str(len(near))})
        if len(stored) > limit:
            del stored[min(stored, key=lambda key: stored[key])]
    return rows


def read_rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def read_json(path: Path) -> Any:
    return json.loads(path.read_text(encoding="utf-8"))


def write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


# -- test-only plugins ----------------------------------------------------------------------


class Exploding:
    """A retriever and a solver that raise: a plugin broken at run time."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass


class ExplodingRetriever(Exploding):
    @hookimpl
    def cbr_retrieve(self) -> None:
        raise RuntimeError("sensor unplugged")


class ExplodingSolver(Exploding):
    @hookimpl
    def cbr_solve(self) -> None:
        raise RuntimeError("planner crashed")


class Faulty:
    """Registers components that raise inside their phase."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("retriever", "exploding", ExplodingRetriever)
        registry.add("solver", "exploding", ExplodingSolver)


class SumOfSquares:
    """Sum the squares below n: n is 4 at size ci."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    def run(self, size: Size, out_dir: Path, progress: Callable[[int, int], None]
            ) -> ExperimentResult:
        n = 4 if size == "ci" else 100
        squares = []
        for i in range(n):
            squares.append(i * i)
            progress(i + 1, n)
        figure = Figure(figsize=(2, 2))
        figure.add_subplot().plot(range(n), squares)
        return ExperimentResult(
            results={"n": n, "sum_of_squares": sum(squares)},
            table=f"| n | sum of squares |\n|---|---|\n| {n} | {sum(squares)} |",
            figures={"squares": figure})


class Lab:
    """Registers the ``sum_of_squares`` experiment."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("experiment", "sum_of_squares", SumOfSquares)


class Greeter:
    """Adds ``greet``, ``refuse`` and ``leave``."""

    @hookimpl
    def cbr_cli(self, app: typer.Typer) -> None:
        @app.command()
        def greet(name: str, loud: bool = typer.Option(False, "--loud")) -> None:
            """Greet a robot by name."""
            text = f"hello {name}"
            typer.echo(text.upper() if loud else text)

        @app.command()
        def refuse() -> None:
            """Always fail with a user error."""
            raise CbrError("refused on purpose")

        @app.command()
        def leave(code: int) -> None:
            """Leave through sys.exit."""
            sys.exit(code if code else "leaving with a message")


class Hijacker:
    """Adds a ``run`` the built-in must win over."""

    @hookimpl
    def cbr_cli(self, app: typer.Typer) -> None:
        @app.command(name="run")
        def hijack() -> None:
            """Not the run command."""
            typer.echo("hijacked")


@pytest.fixture
def toy(load_toy: Callable[..., Plugins]) -> Plugins:
    """The toy domain with the built-ins and this module's test-only plugins."""
    return load_toy(("faulty", Faulty()), ("lab", Lab()), ("greeter", Greeter()))


# -- cbr run --------------------------------------------------------------------------------


@pytest.mark.usefixtures("toy")
def test_run_writes_results_summary_and_manifest(invoke_cbr: Cli, toy_config: Path,
                                                 tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = invoke_cbr("run", str(toy_config), "--out", str(out))

    assert result.exit_code == 0, result.stderr
    assert result.stderr == ""
    assert "toy.yaml: 30 queries" in result.stdout
    rows = read_rows(out / "results.csv")
    assert [row["query"] for row in rows] == [str(i) for i in range(30)]
    xs = [int(row["q_x"]) for row in rows]
    assert all(0 <= x < 8 for x in xs)
    keys = ("source", "fallback_reason", "best_similarity", "retrieved")
    assert [{k: row[k] for k in keys} for row in rows] == expected_rows(xs)
    assert {row["success"] for row in rows} == {"True"}
    assert {row["abs_error"] for row in rows} == {"0.0"}

    summary = read_json(out / "summary.json")
    from_casebase = sum(row["source"] == "casebase" for row in rows)
    assert from_casebase > 0
    assert {key: summary[key] for key in ("queries", "from_casebase", "from_solver", "unsolved",
                                          "learned", "success_rate", "mean_outcome_cost")} == {
        "queries": 30, "from_casebase": from_casebase, "from_solver": 30 - from_casebase,
        "unsolved": 0, "learned": 30, "success_rate": 1.0, "mean_outcome_cost": 0.0}
    assert summary["cbr_share"] == pytest.approx(from_casebase / 30)
    assert summary["fallback_reasons"] == {
        reason: count for reason in (UNUSABLE, REJECTED)
        if (count := sum(row["fallback_reason"] == reason for row in rows))}
    assert summary["metric_means"] == {"abs_error": 0.0}

    manifest = read_json(out / "manifest.json")
    assert manifest["seed"] == 3
    assert manifest["config_file"] == str(toy_config.resolve())
    assert manifest["overrides"] == []
    config = manifest["config"]
    assert config["casebase"]["use"] == "memory"
    assert {key: value for key, value in config.items() if key != "casebase"} == {
        "seed": 3,
        "workload": {"use": "squares", "count": 30, "high": 8},
        "retrieve": {"use": "nearest", "radius": 1},
        "reuse": {"use": "tangent"},
        "revise": {"use": "tolerance", "tolerance": 0.0},
        "solver": {"use": "compute"},
        "retain": [{"use": "keep"}],
        "forget": [{"use": "capacity", "limit": 6}],
        "metrics": [{"use": "abs_error"}],
    }
    assert manifest["cbrcore"] == metadata.version("cbrcore")
    assert manifest["packages"]["pluggy"] == metadata.version("pluggy")
    assert [p["name"] for p in manifest["plugins"]] == [
        "toy", "core", "stores", "experiments", "observers", "faulty", "lab", "greeter"]


@pytest.mark.usefixtures("toy")
def test_run_applies_set_overrides(invoke_cbr: Cli, toy_config: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = invoke_cbr("run", str(toy_config), "--out", str(out), "--set", "workload.count=12",
                     "-s", "forget.0.limit=2", "--set", "seed=11")

    assert result.exit_code == 0, result.stderr
    rows = read_rows(out / "results.csv")
    assert len(rows) == 12
    xs = [int(row["q_x"]) for row in rows]
    keys = ("source", "fallback_reason", "best_similarity", "retrieved")
    assert [{k: row[k] for k in keys} for row in rows] == expected_rows(xs, limit=2)
    manifest = read_json(out / "manifest.json")
    assert manifest["seed"] == 11
    assert manifest["overrides"] == ["workload.count=12", "forget.0.limit=2", "seed=11"]
    assert manifest["config"]["workload"] == {"use": "squares", "count": 12, "high": 8}
    assert manifest["config"]["forget"] == [{"use": "capacity", "limit": 2}]
    assert read_json(out / "summary.json")["queries"] == 12


@pytest.mark.usefixtures("toy")
def test_trace_observer_writes_a_line_per_phase_call(invoke_cbr: Cli, tmp_path: Path) -> None:
    config = write(tmp_path / "traced.yaml", toy_domain.TOY_CONFIG + "observers: [trace]\n")
    out = tmp_path / "out"
    result = invoke_cbr("run", str(config), "--out", str(out), "--set", "workload.count=15")
    assert result.exit_code == 0, result.stderr

    rows = read_rows(out / "results.csv")
    lines = [json.loads(line) for line in
             (out / "trace.jsonl").read_text(encoding="utf-8").splitlines()]
    phases: dict[int, list[str]] = {}
    for line in lines:
        phases.setdefault(line["step"], []).append(line["phase"])
        assert "error" not in line and line["ms"] >= 0
    expected = {
        "": ["retrieve", "reuse", "revise", "retain", "forget"],
        REJECTED: ["retrieve", "reuse", "revise", "solve", "retain", "forget"],
        UNUSABLE: ["retrieve", "solve", "retain", "forget"],
    }
    assert phases == {int(row["query"]): expected[row["fallback_reason"]] for row in rows}
    retrievals = [line for line in lines if line["phase"] == "retrieve"]
    assert [line["matches"] for line in retrievals] == [int(row["retrieved"]) for row in rows]
    verdicts = [line["accepted"] for line in lines if line["phase"] == "revise"]
    assert verdicts == [row["source"] == "casebase" for row in rows if row["retrieved"] != "0"]


# -- cbr validate and bad input -------------------------------------------------------------


@pytest.mark.usefixtures("toy")
def test_validate_lists_the_selected_components(invoke_cbr: Cli, toy_config: Path) -> None:
    result = invoke_cbr("validate", str(toy_config))

    assert result.exit_code == 0, result.stderr
    assert result.stdout.splitlines() == [
        f"{toy_config}: ok",
        "  seed: 3",
        "  casebase: memory",
        "  retrieve: nearest",
        "  reuse: tangent",
        "  revise: tolerance",
        "  solver: compute",
        "  workload: squares",
        "  retain: keep",
        "  forget: capacity",
        "  metrics: abs_error",
    ]


@pytest.mark.usefixtures("toy")
def test_validate_applies_overrides(invoke_cbr: Cli, toy_config: Path) -> None:
    result = invoke_cbr("validate", str(toy_config), "--set", "solver=exploding")
    assert result.exit_code == 0, result.stderr
    assert "  solver: exploding" in result.stdout.splitlines()


def _toy_with(old: str, new: str) -> str:
    assert old in toy_domain.TOY_CONFIG
    return toy_domain.TOY_CONFIG.replace(old, new)


# (configuration text, what the one problem line says)
BAD_CONFIGS = {
    "malformed YAML": (
        _toy_with("reuse: tangent", "reuse: tangent: extra"),
        "line 5, column 15: malformed YAML: mapping values are not allowed here"),
    "unknown key": (
        toy_domain.TOY_CONFIG + "retreive: nearest\n",
        "line 11, column 1: unknown key; expected one of: casebase, forget, metrics, "
        "observers, retain, retrieve, reuse, revise, seed, solver, workload, world"),
    "unknown option": (
        _toy_with("radius: 1", "radius: 1, k: 3"),
        "retrieve.k (line 4, column 40): unknown key; expected one of: radius"),
    "wrong type": (
        _toy_with("radius: 1", "radius: '1'"),
        "retrieve.radius (line 4, column 34): expected an integer, got '1'"),
    "out of range": (
        _toy_with("limit: 6", "limit: -2"),
        "forget.0.limit (line 9, column 33): must be >= 0: -2"),
    "unknown component": (
        _toy_with("solver: compute", "solver: teleport"),
        "solver (line 7, column 9): unknown solver 'teleport'; registered: compute (plugin toy), "
        "exploding (plugin faulty)"),
}


@pytest.mark.usefixtures("toy")
@pytest.mark.parametrize("command", ["validate", "run"])
@pytest.mark.parametrize(("text", "problem"), BAD_CONFIGS.values(), ids=BAD_CONFIGS.keys())
def test_a_bad_configuration_is_one_clear_message(invoke_cbr: Cli, tmp_path: Path, command: str,
                                                  text: str, problem: str) -> None:
    config = write(tmp_path / "bad.yaml", text)

    out = ["--out", str(tmp_path / "out")] if command == "run" else []
    result = invoke_cbr(command, str(config), *out)

    assert result.exit_code == 2
    assert result.stdout == ""
    assert result.stderr == f"error: {config}: 1 problem:\n  - {problem}\n"
    assert not (tmp_path / "out").exists()


@pytest.mark.usefixtures("toy")
def test_every_problem_is_reported_at_once(invoke_cbr: Cli, tmp_path: Path) -> None:
    text = _toy_with("radius: 1", "radius: true").replace("limit: 6", "limit: 2.5")
    config = write(tmp_path / "bad.yaml", text + "seed_: 1\n")

    result = invoke_cbr("validate", str(config))

    assert result.exit_code == 2
    assert result.stderr.splitlines()[0] == f"error: {config}: 3 problems:"
    assert sorted(result.stderr.splitlines()[1:]) == sorted([
        "  - line 11, column 1: unknown key; expected one of: casebase, forget, metrics, "
        "observers, retain, retrieve, reuse, revise, seed, solver, workload, world",
        "  - retrieve.radius (line 4, column 34): expected an integer, got True",
        "  - forget.0.limit (line 9, column 33): expected an integer, got 2.5",
    ])


@pytest.mark.usefixtures("toy")
def test_a_missing_file_is_one_clear_message(invoke_cbr: Cli, tmp_path: Path) -> None:
    missing = tmp_path / "nowhere.yaml"
    for args in (("validate", str(missing)), ("run", str(missing), "--out", str(tmp_path))):
        result = invoke_cbr(*args)
        assert result.exit_code == 2
        assert result.stderr == f"error: {missing}: 1 problem:\n  - file not found\n"


@pytest.mark.usefixtures("toy")
@pytest.mark.parametrize(("slot", "phase", "message"), [
    ("retrieve", "retrieve", "RuntimeError: sensor unplugged"),
    ("solver", "solve", "RuntimeError: planner crashed"),
])
def test_a_plugin_raising_in_a_phase_is_named_with_the_phase(
        invoke_cbr: Cli, toy_config: Path, tmp_path: Path, slot: str, phase: str,
        message: str) -> None:
    result = invoke_cbr("run", str(toy_config), "--out", str(tmp_path / "out"),
                     "--set", f"{slot}=exploding")

    assert result.exit_code == 2
    assert result.stderr == (f"error: plugin 'exploding (faulty)' failed in phase {phase!r}: "
                             f"{message}\n")


@pytest.mark.usefixtures("toy")
def test_traceback_option_shows_where_an_error_came_from(invoke_cbr: Cli, toy_config: Path,
                                                         tmp_path: Path) -> None:
    bad = write(tmp_path / "bad.yaml", _toy_with("radius: 1", "radius: -1"))
    plain = invoke_cbr("validate", str(bad))
    traced = invoke_cbr("--traceback", "validate", str(bad))

    assert plain.exit_code == traced.exit_code == 2
    assert "Traceback" not in plain.stderr
    assert traced.stderr.startswith("Traceback (most recent call last):")
    assert "cbrcore.errors.ConfigError" in traced.stderr
    assert traced.stderr.endswith(plain.stderr)

    phase = invoke_cbr("--traceback", "run", str(toy_config), "--out", str(tmp_path / "out"),
                    "--set", "retrieve=exploding")
    assert phase.exit_code == 2
    # the component's own frame is shown, below the PhaseError that names it
    assert 'raise RuntimeError("sensor unplugged")' in phase.stderr
    assert "cbrcore.errors.PhaseError" in phase.stderr


@pytest.mark.usefixtures("toy")
@pytest.mark.parametrize(("args", "message"), [
    (("run", "--bogus"), "No such option: --bogus"),
    (("validate",), "Missing argument"),
    (("teleport",), "No such command 'teleport'"),
    (("experiment", "sum_of_squares", "--size", "huge"), "--size: 'huge' is not one of ci, full"),
    (("experiment",), "name an experiment, or use --list"),
    (("experiment", "sum_of_squares", "--json"), "--json goes with --list"),
    (("reference", "everything"), "WHAT: 'everything' is not one of config, hooks, cli"),
    (("reference",), "Missing argument 'WHAT'"),
])
def test_usage_errors_exit_with_code_2(invoke_cbr: Cli, args: tuple[str, ...],
                                       message: str) -> None:
    result = invoke_cbr(*args)
    assert result.exit_code == 2
    assert message in result.stderr
    assert "Traceback" not in result.stderr


def _console_env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("CBR_")}
    return {**env, "NO_COLOR": "1"}


@pytest.fixture
def cbr_script() -> str:
    """The installed ``cbr`` console script of this interpreter's environment."""
    found = shutil.which("cbr", path=str(Path(sys.executable).parent))
    if found is None:
        found = shutil.which("cbr")
    assert found is not None, "the cbr console script is not installed"
    return found


def test_console_script_exits_2_without_traceback(cbr_script: str, tmp_path: Path) -> None:
    config = write(tmp_path / "bad.yaml", "seed: 1\nretreive: nearest\n")
    expected = (f"error: {config}: 1 problem:\n  - line 2, column 1: unknown key; "
                "expected one of: casebase, forget, kinematics, metrics, observers, pilot, "
                "retain, retrieve, reuse, revise, seed, solver, workload, world\n")

    done = subprocess.run([cbr_script, "validate", str(config)], capture_output=True, text=True,
                          env=_console_env(), cwd=tmp_path, check=False)
    assert (done.returncode, done.stdout, done.stderr) == (2, "", expected)

    traced = subprocess.run([cbr_script, "--traceback", "validate", str(config)],
                            capture_output=True, text=True, env=_console_env(), cwd=tmp_path,
                            check=False)
    assert traced.returncode == 2
    assert traced.stderr.startswith("Traceback (most recent call last):")
    assert traced.stderr.endswith(expected)


# -- cbr experiment -------------------------------------------------------------------------


@pytest.mark.usefixtures("toy")
def test_experiment_list_shows_name_plugin_and_summary(invoke_cbr: Cli) -> None:
    result = invoke_cbr("experiment", "--list")
    assert result.exit_code == 0
    [line] = [line for line in result.stdout.splitlines() if "sum_of_squares" in line]
    assert "lab" in line
    assert "Sum the squares below n: n is 4 at size ci." in line


@pytest.mark.usefixtures("toy")
def test_experiment_writes_results_table_figures_and_manifest(invoke_cbr: Cli,
                                                              tmp_path: Path) -> None:
    out = tmp_path / "exp"
    result = invoke_cbr("experiment", "sum_of_squares", "--size", "ci", "--out", str(out),
                     "--seed", "7")

    assert result.exit_code == 0, result.stderr
    # 0 + 1 + 4 + 9
    assert read_json(out / "results.json") == {"n": 4, "sum_of_squares": 14}
    table = "| n | sum of squares |\n|---|---|\n| 4 | 14 |\n"
    assert (out / "results.md").read_text(encoding="utf-8") == table
    assert (out / "squares.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    manifest = read_json(out / "manifest.json")
    assert (manifest["experiment"], manifest["size"], manifest["seed"]) == (
        "sum_of_squares", "ci", 7)
    assert manifest["config"] is None
    assert table in result.stdout
    written = [line.removeprefix("wrote ") for line in result.stdout.splitlines()
               if line.startswith("wrote ")]
    assert sorted(written) == sorted(str(out / name) for name in (
        "results.json", "results.md", "manifest.json", "squares.png"))


@pytest.mark.usefixtures("toy")
def test_an_unknown_experiment_lists_the_registered_ones(invoke_cbr: Cli, tmp_path: Path) -> None:
    result = invoke_cbr("experiment", "nope", "--size", "ci", "--out", str(tmp_path / "exp"))
    assert result.exit_code == 2
    assert result.stderr == ("error: unknown experiment 'nope'; registered: sum_of_squares "
                             "(plugin lab)\n")


# -- cbr reference and plugin commands ------------------------------------------------------


def test_reference_config_documents_every_component(toy: Plugins, invoke_cbr: Cli) -> None:
    result = invoke_cbr("reference", "config")

    assert result.exit_code == 0
    assert result.stdout == config_reference(toy.registry)
    lines = result.stdout.splitlines()
    assert lines[0] == "# Configuration reference"
    assert "### `nearest`" in lines
    assert "| `radius` | int | `2` | Largest \\|x - x0\\| of a retrieved case. |" in lines
    assert "| `limit` | int | `5` | Most cases kept. |" in lines


@pytest.mark.usefixtures("toy")
def test_reference_hooks_documents_every_hook(invoke_cbr: Cli) -> None:
    result = invoke_cbr("reference", "hooks")

    assert result.exit_code == 0
    lines = result.stdout.splitlines()
    assert lines[0] == "# Hook reference"
    headings = [line for line in lines if line.startswith("## ")]
    assert headings == ["## `cbr_register`", "## `cbr_cli`", "## `cbr_world_object`",
                        "## `cbr_world_fingerprint`", "## `cbr_check_casebase`",
                        "## `cbr_casebase_formats`",
                        "## `cbr_retrieve`", "## `cbr_reuse`", "## `cbr_revise`",
                        "## `cbr_solve`", "## `cbr_retain`", "## `cbr_forget`", "## `cbr_warm`"]
    assert lines.count("*firstresult*") == 6
    assert lines.count("*collect-all*") == 7


@pytest.mark.usefixtures("toy")
def test_reference_cli_documents_every_command_a_plugin_s_included(invoke_cbr: Cli) -> None:
    result = invoke_cbr("reference", "cli")

    assert result.exit_code == 0
    lines = result.stdout.splitlines()
    assert lines[0] == "# Command line reference"
    headings = [line for line in lines if line.startswith("## `")]
    assert {"## `cbr run`", "## `cbr validate`", "## `cbr plugins`", "## `cbr experiment`",
            "## `cbr reference`", "## `cbr casebase`", "## `cbr greet`"} <= set(headings)
    assert "### `cbr casebase info`" in lines
    # usage lines, option rows with metavar, choices and defaults, as help gives them
    assert "cbr greet [OPTIONS] NAME" in lines
    assert "cbr experiment [OPTIONS] [NAME]" in lines
    assert ("| `--size [ci\\|full]` | ci: small enough for a test run (minutes at most); full: "
            "the papers' scale. | `ci` |") in lines
    assert "| `--seed SEED` | Seed of every random choice. At least 0. | `0` |" in lines
    assert "| `CONFIG` | The YAML configuration to run. | required |" in lines
    assert ("| `--out`, `-o DIR` | Output folder (default: runs/<config name>). A folder "
            "holding an earlier run of the same configuration is continued: its case base "
            "keeps its cases and results.csv grows; one holding another configuration's "
            "results is refused. |  |") in lines
    assert "| `--loud` |  |  |" in lines


def test_the_command_line_reference_is_current(cbr_plugins: Callable[..., Plugins],
                                               invoke_cbr: Cli,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """docs/reference/cli.md is ``cbr reference cli`` with the built-in plugins alone, whatever
    the width of the terminal (the page was written at the default)."""
    monkeypatch.setenv("COLUMNS", "40")
    builtin = sorted(ep.name for ep in metadata.distribution("cbrcore").entry_points
                     if ep.group == "cbr")
    plugins = cbr_plugins(entry_points=True, environ={"CBR_PLUGINS": ",".join(builtin),
                                                      "CBR_STRICT_PLUGINS": "1"})
    assert sorted(p.name for p in plugins.loaded) == builtin

    result = invoke_cbr("reference", "cli")

    assert result.exit_code == 0, result
    page = ROOT / "docs" / "reference" / "cli.md"
    assert page.read_text(encoding="utf-8") == result.stdout


@pytest.mark.usefixtures("toy")
def test_a_plugin_command_appears_and_runs(invoke_cbr: Cli) -> None:
    listing = invoke_cbr("--help")
    assert listing.exit_code == 0
    assert "greet" in listing.stdout and "Greet a robot by name." in listing.stdout

    assert invoke_cbr("greet", "rover") == CliResult(0, "hello rover\n", "")
    assert invoke_cbr("greet", "rover", "--loud") == CliResult(0, "HELLO ROVER\n", "")
    assert invoke_cbr("refuse") == CliResult(2, "", "error: refused on purpose\n")


@pytest.mark.usefixtures("toy")
def test_a_command_leaving_through_sys_exit_keeps_its_exit_code(invoke_cbr: Cli) -> None:
    assert invoke_cbr("leave", "3") == CliResult(3, "", "")
    # as the interpreter does, a message makes exit code 1 and goes to stderr
    assert invoke_cbr("leave", "0") == CliResult(1, "", "leaving with a message\n")


def test_a_plugin_command_cannot_replace_a_builtin(load_toy: Callable[..., Plugins],
                                                   invoke_cbr: Cli, toy_config: Path,
                                                   tmp_path: Path) -> None:
    load_toy(("hijacker", Hijacker()))
    result = invoke_cbr("run", str(toy_config), "--out", str(tmp_path / "out"))
    assert result.exit_code == 0
    assert "hijacked" not in result.stdout
    assert result.stderr == ("warning: plugin 'hijacker' failed to add command 'run': the name "
                             "is taken by cbrcore's own command\n")
    assert len(read_rows(tmp_path / "out" / "results.csv")) == 30


def test_cli_without_registered_plugins_uses_the_installed_ones(
        cbr_plugins: Callable[..., Plugins], invoke_cbr: Cli) -> None:
    cbr_plugins(entry_points=True)
    data = json.loads(invoke_cbr("plugins", "--json").stdout)
    assert [p["name"] for p in data["plugins"]] == installed_plugins()
    assert {"core", "observers"} <= set(installed_plugins())


@pytest.mark.usefixtures("toy")
@pytest.mark.parametrize(("content", "reason"), [
    (b"this is no database, just text " * 200, "not a SQLite database file"),
    (None, "schema version 99"),
], ids=["not-sqlite", "other-schema"])
def test_run_refuses_an_unusable_case_base_and_leaves_it_as_it_was(
        invoke_cbr: Cli, toy_config: Path, tmp_path: Path, content: bytes | None,
        reason: str) -> None:
    """A corrupt file or one of another schema version stops the run with exit code 2, a message
    naming the file, and the file's bytes untouched."""
    path = tmp_path / "cases.sqlite"
    if content is None:
        import sqlite3

        from cbr_stores.sqlite import SQLiteStore

        SQLiteStore(path).close()
        with sqlite3.connect(path) as raw:
            raw.execute("PRAGMA user_version = 99")
        raw.close()
    else:
        path.write_bytes(content)
    before = path.read_bytes()

    result = invoke_cbr("run", str(toy_config), "--out", str(tmp_path / "out"),
                     "--set", f"casebase={{use: sqlite, path: {path}}}")

    assert result.exit_code == 2
    assert str(path) in result.stderr and reason in result.stderr
    assert "Traceback" not in result.stderr
    assert path.read_bytes() == before


@pytest.mark.usefixtures("toy")
def test_run_keeps_the_default_sqlite_case_base_in_a_new_output_folder(
        invoke_cbr: Cli, toy_config: Path, tmp_path: Path) -> None:
    """``casebase: sqlite`` without a path puts casebase.sqlite in the (new) output folder, holding
    what the run retained: every distinct x of the run that the limit of 6 kept."""
    out = tmp_path / "new" / "run"
    result = invoke_cbr("run", str(toy_config), "--out", str(out), "--set", "casebase=sqlite")
    assert result.exit_code == 0, result.stderr

    with (out / "results.csv").open(newline="") as handle:
        xs = [int(row["q_x"]) for row in csv.DictReader(handle)]
    info = invoke_cbr("casebase", "info", str(out / "casebase.sqlite"), "--json")
    assert json.loads(info.stdout)["kinds"] == {toy_domain.KIND: min(6, len(set(xs)))}


# -- conventions: version, help, metavars, completion ----------------------------------------


def test_version_names_cbrcore_and_every_loaded_plugin(toy: Plugins, invoke_cbr: Cli) -> None:
    for option in ("--version", "-V"):
        result = invoke_cbr(option)
        assert result.exit_code == 0, result.stderr
        lines = result.stdout.splitlines()
        python = sys.version.split()[0]
        assert lines[0] == f"cbrcore {metadata.version('cbrcore')} (Python {python})"
        listed = [line.split() for line in lines[1:]]
        assert [words[0] for words in listed] == [p.name for p in toy.loaded]
        # the plugins of this test are registered in code, not installed from a distribution
        assert all(words[1:] == ["(registered", "in", "code)"] for words in listed)


def test_version_shows_the_distribution_of_installed_plugins(
        cbr_plugins: Callable[..., Plugins], invoke_cbr: Cli) -> None:
    cbr_plugins(entry_points=True)
    lines = invoke_cbr("-V").stdout.splitlines()
    assert f"  core{' ' * (len(max(installed_plugins(), key=len)) - 4)}  cbrcore " \
           f"{metadata.version('cbrcore')}" in lines


@pytest.mark.usefixtures("toy")
def test_cbr_alone_prints_help_and_succeeds(invoke_cbr: Cli) -> None:
    alone, helped, short = invoke_cbr(), invoke_cbr("--help"), invoke_cbr("-h")
    assert alone.exit_code == helped.exit_code == short.exit_code == 0
    assert alone.stdout.startswith("Usage: cbr [OPTIONS] COMMAND [ARGS]...")
    assert alone.stdout == helped.stdout == short.stdout
    assert "-h, --help" in alone.stdout and "-V, --version" in alone.stdout


@pytest.mark.parametrize("group", ["casebase", "sim", "map", "rupart"])
def test_a_group_alone_prints_its_help_and_succeeds(group: str, cbr_plugins: Callable[..., Plugins],
                                                    invoke_cbr: Cli) -> None:
    cbr_plugins(entry_points=True)
    alone, helped = invoke_cbr(group), invoke_cbr(group, "--help")
    assert alone.exit_code == helped.exit_code == 0
    assert alone.stdout == helped.stdout
    assert alone.stdout.startswith(f"Usage: cbr {group} [OPTIONS] COMMAND [ARGS]...")


# typer's typed placeholders and braced arguments, none of which help may show
UNREADABLE = re.compile(r"<(?:(?:str|int|float|bool|path|file|directory|datetime|uuid)(?: range)?"
                        r"|list\[[^\]]*\]|[^<>|\s]+(?:\|[^<>|\s]+)+)>|\{[a-z_]+\}")


def _command_paths(command: Any, path: tuple[str, ...] = ()) -> Iterator[tuple[tuple[str, ...],
                                                                            Any]]:
    yield path, command
    for name, sub in getattr(command, "commands", {}).items():
        yield from _command_paths(sub, (*path, name))


@pytest.mark.parametrize(("plugin_set", "some_commands"), [
    ("test", {("run",), ("experiment",), ("casebase", "import"), ("greet",)}),
    ("installed", {("sim", "run"), ("sim", "batch"), ("rupart", "add"), ("plan",),
                   ("map", "show")}),
])
def test_every_help_names_values_by_readable_metavars(
        load_toy: Callable[..., Plugins], cbr_plugins: Callable[..., Plugins], invoke_cbr: Cli,
        plugin_set: str, some_commands: set[tuple[str, ...]]) -> None:
    """Walk the whole command tree, the plugins' commands included: each command's -h is its
    --help, and neither shows a typed placeholder (``<int range>``) or a braced argument."""
    from cbrcore.cli import build_app

    if plugin_set == "test":
        load_toy(("greeter", Greeter()))
    else:
        cbr_plugins(entry_points=True)
    tree = list(_command_paths(typer.main.get_command(build_app())))
    assert some_commands <= {path for path, _ in tree}
    for path, command in tree:
        helped = invoke_cbr(*path, "--help")
        assert helped.exit_code == 0, (path, helped.stderr)
        assert invoke_cbr(*path, "-h") == helped
        assert UNREADABLE.search(helped.stdout) is None, (path, helped.stdout)
        for param in command.params:
            metavar = param.metavar
            if metavar is None:  # a flag
                assert getattr(param, "is_flag", False), (path, param.name)
            else:  # capitals, or a list of choices
                assert metavar == metavar.upper() or (
                    metavar.startswith("[") and metavar.endswith("]")), (path, metavar)


def test_unreadable_shapes_are_recognised() -> None:
    """The pattern the help walk relies on catches typer's shapes and spares real help."""
    for shape in ("{config}", "<list[str]>", "<int range>", "<path>", "<ci|full>"):
        assert UNREADABLE.search(f"  run {shape}  help") is not None, shape
    for fine in ("CONFIG", "[NAME]", "--size [ci|full]", "runs/<config name>",
                 "experiments/<name>-<size>", "'{use: sqlite, path: FILE}'", "FILE..."):
        assert UNREADABLE.search(fine) is None, fine


@pytest.mark.usefixtures("toy")
def test_help_lists_choices_and_the_registered_experiments(invoke_cbr: Cli) -> None:
    experiment = invoke_cbr("experiment", "-h").stdout
    assert "Usage: cbr experiment [OPTIONS] [NAME]" in experiment
    assert re.search(r"--size \[ci\|full\] .*\[default: ci\]", " ".join(experiment.split()))
    assert experiment.splitlines()[-2:] == ["  Experiments:", "    sum_of_squares"]
    reference = invoke_cbr("reference", "-h").stdout
    assert "Usage: cbr reference [OPTIONS] WHAT" in reference
    assert "config:" in reference and "hooks:" in reference
    run = invoke_cbr("run", "-h").stdout
    assert "Usage: cbr run [OPTIONS] CONFIG" in run
    assert "-s, --set KEY.PATH=VALUE" in run


def bash_words(line: str) -> tuple[list[str], int]:
    """The words bash hands a completion function for ``line``, the cursor at its end, and the
    index of the cursor's word: the line split at blanks and at each ``=``, which is in bash's
    COMP_WORDBREAKS and becomes a word of its own; a blank at the end begins an empty word."""
    words = [piece for blank_separated in line.split(" ")
             for piece in ([p for p in re.split("(=)", blank_separated) if p] or [""])]
    return words, len(words) - 1


def test_the_bash_words_are_those_bash_hands_over() -> None:
    """As bash 5 gives them to a ``complete -F`` function (COMP_WORDS, COMP_CWORD)."""
    assert bash_words("cbr run x.yaml --set ret") == (["cbr", "run", "x.yaml", "--set", "ret"], 4)
    assert bash_words("cbr run x.yaml --set retrieve=") == (
        ["cbr", "run", "x.yaml", "--set", "retrieve", "="], 5)
    assert bash_words("cbr run x.yaml --set retrieve=ne") == (
        ["cbr", "run", "x.yaml", "--set", "retrieve", "=", "ne"], 6)
    assert bash_words("cbr experiment ") == (["cbr", "experiment", ""], 2)


@pytest.fixture
def completing(monkeypatch: pytest.MonkeyPatch, invoke_cbr: Cli) -> Callable[..., list[str]]:
    """``completing("cbr run x.yaml --set ret")``: what bash completion offers for the last
    word of the line, through the ``_CBR_COMPLETE`` protocol the installed script uses: the
    words of :func:`bash_words` joined by newlines, as the script joins them. With
    ``split=False`` the line is split at blanks alone, as a bash without ``=`` in its
    COMP_WORDBREAKS splits it."""

    def complete(line: str, *, split: bool = True) -> list[str]:
        words, cword = bash_words(line) if split else (line.split(" "), line.count(" "))
        monkeypatch.setenv("_CBR_COMPLETE", "complete_bash")
        monkeypatch.setenv("COMP_WORDS", "\n".join(words))
        monkeypatch.setenv("COMP_CWORD", str(cword))
        result = invoke_cbr()
        assert result.exit_code == 0, result.stderr
        return result.stdout.split()

    return complete


@pytest.mark.usefixtures("toy")
def test_completion_offers_experiments_references_and_settings(
        completing: Callable[..., list[str]]) -> None:
    assert completing("cbr experiment ") == ["sum_of_squares"]
    assert completing("cbr experiment sum") == ["sum_of_squares"]
    assert completing("cbr experiment x") == []
    assert completing("cbr reference ") == ["config", "hooks", "cli"]
    assert completing("cbr run toy.yaml --set ret") == ["retain=", "retrieve="]
    assert completing("cbr validate toy.yaml -s s") == ["seed=", "solver="]


@pytest.mark.usefixtures("toy")
def test_bash_completes_the_value_after_the_equals_sign_it_split_at(
        completing: Callable[..., list[str]]) -> None:
    """Bash replaces only what follows the ``=``: the value part is offered, not the word."""
    # the toy's retriever and the faulty plugin's
    assert completing("cbr run toy.yaml --set retrieve=") == ["exploding", "nearest"]
    assert completing("cbr run toy.yaml --set retrieve=ne") == ["nearest"]
    assert completing("cbr run toy.yaml --set retrieve.use=n") == ["nearest"]
    assert completing("cbr validate toy.yaml -s forget=c") == ["capacity"]
    assert completing("cbr run toy.yaml --set forget=x") == []
    assert completing("cbr run toy.yaml --set nowhere=") == []
    assert completing("cbr run toy.yaml --set seed=") == []
    # a blank after the '=' begins a word of its own, which is no value of the key before it
    assert completing("cbr run toy.yaml --set retrieve= ") == []


@pytest.mark.usefixtures("toy")
def test_bash_without_the_split_completes_the_whole_word(
        completing: Callable[..., list[str]]) -> None:
    assert completing("cbr run toy.yaml --set retrieve=ne", split=False) == ["retrieve=nearest"]
    assert completing("cbr run toy.yaml --set forget=", split=False) == ["forget=capacity"]


@pytest.mark.usefixtures("toy")
@pytest.mark.parametrize("shell", ["zsh", "fish"])
def test_zsh_and_fish_complete_the_whole_word(shell: str, monkeypatch: pytest.MonkeyPatch,
                                              invoke_cbr: Cli) -> None:
    """Zsh and fish keep ``KEY=VALUE`` one word and pass the line typed so far."""

    def complete(line: str) -> list[str]:
        monkeypatch.setenv("_CBR_COMPLETE", f"complete_{shell}")
        monkeypatch.setenv("_TYPER_COMPLETE_ARGS", line)
        monkeypatch.setenv("_TYPER_COMPLETE_FISH_ACTION", "get-args")
        result = invoke_cbr()
        assert result.exit_code == 0, result.stderr
        if shell == "fish":  # one "value<TAB>help" line each
            return [row.split("\t")[0] for row in result.stdout.splitlines()]
        # zsh: _arguments '*: :(("value":"help" ...))', or _files when nothing matched
        return re.findall(r'(?:^|\(\()"([^"]*)"', result.stdout, flags=re.M)

    assert complete("cbr run toy.yaml --set ret") == ["retain=", "retrieve="]
    assert complete("cbr run toy.yaml --set retrieve=") == ["retrieve=exploding",
                                                             "retrieve=nearest"]
    assert complete("cbr run toy.yaml --set retrieve=ne") == ["retrieve=nearest"]
    assert complete("cbr run toy.yaml -s forget=c") == ["forget=capacity"]


def test_only_a_bash_request_for_a_split_value_is_recognised() -> None:
    """:func:`split_option_value` reads the bash protocol's variables and nothing else."""
    def split(words: list[str], cword: int, shell: str = "bash") -> tuple[str, str] | None:
        return split_option_value("cbr", {"_CBR_COMPLETE": f"complete_{shell}",
                                          "COMP_WORDS": "\n".join(words),
                                          "COMP_CWORD": str(cword)})

    assert split(["cbr", "run", "x", "--set", "retrieve", "="], 5) == ("--set", "retrieve=")
    assert split(["cbr", "run", "x", "-s", "retrieve", "=", "ne"], 6) == ("-s", "retrieve=ne")
    assert split(["cbr", "run", "x", "--set", "retrieve", "=", "ne"], 6, "zsh") is None
    assert split(["cbr", "run", "x", "--set", "retrieve=ne"], 4) is None  # whole: not split
    assert split(["cbr", "run", "x", "--set", "retrieve", "=", ""], 6) is None
    assert split(["cbr", "run", "x", "retrieve", "="], 4) is None  # no option before the key
    assert split(["cbr", "=", "x"], 2) is None
    assert split_option_value("cbr", {"_CBR_COMPLETE": "complete_bash"}) is None


# -- experiment size, tables and JSON ---------------------------------------------------------


@pytest.mark.usefixtures("toy")
@pytest.mark.parametrize(("size", "n"), [((), 4), (("--size", "full"), 100)])
def test_experiment_runs_at_ci_size_unless_told(invoke_cbr: Cli, tmp_path: Path,
                                                size: tuple[str, ...], n: int) -> None:
    out = tmp_path / "exp"
    result = invoke_cbr("experiment", "sum_of_squares", *size, "--out", str(out))
    assert result.exit_code == 0, result.stderr
    # the sum of the squares below n is (n - 1) n (2n - 1) / 6
    assert read_json(out / "results.json") == {"n": n, "sum_of_squares": (n - 1) * n * (2 * n - 1)
                                               // 6}
    assert read_json(out / "manifest.json")["size"] == ("full" if size else "ci")


LONG_SUMMARY = ("A reproduction with a summary much longer than eighty columns, which a table "
                "cut at the width of an absent terminal would wrap or truncate.")


class LongWinded(SumOfSquares):
    pass


LongWinded.__doc__ = LONG_SUMMARY


class Archive:
    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("experiment", "long_winded", LongWinded)


def test_piped_tables_keep_every_cell_whole(load_toy: Callable[..., Plugins], invoke_cbr: Cli,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    load_toy(("archive", Archive()))
    monkeypatch.setenv("COLUMNS", "30")  # ignored: the output is not a terminal
    listing = invoke_cbr("experiment", "--list")
    assert listing.exit_code == 0
    [row] = [line for line in listing.stdout.splitlines() if "long_winded" in line]
    assert LONG_SUMMARY in row and "archive" in row


def test_tables_fit_a_terminal(load_toy: Callable[..., Plugins], invoke_cbr: Cli,
                               monkeypatch: pytest.MonkeyPatch) -> None:
    load_toy(("archive", Archive()))
    monkeypatch.setenv("TTY_COMPATIBLE", "1")  # rich's way to say the output is a terminal
    monkeypatch.setenv("COLUMNS", "60")
    listing = invoke_cbr("experiment", "--list")
    assert listing.exit_code == 0
    lines = re.sub(r"\x1b\[[0-9;]*m", "", listing.stdout).splitlines()
    assert max(len(line) for line in lines) <= 60
    # the summary is wrapped within its cell, not lost
    assert "eighty" in listing.stdout and "truncate." in listing.stdout


@pytest.mark.usefixtures("toy")
def test_run_json_prints_the_summary(invoke_cbr: Cli, toy_config: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = invoke_cbr("run", str(toy_config), "--out", str(out), "--json")
    assert result.exit_code == 0, result.stderr
    printed = json.loads(result.stdout)
    assert printed == read_json(out / "summary.json")
    assert printed["queries"] == 30 and printed["learned"] == 30


@pytest.mark.usefixtures("toy")
def test_validate_json_prints_the_resolved_components(invoke_cbr: Cli, toy_config: Path) -> None:
    result = invoke_cbr("validate", str(toy_config), "--json", "--set", "forget.0.limit=4")
    assert result.exit_code == 0, result.stderr
    printed = json.loads(result.stdout)
    assert printed["config"] == str(toy_config)
    resolved = printed["resolved"]
    assert resolved["seed"] == 3
    # defaults filled in: the toy's nearest has no other option, tolerance's is written
    assert resolved["retrieve"] == {"use": "nearest", "radius": 1}
    assert resolved["forget"] == [{"use": "capacity", "limit": 4}]
    assert resolved["casebase"]["use"] == "memory"


@pytest.mark.usefixtures("toy")
def test_experiment_list_json(invoke_cbr: Cli) -> None:
    result = invoke_cbr("experiment", "--list", "--json")
    assert result.exit_code == 0, result.stderr
    assert json.loads(result.stdout) == {"experiments": [
        {"name": "sum_of_squares", "plugin": "lab",
         "summary": "Sum the squares below n: n is 4 at size ci."}]}


# -- where a problem came from ----------------------------------------------------------------


@pytest.mark.usefixtures("toy")
@pytest.mark.parametrize("command", ["validate", "run"])
def test_a_bad_set_value_names_the_option(invoke_cbr: Cli, toy_config: Path, tmp_path: Path,
                                          command: str) -> None:
    out = ["--out", str(tmp_path / "out")] if command == "run" else []
    result = invoke_cbr(command, str(toy_config), *out, "--set", "retrieve.radius=-1",
                     "--set", "workload={use: squares, count: x}")
    assert result.exit_code == 2
    assert result.stderr == (
        f"error: {toy_config}: 2 problems:\n"
        "  - --set retrieve.radius=-1: must be >= 0: -1\n"
        "  - --set workload={use: squares, count: x}: workload.count: expected an integer, "
        "got 'x'\n")
    assert not (tmp_path / "out").exists()


def test_a_default_store_from_an_unloaded_plugin_is_named(
        cbr_plugins: Callable[..., Plugins], invoke_cbr: Cli, tmp_path: Path) -> None:
    """Without ``core``, a configuration that names no case base is told where its default
    store comes from, not shown an unknown 'memory' at a line the file does not have."""
    cbr_plugins(("toy", toy_domain))
    config = write(tmp_path / "bare.yaml", "# no case base named\n" + _toy_with(
        "casebase: memory\n", ""))
    for args in (("validate",), ("run", "--out", str(tmp_path / "out"))):
        result = invoke_cbr(args[0], str(config), *args[1:])
        assert result.exit_code == 2
        assert result.stderr == (
            f"error: {config}: 1 problem:\n  - casebase: no case base is named, so the default "
            "store 'memory' is used, but plugin 'core', which provides it, is not loaded (see "
            "CBR_PLUGINS and CBR_DISABLE_PLUGINS); load it or name a store; registered stores: "
            "none\n")


def test_out_of_memory_is_one_line_and_exit_2(monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    """A command that runs out of memory ends with one line and exit code 2, the traceback
    shown on request only."""
    import cbrcore.cli as cli

    def app() -> typer.Typer:
        greedy = typer.Typer()

        @greedy.callback()
        def group() -> None:
            pass

        @greedy.command()
        def plan() -> None:
            raise MemoryError

        return greedy

    monkeypatch.setattr(cli, "build_app", app)
    assert cli.main(["plan"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: out of memory") and "Traceback" not in err
    assert "limits.md" in err
    assert cli.main(["plan", "--traceback"]) != 0
