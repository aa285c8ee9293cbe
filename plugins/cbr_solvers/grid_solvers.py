"""The grid solvers: one class per search, planning on the run's grid world with the run's
kinematic model, and what they share (the warm-up grid, the loading of a search's module)."""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any, Literal

import attrs
import numpy as np

from cbr_grid.grid import Grid, grid_world
from cbr_grid.planning import Window
from cbr_grid.query import Cell, GridQuery
from cbr_kinematics import require_any_move, robot_kinematics
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Solution
from cbrcore.options import option

SEARCH_MODULES = {"dijkstra": "cbr_solvers.search", "astar": "cbr_solvers.search",
                  "aistar": "cbr_solvers.aistar", "jps": "cbr_solvers.jps",
                  "genetic": "cbr_solvers.genetic",
                  "randomized": "cbr_solvers.randomized"}
"""Each grid search by name, and the module that holds its function."""

KINEMATIC_MODULES = {"dijkstra": "cbr_solvers.kinematic_search",
                     "astar": "cbr_solvers.kinematic_search",
                     "aistar": "cbr_solvers.kinematic_search",
                     "randomized": "cbr_solvers.randomized"}
"""The grid searches that plan for a kinematic model (section 5 of the case graph paper), and
the module that holds each one's function taking ``kinematics``, ``heading`` and
``final_heading``."""

_KINEMATIC_SOLVERS = ", ".join(sorted(KINEMATIC_MODULES))


