"""Running an experiment's independent tasks: in this process, on a pool of processes, or on a
Dask distributed cluster.

An experiment that has work to spread (seeds, arms, robots, chunks of queries) hands it to a
:class:`TaskRunner` as a top-level function and a list of plain, picklable arguments::

    for row in task_runner(ctx).map(plan_chunk, chunks, progress=progress):
        ...

``map`` submits every task before it returns, so the caller may go on working while they run,
and yields their results in the order of the items, whatever order they finish in;
``progress(done, total)`` is called with no task done as they are submitted, so that a display
knows the total from the start, then as each task finishes. A large value that many tasks take
(a case graph planned on by every chunk of queries) goes into their items as
``runner.share(value)``, which a cluster sends to each worker once rather than with every task;
``priority`` lets the longest tasks start first. A task must depend on its argument alone (its
randomness drawn from a seed it is given, or by the caller before submitting), which makes the
results the same on every runner, and the same as a serial run's.

The runner reaches the experiment through the run's :class:`~cbrcore.context.Context`: ``cbr
experiment`` stores it under :data:`TASKS` in ``ctx.stash`` and :func:`task_runner` reads it,
:class:`LocalTasks` when none is stored (an experiment run from Python, or by a test). An
experiment that never asks keeps running its own way.

Runners:

:class:`LocalTasks`
    Without ``--scheduler``: in this process one after another, or, where the experiment asks
    for ``processes`` greater than 1, on a pool of that many spawned processes (at most the
    machine's cores).
:class:`DaskTasks`
    ``--scheduler local`` (a ``LocalCluster`` of worker processes with one thread each, as many
    as the machine has cores unless ``workers`` says otherwise, started with
    :data:`LOCAL_CLUSTER_CONFIG`) or ``--scheduler ADDRESS`` (a running ``dask scheduler``).
    distributed is imported only then.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import errno
import logging
import multiprocessing
import os
import re
import socket
import struct
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

from cbrcore.errors import CbrError
from cbrcore.stash import StashKey

if TYPE_CHECKING:
    from cbrcore.context import Context

T = TypeVar("T")
R = TypeVar("R")
Progress = Callable[[int, int], None]

CONNECT_SECONDS = 10
"""How long a scheduler address is tried before the run gives up on it."""

WORKERS_PER_CORE = 4
"""The most worker processes ``--scheduler local`` starts per core of the machine: more only
share the cores, each with its own memory, and a mistyped count would start thousands."""

_ADDRESS = re.compile(r"^(?:(?P<scheme>[a-z][a-z0-9+.-]*)://)?(?P<host>\[[^\]]+\]|[^:/\s]+)"
                      r"(?::(?P<port>\d{1,5}))?$")


_DASK_PORT = 8786
"""The port of a scheduler address that gives none, as Dask's own default."""

MAX_GREETING_BYTES = 1 << 20
"""The most bytes a Dask scheduler's first message (its handshake) may take to be believed; a
scheduler's is about a hundred."""


class TaskRunner(Protocol):
    """Runs independent tasks and gives their results back in order."""

    @property
    def description(self) -> str:
        """Where the tasks run, as a run's manifest records it (``local``, ``dask tcp://...``)."""
        ...

    def map(self, function: Callable[[T], R], items: Iterable[T], *,
            progress: Progress | None = None, processes: int = 1,
            priority: Callable[[T], float] | None = None) -> Iterator[R]:
        """Submit ``function(item)`` for every item now; yield the results in the items' order.

        ``function`` is a top-level function and the items plain picklable values. ``progress``
        is called with (0, tasks) as they are submitted, then with (tasks finished, tasks) as
        tasks finish. ``processes`` is how many
        processes the caller would use on this machine when no scheduler is given (1: in this
        process); a cluster decides for itself. ``priority(item)`` says which tasks start first
        where tasks run side by side: higher first, ties in the items' order. Giving the
        longest tasks the highest keeps a worker from idling at the end while another finishes
        a long one. It changes no result.
        """
        ...

    def share(self, value: T) -> T:
        """``value`` as the items of this runner's :meth:`map` should carry it when several
        tasks take it: the value itself, or on a cluster a reference to one copy of it held by
        every worker, which the worker replaces by the value before a task runs.

        Tasks must leave a shared value as they found it (filling a cache of it is fine): on a
        cluster the tasks of one worker see one copy of it, and a serial run's all see the
        value itself.
        """
        ...


