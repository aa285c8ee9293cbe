"""What components derive from a case base, kept at the store's revision.

A family that answers queries from an index of its cases (the arrays of all stored paths, a case
graph, a map of learned risks) cannot re-read the store at every query, so it keeps the index in
memory and writes every change through to the store inside the engine's learn step. The index is
then right exactly as long as nothing else moved the store: not a learn step that rolled back
after the index had changed, not another process sharing the case base.

:class:`StoreMirror` is the one place that knows. It holds each family's index as a *view* under
a typed key, and the engine runs every learn step inside :meth:`StoreMirror.transaction`:

- before each query, and at the start of each learn step inside its transaction (with the
  store's write lock held), :meth:`StoreMirror.sync` compares the store's revision with the one
  the mirror last saw: when they differ another writer committed, and every view is dropped, to
  be loaded anew from the store the next time it is asked for;
- when the learn step commits, the views hold what the step wrote, so they are kept, at the new
  revision;
- when the step fails, the views may hold writes the store no longer has, so they are dropped.

A family's view is what :meth:`StoreMirror.view` returns; it loads it with the family's own
function on first use and after a drop. Components never keep a view across queries: they ask the
mirror each time, which is a dictionary look-up.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

from cbrcore.casebase.store import CaseStore
from cbrcore.stash import StashKey

T = TypeVar("T")


class StoreMirror:
    """The views components derive from ``store``, and the revision they match."""

    def __init__(self, store: CaseStore) -> None:
        self.store = store
        self.revision = store.revision
        """The store revision every view matches."""
        self.reloads = 0
        """How many times the views were dropped because the store moved without them."""
        self._views: dict[StashKey[Any], Any] = {}

    def view(self, key: StashKey[T], load: Callable[[CaseStore], T]) -> T:
        """The view under ``key``, loaded from the store by ``load`` if the mirror has none."""
        try:
            return self._views[key]
        except KeyError:
            value = self._views[key] = load(self.store)
            return value

    def sync(self) -> None:
        """Drop every view if another writer moved the store since the mirror last saw it."""
        now = self.store.revision
        if now != self.revision:
            self._views.clear()
            self.revision = now
            self.reloads += 1

    @contextlib.contextmanager
    def transaction(self) -> Iterator[None]:
        """One learn step: a store transaction whose writes the views follow, all or nothing.

        The mirror catches up with other writers first (inside the transaction, so nobody can
        commit in between); if the block raises, the transaction rolls back and the views,
        which may hold its writes, are dropped.
        """
        try:
            with self.store.transaction():
                self.sync()
                yield
        except BaseException:
            self._views.clear()
            self.revision = self.store.revision
            raise
        self.revision = self.store.revision
