"""PostgreSQL DSNs are never written or shown with their secrets.

A run's files (manifest, summary, results, trace) show a DSN with only its host, port, database
and user, in the configuration and in the recorded command line; an error about a DSN shows
none of its values, whichever field a password was typed into.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from cbrcore.config import config_from_text
from cbrcore.plugins import Plugins
from cbrcore.run import manifest
from cbrcore.testing import CliResult

pytest.importorskip("psycopg")

from cbr_stores.conninfo import MASK, masked_dsn
from cbr_stores.postgres import PostgresStore
from cbrcore.errors import CaseBaseError

Cli = Callable[..., CliResult]
PASSWORD = "s3cret-pw"


@pytest.mark.parametrize(("dsn", "shown"), [
    ("postgresql://robot:s3cret-pw@db:5433/cases?sslmode=require",
     "postgresql://robot:***@db:5433/cases?sslmode=***"),
    ("postgres://robot@db/cases", "postgres://robot@db/cases"),
    ("postgresql://robot:p%40ss@[::1]:5432/cases", "postgresql://robot:***@[::1]:5432/cases"),
    ("postgresql:///cases?host=/run/pg&password=s3cret-pw",
     "postgresql://:***@/cases?host=%2Frun%2Fpg"),
    ("host=db port=5433 dbname=cases user=robot password=s3cret-pw sslmode=require",
     "user=robot password=*** dbname=cases host=db port=5433 sslmode=***"),
    ("host=db options='-c search_path=s3cret-pw'", "host=db options=***"),
    ("host='/run/my pg' user=robot", "user=robot host='/run/my pg'"),
    ("host=db s3cret-pw", MASK),
    ("", ""),
], ids=["uri", "uri without password", "uri ipv6", "uri socket", "pairs", "options",
        "quoted host", "unreadable", "empty"])
def test_a_dsn_is_shown_without_the_values_of_secret_fields(dsn: str, shown: str) -> None:
    assert masked_dsn(dsn) == shown


@pytest.mark.parametrize("dsn", [
    f"host=/nowhere password={PASSWORD}",
    f"host=/nowhere sslmode={PASSWORD}",
    f"host=/nowhere port={PASSWORD}",
    f"host=/nowhere connect_timeout={PASSWORD}",
    f"host=/nowhere options={PASSWORD}",
    f"host=/nowhere/{PASSWORD}",
    f"host={PASSWORD}.invalid",
    f"host=db {PASSWORD}",
    f"host='db {PASSWORD}",
    f"postgresql://robot:{PASSWORD}@/cases?host=/nowhere",
    f"postgresql://db/cases?{PASSWORD}",
    f"postgresql://robot:{PASSWORD}@[::1/cases",
], ids=["password", "sslmode", "port", "connect_timeout", "options", "host folder", "host name",
        "bare word", "unterminated quote", "uri", "uri bare word", "uri bad host"])
def test_an_error_about_a_dsn_shows_none_of_its_values(dsn: str) -> None:
    with pytest.raises(CaseBaseError) as failed:
        PostgresStore(dsn)
    message = str(failed.value)
    assert PASSWORD not in message and "nowhere" not in message
    assert message.startswith(("cannot connect to schema cbrcore on the server of casebase dsn",
                               "casebase dsn: not a PostgreSQL connection string"))


def test_a_misspelt_field_is_named() -> None:
    with pytest.raises(CaseBaseError, match='invalid connection option "hots"'):
        PostgresStore("hots=db")


def test_the_manifest_masks_the_dsn_in_the_config_and_the_command(
        cbr_plugins: Callable[..., Plugins], monkeypatch: pytest.MonkeyPatch) -> None:
    plugins = cbr_plugins(entry_points=True)
    dsn = f"postgresql://robot:{PASSWORD}@db:5433/cases?sslmode=verify-full"
    override = f"casebase.dsn={dsn}"
    config = config_from_text("casebase: {use: postgres, schema: fleet}", plugins.registry,
                              [override])
    monkeypatch.setattr(sys, "argv", ["cbr", "run", "x.yaml", "--set", override,
                                      f"--set={override}",
                                      f"--set=casebase={{use: postgres, dsn: '{dsn}'}}"])

    written = json.dumps(manifest(config, plugins, seed=1))

    assert PASSWORD not in written and "verify-full" not in written
    shown = "postgresql://robot:***@db:5433/cases?sslmode=***"
    recorded = json.loads(written)
    assert recorded["config"]["casebase"]["dsn"] == shown
    assert recorded["command"][4:] == [f"casebase.dsn={shown}", f"--set=casebase.dsn={shown}",
                                       f"--set=casebase={{use: postgres, dsn: '{shown}'}}"]


def test_only_whole_values_are_masked(cbr_plugins: Callable[..., Plugins]) -> None:
    plugins = cbr_plugins(entry_points=True)
    config = config_from_text("casebase: {use: postgres, dsn: 'db'}", plugins.registry)
    # a DSN libpq cannot read shows as *** whole, but the word in a file name stays
    assert config.masked("db.yaml") == "db.yaml"
    assert config.masked("casebase.dsn=db") == "casebase.dsn=***"


def test_validate_shows_the_dsn_masked(invoke_cbr: Cli, cbr_plugins: Callable[..., Plugins],
                                       tmp_path: Path) -> None:
    cbr_plugins(entry_points=True)
    config = tmp_path / "run.yaml"
    config.write_text("casebase: {use: postgres}\n", encoding="utf-8")

    result = invoke_cbr("validate", str(config), "--json", "--set",
                     f"casebase.dsn=host=db password={PASSWORD}")

    assert result.exit_code == 0, result
    assert PASSWORD not in result.stdout + result.stderr
    assert json.loads(result.stdout)["resolved"]["casebase"]["dsn"] == "password=*** host=db"


def test_a_run_folder_holds_no_password(invoke_cbr: Cli, cbr_plugins: Callable[..., Plugins],
                                        postgres_database: str, tmp_path: Path,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    cbr_plugins(entry_points=True)
    config = tmp_path / "run.yaml"
    config.write_text("world: {use: generated, kind: office, width: 24, height: 24}\n"
                      "casebase: {use: postgres, schema: runs}\n"
                      "workload: {use: trips, count: 6}\n"
                      "retrieve: {use: casegraph, delta: 4}\n"
                      "reuse: {use: casegraph, connector: dijkstra}\n"
                      "solver: astar\nretain: [casegraph]\nobservers: [trace]\n",
                      encoding="utf-8")
    # trust authentication ignores the password, so the store connects with it
    dsn = f"{postgres_database} password={PASSWORD} application_name={PASSWORD}"
    out = tmp_path / "out"
    args = ["run", str(config), "--out", str(out), "--set", f"casebase.dsn={dsn}"]
    # the manifest records the command line the process was started with
    monkeypatch.setattr(sys, "argv", ["cbr", *args])

    result = invoke_cbr(*args)

    assert result.exit_code == 0, result
    assert PASSWORD not in result.stdout + result.stderr
    written = sorted(path for path in out.rglob("*") if path.is_file())
    assert {path.name for path in written} >= {"manifest.json", "summary.json", "results.csv",
                                                "trace.jsonl"}
    for path in written:
        assert PASSWORD.encode() not in path.read_bytes(), path
    recorded = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    assert "password=***" in recorded["config"]["casebase"]["dsn"]
    assert "password=***" in recorded["command"][-1]
