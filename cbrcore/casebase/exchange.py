"""Plain data in and out of case bases: the plain-text export format, YAML or JSON.

An exported case base looks like this::

    format: cbrcore-casebase
    schema: 1
    revision: 42
    meta: {grid.index: ...}
    cases:
    - {id: 1, kind: case, problem: ..., solution: ..., meta: {}, uses: 3, created: 1, last_used: 40}

Importing into an empty store keeps ids and revision stamps, so an exported case base imports back
equal. Importing with ``append`` adds the document's cases as new cases of a store that already
holds some. A document is checked against the same rules as a store's contents
(:mod:`cbrcore.casebase.data`).
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal, TextIO

import attrs
import yaml

from cbrcore import files
from cbrcore.casebase.data import (
    MAX_INTEGER,
    REVISION_KEY,
    _is_unicode,
    _short,
    _step,
    is_json,
    json_problems,
)
from cbrcore.casebase.store import CaseStore
from cbrcore.casebase.worlds import ONE, WORLDS_KEY, Worlds, join_worlds, parse_worlds
from cbrcore.documents import (
    DocumentError,
    compose_yaml,
    construct_yaml,
    found,
    load_json,
    position,
    read_text,
    yaml_problem,
)
from cbrcore.errors import CaseBaseError
from cbrcore.model import JSON, Case

FORMAT = "cbrcore-casebase"
"""The ``format`` value that marks an exported case base."""

SCHEMA = 1
"""The version of the export document (and of the SQLite schema) this cbrcore reads and writes."""

Format = Literal["yaml", "json"]
_SUFFIXES: dict[str, Format] = {".yaml": "yaml", ".yml": "yaml", ".json": "json"}
_CASE_KEYS = ("id", "kind", "problem", "solution", "meta", "uses", "created", "last_used")
_MAX_LISTED = 20


@attrs.frozen
class Document:
    """A whole case base as plain data: what export writes and import reads."""

    revision: int = 0
    meta: Mapping[str, JSON] = attrs.field(factory=dict)
    cases: tuple[Case, ...] = ()


def document_of(store: CaseStore) -> Document:
    """A consistent snapshot of ``store``.

    It is read without locking when no commit lands meanwhile (the revision would have moved),
    so a case base that another process keeps busy, or that may not be written, can be exported.
    Otherwise it is read again inside a transaction, which holds writers off and writes nothing.
    """
    revision = store.revision
    document = Document(revision, store.meta_items(), tuple(store.cases()))
    if store.revision == revision:
        return document
    with store.transaction():
        return Document(store.revision, store.meta_items(), tuple(store.cases()))


def document_to_data(document: Document) -> dict[str, Any]:
    """The document as the plain mapping that is written to a file."""
    return {
        "format": FORMAT,
        "schema": SCHEMA,
        "revision": document.revision,
        "meta": dict(document.meta),
        "cases": [
            {
                "id": case.id,
                "kind": case.kind,
                "problem": case.problem,
                "solution": case.solution,
                "meta": dict(case.meta),
                "uses": case.uses,
                "created": case.created,
                "last_used": case.last_used,
            }
            for case in document.cases
        ],
    }


def _type_name(value: Any) -> str:
    return "null" if value is None else type(value).__name__


class _Reader:
    """Collects the problems of a document, each with its path inside the document."""

    def __init__(self) -> None:
        self.problems: list[str] = []

    def problem(self, path: str, message: str) -> None:
        self.problems.append(f"{path}: {message}")

    def count(self, value: Any, path: str, *, least: int = 0) -> int | None:
        if not isinstance(value, int) or isinstance(value, bool) or value < least:
            self.problem(path, f"expected an integer >= {least}, got {_short(value)}")
        elif value > MAX_INTEGER:  # a SQLite integer is a signed 64-bit one
            self.problem(path, f"{_short(value)} is beyond the largest integer a case base "
                               "holds (2^63 - 1)")
        else:
            return value
        return None

    def plain(self, value: Any, path: str) -> Any:
        if not is_json(value):
            self.problems.extend(json_problems(value, path))
        return value

    def mapping(self, value: Any, path: str) -> dict[str, Any] | None:
        if not isinstance(value, dict):
            self.problem(path, f"expected a mapping, got {_type_name(value)}")
            return None
        return self.plain(value, path)

    def stamp(self, value: Any, path: str, revision: int | None) -> int | None:
        if value is None:
            return None
        stamp = self.count(value, path)
        if stamp is not None and revision is not None and stamp > revision:
            self.problem(path, f"revision {stamp} is after the document's revision {revision}")
        return stamp

    def case(self, entry: Any, path: str, revision: int | None, ids: dict[int, str]) -> Case | None:
        if not isinstance(entry, dict):
            self.problem(path, f"expected a mapping, got {_type_name(entry)}")
            return None
        before = len(self.problems)
        known = ", ".join(_CASE_KEYS)
        for key in entry:
            if key not in _CASE_KEYS:
                self.problem(f"{path}.{key}", f"unknown key; expected one of: {known}")
        for key in ("problem", "solution"):
            if key not in entry:
                self.problem(f"{path}.{key}", "required key is missing")
        case_id = entry.get("id")
        if case_id is not None:
            case_id = self.count(case_id, f"{path}.id", least=1)
            if case_id in ids:
                self.problem(f"{path}.id", f"{case_id} is also the id of {ids[case_id]}")
            elif case_id is not None:
                ids[case_id] = path
        kind = entry.get("kind", "case")
        if not isinstance(kind, str) or not kind:
            self.problem(f"{path}.kind", f"expected a non-empty string, got {_short(kind)}")
        elif not _is_unicode(kind):
            self.problem(f"{path}.kind", f"{kind!r} is not valid Unicode text")
        problem = self.plain(entry.get("problem"), f"{path}.problem")
        solution = self.plain(entry.get("solution"), f"{path}.solution")
        meta = self.mapping(entry.get("meta", {}), f"{path}.meta")
        uses = self.count(entry.get("uses", 0), f"{path}.uses")
        created = self.stamp(entry.get("created"), f"{path}.created", revision)
        last_used = self.stamp(entry.get("last_used"), f"{path}.last_used", revision)
        if len(self.problems) > before or meta is None or uses is None:
            return None
        return Case(problem, solution, kind, meta, case_id, uses, created, last_used)


def _unknown_key(node: yaml.Node | None, key: Any, index: int) -> str:
    """Where a top-level key the format does not know is, without quoting it: it may be a
    secret's (the rule of :func:`cbrcore.documents.found`)."""
    where = position(node, str(key), key=True).strip(" ()")
    return where or f"key {index + 1} of the top level"


