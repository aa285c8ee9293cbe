"""The ``delivery`` workload: RUPART's day of message delivery on an office floor (004).

One robot (a Pioneer 2 DX with noisy odometry) spends ``days`` simulated days on the configured
2D world. Messages arrive at seeded random times (:mod:`cbr_behaviors.messages`) and become
navigation goals; the goal manager (:mod:`cbr_behaviors.goals`) picks the one to serve, gives
up those that can no longer be saved and serves pending ones on the way. Three parts run side
by side as in 004 Figure 2:

- the *behavior manager*: the ``behaviors`` pilot executing the installed behavior set, which
  keeps running while re-planning happens;
- the *plan manager*: the current goal's route, planned on the rasterised global map with the
  ``planner`` grid solver (:mod:`cbr_behaviors.globalmap`), its next waypoint the behaviors'
  target; the global map holds the transient objects the sonar reports until they fade;
- *action selection* (004 Figure 3): the re-planning triggers (:mod:`cbr_behaviors.triggers`)
  consult the engine with a :class:`~cbr_behaviors.moment.Moment`, the index of Figure 5 filled
  in from the simulation. A behavior case or meta-plan is installed at once; a plan case has
  the plan manager route through its places (deliberative re-planning).

Each decision is learned when the next retrieval replaces it or the day ends, its outcome's
report a :class:`~cbr_behaviors.moment.SpellReport`. With ``consult: false`` the robot keeps
the pilot's behavior set all day (004's comparison: one fixed hand-made behavior set).

Besides ``results.csv`` the workload writes ``deliveries.csv`` (a row per message: when it
arrived, its deadline, whether and when it was delivered or why it was missed) and
``days.csv`` (a row per day: deliveries, missed deadlines, collisions, mean delivery time,
consultations), and with ``trajectories`` the true path of each day in ``trajectories.npz``.
"""

from __future__ import annotations

import csv
import itertools
import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import attrs
import numpy as np

from cbr_behaviors.cases import freeze
from cbr_behaviors.moment import InstallBehaviors, InstallPlan, Moment, SpellReport
from cbr_behaviors.triggers import TriggerOptions
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
    from cbr_behaviors.globalmap import GlobalMap
    from cbr_behaviors.goals import GoalManager
    from cbr_behaviors.index import Index
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
                             "The grid solver the plan manager routes with on the rasterised "
                             "global map.")
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


@attrs.frozen
class DayRow:
    """One row of ``days.csv``."""

    day: int
    messages: int
    delivered: int
    missed: int
    collisions: int
    contacts: int
    mean_delivery_time: float
    distance: float
    consultations: int
    adapted: int
    plans: int
    meta_plans: int


@attrs.define
class _Spell:
    decision: Decision
    started: float
    progress_from: float
    collisions: int
    impasses: int
    delivered: int


