"""A broken plugin costs the command line its own commands, never the others'.

Each case installs a distribution ``cbr-broken 1.0`` whose entry point ``broken`` is broken one
way: its ``cbr_cli`` raises or exits, it exits when imported, or it adds commands whose names are
cbrcore's or a built-in plugin's. ``cbr --version``, ``cbr plugins`` and ``cbr run`` still work,
and one warning line names the plugin, its distribution and what went wrong; with
``CBR_STRICT_PLUGINS=1`` that line is the error, with exit code 2.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

import toy_domain
from cbrcore.errors import PluginError, PluginWarning
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult
from repo_paths import ROOT

Cli = Callable[..., CliResult]
SOURCE = "cbr-broken 1.0"
ALLOWED = "core,observers,solvers,world2d,broken,toy"

# a command of the broken plugin's own, which must work whatever else it got wrong
HELLO = ("    @app.command()\n"
         "    def hello() -> None:\n"
         "        typer.echo('hello from broken')\n")


def _cli(body: str) -> str:
    return ("import typer\nfrom cbrcore import hookimpl\n\n\n"
            "@hookimpl\ndef cbr_cli(app):\n" + body)


# case id: the module's text, the failure, whether ``cbr hello`` is still added
CASES: dict[str, tuple[str, str, bool]] = {
    "cbr_cli raises": (
        _cli(HELLO + "    raise RuntimeError('no display attached')\n"),
        "failed to add its commands: RuntimeError: no display attached", False),
    "cbr_cli calls sys.exit": (
        _cli(HELLO + "    raise SystemExit(3)\n"),
        "failed to add its commands: SystemExit: 3", False),
    "command typer cannot build": (
        "from typing import Annotated\n\n" + _cli(
            HELLO + "    @app.command()\n"
            "    def odd(x: Annotated[int, typer.Option(), typer.Option()]) -> None:\n"
            "        pass\n"),
        "failed to add its commands: MultipleTyperAnnotationsError: Cannot specify multiple "
        "`Annotated` Typer arguments for 'x'", False),
    "SystemExit at import": (
        "raise SystemExit(1)\n", "failed to import: SystemExit: 1", False),
    "cbr_register calls sys.exit": (
        "from cbrcore import hookimpl\n\n\n@hookimpl\ndef cbr_register(registry):\n"
        "    raise SystemExit('no licence')\n", "failed to register: SystemExit: no licence",
        False),
    "command named run": (
        _cli(HELLO + "    @app.command(name='run')\n    def hijack() -> None:\n"
             "        typer.echo('hijacked')\n"),
        "failed to add command 'run': the name is taken by cbrcore's own command", True),
    "command named plan": (
        _cli(HELLO + "    @app.command()\n    def plan() -> None:\n"
             "        typer.echo('hijacked')\n"),
        "failed to add command 'plan': the name is taken by plugin 'solvers' from cbrcore",
        True),
    "group named sim": (
        _cli(HELLO + "    sim = typer.Typer(name='sim')\n\n    @sim.command()\n"
             "    def run() -> None:\n        typer.echo('hijacked')\n\n"
             "    app.add_typer(sim)\n"),
        "failed to add command 'sim': the name is taken by plugin 'world2d' from cbrcore",
        True),
}


@pytest.fixture
def broken(request: pytest.FixtureRequest, tmp_path: Path,
           monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[Path, str, bool]]:
    """The site folder holding ``cbr-broken 1.0`` for the case, the failure's text, and whether
    its ``hello`` command is added."""
    text, failure, hello = CASES[request.param]
    module = "cbr_test_broken_" + "".join(c if c.isalnum() else "_" for c in request.param)
    site = tmp_path / "site"
    info = site / "cbr_broken-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: cbr-broken\nVersion: 1.0\n",
                                   encoding="utf-8")
    (info / "entry_points.txt").write_text(f"[cbr]\nbroken = {module}\n", encoding="utf-8")
    (site / f"{module}.py").write_text(text, encoding="utf-8")
    monkeypatch.syspath_prepend(str(site))
    yield site, f"plugin 'broken' from {SOURCE} {failure}", hello
    sys.modules.pop(module, None)


def _load(cbr_plugins: Callable[..., Plugins], **environ: str) -> Plugins:
    """The broken plugin with the built-ins, solvers, world2d and the toy domain."""
    return cbr_plugins(("toy", toy_domain), entry_points=True,
                       environ={"CBR_PLUGINS": ALLOWED, **environ})


def _at_load(message: str) -> bool:
    """Whether the failure is found as plugins load, rather than as the CLI adds commands."""
    return "failed to import" in message or "failed to register" in message


def _load_warned(cbr_plugins: Callable[..., Plugins], message: str) -> None:
    """Loading warns only for a plugin that fails to load; its commands fail in the CLI."""
    if _at_load(message):
        with pytest.warns(PluginWarning, match="plugin 'broken'"):
            _load(cbr_plugins)
    else:
        _load(cbr_plugins)


COMMANDS = {
    "--version": lambda tmp: ["--version"],
    "plugins": lambda tmp: ["plugins"],
    "run": lambda tmp: ["run", str(_toy_config(tmp)), "--out", str(tmp / "out")],
}


def _toy_config(tmp: Path) -> Path:
    path = tmp / "toy.yaml"
    path.write_text(toy_domain.TOY_CONFIG, encoding="utf-8")
    return path


@pytest.mark.parametrize("broken", list(CASES), indirect=True)
@pytest.mark.parametrize("command", list(COMMANDS))
def test_every_other_command_works_and_one_line_names_the_plugin(
        broken: tuple[Path, str, bool], command: str, cbr_plugins: Callable[..., Plugins],
        invoke_cbr: Cli, tmp_path: Path) -> None:
    _, message, _ = broken
    _load_warned(cbr_plugins, message)

    result = invoke_cbr(*COMMANDS[command](tmp_path))

    assert result.exit_code == 0, result
    assert "Traceback" not in result.stderr and "hijacked" not in result.stdout
    if _at_load(message):  # reported where plugins load, and listed
        if command != "run":
            assert message in result.stdout
    else:
        assert result.stderr.splitlines() == [f"warning: {message}"]
    if command == "run":
        assert (tmp_path / "out" / "results.csv").is_file()
    else:
        assert "core" in result.stdout and "solvers" in result.stdout


@pytest.mark.parametrize("broken", list(CASES), indirect=True)
def test_the_plugins_other_commands_still_join(broken: tuple[Path, str, bool],
                                               cbr_plugins: Callable[..., Plugins],
                                               invoke_cbr: Cli) -> None:
    """A clash leaves out the one command; a failing ``cbr_cli`` adds none of the plugin's."""
    _, message, hello = broken
    _load_warned(cbr_plugins, message)

    result = invoke_cbr("hello")

    if hello:
        assert (result.exit_code, result.stdout) == (0, "hello from broken\n")
    else:
        assert result.exit_code == 2
        assert "No such command 'hello'" in result.stderr


