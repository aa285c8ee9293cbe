"""Markdown references generated from the code: configuration options and hooks.

The docs pages ``docs/reference/configuration.md`` and ``docs/reference/hooks.md`` are this
module's output (``cbr reference config`` and ``cbr reference hooks``); a test keeps them current.
In a checkout, the hook reference shows under each hook its example plugin from
``docs/examples/hooks/<hook>.py``, which a test runs through the engine.
The command-line reference is :mod:`cbrcore.cli.reference`'s.
"""

from __future__ import annotations

import inspect
import re
import types
import typing
from pathlib import Path

import attrs

from cbrcore import hookspecs
from cbrcore.config import DEFAULT_STORE
from cbrcore.options import referred_kind
from cbrcore.registry import LIST_SLOTS, SINGLE_SLOTS, Component, Kind, NoOptions, Registry

_TOP = """\
# Configuration reference

A configuration is a YAML mapping. `seed` is a non-negative integer (default 0) from which every
random choice of the run derives. Every other key is a slot naming a component, written as its
name or as a mapping whose `use` key names it and whose other keys are its options:

```yaml
casebase: sqlite                               # by name: every option at its default
observers: [{use: trace, file: trace.jsonl}]   # `use` names it, the other keys are options
```

A plugin may declare a kind of its own with a slot of its own, listed below with the plugin that
declared it. An option whose type reads `str naming a solver` takes the name of a registered
component of that kind, and any other name is refused.

| key | takes | component kind |
|---|---|---|
"""


#: the example plugin of each hook, in a checkout; an installed cbrcore has none to show
HOOK_EXAMPLES = Path(__file__).resolve().parent.parent / "docs" / "examples" / "hooks"

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


def _article(word: str) -> str:
    return "an" if word[:1] in "aeiou" else "a"


def _option_type(field: attrs.Attribute) -> str:
    kind = referred_kind(field)
    named = f" naming {_article(kind)} {kind}" if kind is not None else ""
    return _type_name(field.type) + named


def _component_section(component: Component) -> list[str]:
    lines = [f"### `{component.name}`", "", f"Plugin: `{component.plugin}`.", ""]
    doc = _markdown(inspect.cleandoc(component.doc)) if component.doc else ""
    if doc:
        lines += [doc, ""]
    if component.options is NoOptions or not attrs.fields(component.options):
        return [*lines, "No options.", ""]
    lines += ["| option | type | default | meaning |", "|---|---|---|---|"]
    return [*lines, *_option_rows(component.options, ""), ""]


def _nested(kind: object) -> type | None:
    """The options class an option's value is a mapping of (``Inflation | None``, ``list[Site]``),
    if any."""
    if attrs.has(kind):  # type: ignore[arg-type]
        return kind  # type: ignore[return-value]
    for arg in typing.get_args(kind):
        found = _nested(arg)
        if found is not None:
            return found
    return None


def _option_rows(options: type, prefix: str) -> list[str]:
    """A table row per option of ``options``, then per option of the mapping an option takes,
    named by its dotted path (``inflation.robot_radius``; ``sites[].cells`` in list items)."""
    rows = []
    # resolved as when options are read, so the text does not depend on whether they were
    for field in attrs.fields(attrs.resolve_types(options)):
        meaning = _markdown(field.metadata.get("doc", "")).replace("\n", " ").replace("|", "\\|")
        rows.append(f"| `{prefix}{field.name}` | {_option_type(field)} | {_default(field)} "
                    f"| {meaning} |")
        inner = _nested(field.type)
        if inner is not None:
            listed = typing.get_origin(field.type) is list
            rows += _option_rows(inner, f"{prefix}{field.name}{'[]' if listed else ''}.")
    return rows


def _where(kind: Kind) -> str:
    single = {k: slot for slot, k in SINGLE_SLOTS.items()}
    listed = {k: slot for slot, k in LIST_SLOTS.items()}
    slot = kind.slot.name if kind.slot else single.get(kind.name) or listed.get(kind.name)
    if slot is not None:
        return f"slot `{slot}`"
    if kind.name == "experiment":
        return "run by `cbr experiment`"
    return "named by other components' options"


def _declarer(kind: Kind) -> str:
    return "cbrcore" if kind.plugin is None else f"plugin `{kind.plugin}`"


def config_reference(registry: Registry) -> str:
    """The configuration reference for the kinds and components of ``registry``, by kind."""
    lines = [_TOP.rstrip("\n")]
    for slot, kind in SINGLE_SLOTS.items():
        default = f" (default `{DEFAULT_STORE}`)" if slot == "casebase" else ""
        lines.append(f"| `{slot}` | one component{default} | {kind} |")
    for slot in registry.slots.values():
        default = f" (default `{slot.default}`)" if slot.default is not None else ""
        lines.append(f"| `{slot.name}` | one component{default} | {slot.kind} "
                     f"({_declarer(registry.kinds[slot.kind])}) |")
    for slot, kind in LIST_SLOTS.items():
        lines.append(f"| `{slot}` | a list of components (or one) | {kind} |")
    lines.append("")
    by_kind: dict[str, list[Component]] = {}
    for component in registry:
        by_kind.setdefault(component.kind, []).append(component)
    for kind in registry.kinds.values():
        doc = kind.doc.strip().rstrip(".")
        lines += [f"## {kind.name} ({_where(kind)})", "", f"{doc[0].upper()}{doc[1:]}.", "",
                  f"Declared by {_declarer(kind)}.", ""]
        listed = sorted(by_kind.get(kind.name, []), key=lambda c: c.name)
        if not listed:
            lines += ["No component of this kind is installed.", ""]
        for component in listed:
            lines += _component_section(component)
    return "\n".join(lines).rstrip("\n") + "\n"


def hook_reference() -> str:
    """The hook reference: every hookspec with its signature, kind and contract."""
    lines = ["# Hook reference", "", _markdown(inspect.cleandoc(hookspecs.__doc__ or "")), ""]
    for name in hookspecs.HOOKS:
        function = getattr(hookspecs, name)
        opts = getattr(function, f"{hookspecs.PROJECT}_spec")
        signature = str(inspect.signature(function)).replace("'", "")
        kind = "firstresult" if opts.get("firstresult") else "collect-all"
        lines += [f"## `{name}`", "", "```python", f"def {name}{signature}", "```", "",
                  f"*{kind}*", "", _markdown(inspect.cleandoc(function.__doc__ or "")), ""]
        example = HOOK_EXAMPLES / f"{name}.py"
        if example.is_file():
            lines += [f"Example (`docs/examples/hooks/{name}.py`):", "", "```python",
                      example.read_text(encoding="utf-8").rstrip("\n"), "```", ""]
    return "\n".join(lines).rstrip("\n") + "\n"
