"""Simulation steps per second of the 2D world (``cbr_world2d``) beside ir-sim, same world.

A seeded world of 200 segments (the four sides of the bounds, linear obstacles between
neighbouring landmarks as in 002 Figure 1, clutter boxes) and 30 landmarks is built by
:func:`build_world`. A Pioneer 2 DX (``robot.PIONEER_2DX``) with the default sensors (the
16-beam sonar ring, the camera, odometry) drives a tour of legs between free waypoints with
the potential-field pilot, one :class:`~cbr_world2d.simulation.Simulation` per leg, each leg
starting at its waypoint and ending at the next or at a timeout. Timed side by side in one
process, in an order that rotates from repeat to repeat:

- ``Simulation.step``: sense, navigate (potential field, progress monitor, Rescuer), move,
  record; what a trial costs per step.
- the bare loop the issue's target names: ``Sensors.observe`` + ``PotentialField.command`` +
  ``robot.step``, no navigator and no recording.
- ir-sim (the bench extra ``ir-sim``, import ``irsim``): the same world written to its YAML
  (every segment a ``linestring`` obstacle, every disc a ``circle`` obstacle, all static), the
  same robot (a differential-drive disc of the same radius, speed, turn-rate and acceleration
  limits), the same step, a ``lidar2d`` standing in for the sonar ring (16 beams evenly spread,
  reaching as far from the centre as the sonar does from the rim), headless (no figure). It
  replays, leg by leg, the velocities our robot had, so it drives the same path. ir-sim has no
  camera and no pilot: its step is the simulator alone (kinematics, collision check, lidar). A
  second ir-sim row casts as many rays as our sonar does (16 beams times the rays of a cone).

and each part of ours alone, replayed on the states and observations of an untimed run of the
same tour: the sonar ring, the camera, odometry, ``Sensors.observe`` (those three and the
bumper), the pilot, the navigator, the robot step.

Steps per second are medians over ``--repeats``; a ratio is ours over ir-sim's steps per
second (above 1: ours steps faster).

    python benchmarks/world2d_speed.py [--steps 20000] [--irsim-steps 1000] [--repeats 5]
                                       [--seed 0] [--quick] [--no-irsim]
                                       [--out benchmarks/results]

Writes ``world2d_speed.json`` and ``world2d_speed.md``. ``--quick`` is a smoke run of a few
seconds. Without ir-sim installed the ir-sim rows are left out and the run says so.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.metadata
import importlib.util
import io
import itertools
import math
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import attrs
import numpy as np
import yaml
from docfigures.provenance import script_command, write_results

from cbr_world2d import robot
from cbr_world2d.navigator import Navigator, NavigatorOptions
from cbr_world2d.pilots.potential_field import PotentialField
from cbr_world2d.robot import PIONEER_2DX, Pose, RobotSpec, RobotState
from cbr_world2d.sensors import Camera, Observation, Odometry, Sensors, SonarRing
from cbr_world2d.simulation import Simulation
from cbr_world2d.world import Landmark, Point, Wall, World

DT = 0.1
"""Seconds per step, ours and ir-sim's (ir-sim's default ``step_time`` too)."""
SEGMENTS = 200
LANDMARKS = 30
SPACING = 7.0
"""Metres between neighbouring landmarks of the lattice before jitter."""
JITTER = 1.2
LANDMARK_RADIUS = 0.3
WALL_SHARE = 0.4
"""Share of neighbouring landmark pairs joined by a linear obstacle."""
BOX_SIDE = (0.4, 1.2)
"""Sides of the clutter boxes, metres."""
GAP = 1.5
"""Least distance between a box and anything else: three robot widths, so that the pilot's
repulsion from two neighbours leaves a way between them."""
CLEARANCE = 1.0
"""Least distance from a waypoint to any obstacle surface."""
WAYPOINTS = 40
LEG = (5.0, 10.0)
"""Least and largest distance between successive waypoints."""
LEG_TIMEOUT = 60.0
TOLERANCE = 0.5
NAVIGATION = NavigatorOptions(rescue="stuck")
"""The Rescuer diverts on its own when the robot is blocked or oscillates, so that the tour
does not spend its legs trapped where the potential field balances (it still may)."""
STEP_TARGET = 5000.0
"""Steps per second the issue asks for."""
FULL = {"steps": 20000, "irsim_steps": 1000, "repeats": 5}
QUICK = {"steps": 1500, "irsim_steps": 100, "repeats": 2}


# --------------------------------------------------------------------------------------------
# the world


def point_segment_distances(px: Any, py: Any, ax: Any, ay: Any, bx: Any,
                            by: Any) -> np.ndarray:
    """Distance from points ``(px, py)`` to segments ``(ax, ay)-(bx, by)``, broadcast."""
    dx, dy = np.subtract(bx, ax), np.subtract(by, ay)
    length2 = dx * dx + dy * dy
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.where(length2 > 0, ((px - ax) * dx + (py - ay) * dy) / length2, 0.0)
    u = np.clip(u, 0.0, 1.0)
    return np.hypot(ax + u * dx - px, ay + u * dy - py)


def segment_distances(segment: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Distance from one segment to each row ``x0, y0, x1, y1`` of ``segments``: 0 where they
    cross, else the least of the four end-point-to-segment distances."""
    x0, y0, x1, y1 = segment
    ax, ay, bx, by = segments.T

    def side(px: Any, py: Any, qx: Any, qy: Any, rx: Any, ry: Any) -> Any:
        return np.sign((qx - px) * (ry - py) - (qy - py) * (rx - px))

    crossing = ((side(x0, y0, x1, y1, ax, ay) * side(x0, y0, x1, y1, bx, by) < 0)
                & (side(ax, ay, bx, by, x0, y0) * side(ax, ay, bx, by, x1, y1) < 0))
    ends = np.minimum.reduce([
        point_segment_distances(x0, y0, ax, ay, bx, by),
        point_segment_distances(x1, y1, ax, ay, bx, by),
        point_segment_distances(ax, ay, x0, y0, x1, y1),
        point_segment_distances(bx, by, x0, y0, x1, y1)])
    return np.where(crossing, 0.0, ends)


