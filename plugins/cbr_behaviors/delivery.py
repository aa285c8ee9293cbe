"""The ``delivery`` workload: RUPART's day of message delivery on an office floor (004).

One robot (a Pioneer 2 DX with noisy odometry) spends ``days`` simulated days on the configured
2D world. Messages arrive at seeded random times (:mod:`cbr_behaviors.messages`) and become
navigation goals; the goal manager (:mod:`cbr_behaviors.goals`) picks the one to serve, gives
up those that can no longer be saved (judged by the route's length over the speed the robot
has made, :mod:`cbr_behaviors.eta`) and serves pending ones on the way. Three parts run side by
side as in 004 Figure 2:

- the *behavior manager*: the ``behaviors`` pilot executing the installed behavior set, which
  keeps running while re-planning happens;
- the *plan manager*: the current goal's route, planned on the rasterised global map with the
  ``planner`` grid solver (:mod:`cbr_behaviors.globalmap`), its next waypoint the behaviors'
  target; the global map holds the transient objects the sonar reports until they fade, but
  not the people the robot's person tracker sees (:mod:`cbr_behaviors.situation`);
- *action selection* (004 Figure 3): the re-planning triggers (:mod:`cbr_behaviors.triggers`)
  consult the engine with a :class:`~cbr_behaviors.moment.Moment`, the index of Figure 5 and
  the situation features filled in from the simulation. A behavior case or meta-plan is
  installed at once; a plan case has the plan manager route through its places (deliberative
  re-planning). A behavior set in force when an impasse fired stays out of retrieval for
  ``exclude`` seconds.

Each decision is learned when the next retrieval replaces it or the day ends, its outcome's
report a :class:`~cbr_behaviors.moment.SpellReport`. With ``consult: false`` the robot keeps
the pilot's behavior set all day (004's comparison: one fixed hand-made behavior set), or
drives with any other pilot.

Besides ``results.csv`` the workload writes ``deliveries.csv`` (a row per message: when it
arrived, its deadline, whether and when it was delivered or why it was missed) and
``days.csv`` (a row per day, :class:`DayRow`: deliveries, deadlines missed, messages
unfinished, collisions, busy speed, retrievals per minute, install times, stalls, door
waits), with ``trajectories`` the true path of each day in ``trajectories.npz`` and with
``log`` each day's :class:`~cbr_behaviors.daylog.DayLog` in ``day_N.npz``.
"""

from __future__ import annotations

import csv
import itertools
import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import attrs
import numpy as np

from cbr_behaviors.casetypes import freeze
from cbr_behaviors.moment import CaseChoice, InstallBehaviors, InstallPlan, Moment, SpellReport
from cbr_behaviors.triggers import TriggerOptions
from cbr_grid.planning import planner_problem
from cbr_recording.keys import RECORDER
from cbr_world2d.pilots import PILOT, BehaviorPilot, parse_behavior_set
from cbr_world2d.pilots.monitor import STUCK
from cbr_world2d.pilots.primitives import COLLISION_ARC
from cbr_world2d.world import Point, World, world_of
from cbrcore import files
from cbrcore.context import Context
from cbrcore.errors import CbrError, PluginError
from cbrcore.model import Outcome
from cbrcore.options import option, reference
from cbrcore.workload import Decision, Session

if TYPE_CHECKING:
    from cbr_behaviors.daylog import DayLog
    from cbr_behaviors.eta import RouteEta
    from cbr_behaviors.globalmap import GlobalMap
    from cbr_behaviors.goals import GoalManager
    from cbr_behaviors.index import Index
    from cbr_behaviors.situation import PersonSeen
    from cbr_world2d.sensors import Observation
    from cbr_world2d.simulation import Simulation

_POSITIVE = attrs.validators.gt(0.0)
_COUNT = attrs.validators.and_(attrs.validators.instance_of(int), attrs.validators.ge(1))

PRIORITY_URGENCY: dict[str, float] = {"low": 0.25, "normal": 0.5, "high": 0.75,
                                      "critical": 1.0}
"""goal-urgency of a message goal by its priority (004 Figure 5: "urgency of high-level")."""
DELIVERY_COLUMNS = ("id", "place", "priority", "arrives", "deadline", "delivered", "time",
                    "missed", "against")
"""The columns of ``deliveries.csv`` after ``day`` (:meth:`GoalManager.records`)."""
PROGRESS_WINDOW = 10.0
"""Seconds over which behav-conf measures the progress the behaviors make."""


