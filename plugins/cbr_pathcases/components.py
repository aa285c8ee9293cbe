"""Retrieve, reuse and retain whole traversed paths (Kruusmaa & Svensson; Šeda & Dvořák §4).

Each phase hook runs once per query over the arrays of :mod:`cbr_pathcases.base`: retrieval
compares the query with every stored end point at once, retention compares the new path with
the stored paths the spatial index finds near it in one compiled call
(:meth:`cbr_pathcases.base.PathBase.hausdorff`). The reuser and the retainer warm up when the
engine is built (``cbr_warm``): each runs its compiled code once on a small grid of its own, so
that it is ready before the first query is timed.
"""

from __future__ import annotations

from typing import Any, Literal

import attrs
import numpy as np

from cbr_grid.costs import path_cost, path_length
from cbr_grid.distances import DistanceName, distance
from cbr_grid.drive import DriveReport
from cbr_grid.grid import Grid
from cbr_grid.planning import plan_with, planner_of, planner_problem
from cbr_grid.query import GridQuery, path_array, without_loops
from cbr_grid.risk import record_map
from cbr_kinematics import robot_kinematics
from cbr_pathcases.base import PATH, PathBase, base_of
from cbr_pathcases.cost import Combine, Measure, measure
from cbr_pathcases.selection import Rule, probabilities
from cbr_solvers import warm_grid
from cbrcore.casebase.memory import MemoryStore
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Case, Match, Outcome, Retrieval, Solution
from cbrcore.options import option, reference

_UNIT = attrs.validators.and_(attrs.validators.ge(0.0), attrs.validators.le(1.0))
_POSITIVE = attrs.validators.gt(0.0)

_WARM_PATH = np.array([[x, 1] for x in range(1, 7)] + [[6, y] for y in range(2, 7)])
"""A path of the warm-up grid (:func:`cbr_solvers.warm_grid`, 8 x 8 and free): along the top,
then down the right side."""


@attrs.frozen
class RetrieveOptions:
    delta: float = option(
        5.0, "The largest distance from the query's start (goal) to a stored path's start "
        "(goal), eq. (5); either direction of travel counts.", validator=attrs.validators.ge(0))
    distance: DistanceName = option(
        "euclidean", "The distance of eq. (5): euclidean (1), manhattan (2), octile (3) or "
        "chebyshev (9).")
    selection: Rule = option(
        "boltzmann", "How a candidate is chosen from its cost: boltzmann p ∝ exp(-(F - Fmin)/T), "
        "inverse p ∝ F^(-1/T), or greedy (the cheapest, eq. 5 as written).")
    temperature: float = option(
        0.1, "The selection's temperature T; lower prefers the cheap paths more.",
        validator=_POSITIVE)
    explore: float = option(
        0.1, "The probability of planning a new path with the fallback solver instead of "
        "reusing a stored one (asked only when there is a candidate).", validator=_UNIT)
    candidates: int = option(
        8, "How many candidates the retrieval hands on: the chosen one first, then the most "
        "probable; the reuser tries them in that order.", validator=attrs.validators.ge(1))


