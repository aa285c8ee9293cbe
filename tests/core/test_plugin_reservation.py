"""No plugin can take over a built-in, and a plugin that fails reads as one clear line.

The built-in plugins are those the ``cbrcore`` distribution declares. Their plugin names,
component names and kinds are theirs whatever order the names sort in: another plugin taking
one fails alone, named as the culprit. The rival plugins here are installed as a distribution
(``cbr-rival`` 1.0) in a folder put first on ``sys.path``, or given in code.
"""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from collections.abc import Callable, Iterator
from importlib import metadata
from pathlib import Path
from typing import Any

import pytest

import cbr_observers
import cbr_solvers
import cbrcore.builtins
from cbrcore import hookimpl
from cbrcore.errors import PluginError, PluginWarning
from cbrcore.plugins import PluginFailure, PluginInfo, Plugins, builtin_plugins, load_plugins
from cbrcore.registry import Registry
from cbrcore.testing import CliResult

RIVAL_MODULE = "cbr_test_rival"
RIVAL = ("cbr-rival", "1.0")
SOLVERS = ["aistar", "astar", "dijkstra", "genetic", "jps", "landmark_detour", "randomized",
           "rescuer"]
TAKES_ASTAR = 'registry.add("solver", "astar", Impostor)'

# what a rival registers, and the error that fails it
COLLISIONS = {
    "solver": (TAKES_ASTAR, "solver 'astar' is already registered by plugin 'solvers'"),
    "store": ('registry.add("store", "memory", Impostor)',
              "store 'memory' is already registered by plugin 'core'"),
    "observer": ('registry.add("observer", "trace", Impostor)',
                 "observer 'trace' is already registered by plugin 'observers'"),
    "kind": ('registry.add_kind("kinematics", "the rival\'s own robots")',
             "component kind 'kinematics' is already declared by plugin 'kinematics'"),
}
# entry point names sorting before and after every built-in's
ORDERS = {"first": "a_rival", "last": "z_rival"}

InstallRival = Callable[[str, str], Path]


class Impostor:
    """A component standing in for a built-in one."""

    def __init__(self, options: object, ctx: object) -> None:
        pass


class Rival:
    """A plugin given in code that registers ``solver: astar``, as ``cbr_solvers`` does."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("solver", "astar", Impostor)


class Registers:
    """A plugin registering a solver of a name no built-in has."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("solver", "echo", Impostor)


def _builtins(plugins: Plugins) -> dict[str, PluginInfo]:
    return {p.name: p for p in plugins.loaded if p.name in builtin_plugins()}


@pytest.fixture(scope="module")
def untouched() -> dict[str, PluginInfo]:
    """The built-in plugins as they load with no rival installed."""
    return _builtins(load_plugins(environ={}))


