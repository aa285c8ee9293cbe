"""Hostile and careless YAML and JSON documents: each is refused with exit code 2 and a message.

One row per bad input (configurations given to ``cbr validate`` and
``cbr run``, ``--set`` values, documents given to ``cbr casebase import``). Every refusal must
name the file, say where and what was expected, and show no traceback. The documents that would
take a long time or exhaust memory or Python's stack if built (alias bombs, deep nesting) are
asserted to be refused by a limit of :mod:`cbrcore.documents`, whose message proves they were
refused before any Python object was built from them.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from cbrcore.casebase.exchange import parse_document
from cbrcore.documents import DocumentError, Limits, load_json, load_yaml
from cbrcore.errors import CaseBaseError
from cbrcore.testing import CliResult
from repo_paths import ROOT

Cli = Callable[..., CliResult]
HYBRID = ROOT / "configs" / "hybrid_grid.yaml"
SEED_LINE = "seed: 7"
INT64 = 2**63

DEPTH = "collections nested more than 100 levels deep (the limit, set by CBR_MAX_DOCUMENT_DEPTH)"
ALIASES = "aliases repeat more than 100000 values (the limit, set by CBR_MAX_DOCUMENT_ALIAS_NODES)"
RECURSIVE = "the alias *a refers to a node that contains it (a recursive anchor)"
BEYOND = "is beyond the largest integer a case base holds (2^63 - 1)"


def nested(depth: int) -> str:
    return "[" * depth + "]" * depth


def laughs(levels: int = 9) -> str:
    """A flow sequence whose aliases expand to 9^levels values: a billion laughs."""
    items = ["&l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    items += [f"&l{i} [{', '.join([f'*l{i - 1}'] * 9)}]" for i in range(1, levels + 1)]
    return "[" + ", ".join(items) + "]"


def expect_refusal(result: CliResult, *fragments: str) -> None:
    assert result.exit_code == 2, result
    assert "Traceback" not in result.stderr
    assert result.stderr.startswith("error: ")
    for fragment in fragments:
        assert fragment in result.stderr, result.stderr


# --- configurations ---------------------------------------------------------------------------

# the seed's value, the columns where it is refused in the file (line 8) and in a value given
# alone, and why
BAD_SEEDS = {
    "recursive anchor": ("&a [*a]", 11, 5, RECURSIVE),
    # in the file, the top mapping is one of the levels
    "20,000 nested lists": (nested(20_000), 106, 101, DEPTH),
    "billion laughs": (laughs(), 268, 262, ALIASES),
    "5,000-digit integer": ("9" * 5_000, 7, 1, "an integer of more than 4300 digits"),
    "hexadecimal integer beyond printing": ("0x" + "f" * 5_000, 7, 1,
                                            "an integer of more than 4300 digits"),
}


@pytest.fixture
def in_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The test's own folder as the working folder: runs write below it."""
    monkeypatch.chdir(tmp_path)
    return tmp_path


def hybrid_with_seed(folder: Path, seed: str) -> Path:
    text = HYBRID.read_text(encoding="utf-8")
    assert text.splitlines()[7] == SEED_LINE  # the rows' line numbers count on it
    path = folder / "h.yaml"
    path.write_text(text.replace(SEED_LINE, f"seed: {seed}", 1), encoding="utf-8")
    return path


@pytest.mark.parametrize("command", ["validate", "run"])
@pytest.mark.parametrize(("seed", "column", "alone", "problem"), BAD_SEEDS.values(),
                         ids=BAD_SEEDS.keys())
def test_a_bad_configuration_file_is_refused(invoke_cbr: Cli, in_tmp: Path, command: str,
                                             seed: str, column: int, alone: int,
                                             problem: str) -> None:
    path = hybrid_with_seed(in_tmp, seed)
    expect_refusal(invoke_cbr(command, str(path)),
                   f"error: {path}: 1 problem:\n  - line 8, column {column}: {problem}")
    assert not (in_tmp / "runs").exists()


@pytest.mark.parametrize("command", ["validate", "run"])
@pytest.mark.parametrize(("seed", "column", "alone", "problem"), BAD_SEEDS.values(),
                         ids=BAD_SEEDS.keys())
