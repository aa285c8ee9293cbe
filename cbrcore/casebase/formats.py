"""The document formats a case base is written in and read from: cbrcore's own and the plugins'.

cbrcore writes and reads its plain-text export as ``yaml`` or ``json``
(:mod:`cbrcore.casebase.exchange`). A plugin offers more formats through the plugin hook
``cbr_casebase_formats``: a family whose cases are what another tool reads (a case graph is a
Nav2 route graph) converts its cases to and from that tool's files. ``cbr casebase export`` and
``import`` (``--format NAME``) and a store's ``initial`` cases reach every format the same way,
by its name or by the extension of the file.

A format may need the world the cases belong to, to say where they lie (cells of a grid in metres
of its map frame): it then gets the run's world, and is refused without one.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import attrs

from cbrcore.casebase.exchange import (
    Document,
    dump_document,
    parse_document,
    read_document_text,
    write_document_text,
)
from cbrcore.errors import CaseBaseError, PluginError
from cbrcore.plugins import Plugins, current, describe_exception


@attrs.frozen
class DocumentFormat:
    """A way to write a case base as a file and to read one back.

    ``dump(document, world)`` gives the text of ``document`` (the whole case base, as
    :func:`~cbrcore.casebase.exchange.document_of` snapshots it); ``parse(text, source, world)``
    gives the document a file's text stands for, raising
    :class:`~cbrcore.errors.CaseBaseError` that names ``source`` and every problem. ``world``
    is the world the cases belong to, None when none was given; a format whose ``world`` says
    what it needs (``a grid map with a metric frame``) is never called without one. A document
    that only makes sense as the whole case base (``append`` false) is never added to one that
    holds cases.
    """

    name: str
    suffixes: tuple[str, ...]
    summary: str
    dump: Callable[[Document, Any], str]
    parse: Callable[[str, str, Any], Document]
    world: str = ""
    append: bool = True


@attrs.frozen
class Offered:
    """A format and the plugin that offers it (``cbrcore`` for the built-in ones)."""

    format: DocumentFormat
    plugin: str


BUILT_IN = (
    DocumentFormat("yaml", (".yaml", ".yml"), "the plain-text export of any case base, as YAML",
                   lambda document, world: dump_document(document, "yaml"),
                   lambda text, source, world: parse_document(text, "yaml", source)),
    DocumentFormat("json", (".json",), "the plain-text export of any case base, as JSON",
                   lambda document, world: dump_document(document, "json"),
                   lambda text, source, world: parse_document(text, "json", source)),
)
"""cbrcore's own formats."""


def document_formats(plugins: Plugins | None = None) -> dict[str, Offered]:
    """Every format by name: the built-in ones, then those the loaded plugins offer
    (``cbr_casebase_formats``), in the order of the plugins. A plugin whose hook fails, gives
    something else than formats, or names a format already taken is a PluginError."""
    plugins = plugins or current()
    offered = {fmt.name: Offered(fmt, "cbrcore") for fmt in BUILT_IN}
    for impl in reversed(plugins.pm.hook.cbr_casebase_formats.get_hookimpls()):
        try:
            given = impl.function()
        except Exception as exc:
            raise PluginError(f"plugin {impl.plugin_name!r} failed to offer its case base "
                              f"formats: {describe_exception(exc)}") from exc
        for fmt in given or ():
            if not isinstance(fmt, DocumentFormat):
                raise PluginError(f"plugin {impl.plugin_name!r} offered a "
                                  f"{type(fmt).__name__} as a case base format; expected a "
                                  "DocumentFormat")
            if fmt.name in offered:
                raise PluginError(f"plugin {impl.plugin_name!r} offers the case base format "
                                  f"{fmt.name!r}, which {offered[fmt.name].plugin!r} offers")
            offered[fmt.name] = Offered(fmt, impl.plugin_name)
    return offered


def _listed(offered: dict[str, Offered]) -> str:
    return ", ".join(name if o.plugin == "cbrcore" else f"{name} ({o.plugin})"
                     for name, o in offered.items())


def document_format(name: str, plugins: Plugins | None = None) -> DocumentFormat:
    """The format called ``name``; CaseBaseError listing the known ones when there is none."""
    offered = document_formats(plugins)
    if name not in offered:
        raise CaseBaseError(f"no case base format is called {name!r}; expected one of: "
                            f"{_listed(offered)}")
    return offered[name].format


def format_for(path: str | os.PathLike[str], name: str | None = None,
               plugins: Plugins | None = None) -> DocumentFormat:
    """The format ``name`` calls for, else the one the extension of ``path`` does."""
    if name is not None:
        return document_format(name, plugins)
    offered = document_formats(plugins)
    suffix = Path(path).suffix.lower()
    for entry in offered.values():
        if suffix in entry.format.suffixes:
            return entry.format
    known = ", ".join(f"{s} ({o.format.name})" for o in offered.values() for s in o.format.suffixes)
    raise CaseBaseError(f"{path}: cannot tell the format from the extension {suffix!r}; name "
                        f"the file {known}, or give the format")


def _world_for(fmt: DocumentFormat, world: Any, source: str) -> None:
    if fmt.world and world is None:
        raise CaseBaseError(f"{source}: the {fmt.name} format needs the world the cases belong "
                            f"to ({fmt.world}), and none was given")


def read_casebase(path: str | os.PathLike[str], format: str | None = None, *,
                  world: Any = None, plugins: Plugins | None = None) -> Document:
    """Read the case base document ``path`` in ``format`` (default: from its extension) within
    the document limits (:mod:`cbrcore.documents`); ``world`` for a format that needs it."""
    fmt = format_for(path, format, plugins)
    _world_for(fmt, world, str(path))
    return fmt.parse(read_document_text(path), str(path), world)


def write_casebase(document: Document, path: str | os.PathLike[str], format: str | None = None,
                   *, world: Any = None, plugins: Plugins | None = None) -> None:
    """Write ``document`` to the file ``path`` whole, in ``format`` (default: from its
    extension); ``world`` for a format that needs it."""
    fmt = format_for(path, format, plugins)
    _world_for(fmt, world, str(path))
    write_document_text(fmt.dump(document, world), path)
