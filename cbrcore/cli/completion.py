"""Shell completion of the names ``cbr`` takes: experiments, and ``--set`` keys and components.

Each function is a typer ``autocompletion`` callback: it gets the word being completed and
returns ``(value, help)`` pairs, read from the registry of the loaded plugins, so a plugin's
experiments and components complete as the built-in ones do. ``cbr --install-completion``
installs the shell's side.
"""

from __future__ import annotations

from cbrcore.plugins import current
from cbrcore.registry import LIST_SLOTS, SINGLE_SLOTS, Registry


def experiment_names(incomplete: str) -> list[tuple[str, str]]:
    """The registered experiments whose name starts with ``incomplete``, with their summaries."""
    return [(c.name, c.summary) for c in current().registry
            if c.kind == "experiment" and c.name.startswith(incomplete)]


def _slots(registry: Registry) -> dict[str, str]:
    """Every component slot of a configuration and the kind it takes."""
    return {**SINGLE_SLOTS, **LIST_SLOTS,
            **{name: slot.kind for name, slot in registry.slots.items()}}


def settings(incomplete: str) -> list[tuple[str, str]]:
    """``--set`` values: a top-level key (``retrieve=``) while the key is being written, then
    the registered components of the slot's kind (``retrieve=nearest``); ``SLOT.use=`` takes
    them too."""
    registry = current().registry
    slots = _slots(registry)
    key, sep, value = incomplete.partition("=")
    if not sep:
        keys = [("seed=", "the seed of every random choice"),
                *((f"{slot}=", f"a {kind}") for slot, kind in slots.items())]
        return sorted(item for item in keys if item[0].startswith(incomplete))
    kind = slots.get(key.removesuffix(".use"))
    if kind is None or (key.endswith(".use") and key.removesuffix(".use") in LIST_SLOTS):
        return []
    return [(f"{key}={c.name}", c.summary) for c in registry
            if c.kind == kind and c.name.startswith(value)]