class PathRetriever:
    """Eq. (5)/(7): the stored paths with ends within delta of start and goal, one chosen with
    a probability falling with its cost; or none, to explore."""

    def __init__(self, options: RetrieveOptions, ctx: Context) -> None:
        self.options = options
        self.distance = distance(options.distance)
        self.rng = ctx.spawn_rng()
        base_of(ctx)

    @hookimpl
    def cbr_retrieve(self, problem: GridQuery, casebase: CaseStore, ctx: Context) -> Retrieval:
        base = base_of(ctx)
        grid: Grid = ctx.world
        start = np.asarray(grid.check_cell(problem.start, "start"))
        goal = np.asarray(grid.check_cell(problem.goal, "goal"))
        # drawn for every query, so that one query's draws never shift a later query's
        explore = self.rng.random() < self.options.explore
        delta = self.options.delta
        to_start, to_goal = self.distance(base.starts, start), self.distance(base.goals, goal)
        back_start, back_goal = self.distance(base.goals, start), self.distance(base.starts, goal)
        forward = (to_start <= delta) & (to_goal <= delta)
        backward = (back_start <= delta) & (back_goal <= delta)
        # a path that fits both ways is offered the way its ends lie nearer the query's: the
        # other way the reuser would drive it back to where the robot started
        reversed_ = backward & (~forward | (back_start + back_goal < to_start + to_goal))
        rows = np.flatnonzero(forward | backward)
        if not len(rows):
            return Retrieval((), reason=f"no stored path with both ends within delta {delta}")
        if explore:
            return Retrieval((), reason="exploring")
        p = probabilities(base.costs[rows], self.options.selection, self.options.temperature)
        chosen = int(self.rng.choice(len(rows), p=p))
        # the chosen first, then the rest by probability; ties (greedy's zeros, or a probability
        # too small to tell apart) by cost, then id
        rest = np.lexsort((base.ids[rows], base.costs[rows], -p))
        order = [chosen, *(i for i in rest.tolist() if i != chosen)][:self.options.candidates]
        matches = []
        for i in order:
            row = int(rows[i])
            reverse = bool(reversed_[row])
            path = base.paths[row][::-1] if reverse else base.paths[row]
            d_start = float(np.ravel(self.distance(path[0], start))[0])
            d_goal = float(np.ravel(self.distance(path[-1], goal))[0])
            case = Case({"start": path[0].tolist(), "goal": path[-1].tolist()}, path.tolist(),
                        kind=PATH, meta={"cost": float(base.costs[row])},
                        id=int(base.ids[row]), uses=int(base.uses[row]),
                        created=int(base.created[row]))
            matches.append(Match(case, 1.0 / (1.0 + d_start + d_goal), {
                "start_distance": d_start, "goal_distance": d_goal,
                "cost": float(base.costs[row]), "probability": float(p[i]),
                "reversed": float(reverse)}))
        return Retrieval(tuple(matches))


@attrs.frozen
class ReuseOptions:
    connector: str = reference(
        "solver", "astar", "The search that extends the retrieved path from the new start to "
        "its first cell and from its last cell to the new goal: astar, dijkstra, randomized "
        "(with noise) or genetic (with generations; as in Šeda & Dvořák), each seeded from "
        "the reuser's generator; or any other registered grid planner (the solver protocol), "
        "built with its default options.", fits=planner_problem)
    margin: int = option(
        5, "How far beyond the box around the two cells an extension may go, in cells.",
        validator=attrs.validators.ge(0))
    improve: Literal["none", "genetic"] = option(
        "none", "genetic: seed the genetic algorithm's population with the extended candidate "
        "paths and return its best path (Šeda & Dvořák's proposed combination); none returns "
        "the extended chosen path.")
    generations: int = option(
        2000, "The genetic algorithm's budget of children, as connector or improver.",
        validator=attrs.validators.ge(0))
    noise: float = option(
        1.0, "The randomised connector's cost noise (see the randomized solver).",
        validator=attrs.validators.ge(0.0))


_COMPILED_CONNECTORS = ("astar", "dijkstra", "randomized", "genetic")
"""The built-in searches the reuser calls directly with its own options and seeds, as it always
has; every other connector is a grid planner from the registry."""


