"""The simulated robot: it follows a planned path on the true world and replans around what
it meets.

The robot knows only its map. When its next step is blocked in the true world it stops, sees
the obstacle (the whole of a blocked site: a shut door is shut across its width), and replans on
its map with every obstacle met on this trip blocked: first locally, inside a box of radius
``window`` around it, to the nearest cell of its plan beyond the obstacle, else to the goal; a
robot of a constrained kinematic model replans to the goal at once, from the direction it was
moving in. The trip fails when no path is left or after 4 steps per map cell. What happened is
a :class:`DriveReport`.
"""

from __future__ import annotations

from collections.abc import Sequence

import attrs
import numpy as np

from cbr_grid.costs import path_length
from cbr_grid.directions import of_steps
from cbr_grid.grid import Grid
from cbr_grid.planning import GridPlanner
from cbr_grid.query import Cell, GridQuery, path_array
from cbr_grid.true_world import Blocked
from cbrcore.errors import CbrError


@attrs.frozen
class DriveReport:
    """What happened on one trip, as the ``trips`` workload reports it in ``Outcome.report``.

    ``driven`` is the (n, 2) cells the robot drove, from the start to where it stopped for good;
    ``met`` the obstacle cells it met, in the order met; ``stops`` where it stood each time an
    obstacle stopped it (and it replanned); ``blocked`` the unknown obstacles present on the
    trip; ``travel_time`` the driven length plus ``collision_time`` per stop, in the time of one
    straight step; ``failure`` why the robot did not reach the goal ("" when it did).
    """

    driven: np.ndarray
    met: tuple[Cell, ...]
    stops: tuple[Cell, ...]
    blocked: Blocked
    travel_time: float
    failure: str = ""

    @property
    def reached(self) -> bool:
        return not self.failure

    @property
    def replans(self) -> int:
        return len(self.stops)


def checked_path(grid: Grid, problem: GridQuery, value: object) -> np.ndarray:
    """The proposed path as an (n, 2) array; a CbrError unless it is a drivable cell path from
    the query's start to its goal."""
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


@attrs.frozen
class Robot:
    """How the simulated robot drives: its map, its replanner, the radius of a local replan and
    the time one stop costs."""

    grid: Grid
    planner: GridPlanner
    window: int
    collision_time: float

    def drive(self, path: np.ndarray, problem: GridQuery, true: np.ndarray, blocked: Blocked,
              sites: Sequence[np.ndarray] = ()) -> DriveReport:
        """Follow ``path`` on the ``true`` passable mask, replanning around the obstacles met.

        ``sites`` are the cells of the listed sites blocked on this trip: meeting one of their
        cells, the robot sees the whole site.
        """
        grid = self.grid
        site_of = {(x, y): cells for cells in sites for x, y in cells.tolist()}
        plan, legs = path, [path[:1]]
        met: list[Cell] = []
        stops: list[Cell] = []
        driven, limit = 0, 4 * true.size

        def report(failure: str) -> DriveReport:
            cells = np.concatenate(legs)
            travel = path_length(cells) + self.collision_time * len(stops)
            return DriveReport(cells, tuple(met), tuple(stops), blocked, travel, failure)

        while True:
            k = _first_blocked(true, grid.corner_cutting, plan)
            end = len(plan) - 1 if k is None else k
            legs.append(plan[1:end + 1])
            driven += end
            if driven > limit:
                return report("step limit")
            if k is None:
                return report("")
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
            goal = np.array([problem.goal])
            if self.planner.constrained:
                so_far = np.concatenate(legs)
                heading = (problem.heading if len(so_far) < 2
                           else int(of_steps(so_far[-2:])[0]))
                replanned = self.planner.plan(grid, avoid, here, goal, heading=heading)
                if replanned is None:
                    return report("no path around")
                plan = replanned
                continue
            beyond = plan[k + 2:] if not true[plan[k + 1, 1], plan[k + 1, 0]] else plan[k + 1:]
            radius = self.window
            box = (here[0] - radius, here[1] - radius, here[0] + radius, here[1] + radius)
            local = self.planner.plan(grid, avoid, here, beyond, window=box) if len(
                beyond) else None
            if local is not None:
                rejoin = int(np.flatnonzero((beyond == local[-1]).all(axis=1))[0])
                plan = np.concatenate((local, beyond[rejoin + 1:]))
                continue
            replanned = self.planner.plan(grid, avoid, here, goal)
            if replanned is None:
                return report("no path around")
            plan = replanned


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
                   dst: np.ndarray) -> list[Cell]:
    """The blocked cells that stop the step from ``src`` to ``dst``."""
    if not passable[dst[1], dst[0]]:
        return [(int(dst[0]), int(dst[1]))]
    # a diagonal step stopped by the orthogonal cells beside it
    sides = [(int(dst[0]), int(src[1])), (int(src[0]), int(dst[1]))]
    return [cell for cell in sides if not passable[cell[1], cell[0]]]