TASKS = StashKey["TaskRunner"]()
"""Where ``cbr experiment`` puts the runner of the run's tasks in ``ctx.stash``."""


def task_runner(ctx: Context) -> TaskRunner:
    """The runner of the run of ``ctx``: the one ``cbr experiment`` chose, else
    :class:`LocalTasks`."""
    return ctx.stash.get(TASKS, LocalTasks())


class LocalTasks:
    """Tasks in this process, or on a pool of spawned processes when ``processes`` > 1."""

    description = "local"

    def map(self, function: Callable[[T], R], items: Iterable[T], *,
            progress: Progress | None = None, processes: int = 1,
            priority: Callable[[T], float] | None = None) -> Iterator[R]:
        work = list(items)
        _submitted(progress, len(work))
        workers = min(processes, os.cpu_count() or 1, len(work))
        if workers <= 1:
            return _serial(function, work, progress)
        # spawn, not fork: a forked child would inherit the parent's threads' locks (numba's,
        # the progress display's) in whatever state they were
        pool = concurrent.futures.ProcessPoolExecutor(
            max_workers=workers, mp_context=multiprocessing.get_context("spawn"))
        # the pool starts tasks in the order they are submitted; sorted() keeps ties in order
        order = (range(len(work)) if priority is None else
                 sorted(range(len(work)), key=lambda k: -priority(work[k])))
        futures: list[Any] = [None] * len(work)
        try:
            for k in order:
                futures[k] = pool.submit(function, work[k])
        except BaseException:
            pool.shutdown(cancel_futures=True)
            raise
        return _closing(_in_order(futures, concurrent.futures.as_completed, progress),
                        lambda: pool.shutdown(cancel_futures=True))

    def share(self, value: T) -> T:
        # in this process the tasks take the value itself; a spawned pool pickles it per task
        return value


class DaskTasks:
    """Tasks on a Dask distributed cluster, through ``client`` (a ``distributed.Client``)."""

    def __init__(self, client: Any, description: str) -> None:
        self.client = client
        self.description = description

    def map(self, function: Callable[[T], R], items: Iterable[T], *,
            progress: Progress | None = None, processes: int = 1,
            priority: Callable[[T], float] | None = None) -> Iterator[R]:
        from distributed import as_completed  # imported only when a sweep asks for Dask

        # pure=False: the tasks' keys are not derived from hashing their arguments, which may
        # be large (a case graph); equal items then also run twice, as they would serially.
        # The scheduler starts the waiting task of highest priority, earliest submitted first
        futures = [self.client.submit(function, item, pure=False,
                                      priority=0 if priority is None else priority(item))
                   for item in items]
        _submitted(progress, len(futures))
        return _closing(_in_order(futures, as_completed, progress),
                        lambda: self.client.cancel(futures))

    def share(self, value: T) -> T:
        # scattered in a list: a value that is itself a list or dict would otherwise be
        # scattered element by element. hash=False: hashing a large object costs what
        # sending it does. A future inside a task's item is replaced by its value on the worker.
        [future] = self.client.scatter([value], broadcast=True, hash=False)
        return future  # type: ignore[no-any-return]


def _submitted(progress: Progress | None, tasks: int) -> None:
    """Tell ``progress`` how many tasks there are as soon as they are known: the results are
    read lazily, and a display would otherwise show no total until the first task finished."""
    if progress is not None:
        progress(0, tasks)


