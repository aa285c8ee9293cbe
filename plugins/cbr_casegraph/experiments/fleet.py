"""A fleet sharing one case base (``cbr experiment fleet``).

N robots, each a process of its own, drive trips on one map and learn into ONE case base at the
same time; against them, N robots each learning into a case base of its own. Every robot runs the
hybrid planner of ``configs/hybrid_grid.yaml`` (the case graph with ``delta`` 8, the
``path_quality`` reviser, A* as the fallback solver) on a generated office, the map the robot
knows being the world it drives in, so that a trip's retained path is the path it was given. The
experiment reports, for each store, fleet size and mode:

- the CBR share and the cost deviation from A*'s optimum against the total trips the fleet drove;
- the catch-ups (how often a robot found that another robot had committed and brought its views
  of the case base up to date: the store mirror's ``catch_ups``), the views reloaded in full
  instead (the mirror's ``reloads``) and the conflicts retried (none: a learn step holds
  the store's write lock from its first read to its commit, so steps wait, never redo);
- the throughput: learn steps per second of wall time from the moment every robot is ready to
  the moment the last one finishes;
- the integrity of the case base: every robot records each learn step it committed, together
  with the store revision the step read. At the end the store must hold a count of committed
  steps per robot equal to the robot's own, every step of every retained path must lie on a
  segment of the stored case graph, the store's and the families' checks must pass, and
  replaying the retained paths in commit order into a fresh single-process case graph must give
  the same graph (the same vertices and the same segments).

A further fleet of :data:`STALL_ROBOTS` robots (case base ``frozen``) shares its case base with a
stalled learner: a process that takes the write lock as a learn step does and is then frozen
with ``SIGSTOP``, until each robot has skipped :data:`STALL_SKIPS` learn steps. The robots wait
:data:`STALL_LOCK_SECONDS` for the lock, skip the step, keep it and learn it once the learner is
let go (:meth:`cbrcore.engine.Engine.learn`); the row counts the skipped steps, and its audit
shows that none was lost.

Learning is retaining and the ``redundant_vertices`` forgetter only: forgetting by risk or by a
vertex limit removes cases by design, and a lost write could not be told from a forgotten case.
Each learn step also counts itself in the case base's meta data (the experiment's own
``fleet_journal`` retainer, registered only in the robots' processes), so that every step writes
and commits at its own revision: the revisions the steps read order them as they committed.

Stores: SQLite always; PostgreSQL (the ``postgres`` store) when the standard libpq environment
variables name a server (``PGHOST``, ``PGPORT``, ``PGDATABASE``, ``PGUSER``, ``PGPASSWORD``,
``PGSERVICE``...). Each fleet learns into schemas of its own there; results.json says why the
PostgreSQL rows are absent when they are.
"""

from __future__ import annotations

import json
import multiprocessing
import multiprocessing.connection
import os
import signal
import tempfile
import threading
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, ClassVar

import attrs
import numpy as np

from cbr_casegraph.experiments.common import Progress, fmt
from cbr_casegraph.geometry import segments_cells
from cbr_casegraph.graph import CaseGraph
from cbr_experiments.experiment import ExperimentResult, Size
from cbr_grid.query import without_loops
from cbrcore import files
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.errors import CbrError
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Outcome, Proposal
from cbrcore.options import option, structure_options
from cbrcore.plugins import Plugins, current, load_plugins
from cbrcore.registry import Registry

JOURNAL = "fleet_journal"
"""The retainer that counts each learn step of a robot in the case base's meta data."""

DELTA = 8
MAX_RATIO = 1.5
BINS = 20
"""Bins of total trips the share and deviation curves are averaged over."""

SHARE_MARK = 0.8
"""The CBR share whose reaching the table reports (:func:`first_reaching`)."""

WINDOW = 10
"""The fewest trips a share is taken over when it is said to be reached."""

READY_SECONDS = 600.0
"""How long the robots may take to start (import, build and warm their engines)."""

LOCK_SECONDS = 300.0
"""How long a robot waits for the write lock of a shared case base: with 8 robots, each step
catching up with the others', a turn can take seconds, longer than the stores' default."""

