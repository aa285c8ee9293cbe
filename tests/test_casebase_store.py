"""The CaseStore contract, checked on the memory and the SQLite store alike."""

from __future__ import annotations

import math
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import attrs
import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule

import cbrcore.builtins
from cbrcore.casebase import CaseStore, MemoryStore, SQLiteStore, open_store
from cbrcore.context import Context
from cbrcore.errors import ConfigError
from cbrcore.model import Case
from cbrcore.registry import Registry


class Boom(Exception):
    """Raised by tests to abandon a transaction."""


@pytest.fixture(params=["memory", "sqlite"])
def store(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[CaseStore]:
    opened = MemoryStore() if request.param == "memory" else SQLiteStore(tmp_path / "cb.sqlite")
    yield opened
    opened.close()


def state(store: CaseStore) -> tuple[Any, ...]:
    return store.revision, store.cases(), store.meta_items()


def test_both_stores_implement_the_protocol(store: CaseStore) -> None:
    assert isinstance(store, CaseStore)
    assert store.revision == 0
    assert len(store) == 0
    assert store.check() == []


def test_add_outside_a_transaction_commits_each_case(store: CaseStore) -> None:
    first = store.add(Case({"start": [0, 0]}, [[0, 0], [1, 0]], id=99, created=42))
    second = store.add(Case("p", "s", kind="vertex", uses=2))
    assert (first.id, first.created, second.id, second.created) == (1, 1, 2, 2)
    assert second.uses == 2
    assert store.revision == 2
    assert store.get(1) == first
    assert store.get(2) == second
    assert list(store) == [first, second]


def test_ids_are_never_reused(store: CaseStore) -> None:
    for n in range(3):
        store.add(Case(n, n))
    store.remove([3])
    assert store.add(Case(3, 3)).id == 4


def test_replace_overwrites_and_keeps_created_when_none(store: CaseStore) -> None:
    case = store.add(Case("p", "s"))
    store.replace(attrs.evolve(case, solution="better", meta={"why": "shorter"}))
    assert store.get(case.id).solution == "better"
    assert store.revision == 2
    store.replace(Case("q", "t", kind="other", id=case.id, uses=5))
    assert store.get(case.id) == Case("q", "t", "other", {}, case.id, 5, 1, None)


def test_replace_of_a_missing_case_raises_and_writes_nothing(store: CaseStore) -> None:
    store.add(Case("p", "s"))
    with pytest.raises(KeyError):
        store.replace(Case("p", "s", id=7))
    assert store.revision == 1


def test_remove_is_all_or_nothing(store: CaseStore) -> None:
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


def test_touch_counts_uses_and_stamps_the_committing_revision(store: CaseStore) -> None:
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


def test_cases_and_counts_by_kind(store: CaseStore) -> None:
    for kind in ["vertex", "segment", "vertex"]:
        store.add(Case(kind, None, kind=kind))
    assert [c.id for c in store.cases("vertex")] == [1, 3]
    assert store.cases("nothing") == []
    assert (store.count(), store.count("vertex"), store.count("segment")) == (3, 2, 1)
    assert store.kind_counts() == {"segment": 1, "vertex": 2}
    assert len(store) == 3


def test_meta_values_are_plain_data_copied_in_and_out(store: CaseStore) -> None:
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


def test_the_revision_key_is_reserved(store: CaseStore) -> None:
    with pytest.raises(ValueError, match="reserved"):
        store.set_meta("cbrcore.revision", 5)
    with pytest.raises(ValueError, match="reserved"):
        store.get_meta("cbrcore.revision")


def test_a_transaction_commits_once(store: CaseStore) -> None:
    with store.transaction():
        cases = [store.add(Case(n, n)) for n in range(3)]
        store.set_meta("k", 1)
        assert store.revision == 0
    assert store.revision == 1
    assert {c.created for c in cases} == {1}
    assert store.cases() == cases


def test_read_only_and_empty_transactions_do_not_count(store: CaseStore) -> None:
    store.add(Case(1, 1))
    with store.transaction():
        store.cases()
        store.get_meta("k")
    with store.transaction(), store.transaction():
        pass
    assert store.revision == 1


def test_a_raising_transaction_leaves_no_trace(store: CaseStore) -> None:
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


def test_nested_blocks_join_the_outer_transaction(store: CaseStore) -> None:
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


def test_a_nested_block_that_only_undid_its_writes_does_not_count(store: CaseStore) -> None:
    with store.transaction():
        try:
            with store.transaction():
                store.add(Case("undone", 1))
                raise Boom
        except Boom:
            pass
    assert store.revision == 0
    assert store.count() == 0


def test_an_outer_failure_undoes_committed_nested_blocks(store: CaseStore) -> None:
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
def test_contents_that_are_not_plain_data_are_refused(store: CaseStore, case: Case,
                                                       expected: str) -> None:
    with pytest.raises(ValueError, match=expected):
        store.add(case)
    assert (store.revision, store.count()) == (0, 0)


def test_meta_values_must_be_plain_data(store: CaseStore) -> None:
    with pytest.raises(ValueError, match=r"meta key 'k': value\[0\]: nan is not JSON"):
        store.set_meta("k", [math.nan])
    assert store.revision == 0


def test_restore_keeps_ids_and_stamps(store: CaseStore) -> None:
    store.set_meta("old", 1)
    cases = [Case("b", 2, id=5, uses=1, created=2, last_used=7), Case("a", 1, id=2, created=1),
             Case("new", 3)]
    store.restore(cases, {"index": [1]}, 7)
    assert store.revision == 7
    assert [c.id for c in store.cases()] == [2, 5, 6]
    assert store.get(5) == cases[0]
    assert store.get(6).created == 7
    assert store.meta_items() == {"index": [1]}
    assert store.check() == []
    with pytest.raises(ValueError, match="without cases"):
        store.restore([], {}, 0)


def test_open_store_picks_the_store(tmp_path: Path) -> None:
    assert isinstance(open_store(), MemoryStore)
    with open_store(tmp_path / "cb.sqlite") as store:
        assert isinstance(store, SQLiteStore)


def _context(out_dir: Path | None) -> Context:
    registry = Registry()
    cbrcore.builtins.cbr_register(registry)
    return Context(registry=registry, seed=0, out_dir=out_dir)


def test_builtin_store_components(tmp_path: Path) -> None:
    ctx = _context(tmp_path)
    assert isinstance(ctx.registry.create("store", "memory", {}, ctx), MemoryStore)
    with ctx.registry.create("store", "sqlite", None, ctx) as default:
        assert default.path == tmp_path / "casebase.sqlite"
    with ctx.registry.create("store", "sqlite", {"path": str(tmp_path / "x.sqlite"),
                                                 "busy_timeout": 1}, ctx) as chosen:
        assert (chosen.path, chosen.busy_timeout) == (tmp_path / "x.sqlite", 1.0)
    summaries = {c.name: c.summary for c in ctx.registry}
    assert summaries["sqlite"].startswith("A case base in a SQLite file")
    assert summaries["memory"].startswith("An in-memory case base")


def test_builtin_sqlite_store_needs_a_path_without_an_output_folder() -> None:
    ctx = _context(None)
    with pytest.raises(ConfigError, match=r"casebase\.path: required when the engine has no"):
        ctx.registry.create("store", "sqlite", {}, ctx)
    with pytest.raises(ConfigError, match="busy_timeout: must be >= 0"):
        ctx.registry.create("store", "sqlite", {"busy_timeout": -1}, ctx)


# -- the two stores against each other ------------------------------------------------------

json_data = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=4),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner,
                                                                 max_size=3),
    max_leaves=6,
)
case_ids = st.integers(1, 8)
operations = st.one_of(
    st.tuples(st.just("add"), st.sampled_from(["case", "vertex"]), json_data),
    st.tuples(st.just("replace"), case_ids, json_data),
    st.tuples(st.just("remove"), st.lists(case_ids, max_size=3)),
    st.tuples(st.just("touch"), st.lists(case_ids, max_size=3)),
    st.tuples(st.just("meta"), st.sampled_from(["a", "b"]), json_data),
)


