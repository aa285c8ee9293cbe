"""Named components that plugins register and configurations select."""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterator
from typing import Any

import attrs

from cbrcore.errors import CbrError, PluginError

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
    "workload": "produces the queries of a run and carries out proposals (cbrcore.run.Workload)",
    "metric": "turns one query's problem, proposal and outcome into numbers (cbrcore.run.Metric)",
    "experiment": "a reproduction run by `cbr experiment` (cbrcore.experiment.Experiment)",
    "kinematics": "a robot's move condition: which move may follow which at a vertex, named by "
                  "the planners' `kinematics` option",
}
"""Every component kind, with what a component of that kind must provide."""

KIND_HOOK: dict[str, str] = {
    "retriever": "cbr_retrieve",
    "reuser": "cbr_reuse",
    "reviser": "cbr_revise",
    "solver": "cbr_solve",
    "retainer": "cbr_retain",
    "forgetter": "cbr_forget",
}
"""The phase hook a component of each phase kind implements."""


@attrs.frozen
class NoOptions:
    """A component that takes no options."""


@attrs.frozen
class Component:
    """One registered component: how to build it and which plugin supplied it."""

    kind: str
    name: str
    factory: Callable[[Any, Any], Any]
    options: type
    plugin: str
    doc: str

    @property
    def summary(self) -> str:
        return self.doc.strip().splitlines()[0] if self.doc.strip() else ""


class UnknownComponent(CbrError):
    """A configuration names a component nobody registered."""


class Registry:
    """The components of all loaded plugins, by kind and name."""

    def __init__(self) -> None:
        self._components: dict[tuple[str, str], Component] = {}
        self._plugin = "<unknown>"

    def add(self, kind: str, name: str, factory: Callable[[Any, Any], Any], *,
            options: type = NoOptions, doc: str | None = None) -> None:
        """Register ``factory`` as component ``name`` of ``kind``.

        ``factory(options, ctx)`` builds the component; ``options`` is an attrs class whose fields
        are the component's configuration keys (document each field with
        ``cbrcore.options.option``). ``doc`` defaults to the factory's docstring.
        """
        if kind not in KINDS:
            raise PluginError(f"unknown component kind {kind!r}; kinds: {', '.join(KINDS)}")
        if not attrs.has(options):
            raise PluginError(f"{kind} {name!r}: options must be an attrs class, got {options!r}")
        taken = self._components.get((kind, name))
        if taken is not None:
            raise PluginError(f"{kind} {name!r} is already registered by plugin {taken.plugin!r}")
        text = doc if doc is not None else inspect.getdoc(factory) or ""
        self._components[kind, name] = Component(kind, name, factory, options, self._plugin, text)

    def get(self, kind: str, name: str) -> Component:
        """The component ``name`` of ``kind``; the error lists the registered alternatives."""
        found = self._components.get((kind, name))
        if found is not None:
            return found
        known = [c for c in self if c.kind == kind]
        listing = ", ".join(f"{c.name} (plugin {c.plugin})" for c in known) or "none"
        raise UnknownComponent(f"unknown {kind} {name!r}; registered: {listing}")

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

    def _begin(self, plugin: str) -> None:
        self._plugin = plugin

    def _drop(self, plugin: str) -> None:
        self._components = {k: c for k, c in self._components.items() if c.plugin != plugin}