@pytest.fixture
def install_rival(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[InstallRival]:
    """``install_rival(entry_points, register)``: install cbr-rival 1.0 ahead of cbrcore.

    ``entry_points`` is the body of its ``[cbr]`` entry point section, naming ``cbr_test_rival``,
    whose ``cbr_register`` runs the statement ``register``. Returns the folder it is in.
    """
    site = tmp_path / "site"

    def install(entry_points: str, register: str) -> Path:
        info = site / "cbr_rival-1.0.dist-info"
        info.mkdir(parents=True)
        (info / "METADATA").write_text("Metadata-Version: 2.1\nName: cbr-rival\nVersion: 1.0\n",
                                       encoding="utf-8")
        (info / "entry_points.txt").write_text(f"[cbr]\n{entry_points}\n", encoding="utf-8")
        (site / f"{RIVAL_MODULE}.py").write_text(
            "from cbrcore import hookimpl\n\n\n"
            "class Impostor:\n"
            "    def __init__(self, options, ctx):\n"
            "        pass\n\n\n"
            "@hookimpl\n"
            "def cbr_register(registry):\n"
            f"    {register}\n",
            encoding="utf-8")
        monkeypatch.syspath_prepend(str(site))
        return site

    yield install
    sys.modules.pop(RIVAL_MODULE, None)


# -- component names and kinds ----------------------------------------------------------------


@pytest.mark.parametrize("collision", list(COLLISIONS))
@pytest.mark.parametrize("order", list(ORDERS))
def test_a_rival_taking_a_builtin_name_fails_alone_whatever_the_order(
        install_rival: InstallRival, untouched: dict[str, PluginInfo], order: str,
        collision: str) -> None:
    name = ORDERS[order]
    register, error = COLLISIONS[collision]
    install_rival(f"{name} = {RIVAL_MODULE}", register)

    with pytest.warns(PluginWarning) as warned:
        plugins = load_plugins(environ={})

    assert plugins.failed == [PluginFailure(name, *RIVAL, "register", f"PluginError: {error}")]
    assert [str(w.message) for w in warned] == [
        f"plugin {name!r} from cbr-rival 1.0 failed to register: PluginError: {error}"]
    assert _builtins(plugins) == untouched
    assert [c.name for c in plugins.registry if c.kind == "solver"] == SOLVERS
    assert plugins.registry.kinds["kinematics"].plugin == "kinematics"


@pytest.mark.parametrize("first", [True, False])
def test_a_rival_in_code_cannot_take_a_name_of_a_builtin_in_code(first: bool) -> None:
    """The testing kit registers the built-in modules in code; they count as built-ins."""
    rival = ("rival", Rival())
    given = [rival, ("solvers", cbr_solvers)] if first else [("solvers", cbr_solvers), rival]

    with pytest.warns(PluginWarning, match="plugin 'rival' failed to register"):
        plugins = load_plugins(given, entry_points=False, environ={})

    assert [p.name for p in plugins.loaded] == ["solvers"]
    assert plugins.failed == [PluginFailure(
        "rival", None, None, "register",
        "PluginError: solver 'astar' is already registered by plugin 'solvers'")]
    assert plugins.registry.get("solver", "astar").factory is not Impostor


def test_the_builtins_keep_the_order_they_were_given_in() -> None:
    plugins = load_plugins([("toy", Registers()), ("core", cbrcore.builtins),
                            ("watch", cbr_observers)], entry_points=False, environ={})
    assert [p.name for p in plugins.loaded] == ["toy", "core", "watch"]


def test_a_disabled_builtin_leaves_its_names_free(install_rival: InstallRival) -> None:
    """Disabling a built-in is how a distribution replaces it on purpose."""
    install_rival(f"a_rival = {RIVAL_MODULE}", TAKES_ASTAR)

    plugins = load_plugins(environ={"CBR_DISABLE_PLUGINS": "solvers"})

    assert plugins.failed == []
    assert plugins.registry.get("solver", "astar").plugin == "a_rival"


def test_a_rival_is_fatal_when_strict(install_rival: InstallRival) -> None:
    install_rival(f"a_rival = {RIVAL_MODULE}", TAKES_ASTAR)
    with pytest.raises(PluginError, match=r"^plugin 'a_rival' from cbr-rival 1\.0 failed to "
                                          r"register: PluginError: solver 'astar'"):
        load_plugins(environ={"CBR_STRICT_PLUGINS": "1"})


# -- entry point names ------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["core", "observers", "solvers"])
def test_an_entry_point_named_like_a_builtin_cannot_displace_it(
        install_rival: InstallRival, untouched: dict[str, PluginInfo], name: str) -> None:
    install_rival(f"{name} = {RIVAL_MODULE}", TAKES_ASTAR)
    # the rival comes first among the entry points of that name, as it would take over
    assert [ep.dist.name for ep in metadata.entry_points(group="cbr", name=name)
            if ep.dist is not None] == ["cbr-rival", "cbrcore"]

    with pytest.warns(PluginWarning, match=f"plugin '{name}' from cbr-rival 1.0 failed to load"):
        plugins = load_plugins(environ={})

    assert plugins.failed == [PluginFailure(name, *RIVAL, "load",
                                            "the plugin name is already taken by cbrcore")]
    assert _builtins(plugins) == untouched
    assert RIVAL_MODULE not in sys.modules  # refused before it was imported


def test_builtin_plugins_are_those_cbrcore_declares() -> None:
    declared = metadata.distribution("cbrcore").entry_points.select(group="cbr")
    assert builtin_plugins() == {ep.name: ep.module for ep in declared}
    assert builtin_plugins()["core"] == "cbrcore.builtins"


# -- how a failure is shown -------------------------------------------------------------------


def test_library_users_can_filter_plugin_warnings() -> None:
    assert issubclass(PluginWarning, UserWarning)
    with warnings.catch_warnings(record=True) as shown:
        warnings.simplefilter("always")
        warnings.simplefilter("ignore", PluginWarning)
        plugins = load_plugins([("rival", Rival()), ("solvers", cbr_solvers)],
                               entry_points=False, environ={})
    assert [f.name for f in plugins.failed] == ["rival"]
    assert shown == []


class Warns:
    """A plugin whose command warns with a plugin warning and a plain one."""

    @hookimpl
    def cbr_cli(self, app: Any) -> None:
        @app.command("warn")
        def warn() -> None:
            warnings.warn("plugin 'x' from dist 1.0 failed to register: no", PluginWarning,
                          stacklevel=1)
            warnings.warn("something else", UserWarning, stacklevel=1)


def test_the_cli_shows_a_plugin_warning_as_one_line_and_leaves_others_be(
        cbr_plugins: Callable[..., Plugins], invoke_cbr: Callable[..., CliResult]) -> None:
    cbr_plugins(("warns", Warns()))

    with pytest.warns(UserWarning, match="something else") as others:
        result = invoke_cbr("warn")

    assert result.exit_code == 0
    assert result.stderr == "warning: plugin 'x' from dist 1.0 failed to register: no\n"
    assert [w.category for w in others] == [UserWarning]
    # the display is the caller's again once the command is done
    with pytest.warns(PluginWarning):
        warnings.warn("after", PluginWarning, stacklevel=1)


@pytest.mark.parametrize("warnings_are_errors", [False, True])
def test_cbr_keeps_its_builtins_and_blames_the_rival_in_one_line(
        install_rival: InstallRival, tmp_path: Path, warnings_are_errors: bool) -> None:
    site = install_rival(f"a_rival = {RIVAL_MODULE}", TAKES_ASTAR)
    environ = {k: v for k, v in os.environ.items()
               if not k.startswith("CBR_") and k != "PYTHONWARNINGS"}
    environ["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(site), environ.get("PYTHONPATH")) if p)
    if warnings_are_errors:
        environ["PYTHONWARNINGS"] = "error"

    done = subprocess.run([sys.executable, "-m", "cbrcore", "plan", "--help"],
                          capture_output=True, text=True, cwd=tmp_path, env=environ, check=False)

    # with warnings made errors, the failure stops the command: one error line, exit 2
    assert done.returncode == (2 if warnings_are_errors else 0), done.stderr
    assert done.stderr == (f"{'error' if warnings_are_errors else 'warning'}: plugin 'a_rival' "
                           "from cbr-rival 1.0 failed to register: PluginError: solver 'astar' "
                           "is already registered by plugin 'solvers'\n")


@pytest.mark.parametrize("order", list(ORDERS))
def test_a_rivals_command_cannot_replace_a_builtin_plugins_command(
        order: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        cbr_plugins: Callable[..., Plugins], invoke_cbr: Callable[..., CliResult]) -> None:
    site = tmp_path / "site"
    info = site / "cbr_rival-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: cbr-rival\nVersion: 1.0\n",
                                   encoding="utf-8")
    (info / "entry_points.txt").write_text(f"[cbr]\n{ORDERS[order]} = cbr_test_rival_cli\n",
                                           encoding="utf-8")
    (site / "cbr_test_rival_cli.py").write_text(
        "from cbrcore import hookimpl\n\n\n"
        "@hookimpl\n"
        "def cbr_cli(app):\n"
        "    @app.command('plan')\n"
        "    def plan():\n"
        "        print('the rival plans')\n",
        encoding="utf-8")
    monkeypatch.syspath_prepend(str(site))
    try:
        loaded = cbr_plugins(entry_points=True)
        assert ORDERS[order] in {p.name for p in loaded.loaded}

        shown = invoke_cbr("plan", "--help")
    finally:
        sys.modules.pop("cbr_test_rival_cli", None)

    assert shown.exit_code == 0 and "--start" in shown.stdout
    assert "rival" not in shown.stdout