@attrs.frozen
class DeliveryOptions:
    days: int = option(1, "How many simulated days the robot works, one after another, the "
                          "case base carrying over.", validator=_COUNT)
    length: float = option(1800.0, "The length of a day in seconds.", validator=_POSITIVE)
    rate: float = option(30.0, "Messages per hour (a Poisson process).", validator=_POSITIVE)
    start: str = option("hall_west", "Where the robot starts each day and waits when idle: a "
                                     "place of the world or 'X,Y'.")
    consult: bool = option(
        True, "Consult the engine when a re-planning trigger fires; false keeps the pilot's "
        "behavior set all day.")
    planner: str = reference("solver", "astar",
                             "The grid planner (a solver of the solver protocol) the plan "
                             "manager routes with on the rasterised global map.",
                             fits=planner_problem)
    cell: float = option(0.2, "The cell size, in metres, of the rasterised global map.",
                         validator=_POSITIVE)
    fade: float = option(60.0, "Seconds after which a transient object the sonar no longer "
                               "reports leaves the global map (004).", validator=_POSITIVE)
    triggers: TriggerOptions = option(factory=TriggerOptions,
                                      doc="When action selection re-plans (004 Figure 3).")
    odometry_noise: float = option(
        0.0075, "The odometry's error, metres per metre and radians per radian (0.0075 is "
        "MobileRobots' typical Pioneer error): the location confidence falls as the robot "
        "drives until it localizes.", validator=attrs.validators.ge(0.0))
    deliver_radius: float = option(
        0.6, "How near, in metres, the robot's centre must come to a message's place to "
        "deliver it.", validator=_POSITIVE)
    waypoint: float = option(0.5, "How near a route's waypoint counts as passed, in metres.",
                             validator=_POSITIVE)
    trajectories: bool = option(False, "Also write each day's true path into "
                                       "trajectories.npz.")
    exclude: float = option(
        30.0, "Seconds a behavior set that reached an impasse stays out of retrieval: the "
        "retrievals that follow (the re-route the impasse causes among them) do not install "
        "it again.", validator=attrs.validators.ge(0.0))
    log: bool = option(False, "Also write each day's log, every step and decision, into "
                              "day_N.npz, which `cbr rupart day` draws.")
    replay: bool = option(
        False, "Every day repeats the first: the same messages and the same draws of sensor "
        "noise (people and doors keep their schedules), so that from one day to the next only "
        "what the robot learned changes.")


@attrs.frozen
class DayRow:
    """One row of ``days.csv``."""

    day: int
    messages: int
    delivered: int
    """Messages delivered before their deadline."""
    missed: int
    """Messages whose deadline passed (or was given up) during the day."""
    unfinished: int
    """Messages still pending at the day's end, their deadline later."""
    collisions: int
    contacts: int
    mean_delivery_time: float
    distance: float
    consultations: int
    adapted: int
    plans: int
    meta_plans: int
    busy_speed: float
    """Mean true speed while the robot had a message to deliver, m/s."""
    retrievals_per_minute: float
    """Consultations per minute of the day."""
    median_install: float
    """Median seconds a retrieved behavior set stayed installed (nan with none)."""
    longest_stall: float
    """The longest time, seconds, the robot stayed within :data:`STALL_RADIUS` of one spot
    while busy, not counting waits before a shut door on its route."""
    door_wait: float
    """Seconds spent waiting before shut doors on the route."""


@attrs.define
class _Spell:
    decision: Decision
    started: float
    heading: Point
    """Where the robot was sent when the spell began: its goal, home when it had none."""
    progress_from: float
    collisions: int
    impasses: int
    delivered: int
    waited: float


