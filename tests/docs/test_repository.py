"""Repository-level promises: the README's commands, CI, lint, the docs site and the configs."""

from __future__ import annotations

from repo_paths import ROOT

import json
import os
import re
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from cbrcore.cli import main

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


# -- the plugin guide's example package -------------------------------------------------------

#: the plugin guide's pages that hold the example package's files
GUIDE = [ROOT / "docs" / page
         for page in ("plugins.md", "plugins-components.md", "plugins-testing.md")]
EXAMPLE_FILE = re.compile(r"^```\w+\n(# cbr-openfloor/(\S+)\n.*?)^```$", re.S | re.M)


def _environ(**extra: str) -> dict[str, str]:
    environ = {k: v for k, v in os.environ.items() if not k.startswith(("CBR_", "PYTEST_"))}
    return {**environ, **extra}


@pytest.fixture(scope="module")
def guide_example(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The guide's package written out from its pages and installed into a folder."""
    work = tmp_path_factory.mktemp("guide")
    package = work / "cbr-openfloor"
    text = "\n".join(page.read_text(encoding="utf-8") for page in GUIDE)
    for match in EXAMPLE_FILE.finditer(text):
        path = package / match[2]
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(match[1], encoding="utf-8")
    site = work / "site"
    # install from a copy, so the build leaves no build/ or egg-info folder in the package
    done = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation",
         "--no-index", "--disable-pip-version-check", "--quiet", "--target", str(site),
         str(shutil.copytree(package, work / "build"))],
        capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stdout + done.stderr
    return package, site


def test_guide_example_has_every_file(guide_example: tuple[Path, Path]) -> None:
    package, _ = guide_example
    files = sorted(p.relative_to(package).as_posix() for p in package.rglob("*") if p.is_file())
    assert files == ["floor.yaml", "pyproject.toml", "src/cbr_openfloor/__init__.py",
                     "src/cbr_openfloor/cycle.py", "src/cbr_openfloor/experiment.py",
                     "src/cbr_openfloor/floor.py", "src/cbr_openfloor/observe.py",
                     "tests/test_openfloor.py"]


