"""The components cbrcore itself supplies: the memory case base store, defined in
:mod:`cbrcore.casebase.components` (the SQL stores are the ``stores`` plugin's,
:mod:`cbr_stores`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl

if TYPE_CHECKING:
    from cbrcore.registry import Registry

_STORES = "cbrcore.casebase.components"


@hookimpl
def cbr_register(registry: Registry) -> None:
    # named, not imported: the store loads when a configuration names it
    registry.add("store", "memory", f"{_STORES}:memory_store", options=f"{_STORES}:MemoryOptions")
