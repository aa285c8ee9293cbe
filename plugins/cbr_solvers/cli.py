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


def _searcher(solver: SolverName) -> Search:
    """The search function of ``solver``, its compiled kernel loaded before any timing."""
    from cbr_solvers import load_search

    function: Search = load_search(solver.value)
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
    return {"solver": solver.value, "length": path_length(result.path), "cost": result.cost,
            "turns": turns(result.path), "time_ms": time_ms, "expanded": result.expanded,
            "path": result.path.tolist()}


def _save_plot(grid: Grid, out: Path, path: list[list[int]] | None = None,
               start: Cell | None = None, goal: Cell | None = None) -> None:
    """Draw ``grid`` (and the path, start and goal given) into the file ``out``."""
    # matplotlib loads only when a picture is asked for
    from cbr_grid.plot import draw_grid

    figure = draw_grid(grid, path=path, start=start, goal=goal)
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
        start = grid.check_cell(scenario.start, "start")
        goal = grid.check_cell(scenario.goal, "goal")
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
    grid = load_map(map_file)
    search = _searcher(solver)
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
        _save_plot(grid, plot, record["path"], start_cell, goal_cell)
    if as_json:
        typer.echo(json.dumps(record))
        return
    for key in ("length", "cost", "turns", "time_ms", "expanded"):
        value = record[key]
        typer.echo(f"{key:<9} {value:.6g}" if isinstance(value, float) else f"{key:<9} {value}")
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
