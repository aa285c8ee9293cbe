"""Typed shared state (``ctx.stash``) and the core store mirror (``ctx.mirror``)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from cbr_stores.sqlite import SQLiteStore
from cbrcore.casebase.memory import MemoryStore
from cbrcore.casebase.mirror import FollowsChanges, StoreMirror
from cbrcore.casebase.store import CaseStore, Changes
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.model import Case
from cbrcore.registry import Registry
from cbrcore.stash import Stash, StashKey

WORDS = StashKey[list[str]]()
COUNT = StashKey[int]()


def test_a_stash_keeps_values_under_typed_keys_that_never_collide() -> None:
    stash = Stash()
    assert WORDS not in stash and stash.get(WORDS, None) is None
    assert stash.setdefault(WORDS, []) == [] and WORDS in stash
    stash[WORDS].append("door")
    assert stash.setdefault(WORDS, ["other"]) == ["door"]
    stash[COUNT] = 3
    twin = StashKey[int]()  # another plugin's key of the same type is another key
    assert twin not in stash and stash[COUNT] == 3 and len(stash) == 2
    with pytest.raises(KeyError):
        stash[twin]
    del stash[COUNT]
    assert COUNT not in stash and len(stash) == 1


LABELS = StashKey[list[str]]()
"""A view: the labels of all stored cases, as a family would index them."""


class Loads:
    """Load the labels view, counting the loads."""

    def __init__(self) -> None:
        self.count = 0

    def __call__(self, store: CaseStore) -> list[str]:
        self.count += 1
        return [case.problem for case in store.cases()]


def add(mirror: StoreMirror, load: Loads, label: str) -> None:
    """Write through: the store and the view change together, as a family's retainer does."""
    labels = mirror.view(LABELS, load)
    mirror.store.add(Case(label, None))
    labels.append(label)


@pytest.fixture(params=["memory", "sqlite"])
def store(request: pytest.FixtureRequest, tmp_path: Path) -> Any:
    opened = MemoryStore() if request.param == "memory" else SQLiteStore(tmp_path / "cb.sqlite")
    yield opened
    opened.close()


def test_a_view_is_loaded_once_and_follows_the_writes_of_committed_steps(store: Any) -> None:
    mirror, load = StoreMirror(store), Loads()
    assert mirror.view(LABELS, load) == [] and load.count == 1
    with mirror.transaction():
        add(mirror, load, "a")
        add(mirror, load, "b")
    mirror.sync()
    assert mirror.view(LABELS, load) == ["a", "b"] == [c.problem for c in store.cases()]
    assert load.count == 1 and mirror.revision == store.revision and mirror.reloads == 0


def test_a_step_that_rolls_back_drops_the_view_it_changed(store: Any) -> None:
    mirror, load = StoreMirror(store), Loads()
    with mirror.transaction():
        add(mirror, load, "a")
    with pytest.raises(RuntimeError), mirror.transaction():
        add(mirror, load, "b")
        assert mirror.view(LABELS, load) == ["a", "b"]  # the step sees its own writes
        raise RuntimeError("a forgetter failed")
    assert mirror.view(LABELS, load) == ["a"] == [c.problem for c in store.cases()]
    assert load.count == 2 and mirror.revision == store.revision


def test_another_writers_commit_drops_the_views_before_the_next_query_and_step(
        tmp_path: Path) -> None:
    path = tmp_path / "shared.sqlite"
    ours, theirs = SQLiteStore(path), SQLiteStore(path)
    try:
        mirror, load = StoreMirror(ours), Loads()
        with mirror.transaction():
            add(mirror, load, "ours")
        theirs.add(Case("theirs", None))
        assert mirror.view(LABELS, load) == ["ours"]  # kept until the engine syncs
        mirror.sync()
        assert mirror.view(LABELS, load) == ["ours", "theirs"] and mirror.reloads == 1
        theirs.add(Case("again", None))
        with mirror.transaction():  # a step catches up under the write lock before it writes
            add(mirror, load, "last")
        assert mirror.view(LABELS, load) == ["ours", "theirs", "again", "last"]
        assert [c.problem for c in theirs.cases()] == ["ours", "theirs", "again", "last"]
        assert load.count == 3 and mirror.reloads == 2
    finally:
        ours.close()
        theirs.close()