def apply(store: CaseStore, operation: tuple[Any, ...]) -> Any:
    """Run one operation; return its result or the name of the error it raised."""
    name, *args = operation
    try:
        if name == "add":
            return store.add(Case(args[1], args[1], kind=args[0]))
        if name == "replace":
            return store.replace(Case(args[1], "replaced", id=args[0]))
        if name == "remove":
            return store.remove(args[0])
        if name == "touch":
            return store.touch(args[0])
        return store.set_meta(args[0], args[1])
    except KeyError:
        return "KeyError"


class StoresAgree(RuleBasedStateMachine):
    """Random operations and transactions leave both stores in the same state."""

    def __init__(self) -> None:
        super().__init__()
        self.folder = tempfile.TemporaryDirectory()
        self.stores: list[CaseStore] = [MemoryStore(),
                                            SQLiteStore(Path(self.folder.name) / "cb.sqlite")]

    def teardown(self) -> None:
        for store in self.stores:
            store.close()
        self.folder.cleanup()

    @rule(operation=operations)
    def single(self, operation: tuple[Any, ...]) -> None:
        results = [apply(store, operation) for store in self.stores]
        assert results[0] == results[1]

    @rule(outer=st.lists(operations, max_size=4), inner=st.lists(operations, max_size=3),
          inner_fails=st.booleans(), outer_fails=st.booleans())
    def transaction(self, outer: list[Any], inner: list[Any], inner_fails: bool,
                    outer_fails: bool) -> None:
        results = []
        for store in self.stores:
            seen: list[Any] = []
            try:
                with store.transaction():
                    seen += [apply(store, op) for op in outer]
                    try:
                        with store.transaction():
                            seen += [apply(store, op) for op in inner]
                            if inner_fails:
                                raise Boom
                    except Boom:
                        seen.append("inner rolled back")
                    if outer_fails:
                        raise Boom
            except Boom:
                seen.append("rolled back")
            results.append(seen)
        assert results[0] == results[1]

    @invariant()
    def same_state(self) -> None:
        memory, sqlite = (state(store) for store in self.stores)
        assert memory == sqlite
        assert self.stores[1].check() == []


TestStoresAgree = StoresAgree.TestCase
TestStoresAgree.settings = settings(max_examples=20, stateful_step_count=10, deadline=None,
                                    suppress_health_check=[HealthCheck.too_slow])
