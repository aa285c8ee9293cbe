"""Named components that plugins register and configurations select, by kind.

cbrcore declares the kinds its engine uses (:data:`KINDS`). A plugin declares further kinds with
:meth:`Registry.add_kind` from its ``cbr_register``; a kind may own a top-level configuration
slot, so that a configuration chooses its component once for the whole run. A name (of a kind,
or of a component within its kind) goes to the first plugin registering it; the built-in plugins
register first, so their names are theirs (see :mod:`cbrcore.plugins`). A plugin may register
components of a kind that a later plugin declares: kinds are checked once every plugin has
registered (:meth:`Registry.unresolved`).
"""

from __future__ import annotations

import ast
import functools
import importlib
import importlib.util
import inspect
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import attrs

from cbrcore.errors import CbrError, PluginError
from cbrcore.hookimpls import unknown_hooks
from cbrcore.stash import StashKey

KINDS: dict[str, str] = {
    "world": "the environment queries are posed in (a map, a landmark scene, a behavior domain)",
    "store": "a case base store implementing cbrcore.casebase.CaseStore",
    "retriever": "implements cbr_retrieve",
    "reuser": "implements cbr_reuse",
    "reviser": "implements cbr_revise",
    "solver": "implements cbr_solve: the alternative method the hybrid falls back on",
    "retainer": "implements cbr_retain",
    "forgetter": "implements cbr_forget",
    "observer": "wraps phase hooks (wrapper=True hookimpls): tracing, timing, progress, metrics",
    "workload": "poses the queries of a run: yields them and carries out proposals, or runs its "
                "own loop consulting the engine through a session (cbrcore.workload.Workload)",
    "metric": "turns one query's problem, proposal and outcome into numbers "
              "(cbrcore.workload.Metric)",
    "experiment": "a reproduction run by `cbr experiment` (cbr_experiments.experiment.Experiment)",
}
"""The component kinds of cbrcore itself, with what a component of each must provide."""

KIND_HOOK: dict[str, str] = {
    "retriever": "cbr_retrieve",
    "reuser": "cbr_reuse",
    "reviser": "cbr_revise",
    "solver": "cbr_solve",
    "retainer": "cbr_retain",
    "forgetter": "cbr_forget",
}
"""The phase hook a component of each phase kind implements."""

SINGLE_SLOTS: dict[str, str] = {
    "world": "world",
    "casebase": "store",
    "retrieve": "retriever",
    "reuse": "reuser",
    "revise": "reviser",
    "solver": "solver",
    "workload": "workload",
}
"""The core's configuration slots that take one component, and the kind each takes."""

LIST_SLOTS: dict[str, str] = {
    "retain": "retainer",
    "forget": "forgetter",
    "observers": "observer",
    "metrics": "metric",
}
"""The core's slots that take a list of components (a single one is accepted as a list of one)."""

CORE_KEYS = frozenset({"seed", *SINGLE_SLOTS, *LIST_SLOTS})
"""The top-level configuration keys of cbrcore itself, which no plugin's slot may take."""


@attrs.frozen
class Slot:
    """A top-level configuration key that a plugin's kind owns.

    A configuration names one component of ``kind`` there for the whole run (``default`` when
    it names none); the engine builds it and stores it in ``ctx.stash`` under ``key``.
    """

    name: str
    kind: str
    default: str | None
    key: StashKey[Any]


@attrs.frozen
class Kind:
    """A component kind: what its components provide, who declared it, the slot it owns.

    ``plugin`` is None for cbrcore's own kinds, whose slots the configuration itself defines.
    """

    name: str
    doc: str
    plugin: str | None = None
    slot: Slot | None = None

    @property
    def declared_by(self) -> str:
        """``cbrcore`` or ``plugin NAME``, for messages and listings."""
        return "cbrcore" if self.plugin is None else f"plugin {self.plugin!r}"


@attrs.frozen
class NoOptions:
    """A component that takes no options."""


Named = str
"""A factory or options class named as ``"package.module:Attribute"`` (``Attribute`` may be
dotted, ``Outer.Inner``), imported when first needed."""