def test_a_bad_set_value_is_refused(invoke_cbr: Cli, in_tmp: Path, command: str, seed: str,
                                    column: int, alone: int, problem: str) -> None:
    result = invoke_cbr(command, str(HYBRID), "--set", f"seed={seed}")
    expect_refusal(result, f"error: {HYBRID}: 1 problem:\n  - --set seed=...: the value is "
                           f"refused: line 1, column {alone}: {problem}")
    assert len(result.stderr) < 300  # a huge value is not echoed back
    assert not (in_tmp / "runs").exists()


def test_a_store_given_on_the_command_line_is_read_within_the_limits(invoke_cbr: Cli,
                                                                    in_tmp: Path) -> None:
    result = invoke_cbr("casebase", "info", "--store", f"{{use: sqlite, path: {laughs()}}}")
    expect_refusal(result, "error: --store: 1 problem:\n  - line 1, column ", ALIASES)


# --- case base documents -------------------------------------------------------------------------

def document(**changes: Any) -> dict[str, Any]:
    case = {"id": 1, "kind": "case", "problem": 1, "solution": 2, "meta": {}, "uses": 0,
            "created": 1, "last_used": 1}
    data: dict[str, Any] = {"format": "cbrcore-casebase", "schema": 1, "revision": 3,
                            "meta": {}, "cases": [{"problem": 0, "solution": 0}, case]}
    for key, value in changes.items():
        if key in case:
            case[key] = value
        else:
            data[key] = value
    return data


BAD_DOCUMENTS = {
    **{f"{field} beyond int64 ({suffix})": (
        suffix, json.dumps(document(**{field: INT64})),  # JSON text is YAML too
        f"  - {'cases[1].' if field != 'revision' else ''}{field}: {INT64} {BEYOND}")
       for field in ("id", "uses", "created", "last_used", "revision")
       for suffix in ("yaml", "json")},
    "id far beyond int64 (yaml)": (
        "yaml", json.dumps(document(id=10**60)),
        f"  - cases[1].id: {str(10**60)[:57]}... {BEYOND}"),
    "meta with a non-string key (yaml)": (
        "yaml", "format: cbrcore-casebase\nschema: 1\nmeta: {1: x, 2.5: y}\ncases: []\n",
        "  - meta: key 1 is not a string (JSON object keys are strings)\n"
        "  - meta: key 2.5 is not a string"),
    "case meta with a non-string key (yaml)": (
        "yaml", "format: cbrcore-casebase\nschema: 1\ncases:\n"
                "- {problem: 1, solution: 2, meta: {null: x}}\n",
        "  - cases[0].meta: key None is not a string"),
    "5,000-deep problem (yaml)": (
        "yaml", "format: cbrcore-casebase\nschema: 1\ncases:\n"
                f"- {{problem: {nested(5_000)}, solution: 1}}\n",
        f": line 4, column 110: {DEPTH}"),
    "100,000-deep problem (json)": (
        "json", '{"format": "cbrcore-casebase", "schema": 1, "cases": '
                f'[{{"problem": {nested(100_000)}, "solution": 1}}]}}',
        f": line 1, column 164: {DEPTH}"),
    "20,000 nested lists (yaml)": (
        "yaml", f"format: cbrcore-casebase\nschema: 1\nmeta: {{k: {nested(20_000)}}}\n",
        f": line 3, column 109: {DEPTH}"),
    "billion laughs (yaml)": (
        "yaml", f"format: cbrcore-casebase\nschema: 1\nmeta: {{k: {laughs()}}}\n", ALIASES),
    "recursive anchor (yaml)": (
        "yaml", "format: cbrcore-casebase\nschema: 1\nmeta: {k: &a [*a]}\n",
        f": line 3, column 15: {RECURSIVE}"),
    "5,000-digit integer (json)": (
        "json", '{"format": "cbrcore-casebase", "schema": 1,\n "revision": ' + "7" * 5_000 + "}",
        ": line 2, column 14: an integer of more than 4300 digits"),
    "5,000-digit integer (yaml)": (
        "yaml", "format: cbrcore-casebase\nschema: 1\nrevision: " + "7" * 5_000 + "\n",
        ": line 3, column 11: an integer of more than 4300 digits"),
}