class Delivery:
    """The days of message delivery (see the module docstring)."""

    def __init__(self, options: DeliveryOptions, ctx: Context) -> None:
        self.options = options
        self.ctx = ctx
        self.world: World = world_of(ctx, "workload 'delivery'")
        pilot = ctx.stash.get(PILOT, None)
        if pilot is None or (options.consult and not isinstance(pilot, BehaviorPilot)):
            raise CbrError("workload 'delivery' installs behavior sets: name the 'behaviors' "
                           "pilot in the configuration's 'pilot' slot"
                           + ("" if pilot is None else f", not a {type(pilot).__name__}")
                           + " (another pilot drives only with 'consult: false')")
        self.pilot = pilot
        self.default = (tuple(a.data for a in pilot.behaviors)
                        if isinstance(pilot, BehaviorPilot) else ())
        self.home = self.world.point(options.start, "workload.start")
        self.planner: Any = None
        self.rng = ctx.spawn_rng()
        # a replayed day draws from one child seed each time, the next days' streams unused
        self.replayed = self.rng.bit_generator.seed_seq.spawn(1)[0] if options.replay else None
        self.paths: dict[str, np.ndarray] = {}
        self.records: list[dict[str, Any]] = []
        """The goal manager's records of the last day (:data:`DELIVERY_COLUMNS`)."""
        self.fields: dict[str, np.ndarray] | None = None
        self._installed_name = DEFAULT_SET

    def __len__(self) -> int:
        return 0  # decisions are made as the day unfolds: no count is known before

    def describe(self, problem: Moment) -> Mapping[str, Any]:
        location = problem.index.location or (math.nan, math.nan)
        return {"t": round(problem.t, 3), "triggers": "+".join(problem.triggers),
                "x": round(location[0], 3), "y": round(location[1], 3)}

    def run(self, session: Session) -> None:
        out = self.ctx.out_dir
        if out is None:
            for day in range(self.options.days):
                self._day(session, day)
            return
        # written as the days end, like results.csv, so a run cut short keeps what it did
        with (open(out / "days.csv", "w", newline="", encoding="utf-8") as days,
              open(out / "deliveries.csv", "w", newline="", encoding="utf-8") as deliveries):
            day_writer = csv.writer(days)
            day_writer.writerow([f.name for f in attrs.fields(DayRow)])
            message_writer = csv.writer(deliveries)
            message_writer.writerow(["day", *DELIVERY_COLUMNS])
            for day in range(self.options.days):
                row = self._day(session, day)
                day_writer.writerow(attrs.astuple(row))
                message_writer.writerows([day, *(r[c] for c in DELIVERY_COLUMNS)]
                                         for r in self.records)
                days.flush()
                deliveries.flush()
        if self.options.trajectories:
            with files.replacing(out / "trajectories.npz", "wb") as handle:
                np.savez_compressed(handle, **self.paths)

    # --- one day --------------------------------------------------------------------------

    def _day(self, session: Session, day: int) -> DayRow:
        from cbr_behaviors.daylog import DayLog
        from cbr_behaviors.eta import RouteEta, route_fields
        from cbr_behaviors.globalmap import GlobalMap
        from cbr_behaviors.goals import GoalManager
        from cbr_behaviors.messages import message_day, straight_line
        from cbr_behaviors.triggers import ReplanMonitor
        from cbr_world2d.navigator import Navigator
        from cbr_world2d.robot import PIONEER_2DX, Pose
        from cbr_world2d.sensors import Camera, Odometry, Sensors
        from cbr_world2d.simulation import Simulation

        o = self.options
        rng = (self.rng.spawn(1)[0] if self.replayed is None
               else np.random.default_rng(self.replayed))
        messages = message_day(self.world, rng, length=o.length, rate_per_hour=o.rate,
                               origin=self.home, eta=straight_line(CRUISE / ETA_DETOUR))
        spec = PIONEER_2DX
        sensors = Sensors(camera=Camera(), odometry=Odometry(o.odometry_noise, o.odometry_noise))
        if isinstance(self.pilot, BehaviorPilot):
            self.pilot.install(parse_behavior_set(list(self.default)))
        else:
            self.pilot.reset()
        self._installed_name = DEFAULT_SET
        sim = Simulation(self.world, spec, sensors.fitted(spec.radius), Navigator(self.pilot),
                         Pose(*self.home, 0.0), self.home, dt=0.1, rng=rng,
                         tolerance=o.waypoint, capacity=int(o.length / 0.1) + 2,
                         recorder=self.ctx.stash.get(RECORDER, None))
        gmap = GlobalMap(self.world, fade=o.fade, robot_radius=spec.radius, plan_cell=o.cell)
        if self.planner is None:
            self.planner = self._planner(gmap)
        points = {**self.world.places, "start": self.home}
        origin = (self.world.bounds[0], self.world.bounds[1])
        if self.fields is None:
            self.fields = route_fields(gmap.permanent(o.cell), o.cell, origin, points)
        eta = RouteEta(self.fields, points, o.cell, origin, CRUISE)
        goals = GoalManager(eta, radius=o.deliver_radius)
        goals.receive(messages)
        state = _DayState(sim, gmap, goals, ReplanMonitor(o.triggers), len(messages), eta,
                          log=DayLog(day) if o.log else None)
        spell: _Spell | None = None
        counts = {"consultations": 0, "adapted": 0, "plans": 0, "meta_plans": 0}
        obs = sim.observe()
        last = math.ceil(o.length / sim.dt - 1e-9)
        while sim.steps < last:
            fired = self._tick(state, obs)
            if o.consult and fired:
                if spell is not None:
                    self._learn(session, state, spell)
                spell = self._consult(session, state, obs, fired, counts)
                state.monitor.retrieved(state.snapshot(obs, ()))
            obs = sim.step()
        if spell is not None:
            self._learn(session, state, spell)
        for missed in goals.close(sim.t):
            state.note("unfinished", missed.message.point, missed.message.place)
        if o.trajectories:
            self.paths[f"day_{day}"] = sim.trajectory[:, :4].copy()
        if state.log is not None and self.ctx.out_dir is not None:
            clocks = sim.mover_clocks
            if clocks is not None:
                state.log.clocks = clocks[np.rint(state.log.track().t / sim.dt).astype(int)]
            state.log.save(self.ctx.out_dir / f"day_{day}.npz")
        return self._summary(day, state, counts)

    def _tick(self, state: _DayState, obs: Observation) -> tuple[str, ...]:
        """One step of the goal manager, the global map and the plan manager; the re-planning
        triggers that fired."""
        from cbr_behaviors.situation import people_in_view

        sim, o = state.sim, self.options
        t, true = obs.t, obs.true_pose
        decided = state.goals.update((true.x, true.y), t)
        for m in decided.arrived:
            state.note("message", m.point, m.place)
        for d in decided.delivered:
            state.note("delivered", d.message.point, d.message.place)
        for m in decided.missed:
            state.note("missed", m.message.point, m.message.place)
        state.people = people_in_view(sim.crowd, true, obs.pose, sim.dt, obs.v)
        seen = np.array([(p.x, p.y) for p in state.people]).reshape(-1, 2)
        change = state.gmap.update(obs.pose, obs.sonar, obs.sonar_angles, t, seen)
        if getattr(self.pilot, "localizing", False) and len(obs.sightings) >= 2:
            # 004: localization is done by the map subsystem from the landmarks the robot
            # recognises while a localize behavior collects observations
            sim.sensors.odometry.reset(obs.true_pose)
        goal = None if decided.target is None else decided.target.point
        if goal != state.goal:
            state.goal, state.plan_case = goal, None
            state.plan((obs.pose.x, obs.pose.y), self.planner, (), self.home)
        elif any(e.name in STUCK for e in sim.events):
            # the plan manager routes again round what the global map holds now: the same
            # plan, no new one to re-plan the behaviors for
            state.plan((obs.pose.x, obs.pose.y), self.planner, state.steps, self.home,
                       new=False)
        state.advance((obs.pose.x, obs.pose.y), o.waypoint)
        target = state.target if state.target is not None else self.home
        if target != sim.target:
            sim.retarget(target)
        state.track(obs, self._installed_name)
        fired = state.monitor.check(state.snapshot(obs, decided.arrived, change))
        state.plan_installed = False
        if "impasse" in fired and o.consult:
            # the set in force got the robot stuck: out of retrieval for a while
            state.excluded[freeze([a.data for a in self.pilot.behaviors])] = t + o.exclude
        return tuple(fired)

    def _consult(self, session: Session, state: _DayState, obs: Observation,
                 fired: tuple[str, ...], counts: dict[str, int]) -> _Spell:
        t = obs.t
        state.excluded = {k: until for k, until in state.excluded.items() if until > t}
        moment = Moment(t, fired, self._index(state, obs), state.target, state.goal,
                        tuple(a.data for a in self.pilot.behaviors), state.plan_case,
                        excluded=tuple(state.excluded))
        decision = session.consult(moment)
        counts["consultations"] += 1
        solution = decision.proposal.solution
        value = None if solution is None else solution.value
        choice = solution.payload if solution is not None else None
        kind = choice.kind if isinstance(choice, CaseChoice) else ""
        if isinstance(value, InstallBehaviors):
            if freeze(value.behaviors) != freeze([a.data for a in self.pilot.behaviors]):
                # the same set again keeps running: installing restarts what behaviors latch
                self.pilot.install(parse_behavior_set(list(value.behaviors)))
                state.installed(t)
            self._installed_name = value.name
            counts["adapted"] += value.adapted is not None
            counts["meta_plans"] += kind == "meta_plan"
        elif isinstance(value, InstallPlan):
            counts["plans"] += 1
            state.plan_case = value.name
            state.plan((obs.pose.x, obs.pose.y), self.planner, value.route, self.home)
            if value.localize:
                self.pilot.install(parse_behavior_set([[["localize"], "high"],
                                                       *self.default]))
                state.installed(t)
                self._installed_name = value.name
        elif value is not None:
            raise PluginError(f"workload 'delivery': the proposal for query {decision.index} "
                              f"is a {type(value).__name__}, expected InstallBehaviors or "
                              "InstallPlan (cbr_behaviors.moment)")
        recorder = self.ctx.stash.get(RECORDER, None)
        if recorder is not None:
            recorder.decision(decision.index, decision.proposal, action=_action(value),
                              detail={"fired": list(fired), "kind": kind,
                                      "installed": self._installed_name})
        if state.log is not None:
            similarity = 1.0 - (choice.distance if isinstance(choice, CaseChoice) else math.nan)
            adapted = isinstance(value, InstallBehaviors) and value.adapted is not None
            state.log.retrieval(t, getattr(value, "name", ""), kind, fired, similarity, adapted)
        heading = state.goal if state.goal is not None else self.home
        return _Spell(decision, t, heading, state.to_goal(obs, heading), state.collisions,
                      state.impasses, len(state.goals.delivered), state.door_wait)

    def _learn(self, session: Session, state: _DayState, spell: _Spell) -> None:
        sim = state.sim
        report = SpellReport(round(sim.t - spell.started, 4),
                             round(spell.progress_from
                                   - state.to_goal(sim.observe(), spell.heading), 4),
                             state.collisions - spell.collisions, state.impasses - spell.impasses,
                             len(state.goals.delivered) - spell.delivered,
                             round(state.door_wait - spell.waited, 4))
        session.learn(spell.decision, Outcome(report.good, cost=report.active, report=report))

    def _index(self, state: _DayState, obs: Observation) -> Index:
        from cbr_behaviors.index import ATTRIBUTES, SITUATION, SONAR_BEAMS, SONAR_MAX, Index

        pose = obs.pose
        goals = state.goals
        primary = goals.primary
        sonar = np.clip(np.asarray(obs.sonar, dtype=float)[:SONAR_BEAMS], 0.0, SONAR_MAX)
        goal_term: tuple[str, ...] = ()
        urgency = 0.0
        if primary is not None:
            goal_term = ("deliver", primary.place, primary.priority)
            left = primary.deadline - obs.t
            needed = state.eta((pose.x, pose.y), primary.point)
            urgency = 1.0 if left <= 0 else min(1.0, needed / left)
        situation = dict(zip(SITUATION, state.situation(obs).tolist(), strict=True))
        return Index(
            sonar=tuple(float(v) for v in sonar), motors=(obs.v, obs.w),
            map=frozenset(state.gmap.objects_near((pose.x, pose.y))),
            location=(pose.x, pose.y),
            behaviors=frozenset(a.data[0][0] for a in self.pilot.behaviors),
            task_loc=state.target if state.target is not None else self.home,
            task_urgency=urgency, plan=state.steps, goal=goal_term,
            goal_urgency=0.0 if primary is None else PRIORITY_URGENCY[primary.priority],
            pending_goals=frozenset(m.place for m in goals.pending),
            loc_conf=obs.confidence, plan_conf=state.plan_confidence(pose),
            behav_conf=state.behavior_confidence(),
            **{ATTRIBUTES[f]: v for f, v in situation.items()})

    def _planner(self, gmap: GlobalMap) -> Any:
        """The ``planner`` solver, built on the rasterised global map it plans on (a grid
        solver checks at construction that it is given a grid world)."""
        from cbr_grid.planning import planner_of

        ctx = Context(registry=self.ctx.registry, seed=self.ctx.seed,
                      world=gmap.raster(gmap.plan_cell))
        return planner_of(self.options.planner, ctx, "workload 'delivery': planner")

    def _summary(self, day: int, state: _DayState, counts: dict[str, int]) -> DayRow:
        goals = state.goals
        times = [d.time for d in goals.delivered]
        self.records = goals.records()
        unfinished = sum(m.why == "unfinished" for m in goals.missed)
        minutes = state.sim.t / 60.0
        installs = state.install_times(state.sim.t)
        return DayRow(day, state.messages, len(goals.delivered),
                      len(goals.missed) - unfinished, unfinished,
                      state.collisions, state.sim.collisions,
                      round(float(np.mean(times)), 3) if times else math.nan,
                      round(state.sim.distance, 3), counts["consultations"], counts["adapted"],
                      counts["plans"], counts["meta_plans"],
                      round(state.busy_distance / state.busy_time, 4) if state.busy_time
                      else math.nan,
                      round(counts["consultations"] / minutes, 3) if minutes else math.nan,
                      round(float(np.median(installs)), 3) if installs else math.nan,
                      round(state.longest_stall, 1), round(state.door_wait, 1))


