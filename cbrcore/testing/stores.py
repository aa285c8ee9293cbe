"""The store protocol as tests: subclass :class:`StoreContract` to run them on a store.

A store plugin's test suite runs every test of the :class:`~cbrcore.casebase.CaseStore` protocol
on its store with one class::

    import pytest
    from cbrcore.testing import StoreContract

    from my_plugin import MyStore


    class TestMyStore(StoreContract):
        persistent = True   # a closed store opened again holds what it committed
        shared = True       # two stores open at once on one case base see each other's commits

        @pytest.fixture
        def open_store(self, tmp_path):
            return lambda name: MyStore(tmp_path / f"{name}.db")

``open_store`` returns a callable that opens the case base called ``name``: a name not opened
before is a new, empty case base, and the same name opens the same case base again. The
reference for what a store must do is :class:`~cbrcore.casebase.MemoryStore`: random sequences
of operations and transactions must leave the store under test in the state they leave a memory
store in (with hypothesis, a test dependency of cbrcore).

The tests of a promise (``persistent``, ``shared``) are added to a subclass that makes it, and
only then: a store that does not make a promise has no tests of it, rather than skipped ones.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any, ClassVar

import attrs
import pytest

from cbrcore.casebase import (
    CaseStore,
    Changes,
    Document,
    describe,
    document_of,
    load_document,
)
from cbrcore.model import Case

OpenStore = Callable[[str], CaseStore]
"""Opens the case base called ``name`` (a new, empty one when the name is new)."""


class Boom(Exception):
    """Raised by the tests to abandon a transaction."""


def state(store: CaseStore) -> tuple[Any, ...]:
    """What a store holds: its revision, its cases and its meta values."""
    return store.revision, store.cases(), store.meta_items()


class StoreContract:
    """Every test of the store protocol, run on the store that ``open_store`` opens.

    Subclass it in a test module (with a name starting with ``Test``) and define the
    ``open_store`` fixture; set ``persistent`` and ``shared`` to what the store promises, which
    adds the tests of those promises to the subclass (and only then: no test is skipped).
    Inside the class, ``store`` is a new, empty case base, and
    ``stores(name)`` opens case bases as ``open_store`` does; every store they open is closed
    when the test ends.
    """

    persistent: ClassVar[bool] = False
    """Whether a closed store opened again holds everything it had committed."""

    shared: ClassVar[bool] = False
    """Whether two stores open at once on one case base see each other's commits."""

    @pytest.fixture
    def open_store(self) -> OpenStore:
        """Opens the case base called ``name``: define this fixture in the subclass."""
        pytest.fail(f"{type(self).__name__} must define the open_store fixture", pytrace=False)

    @pytest.fixture
    def stores(self, open_store: OpenStore) -> Iterator[OpenStore]:
        """``open_store``, closing every store it opened when the test ends."""
        opened: list[CaseStore] = []

        def open_(name: str) -> CaseStore:
            store = open_store(name)
            opened.append(store)
            return store

        yield open_
        for store in reversed(opened):
            store.close()

    @pytest.fixture
    def store(self, stores: OpenStore) -> CaseStore:
        """A new, empty case base."""
        return stores("casebase")

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """Add the tests of the promises the subclass makes; hide those of the promises it
        does not make but a base class did."""
        super().__init_subclass__(**kwargs)
        for promise, tests in _PROMISES.items():
            for name, test in vars(tests).items():
                if not name.startswith("test_"):
                    continue
                if getattr(cls, promise):
                    setattr(cls, name, test)
                elif hasattr(cls, name):
                    setattr(cls, name, None)  # pytest collects only callables

    # -- the protocol -----------------------------------------------------------------------

    def test_a_new_store_is_empty_and_implements_the_protocol(self, store: CaseStore) -> None:
        assert isinstance(store, CaseStore)
        assert store.revision == 0
        assert len(store) == 0
        assert list(store) == []
        assert store.meta_items() == {}
        assert store.check() == []

    def test_add_outside_a_transaction_commits_each_case(self, store: CaseStore) -> None:
        first = store.add(Case({"start": [0, 0]}, [[0, 0], [1, 0]], id=99, created=42))
        second = store.add(Case("p", "s", kind="vertex", uses=2))
        assert (first.id, first.created, second.id, second.created) == (1, 1, 2, 2)
        assert second.uses == 2
        assert store.revision == 2
        assert store.get(1) == first
        assert store.get(2) == second
        assert list(store) == [first, second]

    def test_ids_are_never_reused(self, store: CaseStore) -> None:
        for n in range(3):
            store.add(Case(n, n))
        store.remove([3])
        assert store.add(Case(3, 3)).id == 4

    def test_replace_overwrites_and_keeps_created_when_none(self, store: CaseStore) -> None:
        case = store.add(Case("p", "s"))
        store.replace(attrs.evolve(case, solution="better", meta={"why": "shorter"}))
        assert store.get(case.id).solution == "better"
        assert store.revision == 2
        store.replace(Case("q", "t", kind="other", id=case.id, uses=5))
        assert store.get(case.id) == Case("q", "t", "other", {}, case.id, 5, 1, None)

    def test_replace_of_a_missing_case_raises_and_writes_nothing(self, store: CaseStore) -> None:
        store.add(Case("p", "s"))
        with pytest.raises(KeyError):
            store.replace(Case("p", "s", id=7))
        assert store.revision == 1

    def test_remove_is_all_or_nothing(self, store: CaseStore) -> None:
        for n in range(3):
            store.add(Case(n, n))
        with pytest.raises(KeyError):
            store.remove([1, 99])
        assert store.count() == 3
        assert store.revision == 3
        store.remove([1, 2, 1])
        assert [c.id for c in store.cases()] == [3]
        assert store.revision == 4
        store.remove([])
        assert store.revision == 4
        with pytest.raises(KeyError):
            store.get(1)

    def test_touch_counts_uses_and_stamps_the_committing_revision(self, store: CaseStore) -> None:
        a = store.add(Case("a", 1))
        b = store.add(Case("b", 2))
        store.touch([a.id, a.id])
        assert store.get(a.id).uses == 1
        assert store.get(a.id).last_used == 3
        with store.transaction():
            store.add(Case("c", 3))
            store.touch([a.id, b.id])
            assert store.revision == 3
        assert store.revision == 4
        assert (store.get(a.id).uses, store.get(a.id).last_used) == (2, 4)
        assert (store.get(b.id).uses, store.get(b.id).last_used) == (1, 4)
        with pytest.raises(KeyError):
            store.touch([b.id, 99])
        assert store.get(b.id).uses == 1
        store.touch([])
        assert store.revision == 4

    def test_a_missing_id_undoes_only_its_own_write_and_is_named(self,
                                                                 store: CaseStore) -> None:
        a, b = store.add(Case("a", 1)), store.add(Case("b", 2))
        with store.transaction():
            store.touch([a.id])
            with pytest.raises(KeyError) as missing:
                store.remove([b.id, 99, 98])
            assert missing.value.args == (99,)
            with pytest.raises(KeyError) as missing:
                store.touch([b.id, a.id, 98])
            assert missing.value.args == (98,)
        assert [(c.id, c.uses) for c in store.cases()] == [(a.id, 1), (b.id, 0)]
        assert store.revision == 3

    def test_cases_and_counts_by_kind(self, store: CaseStore) -> None:
        for kind in ["vertex", "segment", "vertex"]:
            store.add(Case(kind, None, kind=kind))
        assert [c.id for c in store.cases("vertex")] == [1, 3]
        assert store.cases("nothing") == []
        assert (store.count(), store.count("vertex"), store.count("segment")) == (3, 2, 1)
        assert store.kind_counts() == {"segment": 1, "vertex": 2}
        assert len(store) == 3
        assert [c.id for c in store] == [1, 2, 3]

    def test_contents_come_back_as_they_were_given(self, store: CaseStore) -> None:
        given = [
            Case({"cell": [1, 2], "done": True, "none": None}, [[1, 2], [2, 2]],
                 meta={"cost": 1.5, "": []}),
            Case("lone \ud800 surrogate \x00\x85\u2028 ünïcode", -0.0, kind="vértex ✓"),
            Case({"yes": "no", "1:20": "null", "~": 1e300}, [5e-324, 2**70, -(2**63)]),
        ]
        added = [store.add(case) for case in given]
        store.set_meta("odd \x00 key ✓", {"text": "\ud800\x85", "big": 2**70, "tiny": 5e-324})
        assert store.cases() == added
        assert [(c.problem, c.solution, c.kind, c.meta) for c in added] == [
            (c.problem, c.solution, c.kind, c.meta) for c in given]
        assert store.meta_items() == {"odd \x00 key ✓": {"text": "\ud800\x85", "big": 2**70,
                                                         "tiny": 5e-324}}

    def test_meta_values_are_plain_data_copied_in_and_out(self, store: CaseStore) -> None:
        assert store.get_meta("index") is None
        assert store.get_meta("index", {"built": False}) == {"built": False}
        value = {"built_at": 0, "ids": [1, 2]}
        store.set_meta("index", value)
        value["ids"].append(3)
        got = store.get_meta("index")
        assert got == {"built_at": 0, "ids": [1, 2]}
        got["ids"].append(4)
        assert store.get_meta("index") == {"built_at": 0, "ids": [1, 2]}
        assert store.meta_items() == {"index": {"built_at": 0, "ids": [1, 2]}}
        assert store.revision == 1

    def test_the_revision_key_is_reserved(self, store: CaseStore) -> None:
        with pytest.raises(ValueError, match="reserved"):
            store.set_meta("cbrcore.revision", 5)
        with pytest.raises(ValueError, match="reserved"):
            store.get_meta("cbrcore.revision")

    def test_a_transaction_commits_once(self, store: CaseStore) -> None:
        with store.transaction():
            cases = [store.add(Case(n, n)) for n in range(3)]
            store.set_meta("k", 1)
            assert store.revision == 0
        assert store.revision == 1
        assert {c.created for c in cases} == {1}
        assert store.cases() == cases

    def test_read_only_and_empty_transactions_do_not_count(self, store: CaseStore) -> None:
        store.add(Case(1, 1))
        with store.transaction():
            store.cases()
            store.get_meta("k")
        with store.transaction(), store.transaction():
            pass
        assert store.revision == 1

    def test_the_committed_revision_is_where_the_last_transaction_left_the_store(
            self, store: CaseStore) -> None:
        assert store.committed_revision == 0
        store.add(Case(1, 1))
        assert store.committed_revision == 1
        with store.transaction():
            store.add(Case(2, 2))
            store.set_meta("k", 1)
            assert store.committed_revision == 1  # nothing has committed yet
        assert store.committed_revision == 2
        with store.transaction(), store.transaction():
            store.cases()
        assert store.committed_revision == 2  # read, not written
        with pytest.raises(Boom), store.transaction():
            store.add(Case(3, 3))
            raise Boom
        assert store.committed_revision == 2 == store.revision

    def test_a_raising_transaction_leaves_no_trace(self, store: CaseStore) -> None:
        kept = store.add(Case("kept", 1))
        store.set_meta("k", "before")
        before = state(store)
        with pytest.raises(Boom), store.transaction():
            store.add(Case("lost", 2))
            store.replace(attrs.evolve(kept, solution=3))
            store.touch([kept.id])
            store.set_meta("k", "after")
            store.set_meta("new", 1)
            store.remove([kept.id])
            raise Boom
        assert state(store) == before
        assert store.add(Case("next", 3)).id == 2

    def test_nested_blocks_join_the_outer_transaction(self, store: CaseStore) -> None:
        with store.transaction():
            store.add(Case("outer", 1))
            with store.transaction():
                store.add(Case("inner", 2))
            assert store.revision == 0
            try:
                with store.transaction():
                    store.add(Case("undone", 3))
                    store.set_meta("undone", True)
                    raise Boom
            except Boom:
                pass
            store.add(Case("after", 4))
        assert [c.problem for c in store.cases()] == ["outer", "inner", "after"]
        assert {c.created for c in store.cases()} == {1}
        assert store.meta_items() == {}
        assert store.revision == 1

    def test_a_nested_block_that_only_undid_its_writes_does_not_count(
            self, store: CaseStore) -> None:
        with store.transaction():
            try:
                with store.transaction():
                    store.add(Case("undone", 1))
                    raise Boom
            except Boom:
                pass
        assert store.revision == 0
        assert store.count() == 0

    def test_an_outer_failure_undoes_committed_nested_blocks(self, store: CaseStore) -> None:
        with pytest.raises(Boom), store.transaction():
            with store.transaction():
                store.add(Case("inner", 1))
            raise Boom
        assert (store.revision, store.count()) == (0, 0)

    @pytest.mark.parametrize(("case", "expected"), [
        (Case(math.nan, 1, kind="vertex"), r"case kind 'vertex': problem: nan is not JSON"),
        (Case({"d": [1, math.inf]}, 1), r"problem\.d\[1\]: inf is not JSON"),
        (Case(1, (1, 2), kind="segment"), r"case kind 'segment': solution: a tuple is not JSON"),
        (Case(1, {3: "x"}), r"solution: key 3 is not a string"),
        (Case(1, 1, meta={"when": object()}), r"meta\.when: object .* is not JSON"),
        (Case(1, 1, kind=""), r"kind: expected a non-empty string"),
        (Case(1, 1, uses=-1), r"uses: expected a non-negative integer"),
        (Case(1, 1, last_used=5), r"last_used: revision 5 is after the case base's revision 1"),
    ])
    def test_contents_that_are_not_plain_data_are_refused(self, store: CaseStore, case: Case,
                                                          expected: str) -> None:
        with pytest.raises(ValueError, match=expected):
            store.add(case)
        assert (store.revision, store.count()) == (0, 0)

    def test_meta_values_must_be_plain_data(self, store: CaseStore) -> None:
        with pytest.raises(ValueError, match=r"meta key 'k': value\[0\]: nan is not JSON"):
            store.set_meta("k", [math.nan])
        assert store.revision == 0

    def test_restore_keeps_ids_and_stamps(self, store: CaseStore) -> None:
        store.set_meta("old", 1)
        cases = [Case("b", 2, id=5, uses=1, created=2, last_used=7),
                 Case("a", 1, id=2, created=1), Case("new", 3)]
        store.restore(cases, {"index": [1]}, 7)
        assert store.revision == 7
        assert [c.id for c in store.cases()] == [2, 5, 6]
        assert store.get(5) == cases[0]
        assert store.get(6).created == 7
        assert store.meta_items() == {"index": [1]}
        assert store.check() == []
        with pytest.raises(ValueError, match="without cases"):
            store.restore([], {}, 0)

    def test_an_exported_case_base_imports_back_equal(self, stores: OpenStore) -> None:
        original = stores("original")
        with original.transaction():
            for n in range(4):
                original.add(Case({"n": n}, [n, n + 1], kind="vertex" if n % 2 else "case"))
            original.set_meta("index", {"built_at": 1})
        original.touch([1, 3])
        original.remove([2])
        document = document_of(original)
        copy = stores("copy")
        assert load_document(copy, document) == 3
        assert state(copy) == state(original)
        assert document_of(copy) == document

    def test_an_import_is_one_transaction(self, store: CaseStore) -> None:
        document = Document(0, {}, (Case("fine", 1), Case(math.nan, 2)))
        with pytest.raises(ValueError, match="problem: nan"):
            load_document(store, document, append=True)
        with pytest.raises(ValueError, match="problem: nan"):
            load_document(store, document)
        assert (store.revision, store.count()) == (0, 0)

    def test_closing_twice_is_harmless(self, store: CaseStore) -> None:
        store.add(Case(1, 1))
        store.close()
        store.close()

    def test_describe_gives_plain_facts_or_none(self, store: CaseStore) -> None:
        store.add(Case(1, 1))
        facts = describe(store)  # raises, naming the store, what it must not return
        assert all(key for key in facts)
        if not hasattr(store, "describe"):
            assert facts == {}

    # -- what changed -----------------------------------------------------------------------

    def test_changes_name_every_case_written_and_every_id_removed(self,
                                                                  store: CaseStore) -> None:
        kept, touched, replaced, gone = (store.add(Case(n, n)) for n in range(4))
        since = store.revision
        assert store.changes(since) == Changes(since, since, (), ())
        with store.transaction():
            store.touch([touched.id])
            store.replace(attrs.evolve(replaced, solution="new"))
            store.remove([gone.id])
            added = store.add(Case(5, 5))
            store.set_meta("k", 1)  # meta values are not among the changes
        with pytest.raises(Boom), store.transaction():
            store.replace(attrs.evolve(kept, solution="rolled back"))
            raise Boom
        changes = store.changes(since)
        assert changes.since == since and changes.revision == store.revision == since + 1
        assert changes.cases == tuple(store.get(case.id)
                                      for case in (touched, replaced, added))
        assert changes.removed == (gone.id,)
        assert store.changes(0).cases == tuple(store.cases())
        assert store.changes(0).removed == (gone.id,)

    def test_changes_bring_an_old_copy_up_to_date(self, store: CaseStore) -> None:
        copies = {}
        for n in range(6):
            copies[store.revision] = {case.id: case for case in store.cases()}
            with store.transaction():
                store.add(Case(n, n, kind="odd" if n % 2 else "even"))
                if n >= 2:
                    store.touch([n - 1])
                if n >= 3:
                    store.remove([n - 2])
        for since, copy in copies.items():
            changes = store.changes(since)
            for case_id in changes.removed:
                copy.pop(case_id, None)
            copy.update((case.id, case) for case in changes.cases)
            assert sorted(copy.values(), key=lambda case: case.id) == store.cases()

    @pytest.mark.parametrize("since", [-1, 2])
    def test_changes_since_a_revision_the_store_has_not_reached_are_refused(
            self, store: CaseStore, since: int) -> None:
        store.add(Case(1, 1))
        with pytest.raises(ValueError, match="expected a revision from 0 to 1"):
            store.changes(since)

    # -- against the memory store -----------------------------------------------------------

    def test_random_operations_agree_with_the_memory_store(self, stores: OpenStore) -> None:
        from cbrcore.testing._agree import run_against_memory

        run_against_memory(stores)


