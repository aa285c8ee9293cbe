"""Exporting case bases to YAML or JSON and importing them back."""

from __future__ import annotations

import io
import math
import sqlite3
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_stores.sqlite import SQLiteStore
from cbrcore.casebase import (
    MemoryStore,
    document_of,
    dump_document,
    export_casebase,
    format_of,
    import_casebase,
    load_document,
    parse_document,
    read_document,
)
from cbrcore.casebase.exchange import document_to_data
from cbrcore.errors import CaseBaseError
from cbrcore.model import Case

json_data = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner,
                                                                 max_size=3),
    max_leaves=8,
)
new_cases = st.builds(Case, problem=json_data, solution=json_data,
                      kind=st.sampled_from(["case", "vertex", "segment"]),
                      meta=st.dictionaries(st.text(), json_data, max_size=3))


def filled(cases: list[Case], meta: dict[str, Any], removed: int) -> MemoryStore:
    """A store that went through adds, uses, removals and meta updates."""
    store = MemoryStore()
    for case in cases:
        store.add(case)
    store.touch([c.id for c in store.cases()[::2]])
    store.remove([c.id for c in store.cases()[:removed]])
    for key, value in meta.items():
        store.set_meta(key, value)
    return store


@settings(max_examples=25, deadline=None)
@given(cases=st.lists(new_cases, max_size=5), meta=st.dictionaries(st.text(), json_data,
                                                                     max_size=3),
       removed=st.integers(0, 2), format=st.sampled_from(["yaml", "json"]))
def test_export_then_import_gives_equal_cases(cases: list[Case], meta: dict[str, Any],
                                              removed: int, format: Any) -> None:
    meta.pop("cbrcore.revision", None)
    original = filled(cases, meta, removed)
    document = parse_document(dump_document(document_of(original), format), format)
    copy = MemoryStore()
    load_document(copy, document)
    assert copy.cases() == original.cases()
    assert copy.meta_items() == original.meta_items()
    assert copy.revision == original.revision
    assert copy.check() == []


def test_round_trip_through_files_into_sqlite(tmp_path: Path) -> None:
    original = filled([Case({"cell": [1, 2]}, [[1, 2], [2, 2]], meta={"cost": 1.5}),
                       Case("lone \ud800 surrogate \x00\x85\u2028", -0.0, kind="vertex"),
                       Case({"yes": "no", "1:20": "null", "~": 1e300}, [5e-324, 2**70])],
                      {"index": {"built_at": 3}}, 0)
    for name in ("cb.yaml", "cb.yml", "cb.json"):
        export_casebase(original, tmp_path / name)
        with SQLiteStore(tmp_path / f"{name}.sqlite") as copy:
            assert import_casebase(copy, tmp_path / name) == 3
            assert copy.cases() == original.cases()
            assert (copy.revision, copy.meta_items()) == (original.revision,
                                                          original.meta_items())
            assert copy.check() == []


def test_export_to_a_stream_is_yaml_unless_told() -> None:
    store = filled([Case(1, 2)], {}, 0)
    stream = io.StringIO()
    export_casebase(store, stream)
    assert yaml.safe_load(stream.getvalue())["format"] == "cbrcore-casebase"
    stream = io.StringIO()
    export_casebase(store, stream, "json")
    assert stream.getvalue().startswith("{")


class BusyStore(MemoryStore):
    """A store where another writer commits while the cases are being read, once."""

    def cases(self, kind: str | None = None) -> list[Case]:
        if not self.count():
            self.add(Case("from elsewhere", 1))
        return super().cases(kind)


def test_an_export_never_mixes_two_revisions() -> None:
    store = BusyStore()
    document = document_of(store)
    assert (document.revision, len(document.cases)) == (1, 1)


def test_an_export_does_not_wait_for_writers(tmp_path: Path) -> None:
    path = tmp_path / "cb.sqlite"
    with SQLiteStore(path) as store:
        store.add(Case(1, 1))
    other = sqlite3.connect(path, isolation_level=None)
    other.execute("BEGIN EXCLUSIVE")
    try:
        with SQLiteStore(path, busy_timeout=0.01) as store:
            assert document_of(store).revision == 1
    finally:
        other.close()


def test_the_format_comes_from_the_extension(tmp_path: Path) -> None:
    assert (format_of("a.YAML"), format_of("a.yml"), format_of("x/a.json")) == ("yaml", "yaml",
                                                                                "json")
    with pytest.raises(CaseBaseError, match=r"cb\.txt: cannot tell the format .* '\.txt'"):
        export_casebase(MemoryStore(), tmp_path / "cb.txt")
    assert not (tmp_path / "cb.txt").exists()


def valid() -> dict[str, Any]:
    store = filled([Case("p", "s"), Case("q", "t"), Case("r", "u"), Case("v", "w")], {}, 0)
    return document_to_data(document_of(store))


def broken(change: Any) -> dict[str, Any]:
    data = valid()
    change(data)
    return data


