"""Case bases that are damaged, hostile or out of reach: each is one clear message naming the file,
the documented exit code, no traceback, and no file left half written."""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import sqlite3
import subprocess
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

import cbr_stores
import cbrcore.builtins
import cbrcore.files
from cbr_stores.sqlite import SQLiteStore
from cbr_stores.sqlite_file import MAX_ID, SCHEMA_VERSION
from cbrcore.casebase import UnusableCaseBase
from cbrcore.errors import CaseBaseError
from cbrcore.model import Case
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult

Cli = Callable[..., CliResult]

DOCUMENT = "format: cbrcore-casebase\nschema: 1\ncases:\n- {problem: 1, solution: 2}\n"


@pytest.fixture(autouse=True)
def core(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    """cbrcore's own stores, and no other plugin."""
    return cbr_plugins(("core", cbrcore.builtins), ("stores", cbr_stores))


@pytest.fixture
def casebase(tmp_path: Path) -> Path:
    """A sound case base of two cases and a meta value, in a folder of its own."""
    path = tmp_path / "cb" / "cb.sqlite"
    path.parent.mkdir()
    with SQLiteStore(path) as store:
        with store.transaction():
            store.add(Case(1, 1))
            store.add(Case(2, 4))
        store.set_meta("grid", {"size": 8})
    return path


def damage(path: Path, *statements: str) -> None:
    """Change the case base behind its store's back, as another program could."""
    connection = sqlite3.connect(path, isolation_level=None)
    try:
        for statement in statements:
            connection.execute(statement)
    finally:
        connection.close()


def no_tables(path: Path) -> None:
    """A file marked as a case base, of this schema version, without any table."""
    path.unlink()
    damage(path, "PRAGMA application_id = 1128419907", f"PRAGMA user_version = {SCHEMA_VERSION}")


def folder_state(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


DAMAGES: dict[str, Callable[[Path], None]] = {
    "revision-beyond-int64": lambda p: damage(
        p, f"UPDATE meta SET value = '{2**63}' WHERE key = 'cbrcore.revision'"),
    "revision-not-a-number": lambda p: damage(
        p, "UPDATE meta SET value = 'x' WHERE key = 'cbrcore.revision'"),
    "meta-not-json": lambda p: damage(p, "UPDATE meta SET value = '{bad' WHERE key = 'grid'"),
    "no-tables": no_tables,
    "cases-dropped": lambda p: damage(p, "DROP TABLE cases"),
    "last-id-taken": lambda p: damage(p, f"UPDATE cases SET id = {MAX_ID} WHERE id = 2"),
    "trigger": lambda p: damage(
        p, "CREATE TRIGGER hide AFTER INSERT ON cases BEGIN DELETE FROM cases; END"),
    "view": lambda p: damage(p, "CREATE VIEW everything AS SELECT * FROM cases"),
    "extra-index": lambda p: damage(p, "CREATE INDEX by_uses ON cases (uses)"),
}

MISSING = "table cases is missing"
SCHEMA = ("a case base has the tables cases, meta and removed, the indexes cases_kind, "
          "cases_changed and removed_revision and no other")


@pytest.mark.parametrize(("damaged", "command", "code", "message"), [
    ("revision-not-a-number", "export", 2,
     f"is corrupt: its revision record is 'x', expected an integer from 0 to {MAX_ID}"),
    ("revision-not-a-number", "info", 2, "is corrupt: its revision record is 'x'"),
    ("revision-not-a-number", "check", 1, f"revision: expected an integer from 0 to {MAX_ID}, "
                                          "got 'x'"),
    ("revision-beyond-int64", "info", 2, f"its revision record is '{2**63}'"),
    ("revision-beyond-int64", "check", 1, f"revision: expected an integer from 0 to {MAX_ID}, "
                                          f"got '{2**63}'"),
    ("meta-not-json", "export", 2, "is corrupt: meta key 'grid' cannot be decoded"),
    ("meta-not-json", "check", 1, "meta key 'grid': not valid JSON"),
    ("no-tables", "info", 2, f"is not a sound case base: {MISSING}; table meta is missing; "
                             f"table removed is missing ({SCHEMA}"),
    ("no-tables", "check", 1, f"{MISSING}; table meta is missing; table removed is missing"),
    ("no-tables", "export", 2, MISSING),
    ("cases-dropped", "info", 2, f"is not a sound case base: {MISSING} ({SCHEMA}"),
    ("cases-dropped", "check", 1, MISSING),
    ("cases-dropped", "export", 2, MISSING),
    ("cases-dropped", "import", 2, MISSING),
    ("last-id-taken", "import", 2, f"has used every case id: ids are never reused, and the "
                                   f"largest, {MAX_ID}, is taken"),
    ("trigger", "import", 2, "is not a sound case base: trigger 'hide' does not belong in a "
                             "case base"),
    ("trigger", "check", 1, "trigger 'hide' does not belong in a case base"),
    ("view", "check", 1, "view 'everything' does not belong in a case base"),
    ("view", "info", 2, "view 'everything' does not belong in a case base"),
    ("extra-index", "check", 1, "index 'by_uses' does not belong in a case base"),
])
def test_a_bad_case_base_is_one_clear_message(invoke_cbr: Cli, casebase: Path, tmp_path: Path,
                                              damaged: str, command: str, code: int,
                                              message: str) -> None:
    DAMAGES[damaged](casebase)
    document = tmp_path / "doc.yaml"
    document.write_text(DOCUMENT, encoding="utf-8")
    before = folder_state(casebase.parent)
    args = [str(document), "--append"] if command == "import" else []

    result = invoke_cbr("casebase", command, str(casebase), *args)

    assert result.exit_code == code, result
    # check reports on standard output, every error goes to standard error
    shown = result.stdout if code == 1 else result.stderr
    assert shown.startswith(str(casebase) if code == 1 else f"error: {casebase}"), shown
    assert message in shown
    assert "Traceback" not in result.stdout + result.stderr
    assert folder_state(casebase.parent) == before


def test_traceback_shows_where_the_error_came_from(invoke_cbr: Cli, casebase: Path) -> None:
    DAMAGES["cases-dropped"](casebase)

    result = invoke_cbr("--traceback", "casebase", "info", str(casebase))

    assert result.exit_code == 2
    assert "Traceback" in result.stderr and "UnusableCaseBase" in result.stderr


def test_a_case_base_changed_after_opening_is_reported_by_check(casebase: Path) -> None:
    with SQLiteStore(casebase) as store:
        DAMAGES["trigger"](casebase)
        assert store.check() == ["schema: trigger 'hide' does not belong in a case base"]
        DAMAGES["cases-dropped"](casebase)
        with pytest.raises(UnusableCaseBase, match=f"{casebase} is not a sound case base: "
                                                   f"no such table: cases"):
            store.count()


def test_the_id_overflow_leaves_the_case_base_usable(casebase: Path) -> None:
    DAMAGES["last-id-taken"](casebase)
    with SQLiteStore(casebase) as store:
        with pytest.raises(CaseBaseError, match="has used every case id"), store.transaction():
            store.set_meta("before", 1)
            store.add(Case(3, 9))
        assert (store.count(), store.meta_items(), store.revision) == (
            2, {"grid": {"size": 8}}, 2)
        assert store.check() == []


def test_a_nested_failure_sqlite_rolled_back_keeps_nothing_of_the_outer_block(
        casebase: Path) -> None:
    DAMAGES["last-id-taken"](casebase)
    with SQLiteStore(casebase) as store:
        with pytest.raises(CaseBaseError, match="rolled back by SQLite"), store.transaction():
            with contextlib.suppress(CaseBaseError), store.transaction():
                store.add(Case(3, 9))  # no id left: SQLite rolls the whole transaction back
            store.set_meta("after", 1)  # would commit on its own
        assert (store.meta_items(), store.revision) == ({"grid": {"size": 8}}, 2)
        assert store.check() == []


def test_a_case_base_at_the_largest_revision_takes_no_more_writes(casebase: Path) -> None:
    damage(casebase, f"UPDATE meta SET value = '{MAX_ID}' WHERE key = 'cbrcore.revision'")
    with SQLiteStore(casebase) as store:
        with pytest.raises(CaseBaseError, match="has reached the largest revision"):
            store.set_meta("more", 1)
        assert store.revision == MAX_ID and store.check() == []


def test_statistics_of_the_query_planner_are_no_foreign_schema(casebase: Path) -> None:
    damage(casebase, "ANALYZE")
    with SQLiteStore(casebase) as store:
        assert store.check() == [] and store.count() == 2


# -- a run ------------------------------------------------------------------------------------


def test_a_run_on_an_unusable_case_base_names_it_not_a_plugin(
        load_toy: Callable[..., Plugins], invoke_cbr: Cli, casebase: Path, tmp_path: Path) -> None:
    import toy_domain

    load_toy()
    DAMAGES["cases-dropped"](casebase)
    config = tmp_path / "toy.yaml"
    config.write_text(toy_domain.TOY_CONFIG.replace(
        "casebase: memory", f"casebase: {{use: sqlite, path: {casebase}}}"), encoding="utf-8")
    before = folder_state(casebase.parent)

    result = invoke_cbr("run", str(config), "--out", str(tmp_path / "out"))

    assert result.exit_code == 2, result
    assert f"{casebase} is not a sound case base: {MISSING}" in result.stderr
    assert "plugin" not in result.stderr and "Traceback" not in result.stderr
    assert folder_state(casebase.parent) == before


# -- files written whole or not at all --------------------------------------------------------


def test_a_full_disk_keeps_the_earlier_export(invoke_cbr: Cli, casebase: Path, tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    exported = tmp_path / "out.yaml"
    assert invoke_cbr("casebase", "export", str(casebase), "-o", str(exported)).exit_code == 0
    earlier = folder_state(tmp_path / "cb"), exported.read_bytes()

    def full(fd: int) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(cbrcore.files.os, "fsync", full)
    with SQLiteStore(casebase) as store:
        store.add(Case(3, 9))
    result = invoke_cbr("casebase", "export", str(casebase), "-o", str(exported))

    assert result.exit_code == 2
    assert result.stderr == f"error: cannot write {exported}: No space left on device\n"
    assert exported.read_bytes() == earlier[1]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cb", "out.yaml"]


@pytest.mark.parametrize(("document", "message"), [
    # valid, but SQLite has no id left for the second case once the first took the last one
    (f"format: cbrcore-casebase\nschema: 1\ncases:\n- {{id: {MAX_ID}, problem: 1, "
     f"solution: 1}}\n- {{problem: 2, solution: 2}}\n", "has used every case id"),
])
def test_a_failed_import_leaves_no_case_base(invoke_cbr: Cli, tmp_path: Path, document: str,
                                             message: str) -> None:
    source = tmp_path / "doc.yaml"
    source.write_text(document, encoding="utf-8")
    target = tmp_path / "new.sqlite"

    result = invoke_cbr("casebase", "import", str(target), str(source))

    assert result.exit_code == 2, result
    assert result.stderr.startswith(f"error: {target} {message}"), result.stderr
    assert "Traceback" not in result.stderr
    assert [p.name for p in tmp_path.iterdir()] == ["doc.yaml"]


def test_an_import_into_an_empty_leftover_file_replaces_it(invoke_cbr: Cli, tmp_path: Path) -> None:
    source = tmp_path / "doc.yaml"
    source.write_text(DOCUMENT, encoding="utf-8")
    target = tmp_path / "new.sqlite"
    target.touch()  # what a process killed while creating a case base leaves behind

    result = invoke_cbr("casebase", "import", str(target), str(source))

    assert (result.exit_code, result.stdout) == (0, f"imported 1 cases into {target} "
                                                    f"(revision 1)\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["doc.yaml", "new.sqlite"]
    with SQLiteStore(target, create=False) as store:
        assert (store.count(), store.check()) == (1, [])


# -- reading where nothing may be written -----------------------------------------------------


@contextlib.contextmanager
def unwritable(folder: Path) -> Iterator[None]:
    """Make ``folder`` a folder no file can be created in, for as long as the block runs."""
    with contextlib.ExitStack() as undo:
        if os.geteuid() == 0:
            # root writes where permissions forbid it; only the immutable attribute stops it
            chattr = shutil.which("chattr")
            if chattr is None or subprocess.run([chattr, "+i", str(folder)],
                                                capture_output=True).returncode:
                pytest.skip("cannot make a folder unwritable for root here")
            undo.callback(subprocess.run, [chattr, "-i", str(folder)], check=True)
        else:
            undo.callback(folder.chmod, folder.stat().st_mode)
            folder.chmod(0o555)
        yield


@pytest.mark.parametrize("held_open", [False, True], ids=["closed", "open-elsewhere"])
@pytest.mark.parametrize(("command", "expected"), [
    ("info", "cases         2"),
    ("check", "ok"),
    ("export", "revision: 2"),
])
def test_reading_works_in_a_read_only_folder(invoke_cbr: Cli, casebase: Path, command: str,
                                             expected: str, held_open: bool) -> None:
    with contextlib.ExitStack() as stack:
        if held_open:  # another process has it open: its -wal and -shm files are there
            stack.enter_context(SQLiteStore(casebase)).count()
        before = folder_state(casebase.parent)
        with unwritable(casebase.parent):
            result = invoke_cbr("casebase", command, str(casebase))
        assert (result.exit_code, result.stderr) == (0, ""), result
        assert expected in result.stdout
        assert folder_state(casebase.parent) == before


def test_reading_leaves_no_files_beside_the_case_base(invoke_cbr: Cli, casebase: Path) -> None:
    for command in ("info", "check", "export"):
        assert invoke_cbr("casebase", command, str(casebase)).exit_code == 0
        assert [p.name for p in casebase.parent.iterdir()] == ["cb.sqlite"]


def test_a_read_only_store_writes_nothing(casebase: Path) -> None:
    before = casebase.read_bytes()
    with SQLiteStore(casebase, read_only=True) as store:
        assert store.journal_mode == "wal"
        with store.transaction():
            assert store.count() == 2
        with pytest.raises(CaseBaseError, match="is open for reading only"):
            store.add(Case(3, 9))
        assert (store.count(), store.revision) == (2, 2)
    assert casebase.read_bytes() == before
    missing = casebase.with_name("none.sqlite")
    with pytest.raises(CaseBaseError, match="no case base at"):
        SQLiteStore(missing, read_only=True)
    assert not missing.exists()


def test_an_export_follows_a_link_keeps_permissions_and_never_replaces_a_pipe(
        invoke_cbr: Cli, casebase: Path, tmp_path: Path) -> None:
    private = tmp_path / "private.yaml"
    private.write_text("old\n", encoding="utf-8")
    private.chmod(0o600)
    link = tmp_path / "link.yaml"
    link.symlink_to(private)
    pipe = tmp_path / "pipe.yaml"
    os.mkfifo(pipe)
    received: list[str] = []
    reader = threading.Thread(target=lambda: received.append(pipe.read_text(encoding="utf-8")))
    reader.start()

    for target in (link, pipe):
        assert invoke_cbr("casebase", "export", str(casebase), "-o", str(target)).exit_code == 0
    reader.join(timeout=30)

    assert link.is_symlink() and "format: cbrcore-casebase" in private.read_text()
    assert private.stat().st_mode & 0o777 == 0o600
    assert pipe.is_fifo() and "format: cbrcore-casebase" in received[0]


def test_an_import_onto_something_else_than_a_file_is_refused(invoke_cbr: Cli, tmp_path: Path
                                                               ) -> None:
    document = tmp_path / "one.json"
    document.write_text('{"format": "cbrcore-casebase", "schema": 1, "cases": '
                        '[{"problem": 1, "solution": 1}]}', encoding="utf-8")
    pipe = tmp_path / "pipe.sqlite"
    os.mkfifo(pipe)
    empty = tmp_path / "empty.sqlite"
    empty.touch()
    empty.chmod(0o600)

    refused = invoke_cbr("casebase", "import", str(pipe), str(document))
    imported = invoke_cbr("casebase", "import", str(empty), str(document))

    assert refused.exit_code == 2 and "is not a regular file" in refused.stderr
    assert pipe.is_fifo()
    assert imported.exit_code == 0, imported.stderr
    assert empty.stat().st_mode & 0o777 == 0o600 and empty.stat().st_size > 0