def _is_named(target: str) -> bool:
    module, sep, attribute = target.partition(":")
    return bool(sep) and all(part.isidentifier() for part in
                             (*module.split("."), *attribute.split(".")))


def _imported(target: Named) -> Any:
    module, _, attribute = target.partition(":")
    found: Any = importlib.import_module(module)
    for part in attribute.split("."):
        found = getattr(found, part)
    return found


_DEFINITIONS = (ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)


def _bound(node: ast.AST) -> set[str]:
    """The names a statement binds, in any of its branches."""
    names = set()
    for inner in ast.walk(node):
        if isinstance(inner, ast.Name) and isinstance(inner.ctx, ast.Store):
            names.add(inner.id)
        elif isinstance(inner, _DEFINITIONS):
            names.add(inner.name)
        elif isinstance(inner, (ast.Import, ast.ImportFrom)):
            names.update(alias.asname or alias.name.split(".")[0] for alias in inner.names)
    return names


def _source(module: str) -> Path | None:
    """The source file of ``module``, found without importing it or its parent packages (whose
    ``__init__`` may import what naming the component was meant to spare); None when it is not
    a plain ``.py`` file in its top-level package's folders."""
    top, *inner = module.split(".")
    try:
        spec = importlib.util.find_spec(top)
    except (ImportError, ValueError):
        return None
    if spec is None:
        return None
    if not inner:
        return Path(spec.origin) if spec.origin and spec.origin.endswith(".py") else None
    for folder in spec.submodule_search_locations or []:
        base = Path(folder, *inner[:-1])
        for path in (base / f"{inner[-1]}.py", base / inner[-1] / "__init__.py"):
            if path.is_file():
                return path
    return None


def _definitions(module: str) -> dict[str, ast.AST] | None:
    """The classes and functions ``module``'s source defines at its top level, by name, read
    without importing it; None when it has no source file. A name a later statement binds
    otherwise (an assignment, an import, a definition in a branch) is left out: only importing
    would tell what it is."""
    path = _source(module)
    if path is None:
        return None
    try:
        return _parsed(str(path), path.stat().st_mtime_ns)
    except OSError:
        return None


@functools.cache
def _parsed(origin: str, mtime: int) -> dict[str, ast.AST] | None:
    """:func:`_definitions` of the source file ``origin``, as it was at ``mtime``."""
    try:
        tree = ast.parse(Path(origin).read_bytes())
    except (OSError, SyntaxError, ValueError):
        return None
    found: dict[str, ast.AST] = {}
    for node in tree.body:
        if isinstance(node, _DEFINITIONS):
            found[node.name] = node
        else:
            for name in _bound(node):
                found.pop(name, None)
    return found


def _written_doc(target: Named) -> str | None:
    """The docstring of the class or function ``target`` names, as :func:`inspect.getdoc` gives
    it, read from its module's source without importing it; None when the source does not
    settle it (no source, no docstring of its own, a name bound otherwise)."""
    module, _, attribute = target.partition(":")
    scope = _definitions(module)
    node: ast.AST | None = None
    for part in attribute.split("."):
        node = scope.get(part) if scope is not None else None
        if node is None:
            return None
        scope = {child.name: child for child in getattr(node, "body", [])
                 if isinstance(child, _DEFINITIONS)}
    if not isinstance(node, _DEFINITIONS):
        return None
    if node.decorator_list and not isinstance(node, ast.ClassDef):
        return None  # a decorated function may be replaced, docstring and all
    return ast.get_docstring(node)


