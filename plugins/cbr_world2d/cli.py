"""``cbr sim``: look at a 2D world, run one trial in it, or run a batch of random trials.

``WORLD`` is a world file (:func:`cbr_world2d.worldfile.load_world`) or a generated world,
``generated:KIND:SEED`` with ``KIND`` one of :data:`GENERATORS`. The simulator, numba kernels
and matplotlib are imported inside the commands, so that loading the plugin at every start of
``cbr`` stays cheap. Bad input (a broken world file, a start in an obstacle, a target outside
the world, an unknown pilot) is a usage or :class:`~cbrcore.errors.CbrError` error: one message
naming the item, exit code 2.
"""

from __future__ import annotations

import enum
import json
import math
import os
import re
import statistics
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from cbr_experiments.tasks import WORKERS_PER_CORE
from cbr_world2d.checks import MAX_DT, MAX_FRAMES, MAX_TRIALS, MIN_DT, too_many_steps
from cbrcore.errors import CbrError

if TYPE_CHECKING:
    from cbr_world2d.robot import RobotSpec
    from cbr_world2d.simulation import TrialResult
    from cbr_world2d.world import Point, World

GENERATORS = ("semi_structured", "scenario", "office")
"""The world generators of :mod:`cbr_world2d.generate` that ``generated:KIND:SEED`` names."""

SEED_DIGITS = 19
"""The most digits of the SEED of ``generated:KIND:SEED``: any seed of a 64-bit integer."""

_GENERATED = re.compile(rf"generated:([a-z_]+):([0-9]{{1,{SEED_DIGITS}}})")


class RobotName(enum.StrEnum):
    pioneer2dx = "pioneer2dx"
    ros2005 = "ros2005"


class Rescue(enum.StrEnum):
    off = "off"
    blocked = "blocked"
    stuck = "stuck"


WorldArgument = Annotated[str, typer.Argument(
    metavar="WORLD", show_default=False,
    help="A world file (YAML), or generated:KIND:SEED with KIND semi_structured, scenario or "
    "office.")]
PlotOption = Annotated[Path | None, typer.Option(
    "--plot", metavar="FILE", show_default=False,
    help="Draw the picture to this file (PNG, or another format matplotlib knows by the "
    "extension).")]
PilotOption = Annotated[str, typer.Option(
    "--pilot", metavar="PILOT", help="The pilot: a component of kind 'pilot' (potential_field, "
    "behaviors, or another registered one).")]
TimeoutOption = Annotated[float, typer.Option(
    "--timeout", metavar="SECONDS", help="Seconds after which a trial has failed.")]
DtOption = Annotated[float, typer.Option("--dt", metavar="SECONDS",
                                         help="The simulation step in seconds, from 0.0001 "
                                         "to 1.")]
ToleranceOption = Annotated[float, typer.Option(
    "--tolerance", metavar="METRES",
    help="How close, in metres, the robot's centre must come to the target.")]
RobotOption = Annotated[RobotName, typer.Option(
    "--robot", help="The robot: a Pioneer 2 DX (004) or the 5 cm/s robot of 002.")]
RescueOption = Annotated[Rescue, typer.Option(
    "--rescue", help="When the Rescuer diverts on its own: never (the pilot alone), when the "
    "robot is blocked (002's navigation system without CBR), or when it is stuck (blocked or "
    "oscillating).")]
_RESULT_KEYS = ("success, reason (reached or timeout), time, distance, collisions, steps, stuck "
                "(how many times), diverting (a list of [x, y]) and seed")
RecordOption = Annotated[Path | None, typer.Option(
    "--record", metavar="FILE", show_default=False,
    help="Record the trial as MCAP with ROS 2 message types, for Foxglove and ros2 bag play.")]
ForceOption = Annotated[bool, typer.Option(
    "--force", help="With --record: replace the recording file if it exists.")]
RateOption = Annotated[float, typer.Option(
    "--rate", min=0.01, metavar="HZ",
    help="With --record: the most messages a second of simulation time on the fast topics "
    "(transform, odometry, sonar, people, sightings).")]
RunJsonOption = Annotated[bool, typer.Option("--json", help=(
    f"Print one JSON object with the keys world, start, target, pilot, robot, {_RESULT_KEYS}."))]
BatchJsonOption = Annotated[bool, typer.Option("--json", help=(
    f"Print one JSON object per trial with the keys trial, start, target, {_RESULT_KEYS}; then "
    "one with trials, reached, success_rate, median_time and median_distance (null when no "
    "trial reached its target)."))]


