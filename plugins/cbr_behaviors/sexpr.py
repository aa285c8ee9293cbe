"""S-expressions, the written form of 004's cases: a reader that keeps line numbers and a
pretty-printing writer.

The language is small. An *atom* is an integer (``150``, ``-3``), a float (``3.0``, ``.5``,
``1e-05``), a string in double quotes (``"room 3"``; escapes ``\\"``, ``\\\\``, ``\\n``,
``\\t``) or a *symbol*, any other run of characters up to white space, a parenthesis, a double
quote or ``;`` (``mod-fast``, ``curr-head``, ``?x``, ``room_1``, ``*``). A *list* is elements in
parentheses. ``;`` starts a comment that runs to the end of the line.

The reader keeps to the limits of every document (:mod:`cbrcore.documents`): lists nest at
most ``CBR_MAX_DOCUMENT_DEPTH`` levels (100 by default), an integer has at most the digits
Python converts (4300 by default), and a float is finite, so that neither Python's stack, which
whoever walks the lists spends once per level, nor a number that cannot be used gets further.

:func:`read` gives :class:`Node` objects, each with the line and column it starts at, so that
whoever interprets them can say where a problem lies; :meth:`Node.plain` turns one into plain
data (symbols and strings both become ``str``). :func:`write` goes the other way, from plain
data: a string is written as a symbol when it reads back as the same symbol, in double quotes
otherwise, so plain data round-trips.
"""

from __future__ import annotations

import math
import re
import sys
from collections.abc import Iterator, Sequence
from typing import Any

import attrs

from cbrcore.documents import Limits
from cbrcore.errors import CbrError

WIDTH = 100
"""The line width :func:`write` fills up to."""


class SexprError(CbrError):
    """Text that is not a well-formed s-expression; names the source and the line."""

    def __init__(self, source: str, line: int, problem: str) -> None:
        self.source = source
        self.line = line
        self.problem = problem
        super().__init__(f"{source}, line {line}: {problem}")


@attrs.frozen
class Symbol:
    """A symbol atom, told apart from a string atom of the same text."""

    name: str


Atom = Symbol | str | int | float


@attrs.frozen
class Node:
    """One element read from the text: an atom or a list (a tuple of nodes), with the line
    (from 1) and column (from 1) where it starts."""

    value: Atom | tuple[Node, ...]
    line: int
    column: int

    @property
    def is_list(self) -> bool:
        return isinstance(self.value, tuple)

    @property
    def items(self) -> tuple[Node, ...]:
        """The elements of a list node (empty for an atom)."""
        return self.value if isinstance(self.value, tuple) else ()

    @property
    def symbol(self) -> str | None:
        """The name of a symbol atom, None for anything else."""
        return self.value.name if isinstance(self.value, Symbol) else None

    def plain(self) -> Any:
        """The node as plain data: lists become lists, symbols and strings ``str``."""
        if isinstance(self.value, tuple):
            return [node.plain() for node in self.value]
        if isinstance(self.value, Symbol):
            return self.value.name
        return self.value

    def text(self) -> str:
        """The node written on one line."""
        return _flat(self.plain())


_SPACE = frozenset(" \t\r\f\v")
_DELIMITERS = frozenset('()";\n') | _SPACE
_INTEGER = re.compile(r"[+-]?[0-9]+")
_FLOAT = re.compile(r"[+-]?(?:[0-9]+\.[0-9]*|\.[0-9]+|[0-9]+(?=[eE]))(?:[eE][+-]?[0-9]+)?")
_ESCAPES = {'"': '"', "\\": "\\", "n": "\n", "t": "\t"}
_WRITTEN_ESCAPES = {value: "\\" + key for key, value in _ESCAPES.items()}


def _atom(token: str) -> Atom:
    """The atom ``token`` stands for; ValueError when it is a number that cannot be used."""
    if _INTEGER.fullmatch(token):
        digits = sys.get_int_max_str_digits()
        if digits and len(token.lstrip("+-")) > digits:
            raise ValueError(f"an integer of more than {digits} digits")
        return int(token)
    if _FLOAT.fullmatch(token):
        value = float(token)
        if not math.isfinite(value):
            raise ValueError(f"a number beyond the largest float ({sys.float_info.max:g})")
        return value
    return Symbol(token)


