"""Case bases and files the process may not write: ``cbr casebase info``, ``check`` and ``export``
read a SQLite case base in a read-only folder or file, and an export never replaces a read-only
file.

The permissions are real: the commands run in a process that lacks them. A superuser ignores
file permissions, so when the tests run as root the commands run in a forked child that has
become the unprivileged user ``nobody`` (after every module it needs was imported, since the
interpreter may live where that user cannot read).
"""

from __future__ import annotations

import json
import os
import pwd
import shutil
import stat
import tempfile
import traceback
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from cbr_stores.sqlite import SQLiteStore
from cbrcore.model import Case
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult

Cli = Callable[..., CliResult]


def _unprivileged(invoke_cbr: Cli, *args: str) -> CliResult:
    """``invoke_cbr(*args)`` run without a superuser's disregard for file permissions."""
    if os.geteuid() != 0:
        return invoke_cbr(*args)
    try:
        nobody = pwd.getpwnam("nobody")
    except KeyError:
        pytest.skip("running as root, and there is no user 'nobody' to run without privileges")
    reading, writing = os.pipe()
    child = os.fork()
    if child == 0:  # pragma: no cover - the child reports through the pipe and never returns
        code = 1
        try:
            os.close(reading)
            os.setgroups([])
            os.setgid(nobody.pw_gid)
            os.setuid(nobody.pw_uid)
            with os.fdopen(writing, "w") as out:
                try:
                    json.dump(list(invoke_cbr(*args)), out)
                    code = 0
                except BaseException:
                    json.dump([-1, "", traceback.format_exc()], out)
        finally:
            os._exit(code)
    os.close(writing)
    with os.fdopen(reading) as received:
        text = received.read()
    _, status = os.waitpid(child, 0)
    result = CliResult(*json.loads(text))
    assert os.waitstatus_to_exitcode(status) == 0, result.stderr
    return result


def _case_base(path: Path) -> None:
    with SQLiteStore(path) as store:
        store.add(Case({"start": [0, 0]}, {"path": [[0, 0], [1, 1]]}, "trip"))
        store.add(Case({"start": [2, 2]}, {"path": [[2, 2]]}, "trip"))


@pytest.fixture
def place() -> Iterator[Path]:
    """A folder of the test's own that an unprivileged user may enter (pytest's temporary
    folders are in one that only their owner may)."""
    folder = Path(tempfile.mkdtemp(prefix="cbr-read-only-"))
    folder.chmod(0o755)
    try:
        yield folder
    finally:
        shutil.rmtree(folder)


@pytest.fixture(autouse=True)
def installed(cbr_plugins: Callable[..., Plugins], invoke_cbr: Cli, tmp_path: Path) -> Plugins:
    """The installed plugins, with every module the commands use imported already."""
    plugins = cbr_plugins(entry_points=True)
    _case_base(tmp_path / "warm.sqlite")
    for command in ("info", "check", "export"):
        assert invoke_cbr("casebase", command, str(tmp_path / "warm.sqlite")).exit_code == 0
    assert invoke_cbr("casebase", "info", str(tmp_path / "missing.sqlite")).exit_code == 2
    return plugins


@pytest.mark.parametrize("locked", ["folder", "file", "both"])
def test_a_case_base_that_may_not_be_written_is_read(invoke_cbr: Cli, place: Path,
                                                      locked: str) -> None:
    folder = place / "library"
    folder.mkdir()
    path = folder / "cb.sqlite"
    _case_base(path)
    assert sorted(os.listdir(folder)) == ["cb.sqlite"]  # WAL mode, closed cleanly
    if locked in ("file", "both"):
        path.chmod(0o444)
    folder.chmod(0o555 if locked in ("folder", "both") else 0o777)
    try:
        info = _unprivileged(invoke_cbr, "casebase", "info", str(path), "--json")
        check = _unprivileged(invoke_cbr, "casebase", "check", str(path))
        export = _unprivileged(invoke_cbr, "casebase", "export", str(path))
    finally:
        folder.chmod(0o755)

    assert info.exit_code == 0, info
    facts = json.loads(info.stdout)
    assert (facts["cases"], facts["revision"], facts["kinds"]) == (2, 2, {"trip": 2})
    assert check.exit_code == 0 and check.stdout == "ok\n", check
    assert export.exit_code == 0, export
    assert "revision: 2" in export.stdout and export.stdout.count("kind: trip") == 2
    # reading left nothing beside the case base
    assert sorted(os.listdir(folder)) == ["cb.sqlite"]


def test_an_export_never_replaces_a_read_only_file(invoke_cbr: Cli, place: Path) -> None:
    tmp_path = place
    tmp_path.chmod(0o777)
    _case_base(tmp_path / "cb.sqlite")
    target = tmp_path / "reviewed.yaml"
    target.write_text("kept: as it was\n", encoding="utf-8")
    target.chmod(0o444)

    result = _unprivileged(invoke_cbr, "casebase", "export", str(tmp_path / "cb.sqlite"),
                           "-o", str(target))

    assert result.exit_code == 2, result
    assert "Traceback" not in result.stderr
    assert f"cannot write {target}: the file is read-only; it is not replaced" in result.stderr
    assert target.read_text(encoding="utf-8") == "kept: as it was\n"
    assert stat.S_IMODE(target.stat().st_mode) == 0o444
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cb.sqlite", "reviewed.yaml"]
