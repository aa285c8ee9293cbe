"""The case graph's components: retrieve, reuse, retain and three forgetting strategies.

Every component works on the run's one graph (:mod:`cbr_casegraph.state`); each phase hook is
called once per query and hands the work to the vectorised or compiled code of
:mod:`cbr_casegraph.graph` and :mod:`cbr_casegraph.planner`. The retriever, the reuser and the
retainer warm up when the engine is built (``cbr_warm``): each runs its phase once on a small
graph of its own, so that the compiled code is ready before the first query is timed.
"""

from __future__ import annotations

import functools
import importlib
import math
from types import ModuleType
from typing import TYPE_CHECKING, Literal

import attrs
import numpy as np

from cbr_casegraph.cases import SEGMENT
from cbr_casegraph.payoff import SOLVER_CHEAPER, Learned, PassableCells, Payoff, band
from cbr_casegraph.recording import clear_reuse, record_reuse
from cbr_casegraph.state import graph_of
from cbr_grid.costs import uniform_factor
from cbr_grid.distances import DistanceName
from cbr_grid.grid import UNIFORM_FACTOR_CELLS, grid_world
from cbr_grid.planning import plan_with, planner_of, planner_problem
from cbr_grid.query import Cell, GridQuery
from cbr_grid.risk import record_map
from cbr_kinematics import HOLONOMIC, robot_kinematics
from cbr_solvers import warm_grid
from cbrcore.casebase.memory import MemoryStore
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Case, Match, Outcome, Proposal, Retrieval, Solution
from cbrcore.options import configured, option, reference

if TYPE_CHECKING:
    from cbr_casegraph.planner import Neighbourhoods, Settings

_POSITIVE = attrs.validators.ge(1)
_UNIT = attrs.validators.and_(attrs.validators.ge(0.0), attrs.validators.le(1.0))


def _planner() -> ModuleType:
    """The planner module; it loads numba, so only when a query is planned, not at every
    start of ``cbr``."""
    return importlib.import_module("cbr_casegraph.planner")


_WARM_SIZE = 24
_WARM_PATH = [(x, 2) for x in range(2, 21)] + [(20, y) for y in range(3, 21)]
"""The path learned on the warm-up grid: along the top, then down the right side."""
_WARM_QUERY = GridQuery((3, 4), (18, 19))
"""A query whose start and goal lie near the ends of the warm-up path."""
_UNIFORM_WARM_SIZE = math.isqrt(UNIFORM_FACTOR_CELLS) + 1
"""The side of the smallest square grid that holds a shared cost factor once."""


def _warm_context(ctx: Context, *, learned: bool = True) -> Context:
    """A context of its own for a warm-up: a small free grid with the world's corner rule and
    cost model, and a memory case base holding a case graph of one learned path (or none). The
    run's case base, graph, stash and generator stay as they were.

    A world that holds its cost factor once (:data:`cbr_grid.grid.UNIFORM_FACTOR_CELLS`) gets a
    warm-up grid just large enough to hold it once too: the kernels are compiled for the layout
    of the factor they will read, not during the first query."""
    world = grid_world(ctx, "the case graph")
    size = _WARM_SIZE if uniform_factor(world.factor) is None else _UNIFORM_WARM_SIZE
    grid = warm_grid(world, size, wall=False)
    scratch = Context(registry=ctx.registry, seed=ctx.seed, world=grid, casebase=MemoryStore())
    if learned:
        with scratch.mirror.transaction():
            graph_of(scratch).add_path(_WARM_PATH)
    return scratch


@attrs.frozen
class RetrieveOptions:
    delta: int = option(10, "Radius of the neighbourhoods N(start, delta) and N(goal, delta) in "
                        "the Chebyshev distance (eqs. 9-10), in cells.", validator=_POSITIVE)
    selective: bool = option(
        False, "Selective adaptation: use only the cases with an end point within 3·delta of "
        "the start (goal); full adaptation (false) uses every case meeting the neighbourhood.")
    payoff: Literal["always", "learned"] = option(
        "always", "Which queries the case graph is tried on: always (the papers' hybrid), or "
        "learned: per query, from what CBR and the solver took on the queries of about the "
        "same distance already planned on this map (cbr_casegraph.payoff.Learned); a query "
        "left to the solver is counted under the reason 'the solver is cheaper here: "
        "measured at this distance on this map'. The fixed thresholds below apply first.")
    min_cells: int = option(
        0, "Try the case graph only on a map with at least this many passable cells; on a "
        "smaller map A* settles so few cells that it is cheaper than a CBR query, and the "
        "query is left to the solver with the reason 'A* is cheaper here: the map is small'. "
        "0 tries every map.",
        validator=attrs.validators.ge(0))
    min_distance: int = option(
        0, "Try the case graph only when start and goal are at least this far apart "
        "(Chebyshev distance, in cells); nearer, A* is cheaper and plans the query (reason "
        "'A* is cheaper here: start and goal are near'). 0 tries every query.",
        validator=attrs.validators.ge(0))


