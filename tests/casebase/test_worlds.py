"""A case base knows its world: runs and imports of another world's cases are refused, unless
the case base lets them carry over (``worlds: any``), and ``cbr casebase check`` reports a case
base holding several worlds' cases."""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import attrs
import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

import cbr_grid
import cbr_world2d
from cbr_grid import MapFrame
from cbr_grid.generate import generate
from cbr_grid.grid import Grid, grid_fingerprint
from cbr_stores.sqlite import SQLiteStore
from cbr_world2d.worldfile import load_world
from cbrcore.casebase import CaseStore, MemoryStore, document_of, load_document
from cbrcore.casebase.exchange import Document, parse_document
from cbrcore.casebase.worlds import (
    ANY,
    ONE,
    WORLDS_KEY,
    OtherWorld,
    record_world,
    recorded_worlds,
    world_problems,
)
from cbrcore.errors import CaseBaseError
from cbrcore.fingerprint import WorldFingerprint, fingerprint
from cbrcore.model import Case
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult
from repo_paths import ROOT

Cli = Callable[..., CliResult]

SCENARIO = ROOT / "plugins" / "cbr_world2d" / "worlds" / "scenario2.yaml"
CONFIG = """\
seed: 1
world: {use: generated, kind: office, width: 24, height: 24}
casebase: {use: sqlite, path: CASEBASE}
workload: {use: trips, count: 6, unknown_static: 60}
solver: astar
retain: [risk_map]
"""
"""A small grid run whose learned risks are bound to its map."""


