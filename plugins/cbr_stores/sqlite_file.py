"""What a sound case base file is, and how one is recognised, created, migrated and checked.

A cbrcore case base is a SQLite file with its own ``application_id`` and schema version, the
tables ``cases``, ``meta`` and ``removed`` and nothing else: a trigger or a view would act or
answer behind the store's back. :class:`~cbrcore.casebase.sqlite.SQLiteStore` opens files through
these checks and keeps to its operations.

Schema versions: version 1 had no record of when a case last changed nor of removed cases;
version 2 adds the column ``cases.changed`` (the revision that last wrote the case) and the table
``removed`` (each removed id and the revision that removed it), from which the store tells what
changed since a revision (``SQLiteStore.changes``). Opening a case base of an older version
migrates it with the statements of :data:`MIGRATIONS`, all in one transaction.
"""

from __future__ import annotations

import contextlib
import functools
import json
import re
import sqlite3
from collections.abc import Mapping
from pathlib import Path

from cbrcore.casebase.data import REVISION_KEY
from cbrcore.errors import CaseBaseError, UnusableCaseBase
from cbrcore.files import open_regular

APPLICATION_ID = 0x43425243
"""``PRAGMA application_id`` of a cbrcore case base ("CBRC")."""

SCHEMA_VERSION = 2
"""``PRAGMA user_version`` of the case bases this cbrcore reads and writes."""

MAX_ID = 2**63 - 1
"""The largest case id: SQLite's largest integer."""

HEADER = b"SQLite format 3\x00"
WAL_VERSION_OFFSET = 18  # the header's "file format write version": 2 in WAL mode
SCHEMA_STATEMENTS = (
    # AUTOINCREMENT: ids are never reused, because solutions and plugin meta refer to cases by id
    """CREATE TABLE cases (
        id INTEGER PRIMARY KEY AUTOINCREMENT,
        kind TEXT NOT NULL,
        problem TEXT NOT NULL,
        solution TEXT NOT NULL,
        meta TEXT NOT NULL,
        uses INTEGER NOT NULL,
        created INTEGER NOT NULL,
        last_used INTEGER,
        changed INTEGER NOT NULL DEFAULT 0
    )""",
    "CREATE INDEX cases_kind ON cases (kind)",
    "CREATE INDEX cases_changed ON cases (changed)",
    "CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
    "CREATE TABLE removed (id INTEGER PRIMARY KEY, revision INTEGER NOT NULL)",
    "CREATE INDEX removed_revision ON removed (revision)",
)
MIGRATIONS: Mapping[int, tuple[str, ...]] = {
    # a case's last change is at least its creation and its last use; removals before the
    # migration are not known, and no view of the case base can be older than its opening
    1: ("ALTER TABLE cases ADD COLUMN changed INTEGER NOT NULL DEFAULT 0",
        "UPDATE cases SET changed = max(created, coalesce(last_used, 0))",
        "CREATE INDEX cases_changed ON cases (changed)",
        "CREATE TABLE removed (id INTEGER PRIMARY KEY, revision INTEGER NOT NULL)",
        "CREATE INDEX removed_revision ON removed (revision)"),
}
"""The statements taking a case base from schema version ``n`` (the key) to ``n + 1``."""

SCHEMA_EXPECTED = ("a case base has the tables cases, meta and removed, the indexes cases_kind, "
                   "cases_changed and removed_revision and no other tables, indexes, views or "
                   "triggers")

_SPACED = re.compile(r"\s*([(),])\s*")


def normalised(sql: str) -> str:
    """``sql`` with its whitespace normalised, so that a table a migration altered (SQLite
    appends the added column to its definition) reads as the same table created anew."""
    return " ".join(_SPACED.sub(r"\1", sql).split())


def schema_of(conn: sqlite3.Connection) -> dict[tuple[str, str], tuple[str, str | None]]:
    """Every schema object by type and name: its table and its SQL, whitespace normalised."""
    rows = conn.execute("SELECT type, name, tbl_name, sql FROM sqlite_master").fetchall()
    return {(kind, name): (table, None if sql is None else normalised(sql))
            for kind, name, table, sql in rows}


@functools.cache
def case_base_schema() -> dict[tuple[str, str], tuple[str, str | None]]:
    """The schema objects of a case base, with those SQLite adds (sqlite_sequence, autoindexes).

    Read from a database built by :data:`SCHEMA_STATEMENTS`, so the two cannot disagree.
    """
    conn = sqlite3.connect(":memory:")
    try:
        for statement in SCHEMA_STATEMENTS:
            conn.execute(statement)
        return schema_of(conn)
    finally:
        conn.close()


def parse_revision(text: str | None) -> int | None:
    """The revision a meta record holds; None unless it is an integer from 0 to
    :data:`MAX_ID`."""
    try:
        revision = json.loads(text) if text is not None else None
    except ValueError:
        return None
    if isinstance(revision, int) and not isinstance(revision, bool) and 0 <= revision <= MAX_ID:
        return revision
    return None


def inspect_file(path: Path, create: bool) -> bool:
    """Refuse what cannot be a case base before SQLite touches it; True for a new file."""
    try:
        with open_regular(path) as file:
            header = file.read(len(HEADER))
    except FileNotFoundError:
        if not create:
            raise CaseBaseError(f"no case base at {path}") from None
        if not path.parent.is_dir():
            raise CaseBaseError(f"cannot create case base {path}: "
                                f"folder {path.parent} does not exist") from None
        return True
    except IsADirectoryError:
        raise CaseBaseError(f"{path} is a folder, not a case base") from None
    except OSError as exc:
        raise CaseBaseError(f"cannot read {path}: {exc.strerror}") from exc
    if not header:
        if not create:
            raise CaseBaseError(f"no case base at {path}: the file is empty")
        return True
    if header != HEADER:
        raise UnusableCaseBase(f"{path} is not a case base: not a SQLite database file")
    return False