@attrs.frozen
class Found:
    """What the retriever hands the reuser (``Retrieval.payload``): the neighbourhoods of start
    and goal, and the settings they were found with."""

    settings: Settings
    neighbourhoods: Neighbourhoods


class CaseGraphRetriever:
    """The cases meeting the neighbourhoods of start and goal (eq. 11)."""

    def __init__(self, options: RetrieveOptions, ctx: Context) -> None:
        self.options = options
        self.payoff = Payoff(options.min_cells, options.min_distance)
        self.cells = PassableCells()
        self.learned = Learned() if options.payoff == "learned" else None
        self.pending: Pending | None = None
        graph_of(ctx)

    @hookimpl
    def cbr_warm(self, ctx: Context) -> None:
        """Retrieve once from a small graph of its own."""
        scratch = _warm_context(ctx)
        self.retrieve(_WARM_QUERY, scratch, decide=False)

    @hookimpl
    def cbr_retrieve(self, problem: GridQuery, casebase: CaseStore, ctx: Context) -> Retrieval:
        clear_reuse(ctx)
        return self.retrieve(problem, ctx)

    def retrieve(self, problem: GridQuery, ctx: Context, *, decide: bool = True) -> Retrieval:
        """The retrieval of ``problem`` from the case graph of ``ctx``; without ``decide``, the
        learned choice is neither asked nor taught (a warm-up query)."""
        learned = self.learned if decide else None
        if learned is not None:
            self.learn_previous(learned, ctx)
        planner = _planner()
        graph = graph_of(ctx)
        settings = planner.Settings(delta=self.options.delta, selective=self.options.selective)
        start, goal = ctx.world.check_cell(problem.start, "start"), ctx.world.check_cell(
            problem.goal, "goal")
        # the map's cells are counted only when the threshold asks (once per map it is given)
        cells = self.cells.of(ctx.world) if self.payoff.min_cells else 0
        cheaper = self.payoff.reason(cells, start, goal)
        if cheaper is not None:
            return Retrieval((), reason=cheaper)
        if learned is not None and not self.learned_tries(learned, start, goal, ctx):
            return Retrieval((), reason=SOLVER_CHEAPER)
        found = planner.neighbourhoods(graph, start, goal, settings)
        if isinstance(found, planner.Failure):
            return Retrieval((), reason=found.reason)
        matches = []
        for end, cell, edges in (("start", start, found.start), ("goal", goal, found.goal)):
            a, b = graph.ends(edges)
            # the Chebyshev distance from the terminal to the nearest cell of the segment
            near = segment_distance(a, b, np.asarray(cell))
            records = zip(edges.tolist(), a.tolist(), b.tolist(), graph.costs(edges).tolist(),
                          graph.risks(edges).tolist(), graph.uses(edges).tolist(),
                          graph.created(edges).tolist(), near.tolist(), strict=True)
            for edge, pa, pb, cost, risk, uses, created, d in records:
                case = Case({"a": pa, "b": pb}, {"cost": cost, "risk": risk}, kind=SEGMENT,
                            id=edge, uses=uses, created=created)
                matches.append(Match(case, 1.0 / (1.0 + d), {f"{end}_distance": float(d)}))
        matches.sort(key=lambda m: -m.similarity)
        return Retrieval(tuple(matches), payload=Found(settings, found))

    def learn_previous(self, learned: Learned, ctx: Context) -> None:
        """Teach the learned choice what the query it decided last took: the phases' times of
        the engine's proposal for it (``ctx.previous``)."""
        pending, self.pending = self.pending, None
        # a query whose proposal never came (its solve raised) teaches nothing
        if pending is not None and ctx.previous is not None and ctx.previous is not pending.seen:
            learned.learn(pending.band, pending.tried, ctx.previous)

    def learned_tries(self, learned: Learned, start: Cell, goal: Cell, ctx: Context) -> bool:
        """The learned choice for this query; it learns what the query took at the next."""
        which = band(start, goal)
        tried = learned.tries(which)
        self.pending = Pending(which, tried, ctx.previous)
        return tried