def clearance(x: float, y: float, segments: np.ndarray, discs: np.ndarray) -> float:
    """Distance from ``(x, y)`` to the nearest obstacle surface."""
    ax, ay, bx, by = segments.T
    nearest = float(point_segment_distances(x, y, ax, ay, bx, by).min(initial=np.inf))
    if len(discs):
        rims = np.hypot(discs[:, 0] - x, discs[:, 1] - y) - discs[:, 2]
        nearest = min(nearest, float(rims.min()))
    return nearest


def build_world(seed: int = 0, segments: int = SEGMENTS, landmarks: int = LANDMARKS) -> World:
    """A semi-structured world (002 Figure 1) with exactly ``segments`` static segments and
    ``landmarks`` landmarks, deterministic from ``seed``.

    Landmarks sit on a jittered lattice ``SPACING`` apart; a share ``WALL_SHARE`` of the pairs
    of lattice neighbours is joined by a linear obstacle from rim to rim; the rest of the
    segments, after the four sides of the bounds, are clutter: boxes (polygons of four edges,
    sides ``BOX_SIDE``) and, for a remainder under four, single segments, placed at random at
    least ``GAP`` from everything else.
    """
    rng = np.random.default_rng(seed)
    columns = math.ceil(math.sqrt(landmarks * 1.2))
    rows = math.ceil(landmarks / columns)
    bounds = (0.0, 0.0, columns * SPACING, rows * SPACING)
    cells = [(i, j) for j in range(rows) for i in range(columns)][:landmarks]
    marks = []
    for number, (i, j) in enumerate(cells):
        x, y = (np.array([i, j]) + 0.5) * SPACING + rng.uniform(-JITTER, JITTER, 2)
        marks.append(Landmark(f"l{number + 1}", float(x), float(y), LANDMARK_RADIUS))
    where = {cell: mark for cell, mark in zip(cells, marks, strict=True)}
    pairs = [(where[(i, j)], where[(i + di, j + dj)]) for (i, j) in cells
             for di, dj in ((1, 0), (0, 1)) if (i + di, j + dj) in where]
    chosen = rng.permutation(len(pairs))[:round(WALL_SHARE * len(pairs))]
    walls = []
    for k in sorted(chosen.tolist()):
        m1, m2 = pairs[k]
        ux, uy = m2.x - m1.x, m2.y - m1.y
        length = math.hypot(ux, uy)
        ux, uy = ux / length, uy / length
        walls.append(Wall((m1.x + m1.radius * ux, m1.y + m1.radius * uy),
                          (m2.x - m2.radius * ux, m2.y - m2.radius * uy), (m1.id, m2.id)))
    need = segments - 4 - len(walls)
    if need < 0:
        raise ValueError(f"{segments} segments cannot hold the bounds and {len(walls)} walls")
    placed = World(bounds, walls=tuple(walls), landmarks=tuple(marks)).static_segments
    centres = np.array([(m.x, m.y) for m in marks])
    boxes: list[tuple[Point, ...]] = []
    pieces: list[Wall] = []
    attempts = 0
    while need > 0:
        attempts += 1
        if attempts > 1000 * segments:
            raise RuntimeError(f"no room for {need} more clutter segments")
        x, y = rng.uniform(bounds[:2], bounds[2:])
        angle = rng.uniform(0.0, math.pi)
        c, s = math.cos(angle), math.sin(angle)
        if need >= 4:
            half = 0.5 * rng.uniform(*BOX_SIDE, 2)
            corners = [(x + c * u * half[0] - s * v * half[1],
                        y + s * u * half[0] + c * v * half[1])
                       for u, v in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        else:
            half = 0.5 * rng.uniform(*BOX_SIDE)
            corners = [(x - c * half, y - s * half), (x + c * half, y + s * half)]
        # a box closes its outline; a single segment is its own only edge
        k = len(corners)
        edges = np.array([(*corners[i], *corners[(i + 1) % k]) for i in range(k if k > 2 else 1)])
        if min(point_segment_distances(centres[:, 0], centres[:, 1], *edge).min()
               for edge in edges) < LANDMARK_RADIUS + GAP:
            continue
        if min(segment_distances(edge, placed).min() for edge in edges) < GAP:
            continue
        if k == 4:
            boxes.append(tuple((float(px), float(py)) for px, py in corners))
        else:
            pieces.append(Wall(corners[0], corners[1]))
        placed = np.vstack([placed, edges])
        need -= len(edges)
    return World(bounds, walls=tuple(walls + pieces), polygons=tuple(boxes),
                 landmarks=tuple(marks), name=f"world2d_speed seed {seed}")


def free_points(world: World, count: int, seed: int, *, leg: tuple[float, float] = LEG,
                margin: float = CLEARANCE) -> list[Point]:
    """``count`` points at least ``margin`` from every obstacle surface, each between
    ``leg[0]`` and ``leg[1]`` from the one before: the start and the waypoints of the tour."""
    rng = np.random.default_rng([seed, 1])
    xmin, ymin, xmax, ymax = world.bounds
    points: list[Point] = []
    for _ in range(10000 * count):
        if len(points) == count:
            return points
        x, y = (float(v) for v in rng.uniform((xmin, ymin), (xmax, ymax)))
        if clearance(x, y, world.static_segments, world.static_discs) < margin:
            continue
        if points and not leg[0] <= math.hypot(x - points[-1][0], y - points[-1][1]) <= leg[1]:
            continue
        points.append((x, y))
    if len(points) == count:
        return points
    raise RuntimeError(f"found only {len(points)} of {count} free points {leg} apart")


@attrs.frozen
class Setup:
    """What every timed run shares: the world, the robot and the tour, legs of a start pose
    and a target. Each leg starts afresh at its own start, a trial of its own, so that a leg
    in which the potential field gets trapped does not strand the rest of the tour there."""

    world: World
    spec: RobotSpec
    legs: tuple[tuple[Pose, Point], ...]

    def leg(self, number: int) -> tuple[Pose, Point]:
        """Leg ``number`` of the endless tour (the legs repeat in order)."""
        return self.legs[number % len(self.legs)]


def setup(seed: int) -> Setup:
    """The world of ``seed`` and a tour of ``WAYPOINTS`` legs through it, each leg starting
    at one waypoint facing the next, its target."""
    world = build_world(seed)
    points = free_points(world, WAYPOINTS + 1, seed)
    legs = tuple((Pose(x0, y0, math.atan2(y1 - y0, x1 - x0)), (x1, y1))
                 for (x0, y0), (x1, y1) in itertools.pairwise(points))
    return Setup(world, PIONEER_2DX, legs)


# --------------------------------------------------------------------------------------------
# our simulator


@attrs.define
class Record:
    """What an untimed run of the tour saw, step by step, for the replays: the state each step
    started from, the observation the navigator got, the target, the time in the leg, whether
    the robot was touching something, and the velocities it had after the step."""

    states: list[RobotState] = attrs.Factory(list)
    observations: list[Observation] = attrs.Factory(list)
    targets: list[Point] = attrs.Factory(list)
    times: list[float] = attrs.Factory(list)
    bumped: list[bool] = attrs.Factory(list)
    velocities: list[tuple[float, float]] = attrs.Factory(list)
    starts: list[int] = attrs.Factory(list)
    """The steps at which a leg began."""
    ends: list[RobotState] = attrs.Factory(list)
    """Where each leg ended."""
    legs: int = 0
    reached: int = 0
    collisions: int = 0
    distance: float = 0.0


def _legs(run: Setup, steps: int, seed: int, record: Record | None = None) -> float:
    """Drive ``steps`` steps of the tour with one :class:`Simulation` per leg, a leg ending at
    its target or after ``LEG_TIMEOUT``: the seconds spent in ``Simulation.step``. With
    ``record``, keep what each step started from (untimed runs only: keeping it costs)."""
    rng = np.random.default_rng(seed)
    pilot = PotentialField()
    spent = 0.0
    done = legs = 0
    per_leg = round(LEG_TIMEOUT / DT)
    while done < steps:
        start, target = run.leg(legs)
        legs += 1
        sim = Simulation(run.world, run.spec, Sensors(), Navigator(pilot, NAVIGATION), start,
                         target, dt=DT, rng=rng, tolerance=TOLERANCE)
        budget = min(per_leg, steps - done)
        if record is None:
            began = time.perf_counter()
            for _ in range(budget):
                sim.step()
                if sim.reached:
                    break
            spent += time.perf_counter() - began
        else:
            record.starts.append(done)
            while sim.steps < budget and not sim.reached:
                record.states.append(sim.state)
                record.observations.append(sim.observe())
                record.targets.append(target)
                record.times.append(sim.t)
                record.bumped.append(sim.bumped)
                sim.step()
            record.velocities += [(v, w) for v, w in sim.trajectory[1:, 4:6].tolist()]
            record.ends.append(sim.state)
            record.legs += 1
            record.reached += bool(sim.reached)
            record.collisions += sim.collisions
            record.distance += sim.distance
        done += sim.steps
    return spent


def simulation_steps(run: Setup, steps: int, seed: int) -> float:
    """Seconds per ``Simulation.step`` over ``steps`` steps of the tour."""
    return _legs(run, steps, seed) / steps


def direct_steps(run: Setup, steps: int, seed: int) -> float:
    """Seconds per step of the bare loop (``Sensors.observe``, ``PotentialField.command``,
    ``robot.step``) over ``steps`` steps of the same tour; a leg ends at its target or after
    ``LEG_TIMEOUT``."""
    rng = np.random.default_rng(seed)
    world, spec = run.world, run.spec
    sensors, pilot = Sensors(), PotentialField()
    segments, discs = world.static_segments, world.static_discs
    per_leg = round(LEG_TIMEOUT / DT)
    spent = 0.0
    done = legs = 0
    while done < steps:
        start, (tx, ty) = run.leg(legs)
        legs += 1
        sensors.reset()
        state = RobotState(start.x, start.y, start.theta)
        bumped = False
        budget = min(per_leg, steps - done)
        taken = 0
        began = time.perf_counter()
        while taken < budget and math.hypot(state.x - tx, state.y - ty) > TOLERANCE:
            obs = sensors.observe(state, world, taken * DT, bumped, rng, segments, discs)
            state, bumped = robot.step(state, pilot.command(obs, (tx, ty)), spec, DT, segments,
                                       discs)
            taken += 1
        spent += time.perf_counter() - began
        done += taken
    return spent / steps


def part_costs(run: Setup, record: Record, seed: int) -> dict[str, float]:
    """Seconds per call of each part, replayed on the recorded states and observations."""
    world, spec = run.world, run.spec
    segments, discs, marks = world.static_segments, world.static_discs, world.landmark_array
    ids = tuple(m.id for m in world.landmarks)
    sonar, camera, sensors = SonarRing(), Camera(), Sensors()
    poses = [Pose(s.x, s.y, s.theta) for s in record.states]
    commands = record.velocities
    rng = np.random.default_rng(seed)
    pilot = PotentialField()
    navigator = Navigator(PotentialField(), NAVIGATION)

    # a leg (its time starts at 0) starts the navigator and the odometry afresh, as a new
    # Simulation does
    def navigate(k: int) -> object:
        if record.times[k] == 0.0:
            navigator.start(record.targets[k])
        return navigator.command(record.observations[k])

    def observe(k: int) -> object:
        if record.times[k] == 0.0:
            sensors.reset()
        return sensors.observe(record.states[k], world, record.times[k], record.bumped[k], rng)

    def per_call(call: Callable[[int], object]) -> float:
        began = time.perf_counter()
        for k in range(len(poses)):
            call(k)
        return (time.perf_counter() - began) / len(poses)

    odometry = Odometry()

    def dead_reckon(k: int) -> object:
        if record.times[k] == 0.0:
            return odometry.reset(record.states[k])
        return odometry.update(record.states[k - 1], record.states[k], DT, rng)

    return {
        "sonar ring (SonarRing.read)": per_call(
            lambda k: sonar.read(poses[k], segments, discs, rng)),
        "camera (Camera.see)": per_call(
            lambda k: camera.see(poses[k], marks, ids, segments, rng)),
        "odometry (Odometry.update)": per_call(dead_reckon),
        "Sensors.observe (sonar, camera, odometry, bumper)": per_call(observe),
        "pilot (PotentialField.command)": per_call(
            lambda k: pilot.command(record.observations[k], record.targets[k])),
        "navigator (Navigator.command, with the pilot)": per_call(navigate),
        "robot step (robot.step)": per_call(
            lambda k: robot.step(record.states[k], commands[k], spec, DT, segments, discs)),
    }


# --------------------------------------------------------------------------------------------
# ir-sim


def irsim_version() -> str | None:
    """The installed ir-sim's version, or None when it is not installed."""
    try:
        if importlib.util.find_spec("irsim") is None:
            return None
        return importlib.metadata.version("ir-sim")
    except (ImportError, ValueError):
        return None


def _import_irsim() -> Any:
    # ir-sim tries matplotlib backends on import and prints each that fails on a machine without
    # a display before it settles on Agg, which draws nothing (and every env here is headless)
    with contextlib.redirect_stdout(io.StringIO()):
        import irsim
    return irsim


def irsim_scenario(run: Setup, beams: int, reach: float) -> dict[str, Any]:
    """The world, robot and step of ``run`` as an ir-sim YAML document.

    Every static segment is a ``linestring`` obstacle and every disc a ``circle`` obstacle,
    all ``static``; the robot is a ``diff`` disc with a ``lidar2d`` of ``beams`` beams spread
    evenly over the full turn, reaching ``reach`` from the centre. Its goal lies outside the
    world, so that it never arrives and stops.
    """
    world, spec, (start, _) = run.world, run.spec, run.leg(0)
    xmin, ymin, xmax, ymax = world.bounds
    segments, discs = world.static_segments, world.static_discs
    lidar = {"name": "lidar2d", "range_min": 0.0, "range_max": float(reach),
             # ir-sim spreads the beams from -range/2 to +range/2 inclusive: a full turn
             # would put two beams on the rear
             "angle_range": 2 * math.pi * (beams - 1) / beams, "number": beams,
             "noise": False}
    return {
        "world": {"width": xmax - xmin, "height": ymax - ymin,
                  "offset": [xmin, ymin], "step_time": DT, "collision_mode": "stop",
                  "control_mode": "auto"},
        "robot": [{
            "kinematics": {"name": "diff"},
            "shape": {"name": "circle", "radius": spec.radius},
            "state": [start.x, start.y, start.theta],
            "goal": [xmin - 100.0, ymin - 100.0, 0.0],
            "vel_min": [-spec.max_reverse, -spec.max_turn_rate],
            "vel_max": [spec.max_speed, spec.max_turn_rate],
            "acce": [spec.max_accel, spec.max_turn_accel],
            "sensors": [lidar]}],
        "obstacle": [
            {"number": len(segments), "kinematics": {"name": "static"},
             "shape": [{"name": "linestring", "vertices": [[x0, y0], [x1, y1]]}
                       for x0, y0, x1, y1 in segments.tolist()],
             "state": [0.0, 0.0, 0.0]},
            {"number": len(discs), "kinematics": {"name": "static"},
             "shape": [{"name": "circle", "radius": r} for r in discs[:, 2].tolist()],
             "state": [[x, y, 0.0] for x, y in discs[:, :2].tolist()]}]}


Leg = tuple[Pose, list[tuple[float, float]], RobotState]
"""A leg to replay: where it starts, the velocities of each step, where our robot ended."""


def replay_legs(run: Setup, record: Record, steps: int) -> list[Leg]:
    """The first ``steps`` recorded steps cut into legs."""
    legs = []
    bounds = [*record.starts, len(record.velocities)]
    for number, (first, end) in enumerate(itertools.pairwise(bounds)):
        last = min(end, steps)
        if first >= last:
            break
        ours = record.ends[number] if last == end else record.states[last]
        legs.append((run.leg(number)[0], record.velocities[first:last], ours))
    return legs


def irsim_steps(run: Setup, legs: list[Leg], beams: int, reach: float,
                folder: Path) -> tuple[float, float, dict[str, Any]]:
    """(seconds per ``env.step``, seconds to build the env, how the run went) for ir-sim in
    ``run``'s world replaying ``legs``: at the start of each leg the robot is put at the
    leg's start at rest (not timed, as our runs do not time building a Simulation), then
    driven at the recorded velocities."""
    irsim = _import_irsim()
    path = folder / f"world2d_speed_{beams}.yaml"
    path.write_text(yaml.safe_dump(irsim_scenario(run, beams, reach)))
    began = time.perf_counter()
    env = irsim.make(str(path), headless=True, log_level="ERROR")
    built = time.perf_counter() - began
    body = env.robot
    spent = 0.0
    steps = collided = 0
    apart = 0.0
    for start, velocities, ours in legs:
        body.set_state([start.x, start.y, start.theta])
        body.set_velocity([0.0, 0.0])
        began = time.perf_counter()
        for v, w in velocities:
            env.step([v, w])
            collided += body.collision_flag
        spent += time.perf_counter() - began
        steps += len(velocities)
        x, y = body.state.ravel()[:2].tolist()
        apart = max(apart, math.hypot(x - ours.x, y - ours.y))
    how = {"objects": len(env.objects), "steps_in_collision": collided,
           "largest_apart_from_ours_m": apart, "beams": len(body.sensors[0].get_scan()["ranges"])}
    env.end(0)
    return spent / steps, built, how


# --------------------------------------------------------------------------------------------
# the run


def _median(values: list[float]) -> float:
    return statistics.median(values)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, help="our steps per repeat (20000)")
    parser.add_argument("--irsim-steps", type=int,
                        help="ir-sim steps per repeat, the first of the same path (1000)")
    parser.add_argument("--repeats", type=int, help="timed runs of each loop (5)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the world and the tour")
    parser.add_argument("--quick", action="store_true", help="a smoke run of a few seconds")
    parser.add_argument("--no-irsim", action="store_true", help="leave ir-sim out")
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "results")
    args = parser.parse_args(argv)
    for name, value in (QUICK if args.quick else FULL).items():
        if getattr(args, name) is None:
            setattr(args, name, value)
    began = time.perf_counter()
    started = time.perf_counter()
    run = setup(args.seed)
    world_s = time.perf_counter() - started

    # the first step loads the numba kernels from the disk cache, or compiles them when cold
    started = time.perf_counter()
    Simulation(run.world, run.spec, Sensors(), Navigator(PotentialField(), NAVIGATION),
               *run.leg(0), dt=DT, rng=np.random.default_rng(0), tolerance=TOLERANCE).step()
    first_step_s = time.perf_counter() - started

    record = Record()
    _legs(run, args.steps, args.seed, record)
    version = None if args.no_irsim else irsim_version()
    sonar = SonarRing()
    reach = sonar.max_range + run.spec.radius
    rays = len(sonar.angles) * sonar.rays_per_beam
    replay = replay_legs(run, record, args.irsim_steps)
    timed: dict[str, Callable[[Path], float]] = {
        "simulation": lambda _: simulation_steps(run, args.steps, args.seed),
        "direct": lambda _: direct_steps(run, args.steps, args.seed)}
    ends: dict[int, list[tuple[float, dict[str, Any]]]] = {}
    if version is not None:
        for beams in sorted({16, rays}):
            ends[beams] = []

            def irsim(folder: Path, beams: int = beams) -> float:
                seconds, built, end = irsim_steps(run, replay, beams, reach, folder)
                ends[beams].append((built, end))
                return seconds

            timed[f"irsim {beams}"] = irsim
    samples: dict[str, list[float]] = {name: [] for name in timed}
    parts: dict[str, list[float]] = {}
    names = list(timed)
    with tempfile.TemporaryDirectory() as folder:
        for repeat in range(args.repeats):
            # rotate the order so drift on a noisy machine hits every loop alike
            for name in names[repeat % len(names):] + names[:repeat % len(names)]:
                samples[name].append(timed[name](Path(folder)))
            for name, seconds in part_costs(run, record, args.seed).items():
                parts.setdefault(name, []).append(seconds)
    irsim_rows: dict[int, dict[str, Any]] = {}
    for beams, built in ends.items():
        irsim_rows[beams] = {
            "seconds": samples.pop(f"irsim {beams}"), "build_s": _median([b for b, _ in built]),
            "steps": sum(len(leg[1]) for leg in replay), "legs": len(replay), **built[-1][1]}

    simulation = _median(samples["simulation"])
    direct = _median(samples["direct"])
    anchors = {beams: _median(measured["seconds"]) for beams, measured in irsim_rows.items()}

    def row(what: str, seconds: float, repeats: list[float]) -> dict[str, Any]:
        return {"what": what, "steps_per_s": 1 / seconds, "us": seconds * 1e6,
                "steps_per_s_range": [1 / max(repeats), 1 / min(repeats)],
                "over_irsim": {str(beams): anchor / seconds
                               for beams, anchor in anchors.items()}}

    rows = [row("ours: Simulation.step (sonar, camera, potential field + monitor + Rescuer, "
                "robot, recording)", simulation, samples["simulation"]),
            row("ours: Sensors.observe + PotentialField.command + robot.step", direct,
                samples["direct"])]
    rows += [row(f"ir-sim {version}: env.step, lidar2d {beams} beams (no camera, no pilot)",
                 anchors[beams], measured["seconds"]) for beams, measured in irsim_rows.items()]
    targets = [{"target": f"{name} steps/s", "measured": 1 / seconds,
                "goal": f">= {STEP_TARGET:.0f}", "met": 1 / seconds >= STEP_TARGET}
               for name, seconds in (("Simulation.step", simulation), ("bare loop", direct))]
    world = run.world
    result: dict[str, Any] = {
        "steps": args.steps, "irsim_steps": args.irsim_steps, "repeats": args.repeats,
        "seed": args.seed, "quick": args.quick, "dt": DT,
        "world": {"segments": len(world.static_segments), "discs": len(world.static_discs),
                  "landmarks": len(world.landmarks), "boxes": len(world.polygons),
                  "walls_between_landmarks": sum(w.between is not None for w in world.walls),
                  "bounds": list(world.bounds)},
        "robot": attrs.asdict(run.spec), "sonar_rays": rays, "sonar_reach_from_centre": reach,
        "navigation": attrs.asdict(NAVIGATION),
        "tour": {"legs": record.legs, "reached": record.reached,
                 "collisions": record.collisions, "distance_m": record.distance},
        "world_build_s": world_s, "first_step_s": first_step_s,
        "elapsed_s": time.perf_counter() - began, "irsim_version": version,
        "samples_s_per_step": samples, "rows": rows,
        "parts_s_per_call": parts,
        "parts_median_s": {name: _median(values) for name, values in parts.items()},
        "irsim": {str(beams): measured for beams, measured in irsim_rows.items()},
        "targets": targets}
    args.out.mkdir(parents=True, exist_ok=True)
    write_results(args.out / "world2d_speed.json", result,
                  command=script_command(__file__, argv))
    text = report(result, skipped="left out (--no-irsim)" if args.no_irsim
                  else "not installed (pip install -e '.[bench]')")
    (args.out / "world2d_speed.md").write_text(text + "\n")
    print(text)
    return result