STALL_ROBOTS = 2
"""The robots of the ``frozen`` fleet, which learn into one case base beside a stalled learner."""

STALL_LOCK_SECONDS = 0.2
"""How long a robot of the ``frozen`` fleet waits for the write lock before skipping a learn
step: short, so that the stalled learner costs each robot little time per step."""

STALL_SKIPS = 3
"""The learn steps each robot of the ``frozen`` fleet skips before the stalled learner is let go
(fewer when the robot drives fewer trips)."""

DONE = 2**31 - 1
"""What a robot sets its count of skipped steps to once it has driven every trip."""

PG_VARIABLES = ("PGHOST", "PGHOSTADDR", "PGPORT", "PGDATABASE", "PGUSER", "PGPASSWORD",
                "PGSERVICE")
"""libpq's environment variables that name a PostgreSQL server and how to reach it."""


@attrs.frozen
class Scale:
    side: int
    """The side of the square office, in cells."""
    fleets: tuple[int, ...]
    """The fleet sizes N."""
    trips: int
    """Trips driven by each fleet in total, split evenly among its robots."""


SCALES: dict[str, Scale] = {"ci": Scale(48, (1, 2), 120),
                            "full": Scale(100, (1, 2, 4, 8), 10000)}


# -- the robots' side ---------------------------------------------------------------------------


def journal_key(robot: int) -> str:
    """The meta key counting the learn steps robot ``robot`` committed."""
    return f"fleet.robot.{robot}"


@attrs.frozen
class JournalOptions:
    robot: int = option(doc="The robot's number in its fleet.",
                         validator=attrs.validators.ge(0))


class Journal:
    """Counts the robot's learn step in the case base and notes the revision the step read.

    It runs inside the learn step's transaction, with the store's write lock held: the revision
    it reads is the one the step commits after, and its own write makes every step commit a
    revision of its own.
    """

    def __init__(self, options: JournalOptions, ctx: Context) -> None:
        self.key = journal_key(options.robot)
        self.read: int | None = None

    @hookimpl
    def cbr_retain(self, casebase: CaseStore) -> None:
        self.read = casebase.revision
        steps = casebase.get_meta(self.key, 0)
        casebase.set_meta(self.key, (steps if isinstance(steps, int) else 0) + 1)


class JournalPlugin:
    """The plugin registering :class:`Journal`; loaded in the robots' processes only."""

    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("retainer", JOURNAL, Journal, options=JournalOptions)


@attrs.frozen
class RobotJob:
    """What one robot process is told: its number, its case base, the map and its trips."""

    robot: int
    casebase: dict[str, Any]
    side: int
    seed: int
    trips: int
    log: str
    """The JSON file the robot writes its account into."""


def robot_config(job: RobotJob) -> dict[str, Any]:
    """The robot's configuration: configs/hybrid_grid.yaml learning without forgetting by
    risk or by a vertex limit, on a map without unknown obstacles."""
    return {
        "seed": job.seed,
        "world": {"use": "generated", "kind": "office", "width": job.side,
                  "height": job.side},
        "casebase": job.casebase,
        # every robot drives its own trips: the workload's seed differs, the map's does not
        "workload": {"use": "trips", "count": job.trips, "seed": job.seed * 1000 + job.robot},
        "retrieve": {"use": "casegraph", "delta": DELTA},
        "reuse": {"use": "casegraph", "connector": "dijkstra"},
        "revise": {"use": "path_quality", "ideal": "landmarks", "max_ratio": MAX_RATIO},
        "solver": "astar",
        "retain": ["casegraph", {"use": JOURNAL, "robot": job.robot}],
        "forget": ["redundant_vertices"],
        "metrics": ["path_quality"],
    }


