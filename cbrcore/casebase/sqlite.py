"""A case store in a SQLite file, safe against crashes and shared between processes."""

from __future__ import annotations

import contextlib
import json
import operator
import os
import sqlite3
import sys
import time
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import attrs

from cbrcore.casebase.data import (
    REVISION_KEY,
    case_problems,
    change_problems,
    check_case,
    check_meta,
    check_meta_key,
    check_since,
    removal_problems,
)
from cbrcore.casebase.sqlite_file import (
    MAX_ID,
    SCHEMA_EXPECTED,
    WAL_VERSION_OFFSET,
    create_schema,
    inspect_file,
    migrate,
    parse_revision,
    rollback,
    schema_problems,
    validate,
)
from cbrcore.casebase.store import Changes
from cbrcore.errors import CaseBaseError, CaseBaseLocked, UnusableCaseBase
from cbrcore.model import JSON, Case

LOCK_RETRY = (0.0001, 0.0005)
"""The first and the longest pause, in seconds, between two tries for the write lock."""

_NO_SHM = frozenset({"SQLITE_CANTOPEN", "SQLITE_READONLY_DIRECTORY", "SQLITE_READONLY_CANTINIT"})
"""What SQLite reports when it cannot create or set up the ``-shm`` file of a WAL database in
a folder, or beside a file, that may not be written (which one depends on its version and on
what is missing)."""

_COLUMNS = "id, kind, problem, solution, meta, uses, created, last_used"
_CHUNK = 500
"""Ids per statement: SQLite limits the parameters of one statement."""
_WRITTEN = f"{_COLUMNS}, changed"
"""The columns a write sets: a case's and the revision that last wrote it."""
def _dumps(value: JSON) -> str:
    # ASCII escapes keep strings that are not valid Unicode (lone surrogates) storable as UTF-8
    return json.dumps(value, allow_nan=False, separators=(",", ":"))


class _Missing(Exception):
    """A write found fewer of its cases than it was given."""


def _is_busy(exc: CaseBaseError) -> bool:
    """Whether ``exc`` says another connection holds the lock."""
    cause = exc.__cause__
    return getattr(cause, "sqlite_errorname", "").startswith(("SQLITE_BUSY", "SQLITE_LOCKED"))


