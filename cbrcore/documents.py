"""Reading YAML and JSON documents within limits: configurations, ``--set`` values and case base
exchange files.

A document is refused before any Python object is built from it when it is larger than a number
of bytes, nests collections deeper than a number of levels, or holds more values than a number,
counting what YAML aliases repeat (a "billion laughs" document of a few hundred bytes whose
aliases expand to a billion values is refused after reading those few hundred bytes). A YAML alias
that refers to the node containing it (``seed: &a [*a]``) is refused as well: the data it stands
for is infinite. The limits have defaults and are read from environment variables at every read:

=================================  ===========  ===============================================
variable                           default      limit
=================================  ===========  ===============================================
``CBR_MAX_DOCUMENT_BYTES``         100000000    the size of the document, in bytes
``CBR_MAX_DOCUMENT_DEPTH``         100          levels of nested collections (at most 200)
``CBR_MAX_DOCUMENT_NODES``         10000000     values (scalars and collections, mapping keys
                                                included), aliases expanded
``CBR_MAX_DOCUMENT_ALIAS_NODES``   100000       values that YAML aliases repeat
=================================  ===========  ===============================================

A refused document raises :class:`DocumentError`, whose ``problem`` gives the line and column
where the limit was passed when known. Malformed text raises the parser's own error
(:class:`yaml.YAMLError`, :class:`json.JSONDecodeError`), which callers word their own way:
with the parser's ``problem`` and the line and column (:func:`yaml_problem`), never the
exception's text, which quotes the line.

What an error quotes of a document follows one rule, applied by :func:`found`: a value is
quoted only when it is the user's own setting, under a key the schema knows in a document of
the expected shape at its top level. A document that is not of the expected shape at its top
level (a string or a list where a mapping is expected, a ``format`` tag that is not the
expected one) may be any file, a secret, so the error names the file, the line and column and
the shape expected, and says only what kind of value it found; a key the schema does not know
is located by its line and column, never quoted.
"""

from __future__ import annotations

import json
import os
import re
import sys
from collections.abc import Mapping
from itertools import accumulate
from typing import Any

import attrs
import yaml
from yaml.constructor import SafeConstructor
from yaml.events import AliasEvent, CollectionStartEvent

from cbrcore.errors import CbrError
from cbrcore.files import open_regular

MAX_DEPTH_CEILING = 200
"""The highest depth limit that may be configured: reading and checking a document recurses
once or more per level, and deeper documents would exhaust Python's stack."""


class DocumentError(CbrError):
    """A document refused before it was built; ``problem`` says why without naming the source."""

    def __init__(self, source: str, problem: str) -> None:
        self.source = source
        self.problem = problem
        super().__init__(f"{source}: {problem}")


@attrs.frozen
class Limits:
    """The most a document may hold; see the module's documentation."""

    bytes: int = 100_000_000
    depth: int = 100
    nodes: int = 10_000_000
    alias_nodes: int = 100_000

    @classmethod
    def from_environ(cls, environ: Mapping[str, str] | None = None) -> Limits:
        """The defaults, each replaced by its environment variable when that is set."""
        environ = os.environ if environ is None else environ
        values: dict[str, int] = {}
        for field in attrs.fields(cls):
            variable = _VARIABLES[field.name]
            text = environ.get(variable, "").strip()
            if not text:
                continue
            ceiling = MAX_DEPTH_CEILING if field.name == "depth" else None
            value = int(text) if text.isascii() and text.isdigit() else 0
            if value < 1 or (ceiling is not None and value > ceiling):
                bound = f" from 1 to {ceiling}" if ceiling else " of 1 or more"
                raise CbrError(f"environment variable {variable}: expected a whole number"
                               f"{bound}, got {text[:40]!r}")
            values[field.name] = value
        return cls(**values)


