"""The options and factories of the ``sqlite`` and ``postgres`` stores, which the plugin
registers by name: they load when a configuration names one of the stores."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import attrs

from cbr_stores.conninfo import masked_dsn
from cbr_stores.postgres_schema import schema_name_problem
from cbr_stores.sqlite import SQLiteStore
from cbrcore.casebase.components import INITIAL_DOC, started
from cbrcore.casebase.store import StoreCapabilities, StoreFile
from cbrcore.casebase.worlds import ONE, WORLDS_DOC, WORLDS_VALIDATOR, Worlds
from cbrcore.context import Context
from cbrcore.errors import CaseBaseError, ConfigError
from cbrcore.options import OutputPath, in_run_folder, option

if TYPE_CHECKING:
    from cbr_stores.postgres import PostgresStore

SQLITE_FILE = StoreFile("casebase.sqlite", ("-wal", "-shm", "-journal"))
"""The case base file of the ``sqlite`` store, and the files SQLite keeps beside it while it is
open or after a crash."""

@attrs.frozen
class SQLiteOptions:
    """Options of the ``sqlite`` store."""

    CAPABILITIES: ClassVar[StoreCapabilities] = StoreCapabilities(
        file=SQLITE_FILE, read_only=True)

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
    initial: Path | None = option(None, INITIAL_DOC)
    worlds: Worlds = option(ONE, WORLDS_DOC, validator=WORLDS_VALIDATOR)


def _schema_name(instance: Any, attribute: attrs.Attribute, value: str) -> None:
    problem = schema_name_problem(value)
    if problem is not None:
        # the wording of attrs' own validators, which names the option in the problem's path
        raise ValueError(f"'{attribute.name}' must name a PostgreSQL schema: {problem}")


@attrs.frozen
class PostgresOptions:
    """Options of the ``postgres`` store."""

    CAPABILITIES: ClassVar[StoreCapabilities] = StoreCapabilities(read_only=True)

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
    initial: Path | None = option(None, INITIAL_DOC)
    worlds: Worlds = option(ONE, WORLDS_DOC, validator=WORLDS_VALIDATOR)


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
        path = ctx.out_dir / SQLITE_FILE.default_name
    store = SQLiteStore(path, busy_timeout=options.busy_timeout, create=options.create,
                        read_only=options.read_only)
    return store if options.read_only else started(store, options.initial, ctx)


def postgres_store(options: PostgresOptions, ctx: Context) -> PostgresStore:
    """A case base in a PostgreSQL database, shared by robots on several machines.

    The case base lives in one schema of the database, created with its tables when missing
    (unless told not to or opened read-only) and migrated when an older cbrcore made it. One
    that is not a cbrcore case base, or of a newer schema version, is refused and left
    untouched. Needs psycopg (the ``postgres`` extra).
    """
    try:
        from cbr_stores.postgres import PostgresStore
    except ImportError as exc:
        raise CaseBaseError(f"the postgres store needs psycopg, which cannot be imported "
                            f"({exc}): pip install 'cbrcore[postgres]'") from exc
    store = PostgresStore(options.dsn, schema=options.schema,
                          busy_timeout=options.busy_timeout, create=options.create,
                          read_only=options.read_only)
    return store if options.read_only else started(store, options.initial, ctx)
