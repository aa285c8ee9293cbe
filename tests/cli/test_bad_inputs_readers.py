"""Bad inputs to the configuration-style readers: the file, line and column and the shape
expected, never the content of a file that is not what it should be.

Each row gives a reader a file that is not of its format (a secret, say: a line of text, a
mapping whose keys are the secret's, a wrong ``format`` tag, malformed YAML) through the
command a user would run. The command exits with code 2, names the file and the place, says
what was expected, and prints nothing of the file. Text a message does quote (a setting under a
key the schema knows, a file's name) is printed as written: rich renders neither markup nor
emoji shortcodes in it.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from cbrcore import hookimpl
from cbrcore.plugins import Plugins
from cbrcore.registry import Registry
from cbrcore.testing import CliResult

Cli = Callable[..., CliResult]
MARKER = "S3CRETTOKEN4f9a"

# the files the rows read, in tmp: each is a secret of a shape some reader might take
FILES = {
    "line.yaml": f"api_key {MARKER}\n",
    "line.sexp": f"api_key {MARKER}\n",
    "keys.yaml": f"bounds: [0, 0, 5, 5]\n{MARKER} password: hunter2\n",
    "item.yaml": f"- {MARKER} password: hunter2\n",
    "tag.yaml": f"format: {MARKER}\nschema: 1\ncases: []\n",
    "tag.json": f'{{"format": "{MARKER}", "schema": 1, "cases": []}}\n',
    "broken.yaml": f"{MARKER}: [unclosed: {MARKER}\n",
    "list.json": f'["{MARKER}"]\n',
    "numbered.yaml": "bounds: [0, 0, 5, 5]\nwalls: [{3: 1, x: 2}]\n",
    "waypoints.yaml": ("bounds: [0, 0, 8, 6]\n"
                       "movers: [{waypoints: nowhere, speed: 1, radius: 0.2}]\n"),
}

# case id: the command's arguments ({tmp} is the folder of the files), and what the message says
CASES: dict[str, tuple[tuple[str, ...], str]] = {
    "validate a line of text": (
        ("validate", "{tmp}/line.yaml"),
        "line.yaml: 1 problem:\n  - the top level (line 1, column 1): expected a mapping of "
        "settings, got a string"),
    "run a line of text": (
        ("run", "{tmp}/line.yaml", "--out", "{tmp}/out"),
        "line.yaml: 1 problem:\n  - the top level (line 1, column 1): expected a mapping of "
        "settings, got a string"),
    "validate keys that are no settings": (
        ("validate", "{tmp}/keys.yaml"),
        "keys.yaml: 2 problems:\n  - line 1, column 1: unknown key; expected one of: "),
    "casebase info --config a line of text": (
        ("casebase", "info", "--config", "{tmp}/line.yaml"),
        "line.yaml: 1 problem:\n  - the top level (line 1, column 1): expected a mapping of "
        "settings, got a string"),
    "sim show a line of text": (
        ("sim", "show", "{tmp}/line.yaml"),
        "line.yaml: 1 problem:\n  - the top level (line 1, column 1): expected a world: a "
        "mapping with at least bounds [xmin, ymin, xmax, ymax], got a string"),
    "sim run a line of text": (
        ("sim", "run", "{tmp}/line.yaml", "--start", "1,1", "--target", "2,2"),
        "line.yaml: 1 problem:\n  - the top level (line 1, column 1): expected a world"),
    "sim show keys that are no world's": (
        ("sim", "show", "{tmp}/keys.yaml"),
        "keys.yaml: 1 problem:\n  - line 2, column 1: unknown key; expected one of: bounds"),
    "sim show a wall with a number and a name for keys": (
        ("sim", "show", "{tmp}/numbered.yaml"),
        "numbered.yaml: 2 problems:\n  - walls.0.3 (line 2, column 13): unknown key; expected "
        "one of: a, b, between\n  - walls.0.x (line 2, column 19): unknown key"),
    "sim show waypoints that are a string": (
        ("sim", "show", "{tmp}/waypoints.yaml"),
        "waypoints.yaml: 1 problem:\n  - movers.0.waypoints (line 2, column 22): expected a "
        "list, got 'nowhere'"),
    "validate a workload trigger that is no list": (
        ("validate", "{tmp}/trials.yaml"),
        "trials.yaml: 1 problem:\n  - workload.consult_on (line 1, column 49): expected a list, "
        "got 'blocked'"),
    "validate a heading trigger's turn of 0": (
        ("validate", "{tmp}/turn.yaml"),
        "turn.yaml: 1 problem:\n  - workload.turn (line 1, column 43): must be > 0.0: 0.0"),
    "validate a negative landmark memory": (
        ("validate", "{tmp}/memory.yaml"),
        "memory.yaml: 1 problem:\n  - workload.memory.seconds (line 1, column 55): must be >= "
        "0.0: -1.0"),
    "run a landmark memory that blurs by a string": (
        ("run", "{tmp}/blur.yaml", "--out", "{tmp}/out"),
        "blur.yaml: 1 problem:\n  - workload.memory.per_metre (line 1, column 57): expected a "
        "number, got 'fast'"),
    "validate a camera that pans past the half turn": (
        ("validate", "{tmp}/pan.yaml"),
        "pan.yaml: 1 problem:\n  - workload.camera.pan (line 1, column 51): must be <= 180.0: "
        "200.0"),
    "validate a camera that pans at no speed": (
        ("validate", "{tmp}/pan_rate.yaml"),
        "pan_rate.yaml: 1 problem:\n  - workload.camera.pan_rate (line 1, column 56): must be "
        "> 0.0: 0.0"),
    "validate a negative margin of the region in front": (
        ("validate", "{tmp}/margin.yaml"),
        "margin.yaml: 1 problem:\n  - retrieve.region.margin (line 1, column 45): must be >= "
        "0.0: -1.0"),
    "run a world2d_file world of text": (
        ("run", "{tmp}/world.yaml", "--out", "{tmp}/out"),
        "line.yaml: 1 problem:\n  - the top level (line 1, column 1): expected a world"),
    "rupart show a line of text (sexp)": (
        ("rupart", "show", "{tmp}/line.sexp"),
        "line.sexp: 2 problems:\n  - line 1, column 1: expected a case form, one of "
        "(behavior-case ...), (meta-plan ...), (plan-case ...), (alter-strategy ...), "
        "(merge-strategy ...), got a string\n  - line 1, column 9: expected a case form"),
    "rupart add a line of text (sexp)": (
        ("rupart", "add", "{tmp}/line.sexp", "--store", "memory"),
        "line.sexp: 2 problems:\n  - line 1, column 1: expected a case form"),
    "rupart show a line of text (yaml)": (
        ("rupart", "show", "{tmp}/line.yaml"),
        "line.yaml, line 1, column 1 (the document): expected a list of cases (or an exported "
        "case base), got a string"),
    "rupart add an item that is no case": (
        ("rupart", "add", "{tmp}/item.yaml", "--store", "memory"),
        "item.yaml, line 1 ([0]): expected exactly one of behavior-case, meta-plan, plan-case, "
        "alter-strategy, merge-strategy naming the case, got none"),
    "rupart show a wrong format tag": (
        ("rupart", "show", "{tmp}/tag.yaml"),
        "tag.yaml: not a valid case base document, 1 problem:\n  - format (line 1, column 9): "
        "expected 'cbrcore-casebase', got a string; this is not an exported case base"),
    "casebase import a wrong format tag": (
        ("casebase", "import", "{tmp}/cb.sqlite", "{tmp}/tag.yaml"),
        "tag.yaml: not a valid case base document, 1 problem:\n  - format (line 1, column 9): "
        "expected 'cbrcore-casebase', got a string; this is not an exported case base"),
    "casebase import a wrong format tag (json)": (
        ("casebase", "import", "{tmp}/cb.sqlite", "{tmp}/tag.json"),
        "tag.json: not a valid case base document, 1 problem:\n  - format: expected "
        "'cbrcore-casebase', got a string; this is not an exported case base"),
    "casebase import a line of text": (
        ("casebase", "import", "{tmp}/cb.sqlite", "{tmp}/line.yaml"),
        "line.yaml: the top level (line 1, column 1): expected a case base document (a mapping "
        "with format: cbrcore-casebase), got a string"),
    "casebase import a list (json)": (
        ("casebase", "import", "{tmp}/cb.sqlite", "{tmp}/list.json"),
        "list.json: the top level: expected a case base document (a mapping with format: "
        "cbrcore-casebase), got a list"),
    "casebase import malformed YAML": (
        ("casebase", "import", "{tmp}/cb.sqlite", "{tmp}/broken.yaml"),
        "broken.yaml: not valid YAML: line 2, column 1: expected ',' or ']', but got '<stream "
        "end>'"),
    "a store's initial cases with a wrong format tag": (
        ("run", "{tmp}/initial.yaml", "--out", "{tmp}/out"),
        "tag.yaml: not a valid case base document, 1 problem:\n  - format (line 1, column 9): "
        "expected 'cbrcore-casebase', got a string"),
}


@pytest.fixture(autouse=True)
def installed(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    """The installed plugins, world2d and behaviors among them, made current for every test."""
    return cbr_plugins(entry_points=True)


def _write_files(tmp: Path) -> None:
    for name, text in FILES.items():
        (tmp / name).write_text(text, encoding="utf-8")
    (tmp / "world.yaml").write_text(
        "world: {use: world2d_file, path: line.yaml}\nworkload: trials\n", encoding="utf-8")
    (tmp / "trials.yaml").write_text(
        "workload: {use: trials, trials: [], consult_on: blocked}\n", encoding="utf-8")
    (tmp / "turn.yaml").write_text(
        "workload: {use: trials, trials: [], turn: 0}\n", encoding="utf-8")
    (tmp / "memory.yaml").write_text(
        "workload: {use: trials, trials: [], memory: {seconds: -1}}\n", encoding="utf-8")
    (tmp / "blur.yaml").write_text(
        "workload: {use: trials, trials: [], memory: {per_metre: fast}}\n", encoding="utf-8")
    (tmp / "pan.yaml").write_text(
        "workload: {use: trials, trials: [], camera: {pan: 200}}\n", encoding="utf-8")
    (tmp / "pan_rate.yaml").write_text(
        "workload: {use: trials, trials: [], camera: {pan_rate: 0}}\n", encoding="utf-8")
    (tmp / "margin.yaml").write_text(
        "retrieve: {use: landmarks, region: {margin: -1}}\nworkload: {use: trials, trials: []}\n",
        encoding="utf-8")
    (tmp / "initial.yaml").write_text(
        "casebase: {use: memory, initial: tag.yaml}\n", encoding="utf-8")


@pytest.mark.parametrize(("args", "message"), CASES.values(), ids=list(CASES))
def test_a_file_of_the_wrong_shape_is_located_and_never_quoted(
        invoke_cbr: Cli, tmp_path: Path, args: tuple[str, ...], message: str) -> None:
    _write_files(tmp_path)

    result = invoke_cbr(*(arg.format(tmp=tmp_path) for arg in args))

    assert result.exit_code == 2, result
    assert "Traceback" not in result.stderr
    assert MARKER not in result.stdout + result.stderr
    assert "hunter2" not in result.stdout + result.stderr
    assert message in result.stderr, result.stderr
    assert not (tmp_path / "cb.sqlite").exists()


# -- what is quoted is printed as written -----------------------------------------------------

VERBATIM = "bin:x:1:1 [bold]b[/bold] :smile:"


class Complains:
    """A plugin whose registration fails with a message holding markup and shortcodes."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        raise RuntimeError(VERBATIM)