_VARIABLES = {
    "bytes": "CBR_MAX_DOCUMENT_BYTES",
    "depth": "CBR_MAX_DOCUMENT_DEPTH",
    "nodes": "CBR_MAX_DOCUMENT_NODES",
    "alias_nodes": "CBR_MAX_DOCUMENT_ALIAS_NODES",
}


def _over(limit: str, limits: Limits, what: str) -> str:
    """``what`` with the limit's value in place of ``{}``, naming the variable that sets it."""
    return what.format(getattr(limits, limit)) + f" (the limit, set by {_VARIABLES[limit]})"


def _at(line: int, column: int) -> str:
    return f"line {line}, column {column}: "


def _mark(mark: yaml.Mark | None) -> str:
    return _at(mark.line + 1, mark.column + 1) if mark is not None else ""


def read_bytes(path: str | os.PathLike[str], limits: Limits | None = None) -> bytes:
    """The content of the file at ``path``, refused when larger than the byte limit.

    No more than the limit is read, so a huge file costs nothing; anything but a regular file
    (a named pipe, a device) is refused by :func:`cbrcore.files.open_regular` without waiting
    on it. :class:`OSError` is left to the caller to explain.
    """
    limits = limits or Limits.from_environ()
    with open_regular(path) as file:
        data = file.read(limits.bytes + 1)
    if len(data) > limits.bytes:
        raise DocumentError(str(path), _over("bytes", limits, "the file is larger than {} bytes"))
    return data


def read_text(path: str | os.PathLike[str], limits: Limits | None = None) -> str:
    """The UTF-8 text of the file at ``path``, refused when larger than the byte limit.

    :class:`OSError` and :class:`UnicodeDecodeError` are left to the caller to explain.
    """
    return read_bytes(path, limits).decode("utf-8")


def _check_size(text: str, source: str, limits: Limits) -> None:
    # a character is one to four bytes: only text near the limit needs encoding to tell
    if len(text) > limits.bytes or (4 * len(text) > limits.bytes and
                                    len(text.encode("utf-8", "surrogatepass")) > limits.bytes):
        raise DocumentError(source, _over("bytes", limits, "the document is larger than {} bytes"))


# --- YAML ------------------------------------------------------------------------------------

class _Composer(yaml.SafeLoader):
    """The safe loader's composer, counting as it goes and refusing what passes the limits.

    The checks run before each node is composed, so neither Python's stack (the composer
    recurses once per level) nor memory is spent on a document that is refused. An alias is
    counted as the values of the node it repeats, known from when that node was composed.
    """

    def __init__(self, text: str, source: str, limits: Limits) -> None:
        super().__init__(text)
        self.source = source
        self.limits = limits
        self.depth = 0
        self.deepest = 0
        self.nodes = 0
        self.repeated = 0
        # by id of each anchored node once composed: its values and levels, aliases expanded
        self.sizes: dict[int, tuple[int, int]] = {}

    def refuse(self, mark: yaml.Mark | None, problem: str) -> DocumentError:
        return DocumentError(self.source, _mark(mark) + problem)

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node:
        event = self.peek_event()
        if isinstance(event, AliasEvent):
            anchored = self.anchors.get(event.anchor)
            if anchored is not None:  # an undefined alias is the composer's own error
                self.alias(anchored, event)
            return super().compose_node(parent, index)
        outer, level = self.deepest, self.depth
        if isinstance(event, CollectionStartEvent):
            self.depth += 1
            if self.depth > self.limits.depth:
                raise self.refuse(event.start_mark,
                                  _over("depth", self.limits,
                                        "collections nested more than {} levels deep"))
        self.deepest = self.depth
        first = self.nodes
        self.count(1, event.start_mark)
        node = super().compose_node(parent, index)
        if event.anchor is not None:
            self.sizes[id(node)] = (self.nodes - first, self.deepest - level)
        self.deepest = max(outer, self.deepest)
        self.depth = level
        return node

    def alias(self, anchored: yaml.Node, event: AliasEvent) -> None:
        size = self.sizes.get(id(anchored))
        if size is None:  # the anchored node is still being composed: it contains the alias
            raise self.refuse(event.start_mark, f"the alias *{event.anchor} refers to a node "
                                                "that contains it (a recursive anchor)")
        nodes, height = size
        if self.depth + height > self.limits.depth:
            raise self.refuse(event.start_mark,
                              _over("depth", self.limits, f"the alias *{event.anchor} nests "
                                    "collections more than {} levels deep"))
        self.deepest = max(self.deepest, self.depth + height)
        self.repeated += nodes
        if self.repeated > self.limits.alias_nodes:
            raise self.refuse(event.start_mark,
                              _over("alias_nodes", self.limits,
                                    "aliases repeat more than {} values"))
        self.count(nodes, event.start_mark)

    def count(self, nodes: int, mark: yaml.Mark) -> None:
        self.nodes += nodes
        if self.nodes > self.limits.nodes:
            raise self.refuse(mark, _over("nodes", self.limits, "the document holds more than {} "
                                                "values, aliases expanded"))


