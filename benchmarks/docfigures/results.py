"""Reading the results the figures come from: benchmark tables and JSON, kept experiments."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from cbrcore.errors import CbrError

from .provenance import ROOT

DOCS = ROOT / "docs"
RESULTS = ROOT / "benchmarks" / "results"
KEPT = DOCS / "figures"


class FiguresError(CbrError):
    """A block that cannot be rendered: unknown name, missing or malformed results."""


def _named(path: Path) -> str:
    """``path`` as a message names it: within the repository from its root, elsewhere whole (a
    run folder to keep results from may lie anywhere)."""
    return path.relative_to(ROOT).as_posix() if path.is_relative_to(ROOT) else str(path)


def read(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise FiguresError(f"{_named(path)}: no such results file") from None


def load_json(path: Path) -> Any:
    try:
        return json.loads(read(path))
    except json.JSONDecodeError as exc:
        raise FiguresError(f"{_named(path)}: not JSON ({exc})") from None


def tables(text: str) -> list[list[str]]:
    """The markdown tables of ``text``, each as its lines."""
    found: list[list[str]] = []
    current: list[str] = []
    for line in [*text.splitlines(), ""]:
        if line.startswith("|"):
            current.append(line)
        elif current:
            found.append(current)
            current = []
    return found


def _cells(line: str) -> list[str]:
    return [cell.strip() for cell in line.strip().strip("|").split("|")]


def _header_and_rows(text: str, index: int) -> tuple[list[str], list[list[str]]]:
    """The header cells and the rows' cells of table ``index`` of ``text``."""
    found = tables(text)
    if index >= len(found):
        raise FiguresError(f"results hold {len(found)} tables, not table {index + 1}")
    header, _, *rows = found[index]
    return _cells(header), [_cells(row) for row in rows]


def table(text: str, index: int, columns: Sequence[str] | None = None, *, where: str = ""
          ) -> str:
    """Table ``index`` of ``text``, with only ``columns`` (by header, in that order) and only the
    rows whose first cell starts with ``where``."""
    names, rows = _header_and_rows(text, index)
    keep = list(range(len(names))) if columns is None else []
    for column in columns or ():
        if column not in names:
            raise FiguresError(f"results table {index + 1} has no column {column!r}: {names}")
        keep.append(names.index(column))
    chosen = [row for row in rows if row[0].startswith(where)]
    lines = [[names[k] for k in keep], ["---"] * len(keep),
             *[[row[k] for k in keep] for row in chosen]]
    return "\n".join("| " + " | ".join(line) + " |" for line in lines)


def records(text: str, index: int) -> list[dict[str, str]]:
    """Table ``index`` of ``text`` as one dict per row, keyed by the header's cells."""
    names, rows = _header_and_rows(text, index)
    return [dict(zip(names, row, strict=True)) for row in rows]


def paragraphs(text: str, start: str) -> str:
    """The paragraph of ``text`` that starts with ``start``."""
    for paragraph in text.split("\n\n"):
        if paragraph.startswith(start):
            return paragraph.strip()
    raise FiguresError(f"results hold no paragraph starting {start!r}")


def result_md(benchmark: str) -> str:
    """A benchmark's markdown results, ``benchmarks/results/<benchmark>.md``."""
    return read(RESULTS / f"{benchmark}.md")


def bench(benchmark: str) -> dict[str, Any]:
    """A benchmark's JSON results, ``benchmarks/results/<benchmark>.json``."""
    return load_json(RESULTS / f"{benchmark}.json")


def kept(experiment: str) -> dict[str, Any]:
    """An experiment's committed results: ``command``, ``table`` (its results.md), ``results``."""
    data = load_json(KEPT / f"{experiment}.json")
    missing = {"command", "table", "results"} - set(data)
    if missing:
        raise FiguresError(f"docs/figures/{experiment}.json lacks {sorted(missing)}")
    return data


def kept_results(experiment: str) -> dict[str, Any]:
    """The ``results`` of an experiment's committed results."""
    return kept(experiment)["results"]