class PathReuser:
    """Adaptation: extend the retrieved path to the new start and goal by a grid search."""

    def __init__(self, options: ReuseOptions, ctx: Context) -> None:
        from cbr_solvers import load_search  # numba loads with the first reuse

        robot = robot_kinematics(ctx, "reuse 'path_cases'")
        if robot is not None:
            raise CbrError(f"reuse 'path_cases' extends paths for robots that may make any "
                           f"move; the configuration's kinematics is {type(robot).__name__}, "
                           f"for which the case graph plans (reuse: casegraph)")
        self.options = options
        self.connect_search = None
        self.planner = None
        if options.connector in _COMPILED_CONNECTORS:
            self.connect_search = load_search(options.connector)
        else:
            self.planner = planner_of(options.connector, ctx, "reuse 'path_cases': connector")
        self.genetic = load_search("genetic") if options.improve == "genetic" else None
        self.rng = ctx.spawn_rng()
        base_of(ctx)

    def _search_options(self, name: str, seed: int | None = None) -> dict[str, Any]:
        """A search's keyword arguments; ``seed`` None draws one from the component's
        generator."""
        if seed is None:
            seed = int(self.rng.integers(2**32))
        if name == "genetic":
            return {"generations": self.options.generations, "seed": seed}
        if name == "randomized":
            return {"noise": self.options.noise, "seed": seed}
        return {}

    def _connect(self, grid: Grid, a: np.ndarray, b: np.ndarray,
                 seed: int | None = None) -> np.ndarray | None:
        """A path from cell ``a`` to cell ``b`` inside their box widened by the margin."""
        if (a == b).all():
            return a[None, :]
        m = self.options.margin
        window = (*(np.minimum(a, b) - m).tolist(), *(np.maximum(a, b) + m).tolist())
        start, goals = tuple(a.tolist()), np.array([b], dtype=np.int64)
        if self.planner is not None:
            found = plan_with(self.planner, grid, start, goals, window)
        else:
            found = self.connect_search(grid.factor, grid.passable, grid.corner_cutting, start,
                                        goals, window,
                                        **self._search_options(self.options.connector, seed))
        return None if found is None else found.path

    def _extend(self, grid: Grid, start: np.ndarray, goal: np.ndarray,
                path: np.ndarray) -> np.ndarray | None:
        head = self._connect(grid, start, path[0])
        tail = None if head is None else self._connect(grid, path[-1], goal)
        if head is None or tail is None:
            return None
        # an extension that runs back along the case leaves a loop: cut it
        return without_loops(np.concatenate((head, path[1:], tail[1:])))

    @hookimpl
    def cbr_warm(self, ctx: Context) -> None:
        """Connect, and improve with the genetic algorithm if configured, once on a small grid,
        with a fixed seed so that the component's generator is not drawn from."""
        grid = warm_grid(ctx.world, wall=False)
        path = self._connect(grid, _WARM_PATH[0], _WARM_PATH[-1], seed=0)
        if self.genetic is not None and path is not None:
            self.genetic(grid.factor, grid.passable, grid.corner_cutting,
                         tuple(_WARM_PATH[0].tolist()), [tuple(_WARM_PATH[-1].tolist())],
                         seed_paths=[path], **self._search_options("genetic", 0))

    @hookimpl
    def cbr_reuse(self, problem: GridQuery, retrieval: Retrieval, ctx: Context
                  ) -> Solution | None:
        grid: Grid = ctx.world
        start, goal = np.asarray(problem.start), np.asarray(problem.goal)
        extended: list[tuple[Match, np.ndarray]] = []
        for match in retrieval.matches:
            path = self._extend(grid, start, goal, path_array(match.case.solution))
            if path is not None:
                extended.append((match, path))
                if self.genetic is None:
                    break
        if not extended:
            return None
        match, path = extended[0]
        detail: dict[str, Any] = {"case": match.case.id,
                                  "probability": match.features.get("probability"),
                                  "reversed": bool(match.features.get("reversed"))}
        if self.genetic is not None:
            found = self.genetic(grid.factor, grid.passable, grid.corner_cutting,
                                 tuple(problem.start), [tuple(problem.goal)],
                                 seed_paths=[p for _, p in extended],
                                 **self._search_options("genetic"))
            if found is not None and found.cost < path_cost(grid, path):
                path = found.path
                detail["improved"] = True
        return Solution(path.tolist(), cost=path_cost(grid, path), cases=(match.case.id,),
                        detail=detail)


@attrs.frozen
class RetainOptions:
    threshold: float = option(
        2.0, "Paths within this Hausdorff distance are similar (eqs. 6, 8): a new path is kept "
        "only if no similar stored path costs as little, and replaces the costlier ones.",
        validator=attrs.validators.ge(0))
    hausdorff: Literal["symmetric", "directed"] = option(
        "symmetric", "symmetric: max(D(new, old), D(old, new)); directed: D(new, old) as "
        "written in eq. (6), so a new path lying along a longer stored one is similar to it.")
    distance: DistanceName = option(
        "euclidean", "The cell distance inside the Hausdorff distance: euclidean (1, "
        "Kruusmaa's), manhattan (2), octile (3) or chebyshev (9).")
    combine: Combine = option(
        "ratio", "The cost F(l, r, g): ratio (l + w·r) / g, or sum l + w·r (see "
        "cbr_pathcases.cost).")
    risk_weight: float = option(
        1.0, "The weight w of the risk r in the cost.", validator=attrs.validators.ge(0.0))
    experience: Literal["mean", "last"] = option(
        "mean", "A stored path's cost after another traversal (reused, or its very cells "
        "planned and driven again): the mean of all its traversals' costs, or the last one's.")


