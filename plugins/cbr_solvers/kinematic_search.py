"""The modified Dijkstra and A* of section 5 on an 8-connected grid, compiled.

The search settles directed edges, not cells: a state is a cell j with the direction a = δ(i, j)
of the step that reached it, d_s(i, j) its distance and p_s(i, j) its parent state. The start is
the fictitious edge (s', s) of direction w_s, the robot's initial heading (free when none is
given: any first step). An edge (j, k) is explored from (i, j) when the model's condition
P(i, j, k) holds (:mod:`cbr_solvers.manoeuvres`), its distance being d_s(i, j) plus the cost of
any manoeuvre at j plus F(j, k), the step cost of the grid's cost contract
(:mod:`cbr_solvers.search`). The search stops when every edge into the goal g is settled (step 4)
and takes the cheapest of them (step 5), or, with a required final heading w_g, when the
fictitious edge (g, g') of direction w_g is settled: the path must be one the robot could
continue from g in direction w_g, the condition P applied at g as at every vertex. The
modified A* orders the edges by d_s(i, j) plus the octile distance from j to g times the least
cost factor (or a given per-cell table, Ai*'s), which never overestimates.

Reading of the paper: E(g) in step 4 is the set of edges *entering* g (step 5 chooses among
them); when nothing is left to settle before all are, the search stops with those settled.
"""

from __future__ import annotations

from collections.abc import Sequence

import attrs
import numpy as np

from cbr_grid.costs import SQRT2
from cbr_grid.directions import STEPS, check_heading, facing
from cbr_grid.directions import of_steps as step_directions
from cbr_grid.directions import reversing as reversing_steps
from cbr_grid.search_base import (
    INITIAL_HEAP,
    MOVE_OF_DIRECTION,
    Workspace,
    checked_arguments,
    move,
    pop,
    push_grown,
)
from cbr_kernels import njit
from cbr_kinematics.models import Kinematics
from cbr_solvers.aistar import heuristic_table
from cbr_solvers.manoeuvres import CODES, leave_costs, manoeuvre_cells
from cbr_solvers.search import HeuristicTable, guidance, window_min_factor


@attrs.frozen
class KinematicPath:
    """A path found by an edge-based search.

    ``path`` is the (n, 2) array of (x, y) cells the robot drives, manoeuvres included (each an
    out-and-back step), ``cost`` its cost, ``expanded`` the number of edges settled.
    ``arrivals[a]`` is d_s of the edge entering the goal in direction a (inf when it was not
    settled or does not exist). :attr:`headings` and :attr:`reversing` describe each step.
    """

    path: np.ndarray = attrs.field(eq=attrs.cmp_using(eq=np.array_equal))
    cost: float
    expanded: int
    arrivals: np.ndarray = attrs.field(eq=attrs.cmp_using(eq=np.array_equal))

    @property
    def directions(self) -> np.ndarray:
        """The direction of motion of each step, δ in 0..7."""
        return step_directions(self.path)

    @property
    def reversing(self) -> np.ndarray:
        """Whether each step is driven in reverse (after an odd number of cusps)."""
        return reversing_steps(self.directions)

    @property
    def headings(self) -> np.ndarray:
        """The way the robot faces after each step: its direction of motion, turned round
        while it reverses."""
        return facing(self.directions)


@njit(inline="always")
def _step_cost(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, cx: int, cy: int,
               b: int, x0: int, y0: int, x1: int, y1: int) -> float:
    """F of the step from (cx, cy) in direction b; inf when the move is not allowed."""
    if not move(passable, corner_cutting, cx, cy, MOVE_OF_DIRECTION[b], x0, y0, x1, y1):
        return np.inf
    nx, ny = cx + STEPS[b, 0], cy + STEPS[b, 1]
    fa, fb = factor[cy, cx], factor[ny, nx]
    if not (fa > 0.0 and fa < np.inf and fb > 0.0 and fb < np.inf):
        raise ValueError("factor must be finite and positive on passable cells")
    return (SQRT2 if b % 2 == 1 else 1.0) * (fa + fb) * 0.5


