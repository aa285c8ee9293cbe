"""The components cbrcore itself supplies: the case base stores (memory, SQLite, PostgreSQL),
defined in :mod:`cbrcore.casebase.components`."""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl

if TYPE_CHECKING:
    from cbrcore.registry import Registry

_STORES = "cbrcore.casebase.components"


@hookimpl
def cbr_register(registry: Registry) -> None:
    # named, not imported: the stores load when a configuration names one
    registry.add("store", "memory", f"{_STORES}:memory_store", options=f"{_STORES}:MemoryOptions")
    registry.add("store", "sqlite", f"{_STORES}:sqlite_store", options=f"{_STORES}:SQLiteOptions")
    registry.add("store", "postgres", f"{_STORES}:postgres_store",
                 options=f"{_STORES}:PostgresOptions")
