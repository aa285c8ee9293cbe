"""Trials in the 2D world: the step loop, what a trial records, and batches of trials.

:class:`Simulation` advances a robot one time step at a time: the sensors observe the world,
the navigator (pilot, progress monitor and Rescuer) turns the observation into a command, the
robot moves under it against the obstacles present at that time, and the step's events are
recorded. It is driven from outside one :meth:`Simulation.step` at a time, so that the trials
workload can consult the engine between steps and tell the navigator to divert.

:func:`run_trial` runs one :class:`Trial` (start, target, timeout, tolerance, time step) to its
end and returns a :class:`TrialResult`; :func:`run_batch` runs many, spread over processes, with
the same results as one after another. A trial's randomness (sensor noise) comes from its seed
only, so the same trial with the same seed gives the same result, in any process.
"""

from __future__ import annotations

import concurrent.futures
import math
import multiprocessing
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import attrs
import numpy as np

from cbr_world2d.checks import positive, step, too_many_steps
from cbr_world2d.crowd import Crowd
from cbr_world2d.navigator import Navigator, NavigatorOptions
from cbr_world2d.pilots.base import Pilot
from cbr_world2d.pilots.monitor import STUCK
from cbr_world2d.robot import PIONEER_2DX, Pose, RobotSpec, RobotState
from cbr_world2d.robot import step as robot_step
from cbr_world2d.sensors import Observation, Sensors
from cbr_world2d.shapes import free_point
from cbr_world2d.world import Point, World
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.options import structure_options
from cbrcore.registry import Registry

if TYPE_CHECKING:
    from cbr_recording.recorder import Recorder
    from cbr_world2d.recording import TrialRecording

REACHED = "reached"
"""A trial's reason when the robot came within the tolerance of its final target."""
TIMEOUT = "timeout"
"""A trial's reason when the timeout passed first."""

_COLUMNS = 6
"""Trajectory columns: t, x, y, theta, v, w."""


@attrs.frozen
class Event:
    """Something that happened during a step, where the robot was then.

    ``name`` is one of ``diverted`` (the navigator took a diverting target, ``point``),
    ``restored`` (it went back to the original target; ``detail`` says why, as the navigator
    reports it: ``reached`` or ``given_up``), ``blocked`` and ``oscillating`` (the progress
    monitor's verdicts) and ``collision`` (the robot ran into something). ``t``, ``x`` and
    ``y`` are the time and the robot's true position: the start of the step for the
    navigator's events (what it saw when it decided), the contact point for a collision.
    """

    name: str
    t: float
    x: float
    y: float
    detail: str = ""
    point: Point | None = None


@attrs.frozen
class Trial:
    """One trial: drive from ``start`` to ``target`` within ``timeout`` seconds, steps of
    ``dt``; reaching means the robot's centre comes within ``tolerance`` metres of the target.
    ``dt`` lies within [:data:`~cbr_world2d.checks.MIN_DT`, :data:`~cbr_world2d.checks.MAX_DT`]
    and the trial takes at most :data:`~cbr_world2d.checks.MAX_STEPS` steps."""

    start: Pose
    target: Point = attrs.field(converter=lambda p: (float(p[0]), float(p[1])))
    timeout: float = attrs.field(default=600.0, converter=float, validator=positive)
    tolerance: float = attrs.field(default=0.3, converter=float, validator=positive)
    dt: float = attrs.field(default=0.1, converter=float, validator=step)

    def __attrs_post_init__(self) -> None:
        problem = too_many_steps(self.timeout, self.dt)
        if problem is not None:
            raise ValueError(problem)

    @classmethod
    def facing(cls, start: Point, target: Point, **kwargs: float) -> Trial:
        """The trial whose robot starts at ``start`` facing ``target``."""
        heading = math.atan2(target[1] - start[1], target[0] - start[0])
        return cls(Pose(float(start[0]), float(start[1]), heading), target, **kwargs)

    def check(self, world: World, spec: RobotSpec, start: str = "start",
              target: str = "target") -> None:
        """Raise a :class:`CbrError` when the robot cannot start (outside the bounds, inside
        or touching an obstacle, a door or a person there at t = 0) or the target lies outside
        the world's bounds; the message calls them ``start`` and ``target`` and names what is
        in the way."""
        x, y = self.start.x, self.start.y
        if not math.isfinite(self.start.theta):
            raise CbrError(f"{start} heading: expected a finite angle, got {self.start.theta!r}")
        problem = free_point(world, x, y, spec.radius, t=0.0)
        if problem is not None:
            raise CbrError(f"{start} {x:g},{y:g} {problem}")
        tx, ty = self.target
        if not world.inside(tx, ty):
            box = ", ".join(f"{v:g}" for v in world.bounds)
            raise CbrError(f"{target} {tx:g},{ty:g} is outside the bounds [{box}]")


