"""The picture of the house on the architecture page: the layers of the import-linter contract
in ``pyproject.toml`` and the imports the packages make of each other, read from their code.

``python benchmarks/figures.py --write`` reads both anew and, when they differ from what
``docs/figures/layers.json`` keeps (or the picture from what was drawn), keeps them there with
the commit and draws ``docs/img/layers.png`` from what it kept; ``--check`` names what differs.
An import is any ``import`` statement of one package's module naming another package, wherever
it stands (in a function, under ``TYPE_CHECKING``), as import-linter counts them.
"""

from __future__ import annotations

import ast
import hashlib
import json
import tomllib
from pathlib import Path
from typing import Any

from .provenance import ROOT, changed_units, stamped
from .results import FiguresError

KEPT_NAME = "docs/figures/layers.json"
IMAGE_NAME = "docs/img/layers.png"
COMMAND = "python benchmarks/figures.py --write"
#: what each layer holds, named by one of its packages
TITLES = {"cbrcore": "engine", "cbr_stores": "stores, recording, experiments, kernels",
          "cbr_grid": "worlds", "cbr_kinematics": "kinematic models",
          "cbr_solvers": "model-based planners",
          "cbr_casegraph": "CBR families, observers"}


def _sources(root: Path) -> dict[str, Path]:
    """Each package of the code and its folder."""
    return {path.name: path for path in [root / "cbrcore", *sorted((root / "plugins").glob(
        "cbr_*"))] if (path / "__init__.py").is_file()}


