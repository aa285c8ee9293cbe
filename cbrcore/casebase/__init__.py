"""Case bases: the store protocol, the memory store, and plain-text export/import (the SQL
stores are the ``stores`` plugin's, :mod:`cbr_stores`)."""

from __future__ import annotations

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
from cbrcore.casebase.store import SUMMARY_KEYS, CaseStore, Changes, describe
from cbrcore.errors import UnusableCaseBase

__all__ = [
    "SUMMARY_KEYS",
    "CaseStore",
    "Changes",
    "Document",
    "MemoryStore",
    "UnusableCaseBase",
    "describe",
    "document_of",
    "dump_document",
    "export_casebase",
    "format_of",
    "import_casebase",
    "load_document",
    "parse_document",
    "read_document",
    "write_document",
]