@pytest.fixture(autouse=True)
def installed(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    """The installed plugins, the grid and the 2D world among them."""
    return cbr_plugins(entry_points=True)


def _config(tmp_path: Path, casebase: str | None = None) -> Path:
    path = tmp_path / "run.yaml"
    store = casebase or str(tmp_path / "cb.sqlite")
    path.write_text(CONFIG.replace("CASEBASE", store), encoding="utf-8")
    return path


def _run(invoke_cbr: Cli, tmp_path: Path, out: str, *sets: str) -> CliResult:
    args = [item for setting in sets for item in ("--set", setting)]
    return invoke_cbr("run", str(_config(tmp_path)), "--out", str(tmp_path / out), *args)


def _snapshot(path: Path) -> Document:
    with SQLiteStore(path, create=False) as store:
        return document_of(store)


def _world(seed: int) -> WorldFingerprint:
    return grid_fingerprint(cbr_grid.generated_world(
        cbr_grid.GeneratedOptions(kind="office", width=24, height=24),
        _Seeded(seed)))


@attrs.frozen
class _Seeded:
    """The one thing a grid world factory reads of a run's context."""

    seed: int


# -- runs ---------------------------------------------------------------------------------------


def test_a_run_in_another_world_is_refused_and_stores_nothing(invoke_cbr: Cli,
                                                              tmp_path: Path) -> None:
    first = _run(invoke_cbr, tmp_path, "a")
    assert first.exit_code == 0, first.stderr
    before = _snapshot(tmp_path / "cb.sqlite")
    assert before.meta[WORLDS_KEY] == [_world(1).to_data()]

    refused = _run(invoke_cbr, tmp_path, "b", "seed=2")

    assert refused.exit_code == 2
    message = refused.stderr
    assert "Traceback" not in message
    assert f"office 24x24, seed 1 (world {_world(1).short})" in message
    assert f"office 24x24, seed 2 (world {_world(2).short})" in message
    assert "worlds: any" in message and str(tmp_path / "cb.sqlite") in message
    assert _snapshot(tmp_path / "cb.sqlite") == before
    assert not (tmp_path / "b").exists()


def test_the_same_world_with_other_trips_learns_on(invoke_cbr: Cli, tmp_path: Path) -> None:
    for out, trips in (("a", 11), ("b", 12)):
        result = _run(invoke_cbr, tmp_path, out, f"workload.seed={trips}")
        assert result.exit_code == 0, result.stderr
    after = _snapshot(tmp_path / "cb.sqlite")
    assert after.meta[WORLDS_KEY] == [_world(1).to_data()]
    assert after.revision > 2  # both runs learned
    assert invoke_cbr("casebase", "check", str(tmp_path / "cb.sqlite")).stdout == "ok\n"


def test_worlds_any_lets_cases_carry_over_and_check_reports_them(invoke_cbr: Cli,
                                                                 tmp_path: Path) -> None:
    assert _run(invoke_cbr, tmp_path, "a").exit_code == 0
    carried = _run(invoke_cbr, tmp_path, "b", "seed=2", "casebase.worlds=any")
    assert carried.exit_code == 0, carried.stderr
    path = str(tmp_path / "cb.sqlite")

    check = invoke_cbr("casebase", "check", path)
    assert check.exit_code == 1
    assert "worlds: meta 'cbrcore.worlds': the cases belong to 2 worlds" in check.stdout
    assert _world(1).short in check.stdout and _world(2).short in check.stdout
    info = invoke_cbr("casebase", "info", path, "--json")
    assert json.loads(info.stdout)["worlds"] == [_world(1).to_data(), _world(2).to_data()]
    text = invoke_cbr("casebase", "info", path).stdout
    assert f"world         office 24x24, seed 2 ({_world(2).sha256})" in text
    # a case base of several worlds refuses each of them unless the run lets cases carry over
    assert _run(invoke_cbr, tmp_path, "c").exit_code == 2


def test_initial_cases_of_another_world_are_refused_in_memory(invoke_cbr: Cli,
                                                              tmp_path: Path) -> None:
    """A memory case base starting from a document keeps the document's world."""
    assert _run(invoke_cbr, tmp_path, "a").exit_code == 0
    exported = tmp_path / "cases.yaml"
    assert invoke_cbr("casebase", "export", str(tmp_path / "cb.sqlite"), "-o",
                   str(exported)).exit_code == 0
    assert yaml.safe_load(exported.read_text())["meta"][WORLDS_KEY] == [_world(1).to_data()]
    config = _config(tmp_path, "x")
    config.write_text(config.read_text().replace(
        "{use: sqlite, path: x}", f"{{use: memory, initial: {exported}}}"))
    same = invoke_cbr("run", str(config), "--out", str(tmp_path / "m1"))
    other = invoke_cbr("run", str(config), "--out", str(tmp_path / "m2"), "--set", "seed=2")
    assert same.exit_code == 0, same.stderr
    assert other.exit_code == 2 and _world(1).short in other.stderr


def test_a_world_independent_family_records_no_world(invoke_cbr: Cli, tmp_path: Path) -> None:
    """Landmark situations hold in any world: runs in two worlds share one case base."""
    config = ROOT / "configs" / "landmarks.yaml"
    casebase = tmp_path / "situations.sqlite"
    for out, world in (("a", "scenario2"), ("b", "scenario1")):
        result = invoke_cbr("run", str(config), "--out", str(tmp_path / out),
                         "--set", f"casebase.path={casebase}", "--set", "workload.repeat=1",
                         "--set", f"world.path={ROOT / 'plugins/cbr_world2d/worlds'}/{world}.yaml")
        assert result.exit_code == 0, result.stderr
    with SQLiteStore(casebase, create=False) as store:
        assert WORLDS_KEY not in store.meta_items()


# -- the record under the write lock ---------------------------------------------------------


def test_the_second_writer_of_another_world_is_refused_under_the_lock(tmp_path: Path) -> None:
    """Two processes that both found a new case base: the one that learns second is refused,
    however they started."""
    a, b = _world(1), _world(2)
    with SQLiteStore(tmp_path / "cb.sqlite") as first, \
            SQLiteStore(tmp_path / "cb.sqlite") as second:
        record_world(first, a, ONE)
        revision = second.revision
        with pytest.raises(OtherWorld, match=a.short), second.transaction():
            record_world(second, b, ONE)
            second.add(Case(1, 1))
        assert (second.revision, second.count()) == (revision, 0)
        record_world(second, a, ONE)  # the same world again writes nothing
        assert second.revision == revision
        record_world(second, b, ANY)
        assert recorded_worlds(first) == ([a, b], [])


@pytest.mark.parametrize(("value", "problem"), [
    ("office", "is a str; expected a list"),
    ([{"sha256": "abc", "description": "x"}], "[0]: expected a list of {sha256"),
    ([_world(1).to_data(), _world(1).to_data()], "is listed twice"),
])
def test_check_reports_a_malformed_record(value: object, problem: str) -> None:
    store = MemoryStore()
    store.set_meta(WORLDS_KEY, value)
    problems = world_problems(store)
    assert len(problems) == 1 and problem in problems[0]


# -- export and import ----------------------------------------------------------------------


def _document(world: WorldFingerprint, *cases: int) -> Document:
    return Document(len(cases), {WORLDS_KEY: [world.to_data()]},
                    tuple(Case(x, x) for x in cases))


def test_importing_another_worlds_cases_is_refused(store: CaseStore) -> None:
    """On the memory and the SQLite store alike (the ``store`` fixture)."""
    a, b = _world(1), _world(2)
    load_document(store, _document(a, 1, 2))
    with pytest.raises(OtherWorld, match=f"{a.short}.*{b.short}"):
        load_document(store, _document(b, 3), append=True)
    assert (store.count(), recorded_worlds(store)[0]) == (2, [a])
    load_document(store, _document(a, 4), append=True)
    assert (store.count(), recorded_worlds(store)[0]) == (3, [a])
    load_document(store, _document(b, 5), append=True, worlds=ANY)
    assert (store.count(), recorded_worlds(store)[0]) == (4, [a, b])


def test_import_append_of_another_world_is_refused_by_the_command(invoke_cbr: Cli,
                                                                  tmp_path: Path) -> None:
    a, b = _world(1), _world(2)
    target = tmp_path / "cb.sqlite"
    with SQLiteStore(target) as store:
        load_document(store, _document(a, 1))
    document = tmp_path / "other.yaml"
    document.write_text(yaml.safe_dump({"format": "cbrcore-casebase", "schema": 1,
                                        "revision": 1, "meta": {WORLDS_KEY: [b.to_data()]},
                                        "cases": [{"problem": 2, "solution": 2}]}))
    refused = invoke_cbr("casebase", "import", str(target), str(document), "--append")
    assert refused.exit_code == 2 and "Traceback" not in refused.stderr
    assert a.short in refused.stderr and b.short in refused.stderr
    assert _snapshot(target).cases == (Case(1, 1, id=1, created=1),)
    carried = invoke_cbr("casebase", "import", str(document), "--append", "--store",
                      f"{{use: sqlite, path: {target}, worlds: any}}")
    assert carried.exit_code == 0, carried.stderr
    assert _snapshot(target).meta[WORLDS_KEY] == [a.to_data(), b.to_data()]


def test_a_document_with_a_malformed_world_record_is_refused() -> None:
    text = yaml.safe_dump({"format": "cbrcore-casebase", "schema": 1, "revision": 0,
                           "meta": {WORLDS_KEY: "office"}, "cases": []})
    with pytest.raises(CaseBaseError, match=r"meta\['cbrcore.worlds'\]|meta.cbrcore.worlds"):
        parse_document(text, "yaml", "doc.yaml")


# -- fingerprints -------------------------------------------------------------------------------


def test_a_fingerprint_is_the_same_in_another_process() -> None:
    code = ("import cbr_grid, attrs\n"
            "from cbr_grid.grid import grid_fingerprint\n"
            "@attrs.frozen\nclass C:\n    seed: int\n"
            "grid = cbr_grid.generated_world(cbr_grid.GeneratedOptions(kind='office', width=24, "
            "height=24), C(1))\n"
            "print(grid_fingerprint(grid).sha256)\n")
    found = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           check=True, env={"PYTHONPATH": ":".join(sys.path),
                                            "PYTHONHASHSEED": "123"})
    assert found.stdout.strip() == _world(1).sha256


