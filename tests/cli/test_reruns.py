"""A second ``cbr run`` into a folder, ``--fresh``, and progress on a stderr that is no terminal.

The toy domain (``tests/toy_domain.py``) keeps its cases in ``casebase.sqlite`` in the run folder
here; its capacity forgetter leaves 6 cases after a run of 30 queries.
"""

from __future__ import annotations

import csv
import json
import os
import stat
from collections.abc import Callable
from pathlib import Path

import pytest

import toy_domain
from cbr_experiments.experiment import ExperimentResult, Size
from cbrcore.cli.progress import PlainProgress
from cbrcore.context import Context
from cbrcore.hookspecs import hookimpl
from cbrcore.plugins import Plugins
from cbrcore.registry import Registry
from cbrcore.testing import CliResult

Cli = Callable[..., CliResult]

CONFIG = toy_domain.TOY_CONFIG.replace("casebase: memory", "casebase: sqlite")
MARKER = "TOPSECRET"
KEPT = 6
"""The cases the toy composition keeps after a run (its capacity forgetter's limit)."""


class Counts:
    """An experiment of three steps whose first progress call already gives the total."""

    def __init__(self, options: object, ctx: Context) -> None:
        self.ctx = ctx

    def run(self, size: Size, out_dir: Path, progress: Callable[[int, int], None]
            ) -> ExperimentResult:
        progress(0, 3)
        for done in range(1, 4):
            progress(done, 3)
        return ExperimentResult({"steps": 3}, "| steps |\n|---|\n| 3 |\n")


class Experiments:
    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("experiment", "counts", Counts)


@pytest.fixture(autouse=True)
def toy(load_toy: Callable[..., Plugins]) -> Plugins:
    return load_toy(("counting", Experiments()))


@pytest.fixture
def config(tmp_path: Path) -> Path:
    path = tmp_path / "toy.yaml"
    path.write_text(CONFIG, encoding="utf-8")
    return path


def rows(out: Path) -> list[dict[str, str]]:
    with (out / "results.csv").open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def summary(out: Path) -> dict[str, object]:
    return json.loads((out / "summary.json").read_text(encoding="utf-8"))  # type: ignore[no-any-return]


def contents(out: Path) -> dict[str, bytes | str]:
    """The folder's regular files with their bytes, and anything else by its kind."""
    return {path.name: path.read_bytes() if path.is_file() else stat.filemode(path.lstat().st_mode)
            for path in sorted(out.iterdir())}


def test_a_rerun_continues_the_folder_and_says_so(invoke_cbr: Cli, config: Path,
                                                  tmp_path: Path) -> None:
    out = tmp_path / "out"
    first = invoke_cbr("run", str(config), "--out", str(out))
    assert first.exit_code == 0, first
    assert "continuing" not in first.stderr

    second = invoke_cbr("run", str(config), "--out", str(out))

    assert second.exit_code == 0, second
    assert second.stderr == f"cbr run: continuing from {KEPT} cases in {out}\n"
    found = rows(out)
    assert [int(row["query"]) for row in found] == list(range(60))
    header = (out / "results.csv").read_text(encoding="utf-8").splitlines()[0]
    assert (out / "results.csv").read_text(encoding="utf-8").count(header) == 1
    latest = summary(out)
    assert (latest["queries"], latest["first_query"], latest["earlier_queries"],
            latest["cases_at_start"]) == (30, 30, 30, KEPT)
    # the summary's stretches are numbered as results.csv numbers the queries
    assert latest["evolution"][0]["first"] == 30  # type: ignore[index]
    assert "continued" in second.stdout


def test_fresh_empties_the_folder_after_saying_so(invoke_cbr: Cli, config: Path,
                                                  tmp_path: Path) -> None:
    out = tmp_path / "out"
    for _ in range(2):
        assert invoke_cbr("run", str(config), "--out", str(out)).exit_code == 0
    (out / "notes.txt").write_text("kept", encoding="utf-8")

    result = invoke_cbr("run", str(config), "--out", str(out), "--fresh")

    assert result.exit_code == 0, result
    assert result.stderr.startswith(
        f"cbr run: --fresh: removing results.csv, summary.json, manifest.json, casebase.sqlite "
        f"from {out}\n")
    assert "continuing" not in result.stderr
    assert [int(row["query"]) for row in rows(out)] == list(range(30))
    assert summary(out)["cases_at_start"] == 0 and summary(out)["earlier_queries"] == 0
    # files of the user's own are not the run's to remove
    assert (out / "notes.txt").read_text(encoding="utf-8") == "kept"


def test_fresh_into_an_empty_folder_removes_nothing(invoke_cbr: Cli, config: Path,
                                                    tmp_path: Path) -> None:
    result = invoke_cbr("run", str(config), "--out", str(tmp_path / "new"), "--fresh")
    assert result.exit_code == 0, result
    assert result.stderr == ""