class Overtaken(SQLiteStore):
    """A store whose next outermost transaction is followed at once by another's commit.

    ``rival`` (another store object on the same file, standing for another process) writes the
    moment the transaction has ended: the other process that was waiting for the write lock and
    got it before this one could read the revision again.
    """

    def __init__(self, path: Path, rival: SQLiteStore) -> None:
        super().__init__(path)
        self.rival = rival
        self.armed = False
        self.depth = 0

    @contextlib.contextmanager
    def transaction(self) -> Iterator[None]:
        self.depth += 1
        try:
            with super().transaction():
                yield
        finally:
            self.depth -= 1
            if self.depth == 0 and self.armed:
                self.armed = False
                self.rival.add(Case("theirs", None))


@pytest.fixture
def overtaken(tmp_path: Path) -> Iterator[Overtaken]:
    theirs = SQLiteStore(tmp_path / "shared.sqlite")
    ours = Overtaken(tmp_path / "shared.sqlite", theirs)
    yield ours
    ours.close()
    theirs.close()


def test_a_commit_right_after_a_learn_step_drops_the_views_it_kept(overtaken: Overtaken) -> None:
    mirror, load = StoreMirror(overtaken), Loads()
    overtaken.armed = True
    with mirror.transaction():
        add(mirror, load, "ours")
    assert (overtaken.committed_revision, overtaken.revision) == (1, 2)
    mirror.sync()  # the view holds revision 1, without the other writer's case of revision 2
    assert mirror.view(LABELS, load) == ["ours", "theirs"] and load.count == 2
    assert mirror.reloads == 1 and mirror.revision == 2


def test_a_commit_right_after_a_failed_step_is_caught_up_with(overtaken: Overtaken) -> None:
    overtaken.add(Case("kept", None))
    mirror, load = StoreMirror(overtaken), Loads()
    overtaken.armed = True
    with pytest.raises(RuntimeError), mirror.transaction():
        add(mirror, load, "lost")
        raise RuntimeError("a retainer failed")
    assert mirror.revision == 1  # what the step read under the lock, and left the store at
    mirror.sync()
    assert (mirror.catch_ups, mirror.revision) == (1, 2)
    assert mirror.view(LABELS, load) == ["kept", "theirs"] and load.count == 2


class Labels(dict[int, str]):
    """A view that follows changes: the label of each stored case, by id."""

    def __init__(self, store: CaseStore, *, follows: bool = True) -> None:
        super().__init__((case.id, case.problem) for case in store.cases())
        self.follows = follows
        self.seen: list[Changes] = []

    def catch_up(self, changes: Changes) -> bool:
        self.seen.append(changes)
        if not self.follows:
            return False
        for case_id in changes.removed:
            self.pop(case_id, None)
        self.update((case.id, case.problem) for case in changes.cases)
        return True


FOLLOWING = StashKey[Labels]()
REFUSING = StashKey[Labels]()


def test_a_view_that_follows_changes_takes_them_instead_of_a_reload(tmp_path: Path) -> None:
    path = tmp_path / "shared.sqlite"
    with SQLiteStore(path) as ours, SQLiteStore(path) as theirs:
        ours.add(Case("a", None))
        mirror = StoreMirror(ours)
        following = mirror.view(FOLLOWING, Labels)
        refusing = mirror.view(REFUSING, lambda store: Labels(store, follows=False))
        with theirs.transaction():
            theirs.add(Case("b", None))
            theirs.remove([1])
        mirror.sync()
        assert following.seen == [Changes(1, 2, (theirs.get(2),), (1,))]
        assert mirror.view(FOLLOWING, Labels) is following and following == {2: "b"}
        assert isinstance(following, FollowsChanges)
        # the view that could not follow was dropped and is loaded anew
        assert mirror.view(REFUSING, Labels) is not refusing
        assert (mirror.catch_ups, mirror.reloads, mirror.revision) == (1, 1, 2)


def test_the_context_mirrors_its_case_base() -> None:
    ctx = Context(registry=Registry(), seed=0)
    with pytest.raises(CbrError, match="needs one"):
        _ = ctx.mirror
    ctx.casebase = MemoryStore()
    mirror = ctx.mirror
    assert ctx.mirror is mirror and mirror.store is ctx.casebase
    ctx.casebase = MemoryStore()
    assert ctx.mirror is not mirror and ctx.mirror.store is ctx.casebase


def test_a_view_nobody_asked_for_during_a_step_that_wrote_is_loaded_anew(store: Any) -> None:
    mirror, load = StoreMirror(store), Loads()
    assert mirror.view(LABELS, load) == []
    with mirror.transaction():  # another component writes to the store, not through the view
        store.add(Case("met", None))
    assert mirror.view(LABELS, load) == ["met"] and load.count == 2
    with mirror.transaction():  # a step that writes nothing keeps every view
        pass
    assert mirror.view(LABELS, load) == ["met"] and load.count == 2