def drive(job: RobotJob, ready: Any, skipped: Any = None) -> None:
    """A robot process: build the engine, wait for the fleet, drive and learn, write the log.

    The log holds, per committed learn step in the order committed, the revision the step read,
    whether the case base planned the trip, the cost deviation from A*'s optimum and the path
    retained (None when the trip failed); a robot that fails writes why instead. A learn step
    that waits out the store's ``busy_timeout`` is skipped and retried by the engine
    (:meth:`~cbrcore.engine.Engine.learn`); the robot counts its skipped steps in
    ``skipped[robot]`` when given (the shared array a stalled learner's release waits on, set
    to :data:`DONE` once the robot has driven every trip), and retries the steps still
    skipped at the end until every one is learned.
    """
    try:
        plugins = load_plugins(extra=[("fleet", JournalPlugin())])
        with Engine.from_dict(robot_config(job), plugins=plugins) as engine:
            journal: Journal = engine.components["retain.1"]
            ready.wait(READY_SECONDS)
            started = time.time()
            trips: list[dict[str, Any]] = []

            def committed(proposal: Proposal, outcome: Outcome, deviation: Any
                          ) -> Callable[[dict[str, float]], None]:
                solution = outcome.solution or proposal.solution

                def record(timings: dict[str, float]) -> None:
                    trips.append({"read": journal.read, "cbr": proposal.from_casebase,
                                  "deviation": deviation, "learn_seconds": timings["learn"],
                                  "path": (solution.value if outcome.success
                                           and solution is not None else None)})

                return record

            for problem in engine.workload.queries(engine.ctx):
                proposal = engine.solve(problem)
                outcome = engine.workload.execute(problem, proposal, engine.ctx)
                deviation = engine.measure(problem, proposal, outcome).get("deviation")
                engine.learn(problem, proposal, outcome,
                             then=committed(proposal, outcome, deviation))
                if skipped is not None:
                    skipped[job.robot] = engine.stats.learn_skipped
            if skipped is not None:
                skipped[job.robot] = DONE
            # a robot's account is complete only when every step it drove is in the store
            while engine.retry_skipped():
                pass
            account = {"robot": job.robot, "started": started, "finished": time.time(),
                       "catch_ups": engine.ctx.mirror.catch_ups,
                       "reloads": engine.ctx.mirror.reloads,
                       "learn_skipped": engine.stats.learn_skipped, "trips": trips}
    except BaseException as exc:
        account = {"robot": job.robot, "error": f"{type(exc).__name__}: {exc}",
                   "traceback": traceback.format_exc()}
        files.write_text(Path(job.log), json.dumps(account))
        raise
    files.write_text(Path(job.log), json.dumps(account))


# -- the fleet's side ---------------------------------------------------------------------------


@attrs.frozen
class Store:
    """A store the fleets learn into: its name and how to configure one case base in it."""

    name: str
    casebase: Callable[[str], dict[str, Any]]
    """The ``casebase`` configuration of the case base named by the given label."""


def postgres_dsn(environ: Mapping[str, str]) -> str | None:
    """The DSN of the PostgreSQL server the environment names, or None when it names none:
    libpq reads the variables itself, so the DSN is empty."""
    return "" if any(environ.get(name) for name in PG_VARIABLES) else None


def hold_lock(casebase: dict[str, Any], seed: int, locked: Any, release: Any) -> None:
    """The stalled learner's process: take the case base's write lock as a learn step does (an
    open write transaction), say so, and hold it until released; it commits nothing."""
    plugins = load_plugins()
    component = plugins.registry.get("store", casebase["use"])
    options = structure_options(component.options,
                                {k: v for k, v in casebase.items() if k != "use"}, "casebase")
    store = component.factory(options, Context(registry=plugins.registry, seed=seed))
    try:
        with store.transaction():
            locked.set()
            release.wait(READY_SECONDS)
    finally:
        store.close()