@njit
def _search(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, sx: int, sy: int,
            heading: int, gx: int, gy: int, final: int, x0: int, y0: int, x1: int, y1: int,
            informed: bool, scale: float, table: np.ndarray, turns: np.ndarray,
            manoeuvres: int, stamp: np.ndarray, dist: np.ndarray, parent: np.ndarray,
            generation: int) -> tuple[int, int, np.ndarray]:
    """The edge-based search from (sx, sy) heading ``heading`` (-1: free) to (gx, gy), with the
    required final heading ``final`` (-1: none), inside the window [x0, x1] x [y0, y1]; with
    ``gx`` -1, a sweep that settles every edge it can reach.

    Returns (best, expanded, arrivals): the state whose path is the answer (-1 when none; read
    it with :func:`_read_path`), the number of states settled and d_s of the edges into the
    goal by direction. States are 8·cell + direction over the window's cells in row-major
    order, then the fictitious start edge (s', s) and goal edge (g, g'). ``stamp``, ``dist``
    and ``parent`` are reused working arrays (:class:`cbr_grid.search_base.Workspace`);
    ``parent`` packs the parent state and the manoeuvre made before the state's edge as
    state · CODES + code. ``scale`` is A*'s octile scale, negative to find it here (as
    :func:`cbr_solvers.search.guidance` gives it). The caller guarantees that the start and goal
    lie in the window.
    """
    ww = x1 - x0 + 1
    cells = ww * (y1 - y0 + 1)
    source, terminal = 8 * cells, 8 * cells + 1
    settled = generation + 1
    arrivals = np.full(8, np.inf)
    if not (passable[sy, sx] and (gx < 0 or passable[gy, gx])):
        return -1, 0, arrivals
    tabled = table.shape[0] > 0
    if informed and not tabled and scale < 0.0:
        scale = window_min_factor(factor, passable, x0, y0, x1, y1)

    # the edges into g (step 4): one per direction from which a step reaches g
    entering = 0
    for a in range(8 if gx >= 0 else 0):
        px, py = gx - STEPS[a, 0], gy - STEPS[a, 1]
        if x0 <= px <= x1 and y0 <= py <= y1 and passable[py, px] and move(
                passable, corner_cutting, px, py, MOVE_OF_DIRECTION[a], x0, y0, x1, y1):
            entering += 1

    keys = np.empty(INITIAL_HEAP, dtype=np.float64)
    items = np.empty(INITIAL_HEAP, dtype=np.int64)
    stamp[source] = generation
    dist[source] = 0.0
    keys[0] = 0.0
    items[0] = source
    size = 1
    expanded = 0
    best = -1
    settled_goal = 0
    out_cost = np.empty(8)
    steps = np.empty(8)
    extra = np.empty(8)
    code = np.zeros(8, dtype=np.int64)

    while size > 0:
        state = pop(keys, items, size)
        size -= 1
        if stamp[state] == settled:
            continue
        stamp[state] = settled
        expanded += 1
        if state == terminal:
            best = terminal
            break
        if state == source:
            cx, cy, arrival = sx, sy, heading
        else:
            cell = state // 8
            cx, cy, arrival = x0 + cell % ww, y0 + cell // ww, state % 8
        at_goal = cx == gx and cy == gy
        if at_goal and state != source:
            arrivals[arrival] = dist[state]
        if at_goal and final < 0:
            if state == source:
                best = source  # the start is the goal: the empty path
                break
            if best < 0:
                best = state  # popped in order of distance: the first is the cheapest
            settled_goal += 1
            if settled_goal == entering:
                break
        here = dist[state]
        for b in range(8):
            steps[b] = _step_cost(factor, passable, corner_cutting, cx, cy, b, x0, y0, x1, y1)
            out_cost[b] = 2.0 * steps[b]
        leave_costs(arrival, out_cost, turns, manoeuvres, extra, code)
        if at_goal and final >= 0 and extra[final] < np.inf and stamp[terminal] != settled:
            g = here + extra[final]
            if stamp[terminal] != generation or g < dist[terminal]:
                stamp[terminal] = generation
                dist[terminal] = g
                parent[terminal] = state * CODES + code[final]
                keys, items = push_grown(keys, items, size, g, terminal)
                size += 1
        for b in range(8):
            if steps[b] == np.inf or extra[b] == np.inf:
                continue
            nx, ny = cx + STEPS[b, 0], cy + STEPS[b, 1]
            other = 8 * ((ny - y0) * ww + (nx - x0)) + b
            mark = stamp[other]
            if mark == settled:
                continue
            g = here + extra[b] + steps[b]
            if mark == generation and g >= dist[other]:
                continue
            stamp[other] = generation
            dist[other] = g
            parent[other] = state * CODES + code[b]
            key = g
            if tabled:
                key += table[other // 8]
            elif informed:
                dx, dy = abs(nx - gx), abs(ny - gy)
                key += (max(dx, dy) + (SQRT2 - 1.0) * min(dx, dy)) * scale
            keys, items = push_grown(keys, items, size, key, other)
            size += 1

    return best, expanded, arrivals


@njit
def _read_path(parent: np.ndarray, best: int, sx: int, sy: int, x0: int, y0: int, ww: int,
               source: int, terminal: int) -> np.ndarray:
    """The cells driven from (sx, sy) to state ``best``, read back through the packed parents
    (p_s of step 7), each manoeuvre's out-and-back cells included."""
    count = 1
    state = best
    while state != source:
        link = parent[state]
        how = link % CODES
        count += (0 if state == terminal else 1) + 2 * (how > 0) + 2 * (how > 8)
        state = link // CODES
    path = np.empty((count, 2), dtype=np.int64)
    chain = np.empty(count, dtype=np.int64)
    links = 0
    state = best
    while state != source:
        chain[links] = state
        links += 1
        state = parent[state] // CODES
    path[0, 0], path[0, 1] = sx, sy
    at = 1
    x, y = sx, sy
    for i in range(links - 1, -1, -1):
        state = chain[i]
        at = manoeuvre_cells(x, y, parent[state] % CODES, path, at)
        if state != terminal:
            cell = state // 8
            x, y = x0 + cell % ww, y0 + cell // ww
            path[at, 0], path[at, 1] = x, y
            at += 1
    return path


_WORKSPACE = Workspace()


def kinematic_search(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
                     start: Sequence[int], goals: object, window: Sequence[int] | None = None, *,
                     kinematics: Kinematics, heading: int | None = None,
                     final_heading: int | None = None, informed: bool = True,
                     heuristic: HeuristicTable | None = None) -> KinematicPath | None:
    """The cheapest path from ``start`` to the goal a robot of ``kinematics`` can drive.

    ``goals`` holds the one goal cell, as (x, y) or [(x, y)] (the arguments of
    :func:`cbr_solvers.search.astar`). ``heading`` is the robot's initial direction w_s (0-7,
    :mod:`cbr_grid.directions`; None lets it start in any direction), ``final_heading``
    the direction w_g in which it must be able to drive on from the goal (None for any).
    ``informed`` selects the modified A* over the modified Dijkstra; ``heuristic``, given,
    builds A*'s per-cell table as for :func:`cbr_solvers.search.astar` (Ai*'s). ``window``
    limits the search to an inclusive box (x0, y0, x1, y1). Returns None when no path exists.
    ValueError for cells off the grid, more than one goal, headings that are not directions and
    factors that are not finite and positive on passable cells the search meets.
    """
    factor, passable, (sx, sy), targets, (x0, y0, x1, y1) = checked_arguments(
        factor, passable, start, goals, window)
    if len(targets) != 1:
        raise ValueError(f"the edge-based search takes one goal, got {len(targets)}")
    gx, gy = (int(v) for v in targets[0])
    check_heading(heading)
    check_heading(final_heading, "final_heading")
    turns = kinematics.table
    if not (x0 <= sx <= x1 and y0 <= sy <= y1 and x0 <= gx <= x1 and y0 <= gy <= y1):
        return None
    guide = guidance(factor, passable, corner_cutting, targets, (x0, y0, x1, y1), informed,
                     heuristic)
    if guide is None:
        return None
    table, scale = guide
    ww, cells = x1 - x0 + 1, (x1 - x0 + 1) * (y1 - y0 + 1)
    stamp, dist, parent, _, generation = _WORKSPACE.take(8 * cells + 2)
    best, expanded, arrivals = _search(
        factor, passable, bool(corner_cutting), sx, sy, -1 if heading is None else heading,
        gx, gy, -1 if final_heading is None else final_heading, x0, y0, x1, y1,
        bool(informed or heuristic is not None), scale, table, turns, kinematics.manoeuvres,
        stamp, dist, parent, generation)
    if best < 0:
        return None
    path = _read_path(parent, best, sx, sy, x0, y0, ww, 8 * cells, 8 * cells + 1)
    return KinematicPath(path, float(dist[best]), int(expanded), arrivals)


def dijkstra(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
             start: Sequence[int], goals: object, window: Sequence[int] | None = None, *,
             kinematics: Kinematics, heading: int | None = None,
             final_heading: int | None = None) -> KinematicPath | None:
    """The modified Dijkstra of section 5: :func:`kinematic_search` without a heuristic."""
    return kinematic_search(factor, passable, corner_cutting, start, goals, window,
                            kinematics=kinematics, heading=heading, final_heading=final_heading,
                            informed=False)


def astar(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
          start: Sequence[int], goals: object, window: Sequence[int] | None = None, *,
          kinematics: Kinematics, heading: int | None = None,
          final_heading: int | None = None) -> KinematicPath | None:
    """The modified A* of section 5: :func:`kinematic_search` with the octile heuristic."""
    return kinematic_search(factor, passable, corner_cutting, start, goals, window,
                            kinematics=kinematics, heading=heading, final_heading=final_heading)


def aistar(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
           start: Sequence[int], goals: object, window: Sequence[int] | None = None, *,
           kinematics: Kinematics, heading: int | None = None,
           final_heading: int | None = None) -> KinematicPath | None:
    """The modified A* guided by Ai*'s integer distance map (:mod:`cbr_solvers.aistar`), which
    never overestimates the holonomic cost, so neither a constrained one."""
    return kinematic_search(factor, passable, corner_cutting, start, goals, window,
                            kinematics=kinematics, heading=heading, final_heading=final_heading,
                            heuristic=heuristic_table)


@attrs.frozen
class Sweep:
    """The edge distances of a window from one cell, by a sweep of the modified Dijkstra.

    Forward, ``cost[y - y0, x - x0, a]`` is d_s of the edge entering (x, y) in direction a from
    ``origin`` (the robot's start). Reversed, it is the least cost from (x, y), leaving in
    direction a, to ``origin`` (the goal), arriving there so that P holds with the final
    heading: the search runs from the goal backwards, with the turn table mirrored, which
    reverses every path and manoeuvre exactly, since step costs and moves are symmetric. Both
    are inf where no path exists. :meth:`path` reads a path back.
    """

    origin: tuple[int, int]
    window: tuple[int, int, int, int]
    reverse: bool
    cost: np.ndarray
    parent: np.ndarray = attrs.field(repr=False)

    def path(self, cell: Sequence[int], direction: int) -> np.ndarray:
        """The cells from the origin to ``cell`` entered in ``direction`` (reversed: from
        ``cell``, leaving in ``direction``, to the origin), manoeuvres included."""
        x0, y0, x1, y1 = self.window
        ww, cells = x1 - x0 + 1, (x1 - x0 + 1) * (y1 - y0 + 1)
        x, y = int(cell[0]), int(cell[1])
        if not np.isfinite(self.cost[y - y0, x - x0, direction]):
            raise ValueError(f"no path reaches {(x, y)} in direction {direction}")
        state = 8 * ((y - y0) * ww + (x - x0)) + ((direction + 4) % 8 if self.reverse
                                                  else direction)
        path = _read_path(self.parent, state, self.origin[0], self.origin[1], x0, y0, ww,
                          8 * cells, 8 * cells + 1)
        return path[::-1].copy() if self.reverse else path


def sweep(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, origin: Sequence[int],
          window: Sequence[int], *, kinematics: Kinematics, heading: int | None = None,
          reverse: bool = False) -> Sweep:
    """Every edge distance of ``window`` from ``origin`` for a robot of ``kinematics``.

    Forward, ``heading`` is the robot's initial heading at the origin; reversed, the origin is
    the goal and ``heading`` the final heading (None for any). The window must hold the origin.
    """
    factor, passable, (ox, oy), _, (x0, y0, x1, y1) = checked_arguments(
        factor, passable, origin, [origin], window)
    if not (x0 <= ox <= x1 and y0 <= oy <= y1):
        raise ValueError(f"the window {(x0, y0, x1, y1)} does not hold the origin {(ox, oy)}")
    check_heading(heading)
    turns = kinematics.table
    start = heading
    if reverse:
        # the mirrored table: arriving in y+4 and leaving in x+4 reverses leaving x after y
        mirror = (np.arange(8) + 4) % 8
        turns = np.ascontiguousarray(turns[np.ix_(mirror, mirror)].T)
        start = None if heading is None else (heading + 4) % 8
    ww, wh = x1 - x0 + 1, y1 - y0 + 1
    stamp, dist, parent, _, generation = _WORKSPACE.take(8 * ww * wh + 2)
    _search(factor, passable, bool(corner_cutting), ox, oy, -1 if start is None else start,
            -1, -1, -1, x0, y0, x1, y1, False, 1.0, np.empty(0), turns, kinematics.manoeuvres,
            stamp, dist, parent, generation)
    states = 8 * ww * wh
    reached = stamp[:states] == generation + 1
    cost = np.where(reached, dist[:states], np.inf).reshape(wh, ww, 8)
    if reverse:
        # indexed by the direction of leaving a cell, the reverse of the one it was entered by
        cost = np.roll(cost, 4, axis=2)
    return Sweep((ox, oy), (x0, y0, x1, y1), reverse, cost, parent[:states + 2].copy())
