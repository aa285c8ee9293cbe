"""``cbr plan`` and ``cbr map show``: plan on a map, draw a map and a planned path.

Both take every map :func:`cbr_grid.formats.load_grid` reads (Moving AI ``.map``, ROS
map_server ``.yaml``, ``.png``, ``.npy``, ``.grid``) and can inflate its obstacles by a robot's
radius (:mod:`cbr_grid.inflation`). ``cbr plan`` answers one start and goal, given as cells or,
on a map with a metric frame, in metres; or a sample of a Moving AI ``.scen`` file's scenarios
in one process, checking each length against the file's optimal one. With ``--frame map``
every message is in metres (the cell in brackets); ``--path-out`` writes the path to a CSV or
GeoJSON file (:mod:`cbr_grid.path_files`) while the screen gets a short summary. The grid, its
map formats, NumPy, the compiled searches and matplotlib are imported inside the commands, so
that loading the plugin at every start of ``cbr`` stays cheap.
"""

from __future__ import annotations

import enum
import functools
import json
import math
import re
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from cbr_grid import EXTENSIONS
from cbrcore.errors import CbrError

if TYPE_CHECKING:
    from cbr_grid.grid import Grid
    from cbr_grid.movingai import Scenario
    from cbr_grid.query import Cell

Search = Callable[["Grid", "Cell", list["Cell"]], Any]
"""A solver's search as ``cbr plan`` calls it: ``search(grid, start, goals)``, a result with a
``path`` and a ``cost`` (and more from a built-in search), or None."""


class FrameName(enum.StrEnum):
    cell = "cell"
    map = "map"


MapPath = Annotated[Path, typer.Argument(
    metavar="MAP", help="The map file: Moving AI .map, ROS map_server .yaml, .png (dark cells "
    "are obstacles), .npy (risk array) or .grid (text).", show_default=False)]
PlotPath = Annotated[
    Path | None,
    typer.Option("--plot", metavar="FILE", help="Draw the picture to this file (PNG, or "
                 "another format matplotlib knows by the extension).", show_default=False),
]
_ALLOW_UNKNOWN = "--allow-unknown"
"""How errors about unknown cells name the option that lets a planner cross them."""
AllowUnknown = Annotated[bool, typer.Option(
    f"{_ALLOW_UNKNOWN}/--no-allow-unknown",
    help="ROS maps: let the planner cross cells the map leaves unknown, at the highest cost "
    "short of an obstacle (Nav2's planners' allow_unknown and default); --no-allow-unknown "
    "makes them obstacles.")]
RobotRadius = Annotated[float | None, typer.Option(
    "--robot-radius", metavar="R", min=0.0, help="Inflate the obstacles by the robot's "
    "inscribed radius R, as Nav2's inflation layer does (metres on a map with a frame, else "
    "cells).", show_default=False)]
InflationRadius = Annotated[float | None, typer.Option(
    "--inflation-radius", metavar="R", min=0.0, help="With --robot-radius: how far from "
    "obstacles the decaying cost reaches (default: the robot radius).", show_default=False)]
CostScaling = Annotated[float | None, typer.Option(
    "--cost-scaling", metavar="F", min=0.0, help="With --robot-radius: how fast the cost "
    "decays beyond the robot radius, per metre or cell (default 3.0).", show_default=False)]


def _map(map_file: Path, allow_unknown: bool, robot_radius: float | None,
         inflation_radius: float | None, cost_scaling: float | None) -> tuple[Grid, Grid]:
    """The map as read and as planned on (inflated when a robot radius is given)."""
    from cbr_grid.formats import load_grid
    from cbr_grid.inflation import Inflation, inflate

    if robot_radius is None:
        if inflation_radius is not None or cost_scaling is not None:
            raise typer.BadParameter("--inflation-radius and --cost-scaling inflate by a robot "
                                     "radius: give --robot-radius too",
                                     param_hint="'--robot-radius'")
        inflation = None
    else:
        try:
            inflation = Inflation(robot_radius, inflation_radius,
                                  3.0 if cost_scaling is None else cost_scaling)
        except ValueError as exc:
            raise _inflation_usage(exc) from None
    read = load_grid(map_file, allow_unknown=allow_unknown)
    if read.frame is not None and read.frame.yaw != 0:
        # Nav2's costmaps and AMCL ignore the yaw, so the same metres may mean other cells there
        typer.echo(f"warning: {map_file}: the origin's yaw is {read.frame.yaw:g} rad; metre "
                   "coordinates here are turned by the yaw, unlike Nav2, which ignores it",
                   err=True)
    return read, read if inflation is None else inflate(read, inflation)


