"""The line a command writes on stderr before it compiles kernels that are not cached, and its
progress while it compiles.

A first run compiles the numba kernels it uses (tens of seconds) before its first result; a
command that says nothing meanwhile looks hung. The line is written when numba starts to compile
a kernel missing from the cache (a first run, a deleted cache, a new kernel after an upgrade, new
argument types): numba's own compile event, raised only then, tells it, so a command whose
configuration uses no kernel writes nothing even on an empty cache. While it compiles, a line
when a compile ends ``CBR_PROGRESS_SECONDS`` (:func:`cbrcore.cli.progress.interval`, 10 s
unless set) or more after the last line (a kernel compiles the functions it calls one by one,
so the lines come about that often), and one when the command is done if it compiled anything.
A warm cache writes nothing.

On a machine with no cache folder yet (a first run, a deleted cache) ``cbr run`` and
``cbr experiment`` write the first line at once, before the configuration's components load
(:func:`announce_cold_cache`), since those imports take seconds before the first compile; a
command that then compiles nothing makes the folder, so that a configuration without kernels is
announced once, not at every run.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from cbrcore.cli.progress import interval
from cbrcore.kernel_cache import numba_cache_dir, watching

ABOUT_SECONDS = 30
"""What compiling the kernels of ``configs/hybrid_grid.yaml`` takes on a nearly idle 2-core
machine, in seconds (``benchmarks/cold_start.py`` measures it)."""


class CompileNotice:
    """Writes the first line once, before the first compile, and a progress line at most every
    ``every`` seconds of ``clock`` while kernels compile; a
    :class:`~cbrcore.kernel_cache.CompileWatcher`."""

    def __init__(self, write: Callable[[str], object], *, folder: Path, every: float,
                 clock: Callable[[], float] = time.monotonic, announced: bool = False) -> None:
        self.write = write
        self.folder = folder
        self.every = every
        self.clock = clock
        self.announced = announced
        """Whether the first line was written before this notice began (a cold cache)."""
        self.since: float | None = None
        self.last = 0.0
        self.kernels = 0

    def announce(self) -> None:
        """Write the first line, unless it has been written."""
        if self.since is not None:
            return
        self.since = self.last = self.clock()
        if not self.announced:
            self.write(_first_line(self.folder))

    def started(self, name: str, depth: int) -> None:
        self.announce()

    def finished(self, name: str, depth: int) -> None:
        # nested compiles (the kernels a kernel calls) count as part of the outermost one, but a
        # long outermost compile still gets its lines as they end
        if depth == 1:
            self.kernels += 1
        now = self.clock()
        if now - self.last >= self.every:
            self.last = now
            self.write(f"cbr: compiling kernels: {self.kernels} compiled, "
                       f"{now - (self.since or now):.0f} s\n")

    def done(self) -> None:
        """Write how many kernels compiled and how long it took, when any did."""
        if self.announced and not self.kernels:
            with contextlib.suppress(OSError):  # a cache that cannot be made stays cold
                self.folder.mkdir(parents=True, exist_ok=True)
        if self.since is not None and self.kernels:
            kernels = f"{self.kernels} kernel{'s' if self.kernels > 1 else ''}"
            self.write(f"cbr: compiled {kernels} in {self.clock() - self.since:.0f} s "
                       f"(cached for later runs)\n")


def _first_line(folder: Path) -> str:
    """The line that says kernels compile, and where they are cached."""
    return (f"cbr: compiling the kernels this command uses, once (about {ABOUT_SECONDS} s on 2 "
            f"cores; cached in {folder} for later runs)\n")


def _write(line: str) -> None:
    sys.stderr.write(line)
    sys.stderr.flush()


def announce_cold_cache() -> bool:
    """Write the first line now if the kernel cache folder does not exist; whether it did.

    For a command about to load a configuration: pass the result to
    :func:`announcing_compiles`, which then does not repeat the line.
    """
    folder = numba_cache_dir()
    if folder.exists():
        return False
    _write(_first_line(folder))
    return True


@contextmanager
def announcing_compiles(*, announced: bool = False) -> Iterator[None]:
    """For the duration of the block, say on stderr when kernels are compiled (see the module);
    ``announced``: :func:`announce_cold_cache` wrote the first line already."""
    notice = CompileNotice(_write, folder=numba_cache_dir(), every=interval(),
                           announced=announced)
    with watching(notice):
        yield
    notice.done()
