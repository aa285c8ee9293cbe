"""The PostgreSQL store: the store contract, its component, schema versions, checks, and
several processes writing into one case base on one server."""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import psycopg
import pytest
import yaml

import cbr_stores
import cbrcore.builtins
import toy_domain
from cbr_stores import postgres as postgres_module
from cbr_stores import postgres_schema
from cbr_stores.postgres import PostgresStore
from cbrcore.casebase import CaseStore, Changes, document_of, dump_document
from cbrcore.config import parse_config
from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.errors import CaseBaseError, ConfigError, UnusableCaseBase
from cbrcore.model import Case
from cbrcore.plugins import Plugins
from cbrcore.registry import Registry
from cbrcore.run import run_workload
from cbrcore.testing import CliResult, StoreContract


class TestPostgresStore(StoreContract):
    persistent = shared = True

    @pytest.fixture
    def open_store(self, postgres_database: str) -> Callable[[str], CaseStore]:
        return lambda name: PostgresStore(postgres_database, schema=name)


@pytest.fixture
def store(postgres_database: str) -> Iterator[PostgresStore]:
    with PostgresStore(postgres_database) as opened:
        yield opened


def _sql(dsn: str, *statements: str) -> list[tuple[object, ...]]:
    """Run statements behind the store's back; the rows of the last one."""
    with psycopg.connect(dsn, autocommit=True) as conn:
        rows: list[tuple[object, ...]] = []
        for statement in statements:
            cursor = conn.execute(statement)
            rows = cursor.fetchall() if cursor.description else []
        return rows


# -- the component --------------------------------------------------------------------------


def _context(out_dir: Path | None = None) -> Context:
    registry = Registry()
    cbr_stores.cbr_register(registry)
    return Context(registry=registry, seed=0, out_dir=out_dir)


def test_the_postgres_component_opens_the_schema_it_names(postgres_database: str) -> None:
    ctx = _context()
    with ctx.registry.create("store", "postgres", {"dsn": postgres_database, "schema": "fleet",
                                                   "busy_timeout": 2}, ctx) as store:
        store.add(Case(1, 1))
        assert (store.schema, store.busy_timeout) == ("fleet", 2.0)
        assert str(store).startswith("schema fleet of database cbr_test_")
    assert _sql(postgres_database, "SELECT count(*) FROM fleet.cases") == [(1,)]
    summaries = {c.name: c.summary for c in ctx.registry}
    assert summaries["postgres"].startswith("A case base in a PostgreSQL database")


@pytest.mark.parametrize(("options", "expected"), [
    ({"schema": ""}, r"postgres\.schema: must name a PostgreSQL schema: expected a non-empty"),
    ({"schema": "pg_cases"}, r"schema: .*'pg_cases': names starting with pg_ are reserved"),
    ({"schema": "x" * 64}, r"schema: .*'x+' is longer than PostgreSQL's 63 bytes"),
    ({"busy_timeout": -1}, r"busy_timeout: must be >= 0"),
    ({"dns": "host=db"}, r"dns"),
])
def test_bad_postgres_options_are_config_errors(options: dict[str, object],
                                                expected: str) -> None:
    ctx = _context()
    with pytest.raises(ConfigError, match=expected):
        ctx.registry.create("store", "postgres", options, ctx)


def test_the_component_loads_initial_cases_into_a_new_case_base(
        postgres_database: str, tmp_path: Path) -> None:
    with PostgresStore(postgres_database, schema="source") as source:
        source.add(Case({"start": [0, 0]}, [[0, 0], [1, 1]], kind="path"))
        source.set_meta("index", {"built_at": 1})
        (tmp_path / "initial.yaml").write_text(dump_document(document_of(source), "yaml"))
    ctx = _context()
    options = {"dsn": postgres_database, "schema": "started",
               "initial": str(tmp_path / "initial.yaml")}
    for _ in range(2):  # the second time the case base is not new: nothing is loaded again
        with ctx.registry.create("store", "postgres", options, ctx) as store:
            assert [(c.id, c.kind) for c in store.cases()] == [(1, "path")]
            assert store.meta_items() == {"index": {"built_at": 1}}