@pytest.mark.parametrize(("data", "expected"), [
    (broken(lambda d: d["cases"][3].update(kind=5)), "cases[3].kind: expected a non-empty string"),
    # a document without the format's tag is not quoted: it may be any file
    (broken(lambda d: d.update(format="other")), "format (line 1, column 9): expected "
                                                 "'cbrcore-casebase', got a string; this is not "
                                                 "an exported case base"),
    (broken(lambda d: d.pop("format")), "format: expected 'cbrcore-casebase', got nothing"),
    (broken(lambda d: d.update(schema=2)), "schema: this cbrcore reads schema 1, the document "
                                           "has 2"),
    (broken(lambda d: d["cases"][2].update(id=1)), "cases[2].id: 1 is also the id of cases[0]"),
    (broken(lambda d: d["cases"][1].update(created=9)), "cases[1].created: revision 9 is after "
                                                        "the document's revision 5"),
    (broken(lambda d: d["cases"][0].update(problem={"x": [math.nan]})),
     "cases[0].problem.x[0]: nan is not JSON data"),
    (broken(lambda d: d["cases"][0].update(solution={1: "x"})),
     "cases[0].solution: key 1 is not a string"),
    (broken(lambda d: d["cases"][0].update(probelm=1)), "cases[0].probelm: unknown key"),
    (broken(lambda d: d["cases"][0].pop("solution")), "cases[0].solution: required key"),
    (broken(lambda d: d["cases"][0].update(uses=-1)), "cases[0].uses: expected an integer >= 0"),
    (broken(lambda d: d["cases"][0].update(meta=[])), "cases[0].meta: expected a mapping"),
    (broken(lambda d: d.update(cases={})), "cases: expected a list, got dict"),
    (broken(lambda d: d.update(revision="4")), "revision: expected an integer >= 0, got '4'"),
    (broken(lambda d: d.update(meta={"cbrcore.revision": 1})), "meta['cbrcore.revision']: this "
                                                                "key is reserved"),
    (broken(lambda d: d.update(extra=1)), "line 38, column 1: unknown key"),
    ([1, 2], "the top level (line 1, column 1): expected a case base document (a mapping with "
             "format: cbrcore-casebase), got a list"),
])
def test_invalid_documents_are_explained(data: Any, expected: str) -> None:
    with pytest.raises(CaseBaseError) as caught:
        parse_document(dump_document_data(data), "yaml", "cb.yaml")
    assert str(caught.value).startswith("cb.yaml: ")
    assert expected in str(caught.value)


def dump_document_data(data: Any) -> str:
    return yaml.safe_dump(data, sort_keys=False)


def test_every_problem_is_listed() -> None:
    data = valid()
    for entry in data["cases"]:
        entry["kind"] = None
    with pytest.raises(CaseBaseError, match=r"4 problems:\n  - cases\[0\].kind: (.|\n)*"
                                            r"  - cases\[3\].kind"):
        parse_document(dump_document_data(data), "yaml")


@pytest.mark.parametrize(("text", "format", "expected"), [
    ("cases: [", "yaml", "cb: not valid YAML"),
    ("{", "json", "cb: not valid JSON"),
    ('{"format": "cbrcore-casebase", "schema": 1, "cases": [{"problem": NaN, "solution": 1}]}',
     "json", "cases[0].problem: nan is not JSON data"),
    ("format: cbrcore-casebase\nschema: 1\ncases:\n- {problem: 2024-01-01, solution: .inf}",
     "yaml", "cases[0].problem: date datetime.date(2024, 1, 1) is not JSON data"),
])
def test_unreadable_text_is_explained(text: str, format: Any, expected: str) -> None:
    with pytest.raises(CaseBaseError, match=r"^cb: ") as caught:
        parse_document(text, format, "cb")
    assert expected in str(caught.value)


def test_a_hand_written_document_gets_ids_and_stamps(tmp_path: Path) -> None:
    path = tmp_path / "seed.yaml"
    path.write_text("format: cbrcore-casebase\nschema: 1\ncases:\n"
                    "- {problem: a, solution: 1}\n- {problem: b, solution: 2, id: 4}\n")
    store = MemoryStore()
    import_casebase(store, path)
    assert [(c.id, c.problem, c.kind, c.created, c.uses) for c in store.cases()] == [
        (4, "b", "case", 1, 0), (5, "a", "case", 1, 0)]
    assert store.revision == 1


def test_importing_into_a_store_with_cases_needs_append() -> None:
    source = filled([Case("a", 1), Case("b", 2)], {"k": 1}, 0)
    source.touch([1])
    document = document_of(source)
    target = filled([Case("mine", 0)], {"k": "mine"}, 0)
    with pytest.raises(CaseBaseError, match="the in-memory case base already holds 1 cases; "
                                            "refusing to import over them"):
        load_document(target, document)
    assert (target.revision, target.count()) == (3, 1)
    assert load_document(target, document, append=True) == 2
    assert target.revision == 4
    assert [(c.id, c.problem, c.uses, c.created, c.last_used) for c in target.cases()] == [
        (1, "mine", 1, 1, 2), (2, "a", 2, 4, None), (3, "b", 0, 4, None)]
    assert target.meta_items() == {"k": "mine"}


def test_a_missing_file_is_explained(tmp_path: Path) -> None:
    with pytest.raises(CaseBaseError, match=r"no such file: .*missing\.yaml"):
        read_document(tmp_path / "missing.yaml")
    (tmp_path / "latin.yaml").write_bytes(b"\xff\xfe")
    with pytest.raises(CaseBaseError, match=r"latin\.yaml: not UTF-8 text"):
        read_document(tmp_path / "latin.yaml")