def _serial(function: Callable[[T], R], work: Sequence[T], progress: Progress | None
            ) -> Iterator[R]:
    for done, item in enumerate(work, start=1):
        result = function(item)
        if progress is not None:
            progress(done, len(work))
        yield result


def _in_order(futures: Sequence[Any], as_completed: Callable[[Sequence[Any]], Iterable[Any]],
              progress: Progress | None) -> Iterator[Any]:
    """The futures' results in submission order, ``progress`` told as each one finishes."""
    index = {id(future): k for k, future in enumerate(futures)}
    finished: dict[int, Any] = {}
    following = 0
    for done, future in enumerate(as_completed(futures), start=1):
        # result() raises the task's own exception, with its traceback from the worker
        finished[index[id(future)]] = future.result()
        if progress is not None:
            progress(done, len(futures))
        while following in finished:
            yield finished.pop(following)
            following += 1


def _closing(results: Iterator[R], close: Callable[[], Any]) -> Iterator[R]:
    """``results``, then ``close()`` however the caller stops reading them."""
    try:
        yield from results
    finally:
        close()


@contextlib.contextmanager
def open_tasks(scheduler: str | None = None, *, workers: int | None = None,
               option: str = "--scheduler") -> Iterator[TaskRunner]:
    """The runner for ``scheduler``: None for :class:`LocalTasks`, ``"local"`` for a new
    LocalCluster of ``workers`` processes (default: one per core), else the address of a
    running Dask scheduler. The cluster is shut down, or the client disconnected, on leaving.

    A scheduler that cannot be used, or more than :data:`WORKERS_PER_CORE` workers per core,
    raises :class:`CbrError` naming the option.
    """
    if workers is not None and workers < 1:
        raise CbrError(f"--workers: {workers} is not a number of worker processes; expected "
                       "1 or more")
    most = WORKERS_PER_CORE * (os.cpu_count() or 1)
    if workers is not None and workers > most:
        raise CbrError(f"--workers: {workers} is more than the {most} worker processes this "
                       f"machine may run (the limit, {WORKERS_PER_CORE} per core)")
    if scheduler is None:
        if workers is not None:
            raise CbrError("--workers goes with --scheduler local")
        yield LocalTasks()
        return
    if scheduler == "local":
        with _local_cluster(workers or os.cpu_count() or 1) as runner:
            yield runner
        return
    if workers is not None:
        raise CbrError("--workers goes with --scheduler local; a remote scheduler has the "
                       "workers started on its machines")
    with _remote(scheduler, option) as runner:
        yield runner


