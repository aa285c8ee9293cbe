"""The case base store protocol every store implements.

Besides the members of :class:`CaseStore`, a store may have a ``describe()`` method returning
facts about where and how it keeps its case base (a file's path and size, a server's address),
by name, as plain JSON data; ``cbr casebase info`` shows them after the facts every store has
(:data:`SUMMARY_KEYS`), which they may not repeat. A store that finds its case base unusable when
it is opened (damaged, another program's, of another schema version) raises
:class:`~cbrcore.errors.UnusableCaseBase`, which ``cbr casebase check`` reports as a problem.

What ``cbr casebase`` and ``cbr run`` may do with a store's case base beyond the protocol, they
ask the options class of its component (:func:`capabilities`), never its name.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import attrs

from cbrcore.casebase.data import is_json, json_problems
from cbrcore.errors import PluginError
from cbrcore.model import JSON, Case

SUMMARY_KEYS = ("store", "revision", "cases", "kinds", "worlds")
"""The facts ``cbr casebase info`` shows for every store: its registered name, its revision, the
number of cases, the number of cases of each kind and the worlds the cases belong to."""


@attrs.frozen
class Changes:
    """What the commits after revision ``since`` did to the cases, up to ``revision``.

    Brought to ``revision``, a copy of the cases as they stood at ``since`` drops the ``removed``
    ids it holds and takes every case of ``cases`` in place of the one with its id (or as a new
    one): it then equals the cases stored at ``revision``. Meta values are not covered.
    """

    since: int
    revision: int
    cases: tuple[Case, ...]
    """Every case that those commits added, replaced or touched and that is still stored, as
    stored at ``revision``, ordered by id."""
    removed: tuple[int, ...]
    """The ids of the cases those commits removed, ordered (a case added and removed again
    after ``since`` may be among them)."""


@runtime_checkable
class CaseStore(Protocol):
    """A transactional collection of cases.

    Writes made inside ``with store.transaction():`` commit together or not at all; a write made
    outside one is its own transaction. ``revision`` counts committed write transactions and is
    the store's logical clock: a case's ``created`` and ``last_used`` are revisions, and the
    store mirror (:mod:`cbrcore.casebase.mirror`) compares them to know when an index derived
    from the cases must be loaded anew. A store that several processes may open at once shows
    each the other's committed writes.
    """

    @property
    def revision(self) -> int:
        """The number of write transactions committed so far."""
        ...

    @property
    def committed_revision(self) -> int:
        """The revision the last outermost transaction of this store object committed at.

        Its new revision if it wrote, else the revision it read (with the write lock held, where
        the store takes one); before this store object's first transaction, ``revision``. A
        write outside a transaction is such a transaction and one that rolls back changes
        nothing. Once this object has committed a transaction, no other store object's commits
        move it: ``revision`` read after a commit may already count another process's next
        transaction, this says where this object's own one left the case base (the store
        mirror labels its views with it).
        """
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

    def changes(self, since: int) -> Changes:
        """What the commits after revision ``since`` changed (:class:`Changes`), read in one
        consistent snapshot (inside a transaction, before the transaction writes).

        Costs time in proportion to what changed, not to the case base: the store mirror
        brings its views up to date with it each time another process commits.
        ValueError when ``since`` is negative or ahead of the revision.
        """
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


@attrs.frozen
class StoreFile:
    """A store keeps its case base in one file, named by its options' ``path``.

    Its options then have ``path`` (the file; None for :attr:`default_name` in the run's output
    folder, and a relative path names a file inside it), ``create`` (whether a missing file is
    created) and ``read_only``. Knowing it, ``cbr casebase import`` builds a new case base beside
    the file and moves it into place once complete, ``cbr casebase export`` refuses to overwrite
    the file, and starting a run afresh removes the file when it is in the run's folder.
    """

    default_name: str
    """The file's name in the run's output folder when ``path`` names none."""
    companions: tuple[str, ...] = ()
    """The suffixes of the files the store keeps beside the case base file (appended to its
    name) while it is open or after a crash."""

    def files(self, path: Path) -> list[Path]:
        """The case base file ``path`` and its companion files."""
        return [path, *(path.with_name(path.name + suffix) for suffix in self.companions)]


@attrs.frozen
class StoreCapabilities:
    """What a store can do beyond the protocol: the class attribute ``CAPABILITIES`` of its
    component's options class; a class without one has none of them."""

    file: StoreFile | None = None
    """How it keeps its case base in one file; None for a store that does not."""
    read_only: bool = False
    """Whether its options have ``read_only``, which opens the case base for reading alone, never
    creating it nor writing to it (``cbr casebase`` reading commands set it)."""


def capabilities(options: Any) -> StoreCapabilities:
    """What the store that ``options`` configure can do beyond the protocol."""
    found = getattr(type(options), "CAPABILITIES", None)
    return found if isinstance(found, StoreCapabilities) else StoreCapabilities()


def describe(store: CaseStore) -> dict[str, JSON]:
    """What ``store.describe()`` tells of the store, checked; empty for a store without one.

    A PluginError names the store's class when the facts are not a mapping of plain JSON data by
    name, or repeat one of :data:`SUMMARY_KEYS`.
    """
    method = getattr(store, "describe", None)
    if method is None:
        return {}
    facts = method()
    label = f"store {type(store).__name__}: describe()"
    if not isinstance(facts, dict) or not is_json(facts):
        problems = ([f"returned {type(facts).__name__}, expected a mapping"]
                    if not isinstance(facts, dict) else list(json_problems(facts, "describe()")))
        raise PluginError(f"{label} must give plain JSON facts by name: {'; '.join(problems)}")
    repeated = [key for key in facts if key in SUMMARY_KEYS]
    if repeated:
        raise PluginError(f"{label} repeats {', '.join(repeated)}, which cbr casebase info "
                          f"shows")
    return facts