def test_the_dsn_comes_from_the_environment_when_omitted(
        postgres_server: object, postgres_database: str,
        monkeypatch: pytest.MonkeyPatch) -> None:
    settings = dict(item.split("=", 1) for item in postgres_database.split())
    for key, variable in (("host", "PGHOST"), ("port", "PGPORT"), ("user", "PGUSER"),
                          ("dbname", "PGDATABASE")):
        monkeypatch.setenv(variable, settings[key])
    ctx = _context()
    with ctx.registry.create("store", "postgres", {}, ctx) as store:
        store.add(Case(1, 1))
        assert store.describe()["database"] == settings["dbname"]
    assert _sql(postgres_database, "SELECT count(*) FROM cbrcore.cases") == [(1,)]


def test_describe_tells_where_the_case_base_is(store: PostgresStore,
                                               postgres_database: str) -> None:
    facts = store.describe()
    settings = dict(item.split("=", 1) for item in postgres_database.split())
    assert (facts["host"], facts["port"], facts["database"], facts["user"]) == (
        settings["host"], int(settings["port"]), settings["dbname"], settings["user"])
    assert (facts["schema"], facts["schema_version"]) == ("cbrcore", 2)
    assert str(facts["server_version"]).split(".")[0].isdigit()
    assert isinstance(facts["size_bytes"], int) and facts["size_bytes"] > 0


# -- the command line -----------------------------------------------------------------------


def test_the_casebase_commands_work_on_a_postgres_store(
        postgres_database: str, tmp_path: Path, cbr_plugins: Callable[..., Plugins],
        invoke_cbr: Callable[..., CliResult]) -> None:
    cbr_plugins(("core", cbrcore.builtins), ("stores", cbr_stores))
    with PostgresStore(postgres_database, schema="fleet") as store:
        with store.transaction():
            store.add(Case({"start": [0, 0]}, [[0, 0], [0, 1]]))
            store.add(Case("v", None, kind="vertex"))
        store.touch([1])
    fleet = f"{{use: postgres, dsn: '{postgres_database}', schema: fleet}}"
    info = invoke_cbr("casebase", "info", "--store", fleet, "--json")
    assert info.exit_code == 0, info.stderr
    facts = json.loads(info.stdout)
    assert (facts["store"], facts["revision"], facts["cases"], facts["schema"]) == (
        "postgres", 2, 2, "fleet")
    assert facts["kinds"] == {"case": 1, "vertex": 1}
    assert invoke_cbr("casebase", "check", "--store", fleet).stdout == "ok\n"
    exported = tmp_path / "fleet.yaml"
    assert invoke_cbr("casebase", "export", "--store", fleet, "-o", str(exported)).exit_code == 0
    copy = f"{{use: postgres, dsn: '{postgres_database}', schema: copy}}"
    imported = invoke_cbr("casebase", "import", str(exported), "--store", copy)
    assert imported.exit_code == 0, imported.stderr
    assert imported.stdout.startswith("imported 2 cases into schema copy of database cbr_test_")
    with PostgresStore(postgres_database, schema="fleet") as fleet_store, \
            PostgresStore(postgres_database, schema="copy") as copied:
        assert document_of(copied) == document_of(fleet_store)
    _sql(postgres_database, "UPDATE fleet.cases SET uses = -1 WHERE id = 1")
    broken = invoke_cbr("casebase", "check", "--store", fleet)
    assert broken.exit_code == 1
    assert "case 1: uses: expected a non-negative integer, got -1" in broken.stdout
    _sql(postgres_database, "UPDATE fleet.schema_version SET version = 9")
    newer = invoke_cbr("casebase", "check", "--store", fleet)
    assert (newer.exit_code, "schema version 9 (from a newer cbrcore)" in newer.stdout) == (
        1, True)


# -- a run learning into the case base ------------------------------------------------------


def test_a_second_run_continues_from_the_postgres_case_base(
        postgres_database: str, toy_plugins: Plugins, tmp_path: Path) -> None:
    """Two runs of the toy domain share one PostgreSQL case base, as two runs share a SQLite
    file: the second starts with the cases the first kept and answers more from them."""
    config = toy_domain.TOY_CONFIG.replace(
        "casebase: memory", f"casebase: {{use: postgres, dsn: '{postgres_database}'}}")
    kept, shares = [], []
    for run in range(2):
        with Engine(parse_config(yaml.safe_load(config), toy_plugins.registry),
                    plugins=toy_plugins, out_dir=tmp_path / f"run{run}") as engine:
            kept.append(engine.casebase.count(toy_domain.KIND))
            shares.append(run_workload(engine, tmp_path / f"run{run}")["cbr_share"])
            # the workload's forgetter keeps the case base at its capacity
            assert engine.casebase.count(toy_domain.KIND) == 6
            assert engine.casebase.check() == []
    assert kept == [0, 6]
    assert shares[1] > shares[0]