def _references(label: str, factory: Any, options: Any) -> dict[str, str]:
    """The references of a component's ``options``, once its factory and options are checked:
    what :meth:`Registry.add` refuses raises a :class:`PluginError`."""
    if not callable(factory):
        raise PluginError(f"{label}: the factory must be callable, got {factory!r}")
    if not (isinstance(options, type) and attrs.has(options)):
        raise PluginError(f"{label}: options must be an attrs class, got {options!r}")
    if isinstance(factory, type) and (misspelt := unknown_hooks(factory)):
        raise PluginError(f"{label}: {'; '.join(misspelt)}")
    if not attrs.fields(options):  # NoOptions and the like: nothing to resolve or refer to
        return {}
    # cattrs and yaml load with the first options checked, not with the registry
    from cbrcore.options import references

    try:
        return dict(references(options))
    except NameError as exc:  # an annotation naming something the module does not define
        raise PluginError(f"{label}: the annotations of {options.__qualname__} do not "
                          f"resolve: {exc}") from None


@attrs.frozen
class _Loaded:
    factory: Callable[[Any, Any], Any]
    options: type
    references: Mapping[str, str]


@attrs.frozen
class Component:
    """One registered component: how to build it and which plugin supplied it.

    ``references`` maps each option that names another component (see
    :func:`cbrcore.options.reference`) to the kind it names. ``world_independent`` says that
    the cases the component reads or writes hold in any world (see :meth:`Registry.add`).
    A component registered with a named factory or options class imports them when
    ``factory``, ``options`` or ``references`` is first read; a module that fails to import, or
    what :meth:`Registry.add` would have refused, is then a
    :class:`~cbrcore.errors.PluginError` naming the plugin and the component. Its ``doc`` is
    read from the factory's source when it can be, without importing it.
    """

    kind: str
    name: str
    plugin: str
    world_independent: bool
    _factory: Callable[[Any, Any], Any] | Named
    _options: type | Named
    _doc: str | None
    _registry: Registry = attrs.field(eq=False, repr=False)
    _loaded: list[_Loaded] = attrs.field(factory=list, eq=False, repr=False)

    @property
    def factory(self) -> Callable[[Any, Any], Any]:
        """``factory(options, ctx)`` builds the component."""
        return self._load().factory

    @property
    def options(self) -> type:
        """The attrs class of the component's options."""
        return self._load().options

    @property
    def references(self) -> Mapping[str, str]:
        return self._load().references

    @property
    def doc(self) -> str:
        """What the component does: the ``doc`` it was registered with, else its factory's
        docstring."""
        if self._doc is not None:
            return self._doc
        if isinstance(self._factory, str) and not self._loaded:
            # read from the source, so that listing components (TAB completion, say) imports none
            written = _written_doc(self._factory)
            if written is not None:
                return written
        return inspect.getdoc(self.factory) or ""

    @property
    def summary(self) -> str:
        return self.doc.strip().splitlines()[0] if self.doc.strip() else ""

    @property
    def loaded(self) -> bool:
        """Whether the factory and options class are imported and checked."""
        return bool(self._loaded)

    def _load(self) -> _Loaded:
        if self._loaded:
            return self._loaded[0]
        label = f"plugin {self.plugin!r}: {self.kind} {self.name!r}"
        found = []
        for target in (self._factory, self._options):
            if not isinstance(target, str):
                found.append(target)
                continue
            try:
                found.append(_imported(target))
            except KeyboardInterrupt:
                raise
            except BaseException as exc:  # whatever the plugin's module raises is its failure
                raise PluginError(f"{label}: cannot import {target!r}: "
                                  f"{type(exc).__name__}: {exc}") from exc
        factory, options = found
        refers = _references(label, factory, options)
        kinds = self._registry.kinds
        undeclared = {option: kind for option, kind in refers.items() if kind not in kinds}
        if undeclared:
            option, kind = next(iter(undeclared.items()))
            raise PluginError(f"{label}: option {option!r} refers to kind {kind!r}, which no "
                              f"plugin declares; kinds: {', '.join(sorted(kinds))}")
        self._loaded.append(_Loaded(factory, options, refers))
        return self._loaded[0]


class UnknownComponent(CbrError):
    """A configuration names a component nobody registered."""


