"""Repository-level promises: the README's commands, CI, lint, the docs site and the configs."""

from __future__ import annotations

import re
import stat
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from cbrcore.cli import main

ROOT = Path(__file__).resolve().parent.parent
README_COMMANDS = [
    "python3 -m pip install -e . && cbr run configs/hybrid_grid.yaml",
    'python3 -m pip install -e ".[test]" && python3 -m pytest',
]


def _first_block(text: str) -> tuple[str, list[str]]:
    match = re.search(r"^```(\w*)\n(.*?)^```", text, re.S | re.M)
    assert match, "README.md has no fenced block"
    return match[1], match[2].splitlines()


def test_readme_starts_with_the_two_commands() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    language, lines = _first_block(text)
    assert language == "bash"
    assert lines == README_COMMANDS
    before = text[: text.index("```")].strip().splitlines()
    assert len(before) == 1 and before[0].startswith("# "), "only the title precedes the commands"


def test_readme_links_resolve() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text)
    local = [t for t in targets if "://" not in t]
    assert local
    missing = [t for t in local if not (ROOT / t).exists()]
    assert not missing


def test_ci_script_runs_the_readme_test_command() -> None:
    script = ROOT / ".ci" / "run"
    assert script.is_file()
    assert script.stat().st_mode & stat.S_IXUSR, ".ci/run must be executable"
    shown = subprocess.run(["bash", str(script), "--print-command"], capture_output=True,
                           text=True, check=True, timeout=60)
    assert shown.stdout.strip() == README_COMMANDS[1]


def test_ruff_is_clean() -> None:
    result = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", "."], cwd=ROOT,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr


def test_docs_build_strict(tmp_path: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file",
         str(ROOT / "mkdocs.yml"), "--site-dir", str(tmp_path / "site")],
        cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    assert (tmp_path / "site" / "index.html").is_file()


def _nav_pages(node: object) -> list[str]:
    if isinstance(node, str):
        return [node]
    if isinstance(node, dict):
        return [page for value in node.values() for page in _nav_pages(value)]
    if isinstance(node, list):
        return [page for item in node for page in _nav_pages(item)]
    return []


def test_nav_and_docs_pages_match() -> None:
    site = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))
    docs = ROOT / site.get("docs_dir", "docs")
    nav = _nav_pages(site["nav"])
    assert len(nav) == len(set(nav)), "a page is listed twice in the nav"
    missing = [page for page in nav if not (docs / page).is_file()]
    assert not missing, f"nav pages that do not exist: {missing}"
    pages = {p.relative_to(docs).as_posix() for p in docs.rglob("*.md")}
    assert pages - set(nav) == set(), "docs pages missing from the nav"


CONFIGS = sorted((ROOT / "configs").glob("*.yaml"))
CONFIG_PARAMS = [pytest.param(path, id=path.name) for path in CONFIGS] or [
    pytest.param(None, id="no-configs",
                 marks=pytest.mark.skip(reason="configs/ holds no YAML configuration yet"))]


@pytest.mark.parametrize("config", CONFIG_PARAMS)
def test_config_validates_and_runs(config: Path, tmp_path: Path,
                                   monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["validate", str(config)]) == 0
    out = tmp_path / "run"
    assert main(["run", str(config), "--out", str(out)]) == 0
    for name in ("results.csv", "summary.json", "manifest.json"):
        assert (out / name).is_file(), name
    assert (out / "results.csv").stat().st_size > 0