class _Scanner:
    """Walks the text once, yielding ``(kind, value, line, column)`` tokens: kind ``(`` or
    ``)`` or ``atom``."""

    def __init__(self, text: str, source: str) -> None:
        self.text = text
        self.source = source

    def tokens(self) -> Iterator[tuple[str, Atom | None, int, int]]:
        text, n = self.text, len(self.text)
        i, line, line_start = 0, 1, 0
        while i < n:
            char = text[i]
            column = i - line_start + 1
            if char == "\n":
                line, line_start = line + 1, i + 1
                i += 1
            elif char in _SPACE:
                i += 1
            elif char == ";":
                end = text.find("\n", i)
                i = n if end < 0 else end
            elif char in "()":
                yield char, None, line, column
                i += 1
            elif char == '"':
                value, i, lines = self._string(i, line)
                yield "atom", value, line, column
                if lines:
                    line += lines
                    line_start = text.rfind("\n", 0, i) + 1
            else:
                start = i
                while i < n and text[i] not in _DELIMITERS:
                    i += 1
                try:
                    atom = _atom(text[start:i])
                except ValueError as exc:
                    raise SexprError(self.source, line, f"column {column}: {exc}") from None
                yield "atom", atom, line, column

    def _string(self, start: int, line: int) -> tuple[str, int, int]:
        """The string opening at ``start``: its value, the index after it and the line breaks
        inside it."""
        text, out, i = self.text, [], start + 1
        while i < len(text):
            char = text[i]
            if char == '"':
                return "".join(out), i + 1, text.count("\n", start, i)
            if char == "\\":
                escaped = text[i + 1] if i + 1 < len(text) else ""
                if escaped not in _ESCAPES:
                    here = line + text.count("\n", start, i)
                    raise SexprError(self.source, here, f"unknown escape \\{escaped} in a "
                                     'string; known: \\" \\\\ \\n \\t')
                out.append(_ESCAPES[escaped])
                i += 2
            else:
                out.append(char)
                i += 1
        raise SexprError(self.source, line, "a string opened here is never closed")


def read(text: str, source: str = "<text>") -> tuple[Node, ...]:
    """The top-level elements of ``text``; :class:`SexprError` naming ``source`` and the line
    of an unbalanced parenthesis, an unclosed string, a bad escape, lists nested past the
    document depth limit or a number that cannot be used."""
    depth = Limits.from_environ().depth
    stack: list[tuple[int, int, list[Node]]] = []
    top: list[Node] = []
    for kind, value, line, column in _Scanner(text, source).tokens():
        if kind == "(":
            if len(stack) == depth:
                raise SexprError(source, line, f"column {column}: lists nested more than "
                                 f"{depth} levels deep (the limit, set by "
                                 "CBR_MAX_DOCUMENT_DEPTH)")
            stack.append((line, column, []))
        elif kind == ")":
            if not stack:
                raise SexprError(source, line, f"the ')' at column {column} closes nothing")
            opened_line, opened_column, items = stack.pop()
            node = Node(tuple(items), opened_line, opened_column)
            (stack[-1][2] if stack else top).append(node)
        else:
            assert value is not None
            (stack[-1][2] if stack else top).append(Node(value, line, column))
    if stack:
        line, column, _ = stack[-1]
        noun = "list" if len(stack) == 1 else f"list ({len(stack)} in all)"
        raise SexprError(source, line, f"the {noun} opened at column {column} is never closed")
    return tuple(top)


# --- writing ---------------------------------------------------------------------------------

def _symbol_safe(text: str) -> bool:
    return (bool(text) and not any(c in _DELIMITERS for c in text)
            and isinstance(_atom(text), Symbol))


def _write_atom(value: Any) -> str:
    if isinstance(value, Symbol):
        return value.name
    if isinstance(value, bool):
        raise ValueError(f"s-expressions hold no booleans, got {value!r}")
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"s-expressions hold finite numbers only, got {value!r}")
        return repr(value)
    if isinstance(value, str):
        if _symbol_safe(value):
            return value
        return '"' + "".join(_WRITTEN_ESCAPES.get(c, c) for c in value) + '"'
    raise ValueError(f"cannot write {value!r} as an s-expression")


def _is_list(value: Any) -> bool:
    return isinstance(value, Sequence) and not isinstance(value, str)


def _flat(value: Any) -> str:
    if _is_list(value):
        return "(" + " ".join(_flat(v) for v in value) + ")"
    return _write_atom(value)


def _table(value: Sequence[Any]) -> bool:
    # a list of two or more lists (a behavior set) reads best one row per line
    return len(value) >= 2 and all(_is_list(v) for v in value)


def _format(value: Any, indent: int, width: int) -> str:
    flat = _flat(value)
    if not _is_list(value) or not value or (indent + len(flat) <= width and not _table(value)):
        return flat
    if _is_list(value[0]):
        rows = [_format(v, indent + 1, width) for v in value]
        return "(" + ("\n" + " " * (indent + 1)).join(rows) + ")"
    # leading atoms (a head and its name) fill the first lines, the rest one element a line
    body = " " * (indent + 2)
    lines, line = [], "(" + _write_atom(value[0])
    rest = list(value[1:])
    while rest and not _is_list(rest[0]):
        word = _write_atom(rest.pop(0))
        if indent + len(line) + 1 + len(word) > width:
            lines.append(line)
            line = body + word
        else:
            line += " " + word
    lines.append(line)
    lines += [body + _format(v, indent + 2, width) for v in rest]
    return "\n".join(lines) + ")"


def write(value: Any, width: int = WIDTH) -> str:
    """Plain data (lists, tuples, strings, :class:`Symbol`, integers, floats) as an
    s-expression pretty-printed within ``width`` columns where it can be: a list that fits is
    written on one line, unless it is a list of two or more lists (a table, such as a behavior
    set); a table, or a longer list that opens with a list, gets one element a line, aligned
    under the first; a longer list that opens with an atom keeps its leading atoms on the first
    lines and puts each further element on a line of its own, indented by two."""
    return _format(value, 0, width)