@pytest.mark.parametrize("where", ["a setting", "a file name"])
def test_quoted_text_keeps_its_colons_and_brackets(invoke_cbr: Cli, tmp_path: Path,
                                                   where: str) -> None:
    folder = tmp_path / (":x:[bold]d" if where == "a file name" else "plain")
    folder.mkdir()
    config = folder / "run.yaml"
    config.write_text(f"seed: '{VERBATIM}'\n", encoding="utf-8")

    result = invoke_cbr("validate", str(config))

    assert result.exit_code == 2
    assert f"{config}: 1 problem:" in result.stderr
    if where == "a setting":
        assert (f"seed (line 1, column 7): expected a non-negative integer, got '{VERBATIM}'"
                in result.stderr)
    assert "\N{CROSS MARK}" not in result.stderr and "\N{SMILING FACE WITH SMILING EYES}" \
        not in result.stderr


def test_a_plugin_failure_is_listed_as_written(cbr_plugins: Callable[..., Plugins],
                                               invoke_cbr: Cli) -> None:
    with pytest.warns(UserWarning, match="failed to register"):
        cbr_plugins(("complains", Complains()))

    result = invoke_cbr("plugins")

    assert result.exit_code == 0
    assert (f"failed: plugin 'complains' failed to register: RuntimeError: {VERBATIM}"
            in result.stdout)