def test_a_postgres_case_base_refuses_a_run_of_another_world(
        postgres_database: str, tmp_path: Path, cbr_plugins: Callable[..., Plugins],
        invoke_cbr: Callable[..., CliResult]) -> None:
    """The world record lives in the case base's meta, so it is the same on every store: a run
    of another office is refused and stores nothing, the same office learns on."""
    cbr_plugins(entry_points=True)
    config = tmp_path / "run.yaml"
    config.write_text(
        "seed: 1\nworld: {use: generated, kind: office, width: 24, height: 24}\n"
        f"casebase: {{use: postgres, dsn: '{postgres_database}', schema: office}}\n"
        "workload: {use: trips, count: 4, unknown_static: 60}\nsolver: astar\n"
        "retain: [risk_map]\n", encoding="utf-8")
    first = invoke_cbr("run", str(config), "--out", str(tmp_path / "a"))
    assert first.exit_code == 0, first.stderr
    with PostgresStore(postgres_database, schema="office") as store:
        before = document_of(store)
    assert [w["description"] for w in before.meta["cbrcore.worlds"]] == ["office 24x24, seed 1"]

    refused = invoke_cbr("run", str(config), "--out", str(tmp_path / "b"), "--set", "seed=2")
    again = invoke_cbr("run", str(config), "--out", str(tmp_path / "c"), "--set", "workload.seed=5")

    assert refused.exit_code == 2 and "Traceback" not in refused.stderr
    assert "office 24x24, seed 1 (world" in refused.stderr
    assert "this run's world is office 24x24, seed 2 (world" in refused.stderr
    assert again.exit_code == 0, again.stderr
    with PostgresStore(postgres_database, schema="office") as store:
        after = document_of(store)
    assert after.meta["cbrcore.worlds"] == before.meta["cbrcore.worlds"]
    assert after.revision > before.revision


# -- passwords and connection errors --------------------------------------------------------


def test_a_password_is_never_shown(postgres_database: str) -> None:
    # trust authentication ignores the password, so the store connects with it; errors about
    # a DSN are tested in test_dsn_secrets.py
    with PostgresStore(f"{postgres_database} password=s3cret-pw") as store:
        assert "s3cret-pw" not in str(store) + repr(store) + repr(store.describe())


def test_a_missing_case_base_is_refused_when_not_to_be_created(
        postgres_database: str) -> None:
    with pytest.raises(CaseBaseError, match="no case base in schema fleet of database"):
        PostgresStore(postgres_database, schema="fleet", create=False)
    assert _sql(postgres_database,
                "SELECT count(*) FROM pg_namespace WHERE nspname = 'fleet'") == [(0,)]


def test_a_closed_store_says_so(store: PostgresStore) -> None:
    store.close()
    with pytest.raises(CaseBaseError, match="was closed"):
        store.count()


# -- schema versions and what is not a case base --------------------------------------------


def test_a_newer_case_base_is_refused_untouched(postgres_database: str) -> None:
    PostgresStore(postgres_database).close()
    _sql(postgres_database, "UPDATE cbrcore.schema_version SET version = 7")
    with pytest.raises(UnusableCaseBase, match=r"schema version 7 \(from a newer cbrcore\); "
                                               r"this cbrcore reads version 2"):
        PostgresStore(postgres_database)
    assert _sql(postgres_database, "SELECT version FROM cbrcore.schema_version") == [(7,)]


def test_another_programs_schema_is_refused_untouched(postgres_database: str) -> None:
    _sql(postgres_database, "CREATE SCHEMA app", "CREATE TABLE app.orders (id int)")
    with pytest.raises(UnusableCaseBase, match="is not a cbrcore case base: the schema holds "
                                               "orders but no schema_version table"):
        PostgresStore(postgres_database, schema="app")
    assert _sql(postgres_database, "SELECT tablename FROM pg_tables WHERE schemaname = 'app'"
                ) == [("orders",)]


