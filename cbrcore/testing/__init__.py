"""The testing kit for plugin authors: a pytest plugin with three fixtures, and the store contract.

Installing cbrcore makes these fixtures available to every pytest run (through the ``pytest11``
entry point), so a plugin's own test suite can use them without any import:

``cbr_plugins``
    Load plugin modules (or their names) for the duration of one test, without installing them.
``cbr_engine``
    Build an :class:`~cbrcore.engine.Engine` from YAML text, a mapping or a file; closed after
    the test.
``invoke_cbr``
    Run the ``cbr`` command line in-process and capture its exit code, stdout and stderr.

A typical test::

    def test_my_retriever(cbr_plugins, cbr_engine):
        cbr_plugins("my_plugin", entry_points=True)
        engine = cbr_engine("retrieve: {use: my_retriever, k: 2}\\nsolver: my_solver\\n")
        proposal = engine.solve(problem)
        ...

A plugin that registers a store runs the tests of the store protocol by subclassing
:class:`StoreContract` (see :mod:`cbrcore.testing.stores`)::

    from cbrcore.testing import StoreContract

    class TestMyStore(StoreContract):
        persistent = True   # adds the tests of a store that keeps its commits when reopened

        @pytest.fixture
        def open_store(self, tmp_path):
            return lambda name: MyStore(tmp_path / name)

Module-level imports stay light: pytest imports this module in every test session of an
environment where cbrcore is installed.
"""

from __future__ import annotations

import contextlib
import importlib
import io
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import pytest

# registered before the import, so a failing contract test explains its assertion
pytest.register_assert_rewrite("cbrcore.testing.stores", "cbrcore.testing._agree")

from cbrcore.testing.stores import StoreContract  # noqa: E402

if TYPE_CHECKING:
    from cbrcore.config import Config, Overrides
    from cbrcore.engine import Engine
    from cbrcore.plugins import Plugins
    from cbrcore.registry import Registry

__all__ = ["CliResult", "StoreContract", "cbr_engine", "cbr_plugins", "invoke_cbr"]


class CliResult(NamedTuple):
    """What one in-process ``cbr`` invocation produced."""

    exit_code: int
    stdout: str
    stderr: str


def _plugin_pair(plugin: Any) -> tuple[str, Any]:
    if isinstance(plugin, tuple):
        name, obj = plugin
        return str(name), _module(obj) if isinstance(obj, str) else obj
    if isinstance(plugin, str):
        return plugin, _module(plugin)
    name = getattr(plugin, "__name__", None)
    if not isinstance(name, str):
        raise TypeError(f"cannot name plugin {plugin!r}: pass a (name, plugin) pair")
    return name, plugin


def _module(name: str) -> Any:
    """The module called ``name``, imported; a clear error when it cannot be."""
    from cbrcore.errors import CbrError

    try:
        return importlib.import_module(name)
    except ImportError as exc:
        raise CbrError(f"cbr_plugins({name!r}): cannot import the plugin module {name!r}: "
                       f"{type(exc).__name__}: {exc}; expected the dotted name of an importable "
                       f"module (on sys.path), such as 'my_plugin' or 'my_package.plugin'"
                       ) from exc


@pytest.fixture
def cbr_plugins() -> Iterator[Callable[..., Plugins]]:
    """Temporarily register plugins: ``cbr_plugins(*plugins, entry_points=False, environ=None)``.

    Each plugin is a module or object implementing cbrcore hooks, named by its ``__name__``; a
    module's dotted name (``"my_plugin"``), imported with :func:`importlib.import_module` and
    named by that string; or a ``(name, plugin)`` pair to choose the name (and to name objects
    without ``__name__``, such as class instances), whose plugin may be a module name too. A
    name that cannot be imported raises :class:`~cbrcore.errors.CbrError` naming it. The
    plugins are loaded with :func:`cbrcore.plugins.load_plugins` and made current with
    :func:`cbrcore.plugins.use_plugins` until the test ends, so
    :func:`cbrcore.plugins.current`, :meth:`Engine.from_yaml <cbrcore.engine.Engine.from_yaml>`,
    the ``cbr_engine`` fixture and the ``invoke_cbr`` fixture all see them.

    ``entry_points=True`` loads the installed plugins of the ``cbr`` entry point group as well
    (cbrcore's own ``core`` and ``observers`` are declared there). ``environ`` replaces
    ``os.environ`` as the source of ``CBR_PLUGINS``, ``CBR_DISABLE_PLUGINS`` and
    ``CBR_STRICT_PLUGINS``. A plugin that fails to load is reported in the returned
    :class:`~cbrcore.plugins.Plugins`' ``failed`` list (with a warning) while the others load,
    exactly as in the command line.

    Returns the loaded :class:`~cbrcore.plugins.Plugins`. Calling the fixture again within the
    same test makes the new set current until the test ends.
    """
    from cbrcore.plugins import load_plugins, use_plugins

    with contextlib.ExitStack() as stack:

        def register(*plugins: Any, entry_points: bool = False,
                     environ: Mapping[str, str] | None = None) -> Plugins:
            loaded = load_plugins([_plugin_pair(p) for p in plugins], entry_points=entry_points,
                                  environ=environ)
            return stack.enter_context(use_plugins(loaded))

        yield register