_INFLATION_OPTIONS = {"robot_radius": "--robot-radius", "inflation_radius": "--inflation-radius",
                      "cost_scaling_factor": "--cost-scaling"}
"""The command line's spelling of each :class:`Inflation` field."""
_FIELD_PROBLEM = re.compile(r"^'(?P<field>\w+)' (?P<rest>must .*)$", re.S)


def _inflation_usage(exc: ValueError) -> typer.BadParameter:
    """The usage error of an :class:`Inflation` validator's ``'field' must ...``, naming the
    option of the field, and any other field it mentions, as the command line spells them."""
    named = _FIELD_PROBLEM.match(str(exc))
    if named is None or named["field"] not in _INFLATION_OPTIONS:
        return typer.BadParameter(str(exc), param_hint="'--robot-radius'")
    rest = re.sub("|".join(_INFLATION_OPTIONS), lambda m: _INFLATION_OPTIONS[m[0]],
                  named["rest"])
    return typer.BadParameter(rest, param_hint=f"'{_INFLATION_OPTIONS[named['field']]}'")


def _pair(text: str, option: str, number: type[int] | type[float], what: str) -> tuple[Any, Any]:
    """The two numbers written ``X,Y`` in ``text``; a usage error naming ``option`` otherwise."""
    try:
        x, y = (number(part.strip()) for part in text.split(","))
    except ValueError:
        raise typer.BadParameter(f"expected {what} X,Y, got {text!r}",
                                 param_hint=f"'{option}'") from None
    # an integer is finite, and may be too large for numpy: the map says whether it is on it
    if number is float and not (math.isfinite(x) and math.isfinite(y)):
        raise typer.BadParameter(f"expected {what} X,Y, got {text!r}", param_hint=f"'{option}'")
    return x, y


def _cell(text: str, option: str, map_file: Path, allow_unknown: bool) -> Cell:
    """The cell written ``X,Y`` in ``text``; numbers that are not whole on a map with a metric
    frame get the hint that they may be metres."""
    try:
        return _pair(text, option, int, "a cell of two integers")
    except typer.BadParameter as exc:
        try:
            _pair(text, option, float, "")
        except typer.BadParameter:
            raise exc from None
        hint = _frame_hint(_metric_map(map_file, allow_unknown))
        if not hint:
            raise
        raise typer.BadParameter(f"{exc.message}{hint}", param_hint=f"'{option}'") from None


def _metric_map(map_file: Path, allow_unknown: bool) -> Grid | None:
    """The map, read only to tell whether it has a metric frame: None for a format without
    one, or a map that cannot be read (its own error comes when it is read for planning)."""
    from cbr_grid.formats import load_grid

    if map_file.suffix.lower() not in (".yaml", ".yml"):
        return None
    try:
        return load_grid(map_file, allow_unknown=allow_unknown)
    except CbrError:
        return None


def _frame_hint(grid: Grid | None) -> str:
    """The hint, for coordinates that look like metres given as cells, that ``--frame map``
    reads metres, with where the map's frame lies; empty for a map without a frame."""
    if grid is None or grid.frame is None:
        return ""
    return (f"; did you mean --frame map? (the map's frame spans "
            f"{grid.frame.spans(grid.width, grid.height)})")


def _point(text: str, option: str) -> tuple[float, float]:
    """The map-frame point written ``X,Y`` (metres) in ``text``."""
    return _pair(text, option, float, "a point of two finite numbers (metres)")


def _heading(text: str | None, option: str) -> int | None:
    """The direction written in ``text`` (a name or 0-7); a usage error naming ``option``."""
    from cbr_grid.directions import parse

    if text is None:
        return None
    try:
        return parse(text)
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint=f"'{option}'") from None


