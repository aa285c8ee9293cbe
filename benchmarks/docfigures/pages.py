"""The generated blocks of the docs' pages: finding them, rendering them anew, checking them."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

from .catalogue import BLOCKS
from .results import DOCS, ROOT, FiguresError

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
