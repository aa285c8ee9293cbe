"""The project's jit decorator: numba kernels compiled once and cached in the user's cache folder.

Every compiled kernel of the plugins is decorated with :func:`njit` (``@njit`` or
``@njit(inline="always")``), which is ``numba.njit(cache=True, ...)`` with the cache kept out
of the source tree: an installed package's folder is often not writable, and a checkout should
not fill with machine code. The cache folder is :func:`cbrcore.kernel_cache.numba_cache_dir`.

numba chooses where a kernel's cache lives when the kernel is decorated (when its module is
imported), so the folder is read then; a folder that cannot be made falls back to numba's own
choice. Every compile numba makes (a cache miss) is reported to the watchers of
:mod:`cbrcore.kernel_cache`. Importing this package imports numba, which cbrcore itself never
does: plugin modules import their kernel modules lazily, so that loading plugins (``cbr --help``,
``cbr plugins``) stays fast.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar, overload

import numba

from cbrcore.kernel_cache import numba_cache_dir, watchers

F = TypeVar("F", bound=Callable[..., Any])


class _CompileEvents(numba.core.event.Listener):
    """Forwards numba's compile events, raised only when a kernel is not in the cache, to the
    watchers of :mod:`cbrcore.kernel_cache`, with how deeply the compile is nested."""

    def __init__(self) -> None:
        self.depth = 0

    def on_start(self, event: numba.core.event.Event) -> None:
        self.depth += 1
        for watcher in watchers():
            watcher.started(_name(event), self.depth)

    def on_end(self, event: numba.core.event.Event) -> None:
        try:
            for watcher in watchers():
                watcher.finished(_name(event), self.depth)
        finally:
            self.depth -= 1


def _name(event: numba.core.event.Event) -> str:
    function = event.data["dispatcher"].py_func
    return f"{function.__module__}.{function.__qualname__}"


numba.core.event.register("numba:compile", _CompileEvents())


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
