"""The getting-started page (docs/index.md): every command it gives works, and what it says a run
prints and writes is what a run prints and writes.

The commands run in-process from a scratch folder, as a reader runs them from a checkout; the
two learning runs of "change one value" run 30 trips instead of 200.
"""

from __future__ import annotations

from repo_paths import ROOT

import json
import re
import shlex
from collections.abc import Callable
from pathlib import Path

import pytest

from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult

PAGE = ROOT / "docs" / "index.md"
CONFIG = ROOT / "configs" / "hybrid_grid.yaml"
#: rows of the run's summary table that depend on the machine or on where the output went
VOLATILE_ROWS = ("ms", "wall time s", "output")


def _blocks(language: str, text: str | None = None) -> list[str]:
    found = re.findall(rf"^```{language}\n(.*?)^```$",
                       PAGE.read_text(encoding="utf-8") if text is None else text, re.S | re.M)
    return found


def _commands() -> list[str]:
    return [line for block in _blocks("bash") for line in block.splitlines()
            if line.strip() and not line.startswith("#")]


def _words() -> str:
    return " ".join(PAGE.read_text(encoding="utf-8").split())


def _table_column(heading: str) -> list[str]:
    """The first cells, code spans unwrapped and split at commas, of the page's table whose
    header row starts with ``heading``."""
    lines = PAGE.read_text(encoding="utf-8").splitlines()
    start = next(k for k, line in enumerate(lines) if line.startswith(f"| {heading} |"))
    cells = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        cells += re.findall(r"`([^`]+)`", line.split("|")[1])
    return cells


def _summary_rows(block: str) -> dict[str, str]:
    rows = {}
    for line in block.splitlines():
        cells = [cell.strip() for cell in line.strip("│").split("│")]
        if len(cells) == 2 and line.startswith("│"):
            rows[cells[0]] = cells[1]
    return rows