def test_an_empty_schema_prepared_for_the_store_is_used(postgres_database: str) -> None:
    _sql(postgres_database, "CREATE SCHEMA prepared")
    with PostgresStore(postgres_database, schema="prepared") as store:
        assert store.add(Case(1, 1)).id == 1


@pytest.mark.parametrize(("change", "expected"), [
    ("CREATE TRIGGER spy BEFORE INSERT ON cbrcore.cases FOR EACH ROW "
     "EXECUTE FUNCTION suppress_redundant_updates_trigger()",
     "trigger 'spy' on table cases does not belong"),
    ("CREATE RULE nothing AS ON INSERT TO cbrcore.cases DO INSTEAD NOTHING",
     "rule 'nothing' on table cases does not belong"),
    ("CREATE VIEW cbrcore.recent AS SELECT id FROM cbrcore.cases",
     "view 'recent' does not belong"),
    ("ALTER TABLE cbrcore.cases ADD COLUMN extra int", "table cases is not defined as in a case"),
    ("DROP INDEX cbrcore.cases_kind", "index cases_kind is missing"),
    ("DROP INDEX cbrcore.cases_changed", "index cases_changed is missing"),
    ("DROP TABLE cbrcore.removed", "table removed is missing"),
    ("ALTER TABLE cbrcore.cases ALTER COLUMN changed DROP NOT NULL",
     "table cases is not defined as in a case"),
])
def test_a_changed_schema_is_refused_and_reported_by_check(postgres_database: str,
                                                           change: str, expected: str) -> None:
    with PostgresStore(postgres_database) as store:
        _sql(postgres_database, change)
        assert any(expected in problem for problem in store.check())
    with pytest.raises(UnusableCaseBase, match=expected):
        PostgresStore(postgres_database)


VERSION_1 = (
    "CREATE SCHEMA old",
    "CREATE TABLE old.clock (revision bigint NOT NULL, last_id bigint NOT NULL)",
    "CREATE TABLE old.schema_version (version integer NOT NULL)",
    "CREATE TABLE old.cases (id bigint NOT NULL, kind text NOT NULL, problem text NOT NULL, "
    "solution text NOT NULL, meta text NOT NULL, uses bigint NOT NULL, created bigint NOT NULL, "
    "last_used bigint, PRIMARY KEY (id))",
    "CREATE TABLE old.meta (key text NOT NULL, value text NOT NULL, PRIMARY KEY (key))",
    "CREATE INDEX cases_kind ON old.cases (kind)",
    "INSERT INTO old.schema_version VALUES (1)",
    # case 2 was removed and case 4 given to a transaction that rolled back; case 3 was used
    # at revision 5, the last one
    "INSERT INTO old.clock VALUES (5, 4)",
    """INSERT INTO old.cases VALUES (1, '"segment"', '{"a":1}', '[1]', '{}', 0, 1, NULL),
                                    (3, '"segment"', '{"a":3}', '[3]', '{}', 2, 3, 5)""",
    """INSERT INTO old.meta VALUES ('"grid"', '{"width":3}')""",
)
"""A case base in schema ``old`` as cbrcore wrote schema version 1."""


def _columns(dsn: str, table: str) -> list[object]:
    return [row[0] for row in _sql(
        dsn, f"SELECT column_name FROM information_schema.columns WHERE table_schema = 'old' "
             f"AND table_name = '{table}' ORDER BY ordinal_position")]


def test_a_case_base_of_schema_version_1_is_migrated(postgres_database: str) -> None:
    _sql(postgres_database, *VERSION_1)
    with PostgresStore(postgres_database, schema="old") as store:
        assert store.schema_version == 2
        assert store.check() == []
        assert [(c.id, c.kind, c.uses, c.created, c.last_used) for c in store.cases()] == [
            (1, "segment", 0, 1, None), (3, "segment", 2, 3, 5)]
        assert (store.revision, store.get_meta("grid")) == (5, {"width": 3})
        # a case changed last when it was created or last used, whichever came later: case 1
        # at revision 1, case 3 at 5; no removal is known from before the migration
        changed = {0: [1, 3], 1: [3], 2: [3], 3: [3], 4: [3], 5: []}
        for since, ids in changed.items():
            assert store.changes(since) == Changes(since, 5, tuple(map(store.get, ids)), ())
        store.remove([1])
        assert store.changes(5) == Changes(5, 6, (), (1,))
        store.touch([3])
        assert store.changes(5) == Changes(5, 7, (store.get(3),), (1,))
        assert store.add(Case(5, 5)).id == 5  # ids are still never reused
    # a writer of version 1 still running cannot add a case the changes would not show
    with pytest.raises(psycopg.errors.NotNullViolation):
        _sql(postgres_database, "INSERT INTO old.cases (id, kind, problem, solution, meta, uses, "
                                """created) VALUES (6, '"segment"', '6', '6', '{}', 0, 8)""")
    with PostgresStore(postgres_database, schema="old") as again:
        assert again.check() == [] and again.schema_version == 2
        assert [c.id for c in again.changes(6).cases] == [3, 5]


