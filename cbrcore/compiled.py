"""The project's jit decorator: numba kernels compiled once and cached in the user's cache folder.

Every compiled kernel of cbrcore and its plugins is decorated with :func:`njit` (``@njit`` or
``@njit(inline="always")``), which is ``numba.njit(cache=True, ...)`` with the cache kept out
of the source tree: an installed package's folder is often not writable, and a checkout should
not fill with machine code. The cache folder is, in order of precedence,

1. ``NUMBA_CACHE_DIR``, numba's own setting, when it is set;
2. ``$CBR_CACHE_DIR/numba`` when ``CBR_CACHE_DIR`` is set;
3. ``numba`` in the user cache folder of cbrcore (``platformdirs.user_cache_dir("cbrcore")``:
   ``~/.cache/cbrcore/numba`` on Linux).

numba chooses where a kernel's cache lives when the kernel is decorated (when its module is
imported), so the folder is read then; a folder that cannot be made falls back to numba's own
choice. Importing this module imports numba: plugin modules import their kernel modules lazily,
so that loading plugins (``cbr --help``, ``cbr plugins``) stays fast.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar, overload

import numba
import platformdirs

F = TypeVar("F", bound=Callable[..., Any])

CACHE_VARIABLE = "CBR_CACHE_DIR"
"""The environment variable that moves cbrcore's cache folder."""


def cache_dir() -> Path:
    """cbrcore's cache folder: ``$CBR_CACHE_DIR``, else the user cache folder of cbrcore."""
    chosen = os.environ.get(CACHE_VARIABLE)
    if chosen:
        return Path(chosen).expanduser()
    return Path(platformdirs.user_cache_dir("cbrcore"))


def numba_cache_dir() -> Path:
    """Where compiled kernels are cached: ``NUMBA_CACHE_DIR`` if set, else ``cache_dir()/numba``."""
    own = os.environ.get("NUMBA_CACHE_DIR")
    return Path(own).expanduser() if own else cache_dir() / "numba"


@overload
def njit(function: F, /) -> F: ...


@overload
def njit(**options: Any) -> Callable[[F], F]: ...


def njit(function: Callable[..., Any] | None = None, /, **options: Any) -> Any:
    """``numba.njit(cache=True, **options)`` caching in :func:`numba_cache_dir`.

    Used bare (``@njit``) or with numba's options (``@njit(inline="always")``).
    """
    if function is None:
        return lambda inner: _compiled(inner, options)
    return _compiled(function, options)


def _compiled(function: Callable[..., Any], options: dict[str, Any]) -> Any:
    # numba reads config.CACHE_DIR once, when the dispatcher is made; it is set only around
    # that moment so that a program's own cached kernels keep numba's choice
    previous = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(numba_cache_dir())
    try:
        return numba.njit(cache=True, **options)(function)
    finally:
        numba.config.CACHE_DIR = previous