@attrs.frozen
class Pending:
    """A query the learned choice decided, until the engine's proposal for it is known."""

    band: int
    tried: bool
    seen: Proposal | None
    """The context's previous proposal when the query was decided: the one before it."""


def segment_distance(a: np.ndarray, b: np.ndarray, cell: np.ndarray) -> np.ndarray:
    """Chebyshev distance from ``cell`` to the nearest cell of each straight segment a-b."""
    d = np.sign(b - a)
    k = np.abs(b - a).max(axis=1)
    # the best position along a straight 8-direction run is the clamped projection
    denom = np.maximum((d * d).sum(axis=1), 1)
    t = np.clip(np.rint(((cell - a) * d).sum(axis=1) / denom), 0, k)
    best = np.abs(a + t[:, None] * d - cell).max(axis=1)
    for shift in (-1, 1):  # the rounding can miss by one step on diagonal runs
        u = np.clip(t + shift, 0, k)
        best = np.minimum(best, np.abs(a + u[:, None] * d - cell).max(axis=1))
    return best


@attrs.frozen
class ReuseOptions:
    connector: str = reference(
        "solver", "dijkstra", "The local search that makes the temporary edges from start and "
        "goal to the nearest cells of the cases: dijkstra, one sweep serving every case, the "
        "whole query compiled; astar, jps and genetic (seed 0) search once per case, as does "
        "any other registered grid planner (the solver protocol), built with its default "
        "options.", fits=planner_problem)
    margin: int | None = option(
        None, "How far beyond N(., delta) the local search may go, in cells (default delta // 2).",
        validator=attrs.validators.optional(attrs.validators.ge(0)))
    graph_search: Literal["dijkstra", "astar"] = option(
        "astar", "The search for the best path in the extended case graph (step 6); both find "
        "the cheapest path, astar settling fewer vertices by its octile and landmark bounds.")

    @connector.validator
    def _swept(self, attribute: attrs.Attribute, value: str) -> None:
        robot = configured("kinematics")
        check_connector(value, None if robot in (None, HOLONOMIC) else robot)


def check_connector(connector: str, robot: str | None) -> None:
    """The reuser's rule for a robot with kinematic constraints (``robot`` names its model; None
    for one that allows every turn): its temporary edges come from edge-based Dijkstra sweeps,
    so the connector must be dijkstra. ValueError otherwise."""
    if robot is not None and connector != "dijkstra":
        raise ValueError(f"kinematics {robot!r} makes the temporary edges by edge-based "
                         f"Dijkstra sweeps: connector must be dijkstra, not {connector!r}")


_COMPILED_CONNECTORS = ("astar", "jps", "genetic")
"""The built-in searches the reuser calls directly, as it always has (the genetic algorithm
with seed 0); every other connector but dijkstra is a grid planner from the registry."""


class CaseGraphReuser:
    """Adaptation: temporary edges to the retrieved cases, then the best path in the graph."""

    def __init__(self, options: ReuseOptions, ctx: Context) -> None:
        self.options = options
        self.search = None
        self.kinematics = robot_kinematics(ctx, "reuse 'casegraph'")
        if self.kinematics is not None:
            # the robot of a context built in code: no configuration reading checked it
            try:
                check_connector(options.connector, type(self.kinematics).__name__)
            except ValueError as exc:
                raise CbrError(f"reuse 'casegraph': {exc}") from None
        if options.connector in _COMPILED_CONNECTORS:
            from cbr_solvers import load_search

            self.search = _planner().searched(load_search(options.connector))
        elif options.connector != "dijkstra":
            planner = planner_of(options.connector, ctx, "reuse 'casegraph': connector")
            self.search = functools.partial(plan_with, planner)
        graph_of(ctx)

    @hookimpl
    def cbr_warm(self, ctx: Context) -> None:
        """Adapt once on a small graph of its own, from what the default retriever finds."""
        scratch = _warm_context(ctx)
        retrieval = CaseGraphRetriever(RetrieveOptions(), scratch).retrieve(_WARM_QUERY, scratch)
        if retrieval.usable:
            self.reuse(_WARM_QUERY, retrieval, scratch)

    @hookimpl
    def cbr_reuse(self, problem: GridQuery, retrieval: Retrieval, ctx: Context
                  ) -> Solution | None:
        return self.reuse(problem, retrieval, ctx)

    def reuse(self, problem: GridQuery, retrieval: Retrieval, ctx: Context) -> Solution | None:
        """The path adapted from ``retrieval`` in the case graph of ``ctx``, or None."""
        planner = _planner()
        found: Found = retrieval.payload
        settings = attrs.evolve(found.settings, connector=self.options.connector,
                                margin=self.options.margin,
                                graph_search=self.options.graph_search)
        graph = graph_of(ctx)
        start, goal = tuple(problem.start), tuple(problem.goal)
        if self.kinematics is None:
            result = planner.adapt(graph, start, goal, found.neighbourhoods, settings,
                                   self.search)
        else:
            from cbr_casegraph import kinematic

            result = kinematic.adapt(graph, start, goal, found.neighbourhoods, settings,
                                     self.kinematics, problem.heading, problem.final_heading)
        if isinstance(result, planner.Failure):
            return None
        record_reuse(ctx, graph, result.edges)
        return Solution(result.path.tolist(), cost=result.cost, cases=result.edges,
                        detail=result.detail)


