"""A case store in a SQLite file, safe against crashes and shared between processes."""

from __future__ import annotations

import contextlib
import os
import sqlite3
import time
from pathlib import Path
from typing import Any

from cbr_stores.sql import MAX_ID, SQLStore
from cbr_stores.sqlite_file import (
    SCHEMA_EXPECTED,
    WAL_VERSION_OFFSET,
    create_schema,
    inspect_file,
    migrate,
    parse_revision,
    schema_problems,
    validate,
)
from cbrcore.casebase.data import REVISION_KEY
from cbrcore.errors import CaseBaseError, CaseBaseLocked, UnusableCaseBase
from cbrcore.model import JSON, Case

OLDEST_SQLITE = (3, 24)
"""The oldest SQLite library the store works with: the first to read the upsert statements."""

LOCK_RETRY = (0.0001, 0.0005)
"""The first and the longest pause, in seconds, between two tries for the write lock."""

_NO_SHM = frozenset({"SQLITE_CANTOPEN", "SQLITE_READONLY_DIRECTORY", "SQLITE_READONLY_CANTINIT"})
"""What SQLite reports when it cannot create or set up the ``-shm`` file of a WAL database in
a folder, or beside a file, that may not be written (which one depends on its version and on
what is missing)."""


def _is_busy(exc: CaseBaseError) -> bool:
    """Whether ``exc`` says another connection holds the lock."""
    cause = exc.__cause__
    return getattr(cause, "sqlite_errorname", "").startswith(("SQLITE_BUSY", "SQLITE_LOCKED"))


class SQLiteStore(SQLStore):
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

    DATABASE = "SQLite"
    DRIVER_ERROR = sqlite3.Error
    CLOCK_IN_META = True

    def __init__(self, path: str | os.PathLike[str], *, busy_timeout: float = 5.0,
                 create: bool = True, read_only: bool = False) -> None:
        if sqlite3.sqlite_version_info < OLDEST_SQLITE:
            raise CaseBaseError(f"cannot open {path}: Python uses SQLite "
                                f"{sqlite3.sqlite_version}, and the sqlite store needs "
                                f"{'.'.join(map(str, OLDEST_SQLITE))} or later")
        super().__init__(busy_timeout=busy_timeout, read_only=read_only)
        self.path = Path(path)
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

    # -- the dialect ------------------------------------------------------------------------

    def _execute(self, sql: str, params: tuple[Any, ...]) -> sqlite3.Cursor:
        return self._conn.execute(sql, params)

    def _in_transaction(self) -> bool:
        return bool(self._conn.in_transaction)

    def _translate(self, exc: Exception) -> CaseBaseError | None:
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

    def _ids_used_up(self) -> bool:
        """Whether SQLite has no id left to give a new case (it then says the disk is full)."""
        with contextlib.suppress(sqlite3.Error):
            largest = self._conn.execute(
                "SELECT max(coalesce((SELECT seq FROM sqlite_sequence WHERE name = 'cases'), 0), "
                "coalesce((SELECT max(id) FROM cases), 0))").fetchone()[0]
            return bool(largest >= MAX_ID)
        return False

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

    def _begin(self) -> None:
        # reading alone takes no lock: a deferred transaction is a consistent snapshot
        if self.read_only:
            self._run("BEGIN")
        else:
            self._lock()

    def _read_clock(self) -> int:
        return self.revision

    def _write_clock(self) -> None:
        self._run("UPDATE meta SET value = ? WHERE key = ?", (str(self._pending), REVISION_KEY))

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

    def _insert(self, case_id: int | None, case: Case) -> int:
        return int(self._insert_row(case_id, case).lastrowid)

    def _restore_order(self, cases: list[Case]) -> list[Case]:
        # cases with ids go in first, so the ids SQLite hands out come after all of them
        ordered = [c for c in cases if c.id is not None] + [c for c in cases if c.id is None]
        if ordered and ordered[-1].id is None and MAX_ID in (c.id for c in ordered):
            # SQLite would say the disk is full, and roll back what shows it is not
            raise self._no_id_left()
        return ordered

    def _structure_problems(self, problems: list[str]) -> bool:
        """SQLite's ``integrity_check``, the schema, and ids used twice."""
        problems += [f"integrity: {row[0]}" for row in self._rows("PRAGMA integrity_check")
                     if row[0] != "ok"]
        with self._errors():
            schema = schema_problems(self._conn)
        if schema:
            # found when the file was opened, unless another program changed it since
            problems += [f"schema: {p}" for p in schema]
            return False
        problems += [f"case {row[0]}: id is used {row[1]} times" for row in self._rows(
            "SELECT id, count(*) FROM cases GROUP BY id HAVING count(*) > 1")]
        return True

    def _clock_problems(self, problems: list[str], largest_id: int) -> int | None:
        return self._pending if self._depth else self._revision_or_problem(problems)

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

    def _revision_or_problem(self, problems: list[str]) -> int | None:
        text = self._value("SELECT value FROM meta WHERE key = ?", (REVISION_KEY,))
        revision = parse_revision(text)
        if revision is None:
            problems.append(f"revision: expected an integer from 0 to {MAX_ID}, got {text!r}")
            return None
        return revision