def _searcher(solver: str, kinematics: str, heading: int | None,
              final_heading: int | None, seed: int | None, grid: Grid) -> Search:
    """The search of the solver component ``solver`` for the kinematic model named
    ``kinematics``, warmed up for ``grid``'s rules before any timing: a built-in search called
    directly, or any other registered grid planner through the solver protocol."""
    from cbr_grid.planning import planner_problem
    from cbr_kinematics import kinematics_of
    from cbr_solvers import KINEMATIC_MODULES, SEARCH_MODULES, load_search, warm_grid, warm_query
    from cbrcore.context import Context
    from cbrcore.plugins import current

    registry = current().registry
    problem = planner_problem(registry, solver)
    if problem is not None:
        raise CbrError(f"--solver: {problem}")
    if seed is not None and solver not in _SEEDED:
        raise typer.BadParameter(f"--seed applies to --solver {' or '.join(_SEEDED)} only",
                                 param_hint="'--seed'")
    ctx = Context(registry=registry, seed=0, world=grid)
    model = kinematics_of(kinematics, ctx, "--kinematics")
    if model is None and (heading is not None or final_heading is not None):
        raise typer.BadParameter(f"kinematics {kinematics!r} turns any way: headings apply "
                                 "to a constrained model such as forward",
                                 param_hint="'--heading' / '--final-heading'")
    if solver not in SEARCH_MODULES:
        return _registered(solver, ctx, model, heading, final_heading)
    options: dict[str, Any] = {} if seed is None else {"seed": seed}
    if model is None:
        function: Callable[..., Any] = functools.partial(load_search(solver), **options)
    else:
        if solver not in KINEMATIC_MODULES:
            raise typer.BadParameter(
                f"--solver {solver} plans for holonomic robots only; for kinematics "
                f"{kinematics!r} use one of {', '.join(KINEMATIC_MODULES)}",
                param_hint="'--kinematics'")
        function = functools.partial(load_search(solver, kinematic=True), kinematics=model,
                                     heading=heading, final_heading=final_heading, **options)

    def search(on: Grid, start: Cell, goals: list[Cell]) -> Any:
        return function(on.factor, on.passable, on.corner_cutting, start, goals)

    # The first call loads the kernels from the disk cache (or compiles them); a search around
    # a wall, with the map's rules and the same options, runs every kernel the timed search
    # will, so none of that reaches the times reported. 16 cells leave a constrained robot room
    # to turn to any heading.
    warm = warm_grid(grid, size=16)
    query = warm_query(warm)
    search(warm, query.start, [query.goal])
    return search


_SEEDED = ("genetic", "randomized")
"""The built-in solvers ``--seed`` seeds."""


def _registered(solver: str, ctx: Any, model: Any, heading: int | None,
                final_heading: int | None) -> Search:
    """The search of the registered grid planner ``solver`` (not a built-in search), built
    with its default options in ``ctx`` (the map as world, the robot's model stashed) and
    warmed up by its own ``cbr_warm`` hook when it has one, as a run's engine does."""
    import numpy as np

    from cbr_grid.planning import plan_with, planner_of
    from cbr_kinematics import KINEMATICS

    if model is not None:
        ctx.stash[KINEMATICS] = model
    planner = planner_of(solver, ctx, "--solver")
    if model is not None and not planner.constrained:
        raise typer.BadParameter(f"--solver {solver} plans for robots that may make any move, "
                                 f"not for kinematics {type(model).__name__}",
                                 param_hint="'--kinematics'")
    if final_heading is not None:
        raise typer.BadParameter(f"--solver {solver} plans through the solver protocol, which "
                                 "takes no final heading; the built-in searches do",
                                 param_hint="'--final-heading'")
    warm = getattr(planner, "cbr_warm", None)
    if callable(warm):
        warm(ctx=ctx)

    def search(on: Grid, start: Cell, goals: list[Cell]) -> Any:
        return plan_with(planner, on, start, np.array(goals, dtype=np.int64), heading=heading)

    return search


def _plan(search: Search, solver: str, grid: Grid, start: Cell,
          goal: Cell) -> dict[str, Any] | None:
    """Plan from ``start`` to ``goal``: the record ``cbr plan`` prints, or None without a path."""
    from cbr_grid.costs import path_length, turns

    began = time.perf_counter()
    result = search(grid, start, [goal])
    time_ms = (time.perf_counter() - began) * 1000.0
    if result is None:
        return None
    # a solver of the protocol reports no expanded cells
    record = {"solver": solver, "length": path_length(result.path), "cost": result.cost,
              "turns": turns(result.path), "time_ms": time_ms,
              "expanded": getattr(result, "expanded", None), "path": result.path.tolist()}
    if hasattr(result, "headings"):
        record.update(headings=result.headings.tolist(), reversing=result.reversing.tolist())
    if hasattr(result, "search"):
        record["search"] = result.search  # jps: the search that planned, itself or A*
    if grid.frame is not None:
        record.update(length_m=record["length"] * grid.frame.resolution,
                      path_m=grid.to_map(result.path).tolist())
    return record