def random_trials(world: World, count: int, spec: RobotSpec, rng: np.random.Generator,
                  tries: int = 10_000, **options: float) -> list[Trial]:
    """``count`` trials between points drawn uniformly where the robot stands free (as
    :meth:`Trial.check` sees it), each facing its target and farther from it than the
    tolerance; ``options`` are the trials' timeout, tolerance and dt."""
    xmin, ymin, xmax, ymax = world.bounds
    tolerance = float(options.get("tolerance", attrs.fields(Trial).tolerance.default))

    def free() -> Point:
        for _ in range(tries):
            x, y = float(rng.uniform(xmin, xmax)), float(rng.uniform(ymin, ymax))
            if free_point(world, x, y, spec.radius, t=0.0) is None:
                return x, y
        raise CbrError(f"world {world.name!r}: no free point for a robot of radius "
                       f"{spec.radius:g} m in {tries} draws")

    trials: list[Trial] = []
    misses = 0
    while len(trials) < count:
        start, target = free(), free()
        if math.dist(start, target) > tolerance:
            trials.append(Trial.facing(start, target, **options))
            continue
        misses += 1
        if misses == tries:
            raise CbrError(f"world {world.name!r}: no two free points farther apart than the "
                           f"tolerance {tolerance:g} m in {tries} draws")
    return trials


def _array_eq(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.array_equal(a, b))


@attrs.frozen
class TrialResult:
    """What happened in one trial.

    ``trajectory`` is ``(N, 6)``: rows ``t, x, y, theta, v, w`` of the true state, the first
    at the start (t = 0), then one per step. ``time`` is when the trial ended (reaching the
    target or the timeout), ``distance`` the path length driven, ``collisions`` how many times
    the robot ran into something (a contact counts once however long it pushes), ``reason``
    :data:`REACHED` or :data:`TIMEOUT`. ``mover_clocks`` holds each mover's clock at each
    row of the trajectory when some mover yielded to the robot (None: their clocks were the
    time). ``events`` are all of the trial's events in order;
    :attr:`stuck` and :attr:`diverting` pick out where the robot got stuck and the diverting
    targets it was given. ``spec`` is the robot and ``seed`` the seed the trial ran with.
    """

    trial: Trial
    spec: RobotSpec
    seed: int
    success: bool
    reason: str
    time: float
    distance: float
    collisions: int
    steps: int
    trajectory: np.ndarray = attrs.field(eq=attrs.cmp_using(eq=_array_eq), repr=False)
    events: tuple[Event, ...] = ()
    mover_clocks: np.ndarray | None = attrs.field(
        default=None, eq=attrs.cmp_using(eq=_array_eq), repr=False)

    @property
    def stuck(self) -> tuple[Event, ...]:
        """The events where the progress monitor reported the robot blocked or oscillating."""
        return tuple(e for e in self.events if e.name in STUCK)

    @property
    def diverting(self) -> tuple[Point, ...]:
        """The diverting targets the robot was given, in order."""
        return tuple(e.point for e in self.events if e.name == "diverted" and e.point is not None)

    def summary(self) -> dict[str, Any]:
        """Plain data of the result without the trajectory, for printing and JSON."""
        return {"success": self.success, "reason": self.reason, "time": round(self.time, 3),
                "distance": round(self.distance, 3), "collisions": self.collisions,
                "steps": self.steps, "stuck": len(self.stuck),
                "diverting": [list(p) for p in self.diverting], "seed": self.seed}


