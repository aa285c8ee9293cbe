"""Loading plugins: entry points, failures, allow- and block-lists, clashes, the testing kit."""

from __future__ import annotations

import json
import subprocess
import sys
import types
from collections.abc import Callable, Iterator
from importlib import metadata
from pathlib import Path
from typing import Any

import attrs
import pytest

import cbr_observers
import cbr_stores
import cbrcore.builtins
import toy_domain
from cbrcore import Solution, hookimpl
from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.errors import ConfigError, PluginError
from cbrcore.hookimpls import HOOKS, implemented_hooks, unknown_hooks
from cbrcore.plugins import Plugins, current, load_plugins
from cbrcore.registry import Registry
from cbrcore.testing import CliResult
from conftest import installed_plugins

CBRCORE_VERSION = metadata.version("cbrcore")
RAISING_MODULE = "cbr_test_raising_plugin"


class Echo:
    """A solver whose solution is the problem itself."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_solve(self, problem: Any) -> Solution:
        return Solution(problem)


class Registers:
    """A plugin registering an ``Echo`` solver under each of the given names."""

    def __init__(self, *solvers: str) -> None:
        self.solvers = solvers

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        for name in self.solvers:
            registry.add("solver", name, Echo)


class Raising:
    """A plugin that registers a solver and then fails."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("solver", "half_registered", Echo)
        raise RuntimeError("no licence found")


def _names(plugins: Plugins) -> list[str]:
    return [p.name for p in plugins.loaded]


def _components(plugins: Plugins) -> set[str]:
    return {f"{c.kind}:{c.name}:{c.plugin}" for c in plugins.registry}


# -- plugins given in code ------------------------------------------------------------------


def test_plugins_load_in_order_with_their_hooks_and_components() -> None:
    plugins = load_plugins([("a", Registers("one", "two")), ("toy", toy_domain)],
                           entry_points=False, environ={})

    assert _names(plugins) == ["a", "toy"]
    first = plugins.info("a")
    assert first.module == "Registers"
    assert (first.distribution, first.version) == (None, None)
    assert first.hooks == ("cbr_register", "cbr_solve")
    assert first.components == ("solver:one", "solver:two")
    toy = plugins.info("toy")
    assert toy.module == "toy_domain"
    assert toy.hooks == ("cbr_forget", "cbr_register", "cbr_retain", "cbr_retrieve",
                         "cbr_reuse", "cbr_revise", "cbr_solve")
    assert plugins.failed == [] and plugins.skipped == []


def test_a_plugin_whose_register_raises_is_reported_and_the_rest_load() -> None:
    with pytest.warns(UserWarning, match="plugin 'bad' failed to register: RuntimeError"):
        plugins = load_plugins([("a", Registers("one")), ("bad", Raising()),
                                ("c", Registers("three"))], entry_points=False, environ={})

    assert _names(plugins) == ["a", "c"]
    [failure] = plugins.failed
    assert (failure.name, failure.stage, failure.distribution) == ("bad", "register", None)
    assert failure.error == "RuntimeError: no licence found"
    # what it registered before raising is withdrawn, and its hooks are gone
    assert _components(plugins) == {"solver:one:a", "solver:three:c"}
    assert plugins.pm.get_plugin("bad") is None


def test_a_plugin_with_an_invalid_hook_fails_to_import() -> None:
    class WrongArguments:
        @hookimpl
        def cbr_register(self, registry: Registry, unexpected: int) -> None:
            """Declares an argument the hookspec does not have."""

    with pytest.warns(UserWarning, match="plugin 'wrong' failed to import"):
        plugins = load_plugins([("wrong", WrongArguments()), ("a", Registers("one"))],
                               entry_points=False, environ={})

    assert _names(plugins) == ["a"]
    [failure] = plugins.failed
    assert (failure.name, failure.stage) == ("wrong", "import")
    assert "unexpected" in failure.error


