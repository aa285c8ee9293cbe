"""Attributes of a package imported when first asked for.

A plugin's ``__init__`` is imported at every start of ``cbr``; naming what the package exports
without importing the modules that define them keeps NumPy and the map formats out of commands
that do not use them.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, where: Mapping[str, str],
                 namespace: dict[str, Any]) -> Callable[[str], Any]:
    """A module ``__getattr__`` for ``package``: each name of ``where`` is taken from the module
    ``where`` maps it to when first asked for, and kept in ``namespace`` (the package's
    ``globals()``) so that later lookups do not come back here."""

    def __getattr__(name: str) -> Any:
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value

    return __getattr__
