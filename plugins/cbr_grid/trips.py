"""A simulated robot driving trips on a world that may differ from its map.

The configured world is the robot's *private map*. The *true world* the robot drives on is that
map as configured plus obstacles the map does not show: ``unknown_static`` cells that are always
blocked, ``unknown_dynamic`` sites, each blocked during a trip with probability ``appear``, and
the listed ``sites``: named places (a door of one or more cells, a corridor) blocked during a
trip, all their cells together, with their own probability. The random cells are drawn once,
uniformly and without repetition, from the cells free in the configured map that are neither a
listed site's nor a fixed place's, from a generator derived from the run's seed, so a seed
repeats the same true world (also in a later run that continues a case base). Trips go between
random free cells, or between the configured ``places``, and never start or end on an unknown
obstacle or a site.

Each time an obstacle stops the robot it loses ``collision_time`` (stopping, sensing,
replanning) besides the length it drives: the outcome's ``travel_time`` adds both up, in the time
of one straight step. Meeting one cell of a listed site, the robot sees the whole site: a shut
door is shut across its width.

Reading of the paper (sections 4.1 and 4.5): when the robot meets an obstacle in a cell, the
cell's risk in its map rises by ``hit_risk`` (capped at 1, an obstacle), so an obstacle met again
and again becomes one for later planning; a cell passed safely loses ``pass_relief`` of its risk
(floored at 0). The workload replaces ``ctx.world`` with the updated map after every trip, so all
later planning of the run uses what the robot learned; the ``risk_map`` retainer keeps it in the
case base for later runs, and the ``path_quality`` metric rates proposals on the map they were
planned on.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import attrs
import numpy as np

from cbr_grid.costs import path_cost, path_length, turns
from cbr_grid.directions import of_steps
from cbr_grid.grid import Grid
from cbr_grid.query import GridQuery, path_array
from cbr_kinematics import kinematics_of
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Outcome, Proposal, Solution
from cbrcore.options import option

LEARNED_RISK = "grid.learned_risk"
"""Case base meta key of the risks the robot learned: ``{"x,y": risk}``."""

CONFIGURED_WORLD = "cbr_grid.configured_world"
"""``ctx.shared`` key of the world as configured, before learned risks were applied to it."""

PLANNED_WORLD = "cbr_grid.planned_world"
"""``ctx.shared`` key of the map the last executed proposal was planned on."""

_DECIMALS = 12
"""Learned risks are rounded so that rises and reliefs that cancel out return exactly."""

_UNIT = attrs.validators.and_(attrs.validators.instance_of(float), attrs.validators.ge(0.0),
                              attrs.validators.le(1.0))
_COUNT = attrs.validators.and_(attrs.validators.instance_of(int), attrs.validators.ge(0))


def _grid_world(ctx: Context, what: str) -> Grid:
    if not isinstance(ctx.world, Grid):
        raise CbrError(f"{what} needs a grid world; the configured world is "
                       f"{type(ctx.world).__name__}")
    return ctx.world


def _configured_world(ctx: Context, what: str) -> Grid:
    """The world as configured, even after ``risk_map`` applied learned risks to ``ctx.world``."""
    grid = ctx.shared.get(CONFIGURED_WORLD)
    return grid if isinstance(grid, Grid) else _grid_world(ctx, what)


def _astar(grid: Grid, passable: np.ndarray, start: tuple[int, int], goals: np.ndarray,
           window: tuple[int, int, int, int] | None = None) -> np.ndarray | None:
    # imported here: numba loads with the first search, not with every start of ``cbr``
    from cbr_solvers.search import astar

    found = astar(grid.factor, passable, grid.corner_cutting, start, goals, window)
    return None if found is None else found.path


def _some_cells(_: object, attribute: attrs.Attribute, value: list[tuple[int, int]]) -> None:
    if not value:
        raise ValueError(f"'{attribute.name}' must hold at least one cell (x, y), got {value!r}")


@attrs.frozen
class Site:
    """A named place of the true world where an obstacle missing from the map may appear.

    All its ``cells`` are blocked together (a door is its cells), during a trip with probability
    ``appear``.
    """

    cells: list[tuple[int, int]] = option(
        doc="The (x, y) cells blocked together, each free in the configured map.",
        validator=_some_cells)
    appear: float = option(
        doc="The probability that the site is blocked during one trip.", validator=_UNIT)


@attrs.frozen
class TripsOptions:
    count: int = option(1000, "How many trips.", validator=_COUNT)
    unknown_static: int = option(
        0, "Obstacles of the true world missing from the robot's map, always present.",
        validator=_COUNT)
    unknown_dynamic: int = option(
        0, "Sites of the true world where an obstacle missing from the map may appear.",
        validator=_COUNT)
    appear: float = option(
        0.5, "The probability that a dynamic site is blocked during one trip.", validator=_UNIT)
    hit_risk: float = option(
        0.5, "Risk added to a cell where the robot met an obstacle (capped at 1, an obstacle).",
        validator=_UNIT)
    pass_relief: float = option(
        0.05, "Risk removed from each cell the robot passed safely (floored at 0).",
        validator=_UNIT)
    replan_window: int = option(
        8, "Chebyshev radius of the box around the robot that a local replan stays in.",
        validator=attrs.validators.and_(attrs.validators.instance_of(int),
                                        attrs.validators.ge(1)))
    min_distance: int = option(
        1, "The least Chebyshev distance between the start and the goal of a trip.",
        validator=attrs.validators.and_(attrs.validators.instance_of(int),
                                        attrs.validators.ge(1)))
    places: list[tuple[int, int]] | None = option(
        None, "Fixed places (x, y) the trips go between: each trip's start and goal are two "
        "different places drawn uniformly (seeded), whatever min_distance says; null draws "
        "random free cells. At least 2 distinct places, each free in the map and on no site.")
    sites: list[Site] = option(
        doc="Named places where an obstacle missing from the map appears during a trip with its "
        "own probability, all its cells together: a door that is often shut, a crowded "
        "corridor. Each a mapping {cells: [[x, y], ...], appear: probability}; the cells are "
        "free in the map and are neither another site's nor a random unknown obstacle's.",
        factory=list)
    collision_time: float = option(
        5.0, "Time lost each time an obstacle stops the robot (stopping, sensing, replanning), "
        "in the time of one straight step; it adds to the outcome's travel_time.",
        validator=attrs.validators.and_(attrs.validators.instance_of(float),
                                        attrs.validators.ge(0.0), attrs.validators.lt(np.inf)))
    headings: bool = option(
        False, "Give each trip a random initial heading, the direction the robot faces at the "
        "start, for planners of a constrained kinematic model; drawn apart, so the trips and "
        "worlds stay those of the same seed without headings.")
    kinematics: str = option(
        "holonomic", "The robot's kinematic model (a registered kinematics component) when it "
        "replans around an obstacle it met: a constrained one replans with the modified A* of "
        "section 5 straight to the goal, from the direction it was moving in, so the path "
        "driven is one it can drive.")
    seed: int | None = option(
        None, "The seed of the true world's random obstacles, the trips and the obstacles' "
        "presence; null derives one from the run's seed. Give two configurations the same seed "
        "to drive them on the same trips in the same worlds whatever their other components.",
        validator=attrs.validators.optional(attrs.validators.ge(0)))


@attrs.frozen
class _Drive:
    """What happened on one trip: the cells driven, the cells met and where the robot stood
    each time an obstacle stopped it (and it replanned)."""

    driven: np.ndarray
    met: list[tuple[int, int]]
    stops: list[tuple[int, int]]
    reached: bool
    reason: str


class Trips:
    """Trips driven by a simulated robot on a true world that may hold unknown obstacles.

    The configured world is the robot's map; the true world adds ``unknown_static`` obstacles,
    ``unknown_dynamic`` sites (each blocked per trip with probability ``appear``) and the listed
    ``sites`` (each blocked per trip, all its cells together, with its own probability) on cells
    free in that map, the random ones placed uniformly from the run's seed. Each trip goes
    between two random cells free in the current map and holding no unknown obstacle or site,
    or between two different ``places``. The robot follows the proposed path;
    when its next step is blocked it raises the blocked cell's risk by ``hit_risk``, replans
    locally (A* inside a box of radius ``replan_window`` to the nearest remaining path cell
    beyond the obstacle, on its map with the cells met on this trip blocked), else globally to
    the goal, else the trip fails (as it does after 4 steps per map cell); a robot of a
    constrained ``kinematics`` replans to the goal by the modified A*, from the direction it was
    moving in. Cells passed safely
    lose ``pass_relief`` of their risk. The updated map replaces the run's world after every
    trip. Outcome detail: ``encounters`` (obstacle cells met), ``replans``, ``stops`` (the
    [x, y] cell where the robot stood at each replan), ``risk_changes``
    ([x, y, new risk] per changed cell), ``present`` (the dynamic sites blocked on the trip),
    ``sites_present`` (the indexes of the listed sites blocked on the trip) and ``travel_time``
    (the driven path's length plus ``collision_time`` per replan, that is per stop).
    """

    def __init__(self, options: TripsOptions, ctx: Context) -> None:
        self.options = options
        self.kinematics = kinematics_of(options.kinematics, ctx, "workload 'trips'")
        self.configured = _configured_world(ctx, "workload 'trips'")
        self.places: np.ndarray | None = self._checked_places(options.places)
        """The (k, 2) cells trips go between, or None for random free cells."""
        # the random unknowns keep off the listed sites and the places, so they cannot collide
        pool = self.configured.passable.copy()
        for cells in self._site_cells(options.sites):
            pool[cells[:, 1], cells[:, 0]] = False
        if self.places is not None:
            pool[self.places[:, 1], self.places[:, 0]] = False
        free = np.flatnonzero(pool)
        unknown = options.unknown_static + options.unknown_dynamic
        # with places the trips need no free cell of their own
        spare = 0 if self.places is not None else 2
        if unknown + spare > len(free):
            raise CbrError(f"workload 'trips': {options.unknown_static} unknown_static + "
                           f"{options.unknown_dynamic} unknown_dynamic obstacles leave fewer than "
                           f"{spare} of the map's {len(free)} free cells that are no site or "
                           f"place for trips")
        own = ctx.spawn_rng() if options.seed is None else np.random.default_rng(options.seed)
        # spawned children depend only on their index: a fourth leaves the first three as they were
        placement, self._query_rng, self._presence_rng, self._heading_rng = own.spawn(4)
        chosen = placement.choice(free, size=unknown, replace=False)
        width = self.configured.width
        cells = np.column_stack((chosen % width, chosen // width))
        self.place(cells[:options.unknown_static], cells[options.unknown_static:], options.sites)

    def _checked_places(self, places: Sequence[tuple[int, int]] | None) -> np.ndarray | None:
        """The configured places as a (k, 2) array; a CbrError unless they are at least 2
        distinct cells free in the configured map."""
        if places is None:
            return None
        seen: set[tuple[int, int]] = set()
        for i, cell in enumerate(places):
            xy = self.configured.check_cell(cell, f"workload 'trips': places[{i}]")
            if xy in seen:
                raise CbrError(f"workload 'trips': places[{i}] {xy} repeats an earlier place; "
                               f"expected distinct cells")
            seen.add(xy)
        if len(seen) < 2:
            raise CbrError(f"workload 'trips': places must hold at least 2 distinct cells for a "
                           f"trip's start and goal, got {len(seen)}")
        return path_array(places)

    def _site_cells(self, sites: Sequence[Site]) -> list[np.ndarray]:
        """The (k, 2) cells of each site; a CbrError naming the site and the cell unless each is
        free in the configured map."""
        groups = [path_array(site.cells) for site in sites]
        for i, cells in enumerate(groups):
            for x, y in cells.tolist():
                self.configured.check_cell((x, y), f"workload 'trips': sites[{i}] cell")
        return groups

    def place(self, static: object, dynamic: object, sites: Sequence[Site] = ()) -> None:
        """Put the true world's unknown obstacles on the given (x, y) cells, replacing all of
        them, the drawn ones and the configured ``sites`` alike: ``static`` always blocked,
        ``dynamic`` each blocked per trip with probability ``appear`` and each of ``sites``
        blocked per trip, all its cells together, with its own probability. Every cell must be
        free in the configured map, distinct from all the others and no place trips go between.
        """
        static_cells, dynamic_cells = path_array(static), path_array(dynamic)
        grid = self.configured
        for x, y in np.concatenate((static_cells, dynamic_cells)).tolist():
            grid.check_cell((x, y), "an unknown obstacle")
        site_cells = self._site_cells(sites)
        cells = np.concatenate((static_cells, dynamic_cells, *site_cells))
        unique, counts = np.unique(cells, axis=0, return_counts=True)
        if (counts > 1).any():
            twice = tuple(unique[np.argmax(counts > 1)].tolist())
            raise CbrError(f"workload 'trips': cell {twice} holds two unknown obstacles or "
                           f"sites; expected distinct cells")
        unknown = np.zeros(grid.passable.shape, dtype=bool)
        unknown[cells[:, 1], cells[:, 0]] = True
        if self.places is not None:
            taken = unknown[self.places[:, 1], self.places[:, 0]]
            if taken.any():
                i = int(np.argmax(taken))
                raise CbrError(f"workload 'trips': places[{i}] {tuple(self.places[i].tolist())} "
                               f"is on an unknown obstacle or a site; expected a cell the "
                               f"robot can always stand on")
        # set only once every check passed, so a refused placement leaves the world as it was
        self._unknown = unknown
        self.static_unknowns: np.ndarray = static_cells
        """The (k, 2) cells of the true world's always-present unknown obstacles."""
        self.dynamic_sites: np.ndarray = dynamic_cells
        """The (k, 2) cells where an unknown obstacle may appear during a trip."""
        self.sites: list[np.ndarray] = site_cells
        """The (k, 2) cells of each listed site, blocked together during a trip."""
        self.site_appear = np.array([site.appear for site in sites], dtype=np.float64)
        """The probability of each listed site to be blocked during one trip."""
        self._true_static = grid.passable.copy()
        self._true_static[static_cells[:, 1], static_cells[:, 0]] = False
        self._true_static.setflags(write=False)

    def __len__(self) -> int:
        return self.options.count

    def true_passable(self, present: np.ndarray | None = None,
                      sites_present: Sequence[int] = ()) -> np.ndarray:
        """The true world's passable mask (read-only) with the dynamic sites ``present`` ((k, 2)
        cells) and the cells of the listed sites of indexes ``sites_present`` blocked."""
        blocked = [path_array(present if present is not None else []),
                   *(self.sites[i] for i in sites_present)]
        cells = np.concatenate(blocked)
        if not len(cells):
            return self._true_static
        passable = self._true_static.copy()
        passable[cells[:, 1], cells[:, 0]] = False
        passable.setflags(write=False)
        return passable

    def queries(self, ctx: Context) -> Iterator[GridQuery]:
        for _ in range(self.options.count):
            query = self._query(_grid_world(ctx, "workload 'trips'"))
            if self.options.headings:
                query = attrs.evolve(query, heading=int(self._heading_rng.integers(8)))
            yield query

    def _query(self, grid: Grid) -> GridQuery:
        if self.places is not None:
            start, goal = self.places[self._query_rng.choice(len(self.places), size=2,
                                                             replace=False)]
            return GridQuery((int(start[0]), int(start[1])), (int(goal[0]), int(goal[1])))
        flat = np.flatnonzero(grid.passable & ~self._unknown)
        xy = np.column_stack((flat % grid.width, flat // grid.width))
        distance = self.options.min_distance
        starts = flat[:0]
        if len(xy):
            # a cell has a partner far enough iff the farthest extreme coordinate is far enough
            reach = np.maximum(xy - xy.min(axis=0), xy.max(axis=0) - xy).max(axis=1)
            starts = np.flatnonzero(reach >= distance)
        if len(starts) == 0:
            raise CbrError(f"workload 'trips': no two cells free in the map and holding no "
                           f"unknown obstacle are at least min_distance {distance} apart "
                           f"({len(flat)} such cells)")
        start = xy[self._query_rng.choice(starts)]
        goal = xy[self._query_rng.choice(np.flatnonzero(np.abs(xy - start).max(axis=1)
                                                          >= distance))]
        return GridQuery((int(start[0]), int(start[1])), (int(goal[0]), int(goal[1])))

    def describe(self, problem: GridQuery) -> Mapping[str, Any]:
        described = {"start_x": problem.start[0], "start_y": problem.start[1],
                     "goal_x": problem.goal[0], "goal_y": problem.goal[1]}
        if problem.heading is not None:
            described["heading"] = problem.heading
        return described

    def execute(self, problem: GridQuery, proposal: Proposal, ctx: Context) -> Outcome:
        grid = _grid_world(ctx, "workload 'trips'")
        ctx.shared[PLANNED_WORLD] = grid
        # drawn for every trip, solved or not, so the draws of later trips do not depend on it
        present = self.dynamic_sites[self._presence_rng.random(len(self.dynamic_sites))
                                     < self.options.appear]
        # drawn after the random sites, and not at all without listed sites, so that a seed
        # gives the same trips as before sites were configured
        sites_present = np.flatnonzero(self._presence_rng.random(len(self.site_appear))
                                       < self.site_appear).tolist() if self.sites else []
        if proposal.solution is None:
            return Outcome(success=False)
        path = self._checked(grid, problem, proposal.solution.value)
        drive = self._drive(grid, self.true_passable(present, sites_present), path, problem,
                            [self.sites[i] for i in sites_present])
        changes = self._learn(grid, drive)
        if changes:
            risk = grid.risk.copy()
            for x, y, value in changes:
                risk[y, x] = value
            ctx.world = attrs.evolve(grid, risk=risk)
        cost = path_cost(grid, drive.driven)
        travel = path_length(drive.driven) + self.options.collision_time * len(drive.stops)
        detail = {"encounters": len(drive.met), "replans": len(drive.stops),
                  "stops": [list(cell) for cell in drive.stops],
                  "risk_changes": changes, "present": present.tolist(),
                  "sites_present": sites_present, "travel_time": travel}
        if drive.reason:
            detail["failure"] = drive.reason
        driven = Solution(drive.driven.tolist(), cost, proposal.solution.cases,
                          {"encounters": len(drive.met), "replans": len(drive.stops)})
        return Outcome(success=drive.reached, cost=cost, solution=driven, detail=detail)

    @staticmethod
    def _checked(grid: Grid, problem: GridQuery, value: object) -> np.ndarray:
        """The proposed path as an (n, 2) array; a CbrError unless it is a drivable cell path."""
        path = path_array(value)
        if len(path) == 0:
            raise CbrError("workload 'trips': the proposed path has no cells")
        if not grid.inside(path).all():
            raise CbrError(f"workload 'trips': the proposed path leaves the "
                           f"{grid.width}x{grid.height} grid")
        jumps = np.abs(np.diff(path, axis=0)).max(axis=1, initial=0) != 1
        if jumps.any():
            i = int(np.argmax(jumps))
            raise CbrError(f"workload 'trips': proposed path step {i} from {tuple(path[i])} to "
                           f"{tuple(path[i + 1])} is not a move to an 8-neighbour")
        if tuple(path[0]) != tuple(problem.start) or tuple(path[-1]) != tuple(problem.goal):
            raise CbrError(f"workload 'trips': the proposed path runs from {tuple(path[0])} to "
                           f"{tuple(path[-1])}, not from the trip's start {problem.start} to "
                           f"its goal {problem.goal}")
        return path

    def _drive(self, grid: Grid, true: np.ndarray, path: np.ndarray, problem: GridQuery,
               blocked_sites: Sequence[np.ndarray] = ()) -> _Drive:
        """Follow ``path`` on the true passable mask, replanning around the obstacles met.

        Meeting a cell of one of ``blocked_sites`` (the listed sites blocked on this trip), the
        robot sees the whole site blocked: a shut door is shut across its width.
        """
        goal = problem.goal
        site_of = {(x, y): cells for cells in blocked_sites for x, y in cells.tolist()}
        plan, legs = path, [path[:1]]
        met: list[tuple[int, int]] = []
        stops: list[tuple[int, int]] = []
        driven, limit = 0, 4 * true.size
        radius = self.options.replan_window
        while True:
            k = _first_blocked(true, grid.corner_cutting, plan)
            end = len(plan) - 1 if k is None else k
            legs.append(plan[1:end + 1])
            driven += end
            if driven > limit:
                return _Drive(np.concatenate(legs), met, stops, False, "step limit")
            if k is None:
                return _Drive(np.concatenate(legs), met, stops, True, "")
            here = (int(plan[k, 0]), int(plan[k, 1]))
            for hit in _obstacles_met(true, grid.corner_cutting, plan[k], plan[k + 1]):
                seen = site_of.get(hit)
                for cell in [hit] if seen is None else map(tuple, seen.tolist()):
                    if cell not in met:
                        met.append(cell)
            avoid = grid.passable.copy()
            xs, ys = np.array(met).T
            avoid[ys, xs] = False
            avoid[here[1], here[0]] = True  # the robot stands there, whatever its map says
            stops.append(here)
            if self.kinematics is not None:
                plan = self._replan(grid, avoid, here, np.concatenate(legs), problem)
                if plan is None:
                    return _Drive(np.concatenate(legs), met, stops, False, "no path around")
                continue
            beyond = plan[k + 2:] if not true[plan[k + 1, 1], plan[k + 1, 0]] else plan[k + 1:]
            window = (here[0] - radius, here[1] - radius, here[0] + radius, here[1] + radius)
            local = _astar(grid, avoid, here, beyond, window) if len(beyond) else None
            if local is not None:
                rejoin = int(np.flatnonzero((beyond == local[-1]).all(axis=1))[0])
                plan = np.concatenate((local, beyond[rejoin + 1:]))
                continue
            plan = _astar(grid, avoid, here, np.array([goal]))
            if plan is None:
                return _Drive(np.concatenate(legs), met, stops, False, "no path around")

    def _replan(self, grid: Grid, passable: np.ndarray, here: tuple[int, int],
                driven: np.ndarray, problem: GridQuery) -> np.ndarray | None:
        """A path to the goal the robot of a constrained model can drive from ``here``, moving
        as it moved into it (as the trip's heading says at the start)."""
        # numba loads with the first replan, not with every start of ``cbr``
        from cbr_kinematics.grid_search import astar

        heading = problem.heading if len(driven) < 2 else int(of_steps(driven[-2:])[0])
        found = astar(grid.factor, passable, grid.corner_cutting, here, problem.goal,
                      kinematics=self.kinematics, heading=heading)
        return None if found is None else found.path

    def _learn(self, grid: Grid, drive: _Drive) -> list[list[Any]]:
        """The cells whose risk the trip changed, as [x, y, new risk] in row-major order: passed
        cells relieved, met cells raised."""
        # only the cells the trip touched are looked at, so a trip costs in proportion to its path
        flat = np.unique(drive.driven[:, 1] * grid.width + drive.driven[:, 0])
        passed = np.column_stack((flat % grid.width, flat // grid.width))
        met = np.array(drive.met, dtype=np.int64).reshape(-1, 2)
        cells = np.concatenate((passed, met))
        old = grid.risk[cells[:, 1], cells[:, 0]]
        # a met cell is never passed, so no cell is both relieved and raised; rounding lets rises
        # and reliefs that cancel out return exactly to where they started
        new = np.concatenate((
            np.maximum(np.round(old[:len(passed)] - self.options.pass_relief, _DECIMALS), 0.0),
            np.minimum(np.round(old[len(passed):] + self.options.hit_risk, _DECIMALS), 1.0)))
        # a hit or relief of 0 leaves a cell alone rather than rounding its configured risk
        amounts = np.repeat([self.options.pass_relief, self.options.hit_risk],
                            [len(passed), len(met)])
        changed = (new != old) & (amounts > 0)
        order = np.lexsort((cells[changed, 0], cells[changed, 1]))
        return [[int(x), int(y), float(v)] for (x, y), v in zip(
            cells[changed][order].tolist(), new[changed][order].tolist(), strict=True)]


def _first_blocked(passable: np.ndarray, corner_cutting: bool, plan: np.ndarray) -> int | None:
    """The index of the first cell of ``plan`` whose step to the next one is blocked, if any."""
    src, dst = plan[:-1], plan[1:]
    ok = passable[dst[:, 1], dst[:, 0]]
    side_a = passable[src[:, 1], dst[:, 0]]
    side_b = passable[dst[:, 1], src[:, 0]]
    corners = (side_a | side_b) if corner_cutting else (side_a & side_b)
    ok &= corners | ((src[:, 0] == dst[:, 0]) | (src[:, 1] == dst[:, 1]))
    bad = np.flatnonzero(~ok)
    return int(bad[0]) if len(bad) else None


def _obstacles_met(passable: np.ndarray, corner_cutting: bool, src: np.ndarray,
                   dst: np.ndarray) -> list[tuple[int, int]]:
    """The blocked cells that stop the step from ``src`` to ``dst``."""
    if not passable[dst[1], dst[0]]:
        return [(int(dst[0]), int(dst[1]))]
    # a diagonal step stopped by the orthogonal cells beside it
    sides = [(int(dst[0]), int(src[1])), (int(src[0]), int(dst[1]))]
    return [cell for cell in sides if not passable[cell[1], cell[0]]]


def _key(x: int, y: int) -> str:
    return f"{x},{y}"


class RiskMap:
    """Keep the risks the robot learned on trips in the case base, for later runs.

    Built, it applies the risks stored in the case base (meta key ``grid.learned_risk``, a mapping
    ``{"x,y": risk}``) to the run's world. Each retain merges the outcome's ``risk_changes``
    (given by the ``trips`` workload) into the stored mapping, which keeps only cells whose risk
    differs from the configured map, inside the learn step's transaction.
    """

    def __init__(self, options: object, ctx: Context) -> None:
        grid = _grid_world(ctx, "retainer 'risk_map'")
        if ctx.casebase is None:
            raise CbrError("retainer 'risk_map' needs the run's case base")
        ctx.shared.setdefault(CONFIGURED_WORLD, grid)
        self.original = grid.risk
        learned = self._learned(ctx.casebase, grid)
        if learned:
            risk = grid.risk.copy()
            for (x, y), value in learned.items():
                risk[y, x] = value
            ctx.world = attrs.evolve(grid, risk=risk)

    @staticmethod
    def _learned(casebase: CaseStore, grid: Grid) -> dict[tuple[int, int], float]:
        stored = casebase.get_meta(LEARNED_RISK, {})
        where = f"case base {getattr(casebase, 'path', type(casebase).__name__)}"
        if not isinstance(stored, Mapping):
            raise CbrError(f"{where}: meta {LEARNED_RISK!r} must map 'x,y' to a risk, got "
                           f"{type(stored).__name__}")
        learned: dict[tuple[int, int], float] = {}
        for key, value in stored.items():
            try:
                x, y = (int(part) for part in str(key).split(","))
            except ValueError:
                raise CbrError(f"{where}: meta {LEARNED_RISK!r} has key {key!r}, expected a "
                               f"cell 'x,y'") from None
            if not grid.in_bounds((x, y)):
                raise CbrError(f"{where}: learned cell ({x}, {y}) is outside the "
                               f"{grid.width}x{grid.height} world; the case base was learned "
                               f"on another map")
            if isinstance(value, bool) or not isinstance(value, int | float) or not (
                    0 <= value <= 1):
                raise CbrError(f"{where}: learned risk of cell ({x}, {y}) must be a number in "
                               f"[0, 1], got {value!r}")
            learned[x, y] = float(value)
        return learned

    @hookimpl
    def cbr_retain(self, outcome: Outcome, casebase: CaseStore) -> None:
        changes = outcome.detail.get("risk_changes", ())
        if not changes:
            return
        # read back from the store rather than kept here, so a rolled-back step leaves no trace
        learned = dict(casebase.get_meta(LEARNED_RISK, {}))
        for x, y, value in changes:
            if value == self.original[y, x]:
                learned.pop(_key(x, y), None)
            else:
                learned[_key(x, y)] = float(value)
        casebase.set_meta(LEARNED_RISK, learned)


@attrs.frozen
class PathQualityOptions:
    optimal: bool = option(
        True, "Add optimal_cost (A* on the map the proposal was planned on) and deviation; "
        "false leaves out both columns, and the search, on big maps.")


class PathQuality:
    """Per query: the proposed path's length, turns and cost, against the optimal cost.

    Columns ``length``, ``turns``, ``cost`` and, with ``optimal``, ``optimal_cost`` and
    ``deviation`` (cost / optimal_cost - 1); NaN where there is no path. Costs are taken on the
    map the proposal was planned on: the ``trips`` workload records it before it replaces the
    run's world with what the robot learned, other workloads leave the world as it is.
    """

    def __init__(self, options: PathQualityOptions, ctx: Context) -> None:
        _grid_world(ctx, "metric 'path_quality'")
        self.optimal = options.optimal

    def measure(self, problem: GridQuery, proposal: Proposal, outcome: Outcome,
                ctx: Context) -> Mapping[str, float]:
        planned = ctx.shared.get(PLANNED_WORLD)
        grid = planned if isinstance(planned, Grid) else _grid_world(ctx, "metric 'path_quality'")
        nan = float("nan")
        row = {"length": nan, "turns": nan, "cost": nan}
        if proposal.solution is not None:
            path = proposal.solution.value
            row = {"length": path_length(path), "turns": float(turns(path)),
                   "cost": path_cost(grid, path)}
        if self.optimal:
            optimal = nan
            if grid.in_bounds(problem.start) and grid.in_bounds(problem.goal):
                best = _astar(grid, grid.passable, problem.start, np.array([problem.goal]))
                optimal = nan if best is None else path_cost(grid, best)
            row["optimal_cost"] = optimal
            row["deviation"] = row["cost"] / optimal - 1 if optimal > 0 else nan
        return row
