"""The generated blocks of the docs' pages: finding them, rendering them anew, checking them;
and the results files whose source has changed since they were written."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

from .catalogue import BLOCKS
from .provenance import changed_units, result_files
from .results import DOCS, ROOT, FiguresError, load_json

#: how many changed units a line of the check names before it counts the rest
SHOWN_UNITS = 3

BLOCK = re.compile(r"(<!-- figures: (?P<name>[\w.-]+) -->\n)(?P<body>.*?)(<!-- /figures -->)",
                   re.S)


def render(name: str) -> str:
    if name not in BLOCKS:
        raise FiguresError(f"unknown block {name!r}; known: {', '.join(sorted(BLOCKS))}")
    return BLOCKS[name].render().rstrip("\n") + "\n"


def pages(docs: Path = DOCS) -> list[Path]:
    return sorted(docs.rglob("*.md"))


def refresh(text: str, where: str) -> tuple[str, list[str]]:
    """``text`` with every block rendered anew, and the names of the blocks that changed."""
    changed: list[str] = []

    def fill(match: re.Match[str]) -> str:
        name = match["name"]
        try:
            body = render(name)
        except FiguresError as exc:
            raise FiguresError(f"{where}: block {name}: {exc}") from None
        if body != match["body"]:
            changed.append(name)
        return match[1] + body + match[4]

    return BLOCK.sub(fill, text), changed


def _refreshed(docs: Path) -> Iterator[tuple[Path, str, str, list[str]]]:
    """Each page under ``docs``: its path, its name (``docs/x.md``), its text with every block
    rendered anew and the blocks that changed."""
    for page in pages(docs):
        where = _name(page, docs)
        text, changed = refresh(page.read_text(encoding="utf-8"), where)
        yield page, where, text, changed


def _name(page: Path, docs: Path) -> str:
    return page.relative_to(docs.parent).as_posix()


def check(docs: Path = DOCS) -> list[str]:
    """One line per stale block: the page and the block's name."""
    return [f"{where}: block {name} differs from its results "
            f"({BLOCKS[name].source.relative_to(ROOT)})"
            for _, where, _, changed in _refreshed(docs) for name in changed]


def write(docs: Path = DOCS) -> list[str]:
    """Rewrite every stale block; one line per block rewritten."""
    done = []
    for page, where, text, changed in _refreshed(docs):
        if changed:
            page.write_text(text, encoding="utf-8")
            done += [f"{where}: block {name} rewritten" for name in changed]
    return done


def used(docs: Path = DOCS) -> dict[str, list[str]]:
    """Each block name found in the pages, with the pages that hold it."""
    found: dict[str, list[str]] = {}
    for page in pages(docs):
        for match in BLOCK.finditer(page.read_text(encoding="utf-8")):
            found.setdefault(match["name"], []).append(_name(page, docs))
    return found


def _blocks_of(result: str) -> list[str]:
    """The blocks rendered from results file ``result`` or from its markdown twin."""
    return [name for name, block in BLOCKS.items()
            if block.source.with_suffix(".json").relative_to(ROOT).as_posix() == result]


def stale_results(root: Path = ROOT) -> list[str]:
    """One line per results file under ``root`` whose recorded source differs from the source
    there (or that records none): the file, its blocks, the units changed and the command that
    writes it anew."""
    lines = []
    for file in result_files(root):
        data = load_json(file)
        changed = changed_units(data, root)
        if changed == []:
            continue
        name = file.relative_to(root).as_posix()
        blocks = _blocks_of(name)
        if changed is None:
            why = "records no source"
        else:
            # a plugin says more of what changed than cbrcore's modules do
            changed.sort(key=lambda unit: (not unit.startswith("plugins/"), unit))
            shown = ", ".join(changed[:SHOWN_UNITS])
            more = len(changed) - SHOWN_UNITS
            why = (f"source changed since commit {str(data.get('commit'))[:10]}: {shown}"
                   + (f" and {more} more" if more > 0 else ""))
        lines.append(f"{name} ({'blocks ' + ', '.join(blocks) if blocks else 'no block'}): "
                     f"{why}; rerun {_rerun(str(data.get('command', '(no command recorded)')))}")
    return lines


def _rerun(command: str) -> str:
    """How to rerun ``command``: an experiment's run is kept from its output folder."""
    words = command.split()
    if words[:2] != ["cbr", "experiment"] or len(words) < 3:
        return f"`{command}`"
    return (f"`{command} --out DIR`, then "
            f"`python benchmarks/figures.py --keep-experiment {words[2]} DIR`")