def test_the_grid_fingerprint_follows_the_map_not_its_name() -> None:
    grid = generate("office", 30, 20, 4)
    same = grid_fingerprint(attrs.evolve(grid, name="elsewhere"))
    assert same == grid_fingerprint(grid) and same.description == "elsewhere"
    assert grid_fingerprint(generate("office", 30, 20, 5)) != same
    assert grid_fingerprint(attrs.evolve(grid, frame=MapFrame(0.05))) != same
    assert grid_fingerprint(attrs.evolve(grid, corner_cutting=True)) != same


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 12), st.integers(2, 12), st.data())
def test_changing_one_cell_changes_the_grid_fingerprint(width: int, height: int,
                                                        data: st.DataObject) -> None:
    risk = np.array(data.draw(st.lists(
        st.lists(st.floats(0, 1), min_size=width, max_size=width),
        min_size=height, max_size=height)))
    x, y = data.draw(st.integers(0, width - 1)), data.draw(st.integers(0, height - 1))
    value = data.draw(st.floats(0, 1).filter(lambda v: v != risk[y, x]))
    changed = risk.copy()
    changed[y, x] = value
    assert grid_fingerprint(Grid(risk)) == grid_fingerprint(Grid(risk.copy()))
    assert grid_fingerprint(Grid(changed)) != grid_fingerprint(Grid(risk))


_JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner,
                                                                max_size=3),
    max_leaves=8)


@settings(max_examples=100, deadline=None)
@given(_JSON, _JSON)
def test_fingerprints_differ_exactly_when_contents_do(a: object, b: object) -> None:
    """The encoding tells apart every two values that differ in a value or a type (1, 1.0 and
    True; "1" and 1; a list and a mapping), and mappings are compared whatever their order."""
    assert fingerprint("k", a, "") == fingerprint("k", copy.deepcopy(a), "")
    assert (fingerprint("k", a, "") == fingerprint("k", b, "")) == (_typed(a) == _typed(b))
    assert fingerprint("k", a, "") != fingerprint("other kind", a, "")


def _typed(value: object) -> object:
    """``value`` with each scalar paired with its type, mappings in key order."""
    if isinstance(value, dict):
        return ("map", sorted((key, _typed(item)) for key, item in value.items()))
    if isinstance(value, list):
        return ("list", [_typed(item) for item in value])
    return (type(value).__name__, repr(value))


def test_the_world_file_fingerprint_follows_the_file(tmp_path: Path) -> None:
    world = load_world(SCENARIO)
    first = cbr_world2d.cbr_world_fingerprint(world)
    assert first == cbr_world2d.cbr_world_fingerprint(load_world(SCENARIO))
    assert first.description.startswith(world.name)
    copy = tmp_path / "renamed.yaml"
    copy.write_text(SCENARIO.read_text())
    assert cbr_world2d.cbr_world_fingerprint(load_world(copy)) == first
    moved = tmp_path / "moved.yaml"
    moved.write_text(SCENARIO.read_text().replace("at: [6.0, 4.0]", "at: [6.0, 4.1]"))
    assert cbr_world2d.cbr_world_fingerprint(load_world(moved)) != first
