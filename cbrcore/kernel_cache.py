"""Where compiled kernels are cached, and who is told when kernels are compiled; without
importing numba, so that a command can listen before it loads any kernel.

The cache folder is, in order of precedence,

1. ``NUMBA_CACHE_DIR``, numba's own setting, when it is set;
2. ``$CBR_CACHE_DIR/numba`` when ``CBR_CACHE_DIR`` is set;
3. ``numba`` in the user cache folder of cbrcore (``platformdirs.user_cache_dir("cbrcore")``:
   ``~/.cache/cbrcore/numba`` on Linux).

A kernel that numba compiles (one not in the cache, or not for these argument types) is reported
to every watcher registered with :func:`watching`: :mod:`cbr_kernels` forwards numba's own
compile events, which numba raises only on a cache miss, so a warm cache reports nothing.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Protocol

import platformdirs

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


def holds_no_kernels() -> bool:
    """Whether the cache folder holds no compiled kernel yet (it may not exist): a first run, or
    a cache deleted since; the engine then warms its components up in two processes
    (:mod:`cbrcore.warm_split`)."""
    try:
        return not any(numba_cache_dir().rglob("*.nbi"))
    except OSError:  # a folder that cannot be read compiles as it would without a helper
        return False


class CompileWatcher(Protocol):
    """Told when numba compiles: ``started`` before a kernel compiles, ``finished`` after, both
    for the kernels and functions it compiles on the way (``depth`` 1 is the outermost)."""

    def started(self, name: str, depth: int) -> None: ...

    def finished(self, name: str, depth: int) -> None: ...


_watchers: list[CompileWatcher] = []


def watchers() -> tuple[CompileWatcher, ...]:
    """The watchers registered now."""
    return tuple(_watchers)


@contextmanager
def watching(watcher: CompileWatcher) -> Iterator[None]:
    """Tell ``watcher`` of every compile for the duration of the block."""
    _watchers.append(watcher)
    try:
        yield
    finally:
        _watchers.remove(watcher)