def _parse(config: str, overrides: Overrides, registry: Registry) -> Config:
    from cbrcore.config import config_from_text

    return config_from_text(config, registry, overrides)


@pytest.fixture
def cbr_engine() -> Iterator[Callable[..., Engine]]:
    """Build engines: ``cbr_engine(config, *, world=None, plugins=None, out_dir=None,
    overrides=()) -> Engine``.

    ``config`` is YAML text, a mapping of the same shape, or a :class:`~pathlib.Path` to a YAML
    file. Text and mappings are checked by :func:`cbrcore.config.parse_config` against the
    registry of ``plugins`` (default: the current plugins, see ``cbr_plugins``), with relative
    ``Path`` options resolved against the working directory; a mapping goes through
    :meth:`Engine.from_dict <cbrcore.engine.Engine.from_dict>` (which copies it) and a path
    through :meth:`Engine.from_yaml <cbrcore.engine.Engine.from_yaml>`, resolving them against
    the file's folder. ``overrides`` are ``KEY.PATH=VALUE`` strings as given to
    ``cbr run --set``, or a mapping of ``KEY.PATH`` to Python values. ``world`` is a world
    object replacing the configured world (a NumPy array or a grid, with the grid plugin).
    ``out_dir`` is the engine's output folder (None: an embedded engine without one). A bad
    configuration raises :class:`~cbrcore.errors.ConfigError`.

    Every engine built is closed when the test ends.
    """
    from cbrcore.engine import Engine
    from cbrcore.plugins import current

    engines: list[Engine] = []

    def build(config: str | Mapping[str, Any] | Path, *, world: Any = None,
              plugins: Plugins | None = None, out_dir: Path | None = None,
              overrides: Overrides = ()) -> Engine:
        plugins = plugins or current()
        if isinstance(config, Path):
            engine = Engine.from_yaml(config, world=world, overrides=overrides, plugins=plugins,
                                      out_dir=out_dir)
        elif isinstance(config, Mapping):
            engine = Engine.from_dict(config, world=world, overrides=overrides, plugins=plugins,
                                      out_dir=out_dir)
        else:
            parsed = _parse(config, overrides, plugins.registry)
            engine = Engine(parsed, world=world, plugins=plugins, out_dir=out_dir)
        engines.append(engine)
        return engine

    yield build
    for engine in reversed(engines):
        engine.close()


@pytest.fixture
def invoke_cbr() -> Callable[..., CliResult]:
    """Run the command line in-process: ``invoke_cbr(*args) -> CliResult(exit_code, stdout,
    stderr)``.

    Calls :func:`cbrcore.cli.main` with ``args`` (without the leading ``cbr``) while
    ``sys.stdout`` and ``sys.stderr`` are captured separately, and returns the exit code the
    ``cbr`` console script would exit with: 0 on success, 2 for a user error (bad configuration,
    unknown component, failing plugin, bad usage). The command line sees the current plugins, so
    plugins registered with ``cbr_plugins`` (including their ``cbr_cli`` commands) take part. An
    unexpected exception (a bug rather than a user error) propagates to the test.
    """
    from cbrcore.cli import main

    def invoke(*args: str) -> CliResult:
        stdout, stderr = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            try:
                code = main(list(args))
            except SystemExit as exc:  # a plugin command may leave through sys.exit
                if exc.code is None or isinstance(exc.code, int):
                    code = exc.code or 0
                else:
                    print(exc.code, file=stderr)
                    code = 1
        return CliResult(code, stdout.getvalue(), stderr.getvalue())

    return invoke
