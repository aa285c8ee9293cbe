"""``cbr run`` and ``cbr experiment`` fail with a message, never a traceback, and leave files
that agree with the case base.

Each case is a user error or a failing plugin: the command exits with code 2, prints one
``error:`` line naming the folder, the option or the plugin, and no traceback. When a plugin
fails during a run, ``results.csv`` holds a row for exactly the learn steps the case base
committed: the test-only retainer ``tally`` counts its learn steps in the case base's meta, so
a rolled-back step leaves no count behind.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Callable, Generator, Mapping
from pathlib import Path
from typing import Any

import attrs
import pytest
import yaml

import toy_domain
from cbr_experiments.experiment import ExperimentResult, Size
from cbr_stores.sqlite import SQLiteStore
from cbrcore import Outcome, Proposal, hookimpl
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.options import option
from cbrcore.plugins import Plugins
from cbrcore.registry import Registry
from cbrcore.testing import CliResult

Cli = Callable[..., CliResult]
FAILING_STEP = 3
"""The query at which a failing component fails: three rows and learn steps precede it."""
TALLY = "tally"
HUGE = "10000000000000000000"
"""2**63 < HUGE: an integer numpy, SQLite and len() cannot hold."""


# -- test-only plugin -----------------------------------------------------------------------


@attrs.frozen
class FailOptions:
    fail: bool = option(False, f"Raise at query {FAILING_STEP}.")


class Tally:
    """A retainer counting learn steps in the case base's meta; with ``fail``, it raises."""

    def __init__(self, options: FailOptions, ctx: Context) -> None:
        self.fail = options.fail
        self.ctx = ctx

    @hookimpl
    def cbr_retain(self, casebase: CaseStore) -> None:
        casebase.set_meta(TALLY, casebase.get_meta(TALLY, 0) + 1)
        if self.fail and self.ctx.step == FAILING_STEP:
            raise RuntimeError("tally jammed")


class Gauge:
    """A metric; with ``fail``, it raises at the failing query."""

    def __init__(self, options: FailOptions, ctx: Context) -> None:
        self.fail = options.fail

    def measure(self, problem: int, proposal: Proposal, outcome: Outcome,
                ctx: Context) -> Mapping[str, float]:
        if self.fail and ctx.step == FAILING_STEP:
            raise RuntimeError("gauge broke")
        return {"gauge": 1.0}


class Shapeless:
    """A metric returning a list instead of a mapping at the failing query."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    def measure(self, problem: int, proposal: Proposal, outcome: Outcome,
                ctx: Context) -> Any:
        return [1.0] if ctx.step == FAILING_STEP else {"shape": 1.0}


class Heckler:
    """An observer that raises after the forget phase of the failing query."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl(wrapper=True)
    def cbr_forget(self, ctx: Context) -> Generator[None, Any, Any]:
        result = yield
        if ctx.step == FAILING_STEP:
            raise RuntimeError("heckler shouted")
        return result


class Tiny:
    """An experiment writing one number and one figure."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    def run(self, size: Size, out_dir: Path, progress: Callable[[int, int], None]
            ) -> ExperimentResult:
        return ExperimentResult({"n": 1}, "| n |\n|---|\n| 1 |")


class Faults:
    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("retainer", "tally", Tally, options=FailOptions)
        registry.add("metric", "gauge", Gauge, options=FailOptions)
        registry.add("metric", "shapeless", Shapeless)
        registry.add("observer", "heckler", Heckler)
        registry.add("experiment", "tiny", Tiny)


@pytest.fixture
def faults(load_toy: Callable[..., Plugins]) -> Plugins:
    return load_toy(("faults", Faults()))


def toy_config(tmp_path: Path, **changes: Any) -> Path:
    """The toy composition on an SQLite case base in the run folder, counting its learn steps
    with ``tally``, with ``changes`` to its slots."""
    data = {**yaml.safe_load(toy_domain.TOY_CONFIG), "casebase": "sqlite",
            "retain": ["keep", "tally"], **changes}
    path = tmp_path / "toy.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def assert_refused(result: CliResult, *expected: str) -> None:
    """Exit code 2, no traceback, and one error message holding each of ``expected``."""
    assert result.exit_code == 2, result
    assert "Traceback" not in result.stderr
    assert result.stderr.startswith("error: ")
    for text in expected:
        assert text in result.stderr, result.stderr


# -- --out ----------------------------------------------------------------------------------


def existing_file(tmp_path: Path) -> tuple[Path, str]:
    (tmp_path / "taken").write_text("mine\n", encoding="utf-8")
    return tmp_path / "taken", "is a file"


def below_a_file(tmp_path: Path) -> tuple[Path, str]:
    (tmp_path / "taken").write_text("mine\n", encoding="utf-8")
    return tmp_path / "taken" / "run", f"{tmp_path / 'taken'} is a file"


def read_only(tmp_path: Path) -> tuple[Path, str]:
    folder = tmp_path / "sealed"
    folder.mkdir()
    folder.chmod(0o555)
    return folder, "not writable"


@pytest.fixture
def as_if_read_only(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make a folder with no write permission unwritable for root too, who may write anyway:
    ``os.access`` answers for such a folder as it would for any other user."""
    if os.geteuid() != 0:
        return
    access = os.access

    def denying(path: Any, mode: int, **kwargs: Any) -> bool:
        readonly = Path(path).is_dir() and not Path(path).stat().st_mode & 0o222
        return access(path, mode, **kwargs) and not (readonly and mode & os.W_OK)

    monkeypatch.setattr(os, "access", denying)


OUT_PROBLEMS = pytest.mark.parametrize("problem", [existing_file, below_a_file, read_only],
                                       ids=["existing file", "below a file", "read-only"])


