"""What components derive from a case base, kept at the store's revision.

A family that answers queries from an index of its cases (the arrays of all stored paths, a case
graph, a map of learned risks) cannot re-read the store at every query, so it keeps the index in
memory. The index is right exactly as long as nothing moved the store without it: not a learn
step that rolled back after the index had changed, not another process sharing the case base,
not another component writing cases the index does not know of.

:class:`StoreMirror` is the one place that knows. It holds each family's index as a *view* under
a typed key, and the engine runs every learn step inside :meth:`StoreMirror.transaction`:

- before each query, and at the start of each learn step (before its transaction and again
  inside it, with the store's write lock held), :meth:`StoreMirror.sync` compares the store's
  revision with the one the mirror last saw: when they differ another writer committed. A view
  that can follow the changes (it has a ``catch_up`` method, :class:`FollowsChanges`) is handed
  what changed since (the store's :meth:`~cbrcore.casebase.store.CaseStore.changes`, which
  costs what changed, not the case base) and brings itself up to date; every other view is
  dropped, to be loaded anew from the store the next time it is asked for;
- when the learn step commits, a view asked for during the step is kept at the revision the
  step committed at (the store's ``committed_revision``, not its ``revision`` read again, which
  may already count another process's next commit that the view lacks): a component that asks
  for a view in the learn step writes its changes through it, to the store and to the view
  together (the case graph, the path index, the learned map do). A view nobody asked for during
  a step that wrote is dropped, so an index that only reads (a retriever's array of case
  features) is loaded anew after every step that changed the store;
- when the step fails, the views may hold writes the store no longer has, so they are dropped.

A family's view is what :meth:`StoreMirror.view` returns; it loads it with the family's own
function on first use and after a drop. Components never keep a view across queries: they ask the
mirror each time, which is a dictionary look-up.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from typing import Any, Protocol, TypeVar, runtime_checkable

from cbrcore.casebase.store import CaseStore, Changes
from cbrcore.stash import StashKey

T = TypeVar("T")


@runtime_checkable
class FollowsChanges(Protocol):
    """A view that brings itself up to date with another writer's commits.

    ``catch_up`` applies ``changes`` (the cases written and the ids removed since the revision
    the view matches) to the view, reading nothing else and writing nothing to the store, and
    returns True; or returns False, having changed nothing, when it cannot (the mirror then
    drops the view and loads it anew). A view that derives from meta values as well as cases
    cannot follow changes, which do not cover meta values.
    """

    def catch_up(self, changes: Changes) -> bool: ...


class StoreMirror:
    """The views components derive from ``store``, and the revision they match."""

    def __init__(self, store: CaseStore) -> None:
        self.store = store
        self.revision = store.revision
        """The store revision every view matches."""
        self.catch_ups = 0
        """How many times another writer had moved the store and the mirror caught up."""
        self.reloads = 0
        """How many views were dropped, to be loaded anew, because the store moved without them
        and they could not follow the changes."""
        self._views: dict[StashKey[Any], Any] = {}
        self._asked: set[StashKey[Any]] | None = None
        """The views asked for during the learn step under way; None outside one."""

    def view(self, key: StashKey[T], load: Callable[[CaseStore], T]) -> T:
        """The view under ``key``, loaded from the store by ``load`` if the mirror has none.

        Asked for during a learn step, the view is taken to follow that step's writes.
        """
        if self._asked is not None:
            self._asked.add(key)
        try:
            return self._views[key]
        except KeyError:
            value = self._views[key] = load(self.store)
            return value

    def put(self, key: StashKey[T], value: T) -> None:
        """Replace the view under ``key``: a component that writes through an immutable view
        (a map) puts the changed one, inside the learn step that writes it to the store."""
        if self._asked is not None:
            self._asked.add(key)
        self._views[key] = value

    @property
    def learning(self) -> bool:
        """Whether a learn step (:meth:`transaction`) is under way: outside one, a component
        must not write to the store."""
        return self._asked is not None

    def sync(self) -> None:
        """Catch up with another writer that moved the store since the mirror last saw it: the
        views that follow changes take them, the others are dropped."""
        now = self.store.revision
        if now == self.revision:
            return
        following = {key: view for key, view in self._views.items()
                     if isinstance(view, FollowsChanges)}
        try:
            if following:
                changes = self.store.changes(self.revision)
                now = changes.revision
                following = {key: view for key, view in following.items()
                             if view.catch_up(changes)}
        except BaseException:
            # a view may be halfway through the changes
            self._views.clear()
            raise
        self.reloads += len(self._views) - len(following)
        self._views = following
        self.revision = now
        self.catch_ups += 1

    @contextlib.contextmanager
    def transaction(self) -> Iterator[None]:
        """One learn step: a store transaction whose writes the views follow, all or nothing.

        It must be the store's outermost transaction. The mirror catches up with other writers
        first: before the transaction, then inside it for what was committed in between (so
        nobody can commit between the catch-up and the step). If the block raises,
        the transaction rolls back and the views, which may hold its writes, are dropped; if it
        commits writes, the views nobody asked for during the step are dropped, since nothing
        wrote through them.
        """
        self._asked = set()
        try:
            # catching up before the write lock is taken leaves the lock held for the step
            # itself: under it, only what was committed in between is left to catch up with
            self.sync()
            with self.store.transaction():
                self.sync()
                before = self.revision
                yield
        except BaseException:
            # Nothing of the step is in the store, and the views that might show it are gone.
            # The revision stays the one read under the lock (or the last one seen, when the
            # transaction never began): reading the store here could fail and hide the error,
            # and the next sync compares against it and counts a move by another writer.
            self._views.clear()
            raise
        else:
            # Not store.revision: another writer may have committed since our commit, and the
            # kept views would then be labelled with a revision whose writes they lack, so
            # the next sync would find nothing to catch up with.
            self.revision = self.store.committed_revision
            if self.revision != before:
                self._views = {key: view for key, view in self._views.items()
                               if key in self._asked}
        finally:
            self._asked = None
