"""Trials in the 2D world: the step loop driven from outside, what a trial records (checked
against the trajectory itself, analytic contact points and brute-force geometry), seeds that
repeat a trial exactly, and batches on two processes that agree with one after another."""

from __future__ import annotations

import math
import pickle
import re

import attrs
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_world2d.navigator import Navigator, NavigatorOptions
from cbr_world2d.pilots import PotentialFieldOptions, potential_field_pilot
from cbr_world2d.robot import PIONEER_2DX, Pose, RobotSpec
from cbr_world2d.sensors import Observation, Odometry, Sensors, SonarRing
from cbr_world2d.shapes import free_point
from cbr_world2d.simulation import (
    REACHED,
    TIMEOUT,
    PilotRecipe,
    Simulation,
    Trial,
    random_trials,
    run_batch,
    run_trial,
    trial_seeds,
)
from cbr_world2d.world import Door, Landmark, Mover, Point, Wall, World
from cbr_world2d.worldfile import load_world
from cbrcore.errors import CbrError
from cbrcore.registry import Registry, UnknownComponent
from repo_paths import ROOT

WORLDS = ROOT / "plugins" / "cbr_world2d" / "worlds"
RADIUS = PIONEER_2DX.radius
POTENTIAL_FIELD = PilotRecipe("potential_field", potential_field_pilot, PotentialFieldOptions())
NOISY = Sensors(sonar=SonarRing(noise=0.03), odometry=Odometry(noise_v=0.05, noise_w=0.05))

OPEN = World((0.0, 0.0, 10.0, 10.0), name="open")
WALLED = World((0.0, 0.0, 10.0, 10.0), walls=(Wall((5.0, 0.0), (5.0, 10.0)),), name="walled")
# the target sits in a closed box: no pilot can reach it
BOXED = World((0.0, 0.0, 10.0, 10.0), walls=(
    Wall((7.0, 4.0), (9.0, 4.0)), Wall((9.0, 4.0), (9.0, 6.0)), Wall((9.0, 6.0), (7.0, 6.0)),
    Wall((7.0, 6.0), (7.0, 4.0))), name="boxed")
BUSY = World((0.0, 0.0, 12.0, 8.0),
             walls=(Wall((6.0, 0.0), (6.0, 3.0)), Wall((6.0, 5.0), (6.0, 8.0))),
             landmarks=(Landmark("l1", 4.0, 6.0, 0.2), Landmark("l2", 8.0, 2.0, 0.2)),
             doors=(Door((6.0, 3.0), (6.0, 5.0), period=20.0, open_for=12.0, phase=3.0),),
             movers=(Mover(((9.0, 1.0), (9.0, 7.0)), speed=0.5, radius=0.25),),
             points=((3.0, 2.0, 0.1),), name="busy")


class Constant:
    """A pilot that always asks for the same command, whatever it senses."""

    def __init__(self, v: float, w: float) -> None:
        self.v, self.w = v, w

    def command(self, obs: Observation, target: Point) -> tuple[float, float]:
        return self.v, self.w

    def reset(self) -> None:
        pass


class Scripted:
    """A pilot that plays a list of commands, one per step, then repeats the last."""

    def __init__(self, commands: list[tuple[float, float]]) -> None:
        self.commands = commands
        self.k = 0

    def command(self, obs: Observation, target: Point) -> tuple[float, float]:
        command = self.commands[min(self.k, len(self.commands) - 1)]
        self.k += 1
        return command

    def reset(self) -> None:
        self.k = 0


def simulation(world: World, pilot: object, start: Pose, target: Point, **kwargs: object
               ) -> Simulation:
    return Simulation(world, PIONEER_2DX, Sensors().fitted(RADIUS), Navigator(pilot), start,
                      target, **kwargs)


def path_length(trajectory: np.ndarray) -> float:
    return float(np.hypot(np.diff(trajectory[:, 1]), np.diff(trajectory[:, 2])).sum())