def test_a_read_only_store_refuses_an_older_case_base_untouched(postgres_database: str) -> None:
    _sql(postgres_database, *VERSION_1)
    with pytest.raises(CaseBaseError, match=r"schema old of database .* has case base schema "
                                            r"version 1, which must be migrated to version 2: "
                                            r"open it once for writing"):
        PostgresStore(postgres_database, schema="old", read_only=True)
    assert _sql(postgres_database, "SELECT version FROM old.schema_version") == [(1,)]
    assert _columns(postgres_database, "cases")[-1] == "last_used"
    assert _columns(postgres_database, "removed") == []


def test_an_older_case_base_is_migrated_in_one_transaction(
        postgres_database: str, monkeypatch: pytest.MonkeyPatch) -> None:
    _sql(postgres_database, *VERSION_1)
    monkeypatch.setattr(postgres_schema, "SCHEMA_VERSION", 3)
    monkeypatch.setattr(postgres_module, "SCHEMA_VERSION", 3)
    version_2 = postgres_schema.MIGRATIONS[1]
    monkeypatch.setattr(postgres_schema, "MIGRATIONS", {1: version_2, 2: (
        "COMMENT ON TABLE {schema}.cases IS 'migrated'",
        "SELECT no_such_function()",
    )})
    with pytest.raises(UnusableCaseBase, match="migrating the case base from schema version 2 "
                                               "to 3 failed, and nothing was changed: function "
                                               "no_such_function"):
        PostgresStore(postgres_database, schema="old")
    # the step from version 1 to 2, which succeeded, is undone too
    comment = "SELECT obj_description('old.cases'::regclass, 'pg_class')"
    assert _sql(postgres_database, comment) == [(None,)]
    assert _sql(postgres_database, "SELECT version FROM old.schema_version") == [(1,)]
    assert (_columns(postgres_database, "cases")[-1], _columns(postgres_database, "removed")) == (
        "last_used", [])
    monkeypatch.setattr(postgres_schema, "MIGRATIONS", {1: version_2, 2: (
        "COMMENT ON TABLE {schema}.cases IS 'migrated'",)})
    with PostgresStore(postgres_database, schema="old") as migrated:
        assert migrated.schema_version == 3
        assert migrated.get(3).last_used == 5
        assert migrated.check() == []
    assert _sql(postgres_database, comment) == [("migrated",)]


# -- check() --------------------------------------------------------------------------------


def test_check_finds_what_was_changed_behind_the_stores_back(store: PostgresStore,
                                                             postgres_database: str) -> None:
    for n in range(3):
        store.add(Case(n, n, kind="vertex"))
    store.set_meta("index", [1])
    assert store.check() == []
    _sql(postgres_database,
         "UPDATE cbrcore.cases SET problem = '{' WHERE id = 1",
         "UPDATE cbrcore.cases SET created = 9 WHERE id = 2",
         "UPDATE cbrcore.cases SET kind = '7' WHERE id = 3",
         "UPDATE cbrcore.meta SET value = 'nan' WHERE key = '\"index\"'",
         "UPDATE cbrcore.clock SET last_id = 2")
    problems = store.check()
    assert problems[0] == ("ids: case 3 is beyond the largest id recorded as given, 2: new cases "
                           "would take ids again")
    assert problems[1].startswith("case 1: problem: not valid JSON")
    assert problems[2:] == ["case 2: created: revision 9 is after the case base's revision 4",
                            "case 3: kind: expected a non-empty string, got 7",
                            "meta key 'index': not valid JSON (Expecting value: line 1 column "
                            "1 (char 0))"]