def test_guide_example_is_lint_clean(guide_example: tuple[Path, Path]) -> None:
    package, _ = guide_example
    result = subprocess.run(
        [sys.executable, "-m", "ruff", "check", "--no-cache", "--isolated", "--line-length",
         "100", "--select", "E,F,W,I,UP,B,SIM,RUF", "."],
        cwd=package, capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 0, result.stdout + result.stderr


def test_guide_example_tests_pass(guide_example: tuple[Path, Path]) -> None:
    package, site = guide_example
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests"],
        cwd=package, env=_environ(PYTHONPATH=str(site)), capture_output=True, text=True,
        timeout=300, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "6 passed" in result.stdout


def test_guide_example_runs_through_its_entry_point(guide_example: tuple[Path, Path],
                                                   tmp_path: Path) -> None:
    package, site = guide_example

    def cbr(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-m", "cbrcore", *args], cwd=tmp_path,
                              env=_environ(PYTHONPATH=str(site)), capture_output=True, text=True,
                              timeout=300, check=False)

    listed = cbr("plugins", "--json")
    assert listed.returncode == 0, listed.stderr
    plugins = {p["name"]: p for p in json.loads(listed.stdout)["plugins"]}
    assert plugins["openfloor"]["distribution"] == "cbr-openfloor"

    config = package / "floor.yaml"
    assert cbr("validate", str(config)).returncode == 0
    kept = tmp_path / "first" / "floor.sqlite"  # a relative case base path is in the run folder
    for out in ("first", "second"):
        done = cbr("run", str(config), "--out", out, "--set", f"casebase.path={kept}")
        assert done.returncode == 0, done.stderr
    first, second = (json.loads((tmp_path / out / "summary.json").read_text(encoding="utf-8"))
                     for out in ("first", "second"))
    assert first["queries"] == second["queries"] == 200
    assert second["cbr_share"] > first["cbr_share"]  # the second run starts with the kept cases
    assert json.loads((tmp_path / "first" / "phase_counts.json").read_text())["retrieve"] == 200
    assert cbr("floor-path", "0,0", "3,1").stdout == "0,0 1,1 2,1 3,1\n"


# -- dependencies: declared exactly as the code imports them ----------------------------------

# import name -> distribution name, where they differ
DISTRIBUTION_OF = {"yaml": "pyyaml", "PIL": "pillow", "mcap_ros2": "mcap-ros2-support"}
# imported only by the testing kit, which pytest itself loads (the pytest11 entry point)
TESTING_KIT = {"pytest", "hypothesis"}


def _requirement_names(requirements: list[str]) -> set[str]:
    return {re.split(r"[<>=!~\[; ]", r, maxsplit=1)[0].lower() for r in requirements}


def _third_party_imports(folders: list[Path]) -> dict[str, list[str]]:
    """Top-level modules imported anywhere under ``folders`` (lazy imports included) that are
    neither the standard library nor this repository's packages, with where each is imported."""
    import ast

    ours = {"cbrcore"} | {p.name for p in (ROOT / "plugins").iterdir() if p.is_dir()}
    found: dict[str, list[str]] = {}
    for folder in folders:
        for path in folder.rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.Import):
                    names = [alias.name for alias in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names = [node.module]
                else:
                    continue
                for name in names:
                    top = name.split(".")[0]
                    if top not in sys.stdlib_module_names and top not in ours:
                        found.setdefault(top, []).append(path.relative_to(ROOT).as_posix())
    return found


def test_runtime_dependencies_are_what_the_code_imports() -> None:
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    declared = _requirement_names(project["dependencies"])
    imported = _third_party_imports([ROOT / "cbrcore", ROOT / "plugins"])
    # the testing kit's docstring example imports the plugin under test; it is not code we run
    imported.pop("my_plugin", None)
    kit = {name for name in TESTING_KIT if name in imported}
    assert all(p.startswith("cbrcore/testing/") for name in kit for p in imported[name])
    needed = {DISTRIBUTION_OF.get(name, name).lower() for name in imported} - kit
    # what a feature's extra brings is imported only when that feature is used
    features = {name for extra in ("postgres", "dask")
                for name in _requirement_names(project["optional-dependencies"][extra])}
    assert declared - needed == set(), "declared but never imported at runtime"
    assert needed - declared - features == set(), "imported at runtime but not declared"


def test_every_dependency_and_extra_is_in_the_dependencies_page() -> None:
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    page = (ROOT / "docs" / "dependencies.md").read_text(encoding="utf-8")
    rows = {line.split("|")[1].strip() for line in page.splitlines() if line.startswith("| ")}
    runtime = _requirement_names(project["dependencies"])
    assert runtime <= rows, f"runtime packages without a row: {runtime - rows}"
    for extra, requirements in project["optional-dependencies"].items():
        assert f"`{extra}`" in rows, f"the {extra} extra has no row"
        for name in _requirement_names(requirements) - runtime:
            assert name in page, f"{name} (extra {extra}) is not on the dependencies page"


def test_the_readme_test_command_installs_every_package_the_tests_import() -> None:
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    extras = re.findall(r"\.\[([\w,]+)\]", README_COMMANDS[1])
    installed = _requirement_names(project["dependencies"]) | {"cbrcore", "cbr_sample"}
    for extra in ",".join(extras).split(","):
        installed |= _requirement_names(project["optional-dependencies"][extra])
    imported = _third_party_imports([ROOT / "tests", ROOT / "benchmarks"])
    local = ({p.stem for p in (ROOT / "tests").glob("*.py")}
             | {p.parent.name for p in (ROOT / "tests").glob("*/__init__.py")}
             | {p.stem for p in (ROOT / "benchmarks").glob("*.py")}
             | {p.parent.name for p in (ROOT / "benchmarks").glob("*/__init__.py")})
    needed = {DISTRIBUTION_OF.get(name, name).lower() for name in imported} - local
    # the agreement libraries import under other names than they install as
    needed = {{"irsim": "ir-sim", "cbr_openfloor": "cbrcore"}.get(n, n) for n in needed}
    assert needed - installed - {"pyastar2d", "tcod"} == set()


# -- self-contained tests ---------------------------------------------------------------------

# a sibling folder, an absolute path of this machine, or a climb above the repository's root
OUTSIDE = re.compile(r"\.\./shared|[\"']/work/|parents\[(?:[2-9]|\d\d)\]"
                     r"|\.parent\.parent\.parent")


def test_no_test_reads_outside_the_repository() -> None:
    offenders = [f"{path.relative_to(ROOT)}:{number}: {line.strip()}"
                 for path in sorted((ROOT / "tests").rglob("*.py"))
                 for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
                 if OUTSIDE.search(line)]
    assert offenders == []
