"""A case store in a PostgreSQL schema, shared by robots on several machines (psycopg 3)."""

from __future__ import annotations

import contextlib
import json
import operator
from collections.abc import Iterable, Iterator, Mapping
from typing import Any

import attrs
import psycopg
from psycopg import errors as pg_errors
from psycopg import pq

from cbrcore.casebase.conninfo import connection_label, fields, scrubbed
from cbrcore.casebase.data import (
    MAX_INTEGER,
    REVISION_KEY,
    case_problems,
    change_problems,
    check_case,
    check_meta,
    check_meta_key,
    check_since,
    removal_problems,
)
from cbrcore.casebase.postgres_schema import (
    SCHEMA_EXPECTED,
    SCHEMA_VERSION,
    open_schema,
    quoted,
    schema_name_problem,
    schema_problems,
    stored_version,
)
from cbrcore.casebase.store import Changes
from cbrcore.errors import CaseBaseError, CaseBaseLocked, UnusableCaseBase
from cbrcore.model import JSON, Case

MAX_ID = MAX_INTEGER
"""The largest case id: PostgreSQL's largest bigint."""

_COLUMNS = "id, kind, problem, solution, meta, uses, created, last_used"
_WRITTEN = f"{_COLUMNS}, changed"
"""The columns a write sets: a case's and the revision that last wrote it."""


def _dumps(value: JSON) -> str:
    # ASCII escapes keep every string storable (NUL, lone surrogates) in a database of any
    # encoding, and its text readable back exactly
    return json.dumps(value, allow_nan=False, separators=(",", ":"))


