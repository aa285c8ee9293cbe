"""Markdown references generated from the code: configuration options and hooks.

The docs pages ``docs/reference/configuration.md`` and ``docs/reference/hooks.md`` are this
module's output (``cbr reference config`` and ``cbr reference hooks``); a test keeps them current.
"""

from __future__ import annotations

import inspect
import re
import types
import typing
from collections.abc import Iterable

import attrs

from cbrcore import hookspecs
from cbrcore.config import LIST_SLOTS, SINGLE_SLOTS
from cbrcore.registry import KINDS, Component, NoOptions

_TOP = """\
# Configuration reference

A configuration is a YAML mapping. `seed` is a non-negative integer (default 0) from which every
random choice of the run derives. Every other key is a slot naming a component, written as its
name or as a mapping whose `use` key names it and whose other keys are its options:

```yaml
casebase: sqlite                               # by name: every option at its default
observers: [{use: trace, file: trace.jsonl}]   # `use` names it, the other keys are options
```

| key | takes | component kind |
|---|---|---|
"""


_ROLE = re.compile(r":(?:\w+:)?\w+:`(?P<tilde>~?)(?P<text>[^`<]+?)(?:\s*<[^>]*>)?`")
_LITERAL = re.compile(r"``(?P<text>[^`]+)``")


def _markdown(text: str) -> str:
    """Docstring text with its reST markup (``code``, :class:`~a.B`) written as markdown."""

    def role(match: re.Match[str]) -> str:
        text = match["text"].strip()
        return f"`{text.rsplit('.', 1)[-1] if match['tilde'] else text}`"

    return _LITERAL.sub(r"`\g<text>`", _ROLE.sub(role, text))


def _type_name(kind: object) -> str:
    if isinstance(kind, str):
        return kind.replace("|", "\\|")
    if typing.get_origin(kind) is typing.Literal:
        return " \\| ".join(repr(a) for a in typing.get_args(kind))
    if typing.get_origin(kind) in (typing.Union, types.UnionType):
        return " \\| ".join("None" if a is type(None) else _type_name(a)
                             for a in typing.get_args(kind))
    text = getattr(kind, "__name__", None) if typing.get_origin(kind) is None else None
    return text or str(kind).replace("typing.", "").replace("|", "\\|")


def _default(field: attrs.Attribute) -> str:
    if field.default is attrs.NOTHING:
        return "required"
    if isinstance(field.default, attrs.Factory):  # type: ignore[arg-type]
        return f"`{field.default.factory()!r}`"
    return f"`{field.default!r}`"


def _component_section(component: Component) -> list[str]:
    lines = [f"### `{component.name}`", "", f"Plugin: `{component.plugin}`.", ""]
    doc = _markdown(inspect.cleandoc(component.doc)) if component.doc else ""
    if doc:
        lines += [doc, ""]
    if component.options is NoOptions or not attrs.fields(component.options):
        return [*lines, "No options.", ""]
    lines += ["| option | type | default | meaning |", "|---|---|---|---|"]
    # resolved as when options are read, so the text does not depend on whether they were
    for field in attrs.fields(attrs.resolve_types(component.options)):
        meaning = _markdown(field.metadata.get("doc", "")).replace("\n", " ").replace("|", "\\|")
        lines.append(f"| `{field.name}` | {_type_name(field.type)} | {_default(field)} "
                     f"| {meaning} |")
    return [*lines, ""]


def config_reference(components: Iterable[Component]) -> str:
    """The configuration reference for ``components``, grouped by kind."""
    lines = [_TOP.rstrip("\n")]
    slot_of = {kind: slot for slot, kind in SINGLE_SLOTS.items()}
    list_slot_of = {kind: slot for slot, kind in LIST_SLOTS.items()}
    for slot, kind in SINGLE_SLOTS.items():
        default = " (default `memory`)" if slot == "casebase" else ""
        lines.append(f"| `{slot}` | one component{default} | {kind} |")
    for slot, kind in LIST_SLOTS.items():
        lines.append(f"| `{slot}` | a list of components (or one) | {kind} |")
    lines.append("")
    by_kind: dict[str, list[Component]] = {}
    for component in components:
        by_kind.setdefault(component.kind, []).append(component)
    for kind, description in KINDS.items():
        slot = slot_of.get(kind) or list_slot_of.get(kind)
        if slot:
            where = f"slot `{slot}`"
        elif kind == "experiment":
            where = "run by `cbr experiment`"
        else:
            where = "named by other components' options"
        lines += [f"## {kind} ({where})", "", description[0].upper() + description[1:] + ".", ""]
        listed = sorted(by_kind.get(kind, []), key=lambda c: c.name)
        if not listed:
            lines += ["No component of this kind is installed.", ""]
        for component in listed:
            lines += _component_section(component)
    return "\n".join(lines).rstrip("\n") + "\n"


def hook_reference() -> str:
    """The hook reference: every hookspec with its signature, kind and contract."""
    lines = ["# Hook reference", "", _markdown(inspect.cleandoc(hookspecs.__doc__ or "")), ""]
    for name in (*hookspecs.PLUGIN_HOOKS, *hookspecs.PHASE_HOOKS.values()):
        function = getattr(hookspecs, name)
        opts = getattr(function, f"{hookspecs.PROJECT}_spec")
        signature = str(inspect.signature(function)).replace("'", "")
        kind = "firstresult" if opts.get("firstresult") else "collect-all"
        lines += [f"## `{name}`", "", "```python", f"def {name}{signature}", "```", "",
                  f"*{kind}*", "", _markdown(inspect.cleandoc(function.__doc__ or "")), ""]
    return "\n".join(lines).rstrip("\n") + "\n"