@pytest.mark.parametrize("flag", ["1", "yes"])
def test_strict_plugins_make_a_failure_fatal(flag: str) -> None:
    with pytest.raises(PluginError, match=r"^plugin 'bad' failed to register: RuntimeError: "
                                          r"no licence found$"):
        load_plugins([("a", Registers("one")), ("bad", Raising())], entry_points=False,
                     environ={"CBR_STRICT_PLUGINS": flag})


def test_strict_zero_is_not_strict() -> None:
    with pytest.warns(UserWarning):
        plugins = load_plugins([("bad", Raising())], entry_points=False,
                               environ={"CBR_STRICT_PLUGINS": "0"})
    assert [f.name for f in plugins.failed] == ["bad"]


def test_allow_list_loads_only_the_named_plugins() -> None:
    plugins = load_plugins([("a", Registers("one")), ("b", Registers("two")),
                            ("c", Registers("three"))], entry_points=False,
                           environ={"CBR_PLUGINS": " a , c "})
    assert _names(plugins) == ["a", "c"]
    assert plugins.skipped == ["b"]
    assert _components(plugins) == {"solver:one:a", "solver:three:c"}


def test_block_list_skips_the_named_plugins_even_when_allowed() -> None:
    plugins = load_plugins([("a", Registers("one")), ("b", Registers("two")),
                            ("c", Registers("three"))], entry_points=False,
                           environ={"CBR_PLUGINS": "a,b", "CBR_DISABLE_PLUGINS": "b"})
    assert _names(plugins) == ["a"]
    assert plugins.skipped == ["b", "c"]


def test_a_skipped_plugin_is_never_registered() -> None:
    plugins = load_plugins([("bad", Raising()), ("a", Registers("one"))], entry_points=False,
                           environ={"CBR_DISABLE_PLUGINS": "bad"})
    assert plugins.failed == []
    assert _names(plugins) == ["a"]


def test_a_duplicate_component_name_fails_the_second_plugin() -> None:
    with pytest.warns(UserWarning, match="plugin 'b' failed to register"):
        plugins = load_plugins([("a", Registers("echo")), ("b", Registers("other", "echo"))],
                               entry_points=False, environ={})

    assert _names(plugins) == ["a"]
    [failure] = plugins.failed
    assert (failure.name, failure.stage) == ("b", "register")
    assert failure.error == "PluginError: solver 'echo' is already registered by plugin 'a'"
    assert _components(plugins) == {"solver:echo:a"}


def test_a_plugin_name_taken_twice_fails_the_second() -> None:
    with pytest.warns(UserWarning, match="plugin 'a' failed to load"):
        plugins = load_plugins([("a", Registers("one")), ("a", Registers("two"))],
                               entry_points=False, environ={})

    assert _names(plugins) == ["a"]
    assert plugins.info("a").components == ("solver:one",)
    [failure] = plugins.failed
    assert (failure.name, failure.stage) == ("a", "load")
    assert failure.error == "the plugin name is already taken by a plugin registered in code"


# -- hook names -----------------------------------------------------------------------------


def _module(name: str, **functions: Callable[..., Any]) -> types.ModuleType:
    module = types.ModuleType(name)
    for attribute, function in functions.items():
        setattr(module, attribute, function)
    return module


@hookimpl
def _marked(registry: Registry) -> None:
    """A hook implementation, bound below to misspelt names."""


def _unmarked(registry: Registry) -> None:
    """A plugin hook without its ``@hookimpl``."""


class Specnamed:
    """Implements cbr_solve under another attribute name, as pluggy allows."""

    @hookimpl(specname="cbr_solve")
    def solve(self, problem: Any) -> Solution:
        return Solution(problem)