@pytest.mark.parametrize("broken", list(CASES), indirect=True)
def test_strict_plugins_make_the_failure_an_error(broken: tuple[Path, str, bool],
                                                  cbr_plugins: Callable[..., Plugins],
                                                  invoke_cbr: Cli) -> None:
    _, message, _ = broken
    if _at_load(message):  # strict loading refuses it before the command line
        with pytest.raises(PluginError, match=f"^{re.escape(message)}$"):
            _load(cbr_plugins, CBR_STRICT_PLUGINS="1")
        return
    _load(cbr_plugins, CBR_STRICT_PLUGINS="1")

    result = invoke_cbr("--version")

    assert result == CliResult(2, "", f"error: {message}\n")


@pytest.mark.parametrize("broken", ["SystemExit at import"], indirect=True)
@pytest.mark.parametrize(("strict", "code", "prefix", "stdout"), [
    ("", 0, "warning", "cbrcore "), ("1", 2, "error", "")], ids=["lenient", "strict"])
def test_the_installed_cbr_names_a_plugin_exiting_at_import(
        broken: tuple[Path, str, bool], tmp_path: Path, strict: str, code: int, prefix: str,
        stdout: str) -> None:
    """The ``cbr`` program, plugins loaded as it starts: one line naming the plugin."""
    site, message, _ = broken
    environ = {k: v for k, v in os.environ.items() if not k.startswith("CBR_")}
    paths = [str(site), str(ROOT), str(ROOT / "plugins"), environ.get("PYTHONPATH", "")]
    environ.update(PYTHONPATH=os.pathsep.join(p for p in paths if p),
                   CBR_PLUGINS="core,observers,broken", CBR_STRICT_PLUGINS=strict)
    done = subprocess.run([sys.executable, "-m", "cbrcore", "--version"], capture_output=True,
                          text=True, env=environ, cwd=tmp_path, timeout=120, check=False)

    assert done.returncode == code, done
    assert done.stderr == f"{prefix}: {message}\n"
    assert done.stdout.startswith(stdout)