def load(text: str) -> World:
    """The world ``text`` names: ``generated:KIND:SEED`` or a world file's path."""
    if text.startswith("generated:"):
        found = _GENERATED.fullmatch(text)
        if found is None or found.group(1) not in GENERATORS:
            raise typer.BadParameter(
                f"expected generated:KIND:SEED with KIND one of {', '.join(GENERATORS)} and "
                f"SEED an integer >= 0 of at most {SEED_DIGITS} digits, got {text!r}",
                param_hint="'WORLD'")
        from cbr_world2d import generate

        generator = getattr(generate, found.group(1))
        world: World = generator(int(found.group(2)))
        return world
    from cbr_world2d.worldfile import load_world

    return load_world(Path(text))


def _positive(value: float, option: str) -> float:
    if not (math.isfinite(value) and value > 0.0):
        raise typer.BadParameter(f"expected a finite number > 0, got {value!r}",
                                 param_hint=f"'{option}'")
    return value


def _timing(timeout: float, dt: float, tolerance: float) -> None:
    """Refuse a trial's timing unless it can be simulated, naming the option at fault."""
    _positive(timeout, "--timeout")
    _positive(tolerance, "--tolerance")
    if not (MIN_DT <= dt <= MAX_DT):
        raise typer.BadParameter(f"expected a step from {MIN_DT:g} to {MAX_DT:g} seconds, got "
                                 f"{dt!r}", param_hint="'--dt'")
    problem = too_many_steps(timeout, dt)
    if problem is not None:
        raise typer.BadParameter(problem, param_hint="'--timeout'")


def _writable(path: Path | None, option: str) -> None:
    """Refuse a picture file whose folder is missing now, rather than after the trials ran."""
    if path is not None and not path.parent.is_dir():
        raise CbrError(f"{option} {path}: cannot write the picture: the folder {path.parent} "
                       "does not exist")


def _spec(robot: RobotName) -> RobotSpec:
    from cbr_world2d.robot import PRESETS

    return PRESETS[robot.value]


def _navigation(rescue: Rescue) -> Any:
    from cbr_world2d.navigator import NavigatorOptions

    return NavigatorOptions(rescue=rescue.value)


def _point(world: World, text: str, option: str) -> Point:
    point = world.point(text, option)
    return float(point[0]), float(point[1])


def _where(x: float, y: float) -> str:
    return f"{x:.2f},{y:.2f}"


def show(world_name: WorldArgument, plot: PlotOption = None,
         at: Annotated[float, typer.Option(
             "--at", metavar="SECONDS",
             help="Draw doors and people as they are at this time (seconds, from 0 to "
             "1e6).")] = 0.0,
         as_json: Annotated[bool, typer.Option("--json", help=(
             "Print one JSON object with the keys world, bounds ([xmin, ymin, xmax, ymax]), "
             "walls, linear_obstacles, polygons, points, landmarks, doors, movers, places (a "
             "list) and segments."))] = False,
         ) -> None:
    """Print a 2D world's bounds and what it holds; draw it with --plot."""
    from cbr_world2d.worldfile import MAX_MAGNITUDE

    if not 0.0 <= at <= MAX_MAGNITUDE:  # NaN too
        raise typer.BadParameter(f"expected a time from 0 to {MAX_MAGNITUDE:g} seconds, got "
                                 f"{at!r}", param_hint="'--at'")
    _writable(plot, "--plot")
    world = load(world_name)
    xmin, ymin, xmax, ymax = world.bounds
    linear = sum(w.between is not None for w in world.walls)
    if plot is not None:
        from cbr_world2d.plot import plot_world

        plot_world(world, plot, t=at)
    if as_json:
        typer.echo(json.dumps({
            "world": world.name or world_name, "bounds": [xmin, ymin, xmax, ymax],
            "walls": len(world.walls), "linear_obstacles": linear,
            "polygons": len(world.polygons), "points": len(world.points),
            "landmarks": len(world.landmarks), "doors": len(world.doors),
            "movers": len(world.movers), "places": sorted(world.places),
            "segments": int(world.static_segments.shape[0])}))
        return
    lines = [
        ("world", world.name or world_name),
        ("bounds", f"{xmin:g},{ymin:g} to {xmax:g},{ymax:g} ({xmax - xmin:g} x "
                   f"{ymax - ymin:g} m)"),
        ("walls", f"{len(world.walls)} ({linear} linear obstacles between landmarks)"),
        ("polygons", str(len(world.polygons))),
        ("points", str(len(world.points))),
        ("landmarks", str(len(world.landmarks))),
        ("doors", str(len(world.doors))),
        ("movers", str(len(world.movers))),
        ("places", ", ".join(sorted(world.places)) or "none"),
        ("segments", str(world.static_segments.shape[0])),
    ]
    for key, value in lines:
        typer.echo(f"{key:<10} {value}")
    if plot is not None:
        typer.echo(f"wrote {plot}")


