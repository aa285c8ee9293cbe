"""Components registered by name (``"package.module:Attribute"``): imported when first used,
checked then as a given class is at registration, and documented without being imported."""

from __future__ import annotations

import inspect
import sys
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

import cbrcore.builtins
import closed_loop_domain
from cbrcore import hookimpl
from cbrcore.errors import PluginWarning
from cbrcore.plugins import Plugins
from cbrcore.registry import Registry
from cbrcore.testing import CliResult

PACKAGE = "cbr_test_named"
MARKER = "TOPSECRET"

SOLVERS = f'''\
import attrs
from cbrcore import Solution, hookimpl
from cbrcore.options import option, reference

# {MARKER}: never quoted


@attrs.frozen
class OffsetOptions:
    extra: int = option(1, "Units added to the obstacle's size.")


class Offset:
    """Swerve by the obstacle's size plus ``extra``.

    Read from here without importing the module.
    """

    def __init__(self, options, ctx):
        self.extra = options.extra

    @hookimpl
    def cbr_warm(self, ctx):
        pass

    @hookimpl
    def cbr_solve(self, problem):
        return Solution(problem["size"] + self.extra, cost=1.0)


class NotOptions:
    pass


class Misspelt:
    def __init__(self, options, ctx):
        pass

    @hookimpl
    def cbr_solv(self, problem):
        return None


@attrs.frozen
class GripperOptions:
    gripper: str = reference("gripper", "claw", "The gripper.")
'''

BROKEN = f"x = = 1  # {MARKER}\n"


@pytest.fixture
def named(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A package ``cbr_test_named`` of solver classes on the path, not imported yet."""
    package = tmp_path / "site" / PACKAGE
    package.mkdir(parents=True)
    (package / "__init__.py").write_text("", encoding="utf-8")
    (package / "solvers.py").write_text(SOLVERS, encoding="utf-8")
    (package / "broken.py").write_text(BROKEN, encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    yield tmp_path
    for name in [name for name in sys.modules if name.split(".")[0] == PACKAGE]:
        del sys.modules[name]


class NamedPlugin:
    """Registers the solver ``offset`` by name, with the given factory and options."""

    def __init__(self, factory: str = f"{PACKAGE}.solvers:Offset",
                 options: str = f"{PACKAGE}.solvers:OffsetOptions") -> None:
        self.factory = factory
        self.options = options

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("solver", "offset", self.factory, options=self.options)


def _load(cbr_plugins: Callable[..., Plugins], plugin: NamedPlugin) -> Plugins:
    return cbr_plugins(("lane", closed_loop_domain), ("core", cbrcore.builtins),
                       ("named", plugin))


def _config(folder: Path) -> Path:
    path = folder / "lane.yaml"
    path.write_text(closed_loop_domain.LANE_CONFIG.replace("solver: margin",
                                                           "solver: {use: offset}"),
                    encoding="utf-8")
    return path


def test_a_named_component_is_imported_when_a_configuration_uses_it(
        named: Path, cbr_plugins: Callable[..., Plugins],
        invoke_cbr: Callable[..., CliResult]) -> None:
    plugins = _load(cbr_plugins, NamedPlugin())
    assert f"{PACKAGE}.solvers" not in sys.modules
    assert "solver:offset" in plugins.info("named").components

    done = invoke_cbr("run", str(_config(named)), "--out", str(named / "run"))

    assert done.exit_code == 0, done.stderr
    assert f"{PACKAGE}.solvers" in sys.modules
    component = plugins.registry.get("solver", "offset")
    assert component.factory is sys.modules[f"{PACKAGE}.solvers"].Offset
    assert dict(component.references) == {}
    # the lane's obstacles are swerved by their size plus the default extra unit
    assert "answered by the fallback solver" in done.stdout


def test_its_doc_is_read_from_the_source_without_importing_it(
        named: Path, cbr_plugins: Callable[..., Plugins]) -> None:
    plugins = _load(cbr_plugins, NamedPlugin())
    component = plugins.registry.get("solver", "offset")

    read = component.doc

    assert f"{PACKAGE}.solvers" not in sys.modules
    assert component.summary == "Swerve by the obstacle's size plus ``extra``."
    assert read == inspect.getdoc(component.factory)


def test_its_hooks_are_listed_once_it_is_imported(
        named: Path, cbr_plugins: Callable[..., Plugins]) -> None:
    plugins = _load(cbr_plugins, NamedPlugin())
    assert set(plugins.info("named").hooks) == {"cbr_register", "cbr_solve", "cbr_warm"}


@pytest.mark.parametrize(("case", "plugin", "expected"), [
    ("missing module", NamedPlugin(factory=f"{PACKAGE}.nowhere:Offset"),
     f"cannot import '{PACKAGE}.nowhere:Offset': ModuleNotFoundError"),
    ("missing attribute", NamedPlugin(factory=f"{PACKAGE}.solvers:Ofset"),
     f"cannot import '{PACKAGE}.solvers:Ofset': AttributeError"),
    ("module with a syntax error", NamedPlugin(factory=f"{PACKAGE}.broken:Offset"),
     f"cannot import '{PACKAGE}.broken:Offset': SyntaxError"),
    ("options not an attrs class", NamedPlugin(options=f"{PACKAGE}.solvers:NotOptions"),
     "options must be an attrs class"),
    ("misspelt hook", NamedPlugin(factory=f"{PACKAGE}.solvers:Misspelt"),
     "cbr_solv is marked with @hookimpl but names no cbrcore hook; did you mean cbr_solve?"),
    ("reference to an undeclared kind", NamedPlugin(options=f"{PACKAGE}.solvers:GripperOptions"),
     "option 'gripper' refers to kind 'gripper', which no plugin declares"),
])
def test_a_broken_named_component_fails_when_used_naming_its_plugin(
        named: Path, cbr_plugins: Callable[..., Plugins], invoke_cbr: Callable[..., CliResult],
        case: str, plugin: NamedPlugin, expected: str) -> None:
    _load(cbr_plugins, plugin)

    done = invoke_cbr("validate", str(_config(named)))

    assert done.exit_code == 2, case
    assert "plugin 'named': solver 'offset': " in done.stderr, done.stderr
    assert expected in done.stderr, done.stderr
    assert "Traceback" not in done.stderr
    assert MARKER not in done.stdout + done.stderr


@pytest.mark.parametrize("written", ["cbr_test_named.solvers.Offset", "cbr_test_named:",
                                     ":Offset", "cbr test:Offset"])
def test_a_malformed_name_fails_its_plugin_at_registration(
        named: Path, cbr_plugins: Callable[..., Plugins], written: str) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        plugins = _load(cbr_plugins, NamedPlugin(factory=written))

    assert "named" not in [p.name for p in plugins.loaded]
    messages = [str(w.message) for w in caught if issubclass(w.category, PluginWarning)]
    assert any(f"a named factory is written 'package.module:Attribute', got {written!r}" in m
               for m in messages), messages
