"""Warming components up in two processes while the kernel cache is empty.

A first run compiles every kernel its components use while they warm up (``cbr_warm``), one
component after the other, on one core. When the engine is built on an empty cache folder
(:func:`cbrcore.kernel_cache.holds_no_kernels`), :func:`warm_in_turn` forks a helper process
that warms components too: the engine takes them from the end of the list, the helper from its
start, one at a time, so each compiles about half, and numba's cache on disk receives what both
compiled. Once it has no component left, the engine waits for the helper and then warms the
helper's components itself: that loads their kernels from the cache, and compiles whatever the
helper left out (a helper that failed, crashed or was killed costs time, never a result). The
components' state is the engine's own, as after a warm-up in one process.

The helper writes nothing on stdout or stderr and leaves with ``os._exit``, so it runs no exit
handler and flushes no file of the engine's process. It is forked only where that is safe:
on Linux, from a process running a single thread; elsewhere the components warm up in turn in
the engine's process.
"""

from __future__ import annotations

import os
import signal
import struct
import sys
import tempfile
import threading
from collections.abc import Callable, Sequence

if sys.platform != "win32":  # used only where can_fork() holds
    import fcntl

_COUNTS = struct.Struct("qq")


def can_fork() -> bool:
    """Whether a helper process may be forked here: Linux, and a single thread running."""
    return sys.platform.startswith("linux") and threading.active_count() == 1


class _Ends:
    """How many of ``count`` jobs were taken from the front and from the back of the list, in a
    file that a forked process shares. Each take holds a POSIX record lock on the file, which
    the two processes hold in turn and which a process that dies gives back."""

    def __init__(self, count: int) -> None:
        self.count = count
        self._file = tempfile.TemporaryFile()  # noqa: SIM115 - closed by close()
        os.pwrite(self._file.fileno(), _COUNTS.pack(0, 0), 0)

    def take(self, *, front: bool) -> int | None:
        """The index of the next job from that end, or None when every job is taken."""
        fd = self._file.fileno()
        fcntl.lockf(fd, fcntl.LOCK_EX)
        try:
            taken_front, taken_back = _COUNTS.unpack(os.pread(fd, _COUNTS.size, 0))
            if taken_front + taken_back >= self.count:
                return None
            if front:
                os.pwrite(fd, _COUNTS.pack(taken_front + 1, taken_back), 0)
                return taken_front
            os.pwrite(fd, _COUNTS.pack(taken_front, taken_back + 1), 0)
            return self.count - 1 - taken_back
        finally:
            fcntl.lockf(fd, fcntl.LOCK_UN)

    def front(self) -> int:
        """How many jobs were taken from the front (once the helper is gone)."""
        return _COUNTS.unpack(os.pread(self._file.fileno(), _COUNTS.size, 0))[0]

    def close(self) -> None:
        self._file.close()


def warm_in_turn(jobs: Sequence[Callable[[], None]], *, helper: bool) -> None:
    """Run every job in this process, with a forked helper running some first when ``helper``
    (and :func:`can_fork`, and more than one job) allows; see the module. A job's exception in
    this process propagates; the helper's are dropped, since the job runs here again."""
    if not helper or len(jobs) < 2 or not can_fork():
        for job in jobs:
            job()
        return
    ends = _Ends(len(jobs))
    for stream in (sys.stdout, sys.stderr):  # what is buffered is written once, by this process
        stream.flush()
    pid = os.fork()
    if pid == 0:
        _help(jobs, ends)
    try:
        while (index := ends.take(front=False)) is not None:
            jobs[index]()
    except BaseException:  # an error or an interrupt: the helper's work is not wanted now
        os.kill(pid, signal.SIGKILL)
        raise
    finally:
        _reap(pid)
        taken = ends.front()
        ends.close()
    for index in range(taken):
        jobs[index]()


def _reap(pid: int) -> None:
    """Wait for the helper to leave; one interrupted while it waits kills it."""
    try:
        os.waitpid(pid, 0)
    except BaseException:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        raise


def _help(jobs: Sequence[Callable[[], None]], ends: _Ends) -> None:
    """The helper process: take jobs from the front until none is left, then leave."""
    code = 1
    try:
        # an interrupt is the engine's to handle: it kills the helper
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        # silent at both levels: sys.stdout may be another object than file descriptor 1
        quiet = open(os.devnull, "w")  # noqa: SIM115 - open until the process leaves
        os.dup2(quiet.fileno(), 1)
        os.dup2(quiet.fileno(), 2)
        sys.stdout = sys.stderr = quiet
        while (index := ends.take(front=True)) is not None:
            jobs[index]()
        code = 0
    finally:  # whatever went wrong, the engine runs the job again and reports it
        os._exit(code)