def report(result: dict[str, Any], skipped: str) -> str:
    """The markdown of ``result``: steps per second, parts, targets, what was run."""
    beams = list(result["irsim"])
    lines = ["| what is timed | steps/s | range over repeats | µs per step |"
             + "".join(f" ours / ir-sim {b} beams |" for b in beams),
             "|---|---|---|---|" + "---|" * len(beams)]
    for row in result["rows"]:
        ours = row["what"].startswith("ours")
        low, high = row["steps_per_s_range"]
        lines.append(f"| {row['what']} | {row['steps_per_s']:,.0f} | {low:,.0f}-{high:,.0f} | "
                     f"{row['us']:.1f} |"
                     + "".join(f" {row['over_irsim'][b]:.1f} |" if ours else " - |"
                               for b in beams))
    whole = _median(result["samples_s_per_step"]["simulation"])
    parts = ["| part (replayed on the recorded run) | µs per call | share of Simulation.step |",
             "|---|---|---|"]
    parts += [f"| {name} | {seconds * 1e6:.1f} | {seconds / whole:.0%} |"
              for name, seconds in result["parts_median_s"].items()]
    targets = ["| target | measured | goal | met |", "|---|---|---|---|"]
    targets += [f"| {t['target']} | {t['measured']:,.0f} | {t['goal']} | "
                f"{'yes' if t['met'] else 'no'} |" for t in result["targets"]]
    world, tour = result["world"], result["tour"]
    notes = [
        f"World: {world['segments']} segments (the 4 sides, {world['walls_between_landmarks']} "
        f"linear obstacles between landmarks, {world['boxes']} boxes of 4 edges, the rest single "
        f"segments), {world['landmarks']} landmarks, {world['bounds'][2]:.0f} x "
        f"{world['bounds'][3]:.0f} m; step {result['dt']} s; {result['steps']} steps per repeat "
        f"(ir-sim {result['irsim_steps']}), {result['repeats']} repeats, seed {result['seed']}. "
        f"The tour: {tour['legs']} legs, {tour['reached']} reached, {tour['collisions']} "
        f"collisions, {tour['distance_m']:.0f} m driven."]
    if result["irsim_version"] is None:
        notes.append(f"ir-sim {skipped}: its rows are left out.")
    else:
        notes.append(
            f"ir-sim {result['irsim_version']}, headless, replaying our velocities: "
            + "; ".join(f"{b} beams: env built in {m['build_s']:.2f} s, {m['steps']} steps in "
                        f"{m['legs']} legs, each leg ending at most "
                        f"{m['largest_apart_from_ours_m']:.2f} m from where ours did, "
                        f"{m['steps_in_collision']} steps in collision"
                        for b, m in result["irsim"].items()) + ".")
    notes.append(f"One-time costs: world build {result['world_build_s']:.2f} s, first step "
                 f"(numba cache load or compile) {result['first_step_s']:.2f} s. Whole run "
                 f"{result['elapsed_s']:.0f} s.")
    return "\n\n".join(["\n".join(lines), "\n".join(parts), "\n".join(targets), *notes])


if __name__ == "__main__":
    main()