class Simulation:
    """One robot in ``world`` driven by ``navigator`` toward ``target``, a step at a time.

    ``rng`` (or, without one, ``seed``) draws the sensor noise. After construction
    :attr:`observation` holds what the robot senses at its start; each :meth:`step` moves the
    robot and returns the new observation. :attr:`events` are the events of the last step;
    :attr:`reached` says whether the robot is within ``tolerance`` of the final ``target``
    (whatever diverting target the navigator is heading for); :meth:`retarget` changes that
    target mid-run. With a ``recorder`` the simulation is recorded as it steps, an episode of
    the recording (:mod:`cbr_world2d.recording`).
    """

    def __init__(self, world: World, spec: RobotSpec, sensors: Sensors, navigator: Navigator,
                 start: Pose, target: Point, *, dt: float = 0.1,
                 rng: np.random.Generator | None = None, seed: int = 0,
                 tolerance: float = 0.3, capacity: int = 1024,
                 recorder: Recorder | None = None) -> None:
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f"dt must be a finite number > 0, not {dt!r}")
        self.world = world
        self.spec = spec
        self.sensors = sensors
        self.navigator = navigator
        self.target: Point = (float(target[0]), float(target[1]))
        self.dt = float(dt)
        self.tolerance = float(tolerance)
        self.rng = rng if rng is not None else np.random.default_rng(seed)
        self.state = RobotState(float(start.x), float(start.y), float(start.theta))
        self.steps = 0
        self.t = 0.0
        self.distance = 0.0
        self.collisions = 0
        self.bumped = False
        self.events: tuple[Event, ...] = ()
        self.history: list[Event] = []
        self._buffer = np.empty((max(int(capacity), 2), _COLUMNS))
        self._buffer[0] = (0.0, self.state.x, self.state.y, self.state.theta, 0.0, 0.0)
        self._rows = 1
        # a world without doors or movers hands out the same arrays at every time
        self._static = None if world.dynamic else (world.segments_at(0.0), world.discs_at(0.0))
        self.crowd = Crowd(world)
        """Where the movers are now (people stop for the robot when they ``yield``)."""
        self._clocks: list[np.ndarray] | None = [self.crowd.clocks] if self.crowd.yields else None
        navigator.start(self.target)
        sensors.reset()
        self.observation: Observation = self._sense(0.0, False)
        self.reached = self._within()
        self.recording: TrialRecording | None = None
        """What records the simulation, when it is recorded."""
        if recorder is not None:
            from cbr_world2d.recording import TrialRecording

            self.recording = TrialRecording(recorder, self)

    def observe(self) -> Observation:
        """What the robot senses now (the observation of the last step, or of the start)."""
        return self.observation

    @property
    def trajectory(self) -> np.ndarray:
        """The true states so far, ``(steps + 1, 6)`` rows ``t, x, y, theta, v, w`` (a
        read-only view)."""
        view = self._buffer[:self._rows]
        view.flags.writeable = False
        return view

    def retarget(self, point: Point) -> None:
        """Make ``point`` the final target from now on (a delivery robot's goal changes): the
        navigator drops any diverting target and restarts its progress monitor but not the
        pilot (:meth:`Navigator.retarget`), and :attr:`reached` is judged afresh against
        ``point``."""
        self.target = (float(point[0]), float(point[1]))
        self.navigator.retarget(self.target)
        self.reached = self._within()

    def _within(self) -> bool:
        return math.hypot(self.state.x - self.target[0],
                          self.state.y - self.target[1]) <= self.tolerance

    @property
    def mover_clocks(self) -> np.ndarray | None:
        """Each mover's clock at each row of :attr:`trajectory`, ``(steps + 1, movers)``, when
        some mover yields (None: every mover's clock is the time)."""
        return None if self._clocks is None else np.asarray(self._clocks)

    def _obstacles(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        if self._static is not None:
            return self._static
        return self.world.segments_at(t), self.crowd.discs()

    def _sense(self, t: float, bumped: bool) -> Observation:
        segments, discs = self._obstacles(t)
        return self.sensors.observe(self.state, self.world, t, bumped, self.rng, segments, discs)

    def step(self) -> Observation:
        """Advance one time step: command from the current observation, move, sense.

        The robot moves against the obstacles present at the step's start (a door shutting or
        a person walking during the step is seen from the next step on).
        """
        before = self.state
        t = self.t
        command = self.navigator.command(self.observation)
        segments, discs = self._obstacles(t)
        after, collided = robot_step(before, command, self.spec, self.dt, segments, discs)
        self.steps += 1
        # a product, not a running sum, so that the clock does not drift over long trials
        self.t = t_next = self.steps * self.dt
        self.distance += math.hypot(after.x - before.x, after.y - before.y)
        self.state = after
        raised = self.navigator.events
        events = [Event(e.name, t, before.x, before.y, e.detail, e.point)
                  for e in raised] if raised else []
        # a contact counts once, however many steps the robot keeps pushing into it
        if collided and not self.bumped:
            self.collisions += 1
            events.append(Event("collision", t_next, after.x, after.y))
        self.bumped = collided
        if events:
            self.history.extend(events)
            self.events = tuple(events)
        elif self.events:
            self.events = ()
        if self._rows == self._buffer.shape[0]:
            grown = np.empty((2 * self._rows, _COLUMNS))
            grown[:self._rows] = self._buffer
            self._buffer = grown
        self._buffer[self._rows] = (t_next, after.x, after.y, after.theta, after.v, after.w)
        self._rows += 1
        self.crowd.advance(t_next, (after.x, after.y), self.spec.radius)
        if self._clocks is not None:
            self._clocks.append(self.crowd.clocks)
        self.observation = self._sense(t_next, collided)
        self.reached = self._within()
        if self.recording is not None:
            self.recording.step(self)
        return self.observation

    def result(self, trial: Trial, seed: int) -> TrialResult:
        """The :class:`TrialResult` of the trial as it stands."""
        return TrialResult(trial, self.spec, seed, self.reached,
                           REACHED if self.reached else TIMEOUT, self.t, self.distance,
                           self.collisions, self.steps, self._buffer[:self._rows].copy(),
                           tuple(self.history), self.mover_clocks)


@attrs.frozen
class PilotRecipe:
    """A pilot of the registry's ``pilot`` kind: its name, factory and structured options.

    Plain picklable data (the factory is a class or function found by its module), so a batch
    hands it to worker processes and each builds its own pilot there.
    """

    name: str
    factory: Callable[[Any, Context], Pilot]
    options: Any

    @classmethod
    def named(cls, name: str, options: Mapping[str, Any] | None = None,
              registry: Registry | None = None) -> PilotRecipe:
        """The recipe of pilot ``name`` with ``options`` (defaults for those left out), from
        ``registry`` (default: the current plugins'); a CbrError naming an unknown pilot with
        the registered ones, or bad options."""
        if registry is None:
            from cbrcore.plugins import current

            registry = current().registry
        component = registry.get("pilot", name)
        structured = structure_options(component.options, dict(options or {}), f"pilot {name}")
        return cls(name, component.factory, structured)

    def build(self, seed: int = 0) -> Pilot:
        """A new pilot. Its factory gets a context of its own, the generator seeded with
        ``seed`` and an empty registry: a pilot is built where no run's plugins are loaded (a
        batch's worker process), so it must need no other component."""
        return self.factory(self.options, Context(registry=Registry(), seed=seed))


PilotSource = Pilot | PilotRecipe
"""A trial's pilot: one already built, or a recipe to build it from."""


def run_trial(world: World, trial: Trial, pilot: PilotSource, *,
              spec: RobotSpec = PIONEER_2DX, sensors: Sensors | None = None, seed: int = 0,
              navigation: NavigatorOptions | None = None,
              recorder: Recorder | None = None) -> TrialResult:
    """Run ``trial`` in ``world`` to its end and return what happened.

    The start and target are checked first (:meth:`Trial.check`). ``pilot`` is reset (a
    recipe builds a new one) and driven by a :class:`Navigator` with ``navigation``'s options
    (default: the Rescuer diverts only when asked, 002's baseline). ``sensors`` (default:
    sonar ring, camera, noiseless odometry) are copied and mounted on the robot's rim, so the
    caller's suite keeps no state from the trial. A ``recorder`` records the trial.
    """
    trial.check(world, spec)
    built = pilot.build(seed) if isinstance(pilot, PilotRecipe) else pilot
    suite = (sensors if sensors is not None else Sensors()).fitted(spec.radius)
    sim = Simulation(world, spec, suite, Navigator(built, navigation), trial.start, trial.target,
                     dt=trial.dt, seed=seed, tolerance=trial.tolerance,
                     capacity=min(int(trial.timeout / trial.dt) + 2, 1 << 16),
                     recorder=recorder)
    # the step count bounds the loop, not the clock: t is steps * dt, so this is exact
    last = math.ceil(trial.timeout / trial.dt - 1e-9)
    while not sim.reached and sim.steps < last:
        sim.step()
    return sim.result(trial, seed)


def trial_seeds(seed: int, count: int) -> list[int]:
    """``count`` independent trial seeds drawn from ``seed``: trial ``k`` gets the same seed
    however the batch is split."""
    states = np.random.SeedSequence(seed).generate_state(count, dtype=np.uint32)
    return [int(s) for s in states]


@attrs.frozen
class _Batch:
    """What every trial of a batch shares, sent once to each worker process."""

    world: World
    pilot: PilotRecipe
    spec: RobotSpec
    sensors: Sensors
    navigation: NavigatorOptions | None

    def run(self, trial: Trial, seed: int) -> TrialResult:
        return run_trial(self.world, trial, self.pilot, spec=self.spec, sensors=self.sensors,
                         seed=seed, navigation=self.navigation)


_WORKER: list[_Batch] = []
"""The batch of this worker process, set by the pool's initializer."""


def _init_worker(batch: _Batch) -> None:
    _WORKER[:] = [batch]


def _run_one(job: tuple[Trial, int]) -> TrialResult:
    return _WORKER[0].run(*job)


def run_batch(world: World, trials: Sequence[Trial], pilot: PilotRecipe, *,
              spec: RobotSpec = PIONEER_2DX, sensors: Sensors | None = None, seed: int = 0,
              navigation: NavigatorOptions | None = None,
              workers: int = 2) -> list[TrialResult]:
    """Run independent ``trials`` on ``workers`` processes; the results, in the trials' order,
    are those of running them one after another: trial ``k`` runs with seed
    ``trial_seeds(seed, len(trials))[k]`` and a pilot of its own built from ``pilot``.

    Worker processes are spawned, not forked, so a batch behaves the same on every platform
    and never inherits the caller's threads; they receive only picklable data. Every trial is
    checked before any runs.
    """
    if workers < 1:
        raise ValueError(f"workers must be at least 1, not {workers}")
    for k, trial in enumerate(trials):
        try:
            trial.check(world, spec)
        except CbrError as exc:
            raise CbrError(f"trial {k}: {exc}") from None
    batch = _Batch(world, pilot, spec, sensors if sensors is not None else Sensors(), navigation)
    jobs = list(zip(trials, trial_seeds(seed, len(trials)), strict=True))
    if workers == 1 or len(jobs) <= 1:
        return [batch.run(*job) for job in jobs]
    workers = min(workers, len(jobs))
    # a few jobs per worker at a time keeps every worker busy without one long tail
    chunk = max(1, len(jobs) // (4 * workers))
    with concurrent.futures.ProcessPoolExecutor(
            max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
            initializer=_init_worker, initargs=(batch,)) as pool:
        return list(pool.map(_run_one, jobs, chunksize=chunk))
