"""The components cbrcore itself supplies: the case base stores."""

from __future__ import annotations

from pathlib import Path
from typing import TypeVar

import attrs

from cbrcore.casebase import MemoryStore, SQLiteStore
from cbrcore.casebase.exchange import read_document
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.errors import ConfigError
from cbrcore.hookspecs import hookimpl
from cbrcore.options import OutputPath, in_run_folder, option
from cbrcore.registry import Registry

S = TypeVar("S", bound=CaseStore)

_INITIAL_DOC = ("Hand-made cases to start from: an exported case base (YAML or JSON, the format "
                "of 'cbr casebase export'; relative to the configuration file) loaded into the "
                "case base when it is new, never into one that has held cases.")


def _started(store: S, initial: Path | None) -> S:
    """``store``, holding the cases of ``initial`` if it is new."""
    if initial is None:
        return store
    document = read_document(initial)
    # checked under the write lock: two processes creating one case base load it once
    with store.transaction():
        if store.revision == 0 and len(store) == 0:
            store.restore(document.cases, document.meta, document.revision)
    return store


@attrs.frozen
class SQLiteOptions:
    """Options of the ``sqlite`` store."""

    path: OutputPath | None = option(
        None,
        "Case base file: an absolute path, or a file inside the run's output folder. "
        "Default: casebase.sqlite in the run's output folder.",
    )
    busy_timeout: float = option(
        5.0,
        "Seconds to wait for another process's write lock before giving up.",
        validator=attrs.validators.ge(0),
    )
    create: bool = option(True, "Create the case base file when it is missing; false refuses a "
                                "missing file instead.")
    read_only: bool = option(False, "Open an existing case base for reading alone, also in a "
                                    "folder that may not be written; a write is an error.")
    initial: Path | None = option(None, _INITIAL_DOC)


@attrs.frozen
class MemoryOptions:
    """Options of the ``memory`` store."""

    initial: Path | None = option(None, _INITIAL_DOC)


def memory_store(options: MemoryOptions, ctx: Context) -> MemoryStore:
    """An in-memory case base: fast, and gone when the run ends.

    Behaves like the sqlite store (transactions, revisions, JSON-only contents) without a file,
    so it suits tests, benchmarks and runs that start from an empty case base every time (or
    from the same hand-made cases: ``initial``).
    """
    return _started(MemoryStore(), options.initial)


def sqlite_store(options: SQLiteOptions, ctx: Context) -> SQLiteStore:
    """A case base in a SQLite file: survives crashes and can be shared by processes.

    The file is created when missing, unless told not to or opened read-only. One that is not a
    cbrcore case base, is corrupt, has another schema version or a schema a case base does not
    have is refused and left untouched.
    """
    path = (None if options.path is None
            else in_run_folder(options.path, ctx.out_dir, ctx.config_dir))
    if path is None:
        if ctx.out_dir is None:
            raise ConfigError("casebase.path",
                              ["casebase.path: required when the run has no output folder to "
                               "keep the case base in"])
        path = ctx.out_dir / "casebase.sqlite"
    store = SQLiteStore(path, busy_timeout=options.busy_timeout, create=options.create,
                        read_only=options.read_only)
    return store if options.read_only else _started(store, options.initial)


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("store", "memory", memory_store, options=MemoryOptions)
    registry.add("store", "sqlite", sqlite_store, options=SQLiteOptions)
