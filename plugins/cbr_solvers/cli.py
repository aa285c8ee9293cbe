"""``cbr plan`` and ``cbr map show``: plan on a Moving AI map, draw a map and a planned path.

``cbr plan`` answers one start and goal, or a sample of a ``.scen`` file's scenarios in one
process, checking each length against the file's optimal one. The compiled searches and
matplotlib are imported inside the commands, so that loading the plugin at every start of ``cbr``
stays cheap.
"""

from __future__ import annotations

import enum
import functools
import json
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from cbr_grid.costs import path_length, turns
from cbr_grid.grid import Grid
from cbr_grid.movingai import Scenario, load_map, load_scen
from cbr_grid.query import Cell
from cbrcore.errors import CbrError

Search = Callable[..., Any]


class SolverName(enum.StrEnum):
    dijkstra = "dijkstra"
    astar = "astar"
    aistar = "aistar"
    genetic = "genetic"


MapPath = Annotated[Path, typer.Argument(metavar="MAP", help="The Moving AI .map file.",
                                          show_default=False)]
PlotPath = Annotated[
    Path | None,
    typer.Option("--plot", help="Draw the picture to this file (PNG, or another format "
                 "matplotlib knows by the extension).", show_default=False),
]


def _cell(text: str, option: str) -> Cell:
    """The cell written ``X,Y`` in ``text``; a usage error naming ``option`` otherwise."""
    parts = text.split(",")
    try:
        x, y = (int(part.strip()) for part in parts)
    except ValueError:
        raise typer.BadParameter(f"expected a cell X,Y of two integers, got {text!r}",
                                 param_hint=f"'{option}'") from None
    return x, y


def _heading(text: str | None, option: str) -> int | None:
    """The direction written in ``text`` (a name or 0-7); a usage error naming ``option``."""
    from cbr_grid.directions import parse

    if text is None:
        return None
    try:
        return parse(text)
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint=f"'{option}'") from None


def _searcher(solver: SolverName, kinematics: str, heading: int | None,
              final_heading: int | None) -> Search:
    """The search function of ``solver`` for the kinematic model named ``kinematics``, its
    compiled kernel loaded before any timing."""
    from cbr_kinematics import kinematics_of
    from cbr_solvers import KINEMATIC_MODULES, load_search
    from cbrcore.context import Context
    from cbrcore.plugins import current

    model = kinematics_of(kinematics, Context(registry=current().registry, seed=0),
                          "--kinematics")
    if model is None:
        if heading is not None or final_heading is not None:
            raise typer.BadParameter(f"kinematics {kinematics!r} turns any way: headings apply "
                                     "to a constrained model such as forward",
                                     param_hint="'--heading' / '--final-heading'")
        function: Search = load_search(solver.value)
    else:
        if solver.value not in KINEMATIC_MODULES:
            raise typer.BadParameter(
                f"--solver {solver.value} plans for holonomic robots only; for kinematics "
                f"{kinematics!r} use one of {', '.join(KINEMATIC_MODULES)}",
                param_hint="'--kinematics'")
        function = functools.partial(load_search(solver.value, kinematic=True),
                                     kinematics=model, heading=heading,
                                     final_heading=final_heading)
    # The first call loads the kernel from the disk cache (or compiles it); a search on a
    # one-cell grid keeps that out of the times reported. It must be a Grid: numba compiles
    # apart for the read-only arrays a Grid holds.
    tiny = Grid(np.zeros((1, 1)))
    function(tiny.factor, tiny.passable, tiny.corner_cutting, (0, 0), [(0, 0)])
    return function


def _plan(search: Search, solver: SolverName, grid: Grid, start: Cell,
          goal: Cell) -> dict[str, Any] | None:
    """Plan from ``start`` to ``goal``: the record ``cbr plan`` prints, or None without a path."""
    began = time.perf_counter()
    result = search(grid.factor, grid.passable, grid.corner_cutting, start, [goal])
    time_ms = (time.perf_counter() - began) * 1000.0
    if result is None:
        return None
    record = {"solver": solver.value, "length": path_length(result.path), "cost": result.cost,
              "turns": turns(result.path), "time_ms": time_ms, "expanded": result.expanded,
              "path": result.path.tolist()}
    if hasattr(result, "headings"):
        record.update(headings=result.headings.tolist(), reversing=result.reversing.tolist())
    return record


def _save_plot(grid: Grid, out: Path, path: list[list[int]] | None = None,
               start: Cell | None = None, goal: Cell | None = None, **headings: Any) -> None:
    """Draw ``grid`` (and the path, start and goal given, with the headings and reversing
    steps of :func:`cbr_grid.plot.draw_on`) into the file ``out``."""
    # matplotlib loads only when a picture is asked for
    from cbr_grid.plot import draw_grid

    figure = draw_grid(grid, path=path, start=start, goal=goal, **headings)
    try:
        figure.savefig(out, dpi=150)
    except (OSError, ValueError) as exc:
        raise CbrError(f"{out}: cannot write the picture: {exc}") from exc


def _spread(scenarios: list[Scenario], limit: int | None) -> list[Scenario]:
    """``limit`` scenarios evenly spaced over the buckets (in bucket order); all without one."""
    # sorted() is stable, so scenarios keep their file order within a bucket
    ordered = sorted(scenarios, key=lambda scenario: scenario.bucket)
    if limit is None or limit >= len(ordered):
        return ordered
    # with at least one scenario between picks, rounding never picks one twice
    picks = np.linspace(0, len(ordered) - 1, limit).round().astype(int)
    return [ordered[i] for i in picks]


