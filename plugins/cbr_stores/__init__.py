"""The SQL case base stores: ``sqlite``, a case base in a SQLite file
(:mod:`cbr_stores.sqlite`), and ``postgres``, one in a PostgreSQL schema shared by robots on
several machines (:mod:`cbr_stores.postgres`).

Both are a dialect of one SQL store (:mod:`cbr_stores.sql`), which holds their transactions,
savepoints, revision clock and statements; each dialect connects, locks, and creates, migrates
and checks its schema (:mod:`cbr_stores.sqlite_file`, :mod:`cbr_stores.postgres_schema`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl

if TYPE_CHECKING:
    from cbrcore.registry import Registry

_COMPONENTS = "cbr_stores.components"


@hookimpl
def cbr_register(registry: Registry) -> None:
    # named, not imported: the stores load when a configuration names one
    registry.add("store", "sqlite", f"{_COMPONENTS}:sqlite_store",
                 options=f"{_COMPONENTS}:SQLiteOptions")
    registry.add("store", "postgres", f"{_COMPONENTS}:postgres_store",
                 options=f"{_COMPONENTS}:PostgresOptions")
