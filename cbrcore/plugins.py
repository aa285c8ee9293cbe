"""Finding, loading and listing plugins.

Plugins are found through the ``cbr`` entry point group; cbrcore's own built-ins are declared
there too, so they are found exactly as a third party's are. A plugin that fails to import or
register is reported and skipped while the others load, unless ``CBR_STRICT_PLUGINS=1``. Whatever
it raises counts as its failure, ``SystemExit`` included, except ``KeyboardInterrupt``: the user
stopping the program.

The built-in plugins, those the ``cbrcore`` distribution declares (:func:`builtin_plugins`),
register first, then the other distributions' in entry point name order, then those given in
code. So the built-ins claim their plugin names, component names and kinds before any other
plugin can: a plugin taking one fails, named as the culprit, whatever the names' order. A
component kind may be declared by a plugin that loads after one registering components of it,
so kinds are checked once all have registered: a plugin whose components or options use a kind
nobody declared fails then, and with it whatever relied on the kinds it declared.

A failure is reported with a :class:`~cbrcore.errors.PluginWarning`, which the ``cbr`` command
line prints as one ``warning:`` line.

A hook implementation that names no cbrcore hook (``cbr_registr``), or a function named like a
hook but left without ``@hookimpl``, fails its plugin when it loads;
:func:`cbrcore.hookimpls.unknown_hooks` says which and suggests the closest hook.

Environment variables:

``CBR_PLUGINS``
    Comma-separated entry point names: when set, only these plugins load (an allow-list).
``CBR_DISABLE_PLUGINS``
    Comma-separated entry point names that never load (a block-list).
``CBR_STRICT_PLUGINS``
    ``1`` makes any plugin failure fatal (a :class:`~cbrcore.errors.PluginError`).
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import types
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence, Set
from importlib import metadata
from typing import Any

import attrs
import pluggy

from cbrcore import hookspecs
from cbrcore.errors import PluginError, PluginWarning
from cbrcore.hookimpls import implemented_hooks, unknown_hooks
from cbrcore.registry import KIND_HOOK, Component, Registry

ENTRY_POINT_GROUP = "cbr"
BUILTIN_DISTRIBUTION = "cbrcore"

Source = tuple[str | None, str | None]
"""The distribution and version a plugin comes from; (None, None) for one given in code."""


def new_plugin_manager() -> pluggy.PluginManager:
    """A plugin manager that knows cbrcore's hook specifications."""
    pm = pluggy.PluginManager(hookspecs.PROJECT)
    pm.add_hookspecs(hookspecs)
    return pm


@attrs.frozen
class PluginInfo:
    """A loaded plugin: where it comes from and what it provides."""

    name: str
    module: str
    distribution: str | None
    version: str | None
    components: tuple[str, ...]
    kinds: tuple[str, ...]
    _hooks: Callable[[], tuple[str, ...]] = attrs.field(eq=False, repr=False)

    @property
    def hooks(self) -> tuple[str, ...]:
        """The hooks the plugin implements: its module's, its components' kinds', and those
        of its component classes (which imports the components it registered by name)."""
        return self._hooks()


@attrs.frozen
class PluginFailure:
    """A plugin that did not load, and why."""

    name: str
    distribution: str | None
    version: str | None
    stage: str
    error: str

    def describe(self) -> str:
        source = f" from {self.distribution} {self.version}" if self.distribution else ""
        return f"plugin {self.name!r}{source} failed to {self.stage}: {self.error}"


@attrs.define
class Plugins:
    """The loaded plugins: their plugin manager, the components they registered, the failures."""

    pm: pluggy.PluginManager
    registry: Registry
    loaded: list[PluginInfo] = attrs.field(factory=list)
    failed: list[PluginFailure] = attrs.field(factory=list)
    skipped: list[str] = attrs.field(factory=list)
    builtins: set[str] = attrs.field(factory=set)
    """The names of the loaded plugins that are cbrcore's own."""
    strict: bool = False
    """Whether a plugin's failure is fatal (``CBR_STRICT_PLUGINS``), its commands' included."""

    def info(self, name: str) -> PluginInfo:
        for plugin in self.loaded:
            if plugin.name == name:
                return plugin
        raise PluginError(f"no plugin named {name!r} is loaded")


def describe_exception(exc: BaseException) -> str:
    """An exception a plugin raised, as a failure's reason: its type and its message, if any."""
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _names(environ: Mapping[str, str], key: str) -> set[str] | None:
    value = environ.get(key, "").strip()
    return {n.strip() for n in value.split(",") if n.strip()} if value else None