class Stall:
    """A learner that takes the case base's write lock and is then frozen (``SIGSTOP``), as a
    process stopped by a debugger or a machine that stopped answering would be, until every
    robot has skipped :data:`STALL_SKIPS` learn steps or driven all its trips."""

    def __init__(self, casebase: dict[str, Any], seed: int, robots: int) -> None:
        spawn = multiprocessing.get_context("spawn")
        self.locked, self.release = spawn.Event(), spawn.Event()
        self.skipped = spawn.Array("i", robots)
        self.process = spawn.Process(target=hold_lock, daemon=True,
                                     args=(casebase, seed, self.locked, self.release))
        self.frozen_seconds = 0.0

    def start(self) -> None:
        """Start the learner and freeze it once it holds the lock."""
        self.process.start()
        if not self.locked.wait(READY_SECONDS):
            self.process.kill()
            raise CbrError("experiment 'fleet': the stalled learner never got the write lock")
        os.kill(self.process.pid, signal.SIGSTOP)

    def watch(self, ready: Any, wanted: Sequence[int]) -> None:
        """Wait for the fleet to start, then for each robot to skip ``wanted`` steps, then let
        the learner go (at once if the fleet failed to start)."""
        try:
            ready.wait(READY_SECONDS)
            began = time.perf_counter()
            while any(self.skipped[robot] < least for robot, least in enumerate(wanted)):
                if self.release.is_set() or time.perf_counter() - began > READY_SECONDS:
                    break  # a robot failed, or never got as far
                time.sleep(0.01)
            self.frozen_seconds = time.perf_counter() - began
        except threading.BrokenBarrierError:
            pass
        finally:
            self.resume()

    def resume(self) -> None:
        """Let the learner go: it ends its transaction, committing nothing, and exits."""
        if self.process.pid is not None and self.process.exitcode is None:
            os.kill(self.process.pid, signal.SIGCONT)
        self.release.set()
        self.process.join(READY_SECONDS)


def run_fleet(jobs: Sequence[RobotJob], stall: Stall | None = None) -> list[dict[str, Any]]:
    """Start a robot process per job, let them drive together and return their accounts.

    The wall time of the learning phase runs from the moment every robot is ready. With a
    ``stall``, its learner holds the case base's lock, frozen, from before the robots start
    until they have skipped some learn steps. A CbrError names a robot that failed, with its
    error.
    """
    spawn = multiprocessing.get_context("spawn")
    ready = spawn.Barrier(len(jobs) + (stall is not None))
    shared = stall.skipped if stall is not None else None
    robots = [spawn.Process(target=drive, args=(job, ready, shared), daemon=True)
              for job in jobs]
    watcher = None
    if stall is not None:
        stall.start()
        wanted = [min(STALL_SKIPS, job.trips) for job in jobs]
        watcher = threading.Thread(target=stall.watch, args=(ready, wanted), daemon=True)
        watcher.start()
    for robot in robots:
        robot.start()
    running = {robot.sentinel: robot for robot in robots}
    while running:
        for sentinel in multiprocessing.connection.wait(list(running)):
            ended = running.pop(sentinel)
            ended.join()
            if ended.exitcode != 0:
                # a robot that died before the start would leave the others waiting for it,
                # and one that died later would keep the stalled learner frozen
                ready.abort()
                if stall is not None:
                    stall.resume()
    if stall is not None and watcher is not None:
        watcher.join()
    accounts = []
    for job, robot in zip(jobs, robots, strict=True):
        log = Path(job.log)
        account = json.loads(log.read_text(encoding="utf-8")) if log.exists() else None
        if account is None or "error" in account:
            why = ("it wrote no account" if account is None
                   else f"{account['error']}\n{account['traceback']}")
            raise CbrError(f"experiment 'fleet': robot {job.robot} of {len(jobs)} failed "
                           f"(exit code {robot.exitcode}): {why}")
        accounts.append(account)
    return accounts


def graph_steps(graph: CaseGraph) -> np.ndarray:
    """The steps between neighbouring cells along the graph's segments, as sorted pair keys."""
    a, b = graph.ends(graph.edge_ids())
    cells, offsets = segments_cells(a, b)
    flat = cells[:, 1] * graph.grid.width + cells[:, 0]
    inner = np.ones(len(flat) - 1 if len(flat) else 0, dtype=bool)
    inner[offsets[1:-1] - 1] = False  # no step from one segment's last cell to the next's first
    return step_keys(flat, inner, graph.grid.risk.size)


