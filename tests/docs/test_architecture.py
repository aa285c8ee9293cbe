"""The house as drawn in docs/architecture.md: layers import only downward and no package
reaches into another's private names."""

from __future__ import annotations

from repo_paths import ROOT

import ast
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

SOURCES = [ROOT / "cbrcore", *sorted((ROOT / "plugins").glob("cbr_*"))]
PACKAGES = {path.name for path in SOURCES}


def _modules() -> list[Path]:
    return [path for source in SOURCES for path in sorted(source.rglob("*.py"))]


def test_the_import_contracts_hold() -> None:
    linter = shutil.which("lint-imports", path=str(Path(sys.executable).parent)) or shutil.which(
        "lint-imports")
    assert linter, "import-linter is a test dependency"
    result = subprocess.run([linter, "--no-cache"], cwd=ROOT, capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr


def test_every_package_of_the_code_is_in_a_layer() -> None:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    linter = config["tool"]["importlinter"]
    layered = {name.strip() for contract in linter["contracts"] if contract["type"] == "layers"
               for layer in contract["layers"] for name in layer.split("|")}
    assert set(linter["root_packages"]) == PACKAGES == layered


def _private_imports(path: Path) -> list[str]:
    owner = path.relative_to(ROOT).parts[0 if path.is_relative_to(ROOT / "cbrcore") else 1]
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            package = node.module.split(".")[0]
            if package in PACKAGES and package != owner:
                found += [f"{path.relative_to(ROOT)}:{node.lineno}: {node.module}.{alias.name}"
                          for alias in node.names if alias.name.startswith("_")
                          and not alias.name.startswith("__")]
                if any(part.startswith("_") and not part.startswith("__")
                       for part in node.module.split(".")):
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {node.module}")
    return found


def test_no_package_imports_another_packages_private_names() -> None:
    found = [line for path in _modules() for line in _private_imports(path)]
    assert found == []