def warm_grid(world: Grid, size: int = 8, *, wall: bool = True) -> Grid:
    """A ``size`` x ``size`` grid with ``world``'s corner rule and cost model and a wall down
    its middle (rows 1 to size - 2 of column size // 2), to compile a search's kernels on: the
    arrays a search receives have the types of the world's (read-only, C-ordered float64
    factors and boolean passability), so what is compiled for it serves the world. Without
    ``wall`` the grid is free, for a family's warm-up paths that run anywhere."""
    risk = np.zeros((size, size))
    if wall:
        risk[1:size - 1, size // 2] = 1.0  # so that the search expands and turns
    return Grid(risk, corner_cutting=world.corner_cutting, cost_model=world.cost_model)


def warm_query(grid: Grid) -> GridQuery:
    """A query across the wall of a :func:`warm_grid`."""
    return GridQuery((0, grid.height // 2), (grid.width - 1, grid.height // 2))


def load_search(name: str, *, kinematic: bool = False) -> Callable[..., Any]:
    """The search function ``name``, or its edge-based counterpart for constrained kinematics;
    numba loads with it, not with every start of ``cbr``."""
    modules = KINEMATIC_MODULES if kinematic else SEARCH_MODULES
    return getattr(importlib.import_module(modules[name]), name)


class GridSolver:
    """Plan a path of a grid query by a compiled grid search."""

    name = ""

    def __init__(self, options: object, ctx: Context) -> None:
        grid_world(ctx, f"solver {self.name!r}")
        self.kinematics = robot_kinematics(ctx, f"solver {self.name!r}")
        if self.kinematics is not None and self.name not in KINEMATIC_MODULES:
            raise CbrError(f"solver {self.name!r} plans for robots that may make any move; the "
                           f"configuration's kinematics is {type(self.kinematics).__name__}, "
                           f"which {', '.join(sorted(KINEMATIC_MODULES))} plan for")
        self.search = load_search(self.name, kinematic=self.kinematics is not None)
        self.ctx = ctx

    def search_options(self, ctx: Context) -> dict[str, Any]:
        """The keyword arguments of one search call beyond the grid, start and goals."""
        return {}

    @staticmethod
    def query_seed(seed: int | None, ctx: Context) -> int:
        """The seed of one query of a randomised search: ``seed``, or one drawn from the run's
        seeded generator when it is None."""
        return int(ctx.rng.integers(2**32)) if seed is None else seed

    @property
    def constrained(self) -> bool:
        """Whether the robot's kinematic model limits its turns (:class:`GridPlanner`)."""
        return self.kinematics is not None

    def plan(self, grid: Grid, passable: np.ndarray, start: Cell, goals: np.ndarray, *,
             window: Window | None = None, heading: int | None = None) -> np.ndarray | None:
        """The path this solver plans on ``grid``'s costs through ``passable``
        (:class:`cbr_grid.planning.GridPlanner`)."""
        options = self.search_options(self.ctx)
        if self.kinematics is not None:
            options.update(kinematics=self.kinematics, heading=heading)
        else:
            options.update(window=window)
        found = self.search(grid.factor, passable, grid.corner_cutting, start, goals, **options)
        return None if found is None else found.path

    @hookimpl
    def cbr_warm(self, ctx: Context) -> None:
        """Plan once on a :func:`warm_grid` with the world's rules, in a context of its own so
        that the run's generator is not drawn from."""
        grid = warm_grid(ctx.world)
        scratch = Context(registry=ctx.registry, seed=ctx.seed, world=grid)
        self.cbr_solve(warm_query(grid), scratch)

    @hookimpl
    def cbr_solve(self, problem: GridQuery, ctx: Context) -> Solution | None:
        grid: Grid = ctx.world
        start = grid.check_cell(problem.start, "start")
        goal = grid.check_cell(problem.goal, "goal")
        options = self.search_options(ctx)
        if self.kinematics is not None:
            options.update(kinematics=self.kinematics, heading=problem.heading,
                           final_heading=problem.final_heading)
        result = self.search(grid.factor, grid.passable, grid.corner_cutting, start, [goal],
                             **options)
        if result is None:
            return None
        return Solution(result.path.tolist(), cost=result.cost, detail=self.detail(result))

    def detail(self, result: Any) -> dict[str, Any]:
        """The detail of the solution of a search's ``result``."""
        detail: dict[str, Any] = {"expanded": result.expanded, "solver": self.name}
        if self.kinematics is not None:
            detail.update(headings=result.headings.tolist(),
                          reversing=result.reversing.tolist())
        return detail


class Dijkstra(GridSolver):
    """The cheapest path by Dijkstra's algorithm (compiled, binary heap)."""

    name = "dijkstra"


class AStar(GridSolver):
    """The cheapest path by A* with the octile distance times the smallest cost factor."""

    name = "astar"


class AiStar(GridSolver):
    """The cheapest path by Ai*: A* guided by an integer distance map from the goal."""

    name = "aistar"


@attrs.frozen
class JumpPointSearchOptions:
    """Jump point search takes no options; reading them refuses a robot it cannot plan for, so
    that ``cbr validate`` says so rather than the run that builds it."""

    def __attrs_post_init__(self) -> None:
        require_any_move("jump point search", f"{_KINEMATIC_SOLVERS} plan for it")


class JumpPointSearch(GridSolver):
    """The cheapest path by jump point search on a grid of equal costs without corner cutting;
    A* answers on other grids, and the solution's detail names the search that planned
    (``search``: ``jps`` or ``astar``)."""

    name = "jps"

    def detail(self, result: Any) -> dict[str, Any]:
        return {**super().detail(result), "search": result.search}


@attrs.frozen
class GeneticOptions:
    generations: int = option(
        50_000, "The most children made (one per generation of the steady-state algorithm).",
        validator=attrs.validators.ge(0))
    population: int = option(50, "Chromosomes in the population (at least 2).",
                             validator=attrs.validators.ge(2))
    mutation: float = option(
        1.0, "The probability that a child has one gene, selected at random, changed.",
        validator=attrs.validators.and_(attrs.validators.ge(0.0), attrs.validators.le(1.0)))
    distance: Literal["euclidean", "octile"] = option(
        "euclidean", "How far a chromosome's last cell is from the goal, the first criterion of "
        "its fitness.")
    seed: int | None = option(
        None, "The random seed of every query (an integer >= 0); null draws one per query from "
        "the run's seeded generator.",
        validator=attrs.validators.optional(attrs.validators.ge(0)))


    def __attrs_post_init__(self) -> None:
        require_any_move("the genetic algorithm", f"{_KINEMATIC_SOLVERS} plan for it")


class Genetic(GridSolver):
    """A path by the genetic algorithm of direction-coded chromosomes (not always the cheapest).

    Lexicographic fitness (distance of the last cell reached to the goal, then cost), binary
    tournaments, uniform crossover, one-gene mutation and replacement of the worst chromosome.
    Gives no solution when the best chromosome does not reach the goal.
    """

    name = "genetic"

    def __init__(self, options: GeneticOptions, ctx: Context) -> None:
        super().__init__(options, ctx)
        self.options = options

    def search_options(self, ctx: Context) -> dict[str, Any]:
        seed = self.query_seed(self.options.seed, ctx)
        return {"generations": self.options.generations, "population": self.options.population,
                "mutation": self.options.mutation, "distance": self.options.distance,
                "seed": seed}


@attrs.frozen
class RandomizedOptions:
    noise: float = option(
        1.0, "Each cell's cost factor is multiplied by a draw from [1, 1 + noise] per query; the "
        "path costs at most 1 + noise times the cheapest, and 0 gives the cheapest.",
        validator=attrs.validators.and_(attrs.validators.ge(0.0),
                                        attrs.validators.lt(float("inf"))))
    seed: int | None = option(
        None, "The random seed of every query (an integer >= 0); null draws one per query from "
        "the run's seeded generator.",
        validator=attrs.validators.optional(attrs.validators.ge(0)))


class Randomized(GridSolver):
    """A near-cheapest path that varies per query: A* on cost factors scaled by random noise.

    The probabilistic map-based search of Kruusmaa's case-based planner, which gives a
    different plausible path each time so the case base gains alternative routes. Each cell's
    factor is multiplied by its own draw from [1, 1 + noise]; the solution's cost is the path's
    true cost, at most 1 + noise times the cheapest.
    """

    name = "randomized"

    def __init__(self, options: RandomizedOptions, ctx: Context) -> None:
        super().__init__(options, ctx)
        self.options = options

    def search_options(self, ctx: Context) -> dict[str, Any]:
        return {"noise": self.options.noise, "seed": self.query_seed(self.options.seed, ctx)}