@pytest.mark.parametrize(("suffix", "text", "problem"), BAD_DOCUMENTS.values(),
                         ids=BAD_DOCUMENTS.keys())
def test_a_bad_document_is_refused_by_import(invoke_cbr: Cli, in_tmp: Path, suffix: str,
                                             text: str, problem: str) -> None:
    path = in_tmp / f"bad.{suffix}"
    path.write_text(text, encoding="utf-8")
    result = invoke_cbr("casebase", "import", "cb.sqlite", str(path))
    expect_refusal(result, f"error: {path}", problem)
    assert list(in_tmp.iterdir()) == [path]  # no case base file is left behind


def test_a_case_base_holds_integers_up_to_int64(invoke_cbr: Cli, in_tmp: Path) -> None:
    """The largest integer SQLite holds is accepted: the bound is exact."""
    largest = INT64 - 1
    edge = document(id=largest, uses=largest, revision=largest, created=largest,
                    last_used=largest)
    parsed = parse_document(json.dumps(edge), "json")
    assert (parsed.revision, parsed.cases[1].id, parsed.cases[1].uses) == (largest,) * 3
    # an id is left out: a case base that holds the largest id can hold no other
    del edge["cases"][1]["id"]
    path = in_tmp / "edge.json"
    path.write_text(json.dumps(edge))
    assert invoke_cbr("casebase", "import", "cb.sqlite", str(path)).exit_code == 0
    exported = json.loads(invoke_cbr("casebase", "export", "cb.sqlite", "--format", "json").stdout)
    assert (exported["revision"], exported["cases"][1]["uses"]) == (largest, largest)


# --- the limits -------------------------------------------------------------------------------

@pytest.mark.parametrize(("variable", "value", "problem"), [
    ("CBR_MAX_DOCUMENT_BYTES", "1000", "the file is larger than 1000 bytes (the limit, set by "
                                       "CBR_MAX_DOCUMENT_BYTES)"),
    ("CBR_MAX_DOCUMENT_NODES", "20", "line 11, column 31: the document holds more than 20 values, "
                                     "aliases expanded (the limit, set by CBR_MAX_DOCUMENT_NODES)"),
    ("CBR_MAX_DOCUMENT_DEPTH", "1", "line 9, column 8: collections nested more than 1 levels "
                                    "deep (the limit, set by CBR_MAX_DOCUMENT_DEPTH)"),
])
def test_the_limits_are_configurable(invoke_cbr: Cli, in_tmp: Path,
                                     monkeypatch: pytest.MonkeyPatch, variable: str, value: str,
                                     problem: str) -> None:
    assert invoke_cbr("validate", str(HYBRID)).exit_code == 0
    monkeypatch.setenv(variable, value)
    expect_refusal(invoke_cbr("validate", str(HYBRID)),
                   f"error: {HYBRID}: 1 problem:\n  - {problem}")