def document_from_data(data: Any, source: str, node: yaml.Node | None = None) -> Document:
    """Validate a parsed document; CaseBaseError lists every problem with its path in it.

    ``node``, the document's composed YAML, adds the line and column of its top-level
    problems. A document that is not a mapping tagged ``format: cbrcore-casebase`` gets that
    one problem, and nothing of it is quoted.
    """
    if not isinstance(data, dict):
        raise CaseBaseError(f"{source}: the top level{position(node)}: expected a case base "
                            f"document (a mapping with format: {FORMAT}), got {found(data)}")
    reader = _Reader()
    if data.get("format") != FORMAT:
        got = "nothing" if "format" not in data else found(data["format"])
        reader.problem(f"format{position(node, 'format')}",
                       f"expected {FORMAT!r}, got {got}; this is not an exported case base")
        _refuse(reader.problems, source)
    schema = data.get("schema")
    if schema != SCHEMA:
        reader.problem("schema", f"this cbrcore reads schema {SCHEMA}, the document has "
                                 f"{_short(schema) if 'schema' in data else 'none'}")
    for index, key in enumerate(data):
        if key not in ("format", "schema", "revision", "meta", "cases"):
            reader.problem(_unknown_key(node, key, index),
                           "unknown key; expected format, schema, revision, meta, cases")
    revision = reader.count(data.get("revision", 0), "revision")
    meta = reader.mapping(data.get("meta", {}), "meta")
    for key in meta or {}:
        if not isinstance(key, str):
            continue  # the mapping's check named it
        if key == REVISION_KEY:
            reader.problem(_step("meta", key), "this key is reserved for the revision")
        elif not _is_unicode(key):
            reader.problem(_step("meta", key), "this key is not valid Unicode text")
    if meta is not None:
        reader.problems.extend(parse_worlds(meta.get(WORLDS_KEY), _step("meta", WORLDS_KEY))[1])
    entries = data.get("cases", [])
    cases: list[Case] = []
    if not isinstance(entries, list):
        reader.problem("cases", f"expected a list, got {_type_name(entries)}")
        entries = []
    ids: dict[int, str] = {}
    for index, entry in enumerate(entries):
        case = reader.case(entry, f"cases[{index}]", revision, ids)
        if case is not None:
            cases.append(case)
    _refuse(reader.problems, source)
    assert revision is not None and meta is not None
    return Document(revision, meta, tuple(cases))


