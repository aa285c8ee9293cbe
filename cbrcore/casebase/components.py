"""The case base stores that a configuration's ``casebase`` slot builds: memory, SQLite,
PostgreSQL.

The ``core`` plugin (:mod:`cbrcore.builtins`) registers them by name: their options and
factories import the stores, the exchange format and NumPy, which load when a configuration
names a store.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import attrs

from cbrcore.casebase import MemoryStore, SQLiteStore
from cbrcore.casebase.conninfo import masked_dsn
from cbrcore.casebase.formats import read_casebase
from cbrcore.casebase.postgres_schema import schema_name_problem
from cbrcore.casebase.store import CaseStore
from cbrcore.casebase.worlds import ONE, WORLDS_DOC, WORLDS_VALIDATOR, Worlds
from cbrcore.context import Context
from cbrcore.errors import CaseBaseError, ConfigError
from cbrcore.options import OutputPath, in_run_folder, option

if TYPE_CHECKING:
    from cbrcore.casebase.postgres import PostgresStore

S = TypeVar("S", bound=CaseStore)

_INITIAL_DOC = ("Hand-made cases to start from, loaded into the case base when it is new, never "
                "into one that has held cases: a file of 'cbr casebase export' in any format it "
                "writes, told by its extension (YAML, JSON, or a plugin's, such as a Nav2 route "
                "graph .geojson read on the run's world); relative to the configuration file.")


def _started(store: S, initial: Path | None, ctx: Context) -> S:
    """``store``, holding the cases of ``initial`` if it is new; a format that needs the world
    reads them on the run's."""
    if initial is None:
        return store
    document = read_casebase(initial, world=ctx.world)
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
    worlds: Worlds = option(ONE, WORLDS_DOC, validator=WORLDS_VALIDATOR)


def _schema_name(instance: Any, attribute: attrs.Attribute, value: str) -> None:
    problem = schema_name_problem(value)
    if problem is not None:
        # the wording of attrs' own validators, which names the option in the problem's path
        raise ValueError(f"'{attribute.name}' must name a PostgreSQL schema: {problem}")


@attrs.frozen
class PostgresOptions:
    """Options of the ``postgres`` store."""

    dsn: str = option(
        "",
        "The database: a libpq connection string ('host=db dbname=cases user=robot') or URI "
        "('postgresql://robot@db/cases'). Empty: the standard PG* environment variables "
        "(PGHOST, PGPORT, PGUSER, PGDATABASE, PGPASSWORD, ...) say where to connect. "
        "Manifests show only its host, port, database and user; errors show none of its values.",
        shown=masked_dsn,
    )
    schema: str = option(
        "cbrcore",
        "The PostgreSQL schema holding the case base's tables: case bases in different schemas "
        "share a database without meeting.",
        validator=_schema_name,
    )
    busy_timeout: float = option(
        5.0,
        "Seconds to wait for another process's write lock before giving up.",
        validator=attrs.validators.ge(0),
    )
    create: bool = option(True, "Create the case base (its schema and tables) when it is "
                                "missing; false refuses a missing case base instead.")
    read_only: bool = option(False, "Open an existing case base for reading alone, also with a "
                                    "database role that may only read it; a write is an error.")
    initial: Path | None = option(None, _INITIAL_DOC)
    worlds: Worlds = option(ONE, WORLDS_DOC, validator=WORLDS_VALIDATOR)


@attrs.frozen
class MemoryOptions:
    """Options of the ``memory`` store."""

    initial: Path | None = option(None, _INITIAL_DOC)
    worlds: Worlds = option(ONE, WORLDS_DOC, validator=WORLDS_VALIDATOR)


def memory_store(options: MemoryOptions, ctx: Context) -> MemoryStore:
    """An in-memory case base: fast, and gone when the run ends.

    Behaves like the sqlite store (transactions, revisions, JSON-only contents) without a file,
    so it suits tests, benchmarks and runs that start from an empty case base every time (or
    from the same hand-made cases: ``initial``).
    """
    return _started(MemoryStore(), options.initial, ctx)


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
    return store if options.read_only else _started(store, options.initial, ctx)


def postgres_store(options: PostgresOptions, ctx: Context) -> PostgresStore:
    """A case base in a PostgreSQL database, shared by robots on several machines.

    The case base lives in one schema of the database, created with its tables when missing
    (unless told not to or opened read-only) and migrated when an older cbrcore made it. One
    that is not a cbrcore case base, or of a newer schema version, is refused and left
    untouched. Needs psycopg (the ``postgres`` extra).
    """
    try:
        from cbrcore.casebase.postgres import PostgresStore
    except ImportError as exc:
        raise CaseBaseError(f"the postgres store needs psycopg, which cannot be imported "
                            f"({exc}): pip install 'cbrcore[postgres]'") from exc
    store = PostgresStore(options.dsn, schema=options.schema,
                          busy_timeout=options.busy_timeout, create=options.create,
                          read_only=options.read_only)
    return store if options.read_only else _started(store, options.initial, ctx)
