"""The ``casebase`` sub-commands: info, check, export and import, on SQLite files and on a store
that a test plugin registers."""

from __future__ import annotations

import json
import sqlite3
from collections.abc import Callable
from pathlib import Path
from typing import ClassVar

import attrs
import pytest
import yaml
from typer.testing import CliRunner, Result

import cbr_stores
import cbrcore.builtins
from cbr_stores.sqlite import SQLiteStore
from cbr_stores.sqlite_file import SCHEMA_VERSION
from cbrcore import hookimpl
from cbrcore.casebase import CaseStore, MemoryStore, UnusableCaseBase
from cbrcore.casebase.store import StoreCapabilities, StoreFile
from cbrcore.cli.casebase import app as casebase_app
from cbrcore.context import Context
from cbrcore.errors import CaseBaseError
from cbrcore.model import JSON, Case
from cbrcore.options import option
from cbrcore.plugins import Plugins
from cbrcore.registry import Registry
from cbrcore.testing import CliResult, StoreContract

Cli = Callable[..., CliResult]


class Shelf(MemoryStore):
    """A memory case base kept on a shelf, by name, so that opening it again finds it."""

    def __init__(self, name: str) -> None:
        super().__init__()
        self.name = name

    def __str__(self) -> str:
        return f"shelf {self.name!r}"

    def describe(self) -> dict[str, JSON]:
        return {"shelf": self.name}


@attrs.frozen
class ShelfOptions:
    name: str = option("main", "The case base on the shelf.")


class ShelfPlugin:
    """A plugin registering the ``shelf`` store; ``refuse`` maps names to the error opening
    them raises."""

    def __init__(self) -> None:
        self.shelves: dict[str, Shelf] = {}
        self.refuse: dict[str, Exception] = {}

    def open(self, options: ShelfOptions, ctx: Context) -> Shelf:
        """Case bases kept in memory, by name, for as long as the plugin lives."""
        if options.name in self.refuse:
            raise self.refuse[options.name]
        return self.shelves.setdefault(options.name, Shelf(options.name))

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("store", "shelf", self.open, options=ShelfOptions)


