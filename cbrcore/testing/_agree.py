"""Random operations and transactions on a store and on a memory store, compared (hypothesis)."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import Any

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule, run_state_machine_as_test

from cbrcore.casebase import CaseStore, MemoryStore
from cbrcore.model import Case
from cbrcore.testing.stores import Boom, state

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


def run_against_memory(open_store: Callable[[str], CaseStore]) -> None:
    """Check that random operations leave the store opened by ``open_store`` and a memory store
    in the same state, with the same results, whether the transactions commit or roll back."""
    names = (f"agree-{n}" for n in itertools.count())

    class StoresAgree(RuleBasedStateMachine):
        def __init__(self) -> None:
            super().__init__()
            self.stores = [MemoryStore(), open_store(next(names))]
            self.seen: dict[int, dict[int, Case]] = {}
            """The cases the tested store held at each revision the invariant saw."""

        def teardown(self) -> None:
            for store in self.stores:
                store.close()

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
            memory, tested = (state(store) for store in self.stores)
            assert memory == tested
            assert self.stores[1].check() == []
            store = self.stores[1]
            self.seen[store.revision] = {case.id: case for case in store.cases()}
            for since, cases in self.seen.items():
                changes = store.changes(since)
                copy = {k: v for k, v in cases.items() if k not in changes.removed}
                copy.update((case.id, case) for case in changes.cases)
                assert sorted(copy.values(), key=lambda case: case.id) == store.cases()

    run_state_machine_as_test(StoresAgree, settings=settings(
        max_examples=20, stateful_step_count=10, deadline=None,
        suppress_health_check=[HealthCheck.too_slow]))