def test_another_configuration_is_refused_and_nothing_is_lost(invoke_cbr: Cli, config: Path,
                                                              tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert invoke_cbr("run", str(config), "--out", str(out)).exit_code == 0
    before = contents(out)

    refused = invoke_cbr("run", str(config), "--out", str(out), "--set", "workload.count=10")

    assert refused.exit_code == 2, refused
    assert "Traceback" not in refused.stderr
    assert f"{out}: holds the results of a different configuration ({config}" in refused.stderr
    assert "--fresh" in refused.stderr
    assert contents(out) == before

    fresh = invoke_cbr("run", str(config), "--out", str(out), "--set", "workload.count=10",
                    "--fresh")
    assert fresh.exit_code == 0, fresh
    assert len(rows(out)) == 10


def test_a_manifest_without_its_fingerprint_is_compared_by_its_configuration(
        invoke_cbr: Cli, config: Path, tmp_path: Path) -> None:
    """A folder written before manifests recorded the fingerprint is judged by the
    configuration the manifest holds."""
    out = tmp_path / "out"
    assert invoke_cbr("run", str(config), "--out", str(out)).exit_code == 0
    manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    del manifest["config_sha256"]
    (out / "manifest.json").write_text(json.dumps(manifest), encoding="utf-8")

    assert invoke_cbr("run", str(config), "--out", str(out)).exit_code == 0
    assert len(rows(out)) == 60
    manifest["config"]["seed"] = 4
    (out / "manifest.json").write_text(json.dumps(manifest), encoding="utf-8")
    assert invoke_cbr("run", str(config), "--out", str(out)).exit_code == 2


PIPE, FOLDER = "<a named pipe>", "<a folder>"
BAD_FOLDERS = {
    "manifest that is not JSON": (
        {"manifest.json": f"{MARKER} password=hunter2\n"},
        "manifest.json: cannot be read as a run's manifest (not JSON)"),
    "manifest that is a named pipe": (
        {"manifest.json": PIPE},
        "manifest.json: cannot be read as a run's manifest (a named pipe, not a regular file)"),
    "results that are a folder": (
        {"results.csv": FOLDER},
        "results.csv: cannot be read as a run's results (a folder, not a regular file)"),
    "manifest of an experiment": (
        {"manifest.json": json.dumps({"experiment": "x", "config": None, MARKER: 1})},
        "manifest.json: records no run's configuration"),
    "results without a query column": (
        {"results.csv": f"{MARKER},b\n1,2\n"},
        "results.csv: its header has no 'query' column"),
    "results with a query number that is none": (
        {"results.csv": f"query,source\n0,solver\n{MARKER},solver\n"},
        "results.csv, line 3: the query number is not a whole number"),
    "results with a query number in other digits": (
        {"results.csv": f"query,{MARKER}\n0,solver\n\u0663,solver\n"},
        "results.csv, line 3: the query number is not a whole number"),
    "results with a query number too long to convert": (
        {"results.csv": f"query,{MARKER}\n{'9' * 5000},solver\n"},
        "results.csv, line 2: the query number is not a whole number"),
}


@pytest.mark.parametrize(("files", "message"), BAD_FOLDERS.values(), ids=list(BAD_FOLDERS))
def test_a_folder_that_cannot_be_continued_is_refused_untouched(
        invoke_cbr: Cli, config: Path, tmp_path: Path, files: dict[str, str],
        message: str) -> None:
    out = tmp_path / "out"
    out.mkdir()
    for name, text in files.items():
        if text == PIPE:
            os.mkfifo(out / name)
        elif text == FOLDER:
            (out / name).mkdir()
        else:
            (out / name).write_text(text, encoding="utf-8")
    before = contents(out)

    result = invoke_cbr("run", str(config), "--out", str(out))

    assert result.exit_code == 2, result
    assert "Traceback" not in result.stderr
    assert MARKER not in result.stdout + result.stderr
    assert "hunter2" not in result.stdout + result.stderr
    assert message in result.stderr
    assert "--fresh" in result.stderr
    assert contents(out) == before


# -- progress on a stderr that is not a terminal -----------------------------------------------


def test_a_run_writes_plain_progress_lines(invoke_cbr: Cli, config: Path, tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CBR_PROGRESS_SECONDS", "0")
    result = invoke_cbr("run", str(config), "--out", str(tmp_path / "out"))
    assert result.exit_code == 0, result
    lines = result.stderr.splitlines()
    assert [line.split(",")[0] for line in lines] == [
        f"cbr run: {done}/30 queries" for done in range(31)]
    assert all(line.endswith(" s") for line in lines)


def test_an_experiment_writes_plain_progress_lines_with_its_total(
        invoke_cbr: Cli, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CBR_PROGRESS_SECONDS", "0")
    result = invoke_cbr("experiment", "counts", "--out", str(tmp_path / "out"))
    assert result.exit_code == 0, result
    assert [line.split(",")[0] for line in result.stderr.splitlines()] == [
        f"cbr experiment counts: {done}/3 steps" for done in range(4)]


@pytest.mark.parametrize("value", ["soon", "-1", "nan", "inf"])
def test_a_bad_progress_interval_is_refused(invoke_cbr: Cli, config: Path, tmp_path: Path,
                                            monkeypatch: pytest.MonkeyPatch, value: str) -> None:
    monkeypatch.setenv("CBR_PROGRESS_SECONDS", value)
    result = invoke_cbr("run", str(config), "--out", str(tmp_path / "out"))
    assert result.exit_code == 2, result
    assert "CBR_PROGRESS_SECONDS: expected a number of seconds >= 0" in result.stderr
    assert not (tmp_path / "out" / "results.csv").exists()


def test_plain_progress_waits_its_interval_and_closes_what_it_started() -> None:
    now = [0.0]
    lines: list[str] = []
    progress = PlainProgress("cbr run", "queries", lines.append, every=10,
                             clock=lambda: now[0])
    for done, at in ((0, 0.0), (1, 4.0), (2, 9.9)):
        now[0] = at
        progress(done, 5)
    assert lines == []
    now[0] = 12.4
    progress(3, 5)
    now[0] = 13.0
    progress(4, None)
    progress(5, 5)
    assert lines == ["cbr run: 3/5 queries, 12 s\n", "cbr run: 5/5 queries, 13 s\n"]


def test_work_done_within_the_interval_writes_no_line() -> None:
    lines: list[str] = []
    progress = PlainProgress("cbr run", "queries", lines.append, every=10, clock=lambda: 1.0)
    for done in range(4):
        progress(done, 3)
    assert lines == []