class Misspelt:
    """A component whose retrieve hook is misspelt."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_retreive(self, problem: Any) -> None:
        """Never called."""


@pytest.mark.parametrize(("plugin", "message"), [
    (_module("typo", cbr_registr=_marked),
     "cbr_registr is marked with @hookimpl but names no cbrcore hook; did you mean cbr_register?"),
    (_module("forgot", cbr_register=_unmarked),
     "cbr_register is not marked with @hookimpl, so it is never called"),
    (_module("far", cbr_teleport=_marked),
     f"cbr_teleport is marked with @hookimpl but names no cbrcore hook; the hooks: "
     f"{', '.join(HOOKS)}"),
    (Misspelt,
     "cbr_retreive is marked with @hookimpl but names no cbrcore hook; did you mean cbr_retrieve?"),
])
def test_unknown_hooks_names_the_attribute_and_the_closest_hook(plugin: Any,
                                                                message: str) -> None:
    assert unknown_hooks(plugin) == [message]


def test_unknown_hooks_follows_specname() -> None:
    class Renamed:
        @hookimpl(specname="cbr_retreive")
        def retrieve(self) -> None:
            """Never called."""

    assert unknown_hooks(Renamed()) == [
        "retrieve is marked with @hookimpl(specname='cbr_retreive') but names no cbrcore hook; "
        "did you mean cbr_retrieve?"]
    assert unknown_hooks(Specnamed) == []
    assert implemented_hooks(Specnamed()) == ("cbr_solve",)


def test_well_formed_plugins_and_components_have_no_unknown_hooks() -> None:
    assert unknown_hooks(toy_domain) == []
    assert unknown_hooks(cbr_observers) == []
    assert unknown_hooks(Registers("one")) == []
    assert unknown_hooks(Echo(None, None)) == []  # type: ignore[arg-type]


def test_a_plugin_with_a_misspelt_hook_fails_to_load() -> None:
    typo = _module("typo", cbr_registr=_marked, cbr_cli=_unmarked)
    with pytest.warns(UserWarning, match="plugin 'typo' failed to load: cbr_cli is not marked"):
        plugins = load_plugins([("typo", typo), ("a", Registers("one"))], entry_points=False,
                               environ={})

    assert _names(plugins) == ["a"]
    [failure] = plugins.failed
    assert (failure.name, failure.stage) == ("typo", "load")
    assert failure.error == ("cbr_cli is not marked with @hookimpl, so it is never called; "
                             "cbr_registr is marked with @hookimpl but names no cbrcore hook; "
                             "did you mean cbr_register?")
    assert plugins.pm.get_plugin("typo") is None


def test_a_misspelt_hook_is_fatal_when_strict() -> None:
    with pytest.raises(PluginError, match=r"^plugin 'typo' failed to load: cbr_registr is marked "
                                          r"with @hookimpl but names no cbrcore hook; did you "
                                          r"mean cbr_register\?$"):
        load_plugins([("typo", _module("typo", cbr_registr=_marked))], entry_points=False,
                     environ={"CBR_STRICT_PLUGINS": "1"})


def test_a_component_class_with_a_misspelt_hook_is_refused_at_registration() -> None:
    class Plugin:
        @hookimpl
        def cbr_register(self, registry: Registry) -> None:
            registry.add("retriever", "greedy", Misspelt)

    with pytest.warns(UserWarning, match="plugin 'demo' failed to register"):
        plugins = load_plugins([("demo", Plugin())], entry_points=False, environ={})
    [failure] = plugins.failed
    assert failure.error == ("PluginError: retriever 'greedy': cbr_retreive is marked with "
                             "@hookimpl but names no cbrcore hook; did you mean cbr_retrieve?")


def test_a_component_implementing_a_hook_under_a_specname_runs(
        cbr_plugins: Callable[..., Plugins], cbr_engine: Callable[..., Engine]) -> None:
    class Plugin:
        @hookimpl
        def cbr_register(self, registry: Registry) -> None:
            registry.add("solver", "specnamed", lambda options, ctx: Specnamed())

    cbr_plugins(("specnamed", Plugin()), ("core", cbrcore.builtins), ("stores", cbr_stores))
    assert cbr_engine("solver: specnamed\n").solve(4).solution == Solution(4)


# -- installed entry points -----------------------------------------------------------------


def _dist_info(site: Path, name: str, version: str, entry_points: str) -> None:
    info = site / f"{name.replace('-', '_')}-{version}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n",
                                   encoding="utf-8")
    (info / "entry_points.txt").write_text(f"[cbr]\n{entry_points}\n", encoding="utf-8")


@pytest.fixture
def broken_site(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """Two installed distributions with broken ``cbr`` plugins on ``sys.path``.

    ``missing`` (cbr-missing 1.0) points at a module that does not exist; ``raising``
    (cbr-raising 2.0) is importable but its ``cbr_register`` raises.
    """
    site = tmp_path / "site"
    site.mkdir()
    _dist_info(site, "cbr-missing", "1.0", "missing = cbr_test_no_such_module")
    _dist_info(site, "cbr-raising", "2.0", f"raising = {RAISING_MODULE}")
    (site / f"{RAISING_MODULE}.py").write_text(
        "from cbrcore import hookimpl\n\n\n"
        "@hookimpl\n"
        "def cbr_register(registry):\n"
        "    raise ValueError('cannot find the robot')\n",
        encoding="utf-8")
    monkeypatch.syspath_prepend(str(site))
    yield site
    sys.modules.pop(RAISING_MODULE, None)


def test_builtin_plugins_load_from_the_installed_entry_points() -> None:
    plugins = load_plugins(environ={})

    assert plugins.failed == []
    core = plugins.info("core")
    assert (core.module, core.distribution, core.version) == (
        "cbrcore.builtins", "cbrcore", CBRCORE_VERSION)
    assert "store:memory" in core.components
    stores = plugins.info("stores")
    assert (stores.module, stores.distribution) == ("cbr_stores", "cbrcore")
    assert {"store:sqlite", "store:postgres"} <= set(stores.components)
    observers = plugins.info("observers")
    assert (observers.module, observers.distribution) == ("cbr_observers", "cbrcore")
    assert "observer:trace" in observers.components
    # the trace observer wraps every phase hook
    assert observers.hooks == ("cbr_forget", "cbr_register", "cbr_retain", "cbr_retrieve",
                               "cbr_reuse", "cbr_revise", "cbr_solve")


def test_broken_entry_points_are_reported_with_their_distribution(broken_site: Path) -> None:
    with pytest.warns(UserWarning) as warned:
        plugins = load_plugins(environ={})

    assert {"core", "observers"} <= set(_names(plugins))
    assert not {"missing", "raising"} & set(_names(plugins))
    failed = {f.name: f for f in plugins.failed}
    assert set(failed) == {"missing", "raising"}
    missing = failed["missing"]
    assert (missing.distribution, missing.version, missing.stage) == (
        "cbr-missing", "1.0", "import")
    assert missing.error == "ModuleNotFoundError: No module named 'cbr_test_no_such_module'"
    raising = failed["raising"]
    assert (raising.distribution, raising.version, raising.stage) == (
        "cbr-raising", "2.0", "register")
    assert raising.error == "ValueError: cannot find the robot"
    messages = {str(w.message) for w in warned}
    assert ("plugin 'missing' from cbr-missing 1.0 failed to import: ModuleNotFoundError: "
            "No module named 'cbr_test_no_such_module'") in messages
    assert ("plugin 'raising' from cbr-raising 2.0 failed to register: ValueError: "
            "cannot find the robot") in messages


def test_strict_entry_point_failure_names_plugin_and_distribution(broken_site: Path) -> None:
    # entry points load in name order, so 'missing' is the first failure
    with pytest.raises(PluginError, match=r"^plugin 'missing' from cbr-missing 1\.0 failed to "
                                          r"import: ModuleNotFoundError"):
        load_plugins(environ={"CBR_STRICT_PLUGINS": "1"})


def test_allow_list_avoids_importing_broken_entry_points(broken_site: Path) -> None:
    plugins = load_plugins(environ={"CBR_PLUGINS": "observers"})
    assert _names(plugins) == ["observers"]
    assert plugins.failed == []
    assert {"core", "missing", "raising"} <= set(plugins.skipped)
    assert RAISING_MODULE not in sys.modules


def test_block_list_disables_broken_entry_points(broken_site: Path) -> None:
    plugins = load_plugins(environ={"CBR_DISABLE_PLUGINS": "missing,raising"})
    assert plugins.failed == []
    assert {"core", "observers"} <= set(_names(plugins))
    assert plugins.skipped == ["missing", "raising"]


def test_a_code_plugin_cannot_take_an_entry_point_name() -> None:
    with pytest.warns(UserWarning, match="plugin 'core' failed to load"):
        plugins = load_plugins([("core", Registers("one"))], environ={})
    assert plugins.info("core").module == "cbrcore.builtins"
    [failure] = plugins.failed
    assert failure.error == "the plugin name is already taken by cbrcore"


def test_an_installed_plugin_passed_in_code_too_loads_once() -> None:
    """A plugin's own tests may pass its installed module in code: it keeps its entry point
    name and registers its components once, with no failure."""
    import cbrcore.builtins

    plugins = load_plugins([("mine", cbrcore.builtins)], environ={})

    assert plugins.failed == []
    assert [p.name for p in plugins.loaded].count("core") == 1
    assert "mine" not in [p.name for p in plugins.loaded]
    assert [c.name for c in plugins.registry if c.kind == "store"] == ["memory", "postgres",
                                                                        "sqlite"]


def test_a_code_plugin_cannot_take_a_builtin_component_name() -> None:
    class Store:
        @hookimpl
        def cbr_register(self, registry: Registry) -> None:
            registry.add("store", "memory", Echo)

    with pytest.warns(UserWarning, match="plugin 'shadow' failed to register"):
        plugins = load_plugins([("shadow", Store())], environ={})
    [failure] = plugins.failed
    assert failure.error == "PluginError: store 'memory' is already registered by plugin 'core'"
    assert plugins.registry.get("store", "memory").plugin == "core"


# -- what the command line shows ------------------------------------------------------------


def test_cli_plugins_json_lists_loaded_and_failed(
        cbr_plugins: Callable[..., Plugins], invoke_cbr: Callable[..., CliResult]) -> None:
    with pytest.warns(UserWarning):
        cbr_plugins(("good", Registers("one")), ("bad", Raising()))

    result = invoke_cbr("plugins", "--json")

    assert result.exit_code == 0
    assert json.loads(result.stdout) == {
        "plugins": [{"name": "good", "module": "Registers", "distribution": None,
                     "version": None, "hooks": ["cbr_register", "cbr_solve"],
                     "components": ["solver:one"], "kinds": []}],
        "failed": [{"name": "bad", "distribution": None, "version": None, "stage": "register",
                    "error": "RuntimeError: no licence found"}],
        "skipped": [],
    }


def test_cli_plugins_lists_broken_entry_points(
        broken_site: Path, cbr_plugins: Callable[..., Plugins],
        invoke_cbr: Callable[..., CliResult]) -> None:
    with pytest.warns(UserWarning):
        cbr_plugins(entry_points=True, environ={"CBR_DISABLE_PLUGINS": "observers"})

    data = json.loads(invoke_cbr("plugins", "--json").stdout)
    broken = {"observers", "missing", "raising"}
    assert [p["name"] for p in data["plugins"]] == [
        n for n in installed_plugins() if n not in broken]
    assert data["skipped"] == ["observers"]
    assert {(f["name"], f["distribution"], f["version"], f["stage"]) for f in data["failed"]} == {
        ("missing", "cbr-missing", "1.0", "import"), ("raising", "cbr-raising", "2.0", "register")}

    table = invoke_cbr("plugins")
    assert table.exit_code == 0
    assert ("failed: plugin 'raising' from cbr-raising 2.0 failed to register: ValueError: "
            "cannot find the robot") in table.stdout
    assert "skipped by CBR_PLUGINS / CBR_DISABLE_PLUGINS: observers" in table.stdout


# -- the testing kit ------------------------------------------------------------------------


def test_cbr_plugins_names_modules_and_makes_them_current(
        cbr_plugins: Callable[..., Plugins]) -> None:
    plugins = cbr_plugins(toy_domain, ("watch", cbr_observers))

    assert _names(plugins) == ["toy_domain", "watch"]
    assert current() is plugins
    again = cbr_plugins(toy_domain, entry_points=True)
    assert current() is again
    assert _names(again) == [*sorted(installed_plugins()), "toy_domain"]


def test_cbr_plugins_needs_a_name_for_objects_without_one(
        cbr_plugins: Callable[..., Plugins]) -> None:
    with pytest.raises(TypeError, match=r"pass a \(name, plugin\) pair"):
        cbr_plugins(Registers("one"))


@attrs.define
class Closing:
    """A solver that records when it is closed."""

    log: list[str]

    @hookimpl
    def cbr_solve(self, problem: Any) -> Solution:
        return Solution(problem)

    def close(self) -> None:
        self.log.append("closed")


@pytest.fixture
def close_log() -> Iterator[list[str]]:
    """A log of closed components, checked after the test's other fixtures are torn down."""
    log: list[str] = []
    yield log
    assert log == ["closed"]