class _Constructor(SafeConstructor):
    """The safe constructor, refusing integers too long to be turned back into text."""

    def __init__(self, source: str) -> None:
        super().__init__()
        self.source = source

    def construct_yaml_int(self, node: yaml.ScalarNode) -> int:
        # Python's limit on the digits of an integer read or written as decimal text (0: none)
        digits = sys.get_int_max_str_digits()
        refused = DocumentError(self.source, _mark(node.start_mark) + "an integer of more than "
                                f"{digits} digits")
        try:
            value = super().construct_yaml_int(node)
        except ValueError:  # decimal text this long
            raise refused from None
        # binary, octal and hexadecimal text is not limited, but the number could not be printed
        if digits and value.bit_length() > 3 * digits and not _printable(value):
            raise refused
        return value


_Constructor.add_constructor("tag:yaml.org,2002:int", _Constructor.construct_yaml_int)


def _printable(value: int) -> bool:
    try:
        str(value)
    except ValueError:
        return False
    return True


def compose_yaml(text: str, source: str, limits: Limits | None = None) -> yaml.Node | None:
    """The node graph of a single YAML document (None when empty), checked against the limits.

    ``source`` names the document in errors. Malformed YAML raises :class:`yaml.YAMLError`.
    """
    limits = limits or Limits.from_environ()
    _check_size(text, source, limits)
    composer = _Composer(text, source, limits)
    try:
        return composer.get_single_node()
    finally:
        composer.dispose()


def construct_yaml(node: yaml.Node | None, source: str) -> Any:
    """The Python data of a node graph from :func:`compose_yaml`, built as the safe loader does.

    Construction merges ``<<`` keys into their mappings' nodes: inspect the graph before.
    """
    if node is None:
        return None
    return _Constructor(source).construct_document(node)


def load_yaml(text: str, source: str, limits: Limits | None = None) -> Any:
    """Parse one YAML document safely within the limits."""
    return construct_yaml(compose_yaml(text, source, limits), source)


def yaml_problem(exc: yaml.YAMLError) -> str:
    """What is wrong with malformed YAML, and where: ``line L, column C: PROBLEM``.

    The exception's own text quotes the line it is about, which may be a secret's.
    """
    mark = getattr(exc, "problem_mark", None)
    problem = getattr(exc, "problem", None) or type(exc).__name__
    return _mark(mark) + problem


def position(node: yaml.Node | None, *keys: str, key: bool = False) -> str:
    """`` (line L, column C)`` where the value under ``keys`` (mapping keys from the top level)
    starts in a composed document, or with ``key`` where its last key does; the document's
    start without keys; empty when the document does not hold them."""
    found_at = node
    for name in keys:
        if not isinstance(node, yaml.MappingNode):
            return ""
        found_at, node = next(((k, v) for k, v in node.value if k.value == name), (None, None))
    at = found_at if key else node
    if at is None:
        return ""
    return f" (line {at.start_mark.line + 1}, column {at.start_mark.column + 1})"