def house(root: Path = ROOT) -> dict[str, Any]:
    """The layers (top first, each a list of packages), the plugin name of each package and the
    imports between packages as sorted ``[importer, imported]`` pairs."""
    project = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8"))
    layers = [[name.strip() for name in layer.split("|")]
              for contract in project["tool"]["importlinter"]["contracts"]
              if contract["type"] == "layers" for layer in contract["layers"]]
    plugins = {value.split(".")[0] if value != "cbrcore.builtins" else "cbrcore": name
               for name, value in project["project"]["entry-points"]["cbr"].items()}
    sources = _sources(root)
    imports = set()
    for package, folder in sources.items():
        for path in folder.rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.Import):
                    names = [alias.name for alias in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names = [node.module]
                else:
                    continue
                imports |= {(package, top) for name in names
                            if (top := name.split(".")[0]) in sources and top != package}
    return {"layers": layers, "plugins": plugins, "imports": sorted(map(list, imports))}


def _kept(root: Path) -> dict[str, Any] | None:
    path = root / KEPT_NAME
    return json.loads(path.read_text(encoding="utf-8")) if path.is_file() else None


def _image_sha256(root: Path) -> str | None:
    path = root / IMAGE_NAME
    return hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None


def _differences(found: dict[str, Any], kept: dict[str, Any]) -> list[str]:
    said = []
    if found["layers"] != kept["layers"]:
        said.append("the layers of pyproject.toml")
    if found["plugins"] != kept["plugins"]:
        said.append("the plugin names")
    edges = {tuple(pair) for pair in found["imports"]}
    old = {tuple(pair) for pair in kept["imports"]}
    said += [f"{a} now imports {b}" for a, b in sorted(edges - old)]
    said += [f"{a} no longer imports {b}" for a, b in sorted(old - edges)]
    return said


def check(root: Path = ROOT) -> list[str]:
    """One line naming what the kept house or its picture lacks; none when both are current."""
    try:
        found = house(root)
    except (OSError, KeyError, SyntaxError) as exc:
        return [f"{KEPT_NAME}: cannot read the layers and imports of the code: {exc}"]
    kept = _kept(root)
    if kept is None:
        return [f"{KEPT_NAME}: missing; run `{COMMAND}`"]
    lines = []
    differences = _differences(found, kept)
    if differences:
        lines.append(f"{KEPT_NAME} differs from the code: {'; '.join(differences)}")
    if changed_units(kept):  # the script that runs, whichever code it reads
        lines.append(f"{KEPT_NAME} was drawn by an older benchmarks/docfigures/layers.py")
    if _image_sha256(root) != kept.get("image_sha256"):
        lines.append(f"{IMAGE_NAME} is not the picture drawn from {KEPT_NAME}")
    return lines


def write(root: Path = ROOT) -> list[str]:
    """Keep the code's house and draw its picture, when either is not current."""
    if not check(root):
        return []
    try:
        found = house(root)
    except (OSError, KeyError, SyntaxError) as exc:
        raise FiguresError(f"cannot read the layers and imports of the code: {exc}") from None
    data = stamped(found, COMMAND, unit_names=["benchmarks/docfigures/layers.py"])
    draw(data, root / IMAGE_NAME)
    data["image_sha256"] = _image_sha256(root)
    (root / KEPT_NAME).write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")
    return [f"{KEPT_NAME} and {IMAGE_NAME} rewritten from the code"]


def draw(data: dict[str, Any], target: Path) -> None:
    """The layers as rows of boxes, top layer first, and an arrow for each import: grey into the
    engine (every plugin imports it), blue between plugins, red where the contract is broken
    (an import upward or within a layer)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    layers = data["layers"]
    row_of = {p: k for k, layer in enumerate(layers) for p in layer}
    widest = max(len(layer) for layer in layers)
    width, height, gap = 1.75, 0.55, 1.25
    place = {}
    for k, layer in enumerate(layers):
        for i, package in enumerate(layer):
            place[package] = ((i - (len(layer) - 1) / 2) * (width + 0.3),
                              (len(layers) - 1 - k) * gap)
    figure, axes = plt.subplots(figsize=(1.0 + widest * 2.0, 1.0 + len(layers) * 1.2))
    for importer, imported in data["imports"]:
        (x0, y0), (x1, y1) = place[importer], place[imported]
        broken = row_of[imported] <= row_of[importer]
        colour = "#c0392b" if broken else ("#bbbbbb" if imported == "cbrcore" else "#2c6fbb")
        # an arrow over a layer bends, so that it does not seem to leave the box it passes
        bend = 0.12 if row_of[imported] - row_of[importer] > 1 else 0.0
        axes.annotate("", xy=(x1, y1 + height / 2), xytext=(x0, y0 - height / 2),
                      arrowprops={"arrowstyle": "-|>", "color": colour, "lw": 1.1,
                                  "shrinkA": 0, "shrinkB": 0,
                                  "connectionstyle": f"arc3,rad={bend}"}, zorder=1)
    for package, (x, y) in place.items():
        axes.add_patch(plt.Rectangle((x - width / 2, y - height / 2), width, height,
                                     facecolor="#fdf6e3", edgecolor="#555555", zorder=2))
        label = f"{package}\n({data['plugins'].get(package, 'no plugin')})"
        axes.text(x, y, label, ha="center", va="center", fontsize=8.5, zorder=3)
    left = min(x for x, _ in place.values()) - width / 2 - 0.2
    for k, layer in enumerate(layers):
        title = next((TITLES[p] for p in layer if p in TITLES), "")
        axes.text(left, (len(layers) - 1 - k) * gap, title, ha="right", va="center",
                  fontsize=9, style="italic")
    axes.set_xlim(left - 2.3, -left + 0.1)
    axes.set_ylim(-height, (len(layers) - 1) * gap + height)
    axes.axis("off")
    axes.set_title("Packages by layer (top imports down); arrows: imports found in the code "
                   "(grey: into cbrcore)", fontsize=9.5)
    figure.tight_layout()
    figure.savefig(target, dpi=100, metadata={"Software": None})
    plt.close(figure)


def reading() -> str:
    """Where the picture comes from: the counts behind it and the commit it was drawn at."""
    kept = _kept(ROOT)
    if kept is None:
        return f"`{KEPT_NAME}` is missing: run `{COMMAND}`."
    row = {package: k for k, layer in enumerate(kept["layers"]) for package in layer}
    imports = kept["imports"]
    between = [pair for pair in imports if pair[1] != "cbrcore"]
    upward = sum(1 for a, b in imports if row[b] <= row[a])
    return (f"Drawn by `{COMMAND}` from the layers contract in `pyproject.toml` and the "
            f"`import` statements of the {len(row)} packages, read from their "
            f"code at commit {kept['commit'][:12]}: {len(imports)} package dependencies, "
            f"{len(imports) - len(between)} of them on `cbrcore` and {len(between)} between "
            "plugins, "
            + ("every one pointing down." if not upward else
               f"{upward} of them breaking the contract (red)."))