class Delivery:
    """The days of message delivery (see the module docstring)."""

    def __init__(self, options: DeliveryOptions, ctx: Context) -> None:
        self.options = options
        self.ctx = ctx
        self.world: World = world_of(ctx, "workload 'delivery'")
        pilot = ctx.stash.get(PILOT, None)
        if not isinstance(pilot, BehaviorPilot):
            raise CbrError("workload 'delivery' installs behavior sets: name the 'behaviors' "
                           "pilot in the configuration's 'pilot' slot"
                           + ("" if pilot is None else f", not a {type(pilot).__name__}"))
        self.pilot = pilot
        self.default = tuple(a.data for a in pilot.behaviors)
        self.home = self.world.point(options.start, "workload.start")
        self.planner: Any = None
        self.rng = ctx.spawn_rng()
        self.paths: dict[str, np.ndarray] = {}
        self.records: list[dict[str, Any]] = []
        """The goal manager's records of the last day (:data:`DELIVERY_COLUMNS`)."""

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
        from cbr_behaviors.globalmap import GlobalMap
        from cbr_behaviors.goals import GoalManager
        from cbr_behaviors.messages import message_day, straight_line
        from cbr_behaviors.triggers import ReplanMonitor
        from cbr_world2d.navigator import Navigator
        from cbr_world2d.robot import PIONEER_2DX, Pose
        from cbr_world2d.sensors import Camera, Odometry, Sensors
        from cbr_world2d.simulation import Simulation

        o = self.options
        rng = self.rng.spawn(1)[0]
        eta = straight_line(CRUISE / ETA_DETOUR)
        messages = message_day(self.world, rng, length=o.length, rate_per_hour=o.rate,
                               origin=self.home, eta=eta)
        spec = PIONEER_2DX
        sensors = Sensors(camera=Camera(), odometry=Odometry(o.odometry_noise, o.odometry_noise))
        self.pilot.install(parse_behavior_set(list(self.default)))
        sim = Simulation(self.world, spec, sensors.fitted(spec.radius), Navigator(self.pilot),
                         Pose(*self.home, 0.0), self.home, dt=0.1, rng=rng,
                         tolerance=o.waypoint, capacity=int(o.length / 0.1) + 2)
        gmap = GlobalMap(self.world, fade=o.fade, robot_radius=spec.radius, plan_cell=o.cell)
        if self.planner is None:
            self.planner = self._planner(gmap)
        goals = GoalManager(eta, radius=o.deliver_radius)
        goals.receive(messages)
        state = _DayState(sim, gmap, goals, ReplanMonitor(o.triggers), len(messages), eta)
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
        goals.close(sim.t)
        if o.trajectories:
            self.paths[f"day_{day}"] = sim.trajectory[:, :4].copy()
        return self._summary(day, state, counts)

    def _tick(self, state: _DayState, obs: Observation) -> tuple[str, ...]:
        """One step of the goal manager, the global map and the plan manager; the re-planning
        triggers that fired."""
        sim, o = state.sim, self.options
        t, true = obs.t, obs.true_pose
        decided = state.goals.update((true.x, true.y), t)
        arrived = decided.arrived
        change = state.gmap.update(obs.pose, obs.sonar, obs.sonar_angles, t)
        if self.pilot.localizing and len(obs.sightings) >= 2:
            # 004: localization is done by the map subsystem from the landmarks the robot
            # recognises while a localize behavior collects observations
            sim.sensors.odometry.reset(obs.true_pose)
        goal = None if decided.target is None else decided.target.point
        if goal != state.goal:
            state.goal, state.plan_case = goal, None
            state.plan((obs.pose.x, obs.pose.y), self.planner, (), self.home)
        elif any(e.name in STUCK for e in sim.events):
            # the plan manager routes again round what the global map holds now
            state.plan((obs.pose.x, obs.pose.y), self.planner, state.steps, self.home)
        state.advance((obs.pose.x, obs.pose.y), o.waypoint)
        target = state.target if state.target is not None else self.home
        if target != sim.target:
            sim.retarget(target)
        state.track(obs)
        fired = state.monitor.check(state.snapshot(obs, arrived, change))
        state.plan_installed = False
        return tuple(fired)

    def _consult(self, session: Session, state: _DayState, obs: Observation,
                 fired: tuple[str, ...], counts: dict[str, int]) -> _Spell:
        moment = Moment(obs.t, fired, self._index(state, obs), state.target, state.goal,
                        tuple(a.data for a in self.pilot.behaviors), state.plan_case)
        decision = session.consult(moment)
        counts["consultations"] += 1
        solution = decision.proposal.solution
        value = None if solution is None else solution.value
        if isinstance(value, InstallBehaviors):
            if freeze(value.behaviors) != freeze([a.data for a in self.pilot.behaviors]):
                # the same set again keeps running: installing restarts what behaviors latch
                self.pilot.install(parse_behavior_set(list(value.behaviors)))
            counts["adapted"] += value.adapted is not None
            counts["meta_plans"] += solution.detail.get("kind") == "meta_plan"
        elif isinstance(value, InstallPlan):
            counts["plans"] += 1
            state.plan_case = value.name
            state.plan((obs.pose.x, obs.pose.y), self.planner, value.route, self.home)
            if value.localize:
                self.pilot.install(parse_behavior_set([[["localize"], "high"],
                                                       *self.default]))
        elif value is not None:
            raise PluginError(f"workload 'delivery': the proposal for query {decision.index} "
                              f"is a {type(value).__name__}, expected InstallBehaviors or "
                              "InstallPlan (cbr_behaviors.moment)")
        return _Spell(decision, obs.t, state.to_target(obs), state.collisions,
                      state.impasses, len(state.goals.delivered))

    def _learn(self, session: Session, state: _DayState, spell: _Spell) -> None:
        sim = state.sim
        report = SpellReport(round(sim.t - spell.started, 4),
                             round(spell.progress_from - state.to_target(sim.observe()), 4),
                             state.collisions - spell.collisions, state.impasses - spell.impasses,
                             len(state.goals.delivered) - spell.delivered)
        session.learn(spell.decision, Outcome(report.good, cost=report.active, report=report))

    def _index(self, state: _DayState, obs: Observation) -> Index:
        from cbr_behaviors.index import SONAR_BEAMS, SONAR_MAX, Index

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
            behav_conf=state.behavior_confidence())

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
        return DayRow(day, state.messages, len(goals.delivered), len(goals.missed),
                      state.collisions, state.sim.collisions,
                      round(float(np.mean(times)), 3) if times else math.nan,
                      round(state.sim.distance, 3), counts["consultations"], counts["adapted"],
                      counts["plans"], counts["meta_plans"])


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


