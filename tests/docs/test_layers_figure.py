"""The architecture page's picture of the layers (``benchmarks/docfigures/layers.py``): kept
current with the import contract and the packages' imports, and redrawn when they change."""

from __future__ import annotations

from repo_paths import ROOT

import importlib
import json
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import pytest

PYPROJECT = """\
[project.entry-points.cbr]
core = "cbrcore.builtins"
alpha = "cbr_alpha"

[tool.importlinter]
root_packages = ["cbrcore", "cbr_alpha"]

[[tool.importlinter.contracts]]
name = "Layers"
type = "layers"
layers = ["cbr_alpha", "cbrcore"]
"""


@pytest.fixture(scope="module")
def layers() -> Iterator[ModuleType]:
    """The module, imported as ``benchmarks/figures.py`` imports it: from the script's folder."""
    with pytest.MonkeyPatch.context() as patch:
        patch.syspath_prepend(str(ROOT / "benchmarks"))
        yield importlib.import_module("docfigures.layers")


def _house(root: Path) -> Path:
    """A repository of two packages, the plugin importing the core."""
    (root / "pyproject.toml").write_text(PYPROJECT, encoding="utf-8")
    for package, code in (("cbrcore", ""), ("plugins/cbr_alpha", "from cbrcore import x\n")):
        (root / package).mkdir(parents=True)
        (root / package / "__init__.py").write_text(code, encoding="utf-8")
    for folder in ("docs/figures", "docs/img"):
        (root / folder).mkdir(parents=True)
    return root


def test_the_kept_picture_is_the_codes(layers: ModuleType) -> None:
    """``figures.py --check`` passes for the picture: the contract, the plugins and the imports
    it was drawn from are the repository's now."""
    assert layers.check() == []
    kept = json.loads((ROOT / layers.KEPT_NAME).read_text(encoding="utf-8"))
    assert kept["layers"][-1] == ["cbrcore"]
    packages = ["cbrcore", *(p.parent.name for p in (ROOT / "plugins").glob("cbr_*/__init__.py"))]
    assert sorted(p for layer in kept["layers"] for p in layer) == sorted(packages)
    assert ["cbr_solvers", "cbr_grid"] in kept["imports"]
    page = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    assert "](img/layers.png)" in page


def test_a_new_import_makes_the_picture_stale_until_it_is_redrawn(layers: ModuleType,
                                                                  tmp_path: Path) -> None:
    root = _house(tmp_path)
    assert layers.check(root) == [f"{layers.KEPT_NAME}: missing; run `{layers.COMMAND}`"]
    assert layers.write(root) == [f"{layers.KEPT_NAME} and {layers.IMAGE_NAME} rewritten from "
                                  "the code"]
    assert layers.check(root) == [] and layers.write(root) == []
    kept = json.loads((root / layers.KEPT_NAME).read_text(encoding="utf-8"))
    assert kept["imports"] == [["cbr_alpha", "cbrcore"]]
    assert kept["plugins"] == {"cbrcore": "core", "cbr_alpha": "alpha"}

    # an import inside a function counts, as import-linter counts it
    (root / "cbrcore" / "engine.py").write_text("def f():\n    import cbr_alpha.deep\n",
                                                encoding="utf-8")
    assert layers.check(root) == [
        f"{layers.KEPT_NAME} differs from the code: cbrcore now imports cbr_alpha"]
    layers.write(root)
    assert layers.check(root) == []
    (root / layers.IMAGE_NAME).write_bytes(b"not the picture")
    assert layers.check(root) == [
        f"{layers.IMAGE_NAME} is not the picture drawn from {layers.KEPT_NAME}"]