class _PersistentTests:
    """The tests a persistent store adds (``persistent = True``)."""

    def test_a_reopened_store_holds_what_it_committed(self, stores: OpenStore) -> None:
        first = stores("casebase")
        with first.transaction():
            kept = first.add(Case({"n": 1}, [1, 2], kind="vertex", meta={"m": True}))
            first.add(Case("b", None))
            first.set_meta("index", {"built_at": 1})
        first.touch([kept.id])
        with pytest.raises(Boom), first.transaction():
            first.add(Case("lost", 0))
            first.set_meta("index", "lost")
            raise Boom
        before = state(first)
        first.close()
        again = stores("casebase")
        assert state(again) == before
        assert again.committed_revision == before[0]  # before its first transaction
        assert again.check() == []

    def test_ids_are_not_reused_after_reopening(self, stores: OpenStore) -> None:
        first = stores("casebase")
        for n in range(3):
            first.add(Case(n, n))
        first.remove([2, 3])
        first.close()
        assert stores("casebase").add(Case(4, 4)).id == 4


class _SharedTests:
    """The tests a shared store adds (``shared = True``)."""

    def test_two_open_stores_see_each_others_commits(self, stores: OpenStore) -> None:
        first, second = stores("casebase"), stores("casebase")
        first.add(Case(1, 1))
        assert second.revision == 1
        assert second.get(1) == first.get(1)
        second.set_meta("k", "v")
        assert (first.revision, first.get_meta("k")) == (2, "v")

    def test_changes_show_another_stores_commits(self, stores: OpenStore) -> None:
        first, second = stores("casebase"), stores("casebase")
        old = first.add(Case(1, 1))
        since = second.revision
        with first.transaction():
            first.remove([old.id])
            new = first.add(Case(2, 2))
        assert second.changes(since) == Changes(since, since + 1, (new,), (old.id,))

    def test_the_committed_revision_is_this_stores_own(self, stores: OpenStore) -> None:
        first, second = stores("casebase"), stores("casebase")
        # a store may give out one object per case base; then second's commits are first's own
        apart = first is not second
        with first.transaction():
            first.add(Case(1, 1))
        second.add(Case(2, 2))
        # first's transaction committed revision 1, whatever came after it
        assert (first.committed_revision, first.revision) == (1 if apart else 2, 2)
        assert second.committed_revision == 2
        with first.transaction():
            first.count()
        second.set_meta("k", "v")
        # the revision first read
        assert (first.committed_revision, first.revision) == (2 if apart else 3, 3)
        with pytest.raises(Boom), first.transaction():
            first.add(Case(3, 3))
            raise Boom
        assert first.committed_revision == (2 if apart else 3)


_PROMISES: dict[str, type] = {"persistent": _PersistentTests, "shared": _SharedTests}
"""Each promise a store may make, and the class holding its tests."""