@pytest.fixture(autouse=True)
def core(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    """cbrcore's own stores, and no other plugin."""
    return cbr_plugins(("core", cbrcore.builtins), ("stores", cbr_stores))


@pytest.fixture
def shelf(cbr_plugins: Callable[..., Plugins]) -> ShelfPlugin:
    """The shelf plugin, loaded with cbrcore's own stores."""
    plugin = ShelfPlugin()
    cbr_plugins(("core", cbrcore.builtins), ("stores", cbr_stores), ("shelf", plugin))
    return plugin


class TestShelfStore(StoreContract):
    persistent = shared = True

    @pytest.fixture
    def open_store(self, shelf: ShelfPlugin) -> Callable[[str], CaseStore]:
        registry = Registry()
        shelf.cbr_register(registry)
        ctx = Context(registry=registry, seed=0)
        return lambda name: registry.create("store", "shelf", {"name": name}, ctx)


def run(*args: str | Path) -> Result:
    return CliRunner().invoke(casebase_app, [str(a) for a in args])


@pytest.fixture
def casebase(tmp_path: Path) -> Path:
    path = tmp_path / "cb.sqlite"
    with SQLiteStore(path) as store:
        with store.transaction():
            store.add(Case({"start": [0, 0]}, [[0, 0], [0, 1]]))
            store.add(Case("v", None, kind="vertex"))
            store.add(Case("w", None, kind="vertex"))
        store.touch([1])
        store.set_meta("grid", {"size": 8})
    return path


def test_info(casebase: Path) -> None:
    result = run("info", casebase)
    assert result.exit_code == 0, result.output
    assert "revision      3" in result.output
    assert "cases         3" in result.output
    assert "  vertex      2" in result.output
    assert "journal mode  wal" in result.output
    facts = json.loads(run("info", casebase, "--json").output)
    assert facts["kinds"] == {"case": 1, "vertex": 2}
    assert (facts["schema"], facts["revision"], facts["cases"]) == (SCHEMA_VERSION, 3, 3)
    assert facts["size_bytes"] == casebase.stat().st_size


def test_info_on_a_missing_file_creates_nothing(tmp_path: Path) -> None:
    result = run("info", tmp_path / "none.sqlite")
    assert isinstance(result.exception, CaseBaseError)
    assert "no case base at" in str(result.exception)
    assert list(tmp_path.iterdir()) == []


def test_check_a_sound_case_base(casebase: Path) -> None:
    result = run("check", casebase)
    assert (result.exit_code, result.output) == (0, "ok\n")


def test_check_lists_problems(casebase: Path) -> None:
    connection = sqlite3.connect(casebase)
    connection.execute("UPDATE cases SET uses = -1 WHERE id = 2")
    connection.execute("UPDATE cases SET solution = 'nope' WHERE id = 3")
    connection.commit()
    connection.close()
    result = run("check", casebase)
    assert result.exit_code == 1
    assert f"{casebase}: 2 problems:" in result.output
    assert "  - case 2: uses: expected a non-negative integer, got -1" in result.output
    assert "  - case 3: solution: not valid JSON" in result.output


@pytest.mark.parametrize(("content", "reason"), [
    (b"not a database at all", "is not a case base: not a SQLite database file"),
    (b"SQLite format 3\x00" + b"\x00" * 100, "is corrupt"),
])
def test_check_explains_a_file_it_cannot_use(tmp_path: Path, content: bytes, reason: str) -> None:
    path = tmp_path / "cb.sqlite"
    path.write_bytes(content)
    result = run("check", path)
    assert result.exit_code == 1
    assert f"{path} {reason}" in result.output
    assert path.read_bytes() == content


def test_check_json_gives_the_verdict_and_the_problems(casebase: Path, tmp_path: Path) -> None:
    sound = run("check", casebase, "--json")
    assert sound.exit_code == 0
    assert json.loads(sound.output) == {"casebase": str(casebase), "ok": True,
                                        "problems": []}
    connection = sqlite3.connect(casebase)
    connection.execute("UPDATE cases SET uses = -1 WHERE id = 2")
    connection.commit()
    connection.close()
    broken = run("check", casebase, "--json")
    assert broken.exit_code == 1
    assert json.loads(broken.output)["problems"] == [
        "case 2: uses: expected a non-negative integer, got -1"]
    garbage = tmp_path / "garbage.sqlite"
    garbage.write_bytes(b"not a database at all")
    unusable = run("check", garbage, "--json")
    assert unusable.exit_code == 1
    verdict = json.loads(unusable.output)
    assert (verdict["casebase"], verdict["ok"]) == (None, False)
    assert [f"{garbage} is not a case base" in p for p in verdict["problems"]] == [True]


def test_check_a_missing_file(tmp_path: Path) -> None:
    result = run("check", tmp_path / "none.sqlite")
    assert isinstance(result.exception, CaseBaseError)
    assert not (tmp_path / "none.sqlite").exists()


def test_export_to_standard_output(casebase: Path) -> None:
    result = run("export", casebase)
    assert result.exit_code == 0, result.output
    data = yaml.safe_load(result.output)
    assert (data["format"], data["revision"], len(data["cases"])) == ("cbrcore-casebase", 3, 3)
    assert data["meta"] == {"grid": {"size": 8}}
    data = json.loads(run("export", casebase, "--format", "json").output)
    assert data["cases"][0]["uses"] == 1


def test_export_to_a_file_and_import_it(casebase: Path, tmp_path: Path) -> None:
    exported = tmp_path / "cb.json"
    result = run("export", casebase, "-o", exported)
    assert result.exit_code == 0, result.output
    assert json.loads(exported.read_text())["revision"] == 3
    copy = tmp_path / "copy.sqlite"
    result = run("import", copy, exported)
    assert result.exit_code == 0, result.output
    assert f"imported 3 cases into {copy} (revision 3)" in result.output
    with SQLiteStore(casebase) as original, SQLiteStore(copy) as imported:
        assert imported.cases() == original.cases()
        assert imported.meta_items() == original.meta_items()


def test_export_needs_a_known_extension_or_format(casebase: Path, tmp_path: Path) -> None:
    result = run("export", casebase, "-o", tmp_path / "cb.txt")
    assert isinstance(result.exception, CaseBaseError)
    assert "cannot tell the format" in str(result.exception)
    result = run("export", casebase, "-o", tmp_path / "cb.txt", "--format", "yaml")
    assert result.exit_code == 0
    assert yaml.safe_load((tmp_path / "cb.txt").read_text())["revision"] == 3


def test_import_refuses_a_case_base_with_cases_unless_appending(casebase: Path,
                                                                tmp_path: Path) -> None:
    exported = tmp_path / "cb.yaml"
    run("export", casebase, "-o", exported)
    result = run("import", casebase, exported)
    assert isinstance(result.exception, CaseBaseError)
    assert "already holds 3 cases" in str(result.exception)
    result = run("import", casebase, exported, "--append")
    assert result.exit_code == 0, result.output
    with SQLiteStore(casebase) as store:
        assert (store.count(), store.revision) == (6, 4)


def test_a_bad_document_leaves_no_case_base_behind(tmp_path: Path) -> None:
    document = tmp_path / "bad.yaml"
    document.write_text("format: cbrcore-casebase\nschema: 1\ncases:\n- {problem: 1, kind: 3}\n")
    target = tmp_path / "cb.sqlite"
    result = run("import", target, document)
    assert isinstance(result.exception, CaseBaseError)
    assert "cases[0].kind: expected a non-empty string" in str(result.exception)
    assert "cases[0].solution: required key is missing" in str(result.exception)
    assert not target.exists()


def test_no_command_shows_help() -> None:
    result = run()
    assert "info" in result.output
    assert "import" in result.output


# -- any registered store ---------------------------------------------------------------------


def fill(store: CaseStore) -> None:
    """Three cases (two of kind vertex), one use and a meta value, in three transactions."""
    with store.transaction():
        store.add(Case({"start": [0, 0]}, [[0, 0], [0, 1]]))
        store.add(Case("v", None, kind="vertex"))
        store.add(Case("w", None, kind="vertex"))
    store.touch([1])
    store.set_meta("grid", {"size": 8})


def test_info_on_a_registered_store(shelf: ShelfPlugin, invoke_cbr: Cli) -> None:
    fill(shelf.open(ShelfOptions("a"), None))

    result = invoke_cbr("casebase", "info", "--store", "{use: shelf, name: a}")

    assert (result.exit_code, result.stderr) == (0, "")
    assert result.stdout.splitlines() == [
        "store         shelf",
        "revision      3",
        "cases         3",
        "  case        1",
        "  vertex      2",
        "world         none recorded",
        "shelf         a",
    ]
    facts = json.loads(invoke_cbr("casebase", "info", "--store", "{use: shelf, name: a}",
                               "--json").stdout)
    assert facts == {"store": "shelf", "revision": 3, "cases": 3,
                     "kinds": {"case": 1, "vertex": 2}, "worlds": [], "shelf": "a"}


def test_a_store_named_alone_has_its_default_options(shelf: ShelfPlugin, invoke_cbr: Cli) -> None:
    shelf.open(ShelfOptions("main"), None).add(Case(1, 1))

    result = invoke_cbr("casebase", "info", "--store", "shelf", "--json")

    assert json.loads(result.stdout)["shelf"] == "main"
    assert json.loads(result.stdout)["cases"] == 1


def test_export_and_import_through_a_registered_store(shelf: ShelfPlugin, invoke_cbr: Cli,
                                                      casebase: Path, tmp_path: Path) -> None:
    exported = tmp_path / "cb.yaml"
    assert invoke_cbr("casebase", "export", str(casebase), "-o", str(exported)).exit_code == 0

    result = invoke_cbr("casebase", "import", "--store", "{use: shelf, name: copy}", str(exported))

    assert (result.exit_code, result.stderr) == (0, "")
    assert result.stdout == "imported 3 cases into shelf 'copy' (revision 3)\n"
    with SQLiteStore(casebase, create=False) as original:
        assert shelf.shelves["copy"].cases() == original.cases()
        assert shelf.shelves["copy"].meta_items() == original.meta_items()
    again = invoke_cbr("casebase", "export", "--store", "{use: shelf, name: copy}")
    assert again.stdout == invoke_cbr("casebase", "export", str(casebase)).stdout
    refused = invoke_cbr("casebase", "import", "--store", "{use: shelf, name: copy}", str(exported))
    assert refused.exit_code == 2
    assert refused.stderr.startswith("error: shelf 'copy' already holds 3 cases")


def test_check_on_a_registered_store(shelf: ShelfPlugin, invoke_cbr: Cli) -> None:
    fill(shelf.open(ShelfOptions("a"), None))
    assert invoke_cbr("casebase", "check", "--store", "{use: shelf, name: a}").stdout == "ok\n"

    class Damaged(Shelf):
        def check(self) -> list[str]:
            return ["case 1: uses: expected a non-negative integer, got -1", "case 2: odd"]

    shelf.shelves["b"] = Damaged("b")
    result = invoke_cbr("casebase", "check", "--store", "{use: shelf, name: b}")
    assert result.exit_code == 1
    assert result.stdout == ("shelf 'b': 2 problems:\n"
                             "  - case 1: uses: expected a non-negative integer, got -1\n"
                             "  - case 2: odd\n")


def test_check_reports_a_case_base_its_store_finds_unusable(shelf: ShelfPlugin,
                                                             invoke_cbr: Cli) -> None:
    shelf.refuse["old"] = UnusableCaseBase("shelf 'old' has schema version 0")

    checked = invoke_cbr("casebase", "check", "--store", "{use: shelf, name: old}")
    shown = invoke_cbr("casebase", "info", "--store", "{use: shelf, name: old}")

    assert (checked.exit_code, checked.stdout) == (1, "shelf 'old' has schema version 0\n")
    assert (shown.exit_code, shown.stderr) == (2, "error: shelf 'old' has schema version 0\n")


def test_a_store_failing_to_open_is_named(shelf: ShelfPlugin, invoke_cbr: Cli) -> None:
    shelf.refuse["jammed"] = RuntimeError("the shelf is jammed")

    result = invoke_cbr("casebase", "export", "--store", "{use: shelf, name: jammed}")

    assert result.exit_code == 2
    assert result.stderr == ("error: casebase: plugin 'shelf' failed to build store 'shelf': "
                             "RuntimeError: the shelf is jammed\n")


def test_describe_may_not_repeat_the_facts_of_every_store(shelf: ShelfPlugin,
                                                          invoke_cbr: Cli) -> None:
    class Boastful(Shelf):
        def describe(self) -> dict[str, JSON]:
            return {"revision": 99, "cases": 0}

    shelf.shelves["a"] = Boastful("a")

    result = invoke_cbr("casebase", "info", "--store", "{use: shelf, name: a}")

    assert result.exit_code == 2
    assert "describe() repeats revision, cases, which cbr casebase info shows" in result.stderr


def test_the_casebase_slot_of_a_configuration(shelf: ShelfPlugin, invoke_cbr: Cli, casebase: Path,
                                              tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    folder = tmp_path / "configs"
    folder.mkdir()
    (folder / "file.yaml").write_text(f"seed: 3\ncasebase: {{use: sqlite, path: "
                                      f"{casebase.resolve()}}}\n", encoding="utf-8")
    (folder / "shelf.yaml").write_text("casebase: {use: shelf, name: b}\n", encoding="utf-8")
    (folder / "default.yaml").write_text("seed: 1\n", encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    shelf.open(ShelfOptions("b"), None).add(Case(1, 1))

    from_file = json.loads(invoke_cbr("casebase", "info", "--config", "configs/file.yaml",
                                   "--json").stdout)
    from_shelf = json.loads(invoke_cbr("casebase", "info", "-c", "configs/shelf.yaml",
                                    "--json").stdout)
    default = json.loads(invoke_cbr("casebase", "info", "-c", "configs/default.yaml",
                                 "--json").stdout)

    assert (from_file["store"], from_file["cases"]) == ("sqlite", 3)
    assert Path(from_file["path"]).resolve() == casebase.resolve()
    assert (from_shelf["store"], from_shelf["shelf"], from_shelf["cases"]) == ("shelf", "b", 1)
    assert default == {"store": "memory", "revision": 0, "cases": 0, "kinds": {},
                       "worlds": []}


def test_a_store_path_resolves_against_the_working_folder(invoke_cbr: Cli, casebase: Path,
                                                          monkeypatch: pytest.MonkeyPatch
                                                          ) -> None:
    monkeypatch.chdir(casebase.parent)

    result = invoke_cbr("casebase", "info", "--store", f"{{use: sqlite, path: {casebase.name}}}",
                     "--json")

    assert json.loads(result.stdout)["path"] == str(casebase)


@pytest.mark.parametrize(("args", "message"), [
    ((), "name the case base with one of them"),
    (("cb.sqlite", "--store", "memory"), "name the case base with one of them, not FILE and "
                                         "--store"),
    (("--store", "memory", "--config", "x.yaml"), "not --store and --config"),
    # the registered stores follow, each with its plugin (core's, and the shelf)
    (("--store", "nope"), "error: --store: 1 problem:\n  - casebase: unknown store 'nope'; "
                          "registered: memory (plugin core), "),
    (("--store", "{use: shelf, nme: a}"), "error: --store: 1 problem:\n  - casebase.nme: "
                                          "unknown key; expected one of: name\n"),
    (("--store", "{use: shelf"), "error: --store: 1 problem:\n  - line 1, column 12: "
                                 "malformed YAML"),
    (("--store", "{use: sqlite, path: nowhere.sqlite, create: false}"), "no case base at"),
    (("--store", "sqlite"), "casebase.path: required"),
    (("--config", "missing.yaml"), "missing.yaml: 1 problem:\n  - file not found"),
])
def test_a_case_base_that_cannot_be_opened_is_one_clear_message(
        shelf: ShelfPlugin, invoke_cbr: Cli, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        args: tuple[str, ...], message: str) -> None:
    monkeypatch.chdir(tmp_path)
    for command in ("info", "check", "export"):
        result = invoke_cbr("casebase", command, *args)

        assert result.exit_code == 2, (command, result)
        assert message in result.stderr
        assert "Traceback" not in result.stderr
    assert list(tmp_path.iterdir()) == []


def test_import_names_a_missing_document(invoke_cbr: Cli) -> None:
    result = invoke_cbr("casebase", "import", "--store", "memory")

    assert result.exit_code == 2
    assert "name the exported file to import" in result.stderr


def test_a_missing_file_is_an_error_and_stays_missing(invoke_cbr: Cli, tmp_path: Path) -> None:
    path = tmp_path / "none.sqlite"
    for command in ("info", "check", "export"):
        result = invoke_cbr("casebase", command, str(path))

        assert (result.exit_code, result.stderr) == (2, f"error: no case base at {path}\n")
    assert list(tmp_path.iterdir()) == []


def test_a_configuration_without_a_case_base_path_names_its_run_folders_file(
        invoke_cbr: Cli, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "floor.yaml").write_text("seed: 3\ncasebase: sqlite\n", encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    kept = tmp_path / "runs" / "floor" / "casebase.sqlite"

    missing = invoke_cbr("casebase", "info", "--config", "floor.yaml")

    assert missing.exit_code == 2 and str(kept) in missing.stderr
    assert not kept.parent.exists()  # reading never creates the run folder or the file
    kept.parent.mkdir(parents=True)
    with SQLiteStore(kept) as store:
        store.add(Case(1, 1))
    found = json.loads(invoke_cbr("casebase", "info", "-c", "floor.yaml", "--json").stdout)
    assert (found["store"], found["cases"], Path(found["path"])) == ("sqlite", 1, kept)


def test_a_file_or_a_configurations_relative_path_names_the_file_runs_keep(
        invoke_cbr: Cli, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    here = tmp_path / "here"
    here.mkdir()
    with SQLiteStore(tmp_path / "above.sqlite") as store:
        store.add(Case(1, 1))
    (here / "floor.yaml").write_text("casebase: {use: sqlite, path: kept.sqlite}\n",
                                     encoding="utf-8")
    kept = here / "runs" / "floor" / "kept.sqlite"
    kept.parent.mkdir(parents=True)
    with SQLiteStore(kept) as store:
        store.add(Case(1, 1))
        store.add(Case(2, 2))
    monkeypatch.chdir(here)

    above = json.loads(invoke_cbr("casebase", "info", "../above.sqlite", "--json").stdout)
    run = json.loads(invoke_cbr("casebase", "info", "-c", "floor.yaml", "--json").stdout)

    assert (Path(above["path"]), above["cases"]) == (tmp_path / "above.sqlite", 1)
    assert (Path(run["path"]), run["cases"]) == (kept, 2)


@attrs.frozen
class FileShelfOptions:
    """A shelf store that says it keeps its case base in a file and can open it read-only."""

    CAPABILITIES: ClassVar[StoreCapabilities] = StoreCapabilities(
        file=StoreFile("shelf.yaml"), read_only=True)

    path: Path | None = option(None, "The case base file.")
    create: bool = option(True, "Create a missing case base.")
    read_only: bool = option(False, "Open for reading alone.")


class FileShelfPlugin:
    """Registers ``file_shelf``, recording the options each case base is opened with."""

    def __init__(self) -> None:
        self.opened: list[FileShelfOptions] = []

    def open(self, options: FileShelfOptions, ctx: Context) -> Shelf:
        self.opened.append(options)
        shelf = Shelf(str(options.path))
        fill(shelf)
        return shelf

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("store", "file_shelf", self.open, options=FileShelfOptions)


def test_the_commands_ask_a_store_what_it_can_do_not_its_name(
        tmp_path: Path, cbr_plugins: Callable[..., Plugins], invoke_cbr: Cli) -> None:
    plugin = FileShelfPlugin()
    cbr_plugins(("core", cbrcore.builtins), ("file_shelf", plugin))
    kept = tmp_path / "kept.yaml"
    kept.write_text("a case base file\n", encoding="utf-8")
    store = f"{{use: file_shelf, path: '{kept}'}}"

    assert invoke_cbr("casebase", "info", "--store", store).exit_code == 0
    refused = invoke_cbr("casebase", "export", "--store", store, "--output", str(kept))

    # reading opens it read-only; an export over the file the store keeps is refused
    assert [options.read_only for options in plugin.opened] == [True, True]
    assert refused.exit_code == 2
    assert "it is the case base being exported" in refused.stderr
    assert kept.read_text(encoding="utf-8") == "a case base file\n"
