"""Where a results file comes from: the commit it was made at and a hash of the source that made
it, so that ``figures.py --check`` can tell a result the code has moved away from.

Every results file (``benchmarks/results/*.json``, ``docs/figures/*.json``) holds

- ``command``: the command that writes it anew;
- ``commit``: the commit checked out when it was written;
- ``source``: ``{unit: sha256}`` for each unit of the repository's source its producer imported.

A unit is a plugin package whole (``plugins/cbr_casegraph``), one top-level module or
subpackage of cbrcore (``cbrcore/engine.py``, ``cbrcore/casebase``: cbrcore also holds the
command line and the documents, which most results never touch) or a benchmark script
(``benchmarks/solvers.py``). The units are those of the modules in ``sys.modules`` when the
result is written, at the end of its run; a producer that measures another process (the command
line's start-up) names the units of that process itself. A unit's hash
covers its ``.py`` files in sorted path order, each path with its code: the syntax tree without
docstrings, so that a change of comments, docstrings or layout leaves results current and any
other change makes them stale. Data files (worlds, maps) are not covered.

The standard library only, so that a benchmark importing this adds no unit of its own.
"""

from __future__ import annotations

import ast
import hashlib
import json
import os
import shlex
import subprocess
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

ROOT = Path(__file__).resolve().parents[2]

#: the folders results files are kept in, from the repository's root
RESULT_FOLDERS = ("benchmarks/results", "docs/figures")


def unit_of(file: Path, root: Path = ROOT) -> str | None:
    """The unit a source file belongs to, None for a file outside cbrcore, the plugins and the
    benchmark scripts."""
    try:
        parts = file.resolve().relative_to(root).parts
    except ValueError:
        return None
    if len(parts) >= 2 and parts[0] == "cbrcore":
        return "/".join(parts[:2])
    if len(parts) == 2 and parts[0] == "benchmarks" and parts[1].endswith(".py"):
        return "/".join(parts)
    if len(parts) >= 3 and parts[0] == "plugins" and parts[1].startswith("cbr_"):
        return "/".join(parts[:2])
    return None


def units(modules: Iterable[ModuleType] | None = None, root: Path = ROOT) -> list[str]:
    """The units of ``modules`` (default: every module imported so far), sorted."""
    found = set()
    for module in list(sys.modules.values()) if modules is None else modules:
        file = getattr(module, "__file__", None)
        unit = unit_of(Path(file), root) if file else None
        if unit is not None:
            found.add(unit)
    return sorted(found)


def imported_units(modules: Iterable[str]) -> list[str]:
    """The units a fresh interpreter has imported once it has imported ``modules`` and every
    module of those that are packages: for results written by another process, as an
    experiment's are by ``cbr experiment``."""
    code = ("import importlib, pkgutil, sys\n"
            "for name in sys.argv[1:]:\n"
            "    module = importlib.import_module(name)\n"
            "    for found in pkgutil.walk_packages(getattr(module, '__path__', []), name + '.'):\n"
            "        importlib.import_module(found.name)\n"
            "print('\\n'.join(m.__file__ for m in list(sys.modules.values())\n"
            "                 if getattr(m, '__file__', None)))\n")
    done = subprocess.run([sys.executable, "-c", code, *modules], capture_output=True,
                          text=True, check=True,
                          env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    return sorted({unit for line in done.stdout.splitlines()
                   if (unit := unit_of(Path(line))) is not None})


def unit_sha256(unit: str, root: Path = ROOT) -> str | None:
    """The hash of a unit's ``.py`` files as ``root`` holds them; None when it holds none."""
    path = root / unit
    files = sorted(path.rglob("*.py")) if path.is_dir() else [path] if path.is_file() else []
    if not files:
        return None
    digest = hashlib.sha256()
    for file in files:
        digest.update(file.relative_to(root).as_posix().encode() + b"\0")
        digest.update(code_of(file.read_bytes()).encode() + b"\0")
    return digest.hexdigest()


def code_of(source: bytes) -> str:
    """What a module does, as text: its syntax tree without docstrings (comments and layout are
    not in the tree); the source itself when it does not parse."""
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return source.decode("utf-8", "replace")
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if (isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef)
                and body and isinstance(body[0], ast.Expr)
                and isinstance(body[0].value, ast.Constant)
                and isinstance(body[0].value.value, str)):
            node.body = body[1:] or [ast.Pass()]
    return ast.dump(tree)


def head(root: Path = ROOT) -> str:
    """The commit checked out."""
    return subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                          cwd=root, check=False).stdout.strip()


def script_command(script: str | None = None, argv: Sequence[str] | None = None) -> str:
    """The command line that runs ``script`` (default: this process's) with ``argv`` (default:
    this process's arguments), from the repository's root."""
    path = Path(script or sys.argv[0]).resolve()
    shown = path.relative_to(ROOT).as_posix() if path.is_relative_to(ROOT) else str(path)
    return shlex.join(["python", shown, *(sys.argv[1:] if argv is None else argv)])


def stamped(data: Mapping[str, Any], command: str | None = None, *,
            unit_names: Iterable[str] | None = None) -> dict[str, Any]:
    """``data`` with its provenance put first: ``command`` (default: the one ``data`` names,
    else the script's command line), ``commit`` (the one ``data`` names, read before a long
    run, else the one checked out) and ``source`` of ``unit_names`` (default: the units
    imported so far)."""
    chosen = units() if unit_names is None else sorted(unit_names)
    rest = {key: value for key, value in data.items()
            if key not in ("command", "commit", "source")}
    return {"command": command or data.get("command") or script_command(),
            "commit": data.get("commit") or head(),
            "source": {unit: unit_sha256(unit) for unit in chosen}, **rest}


def write_results(path: Path, data: Mapping[str, Any], *, command: str | None = None,
                  unit_names: Iterable[str] | None = None,
                  dumps: Callable[[dict[str, Any]], str] | None = None) -> dict[str, Any]:
    """Write a benchmark's results, :func:`stamped`, into ``path`` as ``dumps`` writes them
    (default: JSON indented by two); return what was written."""
    scripts = [unit for unit in units() if unit.startswith("benchmarks/")]
    done = stamped(data, command,
                   unit_names=None if unit_names is None else [*unit_names, *scripts])
    path.parent.mkdir(parents=True, exist_ok=True)
    text = dumps(done) if dumps else json.dumps(done, indent=2, ensure_ascii=False) + "\n"
    path.write_text(text, encoding="utf-8")
    return done


def result_files(root: Path = ROOT) -> list[Path]:
    """Every results file under ``root``."""
    return sorted(file for folder in RESULT_FOLDERS for file in (root / folder).glob("*.json"))


def changed_units(data: Mapping[str, Any], root: Path = ROOT) -> list[str] | None:
    """The units whose source differs from what the results record; None when they record no
    source."""
    source = data.get("source")
    if not isinstance(source, dict) or not source:
        return None
    return [unit for unit, digest in sorted(source.items())
            if unit_sha256(unit, root) != digest]
