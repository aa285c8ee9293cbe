"""The SQLite store's promises about files: durability, sharing, and refusing what it cannot use."""

from __future__ import annotations

import os
import re
import signal
import sqlite3
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

import cbr_stores
import cbrcore
import cbrcore.builtins
from casebase.test_damage import damage
from cbr_stores.sqlite import SQLiteStore
from cbr_stores.sqlite_file import APPLICATION_ID, SCHEMA_VERSION
from cbrcore.casebase import Changes, UnusableCaseBase
from cbrcore.errors import CaseBaseError
from cbrcore.model import Case
from cbrcore.testing import CliResult

REPO = Path(cbrcore.__file__).resolve().parent.parent

WRITER = """
import sys
from cbr_stores.sqlite import SQLiteStore
from cbrcore.model import Case

store = SQLiteStore(sys.argv[1], busy_timeout=30)
for n in range(1, int(sys.argv[2]) + 1):
    with store.transaction():
        store.add(Case({"writer": sys.argv[3], "n": n}, list(range(50))))
        store.set_meta(sys.argv[3], n)
    print(n, flush=True)
"""


def writer(path: Path, count: int, name: str) -> subprocess.Popen[str]:
    """A child process adding ``count`` cases one transaction each, printing each commit."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH",
                                                                                   "")])}
    return subprocess.Popen([sys.executable, "-c", WRITER, str(path), str(count), name],
                            stdout=subprocess.PIPE, text=True, env=env)


def named(path: Path, rest: str) -> str:
    """A pattern for a message starting with ``path``."""
    return re.escape(str(path)) + rest


@pytest.fixture
def casebase(tmp_path: Path) -> Path:
    """A closed case base file holding a few hundred cases (several pages of them)."""
    path = tmp_path / "cb.sqlite"
    with SQLiteStore(path) as store, store.transaction():
        for n in range(300):
            kind = "vertex" if n % 2 else "case"
            store.add(Case({"n": n, "pad": "x" * 40}, [n, n + 1], kind=kind))
    return path


@pytest.fixture
def unchanged() -> Iterator[Callable[[Path], None]]:
    """``unchanged(path)`` records a file's bytes; the test fails if they differ at its end."""
    recorded: dict[Path, bytes] = {}
    yield lambda path: recorded.setdefault(path, path.read_bytes())
    for path, content in recorded.items():
        assert path.read_bytes() == content, f"{path} was modified"


def test_a_killed_writer_loses_no_committed_case(tmp_path: Path) -> None:
    path = tmp_path / "cb.sqlite"
    child = writer(path, 1_000_000, "w")
    assert child.stdout is not None
    last = 0
    for line in child.stdout:
        last = int(line)
        if last >= 150:
            break
    child.send_signal(signal.SIGKILL)
    child.wait()
    assert child.returncode == -signal.SIGKILL
    with SQLiteStore(path, create=False) as store:
        assert store.check() == []
        count = store.count()
        assert count >= last
        assert store.get_meta("w") == count
        assert [c.problem["n"] for c in store.cases()] == list(range(1, count + 1))
        assert store.revision == count


def test_two_processes_writing_at_once_lose_nothing(tmp_path: Path) -> None:
    path = tmp_path / "cb.sqlite"
    children = [writer(path, 100, name) for name in ("a", "b")]
    for child in children:
        out, _ = child.communicate(timeout=60)
        assert child.returncode == 0
        assert out.split()[-1] == "100"
    with SQLiteStore(path, create=False) as store:
        assert store.count() == 200
        assert store.revision == 200
        assert store.meta_items() == {"a": 100, "b": 100}
        for name in ("a", "b"):
            numbers = [c.problem["n"] for c in store.cases() if c.problem["writer"] == name]
            assert numbers == list(range(1, 101))
        assert store.check() == []


def test_a_new_file_is_a_wal_case_base(tmp_path: Path) -> None:
    path = tmp_path / "cb.sqlite"
    with SQLiteStore(path) as store:
        assert (store.journal_mode, store.schema_version) == ("wal", SCHEMA_VERSION)
    connection = sqlite3.connect(path)
    assert connection.execute("PRAGMA application_id").fetchone()[0] == APPLICATION_ID
    connection.close()
    with SQLiteStore(path, create=False) as store:
        assert store.revision == 0


def test_a_missing_file_is_created_only_when_asked(tmp_path: Path) -> None:
    path = tmp_path / "cb.sqlite"
    with pytest.raises(CaseBaseError, match=f"no case base at {path}"):
        SQLiteStore(path, create=False)
    assert not path.exists()
    with pytest.raises(CaseBaseError, match=r"folder .*nowhere does not exist"):
        SQLiteStore(tmp_path / "nowhere" / "cb.sqlite")
    with pytest.raises(CaseBaseError, match="is a folder"):
        SQLiteStore(tmp_path)