DEFAULT_SET = "default"
"""The name the day log gives the pilot's own behavior set (installed at the start of a day and
all day with ``consult: false``)."""
CRUISE = 0.3
"""m/s: the speed the goal manager's time estimates assume (the ``mod-fast`` speed)."""
ETA_DETOUR = 1.4
"""How much longer than the straight line a route on the floor is taken to be."""
RAM_SPEED = 0.05
"""m/s: a contact counts as a collision of the robot's when the robot drove into it: forward
faster than this, the contact ahead within ``COLLISION_ARC`` of its heading (the arc
avoidCollision watches), and the robot closing the gap faster than the person or object it
touched did (:data:`MOVER_REACH`). People walk into a robot that stands, yields or creeps, and
pass it (every contact is counted in ``contacts``); only the collisions are the robot's
doing."""
MOVER_REACH = 0.3
"""Metres: the person or object the robot touched is the nearest one this near its rim."""
PLAN_SLACK = 1.25
"""A plan case's places are kept when the route through them is at most this many times as
long as the direct route: a case planned for another errand may still lie on the way."""


STALL_RADIUS = 0.5
"""Metres: the robot is stalled while it stays within this of where the stall began."""
WAIT_REACH = 2.5
"""Metres: a robot this near a shut door on its route, straight-line to the doorway's centre,
is waiting for it to open (not stalled, and no impasse)."""


