"""A case store in a PostgreSQL schema, shared by robots on several machines (psycopg 3)."""

from __future__ import annotations

from typing import Any

import psycopg
from psycopg import errors as pg_errors
from psycopg import pq

from cbr_stores.conninfo import connection_label, fields, scrubbed
from cbr_stores.postgres_schema import (
    SCHEMA_EXPECTED,
    SCHEMA_VERSION,
    open_schema,
    quoted,
    schema_name_problem,
    stored_version,
)
from cbr_stores.postgres_schema import schema_problems as postgres_schema_problems
from cbr_stores.sql import MAX_ID, SQLStore
from cbrcore.errors import CaseBaseError, CaseBaseLocked, UnusableCaseBase
from cbrcore.model import JSON, Case


class PostgresStore(SQLStore):
    """A case base in a schema of a PostgreSQL database.

    ``dsn`` is a libpq connection string or URI; an empty one connects where the standard
    environment variables (``PGHOST``, ``PGPORT``, ``PGUSER``, ``PGDATABASE``, ``PGPASSWORD``,
    ...) say. ``schema`` names the PostgreSQL schema holding the case base's tables, so several
    case bases can share one database. A missing case base is created unless ``create`` is
    false; one of an older schema version is migrated, in one transaction; anything else that
    is not a sound cbrcore case base of this version is refused with
    :class:`~cbrcore.errors.UnusableCaseBase` and left as it is.

    Every transaction starts by locking the one row of the ``clock`` table, which holds the
    revision: writers from every machine take turns, waiting up to ``busy_timeout`` seconds
    before giving up with a CaseBaseError, and a learn step reads what others committed before it
    writes. Readers never wait, and see a transaction's writes all at once or not at all. Ids
    come from the same row (the largest id ever given), not from a sequence: a sequence would
    skip the ids of a rolled-back transaction, which the other stores reuse.

    ``read_only`` opens an existing case base for reading alone (a write raises CaseBaseError),
    also with a database role that may only read it; then a transaction is a consistent snapshot
    that takes no lock.

    Kinds and meta keys are stored as JSON strings, as every other text column is JSON text
    (see :mod:`cbr_stores.postgres_schema`).
    """

    DATABASE = "PostgreSQL"
    DRIVER_ERROR = psycopg.Error
    JSON_NAMES = True
    # a snapshot: every read of the block sees the case base as it was at its start
    SNAPSHOT = "BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY"

    def __init__(self, dsn: str = "", *, schema: str = "cbrcore", busy_timeout: float = 5.0,
                 create: bool = True, read_only: bool = False) -> None:
        problem = schema_name_problem(schema)
        if problem is not None:
            raise CaseBaseError(f"casebase schema: {problem}")
        super().__init__(busy_timeout=busy_timeout, read_only=read_only)
        self.schema = schema
        fields(dsn)  # a DSN libpq cannot read is refused before connecting
        self._label = connection_label(dsn, schema)
        self._last_id = 0
        """The largest id given, as the transaction under way has moved it."""
        self._ns = quoted(schema) + "."
        try:
            self._conn = psycopg.connect(dsn, autocommit=True,
                                         fallback_application_name="cbrcore")
        except psycopg.Error as exc:
            raise CaseBaseError(f"cannot connect to {self._label}: "
                                f"{scrubbed(str(exc), dsn)}") from None
        try:
            info = self._conn.info
            self._label = (f"schema {schema} of database {info.dbname} on "
                           f"{info.host}:{info.port}")
            with self._errors():
                # PostgreSQL's lock_timeout of 0 waits for ever: the shortest wait it knows
                # comes closest to giving up at once
                self._conn.execute("SELECT set_config('lock_timeout', %s, false)",
                                   (f"{max(1, round(busy_timeout * 1000))}ms",))
                if read_only:
                    self._conn.execute(
                        "SELECT set_config('default_transaction_read_only', 'on', false)")
                open_schema(self._conn, schema, self._label, create=create and not read_only,
                            migrate=not read_only)
        except BaseException:
            self._conn.close()
            raise

    def __str__(self) -> str:
        return self._label

    def __repr__(self) -> str:
        return f"PostgresStore({self._label!r})"

    def _translate(self, exc: Exception) -> CaseBaseError | None:
        """The CaseBaseError for a problem with the case base or the server; None for a bug."""
        if isinstance(exc, pg_errors.LockNotAvailable):
            return CaseBaseLocked(f"{self} is locked by another process (gave up after waiting "
                                 f"{self.busy_timeout:g} s for it)")
        if isinstance(exc, pg_errors.ReadOnlySqlTransaction):
            return CaseBaseError(f"{self} is open for reading only and cannot be written")
        if isinstance(exc, pg_errors.InsufficientPrivilege):
            return CaseBaseError(f"{self}: {str(exc).strip()} (see 'PostgreSQL' in the case base "
                                 f"documentation for the rights a store needs)")
        if isinstance(exc, pg_errors.UndefinedTable | pg_errors.UndefinedColumn):
            # the schema was checked when the store opened it; another program changed it since
            return UnusableCaseBase(f"{self} is not a sound case base: {str(exc).strip()} "
                                    f"({SCHEMA_EXPECTED})")
        if isinstance(exc, psycopg.OperationalError | psycopg.InterfaceError):
            if self._closed:
                return CaseBaseError(f"{self} was closed")
            return CaseBaseError(f"{self}: {str(exc).strip()}")
        return None

    # -- the dialect ------------------------------------------------------------------------

    def _execute(self, sql: str, params: tuple[Any, ...]) -> psycopg.Cursor[Any]:
        # psycopg's placeholders are %s, and a literal % is written %%
        return self._conn.execute(sql.replace("%", "%%").replace("?", "%s"), params)

    def _in_transaction(self) -> bool:
        return bool(self._conn.info.transaction_status != pq.TransactionStatus.IDLE)

    @property
    def revision(self) -> int:
        """The number of write transactions committed so far, by any process."""
        return self._clock("")[0]

    def _clock(self, lock: str) -> tuple[int, int]:
        """The revision and the largest id given, from the one row of the clock table."""
        rows = self._rows(f"SELECT revision, last_id FROM {self._ns}clock{lock}")
        if len(rows) != 1:
            raise UnusableCaseBase(f"{self} is corrupt: its clock table should hold one row, "
                                   f"and holds {len(rows)}")
        return int(rows[0][0]), int(rows[0][1])

    def _begin(self) -> None:
        self._run(self.SNAPSHOT if self.read_only else "BEGIN")

    def _read_clock(self) -> int:
        # locking the clock row is the write lock: writers from every machine take turns
        read, self._last_id = self._clock("" if self.read_only else " FOR UPDATE")
        return read

    def _write_clock(self) -> None:
        self._run(f"UPDATE {self._ns}clock SET revision = ?, last_id = ?",
                  (self._pending, self._last_id))

    def _savepoint_state(self) -> tuple[Any, ...]:
        return (self._last_id,)

    def _restore_savepoint_state(self, state: tuple[Any, ...]) -> None:
        (self._last_id,) = state

    def _insert(self, case_id: int | None, case: Case) -> int:
        if case_id is None:
            if self._last_id >= MAX_ID:
                raise self._no_id_left()
            self._last_id += 1
            case_id = self._last_id
        self._insert_row(case_id, case)
        return case_id

    def _restore_order(self, cases: list[Case]) -> list[Case]:
        # the ids handed out come after every given one, as in the other stores
        self._last_id = max([self._last_id, *(int(c.id) for c in cases if c.id is not None)])
        return cases

    def _structure_problems(self, problems: list[str]) -> bool:
        """The schema's tables and its version."""
        with self._errors():
            schema = postgres_schema_problems(self._conn, self.schema)
        if schema:
            # found when the case base was opened, unless another program changed it since
            problems += [f"schema: {p}" for p in schema]
            return False
        versions = self._rows(f"SELECT version FROM {self._ns}schema_version")
        if versions != [(SCHEMA_VERSION,)]:
            problems.append(f"schema version: expected one row holding {SCHEMA_VERSION}, "
                            f"found {[row[0] for row in versions]}")
        return True

    def _clock_problems(self, problems: list[str], largest_id: int) -> int | None:
        """The clock's one row, its revision, and no id beyond the largest one given (a new
        case would take it again)."""
        clock = self._rows(f"SELECT revision, last_id FROM {self._ns}clock")
        if len(clock) != 1:
            problems.append(f"clock: expected one row, found {len(clock)}")
            return None
        bound: int | None = None
        revision, last_id = clock[0]
        if not 0 <= revision <= MAX_ID:
            problems.append(f"revision: expected an integer from 0 to {MAX_ID}, got {revision}")
        else:
            bound = self._pending if self._depth else revision
        if self._depth:
            # the ids given by the transaction under way are recorded when it commits
            last_id = self._last_id
        if last_id < largest_id:
            problems.append(f"ids: case {largest_id} is beyond the largest id recorded as "
                            f"given, {last_id}: new cases would take ids again")
        return bound

    @property
    def schema_version(self) -> int:
        """The schema version recorded in the case base."""
        with self._errors():
            return stored_version(self._conn, self.schema, self._label)

    def describe(self) -> dict[str, JSON]:
        """The server, database, user and schema, the schema version, the server's version and
        the size of the case base's tables."""
        info = self._conn.info
        version = info.server_version
        size = self._value(
            "SELECT coalesce(sum(pg_total_relation_size(c.oid)), 0) FROM pg_catalog.pg_class c "
            "JOIN pg_catalog.pg_namespace n ON n.oid = c.relnamespace "
            "WHERE n.nspname = ? AND c.relkind = 'r'", (self.schema,))
        return {
            "host": info.host,
            "port": info.port,
            "database": info.dbname,
            "user": info.user,
            "schema": self.schema,
            "schema_version": self.schema_version,
            "server_version": f"{version // 10000}.{version % 10000}",
            "size_bytes": int(size),
        }
