"""Progress of a long command on stderr: a bar on a terminal, a plain line now and then
elsewhere.

Written to a pipe or a file (a job's log), a bar would be noise or nothing; instead a line such
as ``cbr run: 1200/5000 queries, 34 s`` is written every :data:`EVERY_SECONDS` seconds
(``CBR_PROGRESS_SECONDS`` sets another interval; 0 writes one at every step), and, once a line
has been written, one when the work is done. Work done within the first interval writes none.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from cbrcore.errors import CbrError

EVERY_SECONDS = 10.0
"""How often a plain progress line is written when stderr is not a terminal."""

ENVIRONMENT = "CBR_PROGRESS_SECONDS"
"""The environment variable that sets another interval, in seconds."""


def interval() -> float:
    """The seconds between plain progress lines: ``CBR_PROGRESS_SECONDS`` or
    :data:`EVERY_SECONDS`; a CbrError for a value that is not a number of seconds >= 0."""
    text = os.environ.get(ENVIRONMENT, "").strip()
    if not text:
        return EVERY_SECONDS
    try:
        seconds = float(text)
    except ValueError:
        seconds = -1.0
    if not seconds >= 0 or seconds == float("inf"):
        raise CbrError(f"environment variable {ENVIRONMENT}: expected a number of seconds "
                       f">= 0, such as 10")
    return seconds


class PlainProgress:
    """``progress(done, total)`` that writes ``LABEL: DONE/TOTAL UNIT, S s`` to ``write``
    when ``every`` seconds of ``clock`` have passed since the last line, and when work that
    has had a line is done; None for ``total`` is written as ``DONE UNIT``."""

    def __init__(self, label: str, unit: str, write: Callable[[str], object], *,
                 every: float, clock: Callable[[], float] = time.monotonic) -> None:
        self.label = label
        self.unit = unit
        self.write = write
        self.every = every
        self.clock = clock
        self.started = clock()
        self.last = self.started
        self.written = False

    def __call__(self, done: int, total: int | None) -> None:
        now = self.clock()
        finished = total is not None and done >= total and self.written
        if now - self.last < self.every and not finished:
            return
        self.last = now
        self.written = True
        count = f"{done}/{total}" if total is not None else str(done)
        self.write(f"{self.label}: {count} {self.unit}, {now - self.started:.0f} s\n")


@contextmanager
def progress(label: str, unit: str) -> Iterator[Callable[[int, int], None]]:
    """``progress(done, total)`` for the duration of the block: a transient bar on a terminal
    stderr, :class:`PlainProgress` lines on any other."""
    console = Console(stderr=True, markup=False, emoji=False)
    if not console.is_terminal:
        def write(line: str) -> None:
            sys.stderr.write(line)
            sys.stderr.flush()

        yield PlainProgress(label, unit, write, every=interval())
        return
    bar = Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                   console=console, transient=True)
    task = bar.add_task(label, total=None)
    with bar:
        yield lambda done, total: bar.update(task, completed=done, total=total)