def test_check_finds_a_change_or_removal_recorded_at_a_wrong_revision(
        store: PostgresStore, postgres_database: str) -> None:
    for n in range(4):
        store.add(Case(n, n))  # case n + 1 at revision n + 1
    store.touch([1])  # revision 5
    store.remove([4])  # revision 6
    assert store.check() == []
    _sql(postgres_database,
         "UPDATE cbrcore.cases SET changed = 4 WHERE id = 1",
         "UPDATE cbrcore.cases SET changed = 7 WHERE id = 2",
         "UPDATE cbrcore.cases SET changed = 2 WHERE id = 3",
         "UPDATE cbrcore.removed SET revision = 9 WHERE id = 4")
    expected = "expected a revision from {} (its creation or last use) to the case base's, 6"
    assert store.check() == [
        f"case 1: changed at revision 4; {expected.format(5)}",
        f"case 2: changed at revision 7; {expected.format(2)}",
        f"case 3: changed at revision 2; {expected.format(3)}",
        "removed case 4: removed at revision 9; expected a revision from 1 to the case base's, 6"]


# -- reading only ---------------------------------------------------------------------------


def test_a_read_only_store_reads_snapshots_and_writes_nothing(postgres_database: str) -> None:
    with PostgresStore(postgres_database) as writer:
        writer.add(Case(1, 1))
        with PostgresStore(postgres_database, read_only=True) as reader:
            with pytest.raises(CaseBaseError, match="open for reading only"):
                reader.add(Case(2, 2))
            with pytest.raises(CaseBaseError, match="open for reading only"):
                reader.set_meta("k", 1)
            with reader.transaction():
                assert reader.count() == 1
                writer.add(Case(2, 2))  # a reader's snapshot holds no lock
                assert (reader.count(), reader.revision) == (1, 1)
                assert reader.check() == []
            assert (reader.count(), reader.revision) == (2, 2)
    with pytest.raises(CaseBaseError, match="no case base in schema other"):
        PostgresStore(postgres_database, schema="other", read_only=True)


def test_a_writer_waits_for_the_lock_then_gives_up(postgres_database: str) -> None:
    with PostgresStore(postgres_database) as first, \
            PostgresStore(postgres_database, busy_timeout=0.2) as second:
        with first.transaction():
            first.add(Case(1, 1))
            with pytest.raises(CaseBaseError, match=r"is locked by another process \(gave up "
                                                    r"after waiting 0\.2 s for it\)"):
                second.add(Case(2, 2))
            assert second.count() == 0  # readers do not wait
            assert second.changes(0) == Changes(0, 0, (), ())  # nor does catching up
        assert second.add(Case(2, 2)).id == 2


# -- several processes on one server --------------------------------------------------------

STEPS = 150
"""Learn steps each writer process makes."""


def _learner(dsn: str, writer: int, steps: int) -> None:
    """Learn steps that each read the step counter, add a pair of cases and count the step.

    Two steps that read the same counter (neither waiting for the other's commit) would give two
    pairs one step number, and the counter would lose a step.
    """
    with PostgresStore(dsn, schema="fleet", busy_timeout=60) as store:
        for _ in range(steps):
            with store.transaction():
                step = store.get_meta("steps", 0)
                store.add(Case({"step": step}, writer, kind="first"))
                store.add(Case({"step": step}, writer, kind="second"))
                store.set_meta("steps", step + 1)


def _whole_steps(cases: list[Case]) -> list[int]:
    """The step numbers of ``cases``, checking that every step's pair is there whole."""
    firsts = sorted(c.problem["step"] for c in cases if c.kind == "first")
    seconds = sorted(c.problem["step"] for c in cases if c.kind == "second")
    assert firsts == seconds == list(range(len(firsts)))
    return firsts


