"""The memory store that a configuration's ``casebase`` slot builds, and what every store's
component shares: the ``initial`` cases a new case base starts from.

The ``core`` plugin (:mod:`cbrcore.builtins`) registers the memory store by name: its options
and factory import the store, the exchange format and NumPy, which load when a configuration
names a store. The SQL stores are the ``stores`` plugin's (:mod:`cbr_stores`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TypeVar

import attrs

from cbrcore.casebase.formats import read_casebase
from cbrcore.casebase.memory import MemoryStore
from cbrcore.casebase.store import CaseStore
from cbrcore.casebase.worlds import ONE, WORLDS_DOC, WORLDS_VALIDATOR, Worlds
from cbrcore.context import Context
from cbrcore.options import option

S = TypeVar("S", bound=CaseStore)

INITIAL_DOC = ("Hand-made cases to start from, loaded into the case base when it is new, never "
               "into one that has held cases: a file of 'cbr casebase export' in any format it "
               "writes, told by its extension (YAML, JSON, or a plugin's, such as a Nav2 route "
               "graph .geojson read on the run's world); relative to the configuration file.")
"""The documentation of a store component's ``initial`` option, which :func:`started` loads."""


def started(store: S, initial: Path | None, ctx: Context) -> S:
    """``store``, holding the cases of ``initial`` if it is new (what a store component's factory
    returns); a format that needs the world reads them on the run's."""
    if initial is None:
        return store
    document = read_casebase(initial, world=ctx.world)
    # checked under the write lock: two processes creating one case base load it once
    with store.transaction():
        if store.revision == 0 and len(store) == 0:
            store.restore(document.cases, document.meta, document.revision)
    return store


@attrs.frozen
class MemoryOptions:
    """Options of the ``memory`` store."""

    initial: Path | None = option(None, INITIAL_DOC)
    worlds: Worlds = option(ONE, WORLDS_DOC, validator=WORLDS_VALIDATOR)


def memory_store(options: MemoryOptions, ctx: Context) -> MemoryStore:
    """An in-memory case base: fast, and gone when the run ends.

    Behaves like the sqlite store (transactions, revisions, JSON-only contents) without a file,
    so it suits tests, benchmarks and runs that start from an empty case base every time (or
    from the same hand-made cases: ``initial``).
    """
    return started(MemoryStore(), options.initial, ctx)