def _place(written: Cell | tuple[float, float], cell: Cell, frame: FrameName) -> str:
    """A start or goal as messages write it: the cell, or the point in metres as written with
    its cell in brackets."""
    from cbr_grid.frame import in_metres

    return in_metres(written, cell) if frame is FrameName.map else f"({cell[0]}, {cell[1]})"


def _endpoint(read: Grid, grid: Grid, written: Cell | tuple[float, float], option: str,
              frame: FrameName, radius: float | None) -> Cell:
    """The cell of a start or goal written as a cell or a map-frame point: on ``grid`` (the
    map as planned on) and free, or an error naming ``option`` and the cell (and the point)."""
    if frame is FrameName.map:
        x, y = read.check_point(written, option, allow=_ALLOW_UNKNOWN)
        said = f"{option} {_place(written, (x, y), frame)}"
    else:
        what = option.removeprefix("--")
        try:
            x, y = read.check_cell(written, what, allow=_ALLOW_UNKNOWN)
        except CbrError as exc:
            # Python's integers, since a cell past 64 bits is still only off the grid
            on_grid = 0 <= written[0] < read.width and 0 <= written[1] < read.height
            hint = "" if on_grid else _frame_hint(read)
            if not hint:
                raise
            raise CbrError(f"{exc}{hint}") from exc
        said = f"{what} ({x}, {y})"
    if not grid.passable[y, x]:
        unit = "m" if grid.frame is not None else "cells"
        raise CbrError(f"{said} is within the robot radius ({radius:g} {unit}) of an obstacle")
    return x, y


def _summary(record: dict[str, Any], grid: Grid, frame: FrameName) -> str:
    """The path in one line: how many cells, from where to where (in metres with ``frame``
    map, each point the centre of its cell)."""
    from cbr_grid.frame import in_metres

    ends = [record["path"][0], record["path"][-1]]
    if frame is FrameName.map:
        start, goal = (in_metres(point, cell) for point, cell in zip(grid.to_map(ends).tolist(),
                                                                      ends, strict=True))
    else:
        start, goal = (f"({x}, {y})" for x, y in ends)
    return f"{len(record['path'])} cells from {start} to {goal}"


def _save_plot(grid: Grid, out: Path, path: list[list[int]] | None = None,
               start: Cell | None = None, goal: Cell | None = None, **headings: Any) -> None:
    """Draw ``grid`` (and the path, start and goal given, with the headings and reversing
    steps of :func:`cbr_grid.plot.draw_on`) into the file ``out``."""
    # matplotlib loads only when a picture is asked for
    from cbr_grid.plot import draw_grid

    figure = draw_grid(grid, path=path, start=start, goal=goal, **headings)
    try:
        figure.savefig(out, dpi=150, bbox_inches="tight")
    except (OSError, ValueError) as exc:
        raise CbrError(f"{out}: cannot write the picture: {exc}") from exc


def _spread(scenarios: list[Scenario], limit: int | None) -> list[Scenario]:
    """``limit`` scenarios evenly spaced over the buckets (in bucket order); all without one."""
    import numpy as np

    # sorted() is stable, so scenarios keep their file order within a bucket
    ordered = sorted(scenarios, key=lambda scenario: scenario.bucket)
    if limit is None or limit >= len(ordered):
        return ordered
    # with at least one scenario between picks, rounding never picks one twice
    picks = np.linspace(0, len(ordered) - 1, limit).round().astype(int)
    return [ordered[i] for i in picks]