@attrs.define
class _DayState:
    sim: Simulation
    gmap: GlobalMap
    goals: GoalManager
    monitor: Any
    messages: int
    eta: RouteEta
    log: DayLog | None = None
    goal: Point | None = None
    route: list[Point] = attrs.field(factory=list)
    route_total: float = 0.0
    steps: tuple[str, ...] = ()
    plan_case: str | None = None
    passed: Point | None = None
    plan_installed: bool = False
    impasses: int = 0
    collisions: int = 0
    """Contacts the robot drove into (see :data:`RAM_SPEED`)."""
    people: list[PersonSeen] = attrs.field(factory=list)
    """The people in view at this step."""
    excluded: dict[Any, float] = attrs.field(factory=dict)
    """Behavior sets (frozen) kept out of retrieval, with the time until which."""
    busy_distance: float = 0.0
    busy_time: float = 0.0
    longest_stall: float = 0.0
    door_wait: float = 0.0
    _stall: tuple[float, float, float] | None = None
    """(t, x, y) where the current stall began."""
    _installs: list[float] = attrs.field(factory=list)
    _bumped: bool = False
    _speed: float = 0.0
    _history: list[tuple[float, float]] = attrs.field(factory=list)
    _door: tuple[float, bool] | None = None
    _door_t: float = -math.inf
    """The half-second tick of the doorway ahead kept in ``_door``."""

    @property
    def target(self) -> Point | None:
        return self.route[0] if self.route else self.goal

    def plan(self, at: Point, planner: Any, via: tuple[str, ...], home: Point,
             new: bool = True) -> None:
        """Route from ``at`` to the goal (home when idle), through the places ``via`` of a plan
        case when they are on the way; with no route the goal itself becomes the target.

        The adaptation of a plan case (004 leaves its strategies out): its places are kept
        when the route through them is at most :data:`PLAN_SLACK` times as long as the route
        planned directly, else dropped; a place the world does not have drops them too.
        ``new``: a new high-level plan (a new goal or a plan case), which fires the ``plan``
        trigger; a route planned again round an obstacle is not one."""
        goal = self.goal if self.goal is not None else home
        world = self.sim.world
        direct = self.gmap.route(planner, at, goal)
        chosen, steps = direct, ()
        if via and all(p in world.places for p in via):
            through = self.gmap.route(planner, at, goal, via=[world.places[p] for p in via])
            if through is not None and (direct is None
                                        or _length(through) <= PLAN_SLACK * _length(direct)):
                chosen, steps = through, via
        self.plan_installed = new
        self.passed = at
        self.route = [goal] if chosen is None else list(chosen)
        self.steps = steps if chosen is not None else ()
        self.route_total = self.remaining(at)
        self._door_t = -math.inf  # a new route: look again
        if self.sim.recording is not None:
            self.sim.recording.route([at, *self.route])

    def remaining(self, at: Point) -> float:
        """Metres of route left from ``at``."""
        if not self.route:
            return 0.0
        return math.dist(at, self.route[0]) + _length(self.route)

    def door(self, at: Point, t: float) -> tuple[float, bool] | None:
        """The doorway ahead on the route (:func:`cbr_behaviors.situation.door_ahead`),
        looked at afresh every half second."""
        from cbr_behaviors.situation import door_ahead

        # on a fixed half-second clock, so that looking more often changes nothing
        tick = math.floor(t / 0.5)
        if tick != self._door_t:
            self._door = door_ahead(self.sim.world, at, self.route, t) if self.route else None
            self._door_t = tick
        return self._door

    def situation(self, obs: Observation) -> np.ndarray:
        """The values of :data:`cbr_behaviors.index.SITUATION` now."""
        from cbr_behaviors.index import SONAR_MAX
        from cbr_behaviors.situation import (
            CLOSING_SCALE,
            DOOR_REACH,
            PERSON_REACH,
            WIDTH_SCALE,
            free_width,
            progress,
            sectors,
        )

        at = (obs.pose.x, obs.pose.y)
        front, left, right, rear = sectors(obs.sonar, obs.sonar_angles)
        width = free_width(obs.sonar, obs.sonar_angles, 2.0 * self.sim.spec.radius)
        person = self.people[0] if self.people else None
        door = self.door(at, obs.t)
        return np.array([
            front / SONAR_MAX, left / SONAR_MAX, right / SONAR_MAX, rear / SONAR_MAX,
            min(1.0, width / WIDTH_SCALE),
            1.0 if person is None else min(1.0, max(0.0, person.distance) / PERSON_REACH),
            1.0 if person is None else abs(person.bearing) / math.pi,
            0.0 if person is None else min(1.0, max(0.0, person.closing) / CLOSING_SCALE),
            1.0 if door is None else min(1.0, door[0] / DOOR_REACH),
            0.0 if door is None else float(door[1]),
            progress(self.remaining(at), self.route_total) if self.goal is not None else 1.0,
        ])

    def waiting(self, obs: Observation) -> bool:
        """Whether the robot is before a shut door on its route, within :data:`WAIT_REACH`."""
        door = self.door((obs.pose.x, obs.pose.y), obs.t)
        return door is not None and door[1] and door[0] <= WAIT_REACH

    def note(self, kind: str, at: Point, text: str = "") -> None:
        """An event for the day log."""
        if self.log is not None:
            self.log.event(self.sim.t, kind, at[0], at[1], text)

    def installed(self, t: float) -> None:
        """A new behavior set was installed at ``t``."""
        self._installs.append(t)

    def install_times(self, end: float) -> list[float]:
        """How long each behavior set installed stayed installed (the last until ``end``)."""
        return [b - a for a, b in itertools.pairwise([*self._installs, end])]

    def advance(self, at: Point, within: float) -> None:
        while len(self.route) > 1 and math.dist(at, self.route[0]) <= within:
            self.passed = self.route.pop(0)

    def to_target(self, obs: Observation) -> float:
        target = self.target
        if target is None:
            return 0.0
        return math.dist((obs.pose.x, obs.pose.y), target)

    def to_goal(self, obs: Observation, goal: Point) -> float:
        """Metres of route from the robot to ``goal`` over the permanent map: a spell's
        progress is measured by it, not by the distance to the next waypoint, which jumps
        back each time a waypoint is passed."""
        return self.eta.length((obs.pose.x, obs.pose.y), goal)

    def track(self, obs: Observation, case: str) -> None:
        true = obs.true_pose
        busy = self.goal is not None
        # an idle robot short of its home spot is on no errand to be stuck on
        stuck = sum(e.name in STUCK for e in self.sim.events) if busy else 0
        self.impasses += stuck
        if stuck:
            self.note("impasse", (true.x, true.y))
        if (obs.bumped and not self._bumped and self._speed > RAM_SPEED
                and abs(obs.bump_bearing) <= COLLISION_ARC
                and self._speed * math.cos(obs.bump_bearing) > self._closing(obs)):
            self.collisions += 1
            self.note("collision", (true.x, true.y))
        dt = self.sim.dt
        if busy:
            self.busy_time += dt
            self.busy_distance += abs(obs.v) * dt
            self.eta.observe(abs(obs.v) * dt, dt)
        waiting = busy and self.waiting(obs)
        if waiting:
            self.door_wait += dt
        if (not busy or waiting or self._stall is None
                or math.hypot(true.x - self._stall[1], true.y - self._stall[2]) > STALL_RADIUS):
            if self._stall is not None and obs.t - self._stall[0] >= 60.0:
                self.note("stall", (self._stall[1], self._stall[2]),
                          f"{obs.t - self._stall[0]:.0f} s")
            self._stall = (obs.t, true.x, true.y) if busy and not waiting else None
        else:
            self.longest_stall = max(self.longest_stall, obs.t - self._stall[0])
        if self.log is not None:
            self.log.step(obs.t, true.x, true.y, true.theta, obs.v, obs.w, case,
                          self.target if busy else None, busy)
        self._bumped, self._speed = obs.bumped, obs.v
        self._history.append((obs.t, self.to_target(obs)))
        while self._history and self._history[0][0] < obs.t - PROGRESS_WINDOW:
            self._history.pop(0)

    def _closing(self, obs: Observation) -> float:
        """How fast the nearest person or object within :data:`MOVER_REACH` of the robot came
        toward it over the last step, m/s (0 with none: walls and doors stand still)."""
        crowd, t, dt = self.sim.crowd, obs.t, self.sim.dt
        x, y = obs.true_pose.x, obs.true_pose.y
        closing, nearest = 0.0, MOVER_REACH
        for mover, (x1, y1), (x0, y0) in zip(crowd.world.movers, crowd.now, crowd.before,
                                             strict=True):
            if not mover.present(t):
                continue
            gap = math.hypot(x - x1, y - y1) - mover.radius
            if gap < nearest:
                nearest = gap
                closing = (math.hypot(x - x0, y - y0) - math.hypot(x - x1, y - y1)) / dt
        return closing

    def behavior_confidence(self) -> float:
        """behav-conf: the progress toward the target over the last
        :data:`PROGRESS_WINDOW` seconds against what cruising would make, in [0, 1]."""
        if len(self._history) < 2 or self.target is None:
            return 1.0
        (t0, d0), (t1, d1) = self._history[0], self._history[-1]
        if t1 <= t0 or d1 < 0.5:
            return 1.0
        return min(1.0, max(0.0, (d0 - d1) / (CRUISE * (t1 - t0))))

    def plan_confidence(self, pose: Any) -> float:
        """plan-conf: falls off as the robot strays from the leg of its route it is on, from
        the waypoint it passed last to the next (1 on it, 1/e a metre off)."""
        if not self.route or self.passed is None:
            return 1.0
        return math.exp(-_off_leg((pose.x, pose.y), self.passed, self.route[0]))

    def snapshot(self, obs: Observation, arrived: Any, change: Any = None) -> Any:
        from cbr_behaviors.triggers import Snapshot

        status = self.sim.navigator.status
        return Snapshot(t=obs.t, pose=obs.pose, sonar=obs.sonar, confidence=obs.confidence,
                        added=0 if change is None else change.added,
                        removed=0 if change is None else change.removed,
                        critical=sum(m.priority == "critical" for m in arrived),
                        plan_installed=self.plan_installed, distance=self.sim.distance,
                        target=self.target, status=status, situation=self.situation(obs),
                        waiting=self.waiting(obs), busy=self.goal is not None)


def _action(value: Any) -> str:
    """A consultation's answer in words, for a recording's decision."""
    if isinstance(value, InstallBehaviors):
        behaviors = ", ".join(str(item[0][0]) for item in value.behaviors)
        adapted = " (adapted)" if value.adapted is not None else ""
        return f"install {value.name}{adapted}: {behaviors}"
    if isinstance(value, InstallPlan):
        localize = ", localize first" if value.localize else ""
        return f"plan {value.name} via {', '.join(value.route) or 'no place'}{localize}"
    return "keep the installed behaviors"


def _length(route: list[Point]) -> float:
    return sum(math.dist(a, b) for a, b in itertools.pairwise(route))


def _off_leg(at: Point, a: Point, b: Point) -> float:
    """Distance from ``at`` to the segment from ``a`` to ``b``."""
    (ax, ay), (bx, by) = a, b
    dx, dy = bx - ax, by - ay
    length = dx * dx + dy * dy
    u = 0.0 if length == 0 else max(0.0, min(1.0, ((at[0] - ax) * dx + (at[1] - ay) * dy)
                                              / length))
    return math.hypot(at[0] - ax - u * dx, at[1] - ay - u * dy)