def test_cbr_engine_closes_its_engines(close_log: list[str], cbr_plugins: Callable[..., Plugins],
                                       cbr_engine: Callable[..., Engine]) -> None:
    class Plugin:
        @hookimpl
        def cbr_register(self, registry: Registry) -> None:
            registry.add("solver", "closing", lambda options, ctx: Closing(close_log))

    cbr_plugins(("closing", Plugin()), entry_points=True)
    engine = cbr_engine("solver: closing\n")
    assert engine.solve(5).solution == Solution(5)
    assert close_log == []


@pytest.mark.usefixtures("toy_plugins")
def test_cbr_engine_reads_text_mappings_and_files_alike(
        cbr_engine: Callable[..., Engine], toy_config: Path) -> None:
    import yaml

    engines = [cbr_engine(toy_domain.TOY_CONFIG, overrides=["retrieve.radius=2"]),
               cbr_engine(yaml.safe_load(toy_domain.TOY_CONFIG), overrides=["retrieve.radius=2"]),
               cbr_engine(toy_config, overrides=["retrieve.radius=2"])]

    resolved = [engine.config.resolved() for engine in engines]
    assert resolved[0] == resolved[1] == resolved[2]
    assert resolved[0]["retrieve"] == {"use": "nearest", "radius": 2}
    assert resolved[0]["seed"] == 3


