"""The figures the docs quote from benchmarks and experiments: rendered from committed results,
and a page that differs from its results fails ``benchmarks/figures.py --check``."""

from __future__ import annotations

import importlib.util
import re
import shutil
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pytest

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
