"""The ``trips`` workload: trips of a simulated robot on a world that may differ from its map.

The configured world is the robot's map; the true world it drives on adds the obstacles the map
does not show (:mod:`cbr_grid.true_world`). Each trip goes between random free cells the map
knows (never in its unknown space, which a path may still cross), or between the configured
``places``, and never starts or ends on an unknown obstacle or a site; the robot follows the
proposed path and replans around what it meets (:mod:`cbr_grid.drive`), and the outcome
carries a :class:`~cbr_grid.drive.DriveReport`. The workload learns nothing itself: the
``risk_map`` retainer (:mod:`cbr_grid.risk`) learns the map from the report inside the learn step.

The random unknown cells are drawn once, uniformly and without repetition, from the cells free
(and known) in the configured map that are neither a listed site's nor a fixed place's, from a
generator derived from the run's seed (or the workload's own ``seed``), so a seed repeats the
same true world, also in a later run that continues a case base; ``trip_seed`` draws the trips
apart from it, so that robots sharing one world (and case base) drive their own trips.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from typing import Any, Literal

import attrs
import numpy as np

from cbr_grid.costs import path_cost
from cbr_grid.drive import Robot, checked_path
from cbr_grid.grid import Grid, grid_world
from cbr_grid.planning import planner_of, planner_problem
from cbr_grid.query import GridQuery, path_array
from cbr_grid.recording import TripRecording
from cbr_grid.risk import CONFIGURED_WORLD
from cbr_grid.true_world import TrueWorld
from cbr_recording.keys import RECORDER
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.model import Outcome, Proposal, Solution
from cbrcore.options import option, reference
from cbrcore.stash import StashKey

PLANNED_WORLD = StashKey[Grid]()
"""The map the last executed proposal was planned on (the learn step may change the world)."""

_UNIT = attrs.validators.and_(attrs.validators.instance_of(float), attrs.validators.ge(0.0),
                              attrs.validators.le(1.0))
_COUNT = attrs.validators.and_(attrs.validators.instance_of(int), attrs.validators.ge(0))


def _some_cells(_: object, attribute: attrs.Attribute, value: list[tuple[float, float]]) -> None:
    if not value:
        raise ValueError(f"'{attribute.name}' must hold at least one cell (x, y), got {value!r}")


@attrs.frozen
class Site:
    """A named place of the true world where an obstacle missing from the map may appear.

    All its ``cells`` are blocked together (a door is its cells), during a trip with probability
    ``appear``.
    """

    cells: list[tuple[float, float]] = option(
        doc="The (x, y) cells blocked together, each free in the configured map (points in "
        "metres with the workload's frame: map).", validator=_some_cells)
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
    replan_window: int = option(
        8, "Chebyshev radius of the box around the robot that a local replan stays in.",
        validator=attrs.validators.and_(attrs.validators.instance_of(int),
                                        attrs.validators.ge(1)))
    min_distance: int = option(
        1, "The least Chebyshev distance between the start and the goal of a trip.",
        validator=attrs.validators.and_(attrs.validators.instance_of(int),
                                        attrs.validators.ge(1)))
    frame: Literal["cell", "map"] = option(
        "cell", "How places and sites are written: grid cells (x, y), or points (x, y) in "
        "metres in the map frame of a map that has one (a ROS map), each standing for the cell "
        "it falls in.")
    places: list[tuple[float, float]] | None = option(
        None, "Fixed places (x, y) the trips go between: each trip's start and goal are two "
        "different places drawn uniformly (seeded), whatever min_distance says; null draws "
        "random free cells the map knows (none in its unknown space). At least 2 distinct "
        "places, each free in the map and on no site.")
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
    replanner: str = reference(
        "solver", "astar", "The grid planner (a solver of the solver protocol, built-in or a "
        "plugin's) the robot replans with around an obstacle it met; it plans for the "
        "configuration's kinematic model, a constrained one straight to "
        "the goal from the direction the robot was moving in, so the path driven is one it can "
        "drive.", fits=planner_problem)
    seed: int | None = option(
        None, "The seed of the true world's random obstacles, the trips and the obstacles' "
        "presence; null derives one from the run's seed. Give two configurations the same seed "
        "to drive them on the same trips in the same worlds whatever their other components.",
        validator=attrs.validators.optional(attrs.validators.ge(0)))
    trip_seed: int | None = option(
        None, "The seed of the trips alone (their starts, goals and headings, and the dynamic "
        "obstacles present on each), the true world staying that of seed; null draws them "
        "from seed's stream. Robots sharing one office and its unknown obstacles, each on trips "
        "of its own, give each robot its own trip_seed.",
        validator=attrs.validators.optional(attrs.validators.ge(0)))


class Trips:
    """Trips driven by a simulated robot on a true world that may hold unknown obstacles.

    The configured world is the robot's map; the true world adds ``unknown_static`` obstacles,
    ``unknown_dynamic`` sites (each blocked per trip with probability ``appear``) and the listed
    ``sites`` (each blocked per trip, all its cells together, with its own probability) on cells
    free in that map, the random ones placed uniformly from the run's seed. Each trip goes
    between two random cells free in the current map and holding no unknown obstacle or site,
    or between two different ``places``. The robot follows the proposed path; when its next step
    is blocked it replans with the ``replanner`` solver locally (inside a box of radius
    ``replan_window`` to the nearest remaining path cell beyond the obstacle, on its map with
    the cells met on this trip blocked), else globally to the goal, else the trip fails (as it
    does after 4 steps per map cell); a robot of a constrained kinematic model replans to the
    goal from the direction it was moving in. The outcome's ``report`` is the trip's
    :class:`~cbr_grid.drive.DriveReport`; its cost is the driven path's on the map.
    """

    def __init__(self, options: TripsOptions, ctx: Context) -> None:
        self.options = options
        # the map as configured, which a learned map (the risk_map retainer) may stand for
        self.configured = ctx.stash.setdefault(CONFIGURED_WORLD,
                                               grid_world(ctx, "workload 'trips'"))
        self.planner = planner_of(options.replanner, ctx, "workload 'trips': replanner")
        places = self._checked_places(
            None if options.places is None else self._cells(options.places, "places"))
        self.true_world = TrueWorld(self.configured, appear=options.appear, places=places,
                                    what="workload 'trips'")
        sites = [(self._cells(site.cells, f"sites[{i}].cells"), site.appear)
                 for i, site in enumerate(options.sites)]
        # the random unknowns keep off the listed sites and the places, so they cannot collide
        pool = self.configured.known_passable().copy()
        for cells in self.true_world.site_cells([cells for cells, _ in sites]):
            pool[cells[:, 1], cells[:, 0]] = False
        if places is not None:
            pool[places[:, 1], places[:, 0]] = False
        free = np.flatnonzero(pool)
        unknown = options.unknown_static + options.unknown_dynamic
        # with places the trips need no free cell of their own
        spare = 0 if places is not None else 2
        if unknown + spare > len(free):
            raise CbrError(f"workload 'trips': {options.unknown_static} unknown_static + "
                           f"{options.unknown_dynamic} unknown_dynamic obstacles leave fewer than "
                           f"{spare} of the map's {len(free)} free cells that are no site or "
                           f"place for trips")
        own = ctx.spawn_rng() if options.seed is None else np.random.default_rng(options.seed)
        # spawned children depend only on their index: a fourth leaves the first three as they were
        placement, self._query_rng, self._presence_rng, self._heading_rng = own.spawn(4)
        if options.trip_seed is not None:
            # the same spawn order as above, so a trip seed equal to seed changes nothing
            _, self._query_rng, self._presence_rng, self._heading_rng = np.random.default_rng(
                options.trip_seed).spawn(4)
        chosen = placement.choice(free, size=unknown, replace=False)
        width = self.configured.width
        cells = np.column_stack((chosen % width, chosen // width))
        self.true_world.place(cells[:options.unknown_static], cells[options.unknown_static:],
                              sites)
        self._recording = TripRecording(self.configured)

    @property
    def places(self) -> np.ndarray | None:
        """The (k, 2) cells trips go between, or None for random free cells."""
        return self.true_world.places

    def _cells(self, written: Sequence[tuple[float, float]], what: str) -> list[tuple[int, int]]:
        """The grid cells of ``written`` places or site cells, as the workload's ``frame``
        says they are written. Points in metres are checked here, where the metres as written
        can be quoted with the cell they fall in; cells are checked by their users."""
        if self.options.frame == "map":
            if self.configured.frame is None:
                raise CbrError(f"workload 'trips': {what} are in metres (frame: map), but the map "
                               "has no metric frame (ROS .yaml maps have one); give cells with "
                               "frame: cell")
            return [self.configured.check_point(point, f"workload 'trips': {what}[{i}]")
                    for i, point in enumerate(written)]
        for i, (x, y) in enumerate(written):
            if not (float(x).is_integer() and float(y).is_integer()):
                raise CbrError(f"workload 'trips': {what}[{i}] ({x:g}, {y:g}): expected a cell "
                               "of two whole numbers; for points in metres set frame: map")
        return [(int(x), int(y)) for x, y in written]

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

    def __len__(self) -> int:
        return self.options.count

    def queries(self, ctx: Context) -> Iterator[GridQuery]:
        for _ in range(self.options.count):
            grid = grid_world(ctx, "workload 'trips'")
            recorder = ctx.stash.get(RECORDER, None)
            if recorder is not None:
                self._recording.begin(recorder, grid)
            query = self._query(grid)
            if self.options.headings:
                query = attrs.evolve(query, heading=int(self._heading_rng.integers(8)))
            yield query

    def _query(self, grid: Grid) -> GridQuery:
        if self.places is not None:
            start, goal = self.places[self._query_rng.choice(len(self.places), size=2,
                                                             replace=False)]
            return GridQuery((int(start[0]), int(start[1])), (int(goal[0]), int(goal[1])))
        flat = np.flatnonzero(grid.known_passable() & ~self.true_world.unknown)
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
        grid = grid_world(ctx, "workload 'trips'")
        ctx.stash[PLANNED_WORLD] = grid
        # drawn for every trip, solved or not, so the draws of later trips do not depend on it
        blocked = self.true_world.draw(self._presence_rng)
        recorder = ctx.stash.get(RECORDER, None)
        if proposal.solution is None:
            if recorder is not None:
                self._recording.trip(recorder, grid, ctx.step, problem, proposal, None,
                                     self.options.collision_time)
            return Outcome(success=False)
        path = checked_path(grid, problem, proposal.solution.value)
        robot = Robot(grid, self.planner, self.options.replan_window,
                      self.options.collision_time)
        report = robot.drive(path, problem, self.true_world.passable(blocked), blocked,
                             [self.true_world.sites[i] for i in blocked.sites])
        if recorder is not None:
            self._recording.trip(recorder, grid, ctx.step, problem, proposal, report,
                                 self.options.collision_time)
        cost = path_cost(grid, report.driven)
        driven = Solution(report.driven.tolist(), cost, proposal.solution.cases,
                          {"encounters": len(report.met), "replans": report.replans})
        return Outcome(success=report.reached, cost=cost, solution=driven, report=report)