class PathRetainer:
    """Eqs. (6)/(8): store a traversed path unless a similar one costs no more; learn the cost
    of the path that was reused, or driven again."""

    def __init__(self, options: RetainOptions, ctx: Context) -> None:
        self.options = options
        base_of(ctx)

    def measures(self, grid: Grid, driven: np.ndarray, path: np.ndarray,
                 outcome: Outcome) -> tuple[Measure, Measure]:
        """What the trip cost, and what following ``path`` costs.

        ``driven`` is what the robot drove, ``path`` the same with its loops cut: the path kept.
        The trip is charged its whole length and all the time lost (the outcome's
        ``travel_time`` less the driven length, from its drive report); ``path`` only the time
        lost at the stops made on its cells (the report's ``stops``), shared equally among the
        stops: a dead end the robot walked into, met an obstacle in and left is cut from the
        path and so is its stop. Without a drive report nothing was lost.
        """
        report = outcome.report if isinstance(outcome.report, DriveReport) else None
        lost = 0.0 if report is None else max(report.travel_time - path_length(driven), 0.0)
        stops = () if report is None else report.stops
        kept = lost
        if stops:
            cells = {(int(x), int(y)) for x, y in path.tolist()}
            kept = lost * sum((int(x), int(y)) in cells for x, y in stops) / len(stops)
        trip = measure(grid, driven, lost)
        if len(path) == len(driven) and kept == lost:
            # no loop was cut (a cut drops cells) and all the time lost stays: the same measure
            return trip, trip
        return trip, measure(grid, path, kept, trip.ideal)

    def _traversed(self, base: PathBase, case_id: int, cost: float) -> None:
        """Fold one more traversal of cost ``cost`` into the cost of case ``case_id``."""
        row = int(base.rows([case_id])[0])
        n = int(base.traversals[row]) + 1
        old = float(base.costs[row])
        new = old + (cost - old) / n if self.options.experience == "mean" else cost
        base.set_cost(case_id, new, n)

    @hookimpl
    def cbr_warm(self, ctx: Context) -> None:
        """Retain a path twice into a case base of its own on a small grid: the second time
        compares it with a stored path, as every later retain does."""
        scratch = Context(registry=ctx.registry, seed=ctx.seed,
                          world=warm_grid(ctx.world, wall=False), casebase=MemoryStore())
        for path in (_WARM_PATH, _WARM_PATH[:-1]):
            with scratch.mirror.transaction():
                self.retain(Solution(path.tolist()), Outcome(success=True), scratch)

    @hookimpl
    def cbr_retain(self, solution: Solution, outcome: Outcome, ctx: Context) -> None:
        self.retain(solution, outcome, ctx)

    def retain(self, solution: Solution, outcome: Outcome, ctx: Context) -> None:
        """Learn from the driven ``solution`` into the path base of ``ctx``."""
        base = base_of(ctx)
        grid: Grid = ctx.world
        reused = base.ids[base.rows(solution.cases)].tolist()
        base.refresh(reused)  # the engine has just counted their use
        if not outcome.success:
            # a path that led the robot into a failed trip is not worth following again
            base.remove(reused)
            return
        driven = path_array(solution.value)
        path = without_loops(driven)
        if len(path) < 2:
            return
        trip, measured = self.measures(grid, driven, path, outcome)
        # the case that was reused led the robot along the whole trip
        for case_id in reused:
            self._traversed(base, case_id, trip.cost(self.options.combine,
                                                     self.options.risk_weight))
        cost = measured.cost(self.options.combine, self.options.risk_weight)
        threshold = self.options.threshold
        # the stored paths that can be within the threshold; all others are farther
        rows, forward, backward = base.hausdorff(
            path, distance=self.options.distance, limit=threshold,
            symmetric=self.options.hausdorff == "symmetric")
        same = rows[np.maximum(forward, backward) == 0]
        if len(same):
            # the very cells of a stored path, driven again (reused or planned anew, in either
            # direction): one more traversal of that case, not a new case
            for case_id in base.ids[same].tolist():
                if case_id not in reused:
                    self._traversed(base, case_id, cost)
                    base.touch([case_id])
            return
        apart = forward if self.options.hausdorff == "directed" else np.maximum(forward, backward)
        similar = rows[apart <= threshold]
        if len(similar) and base.costs[similar].min() <= cost:
            # a duplicate: not stored twice, the best similar path's use count grows instead
            best = int(base.ids[similar[np.argmin(base.costs[similar])]])
            if best not in reused:
                base.touch([best])
            return
        base.remove(base.ids[similar].tolist())
        record_map(base.store, grid)
        base.add(path, {"cost": cost, "length": measured.length, "risk": measured.risk,
                        "ideal": measured.ideal, "traversals": 1})