def _plan_scenarios(search: Search, solver: str, grid: Grid, scen: Path,
                    limit: int | None, as_json: bool) -> None:
    """Plan the sampled scenarios of ``scen``: one line each, then a summary line."""
    from cbr_grid.movingai import load_scen

    scenarios = _spread(load_scen(scen, grid), limit)
    matched = 0
    times = []
    for scenario in scenarios:
        try:
            start = grid.check_cell(scenario.start, "start")
            goal = grid.check_cell(scenario.goal, "goal")
        except CbrError as exc:
            # the cell is the scenario file's, so its line is what the reader must find
            raise CbrError(f"{scen}, line {scenario.line}: {exc}") from exc
        record = _plan(search, solver, grid, start, goal)
        if record is None:
            # a scenario without a path still gets its line, so the output stays one per problem
            record = {"solver": solver, "length": None, "cost": None, "turns": None,
                      "time_ms": None, "expanded": None, "path": None}
            agrees = False
        else:
            agrees = scenario.agrees(record["length"])
            times.append(record["time_ms"])
        matched += agrees
        record["optimal"] = scenario.optimal
        if as_json:
            typer.echo(json.dumps(record))
        else:
            found = ("no path" if record["length"] is None else
                     f"length {record['length']:.6g}, {record['time_ms']:.3f} ms")
            verdict = "agrees" if agrees else "DIFFERS"
            typer.echo(f"bucket {scenario.bucket} {start} -> {goal}: {found}, optimal "
                       f"{scenario.optimal:.6g} ({verdict})")
    median = statistics.median(times) if times else None
    if as_json:
        typer.echo(json.dumps({"matched": matched, "total": len(scenarios),
                               "median_time_ms": median}))
    else:
        shown = "-" if median is None else f"{median:.3f} ms"
        typer.echo(f"matched {matched} of {len(scenarios)} optimal lengths, median time {shown}")