def create_schema(conn: sqlite3.Connection) -> None:
    """Give a new, empty file the schema of a case base, at revision 0."""
    # another process may be creating the same file: whoever gets the write lock first
    # creates the schema, the other finds it there
    conn.execute("BEGIN IMMEDIATE")
    try:
        if conn.execute("PRAGMA application_id").fetchone()[0] == 0 and not conn.execute(
                "SELECT name FROM sqlite_master").fetchall():
            conn.execute(f"PRAGMA application_id = {APPLICATION_ID}")
            conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
            for statement in SCHEMA_STATEMENTS:
                conn.execute(statement)
            conn.execute("INSERT INTO meta (key, value) VALUES (?, '0')", (REVISION_KEY,))
        conn.execute("COMMIT")
    except BaseException:
        rollback(conn)
        raise


def migrate(conn: sqlite3.Connection, path: Path) -> None:
    """Bring a case base of an older schema version to this one, in one transaction that holds
    the write lock (of several processes opening it at once, one migrates, the others find it
    done). Anything else is left to :func:`validate`; a migration that fails changes nothing."""
    if conn.execute("PRAGMA application_id").fetchone()[0] != APPLICATION_ID:
        return
    if not 0 < conn.execute("PRAGMA user_version").fetchone()[0] < SCHEMA_VERSION:
        return
    conn.execute("BEGIN IMMEDIATE")
    try:
        version = conn.execute("PRAGMA user_version").fetchone()[0]
        while 0 < version < SCHEMA_VERSION:
            for statement in MIGRATIONS[version]:
                try:
                    conn.execute(statement)
                except sqlite3.OperationalError as exc:
                    raise UnusableCaseBase(
                        f"{path}: migrating the case base from schema version {version} to "
                        f"{version + 1} failed at {statement.split('(')[0].strip()!r}: {exc}; "
                        "nothing was changed") from exc
            version += 1
            conn.execute(f"PRAGMA user_version = {version}")
        conn.execute("COMMIT")
    except BaseException:
        rollback(conn)
        raise


def validate(conn: sqlite3.Connection, path: Path) -> None:
    """Refuse, with UnusableCaseBase naming ``path``, a file that is not a sound case base of
    this schema version."""
    application_id = conn.execute("PRAGMA application_id").fetchone()[0]
    if application_id != APPLICATION_ID:
        raise UnusableCaseBase(f"{path} is not a cbrcore case base: it is a SQLite "
                               f"database of another application (application_id "
                               f"{application_id:#x}, a case base has {APPLICATION_ID:#x})")
    version = conn.execute("PRAGMA user_version").fetchone()[0]
    if version != SCHEMA_VERSION:
        which = "a newer" if version > SCHEMA_VERSION else "an older"
        # a writing store migrated an older one before this check
        how = ": open it once for writing to migrate it" if version < SCHEMA_VERSION else ""
        raise UnusableCaseBase(f"{path} has case base schema version {version} (from "
                               f"{which} cbrcore); this cbrcore reads version "
                               f"{SCHEMA_VERSION}{how}")
    verdict = [row[0] for row in conn.execute("PRAGMA quick_check").fetchall()]
    if verdict != ["ok"]:
        raise UnusableCaseBase(f"{path} is corrupt: {'; '.join(verdict[:3])}")
    problems = schema_problems(conn)
    if problems:
        raise UnusableCaseBase(f"{path} is not a sound case base: "
                               f"{'; '.join(problems)} ({SCHEMA_EXPECTED})")


def schema_problems(conn: sqlite3.Connection) -> list[str]:
    """How the file's schema differs from a case base's.

    Anything added is refused, not only what is missing or changed: a trigger or a view runs
    or answers behind the store's back (a trigger deleting every inserted case would make an
    import report cases it never kept).
    """
    expected = case_base_schema()
    found = schema_of(conn)
    tables = {name for kind, name in found if kind == "table"}
    problems = []
    for (kind, name), (table, sql) in sorted(expected.items()):
        if (kind, name) not in found:
            # the indexes of a missing table, and SQLite's own objects, go with the table
            if table in tables and not name.startswith("sqlite_"):
                problems.append(f"{kind} {name} is missing")
        elif found[kind, name][1] != sql:
            problems.append(f"{kind} {name} is not defined as in a case base")
    problems[:0] = [f"table {name} is missing" for name in ("cases", "meta", "removed")
                    if name not in tables]
    # ANALYZE's statistics only guide SQLite's query planner: they cannot act or answer
    problems += [f"{kind} {name!r} does not belong in a case base"
                 for kind, name in sorted(found.keys() - expected.keys())
                 if not (kind == "table" and name.startswith("sqlite_stat"))]
    return problems


def rollback(conn: sqlite3.Connection) -> None:
    """Roll back the transaction under way, if any, whatever went wrong."""
    # the error that got us here says more than a failed rollback would, and SQLite rolls
    # back by itself when it cannot go on
    with contextlib.suppress(sqlite3.Error):
        if conn.in_transaction:
            conn.execute("ROLLBACK")