@attrs.define
class _DayState:
    sim: Simulation
    gmap: GlobalMap
    goals: GoalManager
    monitor: Any
    messages: int
    eta: Callable[[Point, Point], float]
    goal: Point | None = None
    route: list[Point] = attrs.field(factory=list)
    steps: tuple[str, ...] = ()
    plan_case: str | None = None
    passed: Point | None = None
    plan_installed: bool = False
    impasses: int = 0
    collisions: int = 0
    """Contacts the robot drove into (see :data:`RAM_SPEED`)."""
    _bumped: bool = False
    _speed: float = 0.0
    _history: list[tuple[float, float]] = attrs.field(factory=list)

    @property
    def target(self) -> Point | None:
        return self.route[0] if self.route else self.goal

    def plan(self, at: Point, planner: Any, via: tuple[str, ...], home: Point) -> None:
        """Route from ``at`` to the goal (home when idle), through the places ``via`` of a plan
        case when they are on the way; with no route the goal itself becomes the target.

        The adaptation of a plan case (004 leaves its strategies out): its places are kept
        when the route through them is at most :data:`PLAN_SLACK` times as long as the route
        planned directly, else dropped; a place the world does not have drops them too."""
        goal = self.goal if self.goal is not None else home
        world = self.sim.world
        direct = self.gmap.route(planner, at, goal)
        chosen, steps = direct, ()
        if via and all(p in world.places for p in via):
            through = self.gmap.route(planner, at, goal, via=[world.places[p] for p in via])
            if through is not None and (direct is None
                                        or _length(through) <= PLAN_SLACK * _length(direct)):
                chosen, steps = through, via
        self.plan_installed = True
        self.passed = at
        self.route = [goal] if chosen is None else list(chosen)
        self.steps = steps if chosen is not None else ()

    def advance(self, at: Point, within: float) -> None:
        while len(self.route) > 1 and math.dist(at, self.route[0]) <= within:
            self.passed = self.route.pop(0)

    def to_target(self, obs: Observation) -> float:
        target = self.target
        if target is None:
            return 0.0
        return math.dist((obs.pose.x, obs.pose.y), target)

    def track(self, obs: Observation) -> None:
        self.impasses += sum(e.name in STUCK for e in self.sim.events)
        if (obs.bumped and not self._bumped and self._speed > RAM_SPEED
                and abs(obs.bump_bearing) <= COLLISION_ARC
                and self._speed * math.cos(obs.bump_bearing) > self._closing(obs)):
            self.collisions += 1
        self._bumped, self._speed = obs.bumped, obs.v
        self._history.append((obs.t, self.to_target(obs)))
        while self._history and self._history[0][0] < obs.t - PROGRESS_WINDOW:
            self._history.pop(0)

    def _closing(self, obs: Observation) -> float:
        """How fast the nearest person or object within :data:`MOVER_REACH` of the robot came
        toward it over the last step, m/s (0 with none: walls and doors stand still)."""
        world, t, dt = self.sim.world, obs.t, self.sim.dt
        x, y = obs.true_pose.x, obs.true_pose.y
        closing, nearest = 0.0, MOVER_REACH
        for mover in world.movers:
            if not mover.present(t):
                continue
            (x1, y1), (x0, y0) = mover.position(t), mover.position(t - dt)
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
                        target=self.target, status=status)


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