def plan(
    map_file: MapPath,
    start: Annotated[str | None, typer.Option(
        "--start", metavar="X,Y", help="The start: a cell (column, row), or with --frame map a "
        "point in metres.", show_default=False)] = None,
    goal: Annotated[str | None, typer.Option(
        "--goal", metavar="X,Y", help="The goal: a cell (column, row), or with --frame map a "
        "point in metres.", show_default=False)] = None,
    frame: Annotated[FrameName, typer.Option(
        "--frame", help="How --start and --goal are written: cells, or metres in the map frame "
        "of a ROS map (messages and the summary then give metres, each with its cell in "
        "brackets).")] = FrameName.cell,
    scen: Annotated[Path | None, typer.Option(
        "--scen", metavar="FILE", help="Plan the scenarios of this Moving AI .scen file "
        "instead (with a .map only).", show_default=False)] = None,
    limit: Annotated[int | None, typer.Option(
        "--limit", metavar="N", min=1, help="With --scen: plan this many scenarios, spread "
        "evenly over the buckets (default: all).", show_default=False)] = None,
    solver: Annotated[str, typer.Option(
        "--solver", metavar="NAME", help="The solver component to plan with: dijkstra, astar, "
        "aistar, jps, genetic, randomized or another registered grid planner. jps is jump "
        "point search (it hands a map with risk over to astar); genetic, the genetic algorithm "
        "with its default options, may find no path where one exists, and its path is seldom "
        "the cheapest.")] = "astar",
    seed: Annotated[int | None, typer.Option(
        "--seed", metavar="N", min=0, help="With --solver genetic or randomized: the random "
        "seed (default 0).", show_default=False)] = None,
    kinematics: Annotated[str, typer.Option(
        "--kinematics", metavar="NAME", help="The robot's kinematic model: holonomic, forward, "
        "forward_backward or another registered one.")] = "holonomic",
    heading: Annotated[str | None, typer.Option(
        "--heading", metavar="DIR", help="The direction the robot faces at the start: E, NE, "
        "N, NW, W, SW, S, SE or 0-7 (default: any).", show_default=False)] = None,
    final_heading: Annotated[str | None, typer.Option(
        "--final-heading", metavar="DIR", help="The direction in which the robot must be able "
        "to drive on from the goal (default: any).", show_default=False)] = None,
    allow_unknown: AllowUnknown = True,
    robot_radius: RobotRadius = None,
    inflation_radius: InflationRadius = None,
    cost_scaling: CostScaling = None,
    as_json: Annotated[bool, typer.Option("--json", help=(
        "Print one JSON object with the keys solver, length, cost, turns, time_ms (the search "
        "alone, in milliseconds), expanded and path (a list of [x, y] cells); with --solver "
        "jps also search (jps, or astar when jps handed a map with risk over); with a "
        "constrained --kinematics also headings and reversing (per step); on a map with a "
        "frame also length_m and path_m (the cell centres in metres). With --scen one such "
        "object per scenario plus optimal (the file's length; null values where no path "
        "exists), then one with matched, total and median_time_ms."))] = False,
    plot: PlotPath = None,
    path_out: Annotated[Path | None, typer.Option(
        "--path-out", metavar="FILE", help="Write the path to this file: CSV (a header, then "
        "one x,y line per cell) or, by the extension .geojson or .json, a GeoJSON LineString "
        "feature; in metres in the map frame (cell centres) with --frame map, else cells.",
        show_default=False)] = None,
) -> None:
    """Plan a path on a map: one start and goal, or the scenarios of a Moving AI .scen file."""
    from cbr_grid.path_files import path_format, write_path

    if scen is None:
        _check_one_plan(start, goal, limit)
    else:
        _check_scenario_plans(map_file, start, goal, frame, plot, path_out,
                              (robot_radius, inflation_radius, cost_scaling))
    start_at = _given(start, "--start", frame, map_file, allow_unknown)
    goal_at = _given(goal, "--goal", frame, map_file, allow_unknown)
    if path_out is not None:
        try:
            path_format(path_out)
        except CbrError as exc:
            raise typer.BadParameter(str(exc), param_hint="'--path-out'") from None
    start_heading = _heading(heading, "--heading")
    goal_heading = _heading(final_heading, "--final-heading")
    read, grid = _map(map_file, allow_unknown, robot_radius, inflation_radius, cost_scaling)
    if frame is FrameName.map and grid.frame is None:
        raise typer.BadParameter(f"{map_file} has no metric frame (ROS .yaml maps have one): "
                                 "give --start and --goal as cells", param_hint="'--frame'")
    search = _searcher(solver, kinematics, start_heading, goal_heading, seed, grid)
    if scen is not None:
        _plan_scenarios(search, solver, grid, scen, limit, as_json)
        return
    start_cell = _endpoint(read, grid, start_at, "--start", frame, robot_radius)
    goal_cell = _endpoint(read, grid, goal_at, "--goal", frame, robot_radius)
    record = _plan(search, solver, grid, start_cell, goal_cell)
    if record is None:
        typer.echo(f"no path from {_place(start_at, start_cell, frame)} to "
                   f"{_place(goal_at, goal_cell, frame)} on {map_file}", err=True)
        raise typer.Exit(1)
    if plot is not None:
        _save_plot(grid, plot, record["path"], start_cell, goal_cell, heading=start_heading,
                   final_heading=goal_heading, reversing=record.get("reversing"))
    if path_out is not None:
        metres = frame is FrameName.map
        write_path(path_out, record["path_m"] if metres else record["path"], metres=metres,
                   properties={key: record[key] for key in ("solver", "length", "cost",
                                                            "length_m") if key in record})
    if as_json:
        typer.echo(json.dumps(record))
        return
    _print_plan(record, grid, frame)
    for written in (path_out, plot):
        if written is not None:
            typer.echo(f"wrote {written}")


def _check_one_plan(start: str | None, goal: str | None, limit: int | None) -> None:
    if start is None or goal is None:
        raise typer.BadParameter("give --start and --goal, or --scen",
                                 param_hint="'--start' / '--goal'")
    if limit is not None:
        raise typer.BadParameter("--limit applies to --scen only", param_hint="'--limit'")