@OUT_PROBLEMS
@pytest.mark.usefixtures("faults", "as_if_read_only")
def test_run_refuses_an_unusable_out_folder(
        problem: Callable[[Path], tuple[Path, str]], invoke_cbr: Cli, tmp_path: Path) -> None:
    out, why = problem(tmp_path)
    result = invoke_cbr("run", str(toy_config(tmp_path)), "--out", str(out))
    assert_refused(result, f"output folder {out}: {why}", "expected a folder")
    assert not (out / "results.csv").exists()
    taken = tmp_path / "taken"
    assert not taken.exists() or taken.read_text(encoding="utf-8") == "mine\n"


@OUT_PROBLEMS
@pytest.mark.usefixtures("faults", "as_if_read_only")
def test_experiment_refuses_an_unusable_out_folder(
        problem: Callable[[Path], tuple[Path, str]], invoke_cbr: Cli, tmp_path: Path) -> None:
    out, why = problem(tmp_path)
    result = invoke_cbr("experiment", "tiny", "--size", "ci", "--out", str(out))
    assert_refused(result, f"output folder {out}: {why}", "expected a folder")
    assert not (out / "results.json").exists()


# -- integers beyond int64 ------------------------------------------------------------------


@pytest.mark.parametrize("value", [HUGE, f"-{HUGE}"])
@pytest.mark.usefixtures("faults")
def test_an_integer_beyond_int64_is_refused_at_validation(value: str, invoke_cbr: Cli,
                                                          tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = invoke_cbr("run", str(toy_config(tmp_path)), "--out", str(out),
                     "--set", f"workload.count={value}")
    assert_refused(result, "workload.count", f"expected an integer from {-2**63} to "
                   f"{2**63 - 1}, got {value}")
    assert not out.exists()


# -- failing plugins during a run -----------------------------------------------------------


FAILURES = {
    "metric raises": ({"metrics": ["abs_error", {"use": "gauge", "fail": True}]},
                      "plugin 'gauge (faults)' failed in phase 'measure': RuntimeError: "
                      "gauge broke"),
    "metric returns no mapping": ({"metrics": ["abs_error", "shapeless"]},
                                  "plugin 'shapeless (faults)' failed in phase 'measure': "
                                  "TypeError: returned list, expected a mapping"),
    "retainer raises": ({"retain": ["keep", {"use": "tally", "fail": True}],
                         "metrics": ["abs_error", "gauge"]},
                        "plugin 'tally (faults)' failed in phase 'retain': RuntimeError: "
                        "tally jammed"),
    "observer raises": ({"observers": ["heckler"], "metrics": ["abs_error", "gauge"]},
                        "plugin 'heckler (faults)' failed in phase 'forget': RuntimeError: "
                        "heckler shouted"),
}


@pytest.mark.parametrize("changes, message", FAILURES.values(), ids=FAILURES.keys())
@pytest.mark.usefixtures("faults")
def test_a_failing_plugin_leaves_rows_and_learn_steps_in_agreement(
        changes: dict[str, Any], message: str, invoke_cbr: Cli, tmp_path: Path) -> None:
    """The run stops at the failing query with a message naming the plugin; results.csv has a
    row for each learn step the case base committed, and none for the failing query."""
    out = tmp_path / "out"
    result = invoke_cbr("run", str(toy_config(tmp_path, **changes)), "--out", str(out))
    assert_refused(result, message)
    with (out / "results.csv").open(newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    with SQLiteStore(out / "casebase.sqlite") as casebase:
        learned = casebase.get_meta(TALLY, 0)
    assert [row["query"] for row in rows] == [str(i) for i in range(FAILING_STEP)]
    assert learned == len(rows)
    assert not (out / "summary.json").exists()


@pytest.mark.usefixtures("faults")
def test_metrics_are_measured_before_the_learn_step(invoke_cbr: Cli, tmp_path: Path) -> None:
    """A run whose plugins all work writes a row per learn step, its learn timings filled in
    although the metrics measured each query before its step."""
    out = tmp_path / "out"
    result = invoke_cbr("run", str(toy_config(tmp_path, metrics=["abs_error", "gauge"])),
                     "--out", str(out))
    assert result.exit_code == 0, result.stderr
    with (out / "results.csv").open(newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    with SQLiteStore(out / "casebase.sqlite") as casebase:
        assert casebase.get_meta(TALLY, 0) == len(rows) == 30
    assert all(float(row["ms_learn"]) >= float(row["ms_retain"]) > 0 for row in rows)
    assert {row["gauge"] for row in rows} == {"1.0"}
    assert list(rows[0])[-3:] == ["ms_learn", "abs_error", "gauge"]



@pytest.mark.parametrize("override", ["..=1", "a..b=1", ".seed=1", "seed.=1"])
def test_an_override_with_an_empty_name_is_refused_naming_the_option(
        override: str, invoke_cbr: Callable[..., CliResult], tmp_path: Path) -> None:
    config = tmp_path / "toy.yaml"
    config.write_text("seed: 1\n", encoding="utf-8")

    result = invoke_cbr("validate", str(config), "--set", override)

    assert result.exit_code == 2
    assert f"--set {override!r}: expected KEY.PATH=VALUE" in result.stderr


def test_a_run_that_cannot_be_built_leaves_no_output_folder(
        invoke_cbr: Callable[..., CliResult], tmp_path: Path) -> None:
    config = tmp_path / "bad.yaml"
    config.write_text("world: {use: map_file, path: missing.map}\n"
                      "workload: {use: trips, count: 1}\n", encoding="utf-8")

    result = invoke_cbr("run", str(config), "--out", str(tmp_path / "out"))

    assert result.exit_code == 2 and "missing.map" in result.stderr
    assert not (tmp_path / "out").exists()