class PostgresStore:
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

    Every write records its revision: a case's ``changed`` column says which revision last
    added, replaced, touched or restored it, and the ``removed`` table which revision removed an
    id, so that :meth:`changes` finds what changed since a revision through their indexes.
    """

    def __init__(self, dsn: str = "", *, schema: str = "cbrcore", busy_timeout: float = 5.0,
                 create: bool = True, read_only: bool = False) -> None:
        problem = schema_name_problem(schema)
        if problem is not None:
            raise CaseBaseError(f"casebase schema: {problem}")
        self.schema = schema
        self.busy_timeout = busy_timeout
        self.read_only = read_only
        fields(dsn)  # a DSN libpq cannot read is refused before connecting
        self._label = connection_label(dsn, schema)
        self._depth = 0
        self._pending = 0
        self._last_id = 0
        self._wrote = False
        self._committed: int | None = None
        """What ``committed_revision`` says; None before the first transaction."""
        self._closed = False
        self._s = quoted(schema)
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

    def __enter__(self) -> PostgresStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- talking to PostgreSQL --------------------------------------------------------------

    def _translate(self, exc: psycopg.Error) -> CaseBaseError | None:
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

    @contextlib.contextmanager
    def _errors(self) -> Iterator[None]:
        try:
            yield
        except psycopg.Error as exc:
            translated = self._translate(exc)
            if translated is None:
                raise
            raise translated from exc

    def _rows(self, query: str, params: Iterable[Any] = ()) -> list[Any]:
        with self._errors():
            cursor = self._conn.execute(query, tuple(params))
            return cursor.fetchall() if cursor.description is not None else []

    def _run(self, query: str, params: Iterable[Any] = ()) -> int:
        """Run a statement; the number of rows it changed."""
        with self._errors():
            return self._conn.execute(query, tuple(params)).rowcount

    def _value(self, query: str, params: Iterable[Any] = ()) -> Any:
        rows = self._rows(query, params)
        return rows[0][0] if rows else None

    def _rollback(self) -> None:
        # the error that got us here says more than a failed rollback would; a lost connection
        # has rolled back on the server already
        with contextlib.suppress(psycopg.Error):
            if self._conn.info.transaction_status != pq.TransactionStatus.IDLE:
                self._conn.execute("ROLLBACK")

    def _writable(self) -> None:
        if self.read_only:
            raise CaseBaseError(f"{self} is open for reading only and cannot be written")

    # -- transactions -----------------------------------------------------------------------

    @property
    def revision(self) -> int:
        """The number of write transactions committed so far, by any process."""
        rows = self._rows(f"SELECT revision FROM {self._s}.clock")
        if len(rows) != 1:
            raise UnusableCaseBase(f"{self} is corrupt: its clock table should hold one row, "
                                   f"and holds {len(rows)}")
        return int(rows[0][0])

    @property
    def committed_revision(self) -> int:
        """The revision this store object's last outermost transaction committed at: its new
        revision if it wrote, else the revision it read with the clock row locked (``revision``
        before the first). Other processes' commits do not move it."""
        return self.revision if self._committed is None else self._committed

    @contextlib.contextmanager
    def transaction(self) -> Iterator[None]:
        """Group writes; commits on normal exit, rolls back if the block raises.

        The outermost block locks the case base for writing as it begins (another process's
        transaction waits for it to end), so the block reads what others committed and writes
        against that; a nested block is a savepoint, undone alone when it raises.
        """
        if self._depth:
            with self._savepoint():
                yield
            return
        if self.read_only:
            # a snapshot: every read of the block sees the case base as it was at its start
            self._run("BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY")
        else:
            self._run("BEGIN")
        try:
            lock = "" if self.read_only else " FOR UPDATE"
            rows = self._rows(f"SELECT revision, last_id FROM {self._s}.clock{lock}")
            if len(rows) != 1:
                raise UnusableCaseBase(f"{self} is corrupt: its clock table should hold one "
                                       f"row, and holds {len(rows)}")
            read, self._last_id = rows[0]
            self._pending = read + 1
            self._wrote = False
            self._depth = 1
            try:
                yield
            finally:
                self._depth = 0
            if self._wrote:
                if self._pending > MAX_ID:
                    raise CaseBaseError(f"{self} has reached the largest revision, {MAX_ID}: "
                                        f"it takes no more writes")
                self._run(f"UPDATE {self._s}.clock SET revision = %s, last_id = %s",
                          (self._pending, self._last_id))
            self._run("COMMIT")
            self._committed = self._pending if self._wrote else read
        except BaseException:
            self._rollback()
            raise

    @contextlib.contextmanager
    def _savepoint(self) -> Iterator[None]:
        name = f"cbr{self._depth}"
        saved = (self._pending, self._last_id, self._wrote)
        self._run(f"SAVEPOINT {name}")
        self._depth += 1
        try:
            yield
        except BaseException:
            with contextlib.suppress(psycopg.Error):
                self._conn.execute(f"ROLLBACK TO SAVEPOINT {name}")
                self._conn.execute(f"RELEASE SAVEPOINT {name}")
            self._pending, self._last_id, self._wrote = saved
            raise
        finally:
            self._depth -= 1
        self._run(f"RELEASE SAVEPOINT {name}")

    # -- cases ------------------------------------------------------------------------------

    def _row(self, case: Case) -> tuple[Any, ...]:
        """The written columns of ``case`` but its id, changed by the transaction under way."""
        return (_dumps(case.kind), _dumps(case.problem), _dumps(case.solution),
                _dumps(dict(case.meta)), case.uses, case.created, case.last_used, self._pending)

    def _case(self, row: tuple[Any, ...]) -> Case:
        case_id, kind, problem, solution, meta, uses, created, last_used = row
        try:
            decoded_kind = json.loads(kind)
            if not isinstance(decoded_kind, str):
                raise ValueError(f"kind {kind!r} is not a JSON string")
            return Case(json.loads(problem), json.loads(solution), decoded_kind,
                        json.loads(meta), case_id, uses, created, last_used)
        except (TypeError, ValueError) as exc:
            raise UnusableCaseBase(f"{self} is corrupt: case {case_id} cannot be decoded "
                                   f"({exc})") from exc

    def _new_id(self) -> int:
        if self._last_id >= MAX_ID:
            raise CaseBaseError(f"{self} has used every case id: ids are never reused, and the "
                                f"largest, {MAX_ID}, is taken")
        self._last_id += 1
        return self._last_id

    def add(self, case: Case) -> Case:
        """Store a new case; return it with its ``id`` and ``created`` set (given ones ignored).

        ``uses`` and ``last_used`` are kept.
        """
        self._writable()
        with self.transaction():
            stored = attrs.evolve(case, id=None, created=self._pending)
            check_case(stored, self._pending)
            stored = attrs.evolve(stored, id=self._new_id())
            self._run(f"INSERT INTO {self._s}.cases ({_WRITTEN}) "
                      f"VALUES (%s, %s, %s, %s, %s, %s, %s, %s, %s)",
                      (stored.id, *self._row(stored)))
            self._wrote = True
            return stored

    def replace(self, case: Case) -> None:
        """Overwrite the stored case with ``case.id``; KeyError if there is none.

        Every field is taken from ``case``, except that ``created`` stays when it is None.
        """
        case_id = operator.index(case.id)
        self._writable()
        with self.transaction():
            old = self.get(case_id)
            stored = case if case.created is not None else attrs.evolve(case, created=old.created)
            check_case(stored, self._pending)
            self._run(f"UPDATE {self._s}.cases SET kind = %s, problem = %s, solution = %s, "
                      f"meta = %s, uses = %s, created = %s, last_used = %s, changed = %s "
                      f"WHERE id = %s",
                      (*self._row(stored), case_id))
            self._wrote = True

    def remove(self, ids: Iterable[int]) -> None:
        """Delete the cases with these ids; KeyError if one is missing (then none is deleted)."""
        unique = list(dict.fromkeys(operator.index(i) for i in ids))
        if unique:
            self._writable()
            with self.transaction():
                self._require(unique)
                self._run(f"DELETE FROM {self._s}.cases WHERE id = ANY(%s::bigint[])", (unique,))
                # an id restored after its removal may be removed again
                self._run(f"INSERT INTO {self._s}.removed (id, revision) "
                          f"SELECT unnest(%s::bigint[]), %s ON CONFLICT (id) "
                          f"DO UPDATE SET revision = EXCLUDED.revision", (unique, self._pending))
                self._wrote = True

    def touch(self, ids: Iterable[int]) -> None:
        """Count one more use of each case (once per distinct id) and stamp its ``last_used``.

        The stamp is the revision the write commits as. KeyError if an id is missing.
        """
        unique = list(dict.fromkeys(operator.index(i) for i in ids))
        if unique:
            self._writable()
            with self.transaction():
                self._require(unique)
                self._run(f"UPDATE {self._s}.cases SET uses = uses + 1, last_used = %s, "
                          f"changed = %s WHERE id = ANY(%s::bigint[])",
                          (self._pending, self._pending, unique))
                self._wrote = True

    def _require(self, ids: list[int]) -> None:
        """Raise KeyError for the first of ``ids`` that is not stored."""
        # an id beyond bigint's range is stored nowhere, and PostgreSQL would refuse to compare
        wanted = [i for i in ids if -MAX_ID - 1 <= i <= MAX_ID]
        found = {row[0] for row in self._rows(
            f"SELECT id FROM {self._s}.cases WHERE id = ANY(%s::bigint[])", (wanted,))}
        for case_id in ids:
            if case_id not in found:
                raise KeyError(case_id)

    def get(self, case_id: int) -> Case:
        """The case with this id; KeyError if there is none."""
        case_id = operator.index(case_id)
        if not -MAX_ID - 1 <= case_id <= MAX_ID:
            raise KeyError(case_id)
        rows = self._rows(f"SELECT {_COLUMNS} FROM {self._s}.cases WHERE id = %s", (case_id,))
        if not rows:
            raise KeyError(case_id)
        return self._case(rows[0])

    def changes(self, since: int) -> Changes:
        """What the commits after revision ``since`` changed (:class:`Changes`): the cases
        whose ``changed`` revision is later and the removed ids recorded later, both found
        through an index, in one snapshot."""
        since = operator.index(since)
        with self._snapshot():
            revision = self.revision
            check_since(since, revision)
            # sorted here, as by the SQLite store: the few changed rows come through the index
            # whatever the planner's statistics say of the order by id
            rows = sorted(self._rows(f"SELECT {_COLUMNS} FROM {self._s}.cases "
                                     f"WHERE changed > %s", (since,)))
            removed = sorted(row[0] for row in self._rows(
                f"SELECT id FROM {self._s}.removed WHERE revision > %s", (since,)))
        return Changes(since, revision, tuple(self._case(row) for row in rows), tuple(removed))

    @contextlib.contextmanager
    def _snapshot(self) -> Iterator[None]:
        """Reads that see one state of the case base: the transaction under way, or a
        read-only snapshot transaction of their own, which takes no lock (the clock row's lock
        is the write lock, and a process catching up must not wait for the writers)."""
        if self._depth:
            yield
            return
        self._run("BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY")
        try:
            yield
        finally:
            self._rollback()

    def cases(self, kind: str | None = None) -> list[Case]:
        """All cases (of one kind when given), ordered by id."""
        if kind is None:
            rows = self._rows(f"SELECT {_COLUMNS} FROM {self._s}.cases ORDER BY id")
        else:
            rows = self._rows(f"SELECT {_COLUMNS} FROM {self._s}.cases WHERE kind = %s "
                              f"ORDER BY id", (_dumps(kind),))
        return [self._case(row) for row in rows]

    def count(self, kind: str | None = None) -> int:
        """How many cases (of one kind when given) are stored."""
        if kind is None:
            return int(self._value(f"SELECT count(*) FROM {self._s}.cases"))
        return int(self._value(f"SELECT count(*) FROM {self._s}.cases WHERE kind = %s",
                               (_dumps(kind),)))

    def kind_counts(self) -> dict[str, int]:
        """How many cases of each kind are stored, by kind."""
        rows = self._rows(f"SELECT kind, count(*) FROM {self._s}.cases GROUP BY kind")
        return dict(sorted((self._text(kind, "kind"), int(n)) for kind, n in rows))

    def _text(self, stored: str, what: str) -> str:
        """A kind or meta key, stored as a JSON string."""
        try:
            text = json.loads(stored)
        except ValueError:
            text = None
        if not isinstance(text, str):
            raise UnusableCaseBase(f"{self} is corrupt: {what} {stored!r} is not a JSON string")
        return text

    # -- meta -------------------------------------------------------------------------------

    def get_meta(self, key: str, default: JSON = None) -> JSON:
        """A plugin's stored value (plain JSON data) under ``key``."""
        check_meta_key(key)
        text = self._value(f"SELECT value FROM {self._s}.meta WHERE key = %s", (_dumps(key),))
        return default if text is None else self._meta_value(key, text)

    def _meta_value(self, key: str, text: str) -> JSON:
        try:
            return json.loads(text)
        except (TypeError, ValueError) as exc:
            raise UnusableCaseBase(f"{self} is corrupt: meta key {key!r} cannot be decoded "
                                   f"({exc})") from exc

    def set_meta(self, key: str, value: JSON) -> None:
        """Store a plugin's value under ``key``; it commits with the surrounding transaction."""
        check_meta(key, value)
        self._writable()
        with self.transaction():
            self._run(f"INSERT INTO {self._s}.meta (key, value) VALUES (%s, %s) "
                      f"ON CONFLICT (key) DO UPDATE SET value = EXCLUDED.value",
                      (_dumps(key), _dumps(value)))
            self._wrote = True

    def meta_items(self) -> dict[str, JSON]:
        """Every plugin meta value, by key."""
        rows = self._rows(f"SELECT key, value FROM {self._s}.meta")
        keyed = sorted((self._text(key, "meta key"), text) for key, text in rows)
        return {key: self._meta_value(key, text) for key, text in keyed}

    def restore(self, cases: Iterable[Case], meta: Mapping[str, JSON], revision: int) -> None:
        """Fill this store, which holds no cases, with ``cases`` keeping their ids and stamps.

        Cases without an id get new ones, cases without ``created`` the restoring transaction's
        revision. The store's meta is replaced by ``meta``, and the transaction commits as
        ``revision`` when that is ahead of the store's own clock.
        """
        self._writable()
        with self.transaction():
            if self.count():
                raise ValueError("restore needs a store without cases")
            if revision >= self._pending:
                # moving the clock forward is a write even when nothing else changes
                self._pending = revision
                self._wrote = True
            cases = list(cases)
            given = [operator.index(c.id) for c in cases if c.id is not None]
            seen: set[int] = set()
            for case_id in given:
                if case_id in seen:
                    raise ValueError(f"restore got two cases with id {case_id}")
                if not 1 <= case_id <= MAX_ID:
                    raise ValueError(f"restore got case id {case_id}; ids are from 1 to {MAX_ID}")
                seen.add(case_id)
            # the ids handed out come after every given one, as in the other stores
            self._last_id = max([self._last_id, *given])
            for case in cases:
                stored = case if case.created is not None else attrs.evolve(
                    case, created=self._pending)
                check_case(stored, self._pending)
                case_id = self._new_id() if case.id is None else operator.index(case.id)
                self._run(f"INSERT INTO {self._s}.cases ({_WRITTEN}) "
                          f"VALUES (%s, %s, %s, %s, %s, %s, %s, %s, %s)",
                          (case_id, *self._row(stored)))
                self._wrote = True
            if self._run(f"DELETE FROM {self._s}.meta"):
                self._wrote = True
            for key, value in meta.items():
                self.set_meta(key, value)

    # -- inspection -------------------------------------------------------------------------

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
            "WHERE n.nspname = %s AND c.relkind = 'r'", (self.schema,))
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

    def check(self) -> list[str]:
        """Problems found by a full consistency check; empty when the store is sound.

        Checks the schema's tables, the clock and the schema version, and every case and meta
        value: JSON that decodes, sensible use counts, revision stamps no later than the
        revision, no id beyond the largest one given (a new case would take it again), each
        case's ``changed`` revision from its creation or last use to the revision, and each
        removal's revision no later than the revision.
        """
        problems: list[str] = []
        try:
            with self._errors():
                schema = schema_problems(self._conn, self.schema)
            if schema:
                # found when the case base was opened, unless another program changed it since
                return [f"schema: {p}" for p in schema]
            versions = self._rows(f"SELECT version FROM {self._s}.schema_version")
            if versions != [(SCHEMA_VERSION,)]:
                problems.append(f"schema version: expected one row holding {SCHEMA_VERSION}, "
                                f"found {[row[0] for row in versions]}")
            rows = self._rows(f"SELECT {_WRITTEN} FROM {self._s}.cases ORDER BY id")
            removed = self._rows(f"SELECT id, revision FROM {self._s}.removed ORDER BY id")
            meta = self._rows(f"SELECT key, value FROM {self._s}.meta ORDER BY key")
            # read after the cases: the revision only grows, so a sound case is never after it
            clock = self._rows(f"SELECT revision, last_id FROM {self._s}.clock")
        except CaseBaseError as exc:
            return [*problems, str(exc)]
        bound: int | None = None
        if len(clock) != 1:
            problems.append(f"clock: expected one row, found {len(clock)}")
        else:
            revision, last_id = clock[0]
            if not 0 <= revision <= MAX_ID:
                problems.append(f"revision: expected an integer from 0 to {MAX_ID}, "
                                f"got {revision}")
            else:
                bound = self._pending if self._depth else revision
            largest = rows[-1][0] if rows else 0
            if self._depth:
                # the ids given by the transaction under way are recorded when it commits
                last_id = self._last_id
            if last_id < largest:
                problems.append(f"ids: case {largest} is beyond the largest id recorded as "
                                f"given, {last_id}: new cases would take ids again")
        for row in rows:
            problems += self._row_problems(row, bound)
        problems += removal_problems(removed, bound)
        for key, text in meta:
            try:
                shown = self._text(key, "meta key")
            except UnusableCaseBase as exc:
                problems.append(str(exc).removeprefix(f"{self} is corrupt: "))
                continue
            if shown == REVISION_KEY:
                problems.append(f"meta key {shown!r}: reserved for the revision")
            try:
                json.loads(text)
            except (TypeError, ValueError) as exc:
                problems.append(f"meta key {shown!r}: not valid JSON ({exc})")
        return problems

    def _row_problems(self, row: tuple[Any, ...], revision: int | None) -> list[str]:
        case_id, kind, problem, solution, meta, uses, created, last_used, changed = row
        problems = []
        decoded = {}
        for field, text in (("kind", kind), ("problem", problem), ("solution", solution),
                            ("meta", meta)):
            try:
                decoded[field] = json.loads(text)
            except (TypeError, ValueError) as exc:
                problems.append(f"case {case_id}: {field}: not valid JSON ({exc})")
        if len(decoded) < 4:
            return problems
        case = Case(decoded["problem"], decoded["solution"], decoded["kind"], decoded["meta"],
                    case_id, uses, created, last_used)
        problems += [f"case {case_id}: {p}" for p in case_problems(case, revision)]
        return problems + change_problems(case_id, created, last_used, changed, revision)

    def close(self) -> None:
        """Close the connection, rolling back a transaction left open; safe to call twice."""
        self._closed = True
        self._conn.close()

    def __iter__(self) -> Iterator[Case]:
        return iter(self.cases())

    def __len__(self) -> int:
        return self.count()
