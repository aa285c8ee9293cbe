"""A store's ``initial`` option: hand-made cases a new case base starts with."""

from __future__ import annotations

from pathlib import Path

import pytest

from cbr_stores.components import SQLiteOptions, sqlite_store
from cbrcore.casebase import MemoryStore, export_casebase
from cbrcore.casebase.components import MemoryOptions, memory_store
from cbrcore.context import Context
from cbrcore.errors import CaseBaseError
from cbrcore.model import Case
from cbrcore.registry import Registry

CASES = [Case({"at": [1, 2]}, "left", kind="hand-made"), Case({"at": [3, 4]}, "right")]


@pytest.fixture
def document(tmp_path: Path) -> Path:
    source = MemoryStore()
    with source.transaction():
        for case in CASES:
            source.add(case)
    path = tmp_path / "initial.yaml"
    export_casebase(source, path)
    return path


def ctx(tmp_path: Path) -> Context:
    return Context(registry=Registry(), seed=0, out_dir=tmp_path)


def contents(store: object) -> list[tuple[object, object, str]]:
    return [(c.problem, c.solution, c.kind) for c in store.cases()]  # type: ignore[attr-defined]


def test_a_memory_store_starts_with_the_initial_cases(tmp_path: Path, document: Path) -> None:
    store = memory_store(MemoryOptions(initial=document), ctx(tmp_path))
    assert contents(store) == [(c.problem, c.solution, c.kind) for c in CASES]
    assert [c.id for c in store.cases()] == [1, 2]


def test_a_new_sqlite_file_is_loaded_once_and_never_again(tmp_path: Path,
                                                          document: Path) -> None:
    options = SQLiteOptions(path=tmp_path / "cases.sqlite", initial=document)
    store = sqlite_store(options, ctx(tmp_path))
    assert len(store) == 2
    with store.transaction():
        store.remove([c.id for c in store.cases() if c.id is not None])
    store.close()
    # the case base has held cases and forgotten them: it is not loaded again
    again = sqlite_store(options, ctx(tmp_path))
    assert len(again) == 0
    again.close()


def test_a_case_base_opened_for_reading_ignores_initial(tmp_path: Path,
                                                        document: Path) -> None:
    path = tmp_path / "cases.sqlite"
    sqlite_store(SQLiteOptions(path=path), ctx(tmp_path)).close()  # a new, empty file
    store = sqlite_store(SQLiteOptions(path=path, read_only=True, initial=document),
                         ctx(tmp_path))
    assert len(store) == 0
    store.close()


def test_an_initial_file_that_is_not_a_case_base_is_an_error_naming_it(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("format: something else\n", encoding="utf-8")
    with pytest.raises(CaseBaseError, match=r"bad\.yaml"):
        memory_store(MemoryOptions(initial=bad), ctx(tmp_path))