class Registry:
    """The component kinds and the components of all loaded plugins, by kind and name."""

    def __init__(self) -> None:
        self._kinds: dict[str, Kind] = {name: Kind(name, doc) for name, doc in KINDS.items()}
        self._components: dict[tuple[str, str], Component] = {}
        self._plugin = "<unknown>"

    def add_kind(self, name: str, doc: str, *, slot: str | None = None,
                 default: str | None = None, key: StashKey[Any] | None = None) -> None:
        """Declare the component kind ``name``; ``doc`` says what its components provide.

        With ``slot``, the kind owns that top-level configuration key: a configuration names
        one component of the kind there for the whole run (``default`` when it names none), and
        the engine builds it before the phase components and stores it in ``ctx.stash[key]``,
        where every component reads it. ``slot`` and ``key`` go together; ``default`` needs a
        slot and must name a component of the kind once every plugin has registered.
        """
        taken = self._kinds.get(name)
        if taken is not None:
            raise PluginError(f"component kind {name!r} is already declared by "
                              f"{taken.declared_by}")
        if not name.isidentifier():
            raise PluginError(f"component kind {name!r}: expected a name of letters, digits "
                              "and underscores")
        if not doc.strip():
            raise PluginError(f"component kind {name!r}: the doc must say what a component of "
                              "the kind provides")
        if (slot is None) != (key is None):
            raise PluginError(f"component kind {name!r}: a slot needs a StashKey to store its "
                              "component under, and a key needs a slot")
        if default is not None and slot is None:
            raise PluginError(f"component kind {name!r}: a default needs a slot")
        if slot is not None:
            if not slot.isidentifier():
                raise PluginError(f"component kind {name!r}: slot {slot!r} must be a name of "
                                  "letters, digits and underscores")
            if slot in CORE_KEYS:
                raise PluginError(f"component kind {name!r}: slot {slot!r} is a key of "
                                  "cbrcore's own configuration")
            owner = self.slots.get(slot)
            if owner is not None:
                raise PluginError(f"component kind {name!r}: slot {slot!r} is already taken "
                                  f"by kind {owner.kind!r} of "
                                  f"{self._kinds[owner.kind].declared_by}")
            if not isinstance(key, StashKey):
                raise PluginError(f"component kind {name!r}: key must be a "
                                  f"cbrcore.stash.StashKey, got {key!r}")
        owned = Slot(slot, name, default, key) if slot is not None and key is not None else None
        self._kinds[name] = Kind(name, doc, self._plugin, owned)

    @property
    def kinds(self) -> Mapping[str, Kind]:
        """Every declared kind by name: cbrcore's, then the plugins' as they registered."""
        return dict(self._kinds)

    @property
    def slots(self) -> Mapping[str, Slot]:
        """The top-level configuration slots that plugins' kinds own, by name."""
        return {kind.slot.name: kind.slot for kind in self._kinds.values()
                if kind.slot is not None}

    def add(self, kind: str, name: str, factory: Callable[[Any, Any], Any] | Named, *,
            options: type | Named = NoOptions, doc: str | None = None,
            world_independent: bool = False) -> None:
        """Register ``factory`` as component ``name`` of ``kind``.

        ``factory(options, ctx)`` builds the component; ``options`` is an attrs class whose fields
        are the component's configuration keys (document each field with
        ``cbrcore.options.option``, or ``cbrcore.options.reference`` for a field naming another
        component). ``doc`` defaults to the factory's docstring. ``kind`` may be one a plugin
        loading later declares. ``world_independent`` declares that the cases a retriever,
        reuser, retainer or forgetter reads and writes hold in any world (they index
        situations, not a map's cells): a run whose case components all declare it records no
        world in its case base and is never refused for another world's cases (see
        :mod:`cbrcore.casebase.worlds`); left false, the safe default, a run records its world
        and refuses a case base of another. Refused: a name taken within the kind, options
        whose type annotations do not resolve, and a factory class with a hook implementation
        that names no cbrcore hook (see :func:`cbrcore.hookimpls.unknown_hooks`).

        ``factory`` and ``options`` may each be named as ``"package.module:Attribute"``
        instead: the module is imported when the component is first used (a configuration
        names it, it is built, or a reference lists it), and the checks above are made then,
        along with that of the kinds its options refer to.
        """

        label = f"{kind} {name!r}"
        for what, target in (("factory", factory), ("options", options)):
            if isinstance(target, str) and not _is_named(target):
                raise PluginError(f"{label}: a named {what} is written "
                                  f"'package.module:Attribute', got {target!r}")
        if not isinstance(options, str) and not attrs.has(options):
            raise PluginError(f"{label}: options must be an attrs class, got {options!r}")
        taken = self._components.get((kind, name))
        if taken is not None:
            raise PluginError(f"{label} is already registered by plugin {taken.plugin!r}")
        component = Component(kind, name, self._plugin, world_independent, factory, options,
                              doc, self)
        if not isinstance(factory, str) and not isinstance(options, str):
            # given, not named: checked now, and the component is loaded
            component._loaded.append(_Loaded(factory, options,
                                             _references(label, factory, options)))
        self._components[kind, name] = component

    def get(self, kind: str, name: str) -> Component:
        """The component ``name`` of ``kind``; the error lists the registered alternatives."""
        found = self._components.get((kind, name))
        if found is None:
            raise self._unknown(kind, name)
        return found

    def create(self, kind: str, name: str, options: Any, ctx: Any) -> Any:
        """Build component ``name`` of ``kind`` from an options instance (or a dict of options)."""
        component = self.get(kind, name)
        if not isinstance(options, component.options):
            from cbrcore.options import structure_options

            options = structure_options(component.options, options or {}, f"{kind} {name}")
        return component.factory(options, ctx)

    def __iter__(self) -> Iterator[Component]:
        return iter(sorted(self._components.values(), key=lambda c: (c.kind, c.name)))

    def by_plugin(self, plugin: str) -> list[Component]:
        return [c for c in self if c.plugin == plugin]

    def kinds_by_plugin(self, plugin: str) -> list[Kind]:
        return [k for k in self._kinds.values() if k.plugin == plugin]

    def unresolved(self) -> dict[str, list[str]]:
        """What the registered plugins use but nobody declared or registered, by plugin.

        A component of an undeclared kind, an option referring to an undeclared kind, and a
        slot default that names no registered component are each a problem of the plugin that
        registered the component or declared the kind. Called once every plugin has registered,
        since a kind may be declared by a plugin that loads after the one using it. The
        options of a component registered by name are checked when it loads instead.
        """
        problems: dict[str, list[str]] = {}
        kinds = f"kinds: {', '.join(sorted(self._kinds))}"
        orphans: dict[tuple[str, str], list[str]] = {}
        for component in self:
            if component.kind not in self._kinds:
                orphans.setdefault((component.plugin, component.kind), []).append(component.name)
            if not component.loaded:  # its references are checked when it loads
                continue
            for option, kind in component.references.items():
                if kind not in self._kinds:
                    problems.setdefault(component.plugin, []).append(
                        f"{component.kind} {component.name!r}: option {option!r} refers to "
                        f"kind {kind!r}, which no plugin declares; {kinds}")
        for (plugin, kind), names in orphans.items():
            problems.setdefault(plugin, []).append(
                f"no plugin declares the component kind {kind!r} of {', '.join(names)}; {kinds}")
        for kind in self._kinds.values():
            slot = kind.slot
            if (kind.plugin is not None and slot is not None and slot.default is not None
                    and (kind.name, slot.default) not in self._components):
                problems.setdefault(kind.plugin, []).append(
                    f"the default of slot {slot.name!r}: {self._unknown(kind.name, slot.default)}")
        return problems

    def _unknown(self, kind: str, name: str) -> UnknownComponent:
        known = [c for c in self if c.kind == kind]
        listing = ", ".join(f"{c.name} (plugin {c.plugin})" for c in known) or "none"
        return UnknownComponent(f"unknown {kind} {name!r}; registered: {listing}")

    def _begin(self, plugin: str) -> None:
        self._plugin = plugin

    def _drop(self, plugin: str) -> None:
        self._components = {k: c for k, c in self._components.items() if c.plugin != plugin}
        self._kinds = {n: k for n, k in self._kinds.items() if k.plugin != plugin}