@attrs.frozen
class RetainOptions:
    similarity_delta: int = option(
        0, "Skip a new segment when a stored one has its ends within this distance of its "
        "ends (eq. 12); 0 skips only a segment with the very ends of a stored one.",
        validator=attrs.validators.ge(0))
    distance: DistanceName = option("chebyshev", "The distance of eq. (12).")


class CaseGraphRetainer:
    """Retain a traversed path segment by segment; keep segment costs on the learned map."""

    def __init__(self, options: RetainOptions, ctx: Context) -> None:
        self.options = options
        graph_of(ctx)

    @hookimpl
    def cbr_warm(self, ctx: Context) -> None:
        """Retain one path into a small, empty graph of its own."""
        scratch = _warm_context(ctx, learned=False)
        with scratch.mirror.transaction():
            self.retain(Solution(_WARM_PATH), Outcome(success=True), scratch)

    @hookimpl
    def cbr_retain(self, solution: Solution, outcome: Outcome, ctx: Context) -> None:
        self.retain(solution, outcome, ctx)

    def retain(self, solution: Solution, outcome: Outcome, ctx: Context) -> None:
        """Record the use of the solution's segments and keep the path of a successful trip."""
        graph = graph_of(ctx)
        graph.record_use(solution.cases)
        if outcome.success and len(solution.value) > 1:
            added = graph.add_path(solution.value, similarity_delta=self.options.similarity_delta,
                                   distance=self.options.distance)
            if added and graph.store is not None:
                record_map(graph.store, graph.grid)


class RedundantVertices:
    """Maintenance: delete vertices lying in the middle of a straight edge."""

    def __init__(self, options: object, ctx: Context) -> None:
        graph_of(ctx)

    @hookimpl
    def cbr_forget(self, ctx: Context) -> None:
        graph_of(ctx).merge_redundant()


@attrs.frozen
class RiskyOptions:
    max_risk: float = option(
        0.5, "Forget the segments whose mean cell risk reaches this value, and those crossing "
        "an obstacle of the current map.", validator=_UNIT)


class RiskySegments:
    """Forgetting the worst cases: the most risky segments."""

    def __init__(self, options: RiskyOptions, ctx: Context) -> None:
        self.options = options
        graph_of(ctx)

    @hookimpl
    def cbr_forget(self, ctx: Context) -> None:
        graph = graph_of(ctx)
        edges = graph.edge_ids()
        worst = edges[(graph.risks(edges) >= self.options.max_risk)
                      | ~np.isfinite(graph.costs(edges))]
        if len(worst):
            graph.remove(worst)


@attrs.frozen
class LimitOptions:
    max_coverage: float = option(
        0.15, "The most vertices kept, as a share of the map's cells.", validator=_UNIT)


class VertexLimit:
    """A vertex limit per map size: forget the worst segments until the graph fits it.

    Worst first: the highest mean risk, then the fewest uses, then the oldest.
    """

    def __init__(self, options: LimitOptions, ctx: Context) -> None:
        self.options = options
        graph_of(ctx)

    @hookimpl
    def cbr_forget(self, ctx: Context) -> None:
        graph = graph_of(ctx)
        limit = int(self.options.max_coverage * graph.grid.risk.size)
        if graph.vertex_count <= limit:
            return
        edges = graph.edge_ids()
        order = np.lexsort((graph.created(edges), graph.uses(edges), -graph.risks(edges)))
        for start in range(0, len(order), 16):
            graph.remove(edges[order[start:start + 16]])
            if graph.vertex_count <= limit:
                break