def _check_scenario_plans(map_file: Path, start: str | None, goal: str | None,
                          frame: FrameName, plot: Path | None, path_out: Path | None,
                          inflation: tuple[float | None, float | None, float | None]) -> None:
    """Refuse the options that do not go with ``--scen``; ``inflation`` holds the values of
    --robot-radius, --inflation-radius and --cost-scaling."""
    if start is not None or goal is not None:
        raise typer.BadParameter("--scen plans the file's own starts and goals",
                                 param_hint="'--start' / '--goal'")
    if plot is not None:
        raise typer.BadParameter("--plot draws one path, not the scenarios of --scen",
                                 param_hint="'--plot'")
    if path_out is not None:
        raise typer.BadParameter("--path-out writes one path, not the scenarios of --scen",
                                 param_hint="'--path-out'")
    if map_file.suffix.lower() != ".map":
        raise typer.BadParameter(f"Moving AI scenarios go with a Moving AI .map, not "
                                 f"{map_file.name}", param_hint="'--scen'")
    if frame is FrameName.map:
        raise typer.BadParameter("scenarios give cells: --frame map does not apply",
                                 param_hint="'--frame'")
    given = [option for option, value in zip(("--robot-radius", "--inflation-radius",
                                              "--cost-scaling"), inflation, strict=True)
             if value is not None]
    if given:
        raise typer.BadParameter("a scenario file's optimal lengths are for the map as it "
                                 "is: --scen plans without inflation",
                                 param_hint=" / ".join(f"'{o}'" for o in given))


def _given(text: str | None, option: str, frame: FrameName, map_file: Path,
           allow_unknown: bool) -> Cell | tuple[float, float] | None:
    """The --start or --goal written: a point in metres with --frame map, else a cell; None
    when not given."""
    if text is None:
        return None
    if frame is FrameName.map:
        return _point(text, option)
    return _cell(text, option, map_file, allow_unknown)


def _print_plan(record: dict[str, Any], grid: Grid, frame: FrameName) -> None:
    """A planned path's summary, one fact a line."""
    for key in ("length", "cost", "turns", "time_ms", "expanded", "search", "length_m"):
        value = record.get(key)
        if value is not None:
            typer.echo(f"{key:<9} {value:.6g}" if isinstance(value, float)
                       else f"{key:<9} {value}")
    if "headings" in record:
        from cbr_grid.directions import NAMES

        typer.echo(f"{'headings':<9} {' '.join(NAMES[h] for h in record['headings'])}")
        typer.echo(f"{'reversing':<9} {sum(record['reversing'])} of {len(record['reversing'])} "
                   "steps")
    typer.echo(f"{'path':<9} {_summary(record, grid, frame)}")

def show(
    map_file: MapPath,
    allow_unknown: AllowUnknown = True,
    robot_radius: RobotRadius = None,
    inflation_radius: InflationRadius = None,
    cost_scaling: CostScaling = None,
    as_json: Annotated[bool, typer.Option("--json", help=(
        "Print one JSON object with the keys map, width, height, passable, unknown and frame "
        "(null, or resolution, origin [x, y, yaw] and the extent x and y in metres, each "
        "[from, to])."))] = False,
    plot: PlotPath = None,
) -> None:
    """Print a map's size, passable and unknown cells and metric frame; draw it with --plot."""
    _, grid = _map(map_file, allow_unknown, robot_radius, inflation_radius, cost_scaling)
    unknown = 0 if grid.unknown is None else int(grid.unknown.sum())
    facts: dict[str, object] = {"map": str(map_file), "width": grid.width,
                                "height": grid.height, "passable": int(grid.passable.sum()),
                                "unknown": unknown, "frame": None}
    if grid.frame is not None:
        corners = grid.frame.corners(grid.width, grid.height)
        (left, bottom), (right, top) = corners.min(0), corners.max(0)
        facts["frame"] = {"resolution": grid.frame.resolution,
                          "origin": [float(v) for v in grid.frame.origin],
                          "x": [float(left), float(right)], "y": [float(bottom), float(top)]}
    if plot is not None:
        _save_plot(grid, plot)
    if as_json:
        typer.echo(json.dumps(facts))
        return
    typer.echo(f"{map_file}: {grid.width}x{grid.height}, {facts['passable']} passable "
               f"cells, {unknown} unknown")
    if grid.frame is not None:
        x, y, yaw = grid.frame.origin
        typer.echo(f"frame: {grid.frame.resolution:g} m per cell, origin ({x:g}, {y:g}, "
                   f"yaw {yaw:g}), x {left:g} to {right:g} m, y {bottom:g} to {top:g} m")
    if plot is not None:
        typer.echo(f"wrote {plot}")


def add_commands(app: typer.Typer) -> None:
    """Add ``cbr plan`` and the ``cbr map`` group to ``app``."""
    app.command()(plan)
    maps = typer.Typer(name="map", help=f"Look at maps ({', '.join(EXTENSIONS)}).",
                       no_args_is_help=True)
    maps.command()(show)
    app.add_typer(maps)