def _plan_scenarios(search: Search, solver: SolverName, grid: Grid, scen: Path,
                    limit: int | None, as_json: bool) -> None:
    """Plan the sampled scenarios of ``scen``: one line each, then a summary line."""
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
            record = {"solver": solver.value, "length": None, "cost": None, "turns": None,
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
        "--start", metavar="X,Y", help="The start cell (column, row).", show_default=False)]
    = None,
    goal: Annotated[str | None, typer.Option(
        "--goal", metavar="X,Y", help="The goal cell (column, row).", show_default=False)]
    = None,
    scen: Annotated[Path | None, typer.Option(
        "--scen", help="Plan the scenarios of this Moving AI .scen file instead.",
        show_default=False)] = None,
    limit: Annotated[int | None, typer.Option(
        "--limit", min=1, help="With --scen: plan this many scenarios, spread evenly over the "
        "buckets (default: all).", show_default=False)] = None,
    solver: Annotated[SolverName, typer.Option("--solver", help="The search to plan with.")]
    = SolverName.astar,
    seed: Annotated[int | None, typer.Option(
        "--seed", min=0, help="With --solver genetic: the random seed (default 0).",
        show_default=False)] = None,
    kinematics: Annotated[str, typer.Option(
        "--kinematics", help="The robot's kinematic model: holonomic, forward, "
        "forward_backward or another registered one.")] = "holonomic",
    heading: Annotated[str | None, typer.Option(
        "--heading", metavar="DIR", help="The direction the robot faces at the start: E, NE, "
        "N, NW, W, SW, S, SE or 0-7 (default: any).", show_default=False)] = None,
    final_heading: Annotated[str | None, typer.Option(
        "--final-heading", metavar="DIR", help="The direction in which the robot must be able "
        "to drive on from the goal (default: any).", show_default=False)] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON objects.")] = False,
    plot: PlotPath = None,
) -> None:
    """Plan a path on a Moving AI map: one start and goal, or the scenarios of a .scen file."""
    if scen is None:
        if start is None or goal is None:
            raise typer.BadParameter("give --start and --goal, or --scen",
                                     param_hint="'--start' / '--goal'")
        if limit is not None:
            raise typer.BadParameter("--limit applies to --scen only", param_hint="'--limit'")
    else:
        if start is not None or goal is not None:
            raise typer.BadParameter("--scen plans the file's own starts and goals",
                                     param_hint="'--start' / '--goal'")
        if plot is not None:
            raise typer.BadParameter("--plot draws one path, not the scenarios of --scen",
                                     param_hint="'--plot'")
    if seed is not None and solver is not SolverName.genetic:
        raise typer.BadParameter("--seed applies to --solver genetic only", param_hint="'--seed'")
    start_cell = None if start is None else _cell(start, "--start")
    goal_cell = None if goal is None else _cell(goal, "--goal")
    start_heading = _heading(heading, "--heading")
    goal_heading = _heading(final_heading, "--final-heading")
    grid = load_map(map_file)
    search = _searcher(solver, kinematics, start_heading, goal_heading)
    if seed is not None:
        search = functools.partial(search, seed=seed)
    if scen is not None:
        _plan_scenarios(search, solver, grid, scen, limit, as_json)
        return
    start_cell = grid.check_cell(start_cell, "start")
    goal_cell = grid.check_cell(goal_cell, "goal")
    record = _plan(search, solver, grid, start_cell, goal_cell)
    if record is None:
        typer.echo(f"no path from {start_cell} to {goal_cell} on {map_file}", err=True)
        raise typer.Exit(1)
    if plot is not None:
        _save_plot(grid, plot, record["path"], start_cell, goal_cell, heading=start_heading,
                   final_heading=goal_heading, reversing=record.get("reversing"))
    if as_json:
        typer.echo(json.dumps(record))
        return
    for key in ("length", "cost", "turns", "time_ms", "expanded"):
        value = record[key]
        typer.echo(f"{key:<9} {value:.6g}" if isinstance(value, float) else f"{key:<9} {value}")
    if "headings" in record:
        from cbr_grid.directions import NAMES

        typer.echo(f"{'headings':<9} {' '.join(NAMES[h] for h in record['headings'])}")
        typer.echo(f"{'reversing':<9} {sum(record['reversing'])} of {len(record['reversing'])} "
                   "steps")
    if plot is not None:
        typer.echo(f"wrote {plot}")


def show(
    map_file: MapPath,
    plot: PlotPath = None,
) -> None:
    """Print a Moving AI map's size and passable cells; draw it with --plot."""
    grid = load_map(map_file)
    typer.echo(f"{map_file}: {grid.width}x{grid.height}, {int(grid.passable.sum())} passable "
               "cells")
    if plot is not None:
        _save_plot(grid, plot)
        typer.echo(f"wrote {plot}")


def add_commands(app: typer.Typer) -> None:
    """Add ``cbr plan`` and the ``cbr map`` group to ``app``."""
    app.command()(plan)
    maps = typer.Typer(name="map", help="Look at Moving AI maps.", no_args_is_help=True)
    maps.command()(show)
    app.add_typer(maps)