def builtin_plugins() -> dict[str, str]:
    """cbrcore's own plugins, entry point name to module, as its distribution declares them."""
    try:
        dist = metadata.distribution(BUILTIN_DISTRIBUTION)
    except metadata.PackageNotFoundError:  # a source tree on sys.path, never installed
        return {}
    return {ep.name: ep.module for ep in dist.entry_points.select(group=ENTRY_POINT_GROUP)}


def _is_entry_point(source: Any) -> bool:
    """Whether a candidate plugin is an entry point still to load: the standard library's, or
    the ``importlib_metadata`` backport's, which ``importlib.metadata`` hands out once a
    package such as dask has imported the backport."""
    return isinstance(source, metadata.EntryPoint) or (
        type(source).__name__ == "EntryPoint" and callable(getattr(source, "load", None)))


def _distribution(ep: metadata.EntryPoint) -> Source:
    dist = ep.dist
    return (dist.name, dist.version) if dist is not None else (None, None)


def _is_builtin(source: Any, dist: Source, modules: Set[str]) -> bool:
    """Whether a candidate plugin is one of cbrcore's: its entry point, or its module in code.

    The testing kit registers the built-in modules in code (under any name); they count as the
    built-ins they are. An entry point counts only from cbrcore's own distribution, so another
    distribution cannot claim a built-in by declaring an entry point of the same name.
    """
    if _is_entry_point(source):
        return dist[0] == BUILTIN_DISTRIBUTION
    return isinstance(source, types.ModuleType) and source.__name__ in modules


def _hooks(obj: Any, components: Sequence[Component]) -> Callable[[], tuple[str, ...]]:
    def hooks() -> tuple[str, ...]:
        found = set(implemented_hooks(obj))
        for component in components:
            if component.kind in KIND_HOOK:
                found.add(KIND_HOOK[component.kind])
            if isinstance(component.factory, type):
                found.update(implemented_hooks(component.factory))
        return tuple(sorted(found))

    return hooks


def _withdraw(plugins: Plugins, name: str) -> None:
    plugins.registry._drop(name)
    plugins.pm.unregister(name=name)


def load_plugins(extra: Sequence[tuple[str, Any]] = (), *, entry_points: bool = True,
                 environ: Mapping[str, str] | None = None) -> Plugins:
    """Load the plugins of the ``cbr`` entry point group, then ``extra`` (name, module) pairs.

    ``extra`` registers plugins that no distribution declares (the testing kit uses it);
    ``entry_points=False`` loads only those. The built-in plugins go first wherever they come
    from (see the module's documentation).
    """
    environ = os.environ if environ is None else environ
    strict = environ.get("CBR_STRICT_PLUGINS", "") not in ("", "0")
    plugins = Plugins(pm=new_plugin_manager(), registry=Registry(), strict=strict)
    candidates: list[tuple[str, Any, Source]] = []
    if entry_points:
        for ep in sorted(metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name):
            candidates.append((ep.name, ep, _distribution(ep)))
    candidates.extend((name, obj, (None, None)) for name, obj in extra)
    wanted, reserved = _wanted(plugins, candidates, environ)
    loading = _Loading(plugins)
    loading.add(wanted, reserved)
    registered = loading.register()
    loading.withdraw_unresolved(registered)
    loading.note_loaded(registered)
    return plugins


Wanted = tuple[str, Any, Source, bool]
"""A plugin to load: its name, its entry point or module, its distribution, whether it is a
built-in."""


def _wanted(plugins: Plugins, candidates: Sequence[tuple[str, Any, Source]],
            environ: Mapping[str, str]) -> tuple[list[Wanted], dict[str, Source]]:
    """The candidates that ``CBR_PLUGINS`` and ``CBR_DISABLE_PLUGINS`` let load (the others
    noted as skipped), and the names the built-ins among them reserve."""
    allow = _names(environ, "CBR_PLUGINS")
    block = _names(environ, "CBR_DISABLE_PLUGINS") or set()
    # names go to whoever comes first, and that must be a built-in whatever the order: its
    # plugin name is reserved here, its component names and kinds by registering first
    modules = set(builtin_plugins().values())
    wanted: list[Wanted] = []
    reserved: dict[str, Source] = {}
    for name, source, dist in candidates:
        if name in block or (allow is not None and name not in allow):
            plugins.skipped.append(name)
            continue
        builtin = _is_builtin(source, dist, modules)
        if builtin:
            reserved.setdefault(name, dist)
        wanted.append((name, source, dist, builtin))
    return wanted, reserved