def test_an_empty_file_is_new_only_when_creating(tmp_path: Path) -> None:
    path = tmp_path / "cb.sqlite"
    path.touch()
    with pytest.raises(CaseBaseError, match=f"no case base at {path}: the file is empty"):
        SQLiteStore(path, create=False)
    assert path.stat().st_size == 0
    with SQLiteStore(path) as store:
        store.add(Case(1, 1))
    with SQLiteStore(path, create=False) as store:
        assert store.count() == 1


@pytest.mark.parametrize("content", [b"garbage " * 100, b"short",
                                     b"SQLite format 3\x00" + b"\xff" * 200])
def test_a_file_that_is_no_database_is_refused(tmp_path: Path, content: bytes,
                                               unchanged: Callable[[Path], None]) -> None:
    path = tmp_path / "cb.sqlite"
    path.write_bytes(content)
    unchanged(path)
    with pytest.raises(UnusableCaseBase, match=named(path, " is (not a case base|corrupt)")):
        SQLiteStore(path)


def test_a_corrupted_case_base_is_refused(casebase: Path,
                                          unchanged: Callable[[Path], None]) -> None:
    data = bytearray(casebase.read_bytes())
    middle = len(data) // 2 // 4096 * 4096
    data[middle:middle + 4096] = os.urandom(4096)
    casebase.write_bytes(data)
    unchanged(casebase)
    with pytest.raises(UnusableCaseBase, match=named(casebase, " is corrupt")):
        SQLiteStore(casebase)


def test_a_foreign_sqlite_file_is_refused(tmp_path: Path,
                                          unchanged: Callable[[Path], None]) -> None:
    path = tmp_path / "other.db"
    connection = sqlite3.connect(path)
    connection.execute("CREATE TABLE things (x)")
    connection.commit()
    connection.close()
    unchanged(path)
    with pytest.raises(UnusableCaseBase, match=named(path, " is not a cbrcore case base")):
        SQLiteStore(path)


def test_another_schema_version_is_refused(casebase: Path,
                                           unchanged: Callable[[Path], None]) -> None:
    connection = sqlite3.connect(casebase)
    connection.execute("PRAGMA user_version = 7")
    connection.close()
    unchanged(casebase)
    with pytest.raises(UnusableCaseBase, match=named(
            casebase, r" has case base schema version 7 \(from a newer cbrcore\); "
                      rf"this cbrcore reads version {SCHEMA_VERSION}")):
        SQLiteStore(casebase)


VERSION_1 = (
    "PRAGMA application_id = 1128419907",
    "PRAGMA user_version = 1",
    """CREATE TABLE cases (
        id INTEGER PRIMARY KEY AUTOINCREMENT, kind TEXT NOT NULL, problem TEXT NOT NULL,
        solution TEXT NOT NULL, meta TEXT NOT NULL, uses INTEGER NOT NULL,
        created INTEGER NOT NULL, last_used INTEGER)""",
    "CREATE INDEX cases_kind ON cases (kind)",
    "CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
    "INSERT INTO meta VALUES ('cbrcore.revision', '5'), ('grid', '{\"width\":3}')",
    # case 2 was removed (AUTOINCREMENT remembers it); case 3 was used at revision 5
    """INSERT INTO cases VALUES (1, 'segment', '{"a":1}', '[1]', '{}', 0, 1, NULL),
                               (3, 'segment', '{"a":3}', '[3]', '{}', 2, 3, 5)""",
    "UPDATE sqlite_sequence SET seq = 4 WHERE name = 'cases'",
)
"""A case base as cbrcore wrote schema version 1."""


def version_1(path: Path) -> None:
    damage(path, *VERSION_1)


def test_a_case_base_of_schema_version_1_is_migrated(tmp_path: Path) -> None:
    path = tmp_path / "old.sqlite"
    version_1(path)
    with SQLiteStore(path) as store:
        assert store.schema_version == SCHEMA_VERSION == 2
        assert store.check() == []
        assert [(c.id, c.uses, c.created, c.last_used) for c in store.cases()] == [
            (1, 0, 1, None), (3, 2, 3, 5)]
        assert (store.revision, store.get_meta("grid")) == (5, {"width": 3})
        # what changed is known from each case's creation or last use on
        assert [c.id for c in store.changes(2).cases] == [3]
        store.remove([1])
        assert store.changes(5).removed == (1,)
        assert store.add(Case(5, 5)).id == 5  # ids of removed cases are still never reused
    with SQLiteStore(path) as again:
        assert again.check() == [] and again.schema_version == SCHEMA_VERSION


def test_a_case_base_of_an_older_version_is_not_migrated_for_reading(
        tmp_path: Path, unchanged: Callable[[Path], None]) -> None:
    path = tmp_path / "old.sqlite"
    version_1(path)
    unchanged(path)
    with pytest.raises(UnusableCaseBase, match=named(
            path, r" has case base schema version 1 \(from an older cbrcore\); this cbrcore "
                  r"reads version 2: open it once for writing to migrate it")):
        SQLiteStore(path, read_only=True)


