"""The ``trials`` workload: robots driving trials in the 2D world, consulting the engine as they go.

Each trial runs one :class:`~cbr_world2d.simulation.Simulation` from its start to its target
until the robot reaches it or the timeout. While it runs, a trigger (the progress monitor
reporting the robot blocked, a landmark coming into view, the heading turning, a period
passing; see :mod:`cbr_world2d.triggers`) consults the engine with a :class:`Situation`
(what the camera sees and, with a ``memory``, the landmarks seen shortly before:
:mod:`cbr_world2d.landmark_memory`); the proposal's solution is an
:class:`~cbr_world2d.actions.Action` the simulation carries out.
The decision is learned when the action ends, or when the trial ends first; no consultation is
made while an action is under way or a diverting target is set, so the agent does not ask
again for the situation the robot is already avoiding (002 section 3.3).

Besides the run's ``results.csv`` (one row per decision), the workload writes ``trials.csv`` in
the run folder: one row per trial with its success, time, distance, collisions and
consultations; ``obstacles.csv``, the linear obstacles between landmarks the robot perceived
(:mod:`cbr_world2d.obstacle_map`; its map is kept across the run's trials) beside those the
world declares; and, when asked (``trajectories``), ``trajectories.npz``: each trial's true
path as an array ``trial_<k>`` of rows ``t, x, y, theta``.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import attrs
import numpy as np

from cbr_recording.keys import RECORDER
from cbr_world2d import PILOT, checks
from cbr_world2d.actions import TRIAL_ENDED, Action, ActionReport
from cbr_world2d.landmark_memory import LandmarkMemory, MemoryOptions
from cbr_world2d.navigator import Navigator, NavigatorOptions
from cbr_world2d.obstacle_map import ObstacleMap, PerceptionOptions
from cbr_world2d.pilots.base import Pilot
from cbr_world2d.triggers import TRIGGERS, Trigger, Triggers
from cbr_world2d.world import Point, World, world_of
from cbrcore import files
from cbrcore.context import Context
from cbrcore.errors import CbrError, PluginError
from cbrcore.model import Outcome
from cbrcore.options import option
from cbrcore.workload import Decision, Session

if TYPE_CHECKING:
    from cbr_world2d.robot import Pose
    from cbr_world2d.sensors import Observation, Sighting
    from cbr_world2d.simulation import Simulation, Trial

_POSITIVE = attrs.validators.gt(0.0)
_COUNT = attrs.validators.and_(attrs.validators.instance_of(int), attrs.validators.ge(0))


@attrs.frozen
class TrialEntry:
    start: str = option(doc="Where the robot starts: a place of the world or 'X,Y' in metres.")
    target: str = option(doc="The target: a place of the world or 'X,Y' in metres.")
    heading: float | None = option(
        None, "The start heading in degrees counter-clockwise from +x; none faces the target.")


@attrs.frozen
class CameraOptions:
    fov: float = option(60.0, "The field of view in degrees, centred on the heading.",
                        validator=attrs.validators.and_(_POSITIVE, attrs.validators.le(360.0)))
    range: float = option(6.0, "How far, in metres, a landmark can be seen.",
                          validator=_POSITIVE)
    pan: float = option(
        0.0, "How far, in degrees, the camera pans to each side of the heading (002's Vision "
        "agent turns it to look for landmarks): it sweeps 0, pan, -pan, 0 and so on, and a "
        "sweep sees 'fov' + 2 'pan' round the heading; 0 keeps it on the heading.",
        validator=attrs.validators.and_(attrs.validators.ge(0.0),
                                        attrs.validators.le(180.0)))
    pan_rate: float = option(60.0, "How fast the camera pans, in degrees per second.",
                             validator=_POSITIVE)


@attrs.frozen
class TrialsOptions:
    trials: list[TrialEntry] = option(
        doc="The trials, each a start and a target, run in order.", factory=list)
    random: int = option(
        0, "More trials between random free points of the world, drawn from the run's seed.",
        validator=_COUNT)
    repeat: int = option(1, "How many times the whole list of trials runs.", validator=_COUNT)
    timeout: float = option(600.0, "Seconds after which a trial has failed.",
                            validator=_POSITIVE)
    dt: float = option(0.1, "The simulation step in seconds, from 0.0001 to 1.",
                       validator=checks.step)
    tolerance: float = option(
        0.3, "How close, in metres, the robot's centre must come to the target.",
        validator=_POSITIVE)
    robot: Literal["pioneer2dx", "ros2005"] = option(
        "pioneer2dx", "The robot: a Pioneer 2 DX (004) or the slow robot of 002 (5 cm/s).")
    navigation: NavigatorOptions = option(
        doc="The navigation system around the pilot: progress monitor, Rescuer, and whether "
        "the Rescuer diverts on its own.", factory=NavigatorOptions)
    consult_on: list[Trigger] = option(
        doc="What consults the agent: 'blocked' (the progress monitor reports the robot "
        "blocked or oscillating), 'landmarks' (a landmark came into view, see 'settle' and "
        "'absence'), 'heading' (the heading turned 'turn' degrees since the last "
        "consultation), 'period' ('period' seconds passed since the last consultation).",
        factory=lambda: list(TRIGGERS))
    period: float = option(
        5.0, "Seconds after the last consultation at which the 'period' trigger consults "
        "again: under the 8 s a Pioneer at full speed takes to cross the camera's 6 m, so "
        "a situation that comes into view is looked at again before the robot is in it.",
        validator=_POSITIVE)
    turn: float = option(
        30.0, "Degrees the heading must turn from where it pointed at the last consultation "
        "for the 'heading' trigger: more than the half-width of a fuzzy angle between two "
        "landmarks 3 m away and 2 to 4 m apart (11 to 23 degrees), so the problem case, "
        "measured against the heading, has changed.",
        validator=attrs.validators.and_(_POSITIVE, attrs.validators.le(180.0)))
    settle: float = option(
        0.5, "Seconds a landmark must be in view without a break to count as come into view "
        "for the 'landmarks' trigger (a glimpse as the robot swerves does not consult); "
        "those in view at a trial's start count at once.",
        validator=attrs.validators.ge(0.0))
    absence: float = option(
        30.0, "Seconds a landmark must be out of view before it can come into view again for "
        "the 'landmarks' trigger: a robot swinging in a dead end sees the same landmarks "
        "leave and come back within 30 s; the 'period' trigger looks again meanwhile.",
        validator=attrs.validators.ge(0.0))
    camera: CameraOptions = option(
        doc="The camera that sees the landmarks.", factory=lambda: CameraOptions())
    memory: MemoryOptions = option(
        doc="The short-term memory of landmarks: those seen within 'seconds' stay in the "
        "situation's sightings, carried by odometry and blurred with the time and distance "
        "since (off by default).", factory=MemoryOptions)
    perception: PerceptionOptions = option(
        doc="How the robot learns the linear obstacles between landmarks from its sonar and "
        "bumper (its map is kept across the run's trials).", factory=PerceptionOptions)
    trajectories: bool = option(
        False, "Also write each trial's true path into trajectories.npz in the run folder.")

    def __attrs_post_init__(self) -> None:
        problem = checks.too_many_steps(self.timeout, self.dt)
        if problem is not None:
            raise ValueError(f"'timeout' must be within the step limit: {problem}")
        trials = (len(self.trials) + self.random) * self.repeat
        if trials > checks.MAX_TRIALS:
            raise ValueError(f"'repeat' must keep the trials within {checks.MAX_TRIALS} (the "
                             f"limit, cbr_world2d.checks.MAX_TRIALS): (listed + random) x repeat "
                             f"is {trials}")


def _array(values: np.ndarray) -> list[float]:
    return [round(float(v), 4) for v in values]


@attrs.frozen
class Situation:
    """A consultation's problem: the robot's situation when a trigger fired.

    ``pose`` is the odometry estimate (what the robot believes), ``target`` the trial's final
    target, ``sightings`` what the camera sees (fuzzy distance and bearing per landmark),
    ``obstacles`` the linear obstacles the robot knows between two of those landmarks (pairs
    of ids),
    ``sonar`` the ring's ranges in metres (``sonar_angles`` relative to the heading),
    ``remembered`` the ids of the sightings that come from the landmark memory rather than the
    camera's current view (:mod:`cbr_world2d.landmark_memory`), ``walls`` every obstacle the
    robot's map has perceived, in view or not, as the segment between the places it believes
    the two landmarks at (the odometry's frame, as ``pose``), ``open`` the pairs of those
    landmarks its map has seen the way open between (no linear obstacle there), and ``bounds``
    the arena's
    outline ``(xmin, ymin, xmax, ymax)``, which the robot knows as it knows the target: a
    floor plan's walls, with nothing inside.
    """

    trial: int
    t: float
    trigger: str
    pose: Pose
    target: Point
    sightings: tuple[Sighting, ...]
    obstacles: tuple[tuple[str, str], ...]
    sonar: np.ndarray = attrs.field(eq=False)
    sonar_angles: np.ndarray = attrs.field(eq=False)
    bumped: bool
    confidence: float
    remembered: tuple[str, ...] = ()
    walls: tuple[tuple[Point, Point], ...] = ()
    bounds: tuple[float, float, float, float] | None = None
    open: tuple[tuple[str, str], ...] = ()

    def to_json(self) -> dict[str, Any]:
        """Plain data of the situation, as a retainer stores it in a case."""
        return {
            "trial": self.trial, "t": round(self.t, 4), "trigger": self.trigger,
            "pose": [self.pose.x, self.pose.y, self.pose.theta],
            "target": list(self.target),
            "sightings": [{"id": s.id, "distance": list(attrs.astuple(s.distance)),
                           "bearing": list(attrs.astuple(s.bearing))} for s in self.sightings],
            "obstacles": [list(pair) for pair in self.obstacles],
            "sonar": _array(self.sonar), "sonar_angles": _array(self.sonar_angles),
            "bumped": self.bumped, "confidence": self.confidence,
            "remembered": list(self.remembered),
            "walls": [[list(a), list(b)] for a, b in self.walls],
            "bounds": None if self.bounds is None else list(self.bounds),
            "open": [list(pair) for pair in self.open],
        }


def situation(world: World, trial: int, trigger: str, obs: Observation, target: Point,
              known: ObstacleMap | None = None, memory: LandmarkMemory | None = None
              ) -> Situation:
    """The situation the robot observes. Its sightings are the camera's, and with a
    ``memory`` (updated with ``obs``) the landmarks it remembers besides. Its obstacles are
    those the robot perceived between two of those landmarks, by its map ``known``; without a
    map, the linear obstacles ``world`` declares between them (the ground truth: for hand-made
    cases and tests). Its walls are every obstacle of the map and its open pairs those the map
    has seen open (none without one), its bounds the world's."""
    sightings, remembered = ((obs.sightings, ()) if memory is None
                             else memory.sightings(obs))
    ids = [s.id for s in sightings]
    obstacles = world.obstacles_between(ids) if known is None else known.between(ids)
    return Situation(trial, obs.t, trigger, obs.pose, target, sightings, obstacles,
                     obs.sonar, obs.sonar_angles, obs.bumped, obs.confidence, remembered,
                     () if known is None else known.walls(), world.bounds,
                     () if known is None else known.open_between(ids))


@attrs.frozen
class TrialRow:
    """One row of ``trials.csv``."""

    trial: int
    start_x: float
    start_y: float
    target_x: float
    target_y: float
    success: bool
    reason: str
    time: float
    distance: float
    collisions: int
    consultations: int


@attrs.define
class _Open:
    decision: Decision
    action: Action | None
    started: float
    distance: float
    collisions: int


class Trials:
    """Run the configured trials, consulting the engine through a session."""

    def __init__(self, options: TrialsOptions, ctx: Context) -> None:
        # the simulator's modules load numba: imported by the workload that runs trials, not
        # with the registration at every start of cbr
        from cbr_world2d.robot import PRESETS

        self.options = options
        self.world: World = world_of(ctx, "workload 'trials'")
        pilot = ctx.stash.get(PILOT, None)
        if pilot is None:
            # a grid configuration has no use for a pilot, so the slot has no default
            raise CbrError("workload 'trials' drives the robot with a pilot: name one in the "
                           "configuration's 'pilot' slot (potential_field, behaviors, or "
                           "another component of kind 'pilot')")
        self.pilot: Pilot = pilot
        self.spec = PRESETS[options.robot]
        self.ctx = ctx
        self.rng = ctx.spawn_rng()
        self.plan = self._plan()
        self.paths: dict[str, np.ndarray] = {}
        from cbr_world2d.sensors import SonarRing

        # one map for the whole run: what a trial taught the robot, the next one knows; its
        # ring is the one the trials' sensors carry
        self.obstacles = ObstacleMap(options.perception, SonarRing().fitted(self.spec.radius))

    def _plan(self) -> list[Trial]:
        from cbr_world2d.robot import Pose
        from cbr_world2d.simulation import Trial, random_trials

        o = self.options
        timing = {"timeout": o.timeout, "tolerance": o.tolerance, "dt": o.dt}
        fixed = []
        for k, entry in enumerate(o.trials):
            where = f"workload.trials.{k}"
            start = self.world.point(entry.start, f"{where}.start")
            target = self.world.point(entry.target, f"{where}.target")
            trial = Trial.facing(start, target, **timing)
            if entry.heading is not None:
                trial = attrs.evolve(trial, start=Pose(*start, math.radians(entry.heading)))
            trial.check(self.world, self.spec, f"{where}.start", f"{where}.target")
            fixed.append(trial)
        drawn = random_trials(self.world, o.random, self.spec, self.rng, **timing)
        return (fixed + drawn) * o.repeat

    def __len__(self) -> int:
        return len(self.plan)

    def describe(self, problem: Situation) -> Mapping[str, Any]:
        return {"trial": problem.trial, "t": round(problem.t, 3), "trigger": problem.trigger,
                "x": round(problem.pose.x, 3), "y": round(problem.pose.y, 3)}

    def run(self, session: Session) -> None:
        if self.ctx.out_dir is None:
            for k, trial in enumerate(self.plan):
                self._trial(session, k, trial)
            return
        # written as the trials end, like results.csv, so a run cut short keeps what it did
        with open(self.ctx.out_dir / "trials.csv", "w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle)
            writer.writerow([f.name for f in attrs.fields(TrialRow)])
            for k, trial in enumerate(self.plan):
                writer.writerow(attrs.astuple(self._trial(session, k, trial)))
                handle.flush()
        if self.options.trajectories:
            with files.replacing(self.ctx.out_dir / "trajectories.npz", "wb") as out:
                np.savez_compressed(out, **self.paths)
        self._write_obstacles(self.ctx.out_dir / "obstacles.csv")

    def _write_obstacles(self, path: Path) -> None:
        """``obstacles.csv``: each pair of landmarks the robot sensed something between or the
        world declares an obstacle between, the robot's evidence beside the declaration."""
        known = self.obstacles.landmarks
        declared = [w.between for w in self.world.walls if w.between is not None]
        pairs = [(a, b) for k, a in enumerate(known) for b in known[k + 1:]]
        pairs += [pair for pair in declared if not (pair[0] in known and pair[1] in known)]
        truth = {frozenset(pair) for pair in declared}
        with files.replacing(path) as handle:
            writer = csv.writer(handle)
            writer.writerow(["first", "second", "occupied", "free", "perceived", "declared"])
            for a, b in pairs:
                occupied, free = self.obstacles.evidence(a, b)
                is_declared = frozenset((a, b)) in truth
                if occupied or free or is_declared:
                    writer.writerow([a, b, occupied, free, self.obstacles.perceives(a, b),
                                     is_declared])

    def _trial(self, session: Session, index: int, trial: Trial) -> TrialRow:
        from cbr_world2d.sensors import Camera, Sensors
        from cbr_world2d.simulation import Simulation

        options = self.options
        camera = Camera(fov=math.radians(options.camera.fov), max_range=options.camera.range,
                        pan=math.radians(options.camera.pan),
                        pan_rate=math.radians(options.camera.pan_rate))
        sim = Simulation(self.world, self.spec, Sensors(camera=camera).fitted(self.spec.radius),
                         Navigator(self.pilot, options.navigation), trial.start, trial.target,
                         dt=trial.dt, rng=self.rng.spawn(1)[0], tolerance=trial.tolerance,
                         recorder=session.ctx.stash.get(RECORDER, None))
        opened: _Open | None = None
        consultations = 0
        obs = sim.observe()
        self.obstacles.sense(obs)
        memory = LandmarkMemory(options.memory) if options.memory.seconds > 0.0 else None
        if memory is not None:
            memory.update(obs)
        # the triggers look at the camera's current view: a remembered landmark is not one
        # that comes into view
        triggers = Triggers(options.consult_on, obs, period=options.period, turn=options.turn,
                            settle=options.settle, absence=options.absence)
        last = math.ceil(trial.timeout / trial.dt - 1e-9)
        while not sim.reached and sim.steps < last:
            trigger = triggers.update(obs, sim.events)
            # no consultation while a diverting target is set: the robot is avoiding a situation
            # already, and asking again would only repeat the message (002 section 3.3)
            if trigger is not None and opened is None and not sim.navigator.diverting:
                opened = self._consult(session, sim, index, trigger, obs, trial.target, memory)
                triggers.consulted(obs)
                consultations += 1
            obs = sim.step()
            self.obstacles.sense(obs)
            if memory is not None:
                memory.update(obs)
            if opened is not None and opened.action is not None:
                reason = opened.action.ended(sim)
                if reason is not None:
                    self._learn(session, sim, opened, reason, None)
                    opened = None
        if opened is not None:
            self._learn(session, sim, opened, TRIAL_ENDED, sim.reached)
        if options.trajectories:
            self.paths[f"trial_{index}"] = sim.trajectory[:, :4].copy()
        return TrialRow(index, trial.start.x, trial.start.y, *trial.target, sim.reached,
                        "reached" if sim.reached else "timeout", round(sim.t, 4),
                        round(sim.distance, 4), sim.collisions, consultations)

    def _consult(self, session: Session, sim: Simulation, index: int, trigger: str,
                 obs: Observation, target: Point, memory: LandmarkMemory | None
                 ) -> _Open | None:
        decision = session.consult(situation(self.world, index, trigger, obs, target,
                                             self.obstacles, memory))
        solution = decision.proposal.solution
        action = None if solution is None else solution.value
        if action is not None and not isinstance(action, Action):
            raise PluginError(f"workload 'trials': the proposal for query {decision.index} is "
                              f"a {type(action).__name__}, expected an action of the 2D world "
                              "(cbr_world2d.actions: Divert, or a class with start and ended)")
        recorder = session.ctx.stash.get(RECORDER, None)
        if recorder is not None:
            recorder.decision(decision.index, decision.proposal,
                              action="go on" if action is None else str(action),
                              detail={"trial": index, "trigger": trigger})
        opened = _Open(decision, action, sim.t, sim.distance, sim.collisions)
        if action is None:
            # nothing to carry out: what follows is the navigation system's own doing
            self._learn(session, sim, opened, "no_action", None)
            return None
        action.start(sim)
        return opened

    @staticmethod
    def _learn(session: Session, sim: Simulation, opened: _Open, reason: str,
               trial_success: bool | None) -> None:
        report = ActionReport(reason, round(opened.started, 4), round(sim.t, 4),
                              round(sim.distance - opened.distance, 4),
                              sim.collisions - opened.collisions, trial_success)
        success = reason == "reached"
        session.learn(opened.decision,
                      Outcome(success, cost=round(sim.t - opened.started, 4), report=report))
