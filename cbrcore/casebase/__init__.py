"""Case bases: the store protocol, the memory and SQLite stores, and plain-text export/import."""

from __future__ import annotations

import os

from cbrcore.casebase.exchange import (
    Document,
    document_of,
    dump_document,
    export_casebase,
    format_of,
    import_casebase,
    load_document,
    parse_document,
    read_document,
    write_document,
)
from cbrcore.casebase.memory import MemoryStore
from cbrcore.casebase.sqlite import SQLiteStore
from cbrcore.casebase.sqlite_file import APPLICATION_ID, SCHEMA_VERSION
from cbrcore.casebase.store import SUMMARY_KEYS, CaseStore, Changes, describe
from cbrcore.errors import UnusableCaseBase


def open_store(path: str | os.PathLike[str] | None = None, *, create: bool = True,
               busy_timeout: float = 5.0) -> MemoryStore | SQLiteStore:
    """A new :class:`MemoryStore` when ``path`` is None, else the SQLite case base at ``path``."""
    if path is None:
        return MemoryStore()
    return SQLiteStore(path, busy_timeout=busy_timeout, create=create)


__all__ = [
    "APPLICATION_ID",
    "SCHEMA_VERSION",
    "SUMMARY_KEYS",
    "CaseStore",
    "Changes",
    "Document",
    "MemoryStore",
    "SQLiteStore",
    "UnusableCaseBase",
    "describe",
    "document_of",
    "dump_document",
    "export_casebase",
    "format_of",
    "import_casebase",
    "load_document",
    "open_store",
    "parse_document",
    "read_document",
    "write_document",
]