def _result_lines(result: TrialResult) -> list[tuple[str, str]]:
    stuck = result.stuck
    where = (f" (first at t = {stuck[0].t:.1f} s, {_where(stuck[0].x, stuck[0].y)})"
             if stuck else "")
    diverting = ", ".join(_where(*p) for p in result.diverting)
    return [
        ("success", f"{'yes' if result.success else 'no'} ({result.reason})"),
        ("time", f"{result.time:.1f} s"),
        ("distance", f"{result.distance:.2f} m"),
        ("collisions", str(result.collisions)),
        ("stuck", f"{len(stuck)}{where}"),
        ("diverting", diverting or "none"),
        ("steps", str(result.steps)),
    ]


def run(
    world_name: WorldArgument,
    start: Annotated[str, typer.Option(
        "--start", metavar="X,Y|PLACE", show_default=False,
        help="Where the robot starts: X,Y in metres or a place of the world.")],
    target: Annotated[str, typer.Option(
        "--target", metavar="X,Y|PLACE", show_default=False,
        help="The target: X,Y in metres or a place of the world.")],
    heading: Annotated[float | None, typer.Option(
        "--heading", metavar="DEGREES", show_default=False,
        help="The start heading in degrees counter-clockwise from +x (default: facing the "
        "target).")] = None,
    pilot: PilotOption = "potential_field",
    timeout: TimeoutOption = 300.0,
    dt: DtOption = 0.1,
    tolerance: ToleranceOption = 0.3,
    seed: Annotated[int, typer.Option("--seed", min=0, metavar="SEED",
                                      help="The seed of the sensor noise.")]
    = 0,
    robot: RobotOption = RobotName.pioneer2dx,
    rescue: RescueOption = Rescue.blocked,
    plot: PlotOption = None,
    gif: Annotated[Path | None, typer.Option(
        "--gif", metavar="FILE", show_default=False,
        help="Animate the trial into this GIF file.")] = None,
    fps: Annotated[int, typer.Option("--fps", min=1, metavar="N",
                                     help="Frames a second of the GIF.")] = 10,
    frames: Annotated[int, typer.Option(
        "--frames", min=1, max=MAX_FRAMES, metavar="N",
        help="The most frames of the GIF, spread evenly over the trial.")]
    = 150,
    record: RecordOption = None,
    force: ForceOption = False,
    rate: RateOption = 2.0,
    as_json: RunJsonOption = False,
) -> None:
    """Run one trial from a start to a target; print how it went, draw, animate or record
    it."""
    from cbr_world2d.robot import Pose
    from cbr_world2d.simulation import PilotRecipe, Trial, run_trial

    _timing(timeout, dt, tolerance)
    if force and record is None:
        raise typer.BadParameter("--force goes with --record", param_hint="'--force'")
    if record is not None:
        from cbr_recording.files import check_path

        check_path(record, force=force)
    if heading is not None and not math.isfinite(heading):
        raise typer.BadParameter(f"expected a finite angle, got {heading!r}",
                                 param_hint="'--heading'")
    _writable(plot, "--plot")
    _writable(gif, "--gif")
    world = load(world_name)
    spec = _spec(robot)
    recipe = PilotRecipe.named(pilot)
    start_point = _point(world, start, "--start")
    target_point = _point(world, target, "--target")
    if heading is None:
        theta = math.atan2(target_point[1] - start_point[1], target_point[0] - start_point[0])
    else:
        theta = math.radians(heading)
    trial = Trial(Pose(*start_point, theta), target_point, timeout=timeout,
                  tolerance=tolerance, dt=dt)
    trial.check(world, spec, start="--start", target="--target")
    if record is None:
        result = run_trial(world, trial, recipe, spec=spec, seed=seed,
                           navigation=_navigation(rescue))
    else:
        from cbr_recording.recorder import Recorder

        with Recorder(record, force=force, rate=rate) as recorder:
            result = run_trial(world, trial, recipe, spec=spec, seed=seed,
                               navigation=_navigation(rescue), recorder=recorder)
    if plot is not None:
        from cbr_world2d.plot import plot_trial

        plot_trial(world, result, plot)
    if gif is not None:
        from cbr_world2d.plot import animate_trial

        animate_trial(world, result, gif, fps=fps, max_frames=frames)
    if as_json:
        typer.echo(json.dumps({"world": world.name, "start": list(start_point),
                               "target": list(target_point), "pilot": pilot,
                               "robot": robot.value, **result.summary()}))
        return
    typer.echo(f"{'world':<10} {world.name or world_name}")
    typer.echo(f"{'trial':<10} {_where(*start_point)} -> {_where(*target_point)}, pilot "
               f"{pilot}, robot {robot.value}, rescue {rescue.value}, seed {seed}")
    for key, value in _result_lines(result):
        typer.echo(f"{key:<10} {value}")
    for written in (plot, gif, record):
        if written is not None:
            typer.echo(f"wrote {written}")