class _Loading:
    """One loading of plugins, step by step; each step calls :meth:`fail` itself, so that a
    failure's warning points at the caller of :func:`load_plugins`."""

    def __init__(self, plugins: Plugins) -> None:
        self.plugins = plugins
        self.sources: dict[str, Source] = {}

    def fail(self, name: str, dist: Source, stage: str, error: str) -> None:
        failure = PluginFailure(name, dist[0], dist[1], stage, error)
        if self.plugins.strict:
            raise PluginError(failure.describe())
        self.plugins.failed.append(failure)
        # past this method and the step: the caller of load_plugins
        warnings.warn(failure.describe(), PluginWarning, stacklevel=4)

    def add(self, wanted: Sequence[Wanted], reserved: Mapping[str, Source]) -> None:
        """Import each wanted plugin and add it to the plugin manager."""
        plugins = self.plugins
        for name, source, dist, builtin in wanted:
            taken = self.sources.get(name) or (None if builtin else reserved.get(name))
            if taken is not None:
                owner = taken[0] or "a plugin registered in code"
                self.fail(name, dist, "load", f"the plugin name is already taken by {owner}")
                continue
            try:
                obj = source.load() if _is_entry_point(source) else source
            except KeyboardInterrupt:
                raise
            except BaseException as exc:
                # a broken plugin, even one calling sys.exit, stops no other
                self.fail(name, dist, "import", describe_exception(exc))
                continue
            if plugins.pm.is_registered(obj):
                # a plugin's own tests pass its module in code while it is installed too
                continue
            misspelt = unknown_hooks(obj)
            if misspelt:
                self.fail(name, dist, "load", "; ".join(misspelt))
                continue
            try:
                plugins.pm.register(obj, name=name)
            except Exception as exc:
                # e.g. a hook implementation taking an argument of no hookspec
                self.fail(name, dist, "import", describe_exception(exc))
                continue
            self.sources[name] = dist
            if builtin:
                plugins.builtins.add(name)

    def register(self) -> list[str]:
        """Call each added plugin's ``cbr_register``, the built-ins first; the names of those
        that registered."""
        plugins = self.plugins
        registered = []
        for name in sorted(self.sources, key=lambda n: n not in plugins.builtins):  # stable
            dist = self.sources[name]
            obj = plugins.pm.get_plugin(name)
            plugins.registry._begin(name)
            try:
                register = getattr(obj, "cbr_register", None)
                if register is not None and "cbr_register" in implemented_hooks(obj):
                    register(registry=plugins.registry)
            except KeyboardInterrupt:
                raise
            except BaseException as exc:  # a broken plugin must not stop the others
                _withdraw(plugins, name)
                self.fail(name, dist, "register", describe_exception(exc))
                continue
            registered.append(name)
        return registered

    def withdraw_unresolved(self, registered: list[str]) -> None:
        """Withdraw the plugins whose registrations name what no plugin left declares."""
        plugins = self.plugins
        # withdrawing a plugin withdraws the kinds it declared, which others may have used
        while unresolved := plugins.registry.unresolved():
            for name, problems in unresolved.items():
                _withdraw(plugins, name)
                registered.remove(name)
                plugins.builtins.discard(name)
                self.fail(name, self.sources[name], "register", "; ".join(problems))

    def note_loaded(self, registered: Sequence[str]) -> None:
        """Note what each registered plugin brought."""
        plugins = self.plugins
        # listed as they came (entry point names, then code): `cbr plugins` and manifests
        for name in (n for n in self.sources if n in registered):
            obj = plugins.pm.get_plugin(name)
            components = plugins.registry.by_plugin(name)
            plugins.loaded.append(PluginInfo(
                name=name,
                module=getattr(obj, "__name__", type(obj).__name__),
                distribution=self.sources[name][0],
                version=self.sources[name][1],
                components=tuple(f"{c.kind}:{c.name}" for c in components),
                kinds=tuple(k.name for k in plugins.registry.kinds_by_plugin(name)),
                hooks=_hooks(obj, components),
            ))


_active: contextvars.ContextVar[Plugins | None] = contextvars.ContextVar(
    "cbr_plugins", default=None)
_installed: list[Plugins] = []


def current() -> Plugins:
    """The plugins in use: those of :func:`use_plugins`, else the installed ones, loaded once."""
    active = _active.get()
    if active is not None:
        return active
    if not _installed:
        _installed.append(load_plugins())
    return _installed[0]


@contextlib.contextmanager
def use_plugins(plugins: Plugins) -> Iterator[Plugins]:
    """Make ``plugins`` the ones :func:`current` returns inside the block."""
    token = _active.set(plugins)
    try:
        yield plugins
    finally:
        _active.reset(token)
