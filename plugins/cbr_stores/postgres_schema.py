"""What a sound PostgreSQL case base is, and how one is recognised, created and migrated.

A case base lives in one PostgreSQL schema (a namespace inside a database), so several case
bases can share a database. The schema holds the tables below and nothing else: a trigger, a rule
or another table would act or answer behind the store's back.

Every text column holds JSON text made of ASCII characters only (kinds and meta keys are JSON
strings too): the case base then works in a database of any encoding, and keeps strings that
PostgreSQL's ``text`` cannot hold (NUL characters, lone surrogates) exactly as SQLite does.

The schema's version is the one row of ``schema_version``. Version 1 had no record of when a case
last changed nor of removed cases; version 2 adds the column ``cases.changed`` (the revision that
last wrote the case) and the table ``removed`` (each removed id and the revision that removed
it), both indexed by revision, from which the store tells what changed since a revision
(``PostgresStore.changes``). A cbrcore that changes the tables adds the statements taking
version ``n`` to ``n + 1`` to :data:`MIGRATIONS`, and opening an older case base runs them, all
in one transaction.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

from cbrcore.errors import CaseBaseError, UnusableCaseBase

if TYPE_CHECKING:
    # psycopg is imported when a store connects: checking a configuration must not need it
    import psycopg

SCHEMA_VERSION = 2
"""The version of the case bases this cbrcore reads and writes."""

MIGRATIONS: Mapping[int, tuple[str, ...]] = {
    # A case's last change is at least its creation and its last use. Removals before the
    # migration are not known, and need not be: a store asks what changed since a revision it
    # read, which is never before its case base was migrated.
    1: ("ALTER TABLE {schema}.cases ADD COLUMN changed bigint",
        "UPDATE {schema}.cases SET changed = greatest(created, coalesce(last_used, 0))",
        # a writer of version 1, still running, cannot then add a case hidden from the changes
        "ALTER TABLE {schema}.cases ALTER COLUMN changed SET NOT NULL",
        "CREATE INDEX cases_changed ON {schema}.cases (changed)",
        "CREATE TABLE {schema}.removed (id bigint NOT NULL, revision bigint NOT NULL, "
        "PRIMARY KEY (id))",
        "CREATE INDEX removed_revision ON {schema}.removed (revision)"),
}
"""The statements taking a case base from version ``n`` (the key) to ``n + 1``; ``{schema}``
stands for the quoted schema name."""

LOCK_CLASS = 0x43425243
"""The first key of the advisory lock that serialises creating and migrating a case base
("CBRC"); the second is the hash of the schema name."""

TABLES: dict[str, tuple[tuple[str, str, bool], ...]] = {
    # the one row whose lock is the write lock: revision and the largest id ever given
    "clock": (("revision", "bigint", True), ("last_id", "bigint", True)),
    "schema_version": (("version", "integer", True),),
    "cases": (("id", "bigint", True), ("kind", "text", True), ("problem", "text", True),
              ("solution", "text", True), ("meta", "text", True), ("uses", "bigint", True),
              ("created", "bigint", True), ("last_used", "bigint", False),
              # the revision that last added, replaced, touched or restored the case
              ("changed", "bigint", True)),
    "meta": (("key", "text", True), ("value", "text", True)),
    # each removed id and the revision that removed it
    "removed": (("id", "bigint", True), ("revision", "bigint", True)),
}
"""Each table's columns: name, type and whether it is NOT NULL."""

PRIMARY_KEYS = {"cases": "id", "meta": "key", "removed": "id"}
_SECONDARY_INDEXES = (("cases_kind", "cases", "kind"), ("cases_changed", "cases", "changed"),
                      ("removed_revision", "removed", "revision"))
"""The indexes besides the primary keys' (named ``<table>_pkey``): name, table and column."""

INDEXES = {**{f"{table}_pkey": table for table in PRIMARY_KEYS},
           **{name: table for name, table, _ in _SECONDARY_INDEXES}}
"""Every index of a case base, by name, and the table it belongs to."""

SCHEMA_EXPECTED = ("a case base's schema has the tables clock, schema_version, cases, meta and "
                   "removed with their columns, the indexes cases_pkey, meta_pkey, "
                   "removed_pkey, cases_kind, cases_changed and removed_revision, and no other "
                   "tables, views, sequences, triggers or rules")