def point_segment_distances(x: np.ndarray, y: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Brute force: the distance from every point to every segment, ``(points, segments)``."""
    ax, ay, bx, by = (segments[:, k][None, :] for k in range(4))
    ex, ey = bx - ax, by - ay
    px, py = x[:, None], y[:, None]
    s = np.clip(((px - ax) * ex + (py - ay) * ey) / (ex * ex + ey * ey), 0.0, 1.0)
    return np.hypot(px - (ax + s * ex), py - (ay + s * ey))


# --- stepping from outside ------------------------------------------------------------------

def test_a_simulation_steps_one_dt_at_a_time_and_keeps_the_trajectory() -> None:
    sim = simulation(OPEN, Constant(0.2, 0.3), Pose(2.0, 2.0, 0.0), (8.0, 8.0), dt=0.05,
                     capacity=2)
    first = sim.observe()
    assert first.t == 0.0
    assert (first.true_pose.x, first.true_pose.y) == (2.0, 2.0)
    for k in range(1, 41):
        obs = sim.step()
        assert sim.steps == k
        assert sim.t == pytest.approx(k * 0.05, abs=1e-12)
        assert obs is sim.observe()
        assert obs.t == sim.t
        assert (obs.true_pose.x, obs.true_pose.y) == (sim.state.x, sim.state.y)
    trajectory = sim.trajectory
    # the buffer grew from two rows; every row is still the state of its step
    assert trajectory.shape == (41, 6)
    assert np.allclose(trajectory[:, 0], np.arange(41) * 0.05, atol=1e-12)
    assert tuple(trajectory[0, 1:]) == (2.0, 2.0, 0.0, 0.0, 0.0)
    assert tuple(trajectory[-1, 1:]) == (sim.state.x, sim.state.y, sim.state.theta, sim.state.v,
                                         sim.state.w)
    assert sim.distance == pytest.approx(path_length(trajectory), abs=1e-12)
    assert not trajectory.flags.writeable


def test_a_diversion_asked_from_outside_is_recorded_until_the_rescuer_restores_the_target(
        ) -> None:
    pilot = potential_field_pilot(PotentialFieldOptions(), None)  # type: ignore[arg-type]
    sim = simulation(OPEN, pilot, Pose(1.0, 5.0, 0.0), (9.0, 5.0))
    for _ in range(5):
        sim.step()
    sim.navigator.divert((3.0, 8.0))
    restored = None
    for _ in range(2000):
        sim.step()
        names = [e.name for e in sim.events]
        if "restored" in names:
            restored = sim.events[names.index("restored")]
            break
    assert restored is not None
    diverted = [e for e in sim.history if e.name == "diverted"]
    assert [e.point for e in diverted] == [(3.0, 8.0)]
    assert restored.detail == REACHED
    # the Rescuer restores once the robot (noiseless odometry: where it truly is) is within
    # its tolerance of the diverting target
    tolerance = sim.navigator.rescuer.options.tolerance
    assert math.dist((restored.x, restored.y), (3.0, 8.0)) <= tolerance
    while not sim.reached and sim.t < 120.0:
        sim.step()
    assert sim.reached
    assert math.dist((sim.state.x, sim.state.y), (9.0, 5.0)) <= sim.tolerance


def test_a_contact_counts_once_however_long_the_robot_pushes() -> None:
    sim = simulation(WALLED, Constant(0.3, 0.0), Pose(1.0, 5.0, 0.0), (9.0, 5.0))
    bumped = []
    for _ in range(300):
        bumped.append(sim.step().bumped)
    assert sum(bumped) > 100  # it kept pushing into the wall
    assert sim.collisions == 1
    hits = [e for e in sim.history if e.name == "collision"]
    assert len(hits) == 1
    # stopped where the disc touches the wall at x = 5
    assert hits[0].x == pytest.approx(5.0 - RADIUS, abs=1e-4)
    assert hits[0].t == pytest.approx((bumped.index(True) + 1) * sim.dt)
    assert sim.trajectory[:, 1].max() <= 5.0 - RADIUS


# --- trials --------------------------------------------------------------------------------

def test_a_trial_in_open_space_reaches_its_target() -> None:
    trial = Trial.facing((1.0, 1.0), (8.0, 7.0), timeout=120.0)
    result = run_trial(OPEN, trial, POTENTIAL_FIELD)
    assert result.success
    assert result.reason == REACHED
    final = result.trajectory[-1]
    assert math.dist(final[1:3], (8.0, 7.0)) <= trial.tolerance
    # the step before was not yet there: the trial stops as soon as it arrives
    assert math.dist(result.trajectory[-2, 1:3], (8.0, 7.0)) > trial.tolerance
    assert result.time == pytest.approx(result.steps * trial.dt)
    assert result.time == final[0]
    assert result.distance == pytest.approx(path_length(result.trajectory))
    assert result.distance >= math.dist((1.0, 1.0), (8.0, 7.0)) - trial.tolerance
    assert result.collisions == 0
    assert result.stuck == ()
    assert result.spec == PIONEER_2DX


def test_a_trial_that_cannot_arrive_times_out_and_says_where_it_got_stuck() -> None:
    trial = Trial.facing((1.0, 5.0), (8.0, 5.0), timeout=25.0)
    result = run_trial(BOXED, trial, POTENTIAL_FIELD)
    assert not result.success
    assert result.reason == TIMEOUT
    assert result.steps == 250
    assert result.time == pytest.approx(25.0)
    assert result.trajectory.shape == (251, 6)
    assert result.stuck
    for event in result.stuck:
        assert event.name in ("blocked", "oscillating")
        row = round(event.t / trial.dt)
        assert (event.x, event.y) == tuple(result.trajectory[row, 1:3])


def test_the_potential_field_is_stuck_in_scenario_2_until_the_timeout() -> None:
    world = load_world(WORLDS / "scenario2.yaml")
    trial = Trial.facing(world.places["start"], world.places["target"], timeout=150.0)
    result = run_trial(world, trial, POTENTIAL_FIELD)
    assert result.reason == TIMEOUT
    assert result.stuck
    # stuck inside the V of l1-l2-l3, short of its apex l2
    l1, l2 = world.landmark("l1"), world.landmark("l2")
    for event in result.stuck:
        assert l1.x < event.x < l2.x


def test_the_rescuer_diverting_on_its_own_is_recorded_in_the_result() -> None:
    world = load_world(WORLDS / "scenario2.yaml")
    trial = Trial.facing(world.places["start"], world.places["target"], timeout=120.0)
    result = run_trial(world, trial, POTENTIAL_FIELD,
                       navigation=NavigatorOptions(rescue="stuck"))
    diverted = [e for e in result.events if e.name == "diverted"]
    assert diverted
    assert result.diverting == tuple(e.point for e in diverted)
    assert all(e.detail == "rescuer" for e in diverted)


@pytest.mark.parametrize(("start", "target", "named"), [
    ((5.1, 5.0), (8.0, 5.0), "start 5.1,5 is"),
    ((0.1, 5.0), (8.0, 5.0), "start 0.1,5 is"),
    ((-3.0, 5.0), (8.0, 5.0), "start -3,5 is outside the bounds"),
    ((1.0, 5.0), (18.0, 5.0), "target 18,5 is outside the bounds [0, 0, 10, 10]"),
])
def test_a_trial_refuses_a_start_in_the_way_or_a_target_outside(start: Point, target: Point,
                                                                named: str) -> None:
    with pytest.raises(CbrError, match="^" + re.escape(named)):
        run_trial(WALLED, Trial.facing(start, target), POTENTIAL_FIELD)


def test_a_start_touching_a_person_is_refused_and_the_person_named() -> None:
    with pytest.raises(CbrError, match=re.escape("a person at [9, 1] at t = 0")):
        Trial.facing((9.2, 1.0), (1.0, 1.0)).check(BUSY, PIONEER_2DX)


def test_trial_options_must_be_positive() -> None:
    for key in ("timeout", "tolerance", "dt"):
        with pytest.raises(ValueError, match=key):
            Trial(Pose(1.0, 1.0, 0.0), (2.0, 2.0), **{key: 0.0})


# --- seeds ---------------------------------------------------------------------------------

def test_the_same_seed_gives_the_same_trial_and_another_seed_another() -> None:
    trial = Trial.facing((1.0, 4.0), (11.0, 4.0), timeout=60.0)
    first = run_trial(BUSY, trial, POTENTIAL_FIELD, sensors=NOISY, seed=7)
    again = run_trial(BUSY, trial, POTENTIAL_FIELD, sensors=NOISY, seed=7)
    other = run_trial(BUSY, trial, POTENTIAL_FIELD, sensors=NOISY, seed=8)
    assert first == again
    assert np.array_equal(first.trajectory, again.trajectory)
    assert first.events == again.events
    # the noise drives the odometry the pilot steers by, so another seed drives elsewhere
    assert first != other
    assert not np.array_equal(first.trajectory[:50], other.trajectory[:50])


def test_a_trial_result_survives_pickling() -> None:
    result = run_trial(BUSY, Trial.facing((1.0, 4.0), (4.0, 1.0), timeout=20.0),
                       POTENTIAL_FIELD, seed=3)
    assert pickle.loads(pickle.dumps(result)) == result


def test_trial_seeds_do_not_depend_on_how_many_are_drawn() -> None:
    assert trial_seeds(5, 3) == trial_seeds(5, 8)[:3]
    assert len(set(trial_seeds(5, 100))) == 100


# --- batches -------------------------------------------------------------------------------

def test_a_batch_on_two_processes_gives_the_results_of_one_after_another() -> None:
    trials = random_trials(BUSY, 4, PIONEER_2DX, np.random.default_rng(2), timeout=15.0)
    parallel = run_batch(BUSY, trials, POTENTIAL_FIELD, sensors=NOISY, seed=11, workers=2)
    serial = run_batch(BUSY, trials, POTENTIAL_FIELD, sensors=NOISY, seed=11, workers=1)
    alone = [run_trial(BUSY, trial, POTENTIAL_FIELD, sensors=NOISY, seed=seed)
             for trial, seed in zip(trials, trial_seeds(11, 4), strict=True)]
    assert parallel == serial == alone
    assert [r.trial for r in parallel] == trials


def test_a_batch_checks_every_trial_before_running_any() -> None:
    trials = [Trial.facing((1.0, 1.0), (2.0, 2.0)), Trial.facing((5.0, 5.0), (2.0, 2.0))]
    with pytest.raises(CbrError, match=r"^trial 1: start 5,5"):
        run_batch(WALLED, trials, POTENTIAL_FIELD, workers=2)


def test_random_trials_start_and_end_where_the_robot_stands_free() -> None:
    trials = random_trials(BUSY, 30, PIONEER_2DX, np.random.default_rng(4), timeout=9.0)
    again = random_trials(BUSY, 30, PIONEER_2DX, np.random.default_rng(4), timeout=9.0)
    assert trials == again
    for trial in trials:
        assert trial.timeout == 9.0
        assert free_point(BUSY, trial.start.x, trial.start.y, RADIUS, t=0.0) is None
        assert free_point(BUSY, *trial.target, RADIUS, t=0.0) is None
        assert math.dist((trial.start.x, trial.start.y), trial.target) > trial.tolerance
        # facing the target
        bearing = math.atan2(trial.target[1] - trial.start.y, trial.target[0] - trial.start.x)
        assert trial.start.theta == pytest.approx(bearing)


def test_a_pilot_recipe_comes_from_the_registry_by_name() -> None:
    registry = Registry()
    registry.add_kind("pilot", "Drives the robot.")
    registry.add("pilot", "potential_field", potential_field_pilot,
                 options=PotentialFieldOptions)
    recipe = PilotRecipe.named("potential_field", {"max_speed": 0.2}, registry)
    assert recipe.options == attrs.evolve(PotentialFieldOptions(), max_speed=0.2)
    assert recipe.build().options.max_speed == 0.2
    assert pickle.loads(pickle.dumps(recipe)) == recipe
    with pytest.raises(UnknownComponent, match="unknown pilot 'wander'; registered: "
                                               "potential_field"):
        PilotRecipe.named("wander", registry=registry)


# --- properties over random worlds and controls ----------------------------------------------

walls = st.lists(st.tuples(*[st.floats(0.5, 9.5)] * 4).filter(
    lambda w: math.dist(w[:2], w[2:]) > 0.3), min_size=1, max_size=8)
commands = st.lists(st.tuples(st.floats(-0.4, 0.4), st.floats(-1.5, 1.5)), min_size=1,
                    max_size=20)


@settings(max_examples=30, deadline=None)
@given(walls=walls, commands=commands, seed=st.integers(0, 2**32 - 1))
def test_a_trial_keeps_its_books_and_never_enters_a_wall(
        walls: list[tuple[float, float, float, float]], commands: list[tuple[float, float]],
        seed: int) -> None:
    world = World((0.0, 0.0, 10.0, 10.0),
                  walls=tuple(Wall(w[:2], w[2:]) for w in walls))
    rng = np.random.default_rng(seed)
    start = random_trials(world, 1, PIONEER_2DX, rng)[0].start
    # each command held for 10 steps, so that the robot gets somewhere with it
    script = Scripted([c for c in commands for _ in range(10)])
    sim = simulation(world, script, start, (5.0, 5.0), rng=rng)
    bumped = [sim.step().bumped for _ in range(len(commands) * 10)]
    trajectory = sim.trajectory
    gaps = point_segment_distances(trajectory[:, 1], trajectory[:, 2], world.static_segments)
    assert gaps.min() >= RADIUS - 1e-6
    assert sim.distance == pytest.approx(path_length(trajectory), abs=1e-9)
    rising = [k for k, b in enumerate(bumped) if b and (k == 0 or not bumped[k - 1])]
    assert sim.collisions == len(rising)
    hits = [e for e in sim.history if e.name == "collision"]
    assert [round(e.t / sim.dt) for e in hits] == [k + 1 for k in rising]
    for event in hits:
        row = trajectory[round(event.t / sim.dt)]
        assert (event.x, event.y) == (row[1], row[2])


def test_the_simulation_honours_the_robot_limits() -> None:
    slow = RobotSpec(radius=0.2, max_speed=0.05, max_reverse=0.05, max_turn_rate=0.5,
                     max_accel=0.05, max_turn_accel=1.0)
    sim = Simulation(OPEN, slow, Sensors().fitted(0.2), Navigator(Constant(1.0, 3.0)),
                     Pose(5.0, 5.0, 0.0), (9.0, 9.0))
    for _ in range(100):
        sim.step()
    trajectory = sim.trajectory
    assert np.abs(trajectory[:, 4]).max() <= 0.05 + 1e-12
    assert np.abs(trajectory[:, 5]).max() <= 0.5 + 1e-12
    speeds = np.hypot(np.diff(trajectory[:, 1]), np.diff(trajectory[:, 2])) / sim.dt
    assert speeds.max() <= 0.05 + 1e-9


@pytest.mark.parametrize("yields", [True, False])
def test_a_person_who_yields_stops_short_of_a_standing_robot(yields: bool) -> None:
    person = Mover(((-4.0, 0.0), (4.0, 0.0)), 1.0, 0.25, "person", yields=yields)
    world = World((-6.0, -3.0, 6.0, 3.0), movers=(person,))
    sim = simulation(world, Constant(0.0, 0.0), Pose(0.0, 0.0, 0.0), (5.0, 2.0))
    closest = math.inf
    for _ in range(60):
        sim.step()
        closest = min(closest, math.dist(sim.crowd.now[0], (sim.state.x, sim.state.y)))
    clocks = sim.mover_clocks
    if yields:
        # it waits where one more step would bring its rim within 0.3 m of the robot's
        assert closest >= RADIUS + 0.25 + 0.3 - 0.1 - 1e-9
        assert clocks is not None and clocks.shape == (61, 1)
        assert clocks[-1, 0] < sim.t
        assert np.all(np.diff(clocks[:, 0]) >= 0.0)
    else:
        assert closest < RADIUS + 0.25
        assert clocks is None