def _refuse(problems: list[str], source: str) -> None:
    """Raise the error listing ``problems``, if there are any."""
    if problems:
        raise refusal(source, "a valid case base document", problems)


def refusal(source: str, expected: str, problems: list[str]) -> CaseBaseError:
    """The error refusing the document ``source`` for ``problems`` (at least one), each a line
    naming its place in the document; the first 20 are listed. ``expected`` says what the
    document is not: ``a valid case base document``."""
    listed = problems[:_MAX_LISTED]
    more = len(problems) - len(listed)
    lines = "\n".join(f"  - {p}" for p in listed) + (f"\n  ... and {more} more" if more else "")
    noun = "problem" if len(problems) == 1 else "problems"
    return CaseBaseError(f"{source}: not {expected}, {len(problems)} {noun}:\n{lines}")


class _Dumper(yaml.SafeDumper):
    """Writes shared objects out in full instead of as YAML anchors and aliases."""

    def ignore_aliases(self, data: Any) -> bool:
        return True


def _represent_str(dumper: yaml.SafeDumper, text: str) -> yaml.ScalarNode:
    # PyYAML writes a NEL (U+0085) into single-quoted or plain scalars as a bare line break,
    # which reads back as a space; double quotes escape it
    style = '"' if any(c in text for c in "\x85\u2028\u2029") else None
    return dumper.represent_scalar("tag:yaml.org,2002:str", text, style=style)


_Dumper.add_representer(str, _represent_str)


def dump_document(document: Document, format: Format = "yaml") -> str:
    """The document as YAML or JSON text."""
    data = document_to_data(document)
    if format == "json":
        # ASCII escapes keep strings that are not valid Unicode (lone surrogates) writable
        return json.dumps(data, indent=1, allow_nan=False) + "\n"
    # the pure-Python dumper escapes what libyaml's cannot encode (lone surrogates)
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100)


def parse_document(text: str, format: Format, source: str = "<text>") -> Document:
    """Parse and validate YAML or JSON text within the document limits
    (:mod:`cbrcore.documents`); ``source`` names it in error messages."""
    node = None
    try:
        if format == "json":
            data = load_json(text, source)
        else:
            node = compose_yaml(text, source)
            data = construct_yaml(node, source)
    except json.JSONDecodeError as exc:  # its text names the line and column, quoting nothing
        raise CaseBaseError(f"{source}: not valid JSON: {exc}") from exc
    except yaml.YAMLError as exc:
        raise CaseBaseError(f"{source}: not valid YAML: {yaml_problem(exc)}") from exc
    except DocumentError as exc:
        raise CaseBaseError(str(exc)) from None
    return document_from_data(data, source, node)


