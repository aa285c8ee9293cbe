"""What the SQL case base stores share: transactions, savepoints, the revision clock, the cases
and meta statements, ``changes()`` and ``check()``.

A store is a :class:`SQLStore` and a dialect: the subclass connects, locks, keeps the revision
clock where its schema keeps it, hands out new ids, and runs a statement on its driver. The
statements here use ``?`` placeholders and the upsert syntax (``ON CONFLICT ... DO UPDATE``)
that SQLite (3.24 and later) and PostgreSQL both read; a dialect whose driver wants other
placeholders rewrites them in :meth:`SQLStore._execute`.

Every write records its revision: a case's ``changed`` column says which revision last added,
replaced, touched or restored it, and the ``removed`` table which revision removed an id, so
that :meth:`SQLStore.changes` finds what changed since a revision through their indexes.
"""

from __future__ import annotations

import contextlib
import json
import operator
import sys
from abc import ABC, abstractmethod
from collections.abc import Iterable, Iterator, Mapping
from typing import Any, ClassVar, Self

import attrs

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
from cbrcore.casebase.store import Changes
from cbrcore.errors import CaseBaseError, UnusableCaseBase
from cbrcore.model import JSON, Case

MAX_ID = MAX_INTEGER
"""The largest case id and revision: the largest integer of SQLite and PostgreSQL (bigint)."""

CHUNK = 500
"""Ids per statement: SQLite limits the parameters of one statement."""

_COLUMNS = "id, kind, problem, solution, meta, uses, created, last_used"
_WRITTEN = f"{_COLUMNS}, changed"
"""The columns a write sets: a case's and the revision that last wrote it."""


def dumps(value: JSON) -> str:
    """``value`` as the JSON text a store keeps."""
    # ASCII escapes keep every string storable (NUL, lone surrogates) as UTF-8 and in a
    # PostgreSQL database of any encoding, and its text readable back exactly
    return json.dumps(value, allow_nan=False, separators=(",", ":"))


def _chunks(ids: list[int]) -> Iterator[tuple[str, list[int]]]:
    """The ids a database can hold (one beyond its integers is stored nowhere), :data:`CHUNK` at
    a time, each chunk with its placeholders."""
    held = [i for i in ids if -MAX_ID - 1 <= i <= MAX_ID]
    for start in range(0, len(held), CHUNK):
        chunk = held[start:start + CHUNK]
        yield ", ".join("?" * len(chunk)), chunk


class _Missing(Exception):
    """A write found fewer of its cases than it was given."""