def test_a_write_locked_case_base_times_out(casebase: Path,
                                            unchanged: Callable[[Path], None]) -> None:
    unchanged(casebase)
    other = sqlite3.connect(casebase, isolation_level=None)
    other.execute("BEGIN EXCLUSIVE")
    try:
        with SQLiteStore(casebase, busy_timeout=0.05) as store:
            assert store.count() == 300
            with pytest.raises(CaseBaseError, match=named(casebase, " is locked by another")):
                store.add(Case(1, 1))
            assert store.count() == 300
    finally:
        other.close()


def test_an_exclusively_locked_case_base_cannot_be_opened(
        casebase: Path, unchanged: Callable[[Path], None]) -> None:
    unchanged(casebase)
    other = sqlite3.connect(casebase, isolation_level=None)
    other.execute("PRAGMA locking_mode = EXCLUSIVE")
    other.execute("BEGIN EXCLUSIVE")
    try:
        with pytest.raises(CaseBaseError, match=named(casebase, " is locked by another process")):
            SQLiteStore(casebase, busy_timeout=0.05)
    finally:
        other.close()


def test_check_reports_damaged_cases(casebase: Path) -> None:
    connection = sqlite3.connect(casebase)
    connection.execute("UPDATE cases SET problem = '{broken' WHERE id = 3")
    connection.execute("UPDATE cases SET uses = -2, created = 999 WHERE id = 4")
    connection.execute("UPDATE cases SET last_used = 1000 WHERE id = 5")
    connection.execute("UPDATE meta SET value = 'x' WHERE key = 'grid'")
    connection.execute("INSERT INTO meta VALUES ('grid', '[1,')")
    connection.commit()
    connection.close()
    with SQLiteStore(casebase) as store:
        problems = store.check()
        with pytest.raises(UnusableCaseBase, match="case 3 cannot be decoded"):
            store.get(3)
    assert problems[0].startswith("case 3: problem: not valid JSON")
    assert problems[1:] == [
        "case 4: uses: expected a non-negative integer, got -2",
        "case 4: created: revision 999 is after the case base's revision 1",
        "case 5: last_used: revision 1000 is after the case base's revision 1",
        problems[-1],
    ]
    assert problems[-1].startswith("meta key 'grid': not valid JSON")


# -- files written by earlier code ----------------------------------------------------------

SCHEMA_2_FILE = REPO / "tests" / "data" / "casebases" / "sqlite-schema2.sqlite"
"""A case base written by the stores of schema version 2 before they became a plugin: two cases
of kind ``route`` (the second removed), two of kind ``behavior``, and two meta values, in six
revisions."""


def test_a_case_base_file_of_earlier_code_opens_unchanged(
        tmp_path: Path, cbr_plugins: Callable[..., object],
        invoke_cbr: Callable[..., CliResult]) -> None:
    path = tmp_path / "cb.sqlite"
    path.write_bytes(SCHEMA_2_FILE.read_bytes())

    with SQLiteStore(path, create=False) as store:
        assert (store.revision, store.schema_version) == (6, 2)
        assert [(c.id, c.kind, c.problem, c.solution, c.meta, c.uses, c.created, c.last_used)
                for c in store.cases()] == [
            (1, "route", {"start": [0, 0], "goal": [3, 4]}, {"path": [[0, 0], [1, 1], [3, 4]]},
             {}, 1, 1, 3),
            (3, "behavior", {"situation": "corridor"}, {"behavior": "follow_wall"}, {}, 1, 2, 3),
            (4, "behavior", {"situation": "open"}, {"behavior": "go_to_goal"}, {}, 2, 5, None)]
        assert store.meta_items() == {"note": "written by schema version 2",
                                      "world": {"name": "depot", "sha256": "0" * 64}}
        assert store.changes(3) == Changes(3, 6, (store.get(4),), (2,))
        assert store.check() == []

    cbr_plugins(("core", cbrcore.builtins), ("stores", cbr_stores))
    result = invoke_cbr("casebase", "check", str(path))
    assert (result.exit_code, result.stdout) == (0, "ok\n")
    # it stays a case base this code writes to: ids go on after the largest ever given
    with SQLiteStore(path) as store:
        assert store.add(Case("later", None)).id == 5
        assert store.revision == 7


def test_a_sqlite_library_too_old_for_the_store_is_named(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sqlite3, "sqlite_version_info", (3, 22, 0))
    monkeypatch.setattr(sqlite3, "sqlite_version", "3.22.0")
    with pytest.raises(CaseBaseError, match=r"Python uses SQLite 3\.22\.0, and the sqlite store "
                                            r"needs 3\.24 or later"):
        SQLiteStore(tmp_path / "cb.sqlite")
    assert not (tmp_path / "cb.sqlite").exists()