@pytest.fixture
def every_plugin(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    return cbr_plugins(entry_points=True)


@pytest.fixture
def cbr(invoke_cbr: Callable[..., CliResult], every_plugin: Plugins, tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch) -> Callable[[str], CliResult]:
    """Run one of the page's commands from a scratch folder; the files it reads are the
    checkout's, what it writes lands in the scratch folder."""
    monkeypatch.chdir(tmp_path)

    def run(command: str) -> CliResult:
        words = shlex.split(command)
        assert words[0] == "cbr", command
        args = [str(ROOT / w) if w.startswith(("configs/", "tests/data/")) else w
                for w in words[1:]]
        done = invoke_cbr(*args)
        assert done.exit_code == 0, (command, done.stderr)
        return done

    return run


def test_the_page_gives_exactly_these_commands() -> None:
    """A command added to the page needs its test here."""
    assert _commands() == [
        "python3 -m pip install -e . && cbr run configs/hybrid_grid.yaml",
        'python3 -m pip install -e ".[test]" && python3 -m pytest',
        "cbr run configs/hybrid_grid.yaml",
        "cbr experiment cbr-share --size ci --out runs/cbr-share",
        "cbr run configs/hybrid_grid.yaml --set workload.count=200 --set seed=3 --out runs/seed3",
        "cbr run configs/hybrid_grid.yaml --set workload.count=200 --set seed=3 --out runs/seed3",
        "cbr casebase info runs/seed3/casebase.sqlite",
        "cbr map show tests/data/ros/depot.yaml --plot depot.png",
        "cbr plan tests/data/ros/depot.yaml --frame map --start 2,2 --goal 20,3.5 "
        "--robot-radius 0.22 --plot depot-path.png"]


def test_the_install_commands_are_the_readmes() -> None:
    """The README's two lines, which CI runs (``test_repository`` checks that it does)."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert _blocks("bash")[0] == _blocks("bash", readme)[0]


def test_the_configuration_shown_is_the_main_jobs() -> None:
    config = [line.split("#")[0].rstrip() for line in CONFIG.read_text(encoding="utf-8")
              .splitlines() if line.strip() and not line.startswith("#")]
    (shown,) = _blocks("yaml")
    for line in shown.splitlines():
        assert line.split("#")[0].rstrip() in config, line


def test_the_main_job_prints_and_writes_what_the_page_says(
        cbr: Callable[[str], CliResult], tmp_path: Path) -> None:
    done = cbr("cbr run configs/hybrid_grid.yaml")
    (shown,) = [b for b in _blocks("text") if b.startswith("hybrid_grid.yaml: 1000 queries")]
    ours, page = _summary_rows(done.stdout), _summary_rows(shown)
    steady = [k for k in page if not k.endswith(VOLATILE_ROWS)]
    assert len(steady) >= 10 and {k: ours[k] for k in steady} == {k: page[k] for k in steady}
    # the decile table: every row the page shows, the milliseconds aside
    printed = {line.split("│")[1].strip(): line for line in done.stdout.splitlines()
               if re.match(r"│ +\d+-\d+ │", line)}
    for line in shown.splitlines():
        if re.match(r"│ +\d+-\d+ │", line):
            cells = [c.strip() for c in line.split("│")[1:-1]]
            theirs = [c.strip() for c in printed[cells[0]].split("│")[1:-1]]
            assert cells[:2] + cells[3:] == theirs[:2] + theirs[3:]

    out = tmp_path / "runs" / "hybrid_grid"
    assert sorted(p.name for p in out.iterdir()) == sorted(_table_column("file"))
    header = (out / "results.csv").read_text(encoding="utf-8").splitlines()[0].split(",")
    assert header == _table_column("column")
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    for key in ("from_casebase", "from_solver", "unsolved", "cbr_share", "success_rate",
                "fallback_reasons", "median_ms", "metric_means", "evolution"):
        assert key in summary and f"`{key}`" in _words(), key
    assert f"the paths cost on average {summary['metric_means']['deviation'] * 100:.2f} % " in (
        _words())
    shares = [round(tenth["cbr_share"] * 100) for tenth in summary["evolution"]]
    assert (f"answers {shares[0]} % of the first hundred trips and between {min(shares[1:])} % "
            f"and {max(shares[1:])} % of each hundred after") in _words()
    info = cbr("cbr casebase info runs/hybrid_grid/casebase.sqlite")
    segments = re.search(r"segment +(\d+)", info.stdout)
    assert segments and f"{segments[1]} segments after this run" in _words()


def test_the_learning_curve_experiment_writes_its_table_and_picture(
        cbr: Callable[[str], CliResult], tmp_path: Path) -> None:
    cbr("cbr experiment cbr-share --size ci --out runs/cbr-share")
    written = sorted(p.name for p in (tmp_path / "runs" / "cbr-share").iterdir())
    assert written == ["cbr_share.png", "manifest.json", "results.json", "results.md"]
    assert all(f"`{name}`" in _words() for name in written)


def test_a_second_run_into_the_same_folder_keeps_learning(
        cbr: Callable[[str], CliResult], tmp_path: Path) -> None:
    runs = [c.replace("workload.count=200", "workload.count=30") for c in _commands()
            if "--out runs/seed3" in c]
    summaries = []
    for command in runs:
        cbr(command)
        summaries.append(json.loads((tmp_path / "runs" / "seed3" / "summary.json")
                                    .read_text(encoding="utf-8")))
    first, second = summaries
    assert first["cases_at_start"] == 0 < second["cases_at_start"]
    assert second["cbr_share"] > first["cbr_share"]
    info = cbr("cbr casebase info runs/seed3/casebase.sqlite")
    assert re.search(r"segment +\d+", info.stdout)


def test_the_real_map_commands_draw_their_pictures(cbr: Callable[[str], CliResult],
                                                   tmp_path: Path) -> None:
    for command in _commands():
        if command.startswith(("cbr map show", "cbr plan")):
            cbr(command)
    assert (tmp_path / "depot.png").stat().st_size > 0
    assert (tmp_path / "depot-path.png").stat().st_size > 0