def step_keys(flat: np.ndarray, keep: np.ndarray, cells: int) -> np.ndarray:
    first, second = flat[:-1][keep], flat[1:][keep]
    return np.minimum(first, second) * cells + np.maximum(first, second)


def path_steps(paths: Sequence[Sequence[Sequence[int]]], width: int, cells: int) -> np.ndarray:
    """The steps of the paths, as :func:`graph_steps` keys them."""
    keys = []
    for path in paths:
        xy = without_loops(path)
        flat = xy[:, 1] * width + xy[:, 0]
        keys.append(step_keys(flat, np.ones(max(len(flat) - 1, 0), dtype=bool), cells))
    return np.concatenate(keys) if keys else np.zeros(0, dtype=np.int64)


def structure(graph: CaseGraph) -> tuple[set[tuple[int, int]], set[frozenset[tuple[int, int]]]]:
    """The graph's vertices (cells) and segments (pairs of end cells)."""
    vertices = {(int(x), int(y)) for x, y in graph.vertices()}
    a, b = graph.ends(graph.edge_ids())
    segments = {frozenset(((int(p[0]), int(p[1])), (int(q[0]), int(q[1]))))
                for p, q in zip(a, b, strict=True)}
    return vertices, segments


def replayed(grid: Any, steps: Sequence[dict[str, Any]]) -> CaseGraph:
    """A fresh graph that learned ``steps`` (in the order given) as one robot's learn steps do:
    the path retained, then the redundant vertices merged."""
    graph = CaseGraph(grid)
    for step in steps:
        if step["path"] is not None and len(step["path"]) > 1:
            graph.add_path(step["path"])
        graph.merge_redundant()
    return graph


def audit(store: CaseStore, grid: Any, accounts: Sequence[dict[str, Any]],
          plugins: Plugins) -> dict[str, Any]:
    """What the case base holds against what the robots learning into it committed."""
    steps = sorted((step for account in accounts for step in account["trips"]),
                   key=lambda step: step["read"])
    reads = [step["read"] for step in steps]
    lost_steps = 0
    for account in accounts:
        stored = store.get_meta(journal_key(account["robot"]), 0)
        lost_steps += len(account["trips"]) - (stored if isinstance(stored, int) else 0)
    graph = CaseGraph.load(grid, store)
    retained = [step["path"] for step in steps if step["path"] is not None]
    uncovered = np.setdiff1d(path_steps(retained, grid.width, graph.grid.risk.size),
                             graph_steps(graph))
    problems = list(store.check())
    for found in plugins.pm.hook.cbr_check_casebase(casebase=store):
        problems.extend(found or ())
    vertices, segments = structure(graph)
    again = structure(replayed(grid, steps))
    return {"learn_steps": len(steps), "lost_steps": lost_steps,
            "distinct_revisions": len(set(reads)), "uncovered_steps": len(uncovered),
            "check_problems": problems, "vertices": len(vertices), "segments": len(segments),
            "replay_vertices_equal": vertices == again[0],
            "replay_segments_equal": segments == again[1]}


def curve(ordered: Sequence[dict[str, Any]], bins: int = BINS) -> list[dict[str, Any]]:
    """The CBR share and the mean cost deviation in at most ``bins`` bins of the trips in the
    order driven, each at the total trips driven by its end.

    The bins grow geometrically, as the share does most of its growing in the first trips.
    """
    edges = np.unique(np.geomspace(1, len(ordered), bins + 1).round().astype(int)) if (
        ordered) else np.zeros(1, dtype=int)
    rows = []
    for first, last in zip([0, *edges[:-1].tolist()], edges.tolist(), strict=True):
        trips = ordered[first:last]
        if not trips:
            continue
        deviations = [t["deviation"] for t in trips
                      if t["deviation"] is not None and np.isfinite(t["deviation"])]
        rows.append({"trips": last,
                     "cbr_share": sum(t["cbr"] for t in trips) / len(trips),
                     "deviation": float(np.mean(deviations)) if deviations else None})
    return rows


