"""The figures the docs quote from benchmarks and experiments: rendered from committed results,
and a page that differs from its results fails ``benchmarks/figures.py --check``."""

from __future__ import annotations

import csv
import importlib.util
import json
import re
import shlex
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "figures.py"


@pytest.fixture(scope="module")
def figures() -> ModuleType:
    spec = importlib.util.spec_from_file_location("figures", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["figures"] = module
    spec.loader.exec_module(module)
    return module


def test_the_pages_hold_what_the_results_say() -> None:
    done = subprocess.run([sys.executable, str(SCRIPT), "--check"], capture_output=True,
                          text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr


def test_every_block_is_on_a_page_and_every_page_block_is_known(figures: ModuleType) -> None:
    used = figures.used()
    assert set(used) == set(figures.BLOCKS)
    for block in figures.BLOCKS.values():
        assert block.source.is_file(), block.source


def test_a_changed_figure_is_reported_with_its_page_and_block(figures: ModuleType,
                                                              tmp_path: Path) -> None:
    docs = tmp_path / "docs"
    shutil.copytree(ROOT / "docs", docs)
    page = docs / "benchmarks.md"
    text = page.read_text(encoding="utf-8")
    start = text.index("<!-- figures: genetic -->")
    cell = re.compile(r"\| 0\.90 \|")
    assert cell.search(text, start), "the genetic table holds a success rate of 0.90"
    page.write_text(text[:start] + cell.sub("| 0.95 |", text[start:], count=1),
                    encoding="utf-8")
    stale = figures.check(docs)
    assert len(stale) == 1
    assert stale[0].startswith("docs/benchmarks.md: block genetic differs")
    assert figures.write(docs) == ["docs/benchmarks.md: block genetic rewritten"]
    assert page.read_text(encoding="utf-8") == text
    assert figures.check(docs) == []


def test_an_unknown_block_names_its_page(figures: ModuleType, tmp_path: Path) -> None:
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "page.md").write_text("# P\n\n<!-- figures: nowhere -->\n<!-- /figures -->\n",
                                  encoding="utf-8")
    with pytest.raises(figures.FiguresError, match=r"docs/page\.md: block nowhere: unknown"):
        figures.check(docs)


def test_table_selects_columns_and_rows_by_name(figures: ModuleType) -> None:
    text = ("intro\n\n| map | a | b |\n|---|---|---|\n| x 1 | 1 | 2 |\n| y 2 | 3 | 4 |\n\n"
            "| k |\n|---|\n| v |\n")
    assert figures.table(text, 0, ["b", "map"], where="y") == (
        "| b | map |\n| --- | --- |\n| 4 | y 2 |")
    assert figures.table(text, 1) == "| k |\n| --- |\n| v |"
    with pytest.raises(figures.FiguresError, match="no column 'c'"):
        figures.table(text, 0, ["c"])
    with pytest.raises(figures.FiguresError, match="2 tables, not table 3"):
        figures.table(text, 2)


def test_check_fails_naming_the_page_from_the_command_line(tmp_path: Path) -> None:
    """The command line's exit status and message, on a copy of the repository's docs."""
    root = tmp_path / "repo"
    shutil.copytree(ROOT / "docs", root / "docs")
    shutil.copytree(ROOT / "benchmarks", root / "benchmarks",
                    ignore=shutil.ignore_patterns("__pycache__"))
    page = root / "docs" / "benchmarks.md"
    text = page.read_text(encoding="utf-8")
    marker = "<!-- figures: engine-overhead -->\n"
    page.write_text(text.replace(marker, marker + "| stale |\n"), encoding="utf-8")
    done = subprocess.run([sys.executable, str(root / "benchmarks" / "figures.py"), "--check"],
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 1
    assert "docs/benchmarks.md: block engine-overhead differs" in done.stderr


def test_every_experiment_command_on_a_page_names_its_size() -> None:
    """The default size of ``cbr experiment`` is not what a page quoting figures means."""
    missing = []
    for page in sorted((ROOT / "docs").glob("*.md")):
        for line in page.read_text(encoding="utf-8").splitlines():
            for command in re.findall(r"cbr experiment [a-z][\w-]*[^`\n]*", line):
                if "--size" not in command and "--list" not in command:
                    missing.append(f"{page.name}: {command}")
    assert missing == []


# --- the 2D world page: its example runs are small enough to run here --------------------------

WORLD2D = ROOT / "docs" / "world2d.md"
TEXT_BLOCK = re.compile(r"^```text\n(.*?)^```$", re.S | re.M)
#: rows of the run summary that depend on the machine or on where the output went
VOLATILE_ROWS = ("ms", "wall time s", "output")


def _session_commands() -> list[tuple[str, list[str]]]:
    """Each ``$ cbr sim ...`` command in the 2D world page's text blocks with the lines shown
    after it."""
    found: list[tuple[str, list[str]]] = []
    for block in TEXT_BLOCK.findall(WORLD2D.read_text(encoding="utf-8")):
        for line in block.replace("\\\n    ", "").splitlines():
            if line.startswith("$ "):
                found.append((line[2:], []))
            elif found and block.lstrip().startswith("$ "):
                found[-1][1].append(line)
    return [(command, shown) for command, shown in found if command.startswith("cbr sim ")]


@pytest.fixture
def every_plugin(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    return cbr_plugins(entry_points=True)


@pytest.mark.usefixtures("every_plugin")
@pytest.mark.parametrize(("command", "shown"), _session_commands(),
                         ids=[c for c, _ in _session_commands()])
def test_the_2d_world_page_shows_what_its_sim_commands_print(
        cbr_cli: Callable[..., CliResult], tmp_path: Path, command: str,
        shown: list[str]) -> None:
    args = shlex.split(command)[1:]
    if "--plot" in args:
        # the picture goes to a scratch folder; the page's picture is not rewritten here
        args[args.index("--plot") + 1] = str(tmp_path / "trial.png")
    done = cbr_cli(*args)
    printed = (done.stdout + done.stderr).splitlines()
    assert [line for line in printed if not line.startswith("wrote ")] == [
        line for line in shown if not line.startswith("wrote ")]


def _sim(cbr_cli: Callable[..., CliResult], *args: str) -> dict[str, Any]:
    done = cbr_cli("sim", "run", *args, "--json")
    assert done.exit_code == 0, done.stderr
    result: dict[str, Any] = json.loads(done.stdout)
    return result


@pytest.mark.usefixtures("every_plugin")
def test_the_2d_world_page_figures_of_the_pilot_alone_and_the_pioneer(
        cbr_cli: Callable[..., CliResult]) -> None:
    """'With --rescue off the robot times out in both scenarios: in scenario 1 it stays in front
    of the obstacle (2.72 m driven in 300 s). A Pioneer 2 DX passes scenario 1 in 39.4 s and is
    trapped in scenario 2 like 002's robot.'"""
    text = " ".join(WORLD2D.read_text(encoding="utf-8").split())
    worlds = "plugins/cbr_world2d/worlds"
    places = ("--start", "start", "--target", "target")
    alone = [_sim(cbr_cli, f"{worlds}/scenario{k}.yaml", *places, "--robot", "ros2005",
                  "--rescue", "off") for k in (1, 2)]
    assert [r["success"] for r in alone] == [False, False]
    assert f"({alone[0]['distance']:.2f} m driven in {alone[0]['time']:.0f} s)" in text
    pioneer = [_sim(cbr_cli, f"{worlds}/scenario{k}.yaml", *places) for k in (1, 2)]
    assert pioneer[0]["success"] and not pioneer[1]["success"]
    assert f"passes scenario 1 in {pioneer[0]['time']:.1f} s" in text


def _summary_rows(block: str) -> dict[str, str]:
    rows = {}
    for line in block.splitlines():
        cells = [cell.strip() for cell in line.strip("│").split("│")]
        if len(cells) == 2 and line.startswith("│"):
            rows[cells[0]] = cells[1]
    return rows


@pytest.mark.usefixtures("every_plugin")
def test_the_2d_world_page_shows_what_its_trials_config_does(
        cbr_cli: Callable[..., CliResult], tmp_path: Path) -> None:
    """The summary table, the rows of trials.csv and results.csv and the figures of the prose
    about ``cbr run configs/world2d_trials.yaml``."""
    page = WORLD2D.read_text(encoding="utf-8")
    blocks = TEXT_BLOCK.findall(page)
    (summary,) = [b for b in blocks if b.startswith("$ cbr run configs/world2d_trials.yaml")]
    done = cbr_cli("run", str(ROOT / "configs" / "world2d_trials.yaml"), "--out",
                   str(tmp_path))
    assert done.exit_code == 0, done.stderr
    ours, shown = _summary_rows(done.stdout), _summary_rows(summary)
    steady = [k for k in shown if not any(k.endswith(v) for v in VOLATILE_ROWS)]
    assert {k: ours[k] for k in steady} == {k: shown[k] for k in steady}
    (trials_shown,) = [b for b in blocks if b.startswith("trial,start_x")
                       and "consultations\n0,1.0,3.9,8.0,4.0,False" in b]
    trials = (tmp_path / "trials.csv").read_text(encoding="utf-8").splitlines()
    for line in trials_shown.splitlines():
        if line != "...":
            assert line in trials
    results = list(csv.DictReader((tmp_path / "results.csv").open(encoding="utf-8")))
    reached = [float(r["outcome_cost"]) for r in results if r["success"] == "True"]
    text = " ".join(page.split())
    assert (f"reached (`True`, in {min(reached):g} to {max(reached):g} s)" in text)
    assert f"the {len(reached) / len(results) * 100:.1f} % success rate" in text
    assert all(r["consultations"] == "6" for r in csv.DictReader(
        (tmp_path / "trials.csv").open(encoding="utf-8"))), "six consultations each"