def test_a_deeper_limit_admits_deeper_documents(invoke_cbr: Cli, in_tmp: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    path = in_tmp / "deep.json"
    path.write_text(json.dumps(document(problem=json.loads(nested(190)))))
    expect_refusal(invoke_cbr("casebase", "import", "cb.sqlite", str(path)), DEPTH)
    monkeypatch.setenv("CBR_MAX_DOCUMENT_DEPTH", "200")
    assert invoke_cbr("casebase", "import", "cb.sqlite", str(path)).exit_code == 0
    assert invoke_cbr("casebase", "check", "cb.sqlite").exit_code == 0


@pytest.mark.parametrize(("variable", "value", "expected"), [
    ("CBR_MAX_DOCUMENT_DEPTH", "201", "expected a whole number from 1 to 200, got '201'"),
    ("CBR_MAX_DOCUMENT_DEPTH", "0", "expected a whole number from 1 to 200, got '0'"),
    ("CBR_MAX_DOCUMENT_BYTES", "1e6", "expected a whole number of 1 or more, got '1e6'"),
    ("CBR_MAX_DOCUMENT_ALIAS_NODES", "-5", "expected a whole number of 1 or more, got '-5'"),
])
def test_a_bad_limit_is_explained(invoke_cbr: Cli, in_tmp: Path, monkeypatch: pytest.MonkeyPatch,
                                  variable: str, value: str, expected: str) -> None:
    monkeypatch.setenv(variable, value)
    expect_refusal(invoke_cbr("validate", str(HYBRID)),
                   f"error: environment variable {variable}: {expected}")


def test_limits_default_and_read_the_environment() -> None:
    assert Limits.from_environ({}) == Limits(100_000_000, 100, 10_000_000, 100_000)
    assert Limits.from_environ({"CBR_MAX_DOCUMENT_NODES": " 7 ", "CBR_MAX_DOCUMENT_DEPTH": ""}) \
        == Limits(nodes=7)


# --- the readers -----------------------------------------------------------------------------

def test_aliases_count_what_they_repeat() -> None:
    text = "a: &x {k: [1, 2]}\nb: *x\nc: [*x, *x]\n"
    # the top mapping, a, its mapping, k, its list and two items (7); b and the repeat (1 + 5);
    # c and its list (2) with two repeats (10): 25 values, 15 of them repeated
    assert load_yaml(text, "t", Limits(nodes=25, alias_nodes=15))["c"][1] == {"k": [1, 2]}
    with pytest.raises(DocumentError, match=r"^t: line 3, column 9: the document holds more "
                                            r"than 24 values"):
        load_yaml(text, "t", Limits(nodes=24))
    with pytest.raises(DocumentError, match=r"^t: line 3, column 9: aliases repeat more than "
                                            r"14 values"):
        load_yaml(text, "t", Limits(alias_nodes=14))


def test_an_alias_counts_the_depth_of_what_it_repeats() -> None:
    text = "a: &x [[[1]]]\nb: [[*x]]\n"  # the top mapping, two lists and three repeated: 6
    assert load_yaml(text, "t", Limits(depth=6))["b"] == [[[[[1]]]]]
    with pytest.raises(DocumentError, match=r"line 2, column 6: the alias \*x nests collections "
                                            r"more than 5 levels deep"):
        load_yaml(text, "t", Limits(depth=5))


def test_merge_keys_still_work() -> None:
    assert load_yaml("a: &b {x: 1, y: 2}\nc:\n  <<: *b\n  x: 3\n", "t")["c"] == {"x": 3, "y": 2}


@pytest.mark.parametrize(("text", "nodes"), [
    ('{"a": [1, 2, {}], "b": "x:,[{", "c": []}', 10),
    ("[]", 1),
    ("3", 1),
    ('[[], [[]], {"k": {}}]', 7),
])
def test_json_values_are_counted_before_parsing(text: str, nodes: int) -> None:
    assert load_json(text, "t", Limits(nodes=nodes)) == json.loads(text)
    with pytest.raises(DocumentError, match=f"more than {nodes - 1} values"):
        load_json(text, "t", Limits(nodes=nodes - 1))


def test_json_brackets_in_strings_do_not_nest() -> None:
    text = json.dumps({"a": "[" * 500, "b": ["\\\"[[[", "]]]"]})
    assert load_json(text, "t", Limits(depth=2)) == json.loads(text)
    with pytest.raises(DocumentError, match=r"^t: line 1, column \d+: collections nested more "
                                            r"than 1 levels deep"):
        load_json(text, "t", Limits(depth=1))


def test_a_refused_document_is_a_case_base_error() -> None:
    with pytest.raises(CaseBaseError, match=r"^doc: line 1, column 101: collections nested"):
        parse_document(nested(101), "json", "doc")


def test_import_reads_no_more_than_the_byte_limit(invoke_cbr: Cli, in_tmp: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    path = in_tmp / "big.json"
    path.write_text(json.dumps(document()))
    monkeypatch.setenv("CBR_MAX_DOCUMENT_BYTES", "100")
    expect_refusal(invoke_cbr("casebase", "import", "cb.sqlite", str(path)),
                   f"error: {path}: the file is larger than 100 bytes (the limit, set by "
                   "CBR_MAX_DOCUMENT_BYTES)")
    assert list(in_tmp.iterdir()) == [path]
