"""The case base store protocol every store implements."""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from contextlib import AbstractContextManager
from typing import Protocol, runtime_checkable

from cbrcore.model import JSON, Case


@runtime_checkable
class CaseStore(Protocol):
    """A transactional collection of cases.

    Writes made inside ``with store.transaction():`` commit together or not at all; a write made
    outside one is its own transaction. ``revision`` counts committed write transactions and is
    the store's logical clock: a case's ``created`` and ``last_used`` are revisions, and a plugin
    that keeps a derived index (an array of case features, a graph) rebuilds it when the revision
    it was built at is no longer current. A store opened by two processes shows each the other's
    committed writes.
    """

    @property
    def revision(self) -> int:
        """The number of write transactions committed so far."""
        ...

    def transaction(self) -> AbstractContextManager[None]:
        """Group writes; commits on normal exit, rolls back if the block raises. Re-entrant."""
        ...

    def add(self, case: Case) -> Case:
        """Store a new case (its ``id`` is ignored); return it with ``id`` and ``created`` set."""
        ...

    def replace(self, case: Case) -> None:
        """Overwrite the stored case with ``case.id``; KeyError if there is none."""
        ...

    def remove(self, ids: Iterable[int]) -> None:
        """Delete the cases with these ids; KeyError if one is missing."""
        ...

    def touch(self, ids: Iterable[int]) -> None:
        """Count one more use of each case and set its ``last_used`` to the current revision."""
        ...

    def get(self, case_id: int) -> Case:
        """The case with this id; KeyError if there is none."""
        ...

    def cases(self, kind: str | None = None) -> list[Case]:
        """All cases (of one kind when given), ordered by id."""
        ...

    def count(self, kind: str | None = None) -> int:
        """How many cases (of one kind when given) are stored."""
        ...

    def kind_counts(self) -> dict[str, int]:
        """How many cases of each kind are stored, by kind."""
        ...

    def get_meta(self, key: str, default: JSON = None) -> JSON:
        """A plugin's stored value (plain JSON data) under ``key``."""
        ...

    def set_meta(self, key: str, value: JSON) -> None:
        """Store a plugin's value under ``key``; it commits with the surrounding transaction."""
        ...

    def meta_items(self) -> dict[str, JSON]:
        """Every plugin meta value, by key."""
        ...

    def restore(self, cases: Iterable[Case], meta: Mapping[str, JSON], revision: int) -> None:
        """Fill this store, which holds no cases, with ``cases`` keeping their ids and stamps.

        Cases without an id get new ones, cases without ``created`` the restoring transaction's
        revision. The store's meta is replaced by ``meta``, and the transaction commits as
        ``revision`` when that is ahead of the store's own clock.
        """
        ...

    def check(self) -> list[str]:
        """Problems found by a full consistency check; empty when the store is sound."""
        ...

    def close(self) -> None:
        """Release the store's resources; safe to call twice."""
        ...

    def __iter__(self) -> Iterator[Case]: ...

    def __len__(self) -> int: ...


def still_current(now: int, known: int, wrote: bool) -> bool:
    """Whether an in-memory index of a store, matching it at revision ``known``, still matches
    at revision ``now``.

    For plugins that keep an index of their cases and write through to the store inside the
    engine's learn step: a step in which the index wrote must have committed exactly one
    revision (anything else is a rollback, or another process writing), one in which it did not
    write may have committed one through other writers of the same step (the engine counting
    case uses) or none. So one transaction of another process in a step without writes goes
    unnoticed: two processes should not share one such index.
    """
    return now == known + 1 if wrote else now in (known, known + 1)

