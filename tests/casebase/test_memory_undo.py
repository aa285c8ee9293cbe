"""The memory store's rollback: a transaction that raises leaves exactly the state before it.

The store undoes a failed transaction from a log of what each write overwrote. The reference
for "exactly the state before" is a twin store that was given the same committed history and
never saw the failed transaction: everything the protocol shows (revision, committed revision,
cases in order, counts, meta values, ``changes()`` since every revision, the consistency check)
must agree, and must go on agreeing when both stores are then given the same writes (so hidden
state, such as the next id, was restored too).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import attrs
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbrcore.casebase import MemoryStore
from cbrcore.model import Case


class Boom(Exception):
    """Raised to abandon a transaction."""


def observed(store: MemoryStore) -> tuple[Any, ...]:
    """Everything the store protocol shows of ``store``."""
    return (store.revision, store.committed_revision, store.cases(), store.count(),
            store.kind_counts(), store.meta_items(), store.check(),
            [store.changes(since) for since in range(store.revision + 1)])


Write = Callable[[MemoryStore], None]


def history(store: MemoryStore) -> None:
    """Committed writes of every kind, so that a rollback has old values to put back."""
    for n in range(5):
        store.add(Case({"n": n}, [n], kind="a" if n % 2 else "b", meta={"n": n}))
    store.set_meta("k", {"v": 1})
    with store.transaction():
        store.touch([2, 3])
        store.replace(attrs.evolve(store.get(4), solution=["replaced"]))
    store.remove([1])


WRITES: dict[str, Write] = {
    "add": lambda s: s.add(Case("new", 1, kind="c")),
    "replace": lambda s: s.replace(attrs.evolve(s.get(3), solution=[9], created=None)),
    "touch": lambda s: s.touch([2, 5, 2]),
    "remove": lambda s: s.remove([2, 3]),
    "remove_first_and_last": lambda s: s.remove([5, 2]),
    "set_meta_over": lambda s: s.set_meta("k", [1, 2]),
    "set_meta_new": lambda s: s.set_meta("other", None),
    "touch_then_remove": lambda s: (s.touch([3]), s.remove([3])),
    "add_then_remove": lambda s: s.remove([s.add(Case("brief", 0)).id]),
    "replace_then_touch": lambda s: (s.replace(attrs.evolve(s.get(4), meta={"x": 1})),
                                     s.touch([4])),
}


def twins() -> tuple[MemoryStore, MemoryStore]:
    first, second = MemoryStore(), MemoryStore()
    history(first)
    history(second)
    return first, second


def carry_on(store: MemoryStore) -> None:
    """The same later writes for both twins."""
    store.add(Case("later", 1))
    store.touch([2])
    store.set_meta("k", "later")


def assert_alike(store: MemoryStore, twin: MemoryStore) -> None:
    """The twins look the same, and still do after the same later writes (which would show a
    hidden difference, such as the next id)."""
    assert observed(store) == observed(twin)
    carry_on(store)
    carry_on(twin)
    assert observed(store) == observed(twin)


@pytest.mark.parametrize("name", list(WRITES))
def test_a_failed_transaction_after_any_write_restores_the_state(name: str) -> None:
    store, twin = twins()
    with pytest.raises(Boom), store.transaction():
        WRITES[name](store)
        raise Boom
    assert_alike(store, twin)


def test_a_failed_transaction_of_every_write_restores_the_state() -> None:
    store, twin = twins()
    with pytest.raises(Boom), store.transaction():
        # in an order in which each write finds the cases it names
        for name in ("add", "replace", "touch", "set_meta_over", "set_meta_new",
                     "replace_then_touch", "touch_then_remove", "remove_first_and_last",
                     "add_then_remove"):
            WRITES[name](store)
        raise Boom
    assert_alike(store, twin)


@pytest.mark.parametrize("name", list(WRITES))
def test_a_failed_nested_block_undoes_only_its_own_writes(name: str) -> None:
    store, twin = twins()
    with store.transaction():
        store.touch([4])
        with pytest.raises(Boom), store.transaction():
            WRITES[name](store)
            raise Boom
        store.set_meta("after", 1)
    with twin.transaction():
        twin.touch([4])
        twin.set_meta("after", 1)
    assert observed(store) == observed(twin)


def test_an_outer_failure_undoes_a_nested_block_that_had_ended() -> None:
    store, twin = twins()
    with pytest.raises(Boom), store.transaction():
        with store.transaction():
            store.remove([3])
            store.add(Case("inner", 1))
        store.touch([2])
        raise Boom
    assert observed(store) == observed(twin)


def test_a_failed_restore_restores_the_state() -> None:
    store, twin = MemoryStore(), MemoryStore()
    for s in (store, twin):
        s.remove([s.add(Case("gone", 1)).id])
        s.set_meta("k", 1)
        s.set_meta("j", 2)
    cases = [Case("x", 1, id=7, created=1), Case("y", 2)]
    with pytest.raises(Boom), store.transaction():
        store.restore(cases, {"k": 3}, revision=40)
        raise Boom
    assert observed(store) == observed(twin)
    store.restore(cases, {"k": 3}, revision=40)
    twin.restore(cases, {"k": 3}, revision=40)
    assert observed(store) == observed(twin)


def test_a_commit_after_a_rolled_back_nested_block_keeps_the_order_by_id() -> None:
    store = MemoryStore()
    for n in range(4):
        store.add(Case(n, n))
    with store.transaction():
        with pytest.raises(Boom), store.transaction():
            store.remove([1, 2])
            raise Boom
        store.touch([3])
    assert [c.id for c in store.cases()] == [1, 2, 3, 4]
    assert [c.id for c in store.changes(4).cases] == [3]


# -- random histories and failed transactions ------------------------------------------------

_ops = st.lists(st.tuples(st.sampled_from(["add", "replace", "touch", "remove", "meta"]),
                          st.integers(0, 7), st.integers(0, 3)), max_size=8)


def apply(store: MemoryStore, ops: list[tuple[str, int, int]]) -> None:
    """Play ``ops`` on ``store``, each on a stored case picked by position (skipped when
    there is none)."""
    for op, pick, value in ops:
        ids = [c.id for c in store.cases()]
        target = ids[pick % len(ids)] if ids else None
        if op == "add":
            store.add(Case({"p": pick}, [value], kind=f"k{value % 2}"))
        elif op == "meta":
            store.set_meta(f"m{pick % 3}", [value])
        elif target is None:
            continue
        elif op == "replace":
            store.replace(attrs.evolve(store.get(target), solution=value))
        elif op == "touch":
            store.touch([target, ids[value % len(ids)]])
        else:
            store.remove([target])


@settings(max_examples=60, deadline=None)
@given(st.lists(_ops, max_size=4), _ops, _ops, _ops)
def test_random_failed_transactions_restore_the_state(
        committed: list[list[tuple[str, int, int]]], before: list[tuple[str, int, int]],
        nested: list[tuple[str, int, int]], after: list[tuple[str, int, int]]) -> None:
    store, twin = MemoryStore(), MemoryStore()
    for ops in committed:
        for s in (store, twin):
            with s.transaction():
                apply(s, ops)
    # inside the failing transaction: writes, a nested block that fails, more writes
    with pytest.raises(Boom), store.transaction():
        apply(store, before)
        with pytest.raises(Boom), store.transaction():
            apply(store, nested)
            raise Boom
        apply(store, after)
        raise Boom
    assert observed(store) == observed(twin)
    for s in (store, twin):
        apply(s, after)
    assert observed(store) == observed(twin)
