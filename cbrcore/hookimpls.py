"""Which cbrcore hooks an object implements, and which of its implementations name no hook.

pluggy registers an implementation whose name no specification knows without a word (it may be
meant for a specification added later), so a misspelt ``cbr_registr`` would never be called and
nobody would know; plugin loading and the engine ask :func:`unknown_hooks` instead.
"""

from __future__ import annotations

import difflib
import inspect
from collections.abc import Iterator
from typing import Any

from cbrcore import hookspecs

HOOKS = hookspecs.HOOKS
"""The name of every cbrcore hook."""


def _marked(obj: Any) -> Iterator[tuple[str, str | None]]:
    """``(attribute, hook)`` for each routine of ``obj``; ``hook`` is the hook a ``@hookimpl``
    marker makes it implement (``specname`` or the attribute's name), None when unmarked."""
    marker = f"{hookspecs.PROJECT}_impl"
    for name in dir(obj):
        value = getattr(obj, name, None)  # as pluggy looks for implementations
        if inspect.isroutine(value):
            opts = getattr(value, marker, None)
            yield name, (opts.get("specname") or name) if isinstance(opts, dict) else None


def implemented_hooks(obj: Any) -> tuple[str, ...]:
    """The hooks that ``obj`` (a module, class or instance) marks implementations of."""
    return tuple(sorted({hook for _, hook in _marked(obj) if hook is not None}))


def unknown_hooks(obj: Any) -> list[str]:
    """What is wrong with the hook implementations of ``obj`` (a module, class or instance).

    One message for each ``@hookimpl`` whose hook cbrcore does not have (``cbr_registr``,
    suggesting ``cbr_register``), and for each routine named exactly like a cbrcore hook but
    not marked with ``@hookimpl``, which pluggy would never call. Empty when all is well.
    """
    problems = []
    for name, hook in _marked(obj):
        if hook is None and name in HOOKS:
            problems.append(f"{name} is not marked with @hookimpl, so it is never called")
        elif hook is not None and hook not in HOOKS:
            mark = "@hookimpl" if hook == name else f"@hookimpl(specname={hook!r})"
            # without the shared prefix, which would make every cbr_ name look close
            stems = {known.removeprefix("cbr_"): known for known in HOOKS}
            close = difflib.get_close_matches(hook.removeprefix("cbr_"), stems, n=1)
            hint = (f"did you mean {stems[close[0]]}?" if close
                    else f"the hooks: {', '.join(HOOKS)}")
            problems.append(f"{name} is marked with {mark} but names no cbrcore hook; {hint}")
    return problems
