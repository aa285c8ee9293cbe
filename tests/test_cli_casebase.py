"""The ``casebase`` sub-commands: info, check, export and import."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner, Result

from cbrcore.casebase import SQLiteStore
from cbrcore.cli.casebase import app as casebase_app
from cbrcore.errors import CaseBaseError
from cbrcore.model import Case


def run(*args: str | Path) -> Result:
    return CliRunner().invoke(casebase_app, [str(a) for a in args])


@pytest.fixture
def casebase(tmp_path: Path) -> Path:
    path = tmp_path / "cb.sqlite"
    with SQLiteStore(path) as store:
        with store.transaction():
            store.add(Case({"start": [0, 0]}, [[0, 0], [0, 1]]))
            store.add(Case("v", None, kind="vertex"))
            store.add(Case("w", None, kind="vertex"))
        store.touch([1])
        store.set_meta("grid", {"size": 8})
    return path


def test_info(casebase: Path) -> None:
    result = run("info", casebase)
    assert result.exit_code == 0, result.output
    assert "revision      3" in result.output
    assert "cases         3" in result.output
    assert "  vertex      2" in result.output
    assert "journal mode  wal" in result.output
    facts = json.loads(run("info", casebase, "--json").output)
    assert facts["kinds"] == {"case": 1, "vertex": 2}
    assert (facts["schema"], facts["revision"], facts["cases"]) == (1, 3, 3)
    assert facts["size_bytes"] == casebase.stat().st_size


def test_info_on_a_missing_file_creates_nothing(tmp_path: Path) -> None:
    result = run("info", tmp_path / "none.sqlite")
    assert isinstance(result.exception, CaseBaseError)
    assert "no case base at" in str(result.exception)
    assert list(tmp_path.iterdir()) == []


def test_check_a_sound_case_base(casebase: Path) -> None:
    result = run("check", casebase)
    assert (result.exit_code, result.output) == (0, "ok\n")


def test_check_lists_problems(casebase: Path) -> None:
    connection = sqlite3.connect(casebase)
    connection.execute("UPDATE cases SET uses = -1 WHERE id = 2")
    connection.execute("UPDATE cases SET solution = 'nope' WHERE id = 3")
    connection.commit()
    connection.close()
    result = run("check", casebase)
    assert result.exit_code == 1
    assert f"{casebase}: 2 problems:" in result.output
    assert "  - case 2: uses: expected a non-negative integer, got -1" in result.output
    assert "  - case 3: solution: not valid JSON" in result.output


@pytest.mark.parametrize(("content", "reason"), [
    (b"not a database at all", "is not a case base: not a SQLite database file"),
    (b"SQLite format 3\x00" + b"\x00" * 100, "is corrupt"),
])
def test_check_explains_a_file_it_cannot_use(tmp_path: Path, content: bytes, reason: str) -> None:
    path = tmp_path / "cb.sqlite"
    path.write_bytes(content)
    result = run("check", path)
    assert result.exit_code == 1
    assert f"{path} {reason}" in result.output
    assert path.read_bytes() == content


def test_check_a_missing_file(tmp_path: Path) -> None:
    result = run("check", tmp_path / "none.sqlite")
    assert isinstance(result.exception, CaseBaseError)
    assert not (tmp_path / "none.sqlite").exists()


def test_export_to_standard_output(casebase: Path) -> None:
    result = run("export", casebase)
    assert result.exit_code == 0, result.output
    data = yaml.safe_load(result.output)
    assert (data["format"], data["revision"], len(data["cases"])) == ("cbrcore-casebase", 3, 3)
    assert data["meta"] == {"grid": {"size": 8}}
    data = json.loads(run("export", casebase, "--format", "json").output)
    assert data["cases"][0]["uses"] == 1


def test_export_to_a_file_and_import_it(casebase: Path, tmp_path: Path) -> None:
    exported = tmp_path / "cb.json"
    result = run("export", casebase, "-o", exported)
    assert result.exit_code == 0, result.output
    assert json.loads(exported.read_text())["revision"] == 3
    copy = tmp_path / "copy.sqlite"
    result = run("import", copy, exported)
    assert result.exit_code == 0, result.output
    assert f"imported 3 cases into {copy} (revision 3)" in result.output
    with SQLiteStore(casebase) as original, SQLiteStore(copy) as imported:
        assert imported.cases() == original.cases()
        assert imported.meta_items() == original.meta_items()


def test_export_needs_a_known_extension_or_format(casebase: Path, tmp_path: Path) -> None:
    result = run("export", casebase, "-o", tmp_path / "cb.txt")
    assert isinstance(result.exception, CaseBaseError)
    assert "cannot tell the format" in str(result.exception)
    result = run("export", casebase, "-o", tmp_path / "cb.txt", "--format", "yaml")
    assert result.exit_code == 0
    assert yaml.safe_load((tmp_path / "cb.txt").read_text())["revision"] == 3


def test_import_refuses_a_case_base_with_cases_unless_appending(casebase: Path,
                                                                tmp_path: Path) -> None:
    exported = tmp_path / "cb.yaml"
    run("export", casebase, "-o", exported)
    result = run("import", casebase, exported)
    assert isinstance(result.exception, CaseBaseError)
    assert "already holds 3 cases" in str(result.exception)
    result = run("import", casebase, exported, "--append")
    assert result.exit_code == 0, result.output
    with SQLiteStore(casebase) as store:
        assert (store.count(), store.revision) == (6, 4)


def test_a_bad_document_leaves_no_case_base_behind(tmp_path: Path) -> None:
    document = tmp_path / "bad.yaml"
    document.write_text("format: cbrcore-casebase\nschema: 1\ncases:\n- {problem: 1, kind: 3}\n")
    target = tmp_path / "cb.sqlite"
    result = run("import", target, document)
    assert isinstance(result.exception, CaseBaseError)
    assert "cases[0].kind: expected a non-empty string" in str(result.exception)
    assert "cases[0].solution: required key is missing" in str(result.exception)
    assert not target.exists()


def test_no_command_shows_help() -> None:
    result = run()
    assert "info" in result.output
    assert "import" in result.output