def quoted(name: str) -> str:
    """``name`` as a PostgreSQL identifier, quoted so that any name is taken literally."""
    return '"' + name.replace('"', '""') + '"'


def schema_name_problem(name: str) -> str | None:
    """Why ``name`` cannot name a case base's PostgreSQL schema; None when it can."""
    if not name:
        return "expected a non-empty schema name"
    if "\x00" in name:
        return "a schema name cannot hold a NUL character"
    if len(name.encode("utf-8", "surrogatepass")) > 63:
        # PostgreSQL would cut it short, and two long names could then name one schema
        return f"{name!r} is longer than PostgreSQL's 63 bytes for a name"
    if name.lower().startswith("pg_"):
        return f"{name!r}: names starting with pg_ are reserved for PostgreSQL's own schemas"
    return None


def create_statements(schema: str) -> list[str]:
    """The statements giving the existing, empty ``schema`` the tables of a case base."""
    statements = []
    for table, columns in TABLES.items():
        defined = [f"{name} {kind}{' NOT NULL' if required else ''}"
                   for name, kind, required in columns]
        if table in PRIMARY_KEYS:
            defined.append(f"PRIMARY KEY ({PRIMARY_KEYS[table]})")
        statements.append(f"CREATE TABLE {quoted(schema)}.{table} ({', '.join(defined)})")
    statements += [f"CREATE INDEX {name} ON {quoted(schema)}.{table} ({column})"
                   for name, table, column in _SECONDARY_INDEXES]
    statements.append(f"INSERT INTO {quoted(schema)}.clock (revision, last_id) VALUES (0, 0)")
    statements.append(f"INSERT INTO {quoted(schema)}.schema_version (version) "
                      f"VALUES ({SCHEMA_VERSION})")
    return statements


def open_schema(conn: psycopg.Connection, schema: str, label: str, *, create: bool,
                migrate: bool) -> None:
    """Make sure ``schema`` holds a sound case base of this version, creating or migrating it.

    Runs in a transaction of its own holding an advisory lock on the schema's name, so two
    processes opening a new case base at once create it once. Refuses with UnusableCaseBase,
    writing nothing, a schema holding something else or a case base of a newer version; with
    CaseBaseError a missing case base when ``create`` is false, and an older one when
    ``migrate`` is false.
    """
    with conn.transaction():
        conn.execute("SELECT pg_advisory_xact_lock(%s, hashtext(%s))", (LOCK_CLASS, schema))
        found = _relations(conn, schema)
        if not found:
            if not create:
                raise CaseBaseError(f"no case base in {label}")
            # a schema prepared for a role that may not create one is used as it is
            if not conn.execute("SELECT 1 FROM pg_catalog.pg_namespace WHERE nspname = %s",
                                (schema,)).fetchall():
                conn.execute(f"CREATE SCHEMA {quoted(schema)}")
            for statement in create_statements(schema):
                conn.execute(statement)
            return
        if "schema_version" not in found:
            raise UnusableCaseBase(f"{label} is not a cbrcore case base: the schema holds "
                                   f"{', '.join(sorted(found))} but no schema_version table")
        version = stored_version(conn, schema, label)
        if version > SCHEMA_VERSION:
            raise UnusableCaseBase(f"{label} has case base schema version {version} (from a "
                                   f"newer cbrcore); this cbrcore reads version "
                                   f"{SCHEMA_VERSION}")
        if version < SCHEMA_VERSION:
            if not migrate:
                raise CaseBaseError(f"{label} has case base schema version {version}, which "
                                    f"must be migrated to version {SCHEMA_VERSION}: open it "
                                    f"once for writing")
            _migrate(conn, schema, label, version)
        problems = schema_problems(conn, schema)
        if problems:
            raise UnusableCaseBase(f"{label} is not a sound case base: {'; '.join(problems)} "
                                   f"({SCHEMA_EXPECTED})")