def first_reaching(ordered: Sequence[dict[str, Any]], share: float, least: int = WINDOW
                   ) -> int | None:
    """The fewest total trips T after which the trips in (T/2, T], at least ``least`` of them,
    were planned by CBR in a share of ``share`` or more; None if the trips never got there.

    A window of the later half is as long as the experience behind it, so one lucky trip early
    on does not count as reaching the share.
    """
    done = np.concatenate([[0], np.cumsum([bool(t["cbr"]) for t in ordered])])
    total = np.arange(1, len(ordered) + 1)
    half = total // 2
    window = total - half
    reached = np.flatnonzero((window >= least)
                             & ((done[total] - done[half]) >= share * window))
    return int(total[reached[0]]) if len(reached) else None


class Fleet:
    """N robots learning into one case base at once, against N robots with one each."""

    SCALES: ClassVar[dict[str, Scale]] = SCALES

    def __init__(self, options: object, ctx: Context) -> None:
        self.seed = ctx.seed
        self.plugins = current()
        self.registry = ctx.registry

    def stores(self, folder: Path, environ: Mapping[str, str]) -> tuple[list[Store], str | None]:
        """SQLite, and PostgreSQL when the environment names a server; why it is left out
        when it is."""
        stores = [Store("sqlite", lambda label: {"use": "sqlite",
                                                 "path": str(folder / f"{label}.sqlite"),
                                                 "busy_timeout": LOCK_SECONDS})]
        dsn = postgres_dsn(environ)
        if dsn is None:
            return stores, ("no PostgreSQL server named: set the libpq environment variables "
                            f"({', '.join(PG_VARIABLES[:5])}, ...) to include it")
        if "postgres" not in {c.name for c in self.registry if c.kind == "store"}:
            return stores, "no plugin registers the 'postgres' store"
        run = f"cbr_fleet_{os.getpid()}_{int(time.time())}"
        # a schema name is an identifier: no hyphens
        stores.append(Store("postgres", lambda label: {
            "use": "postgres", "dsn": dsn, "schema": f"{run}_{label.replace('-', '_')}",
            "busy_timeout": LOCK_SECONDS}))
        return stores, None

    def grid(self, side: int) -> Any:
        """The robots' map, made by the world component they configure."""
        component = self.registry.get("world", "generated")
        ctx = Context(registry=self.registry, seed=self.seed)
        return component.factory(component.options(kind="office", width=side, height=side), ctx)

    def open_store(self, casebase: dict[str, Any]) -> CaseStore:
        """The case base ``casebase`` configures, opened as a robot's engine opens it."""
        options = dict(casebase)
        component = self.registry.get("store", options.pop("use"))
        ctx = Context(registry=self.registry, seed=self.seed)
        return component.factory(structure_options(component.options, options, "casebase"),
                                 ctx)

    def run(self, size: Size, out_dir: Path, progress: Progress) -> ExperimentResult:
        import matplotlib

        # the experiment draws into files only; no display is needed or wanted
        matplotlib.use("Agg")
        scale = self.SCALES[size]
        grid = self.grid(scale.side)
        rows: list[dict[str, Any]] = []
        with tempfile.TemporaryDirectory(prefix="cbr-fleet-") as scratch:
            folder = Path(scratch)
            stores, absent = self.stores(folder, os.environ)
            plan = [(store, n, mode) for store in stores for n in scale.fleets
                    for mode in (("shared",) if n == 1 else ("shared", "separate"))]
            plan += [(store, STALL_ROBOTS, "frozen") for store in stores]
            progress(0, len(plan))
            for done, (store, n, mode) in enumerate(plan):
                rows.append(self.fleet(store, n, mode, scale, grid, folder))
                progress(done + 1, len(plan))
        results = {"map": {"kind": "office", "width": scale.side, "height": scale.side,
                           "seed": self.seed},
                   "trips_per_fleet": scale.trips, "delta": DELTA, "max_ratio": MAX_RATIO,
                   "stores": [store.name for store in stores], "postgres_absent": absent,
                   "conflict_policy": "a learn step holds the store's write lock from its first "
                                      "read to its commit: steps wait for each other and are "
                                      "never redone; a step that waits out the store's "
                                      "busy_timeout is skipped, kept and learned later",
                   "rows": rows, "targets": targets(rows)}
        return ExperimentResult(results=results, table=table(rows, absent),
                                figures={"fleet_share": figure(rows)})

    def fleet(self, store: Store, n: int, mode: str, scale: Scale, grid: Any,
              folder: Path) -> dict[str, Any]:
        """Drive one fleet and audit its case bases: one row of the results."""
        label = f"{store.name}-{n}-{mode}"
        labels = ([f"{label}-{robot}" for robot in range(n)] if mode == "separate"
                  else [label] * n)
        trips = [scale.trips // n + (robot < scale.trips % n) for robot in range(n)]
        lock = {"busy_timeout": STALL_LOCK_SECONDS} if mode == "frozen" else {}
        jobs = [RobotJob(robot, {**store.casebase(labels[robot]), **lock}, scale.side,
                         self.seed, trips[robot], str(folder / f"{label}-robot-{robot}.json"))
                for robot in range(n)]
        stall = Stall(jobs[0].casebase, self.seed, n) if mode == "frozen" else None
        began = time.perf_counter()
        accounts = run_fleet(jobs, stall)
        audits = []
        for case_base in dict.fromkeys(labels):
            mine = [a for a, own in zip(accounts, labels, strict=True) if own == case_base]
            opened = self.open_store(store.casebase(case_base))
            try:
                audits.append(audit(opened, grid, mine, self.plugins))
            finally:
                opened.close()
        wall = max(a["finished"] for a in accounts) - min(a["started"] for a in accounts)
        steps = sum(len(a["trips"]) for a in accounts)
        if mode != "separate":
            ordered = sorted((t for a in accounts for t in a["trips"]), key=lambda t: t["read"])
        else:
            # each robot learns alone: by the time the fleet drove k * n trips, each drove k
            ordered = [t for k in range(max(trips)) for a in accounts
                       if k < len(a["trips"]) for t in (a["trips"][k],)]
        points = curve(ordered)
        learn = [t["learn_seconds"] for a in accounts for t in a["trips"]]
        return {
            "store": store.name, "mode": mode, "robots": n, "trips_per_robot": trips,
            "learn_steps": steps, "wall_seconds": wall,
            "steps_per_second": steps / wall if wall > 0 else None,
            "catch_ups": sum(a["catch_ups"] for a in accounts),
            "reloads": sum(a["reloads"] for a in accounts),
            "conflicts_retried": 0,
            "learn_skipped": sum(a["learn_skipped"] for a in accounts),
            "frozen_seconds": stall.frozen_seconds if stall is not None else None,
            "mean_learn_ms": float(np.mean(learn) * 1000) if learn else None,
            "cbr_share": sum(t["cbr"] for t in ordered) / len(ordered) if ordered else None,
            "trips_to_share": first_reaching(ordered, SHARE_MARK),
            "curve": points,
            "integrity": {
                "case_bases": len(audits),
                "lost_steps": sum(a["lost_steps"] for a in audits),
                "uncovered_steps": sum(a["uncovered_steps"] for a in audits),
                "check_problems": [p for a in audits for p in a["check_problems"]],
                "replay_equal": all(a["replay_vertices_equal"] and a["replay_segments_equal"]
                                    for a in audits),
                "serialised": all(a["distinct_revisions"] == a["learn_steps"] for a in audits),
                "vertices": [a["vertices"] for a in audits],
                "segments": [a["segments"] for a in audits]},
            "seconds_with_start_and_audit": time.perf_counter() - began,
        }


def sound(row: Mapping[str, Any]) -> bool:
    """Whether a fleet's case bases hold every committed step, intact."""
    integrity = row["integrity"]
    return (integrity["lost_steps"] == 0 and integrity["uncovered_steps"] == 0
            and not integrity["check_problems"] and integrity["replay_equal"]
            and integrity["serialised"])


def targets(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The issue's targets, as far as the rows show them."""
    largest = max(row["robots"] for row in rows)
    shared = [row for row in rows if row["mode"] == "shared" and row["robots"] == largest]
    rate = {row["robots"]: row["steps_per_second"] for row in rows
            if row["store"] == "sqlite" and row["mode"] == "shared"}
    speedup = rate[2] / rate[1] if rate.get(1) and rate.get(2) else None
    return {
        "integrity": {"robots": largest, "stores": [row["store"] for row in shared],
                      "learn_steps": [row["learn_steps"] for row in shared],
                      "wanted_learn_steps": 10000, "wanted_robots": 8,
                      "sound": all(sound(row) for row in rows),
                      "met": (largest >= 8 and all(sound(row) for row in rows)
                              and all(row["learn_steps"] >= 10000 for row in shared))},
        "throughput": {"sqlite_2_over_1_robot": speedup, "wanted": 1.6, "cores": os.cpu_count(),
                       "met": speedup is not None and speedup >= 1.6},
    }


def table(rows: Sequence[Mapping[str, Any]], absent: str | None) -> str:
    lines = ["| store | robots | case base | learn steps | steps/s | catch-ups | reloads "
             "| conflicts retried | skipped (locked) | learn ms | CBR share | trips to share "
             f"{SHARE_MARK:.1f} | lost | uncovered | check | replay equal |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        integrity = row["integrity"]
        lines.append(
            f"| {row['store']} | {row['robots']} | {row['mode']} | {row['learn_steps']} "
            f"| {fmt(row['steps_per_second'], 1)} | {row['catch_ups']} | {row['reloads']} "
            f"| {row['conflicts_retried']} | {row['learn_skipped']} "
            f"| {fmt(row['mean_learn_ms'])} "
            f"| {fmt(row['cbr_share'], 3)} | {row['trips_to_share'] or 'n/a'} "
            f"| {integrity['lost_steps']} | {integrity['uncovered_steps']} "
            f"| {'ok' if not integrity['check_problems'] else len(integrity['check_problems'])} "
            f"| {'yes' if integrity['replay_equal'] else 'NO'} |")
    frozen = [row for row in rows if row["mode"] == "frozen"]
    if frozen:
        held = ", ".join(f"{row['store']} {fmt(row['frozen_seconds'], 2)} s" for row in frozen)
        lines += ["", f"Case base 'frozen': the robots share it with a learner frozen (SIGSTOP) "
                      f"while it holds the write lock ({held} after the start); a robot skips "
                      f"a learn step after waiting {STALL_LOCK_SECONDS:g} s for the lock and "
                      f"learns it once the lock is free ('lost' counts any step the store "
                      f"misses)."]
    if absent:
        lines += ["", f"PostgreSQL rows absent: {absent}."]
    return "\n".join(lines)


def figure(rows: Sequence[Mapping[str, Any]]) -> Any:
    """CBR share and cost deviation against total trips, shared (solid) against separate
    (dashed) and shared beside a frozen learner (dotted), one colour per fleet size; SQLite
    rows only, the PostgreSQL ones being alike."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 4))
    share, deviation = fig.subplots(1, 2)
    sizes = sorted({row["robots"] for row in rows})
    for row in rows:
        if row["store"] != "sqlite":
            continue
        colour = f"C{sizes.index(row['robots'])}"
        style = {"shared": "-", "separate": "--", "frozen": ":"}[row["mode"]]
        label = f"{row['robots']} robot{'s' if row['robots'] > 1 else ''}, {row['mode']}"
        xs = [point["trips"] for point in row["curve"]]
        share.plot(xs, [point["cbr_share"] for point in row["curve"]], style, color=colour,
                   label=label)
        deviation.plot(xs, [np.nan if point["deviation"] is None else point["deviation"]
                            for point in row["curve"]], style, color=colour, label=label)
    share.set(xlabel="trips driven by the fleet", ylabel="share planned by CBR", ylim=(0, 1),
              xscale="log", title="CBR share")
    deviation.set(xlabel="trips driven by the fleet", ylabel="cost / A* optimum - 1",
                  xscale="log", title="Cost deviation")
    for axes in (share, deviation):
        axes.grid(True, alpha=0.3)
    share.legend(fontsize="small")
    return fig