class SQLiteStore:
    """A case base in a SQLite file.

    Opening checks the file and refuses, with :class:`~cbrcore.errors.CaseBaseError` naming it,
    anything that is not a sound cbrcore case base of this schema version (see
    :class:`UnusableCaseBase`), without writing to it. A missing file is created unless
    ``create`` is false; so is an empty (zero-byte) one, which is what a process killed while
    creating a case base leaves behind.

    The file is in WAL mode with ``synchronous=NORMAL``: a commit is in the write-ahead log, in the
    operating system's hands, before it returns, so a killed process loses nothing it committed;
    a power cut may lose the last commits but never corrupts the file. Syncing to disk on every
    commit (``FULL``) would cost more than a fast domain's whole learn step, and losing the last
    few learned cases on a power cut is harmless.

    Several processes may use one file: writers take turns, waiting up to ``busy_timeout``
    seconds for the write lock before giving up with a CaseBaseError. Readers never wait. A
    writer waiting for the lock tries again every half millisecond at most (:data:`LOCK_RETRY`):
    SQLite's own waiting sleeps up to 100 ms between tries, so a robot would miss turn after
    turn of a lock that the others hold for a few milliseconds per learn step.
    Every transaction starts with the write lock held (``BEGIN IMMEDIATE``), so it never fails
    halfway for want of it.

    ``read_only`` opens an existing case base for reading alone (a write raises CaseBaseError),
    also in a folder the process may not write into; then a transaction is a consistent snapshot
    that takes no lock.
    """

    def __init__(self, path: str | os.PathLike[str], *, busy_timeout: float = 5.0,
                 create: bool = True, read_only: bool = False) -> None:
        self.path = Path(path)
        self.busy_timeout = busy_timeout
        self.read_only = read_only
        self._depth = 0
        self._pending = 0
        self._wrote = False
        self._committed: int | None = None
        """What ``committed_revision`` says; None before the first transaction."""
        self._aborted: str | None = None
        """Why SQLite rolled back the transaction under way, when it did so by itself."""
        self._immutable = False
        create = create and not read_only
        new = inspect_file(self.path, create)
        self._conn = self._connect_reading() if read_only else self._connect(
            "mode=rwc" if create else "mode=rw")
        try:
            with self._errors():
                if new:
                    create_schema(self._conn)
                elif not read_only:
                    migrate(self._conn, self.path)
                validate(self._conn, self.path)
            if not read_only:
                if self._value("PRAGMA journal_mode") != "wal":
                    self._rows("PRAGMA journal_mode = WAL")
                self._run("PRAGMA synchronous = NORMAL")
        except BaseException:
            self._conn.close()
            raise

    def _connect(self, parameters: str) -> sqlite3.Connection:
        try:
            return sqlite3.connect(f"{self.path.absolute().as_uri()}?{parameters}", uri=True,
                                   timeout=self.busy_timeout, isolation_level=None)
        except sqlite3.Error as exc:
            raise self._translate(exc) or CaseBaseError(f"cannot open {self.path}: {exc}") from exc

    def _connect_reading(self) -> sqlite3.Connection:
        """A connection that cannot write the case base.

        A read-write connection told to write nothing comes first: unlike a read-only one, the
        last such connection to close removes the ``-wal`` and ``-shm`` files beside the case
        base, so reading leaves nothing behind. In a folder the process may not write, reading
        a WAL database needs its ``-shm`` file to exist already, and SQLite refuses it
        (:data:`_NO_SHM`); without a ``-wal`` file everything committed is in the case base
        file itself, and SQLite may read it as immutable (a snapshot that takes no locks). A
        file the process may not write is read so at once: SQLite would open it read-only and
        leave ``-wal`` and ``-shm`` files it cannot remove.
        """
        wal = self.path.with_name(self.path.name + "-wal")
        if not os.access(self.path, os.W_OK) and not wal.exists():
            self._immutable = True
            return self._connect("mode=ro&immutable=1")
        conn = self._connect("mode=rw")
        try:
            conn.execute("PRAGMA query_only = ON")
            # the first read opens the -shm file, which fails in a folder that may not be written
            conn.execute("SELECT count(*) FROM sqlite_master").fetchall()
            return conn
        except sqlite3.Error as exc:
            conn.close()
            if getattr(exc, "sqlite_errorname", "") not in _NO_SHM:
                raise self._translate(exc) or CaseBaseError(
                    f"cannot open {self.path}: {exc}") from exc
        if wal.exists():
            return self._connect("mode=ro")
        self._immutable = True
        return self._connect("mode=ro&immutable=1")

    def __str__(self) -> str:
        return str(self.path)

    def __repr__(self) -> str:
        return f"SQLiteStore({str(self.path)!r})"

    def __enter__(self) -> SQLiteStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- talking to SQLite ------------------------------------------------------------------

    def _translate(self, exc: sqlite3.Error) -> CaseBaseError | None:
        """The CaseBaseError for a problem with the file; None for anything else (a bug)."""
        name = getattr(exc, "sqlite_errorname", "")
        if name.startswith(("SQLITE_BUSY", "SQLITE_LOCKED")):
            return CaseBaseLocked(f"{self.path} is locked by another process (gave up after "
                                 f"waiting {self.busy_timeout:g} s for it)")
        if name.startswith("SQLITE_CORRUPT") or name == "SQLITE_NOTADB":
            return UnusableCaseBase(f"{self.path} is corrupt: {exc}")
        if name.startswith("SQLITE_READONLY"):
            if self.read_only:
                return CaseBaseError(f"{self.path} is open for reading only and cannot be "
                                     f"written")
            return CaseBaseError(f"{self.path} cannot be written: {exc}")
        if name.startswith("SQLITE_FULL") and self._ids_used_up():
            return self._no_id_left()
        if name.startswith(("SQLITE_IOERR", "SQLITE_FULL", "SQLITE_CANTOPEN", "SQLITE_PERM")):
            return CaseBaseError(f"{self.path}: {exc}")
        if str(exc).startswith(("no such table", "no such column")):
            # the schema was checked when the file was opened; another program changed it since
            return UnusableCaseBase(f"{self.path} is not a sound case base: {exc} "
                                    f"({SCHEMA_EXPECTED})")
        return None

    def _no_id_left(self) -> CaseBaseError:
        return CaseBaseError(f"{self.path} has used every case id: ids are never reused, and the "
                             f"largest, {MAX_ID}, is taken")

    def _ids_used_up(self) -> bool:
        """Whether SQLite has no id left to give a new case (it then says the disk is full)."""
        with contextlib.suppress(sqlite3.Error):
            largest = self._conn.execute(
                "SELECT max(coalesce((SELECT seq FROM sqlite_sequence WHERE name = 'cases'), 0), "
                "coalesce((SELECT max(id) FROM cases), 0))").fetchone()[0]
            return bool(largest >= MAX_ID)
        return False

    @contextlib.contextmanager
    def _errors(self) -> Iterator[None]:
        try:
            yield
        except sqlite3.Error as exc:
            translated = self._translate(exc)
            if translated is None:
                raise
            raise translated from exc

    def _refuse_if_aborted(self) -> None:
        if self._aborted is not None:
            raise CaseBaseError(f"{self.path}: the transaction was rolled back by SQLite "
                                f"({self._aborted}); nothing of it was kept")

    def _run(self, sql: str, params: Iterable[Any] = ()) -> sqlite3.Cursor:
        if self._depth:
            self._refuse_if_aborted()
        with self._errors():
            return self._conn.execute(sql, tuple(params))

    def _rows(self, sql: str, params: Iterable[Any] = ()) -> list[Any]:
        with self._errors():
            return self._conn.execute(sql, tuple(params)).fetchall()

    def _value(self, sql: str, params: Iterable[Any] = ()) -> Any:
        rows = self._rows(sql, params)
        return rows[0][0] if rows else None

    def _rollback(self) -> None:
        rollback(self._conn)

    # -- transactions -----------------------------------------------------------------------

    @property
    def revision(self) -> int:
        """The number of write transactions committed so far, by any process."""
        text = self._value("SELECT value FROM meta WHERE key = ?", (REVISION_KEY,))
        if text is None:
            raise UnusableCaseBase(f"{self.path} is corrupt: its revision record is missing")
        revision = parse_revision(text)
        if revision is None:
            raise UnusableCaseBase(f"{self.path} is corrupt: its revision record is {text!r}, "
                                   f"expected an integer from 0 to {MAX_ID}")
        return revision

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
        # reading alone takes no lock: a deferred transaction is a consistent snapshot
        if self.read_only:
            self._run("BEGIN")
        else:
            self._lock()
        try:
            read = self.revision
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
                    raise CaseBaseError(f"{self.path} has reached the largest revision, "
                                        f"{MAX_ID}: it takes no more writes")
                self._run("UPDATE meta SET value = ? WHERE key = ?",
                          (str(self._pending), REVISION_KEY))
            self._run("COMMIT")
            self._committed = self._pending if self._wrote else read
        except BaseException:
            self._rollback()
            raise

    def _lock(self) -> None:
        """Begin a transaction holding the write lock, trying again after short pauses until
        ``busy_timeout`` has passed."""
        deadline = time.monotonic() + self.busy_timeout
        pause = LOCK_RETRY[0]
        self._run("PRAGMA busy_timeout = 0")
        try:
            while True:
                try:
                    self._run("BEGIN IMMEDIATE")
                    return
                except CaseBaseError as exc:
                    left = deadline - time.monotonic()
                    if not _is_busy(exc) or left <= 0:
                        raise
                time.sleep(min(pause, left))
                pause = min(2 * pause, LOCK_RETRY[1])
        finally:
            self._run(f"PRAGMA busy_timeout = {round(self.busy_timeout * 1000)}")

    @contextlib.contextmanager
    def _savepoint(self) -> Iterator[None]:
        name = f"cbr{self._depth}"
        saved = (self._pending, self._wrote)
        self._run(f"SAVEPOINT {name}")
        self._depth += 1
        try:
            yield
        except BaseException:
            # after some errors (a full disk, no id left) SQLite has rolled back the whole
            # transaction and the savepoint is gone; the error says what happened
            if self._conn.in_transaction:
                self._run(f"ROLLBACK TO {name}")
                self._run(f"RELEASE {name}")
            elif self._aborted is None:
                # the outer block may go on: its writes must not commit one by one
                self._aborted = str(sys.exc_info()[1])
            self._pending, self._wrote = saved
            raise
        finally:
            self._depth -= 1
        self._run(f"RELEASE {name}")

    # -- cases ------------------------------------------------------------------------------

    def _row(self, case: Case) -> tuple[Any, ...]:
        """The written columns of ``case`` but its id, changed by the transaction under way."""
        return (case.kind, _dumps(case.problem), _dumps(case.solution), _dumps(dict(case.meta)),
                case.uses, case.created, case.last_used, self._pending)

    def _case(self, row: tuple[Any, ...]) -> Case:
        case_id, kind, problem, solution, meta, uses, created, last_used = row
        try:
            return Case(json.loads(problem), json.loads(solution), kind, json.loads(meta),
                        case_id, uses, created, last_used)
        except (TypeError, ValueError) as exc:
            raise UnusableCaseBase(f"{self.path} is corrupt: case {case_id} cannot be decoded "
                                   f"({exc})") from exc

    def add(self, case: Case) -> Case:
        """Store a new case; return it with its ``id`` and ``created`` set (given ones ignored).

        ``uses`` and ``last_used`` are kept.
        """
        with self.transaction():
            stored = attrs.evolve(case, id=None, created=self._pending)
            check_case(stored, self._pending)
            cursor = self._run(f"INSERT INTO cases ({_WRITTEN}) "
                               "VALUES (NULL, ?, ?, ?, ?, ?, ?, ?, ?)", self._row(stored))
            self._wrote = True
            return attrs.evolve(stored, id=cursor.lastrowid)

    def replace(self, case: Case) -> None:
        """Overwrite the stored case with ``case.id``; KeyError if there is none.

        Every field is taken from ``case``, except that ``created`` stays when it is None.
        """
        case_id = operator.index(case.id)
        with self.transaction():
            old = self.get(case_id)
            stored = case if case.created is not None else attrs.evolve(case, created=old.created)
            check_case(stored, self._pending)
            self._run("UPDATE cases SET kind = ?, problem = ?, solution = ?, meta = ?, uses = ?, "
                      "created = ?, last_used = ?, changed = ? WHERE id = ?",
                      (*self._row(stored), case_id))
            self._wrote = True

    def remove(self, ids: Iterable[int]) -> None:
        """Delete the cases with these ids; KeyError if one is missing (then none is deleted)."""
        unique = list(dict.fromkeys(operator.index(i) for i in ids))
        if unique:
            with self.transaction():
                self._each("DELETE FROM cases WHERE id IN ({})", (), unique)
                with self._errors():
                    self._conn.executemany(
                        "INSERT OR REPLACE INTO removed (id, revision) VALUES (?, ?)",
                        [(i, self._pending) for i in unique])
                self._wrote = True

    def touch(self, ids: Iterable[int]) -> None:
        """Count one more use of each case (once per distinct id) and stamp its ``last_used``.

        The stamp is the revision the write commits as. KeyError if an id is missing.
        """
        unique = list(dict.fromkeys(operator.index(i) for i in ids))
        if unique:
            with self.transaction():
                self._each("UPDATE cases SET uses = uses + 1, last_used = ?, changed = ? "
                           "WHERE id IN ({})", (self._pending, self._pending), unique)
                self._wrote = True

    def _each(self, sql: str, params: tuple[Any, ...], ids: list[int]) -> None:
        """Run ``sql`` on the cases ``ids`` (its ``{}`` takes their placeholders), a statement
        per chunk of ids; if one is missing, undo it and raise KeyError for the first missing."""
        try:
            with self.transaction():
                changed = 0
                # SQLite limits the number of parameters of one statement
                for start in range(0, len(ids), _CHUNK):
                    chunk = ids[start:start + _CHUNK]
                    changed += self._run(sql.format(", ".join("?" * len(chunk))),
                                         (*params, *chunk)).rowcount
                if changed != len(ids):
                    raise _Missing
        except _Missing:
            self._require(ids)

    def _require(self, ids: list[int]) -> None:
        """Raise KeyError for the first of ``ids`` that is not stored."""
        found: set[int] = set()
        for start in range(0, len(ids), _CHUNK):
            chunk = ids[start:start + _CHUNK]
            marks = ", ".join("?" * len(chunk))
            found.update(r[0] for r in self._rows(f"SELECT id FROM cases WHERE id IN ({marks})",
                                                  chunk))
        for case_id in ids:
            if case_id not in found:
                raise KeyError(case_id)

    def get(self, case_id: int) -> Case:
        """The case with this id; KeyError if there is none."""
        case_id = operator.index(case_id)
        rows = self._rows(f"SELECT {_COLUMNS} FROM cases WHERE id = ?", (case_id,))
        if not rows:
            raise KeyError(case_id)
        return self._case(rows[0])

    def changes(self, since: int) -> Changes:
        """What the commits after revision ``since`` changed (:class:`Changes`): the cases
        whose ``changed`` revision is later, and the removed ids recorded later, both found
        through an index, in one read transaction."""
        with self._snapshot():
            revision = self.revision
            check_since(since, revision)
            # sorted here: ordered by id, SQLite would scan the table rather than the index
            rows = sorted(self._rows(f"SELECT {_COLUMNS} FROM cases WHERE changed > ?",
                                     (since,)))
            removed = sorted(row[0] for row in self._rows(
                "SELECT id FROM removed WHERE revision > ?", (since,)))
        return Changes(since, revision, tuple(self._case(row) for row in rows), tuple(removed))

    @contextlib.contextmanager
    def _snapshot(self) -> Iterator[None]:
        """Reads that see one state of the case base: the transaction under way, or a read
        transaction of their own, which takes no lock."""
        if self._depth or self.read_only:
            with self.transaction():
                yield
            return
        self._run("BEGIN")
        try:
            yield
        finally:
            self._rollback()

    def cases(self, kind: str | None = None) -> list[Case]:
        """All cases (of one kind when given), ordered by id."""
        if kind is None:
            rows = self._rows(f"SELECT {_COLUMNS} FROM cases ORDER BY id")
        else:
            rows = self._rows(f"SELECT {_COLUMNS} FROM cases WHERE kind = ? ORDER BY id", (kind,))
        return [self._case(row) for row in rows]

    def count(self, kind: str | None = None) -> int:
        """How many cases (of one kind when given) are stored."""
        if kind is None:
            return int(self._value("SELECT count(*) FROM cases"))
        return int(self._value("SELECT count(*) FROM cases WHERE kind = ?", (kind,)))

    def kind_counts(self) -> dict[str, int]:
        """How many cases of each kind are stored, by kind."""
        return dict(self._rows("SELECT kind, count(*) FROM cases GROUP BY kind ORDER BY kind"))

    # -- meta -------------------------------------------------------------------------------

    def get_meta(self, key: str, default: JSON = None) -> JSON:
        """A plugin's stored value (plain JSON data) under ``key``."""
        check_meta_key(key)
        text = self._value("SELECT value FROM meta WHERE key = ?", (key,))
        return default if text is None else self._meta_value(key, text)

    def _meta_value(self, key: str, text: str) -> JSON:
        try:
            return json.loads(text)
        except (TypeError, ValueError) as exc:
            raise UnusableCaseBase(f"{self.path} is corrupt: meta key {key!r} cannot be decoded "
                                   f"({exc})") from exc

    def set_meta(self, key: str, value: JSON) -> None:
        """Store a plugin's value under ``key``; it commits with the surrounding transaction."""
        check_meta(key, value)
        with self.transaction():
            self._run("INSERT OR REPLACE INTO meta (key, value) VALUES (?, ?)",
                      (key, _dumps(value)))
            self._wrote = True

    def meta_items(self) -> dict[str, JSON]:
        """Every plugin meta value, by key."""
        rows = self._rows("SELECT key, value FROM meta WHERE key != ? ORDER BY key",
                          (REVISION_KEY,))
        return {key: self._meta_value(key, text) for key, text in rows}

    def restore(self, cases: Iterable[Case], meta: Mapping[str, JSON], revision: int) -> None:
        """Fill this store, which holds no cases, with ``cases`` keeping their ids and stamps.

        Cases without an id get new ones, cases without ``created`` the restoring transaction's
        revision. The store's meta is replaced by ``meta``, and the transaction commits as
        ``revision`` when that is ahead of the store's own clock.
        """
        with self.transaction():
            if self.count():
                raise ValueError("restore needs a store without cases")
            if revision >= self._pending:
                # moving the clock forward is a write even when nothing else changes
                self._pending = revision
                self._wrote = True
            cases = list(cases)
            # cases with ids go in first, so the ids SQLite hands out come after all of them
            ordered = [c for c in cases if c.id is not None] + [c for c in cases if c.id is None]
            if ordered and ordered[-1].id is None and MAX_ID in (c.id for c in ordered):
                # SQLite would say the disk is full, and roll back what shows it is not
                raise self._no_id_left()
            for case in ordered:
                stored = case if case.created is not None else attrs.evolve(
                    case, created=self._pending)
                check_case(stored, self._pending)
                case_id = None if case.id is None else operator.index(case.id)
                try:
                    self._run(f"INSERT INTO cases ({_WRITTEN}) "
                              "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)", (case_id, *self._row(stored)))
                except sqlite3.IntegrityError as exc:
                    raise ValueError(f"restore got two cases with id {case_id}") from exc
                self._wrote = True
            if self._run("DELETE FROM meta WHERE key != ?", (REVISION_KEY,)).rowcount:
                self._wrote = True
            for key, value in meta.items():
                self.set_meta(key, value)

    # -- inspection -------------------------------------------------------------------------

    @property
    def schema_version(self) -> int:
        """The schema version recorded in the file."""
        return int(self._value("PRAGMA user_version"))

    @property
    def journal_mode(self) -> str:
        """SQLite's journal mode for the file (``wal`` for every case base this store opened)."""
        if self._immutable:
            # SQLite ignores the log of a file it reads as immutable and reports "delete"; the
            # file's header says whether it is in WAL mode (format version 2)
            with self._errors(), self.path.open("rb") as file:
                header = file.read(WAL_VERSION_OFFSET + 1)
            return "wal" if header[WAL_VERSION_OFFSET:] == b"\x02" else "delete"
        return str(self._value("PRAGMA journal_mode"))

    def describe(self) -> dict[str, JSON]:
        """The file's path, schema version, size, write-ahead log size and journal mode."""
        wal = self.path.with_name(self.path.name + "-wal")
        return {
            "path": str(self.path),
            "schema": self.schema_version,
            "size_bytes": self.path.stat().st_size,
            "wal_bytes": wal.stat().st_size if wal.exists() else 0,
            "journal_mode": self.journal_mode,
        }

    def check(self) -> list[str]:
        """Problems found by a full consistency check; empty when the store is sound.

        Runs SQLite's ``integrity_check`` and checks every case and meta value: JSON that
        decodes, unique ids, sensible use counts and revision stamps no later than the revision.
        """
        problems: list[str] = []
        try:
            problems += [f"integrity: {row[0]}" for row in self._rows("PRAGMA integrity_check")
                         if row[0] != "ok"]
            with self._errors():
                schema = schema_problems(self._conn)
            if schema:
                # found when the file was opened, unless another program changed it since
                return [*problems, *(f"schema: {p}" for p in schema)]
            rows = self._rows(f"SELECT {_WRITTEN} FROM cases ORDER BY id")
            removed = self._rows("SELECT id, revision FROM removed ORDER BY id")
            problems += [f"case {row[0]}: id is used {row[1]} times" for row in self._rows(
                "SELECT id, count(*) FROM cases GROUP BY id HAVING count(*) > 1")]
            # the revision record is checked on its own, below
            meta = self._rows("SELECT key, value FROM meta WHERE key != ?", (REVISION_KEY,))
            # read after the cases: the revision only grows, so a sound case is never after it
            bound = self._pending if self._depth else self._revision_or_problem(problems)
        except CaseBaseError as exc:
            return [*problems, str(exc)]
        for row in rows:
            problems += self._row_problems(row, bound)
        problems += removal_problems(removed, bound)
        for key, text in meta:
            try:
                json.loads(text)
            except (TypeError, ValueError) as exc:
                problems.append(f"meta key {key!r}: not valid JSON ({exc})")
        return problems

    def _revision_or_problem(self, problems: list[str]) -> int | None:
        text = self._value("SELECT value FROM meta WHERE key = ?", (REVISION_KEY,))
        revision = parse_revision(text)
        if revision is None:
            problems.append(f"revision: expected an integer from 0 to {MAX_ID}, got {text!r}")
            return None
        return revision

    def _row_problems(self, row: tuple[Any, ...], revision: int | None) -> list[str]:
        case_id, kind, problem, solution, meta, uses, created, last_used, changed = row
        problems = []
        decoded = {}
        for field, text in (("problem", problem), ("solution", solution), ("meta", meta)):
            try:
                decoded[field] = json.loads(text)
            except (TypeError, ValueError) as exc:
                problems.append(f"case {case_id}: {field}: not valid JSON ({exc})")
        if len(decoded) < 3:
            return problems
        if created is None:
            problems.append(f"case {case_id}: created: missing")
        case = Case(decoded["problem"], decoded["solution"], kind, decoded["meta"], case_id,
                    uses, created, last_used)
        problems += [f"case {case_id}: {p}" for p in case_problems(case, revision)]
        return problems + change_problems(case_id, created, last_used, changed, revision)

    def close(self) -> None:
        """Close the connection; safe to call twice."""
        self._conn.close()

    def __iter__(self) -> Iterator[Case]:
        return iter(self.cases())

    def __len__(self) -> int:
        return self.count()