def stored_version(conn: psycopg.Connection, schema: str, label: str) -> int:
    """The version in ``schema_version``; UnusableCaseBase unless it holds one sensible row."""
    rows = conn.execute(f"SELECT version FROM {quoted(schema)}.schema_version").fetchall()
    if len(rows) != 1 or rows[0][0] is None or rows[0][0] < 1:
        shown = ", ".join(str(row[0]) for row in rows) or "no row"
        raise UnusableCaseBase(f"{label} is corrupt: its schema_version table should hold one "
                               f"version from 1 up, and holds {shown}")
    return int(rows[0][0])


def _migrate(conn: psycopg.Connection, schema: str, label: str, version: int) -> None:
    import psycopg

    for step in range(version, SCHEMA_VERSION):
        try:
            with conn.transaction():
                for statement in MIGRATIONS[step]:
                    conn.execute(statement.format(schema=quoted(schema)))
        except (KeyError, psycopg.Error) as exc:
            why = "no migration is known" if isinstance(exc, KeyError) else str(exc).strip()
            raise UnusableCaseBase(f"{label}: migrating the case base from schema version "
                                   f"{step} to {step + 1} failed, and nothing was changed: "
                                   f"{why}") from exc
        conn.execute(f"UPDATE {quoted(schema)}.schema_version SET version = %s", (step + 1,))


def _relations(conn: psycopg.Connection, schema: str) -> dict[str, str]:
    """Every table, index, view, sequence and other relation in ``schema``, by name: its kind."""
    rows = conn.execute(
        "SELECT c.relname, c.relkind FROM pg_catalog.pg_class c "
        "JOIN pg_catalog.pg_namespace n ON n.oid = c.relnamespace WHERE n.nspname = %s",
        (schema,)).fetchall()
    return {name: kind for name, kind in rows}


_KINDS = {"r": "table", "i": "index", "S": "sequence", "v": "view", "m": "materialized view",
          "c": "type", "f": "foreign table", "p": "table", "I": "index"}


def schema_problems(conn: psycopg.Connection, schema: str) -> list[str]:
    """How ``schema`` differs from a case base's, one line each.

    Anything added is refused, not only what is missing or changed: a trigger or a rule runs
    behind the store's back (one deleting every inserted case would make an import report cases
    it never kept).
    """
    found = _relations(conn, schema)
    problems = []
    for table in TABLES:
        if found.get(table) not in ("r", "p"):
            problems.append(f"table {table} is missing")
    for index, table in INDEXES.items():
        if index not in found and found.get(table) in ("r", "p"):
            problems.append(f"index {index} is missing")
    expected = set(TABLES) | set(INDEXES)
    problems += [f"{_KINDS.get(kind, 'relation')} {name!r} does not belong in a case base"
                 for name, kind in sorted(found.items()) if name not in expected]
    columns: dict[str, list[tuple[str, str, bool]]] = {}
    for table, name, kind, required in conn.execute(
            "SELECT c.relname, a.attname, format_type(a.atttypid, a.atttypmod), a.attnotnull "
            "FROM pg_catalog.pg_attribute a JOIN pg_catalog.pg_class c ON c.oid = a.attrelid "
            "JOIN pg_catalog.pg_namespace n ON n.oid = c.relnamespace "
            "WHERE n.nspname = %s AND a.attnum > 0 AND NOT a.attisdropped "
            "ORDER BY c.relname, a.attnum", (schema,)).fetchall():
        columns.setdefault(table, []).append((name, kind, required))
    for table, wanted in TABLES.items():
        if table in columns and tuple(columns[table]) != wanted:
            problems.append(f"table {table} is not defined as in a case base")
    problems += [f"trigger {name!r} on table {table} does not belong in a case base"
                 for name, table in conn.execute(
                     "SELECT t.tgname, c.relname FROM pg_catalog.pg_trigger t "
                     "JOIN pg_catalog.pg_class c ON c.oid = t.tgrelid "
                     "JOIN pg_catalog.pg_namespace n ON n.oid = c.relnamespace "
                     "WHERE n.nspname = %s AND NOT t.tgisinternal ORDER BY 1", (schema,))]
    problems += [f"rule {name!r} on table {table} does not belong in a case base"
                 for name, table in conn.execute(
                     "SELECT rulename, tablename FROM pg_catalog.pg_rules "
                     "WHERE schemaname = %s ORDER BY 1", (schema,))]
    return problems