def _check_greeting(host: str, port: int, said: str) -> None:
    """Refuse a TCP address whose service does not greet as a Dask scheduler does, within
    :data:`CONNECT_SECONDS`, before distributed connects to it.

    A Dask peer's first message is a handshake in Dask's framing: the byte count of the frames
    and, within it, the number of frames, their lengths and the frames. distributed itself
    trusts the count, and allocates it, whatever service answers: a web server's reply read as
    a count asks for exabytes. The handshake is read here and its framing checked (in the
    machine's byte order, as Dask writes it), the count against :data:`MAX_GREETING_BYTES`
    first; the handshake's content is not interpreted.
    """
    expected = ("expected 'local' or the address of a running Dask scheduler (dask scheduler "
                "prints it)")
    not_dask = (f"{said}: the service there does not speak Dask's protocol (its first message "
                f"is not a Dask handshake); {expected}")
    deadline = time.monotonic() + CONNECT_SECONDS
    try:
        connection = socket.create_connection((host, port), timeout=CONNECT_SECONDS)
    except OSError:  # nothing there yet: distributed retries, and says so when it gives up
        return
    try:
        with connection:
            size = struct.unpack("Q", _receive(connection, 8, deadline))[0]
            if not 16 <= size <= MAX_GREETING_BYTES:
                raise CbrError(not_dask)
            message = _receive(connection, size, deadline)
    except TimeoutError:
        raise CbrError(f"{said}: no Dask scheduler answered within {CONNECT_SECONDS} s (the "
                       f"service there sent no Dask handshake); {expected}") from None
    except OSError:  # closed or reset before a whole handshake
        raise CbrError(not_dask) from None
    count = struct.unpack("Q", message[:8])[0]
    lengths = struct.unpack(f"{count}Q", message[8:8 + 8 * count]) if (
        1 <= count <= (size - 8) // 8) else None
    if lengths is None or 8 + 8 * count + sum(lengths) != size:
        raise CbrError(not_dask)


def _receive(connection: socket.socket, size: int, deadline: float) -> bytes:
    """Exactly ``size`` bytes from ``connection`` by the ``deadline`` (of time.monotonic);
    TimeoutError when it passes, ConnectionResetError when the peer closes first."""
    data = bytearray()
    while len(data) < size:
        connection.settimeout(max(deadline - time.monotonic(), 1e-3))
        chunk = connection.recv(min(size - len(data), 1 << 16))
        if not chunk:
            raise ConnectionResetError(errno.ECONNRESET, "the service closed the connection")
        data += chunk
    return bytes(data)


LOCAL_CLUSTER_CONFIG: dict[str, Any] = {
    # Dask starts its workers with glibc told to hand freed memory back at once, which turns
    # every large numpy allocation of a task into fresh pages: about a tenth more CPU for the
    # experiments' planning. A LocalCluster's workers allocate as a serial run does, and
    # inherit the variable only where the user set it.
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    # What follows watches a cluster for its dashboard, which a run's cluster does not have,
    # and for a person at the console: the workers' sampling profiler, and the scheduler's,
    # nannies' and workers' polls of their event loops, memory and machine. At Dask's
    # intervals they take about a twentieth of a core in this process and in each worker,
    # and wake a worker's event loop, which then takes the interpreter lock from its task,
    # fifty times a second.
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "1s",
}
"""Dask configuration a :func:`open_tasks` LocalCluster is started with: its scheduler here,
and through the nannies its workers."""


@contextlib.contextmanager
def _local_cluster(workers: int) -> Iterator[TaskRunner]:
    import dask.config
    import distributed

    # the nannies read the configuration as the cluster starts and pass it to their workers.
    # No dashboard: it would need a free port and bokeh, and nobody watches a run's cluster
    with dask.config.set(LOCAL_CLUSTER_CONFIG):
        # the scheduler serves its health checks over HTTP even without a dashboard: on any
        # free port, since two clusters on one machine would both ask for 8787 and warn
        cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1,
                                           processes=True, dashboard_address=None,
                                           scheduler_kwargs={"dashboard_address": ":0"},
                                           silence_logs=logging.ERROR)
    with cluster, distributed.Client(cluster) as client:
        yield DaskTasks(client, f"dask LocalCluster of {workers} workers")


@contextlib.contextmanager
def _remote(address: str, option: str) -> Iterator[TaskRunner]:
    written = _ADDRESS.match(address)
    if not written or address.startswith("-"):
        raise CbrError(f"{option} {address!r}: not a scheduler address; expected 'local' or "
                       "the address of a running Dask scheduler, such as tcp://host:8786")
    if written["scheme"] in (None, "tcp"):
        _check_greeting(written["host"].strip("[]"), int(written["port"] or _DASK_PORT),
                        f"{option} {address!r}")
    import distributed

    try:
        client = distributed.Client(address, timeout=CONNECT_SECONDS)
    except ValueError as exc:  # an address distributed cannot parse (an unknown scheme)
        raise CbrError(f"{option} {address!r}: {exc}; expected 'local' or the address of a "
                       "running Dask scheduler, such as tcp://host:8786") from exc
    except (OSError, TimeoutError) as exc:
        raise CbrError(f"{option} {address!r}: no Dask scheduler answered within "
                       f"{CONNECT_SECONDS} s ({type(exc).__name__}: {exc}); expected 'local' or "
                       "the address of a running scheduler (dask scheduler prints it)") from exc
    with client:
        yield DaskTasks(client, f"dask {address}")