@pytest.mark.usefixtures("toy_plugins")
def test_cbr_engine_reports_problems_with_line_and_column(
        cbr_engine: Callable[..., Engine]) -> None:
    with pytest.raises(ConfigError) as raised:
        cbr_engine("seed: 1\nretrieve: {use: nearest, radius: -1}\n")
    assert raised.value.problems == ["retrieve.radius (line 2, column 34): must be >= 0: -1"]


def test_entry_points_load_after_the_importlib_metadata_backport_took_over() -> None:
    # dask imports the backport, after which importlib.metadata hands out the backport's entry
    # point objects; the plugins must load all the same
    script = ("import json, importlib_metadata\n"
              "from importlib import metadata\n"
              "from cbrcore.plugins import load_plugins\n"
              "plugins = load_plugins(environ={})\n"
              "print(json.dumps({'kinds': sorted({type(ep).__module__ for ep in "
              "metadata.entry_points(group='cbr')}), 'loaded': sorted(p.name for p in "
              "plugins.loaded), 'grid': len(plugins.registry.by_plugin('grid'))}))\n")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=120, check=True)
    seen = json.loads(done.stdout)
    assert seen["kinds"] == ["importlib_metadata"]
    assert {"core", "grid", "solvers"} <= set(seen["loaded"])
    assert seen["grid"] > 0