class SQLStore(ABC):
    """A case base in the tables ``cases``, ``meta`` and ``removed`` of a SQL database.

    A dialect subclass opens the connection (``_conn``) and supplies the members marked as its
    own below. ``read_only`` stores refuse every write with a CaseBaseError, and a transaction of
    theirs is a consistent snapshot that takes no lock.

    A transaction nests: a nested block is a savepoint, undone alone when it raises, and nothing
    commits before the outermost block ends. The outermost block holds the write lock from its
    start, so it reads what other processes committed before it writes; when it wrote, it moves
    the revision clock on by one as it commits.
    """

    DATABASE: ClassVar[str]
    """The database's name, as messages give it."""
    DRIVER_ERROR: ClassVar[type[Exception]]
    """The base class of the driver's errors."""
    JSON_NAMES: ClassVar[bool] = False
    """Whether kinds and meta keys are stored as JSON strings, rather than as the text itself."""
    CLOCK_IN_META: ClassVar[bool] = False
    """Whether the revision is kept in the meta table under :data:`REVISION_KEY`."""
    SNAPSHOT: ClassVar[str] = "BEGIN"
    """The statement beginning a read transaction that sees one state and takes no lock."""

    def __init__(self, *, busy_timeout: float, read_only: bool) -> None:
        self.busy_timeout = busy_timeout
        self.read_only = read_only
        self._depth = 0
        self._pending = 0
        self._wrote = False
        self._committed: int | None = None
        """What ``committed_revision`` says; None before the first transaction."""
        self._aborted: str | None = None
        """Why the database rolled back the transaction under way, when it did so by itself."""
        self._closed = False
        self._ns = ""
        """What comes before a table's name: its schema, quoted and with a dot, if any."""
        self._conn: Any = None

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- the dialect's ----------------------------------------------------------------------

    @abstractmethod
    def _translate(self, exc: Exception) -> CaseBaseError | None:
        """The CaseBaseError for a problem with the case base; None for anything else (a bug)."""

    @abstractmethod
    def _execute(self, sql: str, params: tuple[Any, ...]) -> Any:
        """Run one statement with ``?`` placeholders; its driver cursor."""

    @abstractmethod
    def _in_transaction(self) -> bool:
        """Whether a transaction is under way on the connection."""

    @abstractmethod
    def _begin(self) -> None:
        """Begin the outermost transaction: a snapshot when read-only, else holding the write
        lock (or taking it with :meth:`_read_clock`)."""

    @abstractmethod
    def _read_clock(self) -> int:
        """The revision, read at the start of the outermost transaction."""

    @abstractmethod
    def _write_clock(self) -> None:
        """Record ``_pending`` as the revision, as a writing transaction commits."""

    def _savepoint_state(self) -> tuple[Any, ...]:
        """What a savepoint undone must restore of the dialect's own transaction state."""
        return ()

    def _restore_savepoint_state(self, state: tuple[Any, ...]) -> None:  # noqa: B027
        """Restore what :meth:`_savepoint_state` returned; nothing, for a dialect that keeps no
        transaction state of its own."""

    @abstractmethod
    def _insert(self, case_id: int | None, case: Case) -> int:
        """Insert ``case`` with ``case_id``, or a new id when it is None; the id."""

    def _restore_order(self, cases: list[Case]) -> list[Case]:
        """``cases`` in the order a restore inserts them, once their ids are known to be sound."""
        return cases

    @abstractmethod
    def _structure_problems(self, problems: list[str]) -> bool:
        """Add to ``problems`` what is wrong with the database as a whole; False when the
        tables cannot be read."""

    @abstractmethod
    def _clock_problems(self, problems: list[str], largest_id: int) -> int | None:
        """Add to ``problems`` what is wrong with the revision clock; the revision a sound case
        is not after (None when the clock is unusable)."""

    @property
    @abstractmethod
    def revision(self) -> int:
        """The number of write transactions committed so far, by any process."""

    # -- talking to the database ------------------------------------------------------------

    @contextlib.contextmanager
    def _errors(self) -> Iterator[None]:
        try:
            yield
        except self.DRIVER_ERROR as exc:
            translated = self._translate(exc)
            if translated is None:
                raise
            raise translated from exc

    def _refuse_if_aborted(self) -> None:
        if self._aborted is not None:
            raise CaseBaseError(f"{self}: the transaction was rolled back by {self.DATABASE} "
                                f"({self._aborted}); nothing of it was kept")

    def _cursor(self, sql: str, params: Iterable[Any] = ()) -> Any:
        """Run a statement of the transaction under way, if any; the driver's cursor."""
        if self._depth:
            self._refuse_if_aborted()
        with self._errors():
            return self._execute(sql, tuple(params))

    def _run(self, sql: str, params: Iterable[Any] = ()) -> int:
        """Run a statement; the number of rows it changed."""
        return int(self._cursor(sql, params).rowcount)

    def _rows(self, sql: str, params: Iterable[Any] = ()) -> list[Any]:
        with self._errors():
            cursor = self._execute(sql, tuple(params))
            return cursor.fetchall() if cursor.description is not None else []

    def _value(self, sql: str, params: Iterable[Any] = ()) -> Any:
        rows = self._rows(sql, params)
        return rows[0][0] if rows else None

    def _rollback(self) -> None:
        # the error that got us here says more than a failed rollback would; a database that
        # cannot go on has rolled back by itself
        with contextlib.suppress(self.DRIVER_ERROR):
            if self._in_transaction():
                self._execute("ROLLBACK", ())

    def _writable(self) -> None:
        if self.read_only:
            raise CaseBaseError(f"{self} is open for reading only and cannot be written")

    def _name(self, name: str) -> str:
        """A kind or meta key as stored."""
        return dumps(name) if self.JSON_NAMES else name

    def _stored_name(self, stored: str, what: str) -> str:
        """A kind or meta key as read back; UnusableCaseBase when it cannot be."""
        if not self.JSON_NAMES:
            return stored
        try:
            text = json.loads(stored)
        except ValueError:
            text = None
        if not isinstance(text, str):
            raise UnusableCaseBase(f"{self} is corrupt: {what} {stored!r} is not a JSON string")
        return text

    # -- transactions -----------------------------------------------------------------------

    @property
    def committed_revision(self) -> int:
        """The revision this store object's last outermost transaction committed at: its new
        revision if it wrote, else the revision it read under the write lock (``revision`` before
        the first). Other processes' commits do not move it."""
        return self.revision if self._committed is None else self._committed

    @contextlib.contextmanager
    def transaction(self) -> Iterator[None]:
        """Group writes; commits on normal exit, rolls back if the block raises.

        A nested block joins the outer transaction (nothing commits before the outermost block
        ends); if a nested block raises, its own writes are undone and the outer block may go on.
        """
        if self._depth:
            with self._savepoint():
                yield
            return
        self._begin()
        try:
            read = self._read_clock()
            self._pending = read + 1
            self._wrote = False
            self._aborted = None
            self._depth = 1
            try:
                yield
            finally:
                self._depth = 0
            self._refuse_if_aborted()
            if self._wrote:
                if self._pending > MAX_ID:
                    raise CaseBaseError(f"{self} has reached the largest revision, {MAX_ID}: "
                                        f"it takes no more writes")
                self._write_clock()
            self._run("COMMIT")
            self._committed = self._pending if self._wrote else read
        except BaseException:
            self._rollback()
            raise

    @contextlib.contextmanager
    def _savepoint(self) -> Iterator[None]:
        name = f"cbr{self._depth}"
        saved = (self._pending, self._wrote, self._savepoint_state())
        self._run(f"SAVEPOINT {name}")
        self._depth += 1
        try:
            yield
        except BaseException:
            # after some errors (SQLite's full disk, no id left) the database has rolled back
            # the whole transaction and the savepoint is gone; the error says what happened
            if self._in_transaction():
                with contextlib.suppress(CaseBaseError, self.DRIVER_ERROR):
                    self._execute(f"ROLLBACK TO SAVEPOINT {name}", ())
                    self._execute(f"RELEASE SAVEPOINT {name}", ())
            elif self._aborted is None:
                # the outer block may go on: its writes must not commit one by one
                self._aborted = str(sys.exc_info()[1])
            self._pending, self._wrote, state = saved
            self._restore_savepoint_state(state)
            raise
        finally:
            self._depth -= 1
        self._run(f"RELEASE SAVEPOINT {name}")

    @contextlib.contextmanager
    def _snapshot(self) -> Iterator[None]:
        """Reads that see one state of the case base: the transaction under way, or a read
        transaction of their own, which takes no lock (a process catching up must not wait for
        the writers)."""
        if self._depth:
            yield
            return
        self._run(self.SNAPSHOT)
        try:
            yield
        finally:
            self._rollback()

    # -- cases ------------------------------------------------------------------------------

    def _row(self, case: Case) -> tuple[Any, ...]:
        """The written columns of ``case`` but its id, changed by the transaction under way."""
        return (self._name(case.kind), dumps(case.problem), dumps(case.solution),
                dumps(dict(case.meta)), case.uses, case.created, case.last_used, self._pending)

    def _insert_row(self, case_id: int | None, case: Case) -> Any:
        """Insert ``case`` under ``case_id`` (None: the database's next id); the cursor."""
        return self._cursor(f"INSERT INTO {self._ns}cases ({_WRITTEN}) "
                            f"VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)", (case_id, *self._row(case)))

    def _case(self, row: tuple[Any, ...]) -> Case:
        case_id, kind, problem, solution, meta, uses, created, last_used = row
        try:
            return Case(json.loads(problem), json.loads(solution), self._stored_name(kind, "kind"),
                        json.loads(meta), case_id, uses, created, last_used)
        except (TypeError, ValueError, UnusableCaseBase) as exc:
            why = str(exc).removeprefix(f"{self} is corrupt: ")
            raise UnusableCaseBase(f"{self} is corrupt: case {case_id} cannot be decoded "
                                   f"({why})") from exc

    def _no_id_left(self) -> CaseBaseError:
        return CaseBaseError(f"{self} has used every case id: ids are never reused, and the "
                             f"largest, {MAX_ID}, is taken")

    def add(self, case: Case) -> Case:
        """Store a new case; return it with its ``id`` and ``created`` set (given ones ignored).

        ``uses`` and ``last_used`` are kept.
        """
        self._writable()
        with self.transaction():
            stored = attrs.evolve(case, id=None, created=self._pending)
            check_case(stored, self._pending)
            case_id = self._insert(None, stored)
            self._wrote = True
            return attrs.evolve(stored, id=case_id)

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
            self._run(f"UPDATE {self._ns}cases SET kind = ?, problem = ?, solution = ?, "
                      f"meta = ?, uses = ?, created = ?, last_used = ?, changed = ? WHERE id = ?",
                      (*self._row(stored), case_id))
            self._wrote = True

    def remove(self, ids: Iterable[int]) -> None:
        """Delete the cases with these ids; KeyError if one is missing (then none is deleted)."""
        unique = list(dict.fromkeys(operator.index(i) for i in ids))
        if unique:
            self._writable()
            with self.transaction():
                # an id restored after its removal may be removed again
                self._on_each(unique, (
                    f"INSERT INTO {self._ns}removed (id, revision) SELECT id, ? "
                    f"FROM {self._ns}cases WHERE id IN ({{}}) ON CONFLICT (id) "
                    f"DO UPDATE SET revision = excluded.revision", (self._pending,)),
                    (f"DELETE FROM {self._ns}cases WHERE id IN ({{}})", ()))

    def touch(self, ids: Iterable[int]) -> None:
        """Count one more use of each case (once per distinct id) and stamp its ``last_used``.

        The stamp is the revision the write commits as. KeyError if an id is missing.
        """
        unique = list(dict.fromkeys(operator.index(i) for i in ids))
        if unique:
            self._writable()
            with self.transaction():
                self._on_each(unique, (
                    f"UPDATE {self._ns}cases SET uses = uses + 1, last_used = ?, changed = ? "
                    f"WHERE id IN ({{}})", (self._pending, self._pending)))

    def _on_each(self, ids: list[int], *statements: tuple[str, tuple[Any, ...]]) -> None:
        """Run each statement on the cases ``ids`` (its ``{}`` takes their placeholders), a
        statement per :data:`CHUNK` of ids, in one transaction; unless the last one changed a row
        for every id, undo them all and raise KeyError for the first missing id."""
        try:
            with self.transaction():
                changed = 0
                for sql, params in statements:
                    changed = sum(self._run(sql.format(marks), (*params, *chunk))
                                  for marks, chunk in _chunks(ids))
                if changed != len(ids):
                    raise _Missing
                self._wrote = True
        except _Missing:
            self._require(ids)

    def _require(self, ids: list[int]) -> None:
        """Raise KeyError for the first of ``ids`` that is not stored."""
        found = {row[0] for marks, chunk in _chunks(ids) for row in self._rows(
            f"SELECT id FROM {self._ns}cases WHERE id IN ({marks})", chunk)}
        for case_id in ids:
            if case_id not in found:
                raise KeyError(case_id)

    def get(self, case_id: int) -> Case:
        """The case with this id; KeyError if there is none."""
        case_id = operator.index(case_id)
        if not -MAX_ID - 1 <= case_id <= MAX_ID:
            raise KeyError(case_id)
        rows = self._rows(f"SELECT {_COLUMNS} FROM {self._ns}cases WHERE id = ?", (case_id,))
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
            # sorted here: ordered by id, the database may scan the table rather than the index
            rows = sorted(self._rows(f"SELECT {_COLUMNS} FROM {self._ns}cases "
                                     f"WHERE changed > ?", (since,)))
            removed = sorted(row[0] for row in self._rows(
                f"SELECT id FROM {self._ns}removed WHERE revision > ?", (since,)))
        return Changes(since, revision, tuple(self._case(row) for row in rows), tuple(removed))

    def cases(self, kind: str | None = None) -> list[Case]:
        """All cases (of one kind when given), ordered by id."""
        if kind is None:
            rows = self._rows(f"SELECT {_COLUMNS} FROM {self._ns}cases ORDER BY id")
        else:
            rows = self._rows(f"SELECT {_COLUMNS} FROM {self._ns}cases WHERE kind = ? "
                              f"ORDER BY id", (self._name(kind),))
        return [self._case(row) for row in rows]

    def count(self, kind: str | None = None) -> int:
        """How many cases (of one kind when given) are stored."""
        if kind is None:
            return int(self._value(f"SELECT count(*) FROM {self._ns}cases"))
        return int(self._value(f"SELECT count(*) FROM {self._ns}cases WHERE kind = ?",
                               (self._name(kind),)))

    def kind_counts(self) -> dict[str, int]:
        """How many cases of each kind are stored, by kind."""
        rows = self._rows(f"SELECT kind, count(*) FROM {self._ns}cases GROUP BY kind")
        return dict(sorted((self._stored_name(kind, "kind"), int(n)) for kind, n in rows))

    # -- meta -------------------------------------------------------------------------------

    def get_meta(self, key: str, default: JSON = None) -> JSON:
        """A plugin's stored value (plain JSON data) under ``key``."""
        check_meta_key(key)
        text = self._value(f"SELECT value FROM {self._ns}meta WHERE key = ?", (self._name(key),))
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
            self._run(f"INSERT INTO {self._ns}meta (key, value) VALUES (?, ?) "
                      f"ON CONFLICT (key) DO UPDATE SET value = excluded.value",
                      (self._name(key), dumps(value)))
            self._wrote = True

    def meta_items(self) -> dict[str, JSON]:
        """Every plugin meta value, by key."""
        rows = self._rows(f"SELECT key, value FROM {self._ns}meta WHERE key != ?",
                          (self._name(REVISION_KEY),))
        keyed = sorted((self._stored_name(key, "meta key"), text) for key, text in rows)
        return {key: self._meta_value(key, text) for key, text in keyed}

    def restore(self, cases: Iterable[Case], meta: Mapping[str, JSON], revision: int) -> None:
        """Fill this store, which holds no cases, with ``cases`` keeping their ids and stamps.

        Cases without an id get new ones, after every given id; cases without ``created`` the
        restoring transaction's revision. The store's meta is replaced by ``meta``, and the
        transaction commits as ``revision`` when that is ahead of the store's own clock.
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
            seen: set[int] = set()
            for case_id in (operator.index(c.id) for c in cases if c.id is not None):
                if case_id in seen:
                    raise ValueError(f"restore got two cases with id {case_id}")
                if not 1 <= case_id <= MAX_ID:
                    raise ValueError(f"restore got case id {case_id}; ids are from 1 to {MAX_ID}")
                seen.add(case_id)
            for case in self._restore_order(cases):
                stored = case if case.created is not None else attrs.evolve(
                    case, created=self._pending)
                check_case(stored, self._pending)
                self._insert(None if case.id is None else operator.index(case.id), stored)
                self._wrote = True
            if self._run(f"DELETE FROM {self._ns}meta WHERE key != ?",
                         (self._name(REVISION_KEY),)):
                self._wrote = True
            for key, value in meta.items():
                self.set_meta(key, value)

    # -- inspection -------------------------------------------------------------------------

    def check(self) -> list[str]:
        """Problems found by a full consistency check; empty when the store is sound.

        Checks the database as its dialect can (its tables, its clock), and every case and meta
        value: JSON that decodes, sensible use counts, revision stamps no later than the
        revision, each case's ``changed`` revision from its creation or last use to the
        revision, and each removal's revision no later than the revision.
        """
        problems: list[str] = []
        try:
            if not self._structure_problems(problems):
                return problems
            rows = self._rows(f"SELECT {_WRITTEN} FROM {self._ns}cases ORDER BY id")
            removed = self._rows(f"SELECT id, revision FROM {self._ns}removed ORDER BY id")
            meta = self._rows(f"SELECT key, value FROM {self._ns}meta ORDER BY key")
            # read after the cases: the revision only grows, so a sound case is never after it
            bound = self._clock_problems(problems, rows[-1][0] if rows else 0)
        except CaseBaseError as exc:
            return [*problems, str(exc)]
        for row in rows:
            problems += self._row_problems(row, bound)
        problems += removal_problems(removed, bound)
        for key, text in meta:
            try:
                shown = self._stored_name(key, "meta key")
            except UnusableCaseBase as exc:
                problems.append(str(exc).removeprefix(f"{self} is corrupt: "))
                continue
            if shown == REVISION_KEY:
                if not self.CLOCK_IN_META:
                    problems.append(f"meta key {shown!r}: reserved for the revision")
                continue
            try:
                json.loads(text)
            except (TypeError, ValueError) as exc:
                problems.append(f"meta key {shown!r}: not valid JSON ({exc})")
        return problems

    def _row_problems(self, row: tuple[Any, ...], revision: int | None) -> list[str]:
        case_id, kind, problem, solution, meta, uses, created, last_used, changed = row
        problems = []
        decoded = {} if self.JSON_NAMES else {"kind": kind}
        for field, text in (("kind", kind), ("problem", problem), ("solution", solution),
                            ("meta", meta)):
            if field in decoded:
                continue
            try:
                decoded[field] = json.loads(text)
            except (TypeError, ValueError) as exc:
                problems.append(f"case {case_id}: {field}: not valid JSON ({exc})")
        if len(decoded) < 4:
            return problems
        if created is None:
            problems.append(f"case {case_id}: created: missing")
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