def batch(
    world_name: WorldArgument,
    trials: Annotated[int, typer.Option(
        "--trials", min=1, max=MAX_TRIALS, metavar="N",
        help="How many trials, between random free points.")] = 10,
    seed: Annotated[int, typer.Option(
        "--seed", min=0, metavar="SEED",
        help="The seed of the random points and of every trial's noise.")]
    = 0,
    workers: Annotated[int, typer.Option(
        "--workers", min=1, metavar="N",
        help="Processes running trials at once (at most 4 per core).")] = 2,
    pilot: PilotOption = "potential_field",
    timeout: TimeoutOption = 300.0,
    dt: DtOption = 0.1,
    tolerance: ToleranceOption = 0.3,
    robot: RobotOption = RobotName.pioneer2dx,
    rescue: RescueOption = Rescue.blocked,
    record: Annotated[Path | None, typer.Option(
        "--record", metavar="FILE", show_default=False, hidden=True)] = None,
    as_json: BatchJsonOption = False,
) -> None:
    """Run trials between random free points of a world; print a table and the success rate,
    median time and distance."""
    import numpy as np

    from cbr_world2d.simulation import PilotRecipe, random_trials, run_batch

    if record is not None:
        raise typer.BadParameter(
            "cbr sim batch runs its trials in parallel processes and records none; record "
            "one trial with 'cbr sim run --record FILE.mcap', or trials one after another "
            "with 'cbr run CONFIG --record FILE.mcap' (the trials workload)",
            param_hint="'--record'")
    _timing(timeout, dt, tolerance)
    most = WORKERS_PER_CORE * (os.cpu_count() or 1)
    if workers > most:
        raise typer.BadParameter(f"{workers} is more than the {most} processes this machine "
                                 f"may run (the limit, {WORKERS_PER_CORE} per core)",
                                 param_hint="'--workers'")
    world = load(world_name)
    spec = _spec(robot)
    recipe = PilotRecipe.named(pilot)
    rng = np.random.default_rng(seed)
    planned = random_trials(world, trials, spec, rng, timeout=timeout, tolerance=tolerance,
                            dt=dt)
    results = run_batch(world, planned, recipe, spec=spec, seed=seed,
                        navigation=_navigation(rescue), workers=workers)
    reached = [r for r in results if r.success]
    median_time = statistics.median(r.time for r in reached) if reached else None
    median_distance = statistics.median(r.distance for r in reached) if reached else None
    if as_json:
        for k, result in enumerate(results):
            typer.echo(json.dumps({"trial": k, "start": [result.trial.start.x,
                                                         result.trial.start.y],
                                   "target": list(result.trial.target), **result.summary()}))
        typer.echo(json.dumps({"trials": len(results), "reached": len(reached),
                               "success_rate": len(reached) / len(results),
                               "median_time": median_time,
                               "median_distance": median_distance}))
        return
    typer.echo(f"{'trial':>5}  {'start':>13}  {'target':>13}  {'success':<7}  {'time s':>7}  "
               f"{'dist m':>7}  {'coll':>4}  {'stuck':>5}")
    for k, result in enumerate(results):
        trial = result.trial
        typer.echo(f"{k:>5}  {_where(trial.start.x, trial.start.y):>13}  "
                   f"{_where(*trial.target):>13}  {'yes' if result.success else 'no':<7}  "
                   f"{result.time:>7.1f}  {result.distance:>7.2f}  {result.collisions:>4}  "
                   f"{len(result.stuck):>5}")
    shown_time = "-" if median_time is None else f"{median_time:.1f} s"
    shown_distance = "-" if median_distance is None else f"{median_distance:.2f} m"
    typer.echo(f"reached {len(reached)} of {len(results)} "
               f"({100.0 * len(reached) / len(results):.0f}%), median time {shown_time}, median "
               f"distance {shown_distance} (of the trials that reached their target)")


def add_commands(app: typer.Typer) -> None:
    """Add the ``cbr sim`` group (``show``, ``run``, ``batch``) to ``app``."""
    sim = typer.Typer(name="sim", help="Simulate robots in the continuous 2D world.",
                      no_args_is_help=True)
    sim.command("show")(show)
    sim.command("run")(run)
    sim.command("batch")(batch)
    app.add_typer(sim)