# --- what errors show of a document ----------------------------------------------------------

SHOWN_LENGTH = 60
"""The most characters of a setting an error quotes."""

_KINDS: tuple[tuple[type | tuple[type, ...], str], ...] = (
    (bool, "a boolean"), ((int, float), "a number"), (str, "a string"), (list, "a list"),
    (Mapping, "a mapping"),
)


def found(value: Any, *, setting: bool = False) -> str:
    """What an error says it found in a document (see the module's documentation for the rule).

    A ``setting``, a value under a key the schema knows in a document of the expected shape,
    is quoted, cut to :data:`SHOWN_LENGTH` characters. Anything else is named by its kind
    alone: ``a string``, ``a list``, ``a mapping``, ``a number``, ``a boolean``, ``null``.
    """
    if setting:
        text = repr(value)
        return text if len(text) <= SHOWN_LENGTH else text[: SHOWN_LENGTH - 3] + "..."
    if value is None:
        return "null"
    return next((kind for types, kind in _KINDS if isinstance(value, types)),
                f"a {type(value).__name__}")


# --- JSON ------------------------------------------------------------------------------------

# a string, escapes included; an unterminated one runs to the end, as the parser will say
_STRING = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"?', re.DOTALL)
_NOT_BRACKETS = re.compile(r"[^\[\]{}]+")
_EMPTY = re.compile(r"[\[{]\s*[\]}]")
_STEP = {"[": 1, "{": 1, "]": -1, "}": -1}
_STRUCTURE = re.compile(_STRING.pattern + r"|[\[\]{}]", re.DOTALL)


def _line_column(text: str, position: int) -> str:
    line_start = text.rfind("\n", 0, position) + 1
    return _at(text.count("\n", 0, position) + 1, position - line_start + 1)


def load_json(text: str, source: str, limits: Limits | None = None) -> Any:
    """Parse JSON text within the limits, checked by linear scans before it is parsed.

    Malformed JSON raises :class:`json.JSONDecodeError`.
    """
    limits = limits or Limits.from_environ()
    _check_size(text, source, limits)
    # blanked strings may not hold brackets, commas or colons, so counting those sees structure
    bare = _STRING.sub('""', text)
    brackets = _NOT_BRACKETS.sub("", bare)
    if brackets and max(accumulate(map(_STEP.__getitem__, brackets))) > limits.depth:
        raise DocumentError(source, _too_deep(text, limits))
    # a value is the document or follows a comma or opens a non-empty collection; a colon
    # follows a key, which is one more
    nodes = (1 + bare.count(",") + bare.count(":") + bare.count("[") + bare.count("{")
             - len(_EMPTY.findall(bare)))
    if nodes > limits.nodes:
        raise DocumentError(source, _over("nodes", limits,
                                          "the document holds more than {} values"))
    try:
        return json.loads(text)
    except json.JSONDecodeError:  # malformed text: the caller's to explain
        raise
    except ValueError:  # Python refuses decimal text longer than its limit
        digits = sys.get_int_max_str_digits()
        number = re.compile(_STRING.pattern + rf"|\d{{{digits + 1},}}", re.DOTALL)
        where = next((_line_column(text, m.start()) for m in number.finditer(text)
                      if not m.group().startswith('"')), "")
        raise DocumentError(source, f"{where}an integer of more than {digits} digits") from None


def _too_deep(text: str, limits: Limits) -> str:
    """Where the text first nests past the depth limit (scanned again only when it does)."""
    depth = 0
    for match in _STRUCTURE.finditer(text):
        bracket = match.group()
        if bracket in ("[", "{"):
            depth += 1
            if depth > limits.depth:
                return _line_column(text, match.start()) + _over(
                    "depth", limits, "collections nested more than {} levels deep")
        elif bracket in ("]", "}"):
            depth -= 1
    return _over("depth", limits, "collections nested more than {} levels deep")
