"""What the case graph reproductions share: the test maps, the quality test, the tasks with a
CBR path between them, timing, table formatting, figures and the base class of the experiments."""

from __future__ import annotations

import copy
import time
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from cbr_casegraph.build import SOLVERS, connected_cells, random_task
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.planner import Failure, Plan, Settings, plan
from cbr_experiments.tasks import task_runner
from cbr_grid.costs import path_length
from cbr_grid.distances import octile
from cbr_grid.generate import generate
from cbr_grid.grid import Grid
from cbrcore.context import Context

if TYPE_CHECKING:
    from matplotlib.figure import Figure

Cell = tuple[int, int]
Progress = Callable[[int, int], None]

DENSITY = 0.15
TERRAIN = 0.5
MAX_RATIO = 1.5
"""The quality test's largest accepted ratio of path length to the octile distance."""

METHODS = ("dijkstra", "astar", "aistar")

CHUNK = 1000
"""Queries per task when an experiment's queries are spread over processes: large enough that a
task's own cost (receiving its case graph, which :func:`chunked` copies into each chunk) is small
beside its planning, small enough that the last tasks leave no worker idle for long."""

REPEATS = 3
"""Runs per CBR query in the timing experiments: a query's time is the median of its runs, so
that one interruption by another process on a shared machine does not count."""

LABELS = {"cbr": "CBR", "dijkstra": "Dijkstra", "astar": "A*", "aistar": "Ai*"}


def make_map(size: int, seed: int) -> Grid:
    """The square test map of side ``size``: random obstacles with terrain risk."""
    return generate("random", size, size, seed, density=DENSITY, terrain=TERRAIN)


def map_info(side: int, seed: int) -> dict[str, Any]:
    """The test map of side ``side`` as results.json describes it."""
    return {"kind": "random", "width": side, "height": side, "density": DENSITY,
            "terrain": TERRAIN, "seed": seed}


def accepted(path: np.ndarray, start: Cell, goal: Cell, max_ratio: float = MAX_RATIO) -> bool:
    """Step 7, as the ``path_quality`` reviser decides it."""
    ideal = float(octile(start, goal))
    return ideal == 0 or path_length(path) / ideal <= max_ratio


def outcome(result: Plan | Failure, start: Cell, goal: Cell) -> str:
    """Why a CBR attempt ended: ``cbr`` when it gave an accepted path, else the failure's kind."""
    if isinstance(result, Plan):
        return "cbr" if accepted(result.path, start, goal) else "rejected by quality"
    if result.reason.startswith("start and goal within delta"):
        return "within delta"
    if result.reason.startswith("no case meets"):
        return "no case near"
    if result.reason.startswith("no local path"):
        return "no local path"
    return "graph not connected"


def timed(call: Callable[[], Any]) -> tuple[Any, float]:
    began = time.perf_counter()
    result = call()
    return result, time.perf_counter() - began


def median_of_runs(call: Callable[[], Any], repeats: int = REPEATS) -> float:
    return float(np.median([timed(call)[1] for _ in range(repeats)]))


def solve(method: str, grid: Grid, start: Cell, goal: Cell) -> Any:
    return SOLVERS[method](grid.factor, grid.passable, grid.corner_cutting, start, [goal])


def warm_up(grid: Grid, cells: np.ndarray, rng: np.random.Generator) -> None:
    """Compile the searches before anything is timed (they are just-in-time compiled)."""
    start, goal = random_task(cells, rng)
    for method in METHODS:
        solve(method, grid, start, goal)


def cbr_tasks(graph: CaseGraph, region: np.ndarray, rng: np.random.Generator, count: int,
              settings: Settings, min_span: float = 0.0) -> list[tuple[Cell, Cell]]:
    """Tasks "set so that a CBR path lies between them" (section 6.3).

    Start and goal lie within delta / 2 of two random graph vertices, on reachable cells,
    farther than delta and at least ``min_span`` (octile) apart, and CBR plans an accepted path
    between them. Fewer than ``count`` are returned only when 50 times as many draws found no
    more.
    """
    vertices = graph.vertices()
    height, width = region.shape
    reach = max(settings.delta // 2, 1)
    tasks: list[tuple[Cell, Cell]] = []
    for _ in range(50 * count):
        if len(tasks) == count or len(vertices) < 2:
            break
        ends = vertices[rng.choice(len(vertices), size=2, replace=False)]
        ends = ends + rng.integers(-reach, reach + 1, size=(2, 2))
        ends[:, 0] = np.clip(ends[:, 0], 0, width - 1)
        ends[:, 1] = np.clip(ends[:, 1], 0, height - 1)
        if not region[ends[:, 1], ends[:, 0]].all():
            continue
        start = (int(ends[0, 0]), int(ends[0, 1]))
        goal = (int(ends[1, 0]), int(ends[1, 1]))
        if float(octile(start, goal)) < min_span:
            continue
        if outcome(plan(graph, start, goal, settings), start, goal) == "cbr":
            tasks.append((start, goal))
    return tasks


def chunked(graph: CaseGraph, tasks: Sequence[tuple[Cell, Cell]], size: int = CHUNK
            ) -> Iterator[tuple[CaseGraph, list[tuple[Cell, Cell]]]]:
    """``tasks`` in chunks of ``size``, each with a copy of ``graph`` as it is now: the tasks of
    a chunk are planned on that copy, wherever they run, while the graph here grows on."""
    frozen = copy.deepcopy(graph)
    for first in range(0, len(tasks), size):
        yield frozen, list(tasks[first:first + size])


def region_mask(grid: Grid, cells: np.ndarray) -> np.ndarray:
    mask = np.zeros(grid.passable.shape, dtype=bool)
    mask[cells[:, 1], cells[:, 0]] = True
    return mask


def median_ms(seconds: Sequence[float]) -> float | None:
    return float(np.median(seconds) * 1000) if len(seconds) else None


def fmt(value: float | None, digits: int = 2) -> str:
    """``value`` for a table cell: ``digits`` decimals, or ``n/a`` when there is none."""
    return "n/a" if value is None else f"{value:.{digits}f}"


def new_figure() -> tuple[Figure, Any]:
    """A figure with one set of axes for an experiment's plot."""
    # imported here: loading the plugin for any other command should not load matplotlib
    from matplotlib.figure import Figure

    figure = Figure(figsize=(6, 4))
    return figure, figure.add_subplot()


class GridExperiment:
    """Keeps the run's seed (every map and task draw derives from it) and the runner of its
    tasks."""

    def __init__(self, options: object, ctx: Context) -> None:
        self.seed = ctx.seed
        self.rng = ctx.spawn_rng()
        self.tasks = task_runner(ctx)

    def prepare(self, size: int) -> tuple[Grid, np.ndarray]:
        """The test map of side ``size``, its reachable cells, and the searches compiled."""
        import matplotlib

        # the experiments draw into files only; no display is needed or wanted
        matplotlib.use("Agg")
        grid = make_map(size, self.seed)
        cells = connected_cells(grid, self.rng)
        warm_up(grid, cells, self.rng)
        return grid, cells