def test_processes_learning_at_once_lose_nothing_and_readers_see_whole_steps(
        postgres_database: str) -> None:
    spawn = multiprocessing.get_context("spawn")
    writers = [spawn.Process(target=_learner, args=(postgres_database, w, STEPS))
               for w in range(2)]
    for process in writers:
        process.start()
    reads = 0
    try:
        # the case base may not exist yet: the reader and both writers race to create it
        with PostgresStore(postgres_database, schema="fleet", busy_timeout=60) as reader:
            while any(p.is_alive() for p in writers) or reads == 0:
                # one statement reads one snapshot: a step's writes are in it all or not at all
                _whole_steps(reader.cases())
                with reader.transaction():
                    assert reader.count() == 2 * reader.get_meta("steps", 0)
                # the revision and the cases are read in one snapshot: two cases a step
                changes = reader.changes(0)
                assert len(changes.cases) == 2 * changes.revision
                _whole_steps(list(changes.cases))
                reads += 1
    finally:
        for process in writers:
            process.join()
    assert [p.exitcode for p in writers] == [0, 0]
    with PostgresStore(postgres_database, schema="fleet") as store:
        cases = store.cases()
        assert _whole_steps(cases) == list(range(2 * STEPS))
        assert store.get_meta("steps") == 2 * STEPS
        assert store.revision == 2 * STEPS
        assert [c.id for c in cases] == list(range(1, 4 * STEPS + 1))
        assert sorted(c.solution for c in cases) == [0] * 2 * STEPS + [1] * 2 * STEPS
        assert store.check() == []


def _stuck_learner(dsn: str, ready: str) -> None:
    """A learn step that has written half of what it will and then waits to be killed."""
    with PostgresStore(dsn, schema="fleet") as store, store.transaction():
        store.add(Case("half", 0))
        Path(ready).write_text("in the step", encoding="utf-8")
        time.sleep(600)


def test_a_learner_killed_mid_step_leaves_the_others_running(postgres_database: str,
                                                             tmp_path: Path) -> None:
    with PostgresStore(postgres_database, schema="fleet", busy_timeout=60) as store:
        store.add(Case("before", 0))
        ready = tmp_path / "ready"
        stuck = multiprocessing.get_context("spawn").Process(
            target=_stuck_learner, args=(postgres_database, str(ready)))
        stuck.start()
        try:
            while not ready.exists():
                assert stuck.is_alive(), "the learner ended before its step"
                time.sleep(0.02)
            assert [c.problem for c in store.cases()] == ["before"]
        finally:
            os.kill(stuck.pid, signal.SIGKILL)
            stuck.join()
        # the server rolls the killed step back and releases its lock
        after = store.add(Case("after", 1))
        assert after.id == 2
        assert [c.problem for c in store.cases()] == ["before", "after"]
        assert store.revision == 2
        assert store.check() == []


# -- database roles -------------------------------------------------------------------------


def test_roles_with_the_rights_the_documentation_grants(postgres_database: str) -> None:
    """A robot that owns a prepared schema but may not create schemas, and a reviewer that may
    only read: the grants docs/casebase.md gives."""
    database = dict(item.split("=", 1) for item in postgres_database.split())["dbname"]
    robot, reviewer = f"{database}_robot", f"{database}_reviewer"
    _sql(postgres_database,
         f"CREATE ROLE {robot} LOGIN", f"CREATE ROLE {reviewer} LOGIN",
         f"REVOKE CREATE ON DATABASE {database} FROM PUBLIC",
         "REVOKE CREATE ON SCHEMA public FROM PUBLIC",
         f"CREATE SCHEMA office AUTHORIZATION {robot}")
    try:
        with pytest.raises(CaseBaseError, match="permission denied for database"):
            PostgresStore(f"{postgres_database} user={robot}", schema="elsewhere")
        with PostgresStore(f"{postgres_database} user={robot}", schema="office") as store:
            store.add(Case(1, 1))
        _sql(postgres_database, f"GRANT USAGE ON SCHEMA office TO {reviewer}",
             f"GRANT SELECT ON ALL TABLES IN SCHEMA office TO {reviewer}")
        with PostgresStore(f"{postgres_database} user={reviewer}", schema="office",
                           read_only=True) as looking:
            assert [c.problem for c in looking.cases()] == [1]
            assert looking.check() == []
            with pytest.raises(CaseBaseError, match="open for reading only"):
                looking.touch([1])
        with pytest.raises(CaseBaseError, match="permission denied for table clock"), \
                PostgresStore(f"{postgres_database} user={reviewer}", schema="office") as store:
            store.add(Case(2, 2))
    finally:
        _sql(postgres_database, f"DROP OWNED BY {robot}, {reviewer} CASCADE",
             f"DROP ROLE {robot}", f"DROP ROLE {reviewer}")
