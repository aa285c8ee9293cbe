"""An in-memory case store with the transaction semantics of the SQLite store."""

from __future__ import annotations

import contextlib
import json
import operator
from collections.abc import Iterable, Iterator, Mapping
from typing import Any

import attrs

from cbrcore.casebase.data import (
    case_problems,
    check_case,
    check_meta,
    check_meta_key,
    check_since,
)
from cbrcore.casebase.store import Changes
from cbrcore.model import JSON, Case

_ABSENT = object()
"""In the undo log: the key was not in the dictionary before the write."""


class MemoryStore:
    """A case base held in memory: fast, and gone when the process ends.

    It behaves like :class:`~cbr_stores.sqlite.SQLiteStore` in everything but persistence:
    contents must be plain JSON data, a transaction commits or rolls back as a whole, ids are
    never reused, and ``revision`` counts committed write transactions.

    Stored cases are kept as given, not copied: treat a case's ``problem``, ``solution`` and
    ``meta`` as immutable and change a case with ``attrs.evolve`` and :meth:`replace`. Meta
    values are copied in and out, since plugins typically update them in place.
    """

    def __init__(self) -> None:
        self._cases: dict[int, Case] = {}
        self._meta: dict[str, str] = {}
        self._changed: dict[int, int] = {}
        """The revision each stored case was last written at."""
        self._removed: dict[int, int] = {}
        """The revision each removed case was removed at."""
        self._revision = 0
        self._next_id = 1
        self._depth = 0
        self._pending = 0
        self._wrote = False
        self._undo: list[tuple[dict[Any, Any], Any, Any]] = []
        """What the open transaction's writes overwrote, in order: (dictionary, key, old value
        or :data:`_ABSENT`); a rollback puts the old values back, newest first."""

    def __str__(self) -> str:
        return "the in-memory case base"

    def __repr__(self) -> str:
        return f"<MemoryStore {len(self._cases)} cases, revision {self._revision}>"

    def __enter__(self) -> MemoryStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def revision(self) -> int:
        """The number of write transactions committed so far."""
        return self._revision

    @property
    def committed_revision(self) -> int:
        """The revision this store's last outermost transaction committed at: its new revision
        if it wrote, else the revision it read.

        No other store object shares a memory case base, so that is always ``revision``.
        """
        return self._revision

    @contextlib.contextmanager
    def transaction(self) -> Iterator[None]:
        """Group writes; commits on normal exit, rolls back if the block raises.

        A nested block joins the outer transaction (nothing commits before the outermost block
        ends); if a nested block raises, its own writes are undone and the outer block may go on.
        Each write records what it overwrites in an undo log, so a transaction costs what it
        writes, not what the store holds.
        """
        mark = len(self._undo)
        saved = (self._next_id, self._pending, self._wrote)
        outermost = self._depth == 0
        if outermost:
            self._pending = self._revision + 1
            self._wrote = False
        self._depth += 1
        try:
            yield
        except BaseException:
            self._roll_back(mark)
            self._next_id, self._pending, self._wrote = saved
            raise
        finally:
            self._depth -= 1
            if outermost:
                self._undo.clear()
        if outermost and self._wrote:
            self._revision = self._pending

    def _roll_back(self, mark: int) -> None:
        """Undo the writes logged after ``mark``, newest first."""
        returned = False
        while len(self._undo) > mark:
            table, key, old = self._undo.pop()
            if old is _ABSENT:
                del table[key]
            else:
                returned |= table is self._cases and key not in table
                table[key] = old
        if returned:
            # a case put back after its removal went to the end: cases are listed by id
            ordered = sorted(self._cases.items())
            self._cases.clear()
            self._cases.update(ordered)

    def _set(self, table: dict[Any, Any], key: Any, value: Any) -> None:
        """``table[key] = value``, logged for a rollback inside a transaction."""
        if self._depth:
            self._undo.append((table, key, table.get(key, _ABSENT)))
        table[key] = value

    def _delete(self, table: dict[Any, Any], key: Any) -> None:
        """``del table[key]``, logged for a rollback inside a transaction."""
        if self._depth:
            self._undo.append((table, key, table[key]))
        del table[key]

    def _stamp(self) -> int:
        """The revision the write being made commits as."""
        return self._pending if self._depth else self._revision + 1

    def _written(self) -> None:
        # every write method checks everything before changing anything, so a write outside a
        # transaction commits right here and needs no rollback
        if self._depth:
            self._wrote = True
        else:
            self._revision += 1

    def add(self, case: Case) -> Case:
        """Store a new case; return it with its ``id`` and ``created`` set (given ones ignored).

        ``uses`` and ``last_used`` are kept.
        """
        revision = self._stamp()
        stored = attrs.evolve(case, id=self._next_id, created=revision)
        check_case(stored, revision)
        self._set(self._cases, stored.id, stored)
        self._set(self._changed, stored.id, revision)
        self._next_id += 1
        self._written()
        return stored

    def replace(self, case: Case) -> None:
        """Overwrite the stored case with ``case.id``; KeyError if there is none.

        Every field is taken from ``case``, except that ``created`` stays when it is None.
        """
        old = self.get(case.id)
        stored = case if case.created is not None else attrs.evolve(case, created=old.created)
        check_case(stored, self._stamp())
        self._set(self._cases, old.id, attrs.evolve(stored, id=old.id))
        self._set(self._changed, old.id, self._stamp())
        self._written()

    def remove(self, ids: Iterable[int]) -> None:
        """Delete the cases with these ids; KeyError if one is missing (then none is deleted)."""
        unique = self._existing(ids)
        if unique:
            for case_id in unique:
                self._delete(self._cases, case_id)
                self._delete(self._changed, case_id)
                self._set(self._removed, case_id, self._stamp())
            self._written()

    def touch(self, ids: Iterable[int]) -> None:
        """Count one more use of each case (once per distinct id) and stamp its ``last_used``.

        The stamp is the revision the write commits as. KeyError if an id is missing.
        """
        unique = self._existing(ids)
        if unique:
            revision = self._stamp()
            for case_id in unique:
                case = self._cases[case_id]
                self._set(self._cases, case_id,
                          attrs.evolve(case, uses=case.uses + 1, last_used=revision))
                self._set(self._changed, case_id, revision)
            self._written()

    def _existing(self, ids: Iterable[int]) -> list[int]:
        unique = list(dict.fromkeys(operator.index(i) for i in ids))
        for case_id in unique:
            if case_id not in self._cases:
                raise KeyError(case_id)
        return unique

    def get(self, case_id: int) -> Case:
        """The case with this id; KeyError if there is none."""
        return self._cases[operator.index(case_id)]

    def changes(self, since: int) -> Changes:
        """What the commits after revision ``since`` changed (:class:`Changes`).

        A scan of the cases, not an index: no other process shares a memory case base, so its
        mirror never has another writer's commits to catch up with.
        """
        check_since(since, self._revision)
        return Changes(since, self._revision,
                       tuple(case for case_id, case in self._cases.items()
                             if self._changed[case_id] > since),
                       tuple(sorted(case_id for case_id, revision in self._removed.items()
                                    if revision > since)))

    def cases(self, kind: str | None = None) -> list[Case]:
        """All cases (of one kind when given), ordered by id."""
        if kind is None:
            return list(self._cases.values())
        return [case for case in self._cases.values() if case.kind == kind]

    def count(self, kind: str | None = None) -> int:
        """How many cases (of one kind when given) are stored."""
        if kind is None:
            return len(self._cases)
        return sum(1 for case in self._cases.values() if case.kind == kind)

    def kind_counts(self) -> dict[str, int]:
        """How many cases of each kind are stored, by kind."""
        counts: dict[str, int] = {}
        for case in self._cases.values():
            counts[case.kind] = counts.get(case.kind, 0) + 1
        return dict(sorted(counts.items()))

    def get_meta(self, key: str, default: JSON = None) -> JSON:
        """A plugin's stored value (plain JSON data) under ``key``."""
        check_meta_key(key)
        text = self._meta.get(key)
        return default if text is None else json.loads(text)

    def set_meta(self, key: str, value: JSON) -> None:
        """Store a plugin's value under ``key``; it commits with the surrounding transaction."""
        check_meta(key, value)
        self._set(self._meta, key, json.dumps(value))
        self._written()

    def meta_items(self) -> dict[str, JSON]:
        """Every plugin meta value, by key."""
        return {key: json.loads(text) for key, text in sorted(self._meta.items())}

    def restore(self, cases: Iterable[Case], meta: Mapping[str, JSON], revision: int) -> None:
        """Fill this store, which holds no cases, with ``cases`` keeping their ids and stamps.

        Cases without an id get new ones, cases without ``created`` the restoring transaction's
        revision. The store's meta is replaced by ``meta``, and the transaction commits as
        ``revision`` when that is ahead of the store's own clock.
        """
        if self._cases:
            raise ValueError("restore needs a store without cases")
        with self.transaction():
            if revision >= self._pending:
                # moving the clock forward is a write even when nothing else changes
                self._pending = revision
                self._wrote = True
            cases = list(cases)
            given = [operator.index(case.id) for case in cases if case.id is not None]
            if len(set(given)) != len(given):
                raise ValueError("restore got two cases with the same id")
            self._next_id = max([self._next_id, *(i + 1 for i in given)])
            restored = []
            for case in cases:
                stored = case
                if case.id is None:
                    stored = attrs.evolve(stored, id=self._next_id)
                    self._next_id += 1
                if case.created is None:
                    stored = attrs.evolve(stored, created=self._pending)
                check_case(stored, self._pending)
                restored.append(stored)
            if restored or self._meta:
                self._wrote = True
            for case in sorted(restored, key=operator.attrgetter("id")):
                self._set(self._cases, case.id, case)
                self._set(self._changed, case.id, self._pending)
            for key in list(self._meta):
                self._delete(self._meta, key)
            for key, value in meta.items():
                self.set_meta(key, value)

    def check(self) -> list[str]:
        """Problems found by a full consistency check; empty when the store is sound."""
        bound = self._pending if self._depth else self._revision
        problems = []
        for case_id, case in self._cases.items():
            if case.id != case_id:
                problems.append(f"case {case_id}: stored under id {case_id} but says id {case.id}")
            problems.extend(f"case {case_id}: {p}" for p in case_problems(case, bound))
            if case.created is None:
                problems.append(f"case {case_id}: created: missing")
        return problems

    def close(self) -> None:
        """Nothing to release; the contents stay readable."""

    def __iter__(self) -> Iterator[Case]:
        return iter(self.cases())

    def __len__(self) -> int:
        return len(self._cases)