def format_of(path: str | os.PathLike[str]) -> Format:
    """The format a file's extension calls for."""
    suffix = Path(path).suffix.lower()
    if suffix not in _SUFFIXES:
        raise CaseBaseError(f"{path}: cannot tell the format from the extension {suffix!r}; "
                            "name the file .yaml, .yml or .json, or give the format")
    return _SUFFIXES[suffix]


def read_document(path: str | os.PathLike[str], format: Format | None = None) -> Document:
    """Read and validate an exported case base file (format from the extension by default)."""
    fmt = format or format_of(path)
    return parse_document(read_document_text(path), fmt, str(path))


def read_document_text(path: str | os.PathLike[str]) -> str:
    """The text of a case base document file, read within the document limits
    (:mod:`cbrcore.documents`); CaseBaseError when it cannot be read."""
    try:
        return read_text(path)
    except DocumentError as exc:
        raise CaseBaseError(str(exc)) from None
    except FileNotFoundError as exc:
        raise CaseBaseError(f"no such file: {path}") from exc
    except UnicodeDecodeError as exc:
        raise CaseBaseError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from exc
    except OSError as exc:
        raise CaseBaseError(f"cannot read {path}: {exc.strerror}") from exc


def write_document(document: Document, target: str | os.PathLike[str] | TextIO,
                   format: Format | None = None) -> None:
    """Write the document to a file or a text stream.

    A file's format comes from its extension unless given; a stream gets YAML unless told.
    """
    if not isinstance(target, str | os.PathLike):
        target.write(dump_document(document, format or "yaml"))
        return
    write_document_text(dump_document(document, format or format_of(target)), target)


def write_document_text(text: str, path: str | os.PathLike[str]) -> None:
    """Write a document's text to ``path`` whole; CaseBaseError when it cannot be written."""
    try:
        # a full disk or a kill leaves the earlier file, never a truncated one
        files.write_text(Path(path), text)
    except OSError as exc:
        raise CaseBaseError(f"cannot write {path}: {exc.strerror or exc}") from exc


def load_document(store: CaseStore, document: Document, *, append: bool = False,
                  worlds: Worlds = ONE) -> int:
    """Load the document into ``store`` in one transaction; return how many cases it added.

    Without ``append`` the store must hold no cases: it then becomes a copy of the document (ids,
    revision stamps, meta). With ``append`` the cases are added as new ones (new ids, ``created``
    is the import's revision, ``last_used`` is cleared since the document's revisions count
    another case base's transactions; ``uses`` is kept) and the store's meta is left alone but
    for the worlds the document records, which join the store's: with ``worlds`` ``one`` (the
    store's setting) a document of another world than the store's is refused
    (:class:`~cbrcore.casebase.worlds.OtherWorld`) and nothing is loaded.
    """
    with store.transaction():
        if append:
            joining, _ = parse_worlds(document.meta.get(WORLDS_KEY), WORLDS_KEY)
            join_worlds(store, joining, worlds, "the document's cases belong to")
            for case in document.cases:
                store.add(attrs.evolve(case, last_used=None))
        else:
            held = len(store)
            if held:
                raise CaseBaseError(f"{store} already holds {held} cases; refusing to import "
                                    "over them (append adds the cases with new ids)")
            store.restore(document.cases, document.meta, document.revision)
    return len(document.cases)


def export_casebase(store: CaseStore, target: str | os.PathLike[str] | TextIO,
                    format: Format | None = None) -> Document:
    """Write ``store`` to a file or stream (see :func:`write_document`); return what was written."""
    document = document_of(store)
    write_document(document, target, format)
    return document


def import_casebase(store: CaseStore, path: str | os.PathLike[str],
                    format: Format | None = None, *, append: bool = False,
                    worlds: Worlds = ONE) -> int:
    """Read an exported file and load it into ``store`` (see :func:`load_document`)."""
    return load_document(store, read_document(path, format), append=append, worlds=worlds)
