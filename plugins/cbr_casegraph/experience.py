"""The experience-graph planner: weighted A* on the grid, drawn along the case graph's segments.

Phillips, Cohen, Chitta and Likhachev, "E-Graphs: Bootstrapping Planning with Experience
Graphs" (RSS 2012). The search is A* on the 8-connected grid with

    f(s) = g(s) + epsilon · h^E(s)

where h^G(s, t) is the octile distance times the least passable cost factor (no path from s to
t costs less) and the experience heuristic is

    h^E(s) = min( eps_E · h^G(s, goal),  min over v in K of  eps_E · h^G(s, v) + H(v) ).

H(v) is the E-graph heuristic of case graph vertex v: the cheapest way from v to the goal that
rides stored segments at their real cost and jumps, at eps_E times h^G, from the last vertex to
the goal (one A* from the goal over the case graph, towards the start). K is a thinned copy of
the best experience route from the start (the vertex v* minimising eps_E · h^G(start, v) + H(v),
then its ride to the goal). A cell that is a case graph vertex also has the other ends of its stored
segments as successors, at the segments' real cost (infinite, so left out, for a segment that
crosses an obstacle of the current map), so a ride along a stored segment is one expansion.
At eps_E = 1 no term over K undercuts h^G(s, goal) (a ride costs at least h^G of its ends, so
H(v) >= h^G(v, goal), and the triangle inequality does the rest): K is left empty and H is not
searched. For the same reason a vertex of the route whose H is no less than eps_E · h^G(v, goal)
is left out of K: its term is never the least.

**The bound.** Every term of h^E is eps_E-Lipschitz in h^G and h^G(s, s') never exceeds the
cost of a step (or of a shortcut, a straight run of steps) from s to s', so h^E / eps_E is
consistent, whatever K and whatever constants H >= 0; and h^E(goal) = 0. So h^E / eps_E is
admissible (h^E(s) <= eps_E · h^G(s, goal) <= eps_E · h*(s)) and the search is weighted A* with
weight epsilon · eps_E on a consistent admissible heuristic. Without re-expansions such a search
returns a path of cost at most epsilon · eps_E times the optimum (Likhachev, Gordon and Thrun,
"ARA*: Anytime A* with Provable Bounds on Sub-Optimality", NIPS 2003); a shortcut's cost is that
of the grid path it stands for, so the optimum over the grid with shortcuts is the grid's own.
Phillips et al. state the same bound for their planner (the solution cost is no more than
epsilon · eps_E times the optimal cost), from the eps_E-consistency of their h^E.

**The tie rule, and why it keeps the bound.** Among the successors of the cell being expanded,
the first of least f, if its f is at most the expanded cell's, is expanded next, before anything
on the heap (it is held aside instead of pushed); everything else is expanded in the order of f.
The proof above uses one fact about the order of expansion (ARA*'s Theorem 1): when a cell s is
expanded, f(s) <= f(s') for every cell s' on the frontier. The expanded cell's f was the least
on the frontier, so the held successor's, no greater, is the least too: the fact holds, and the
rule only chooses among cells of least f, which the proof leaves in any order. So the bound
holds with the rule, and at epsilon = eps_E = 1 the path is optimal. On a plateau of equal f the
held successor has the larger g (by the step's cost) and so the smaller heuristic term: the
search runs on toward the goal instead of widening the plateau. (A*'s bias tie · h added to f
is proved by a gap between different f of a uniform map, a + b·sqrt(2) with integers a and b,
which epsilon, eps_E and H do not leave. A second heap key for ties, which needs no gap, made
the search about 1.7 times slower on den520d at epsilon = eps_E = 1 and expanded no fewer
cells there.)

**Uniform costs.** When every passable cell has one factor (the least, ``scale``), g is counted
in orthogonal and diagonal steps (two integers in one int64, as A* counts them,
:mod:`cbr_solvers.search`) and no factor is read; a ride adds the steps of its straight segment.
Costs are then in units of ``scale``. With eps_E = 1 the heuristic is counted in steps too and,
at epsilon = 1, f is the length of the summed steps: two cells whose f is the same real number
get the same float, so the tie rule sees every tie and an exact search crosses open ground
expanding only the cells of its path, where it used to expand whole plateaus of equal f.

**Moves** are read from the grid's move masks (one byte a cell, shared with A*:
:func:`cbr_solvers.search.grid_moves`). **Vertices** are found through a bitmap of their cells
with the count of cells marked before each word (two bits a map cell, so most cells are tested
in the first level of cache) and the vertices in the order of their cells, the vertex on a
marked cell being the one at its rank: built once per case graph, no hashing. The working
arrays are 10 bytes a cell, a :class:`~cbr_grid.search_base.CellWorkspace` reused across calls.

Both passes, the search of H over the case graph and the grid search, the path's unwinding, the
cutting of its loops and its cost are one compiled kernel on the ground floor of
:mod:`cbr_grid.search_base`.
"""

from __future__ import annotations

import threading
import weakref
from typing import Any

import attrs
import numpy as np

from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.index import Adjacency
from cbr_grid.costs import SQRT2
from cbr_grid.grid import Grid
from cbr_grid.query import Cell
from cbr_grid.search_base import (
    DX,
    DY,
    INITIAL_HEAP,
    CellWorkspace,
    cell_moves,
    pop,
    pop4,
    push,
    push4,
)
from cbr_kernels import njit
from cbr_kernels.bits import popcount
from cbr_solvers.search import grid_moves, grid_profile
from cbrcore.errors import CbrError

ROUTE_VERTICES = 16
"""Into how many equal parts of its H the start's experience route is thinned for K, which keeps
a vertex per part and the route's two ends: every vertex of K costs one octile distance at each
cell the search reaches, and a route of staircase steps has hundreds."""

_RIDE = 8
"""The parent code of a cell reached by a ride (0-7 are the moves)."""

_LOW = (1 << 32) - 1
_ORTHOGONAL_STEP = 1 << 32
"""A uniform search counts steps in one int64: orthogonal ones above bit 32, diagonal below."""


@attrs.frozen
class ExperiencePath:
    """A path found by the experience-graph search.

    ``path`` is the (n, 2) cell path from start to goal, loops cut out; ``cost`` its cost on the
    map; ``edges`` the ids of the stored segments ridden as shortcuts; ``bound`` the guaranteed
    factor (epsilon · eps_E) over the cheapest path's cost; ``detail`` the work done.
    """

    path: np.ndarray
    cost: float
    edges: tuple[int, ...]
    bound: float
    detail: dict[str, Any]


@njit(inline="always")
def _octile(ax: int, ay: int, bx: int, by: int) -> float:
    dx = abs(ax - bx)
    dy = abs(ay - by)
    return max(dx, dy) + (SQRT2 - 1.0) * min(dx, dy)


@njit(inline="always")
def _length(steps: int) -> float:
    """The length a + b·sqrt(2) of a step count (see ``_ORTHOGONAL_STEP``)."""
    return (steps >> 32) + (steps & _LOW) * SQRT2


@njit(inline="always")
def _octile_steps(ax: int, ay: int, bx: int, by: int) -> int:
    """The octile distance from a to b as a step count."""
    dx = abs(ax - bx)
    dy = abs(ay - by)
    return ((max(dx, dy) - min(dx, dy)) << 32) + min(dx, dy)


@njit
def _grown(keys: np.ndarray, items: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The heap's arrays doubled (called only when full, so that the hot loops do not carry
    arrays reassigned at every push)."""
    return (np.concatenate((keys, np.empty_like(keys))),
            np.concatenate((items, np.empty_like(items))))


@njit
def _experience_heuristic(indptr: np.ndarray, target: np.ndarray, weight: np.ndarray,
                          xy: np.ndarray, sx: int, sy: int, gx: int, gy: int, scale: float,
                          experience: float, route_max: int) -> tuple[np.ndarray, np.ndarray, int]:
    """K and its constants H: the thinned experience route of the start, and vertices settled.

    A jump between cells a and b costs ``experience · scale · octile(a, b)``. The route is the
    cheapest way from the start to the goal that jumps once to a vertex v, rides stored segments
    and jumps to the goal: H(v) is its cost from v, found by A* from the goal (every vertex
    seeded with its jump to the goal) towards the start, guided by ``scale · octile(v, start)``,
    which no ride or jump undercuts, so the heuristic is consistent and the H of every settled
    vertex, the route's among them, is exact. It stops once no vertex left can beat the best
    route seen (at worst the start's own jump to the goal).
    """
    n = indptr.shape[0] - 1
    jump = experience * scale
    best = jump * _octile(sx, sy, gx, gy)
    value = np.full(n, np.inf)
    towards = np.full(n, -1, dtype=np.int64)
    done = np.zeros(n, dtype=np.bool_)
    keys = np.empty(max(n, 1), dtype=np.float64)
    items = np.empty(max(n, 1), dtype=np.int64)
    size = 0
    for v in range(n):
        if indptr[v + 1] == indptr[v]:
            continue  # a free vertex slot has no segment
        seed = jump * _octile(xy[v, 0], xy[v, 1], gx, gy)
        key = seed + scale * _octile(xy[v, 0], xy[v, 1], sx, sy)
        if key < best:  # else no route through v beats the start's own jump
            value[v] = seed
            push(keys, items, size, key, v)  # n slots: every vertex is seeded once at most
            size += 1
    entry = -1
    settled = 0
    while size > 0:
        v = pop(keys, items, size)
        size -= 1
        if done[v]:
            continue
        done[v] = True
        settled += 1
        here = value[v]
        vx, vy = xy[v, 0], xy[v, 1]
        if here + scale * _octile(vx, vy, sx, sy) >= best:
            break
        through = jump * _octile(sx, sy, vx, vy) + here
        if through < best:
            best, entry = through, v
        for k in range(indptr[v], indptr[v + 1]):
            u = target[k]
            g = here + weight[k]
            if done[u] or not g < value[u]:
                continue
            value[u] = g
            towards[u] = v
            if size == keys.shape[0]:
                keys, items = _grown(keys, items)
            push(keys, items, size, g + scale * _octile(xy[u, 0], xy[u, 1], sx, sy), u)
            size += 1
    if entry < 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0), settled
    count = 0
    last = entry
    v = entry
    while v >= 0:
        count += 1
        last = v
        v = towards[v]
    # keep the entry, the last vertex (which jumps to the goal) and vertices spaced evenly
    # along the route's H in between
    spacing = (value[entry] - value[last]) / route_max
    kept = np.empty(min(count, route_max + 2), dtype=np.int64)
    size = 0
    v = entry
    while towards[v] >= 0:
        if size == 0 or (value[kept[size - 1]] - value[v] >= spacing
                         and size < kept.shape[0] - 1):
            kept[size] = v
            size += 1
        v = towards[v]
    kept[size] = v
    size += 1
    return kept[:size], value[kept[:size]], settled


_ONE = np.uint64(1)


@njit
def _vertex_table(xy: np.ndarray, indptr: np.ndarray, w: int, h: int
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the vertices that have a segment are: (marks, before, order). ``marks`` has bit
    ``c % 64`` of word ``c // 64`` set for each flat cell ``c = y · w + x`` holding one,
    ``before`` the number of bits set in the words before each word, and ``order`` the vertices
    by their cells: the vertex on a marked cell is ``order`` at its rank among the marked cells.
    Two bits a map cell, read in the first levels of cache, and 8 bytes a vertex;
    :func:`_vertex_of` reads them."""
    n = indptr.shape[0] - 1
    marks = np.zeros((w * h + 63) >> 6, dtype=np.uint64)
    for v in range(n):
        if indptr[v + 1] > indptr[v]:
            cell = xy[v, 1] * w + xy[v, 0]
            marks[cell >> 6] |= _ONE << np.uint64(cell & 63)
    before = np.empty(marks.shape[0], dtype=np.int64)
    count = 0
    for k in range(marks.shape[0]):
        before[k] = count
        count += popcount(marks[k])
    order = np.empty(count, dtype=np.int64)
    for v in range(n):
        if indptr[v + 1] > indptr[v]:
            order[_rank(marks, before, xy[v, 1] * w + xy[v, 0])] = v
    return marks, before, order


@njit(inline="always")
def _rank(marks: np.ndarray, before: np.ndarray, cell: int) -> int:
    """How many marked cells come before ``cell``."""
    low = (_ONE << np.uint64(cell & 63)) - _ONE
    return before[cell >> 6] + popcount(marks[cell >> 6] & low)


@njit(inline="always")
def _vertex_of(marks: np.ndarray, before: np.ndarray, order: np.ndarray, cell: int) -> int:
    """The vertex on flat cell ``cell``, or -1 (see :func:`_vertex_table`)."""
    if not (marks[cell >> 6] >> np.uint64(cell & 63)) & _ONE:
        return -1
    return order[_rank(marks, before, cell)]


@njit(inline="always")
def _estimate(x: int, y: int, gx: int, gy: int, kx: np.ndarray, ky: np.ndarray,
              constant: np.ndarray, jump: float) -> float:
    """h^E of cell (x, y): the jump to the goal, or to a vertex of K and on from there."""
    best = jump * _octile(x, y, gx, gy)
    for j in range(kx.shape[0]):
        value = jump * _octile(x, y, kx[j], ky[j]) + constant[j]
        if value < best:
            best = value
    return best


@njit(inline="always")
def _priority(x: int, y: int, gx: int, gy: int, count: int, g: float, counted: bool,
              exact: bool, epsilon: float, kx: np.ndarray, ky: np.ndarray,
              constant: np.ndarray, jump: float) -> float:
    """f of a cell (x, y) reached at cost ``g`` (``count`` steps on a uniform map)."""
    if counted:
        left = _octile_steps(x, y, gx, gy)
        return _length(count + left) if exact else g + epsilon * _length(left)
    return g + epsilon * _estimate(x, y, gx, gy, kx, ky, constant, jump)


@njit(inline="always")
def _offer(keys: np.ndarray, items: np.ndarray, size: int, held: int, held_key: float,
           current_key: float, other: int, key: float) -> tuple[int, int, float]:
    """Put a cell on the frontier: held aside when it would be the next one popped (f at most
    that of the cell being expanded and below the one held, -1 for none), the one held before
    then pushed, else pushed. The heap has room. Returns (size, held, held_key)."""
    if key <= current_key and (held < 0 or key < held_key):
        held, held_key, other, key = other, key, held, held_key
        if other < 0:
            return size, held, held_key
    push4(keys, items, size, key, other)
    return size + 1, held, held_key


@njit
def _search(factor: np.ndarray, passable: np.ndarray, moves: np.ndarray, corner_cutting: bool,
            uniform: bool, scale: float, sx: int, sy: int, gx: int, gy: int,
            marks: np.ndarray, before: np.ndarray, order: np.ndarray, indptr: np.ndarray,
            target: np.ndarray, weight: np.ndarray, edge: np.ndarray, xy: np.ndarray,
            epsilon: float,
            experience: float, route_max: int, stamp: np.ndarray, dist: np.ndarray,
            steps: np.ndarray, parent: np.ndarray, ride_from: np.ndarray,
            ride_edge: np.ndarray, generation: int
            ) -> tuple[bool, np.ndarray, np.ndarray, float, int, int, int]:
    """The experience-graph search from (sx, sy) to (gx, gy) on the whole grid.

    Returns (found, path, shortcut edges, path cost, cells expanded, vertices settled by H,
    size of K); the path has its loops cut out and its cost is counted on the map. ``factor``
    is the grid's factor array raveled, ``moves`` the grid's move masks or empty (each cell's
    worked out), ``uniform`` whether every passable factor is ``scale`` (see the module's
    docstring), ``marks``, ``before`` and ``order`` the table of :func:`_vertex_table`.

    ``stamp``, ``dist`` (``steps``, the same memory as int64) and ``parent`` are a
    :class:`~cbr_grid.search_base.CellWorkspace`'s: a cell is reached iff ``stamp ==
    generation``, settled iff ``generation + 1``; ``parent`` is the move that reached it or
    ``_RIDE``, and then ``ride_from`` and ``ride_edge`` (one slot per vertex) hold the vertex
    the ride left and the segment ridden. Nothing is cleared between searches.
    """
    w = passable.shape[1]
    nothing = np.empty((0, 2), dtype=np.int64), np.empty(0, dtype=np.int64)
    if experience > 1.0:
        route, constant, settled_vertices = _experience_heuristic(
            indptr, target, weight, xy, sx, sy, gx, gy, scale, experience, route_max)
    else:  # no term over K undercuts the jump to the goal (module docstring)
        route, constant, settled_vertices = np.zeros(0, np.int64), np.zeros(0), 0
    if not (passable[sy, sx] and passable[gy, gx]):
        return False, nothing[0], nothing[1], np.inf, 0, settled_vertices, route.shape[0]
    # A uniform search counts in units of scale; ``counted`` says whether the heuristic is a
    # step count too (eps_E = 1), ``exact`` whether f is then the length of g's and h's steps.
    jump = experience if uniform else experience * scale
    if uniform:
        constant = constant / scale
    # A vertex of K whose H is no less than the jump from it to the goal never undercuts the
    # jump from any cell (triangle inequality): left out, h^E is the same at every cell.
    useful = np.zeros(route.shape[0], dtype=np.bool_)
    for j in range(route.shape[0]):
        useful[j] = constant[j] < jump * _octile(xy[route[j], 0], xy[route[j], 1], gx, gy)
    kept = np.flatnonzero(useful)
    kx = np.empty(kept.shape[0], dtype=np.int64)
    ky = np.empty(kept.shape[0], dtype=np.int64)
    for j in range(kept.shape[0]):
        kx[j], ky[j] = xy[route[kept[j]], 0], xy[route[kept[j]], 1]
    constant = constant[kept]
    counted = uniform and kx.shape[0] == 0 and experience == 1.0
    exact = counted and epsilon == 1.0
    masked = moves.shape[0] > 0
    grid_step = DY * w + DX
    settled = generation + 1
    start = sy * w + sx
    goal = gy * w + gx

    keys = np.empty(INITIAL_HEAP, dtype=np.float64)
    items = np.empty(INITIAL_HEAP, dtype=np.int64)
    stamp[start] = generation
    steps[start] = 0  # also dist 0.0: both are all-zero bits
    size = 0
    expanded = 0
    held, held_key = start, 0.0  # the start, the first cell popped
    while size > 0 or held >= 0:
        if held >= 0:
            cell, current_key = held, held_key
            held = -1
        else:
            cell, current_key = items[0], keys[0]
            pop4(keys, items, size)
            size -= 1
        if stamp[cell] == settled:
            continue  # no re-expansions: the bound's proof needs none
        stamp[cell] = settled
        expanded += 1
        if cell == goal:
            break
        cy = cell // w
        cx = cell - cy * w
        mask = np.int64(moves[cell]) if masked else cell_moves(passable, corner_cutting, cx, cy)
        here_steps = steps[cell]
        here = dist[cell]
        fc = 0.0 if uniform else factor[cell]
        v = _vertex_of(marks, before, order, cell)
        rides = indptr[v + 1] - indptr[v] if v >= 0 else 0
        while size + 8 + rides > keys.shape[0]:  # room for every push of this expansion
            keys, items = _grown(keys, items)
        count = 0
        for d in range(8):
            if not (mask >> d) & 1:
                continue
            other = cell + grid_step[d]
            mark = stamp[other]
            if mark == settled:
                continue
            if uniform:
                count = here_steps + (1 if d >= 4 else _ORTHOGONAL_STEP)
                g = _length(count)
                if mark == generation and g >= _length(steps[other]):
                    continue
                steps[other] = count
            else:
                g = here + (SQRT2 if d >= 4 else 1.0) * (fc + factor[other]) * 0.5
                if mark == generation and g >= dist[other]:
                    continue
                dist[other] = g
            stamp[other] = generation
            parent[other] = d
            key = _priority(cx + DX[d], cy + DY[d], gx, gy, count, g, counted, exact,
                                 epsilon, kx, ky, constant, jump)
            size, held, held_key = _offer(keys, items, size, held, held_key, current_key,
                                          other, key)
        for k in range(indptr[v], indptr[v] + rides):
            if not weight[k] < np.inf:
                continue  # the segment crosses an obstacle of the current map
            u = target[k]
            nx, ny = xy[u, 0], xy[u, 1]
            other = ny * w + nx
            mark = stamp[other]
            if mark == settled:
                continue
            if uniform:
                count = here_steps + _octile_steps(cx, cy, nx, ny)
                g = _length(count)
                if mark == generation and g >= _length(steps[other]):
                    continue
                steps[other] = count
            else:
                g = here + weight[k]
                if mark == generation and g >= dist[other]:
                    continue
                dist[other] = g
            stamp[other] = generation
            parent[other] = _RIDE
            ride_from[u] = v
            ride_edge[u] = edge[k]
            key = _priority(nx, ny, gx, gy, count, g, counted, exact, epsilon, kx, ky,
                                 constant, jump)
            size, held, held_key = _offer(keys, items, size, held, held_key, current_key,
                                          other, key)
    if stamp[goal] != settled:
        return False, nothing[0], nothing[1], np.inf, expanded, settled_vertices, kx.shape[0]
    path, rides_taken = _unwound(parent, ride_from, ride_edge, marks, before, order, xy,
                                 start, goal, w)
    path = _without_loops(path, steps, w)
    total = 0.0
    counted_steps = 0
    for i in range(path.shape[0] - 1):
        a = path[i, 1] * w + path[i, 0]
        b = path[i + 1, 1] * w + path[i + 1, 0]
        diagonal = path[i, 0] != path[i + 1, 0] and path[i, 1] != path[i + 1, 1]
        if uniform:
            counted_steps += 1 if diagonal else _ORTHOGONAL_STEP
        else:
            total += (SQRT2 if diagonal else 1.0) * (factor[a] + factor[b]) * 0.5
    if uniform:
        total = _length(counted_steps) * scale
    return True, path, rides_taken, total, expanded, settled_vertices, kx.shape[0]


@njit
def _unwound(parent: np.ndarray, ride_from: np.ndarray, ride_edge: np.ndarray,
             marks: np.ndarray, before: np.ndarray, order: np.ndarray, xy: np.ndarray,
             start: int, goal: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """The cells from start to goal, each ride laid out as its straight run of cells, and the
    stored edges ridden."""
    n = 1
    rides = 0
    cell = goal
    while cell != start:
        if parent[cell] == _RIDE:
            u = ride_from[_vertex_of(marks, before, order, cell)]
            back = xy[u, 1] * w + xy[u, 0]
            rides += 1
        else:
            back = cell - (DY[parent[cell]] * w + DX[parent[cell]])
        n += max(abs(cell % w - back % w), abs(cell // w - back // w))
        cell = back
    path = np.empty((n, 2), dtype=np.int64)
    edges = np.empty(rides, dtype=np.int64)
    i = n - 1
    cell = goal
    path[i, 0], path[i, 1] = cell % w, cell // w
    while cell != start:
        if parent[cell] == _RIDE:
            v = _vertex_of(marks, before, order, cell)
            u = ride_from[v]
            back = xy[u, 1] * w + xy[u, 0]
            rides -= 1
            edges[rides] = ride_edge[v]
        else:
            back = cell - (DY[parent[cell]] * w + DX[parent[cell]])
        bx, by = back % w, back // w
        x, y = cell % w, cell // w
        dx, dy = np.sign(bx - x), np.sign(by - y)
        for _ in range(max(abs(bx - x), abs(by - y))):
            x += dx
            y += dy
            i -= 1
            path[i, 0], path[i, 1] = x, y
        cell = back
    return path, edges


@njit
def _without_loops(path: np.ndarray, position: np.ndarray, w: int) -> np.ndarray:
    """``path`` with every loop cut out (a ride may pass cells the path also reaches
    otherwise): when a cell comes back, everything since its first visit is dropped, so the
    result is a connected path of the same steps and never costs more. ``position`` is a
    working array over the grid's cells (the search's, once it is done)."""
    for i in range(path.shape[0]):
        position[path[i, 1] * w + path[i, 0]] = -1
    kept = np.empty_like(path)
    size = 0
    for i in range(path.shape[0]):
        cell = path[i, 1] * w + path[i, 0]
        first = position[cell]
        if first >= 0:
            for j in range(first + 1, size):
                position[kept[j, 1] * w + kept[j, 0]] = -1
            size = first + 1
            continue
        position[cell] = size
        kept[size, 0], kept[size, 1] = path[i, 0], path[i, 1]
        size += 1
    return kept[:size]


class _Workspace(threading.local):
    """The search's working arrays, kept per thread: a cell workspace and, per vertex slot,
    the ride that reached it."""

    def __init__(self) -> None:
        self.cells = CellWorkspace()
        self.ride_from = np.empty(0, dtype=np.int64)
        self.ride_edge = np.empty(0, dtype=np.int64)

    def rides(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        if self.ride_from.shape[0] < n:
            self.ride_from = np.empty(max(n, 64), dtype=np.int64)
            self.ride_edge = np.empty(max(n, 64), dtype=np.int64)
        return self.ride_from, self.ride_edge


_WORKSPACE = _Workspace()


@attrs.frozen
class _GridInputs:
    """What the kernel reads of a grid, worked out once per grid."""

    factor: np.ndarray  # raveled
    moves: np.ndarray
    uniform: bool
    scale: float


_GRIDS: weakref.WeakKeyDictionary[Grid, _GridInputs] = weakref.WeakKeyDictionary()
# id(adjacency) -> (weak reference, table): an adjacency compares by its arrays, so it is no
# dictionary key itself; the reference tells a live one from a new one at a reused id
_TABLES: dict[int, tuple[weakref.ref, tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}
_TABLES_KEPT = 4


def _grid_inputs(grid: Grid) -> _GridInputs:
    known = _GRIDS.get(grid)
    if known is None:
        least, most = grid_profile(grid.factor, grid.passable)
        scale = least if np.isfinite(least) else 1.0
        known = _GridInputs(grid.factor.reshape(-1), grid_moves(grid.passable,
                                                                grid.corner_cutting),
                            bool(least == most), float(scale))
        _GRIDS[grid] = known
    return known


def _table(adjacency: Adjacency, width: int, height: int
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    known = _TABLES.get(id(adjacency))
    if known is not None and known[0]() is adjacency:
        return known[1]
    for old in [key for key, (ref, _) in _TABLES.items() if ref() is None]:
        del _TABLES[old]
    if len(_TABLES) >= _TABLES_KEPT:
        _TABLES.pop(next(iter(_TABLES)))
    table = _vertex_table(adjacency.xy, adjacency.indptr, width, height)
    _TABLES[id(adjacency)] = (weakref.ref(adjacency), table)
    return table


def plan(graph: CaseGraph, start: Cell, goal: Cell, epsilon: float, experience_factor: float,
         *, route_vertices: int = ROUTE_VERTICES) -> ExperiencePath | None:
    """The experience-graph path from ``start`` to ``goal`` on ``graph``'s map, or None when
    the map does not connect them. Its cost is at most ``epsilon · experience_factor`` times the
    cheapest path's. CbrError for a factor below 1 or cells off the grid."""
    if not (epsilon >= 1.0 and experience_factor >= 1.0):
        raise CbrError(f"the experience-graph search: epsilon {epsilon!r} and "
                       f"experience_factor {experience_factor!r} must both be at least 1")
    grid = graph.grid
    for name, (x, y) in (("start", start), ("goal", goal)):
        if not (0 <= x < grid.width and 0 <= y < grid.height):
            raise CbrError(f"the experience-graph search: {name} {(x, y)} is outside the "
                           f"{grid.width}x{grid.height} grid")
    inputs = _grid_inputs(grid)
    adjacency = graph.adjacency()
    marks, before, order = _table(adjacency, grid.width, grid.height)
    stamp, dist, parent, generation = _WORKSPACE.cells.take(grid.passable.size)
    ride_from, ride_edge = _WORKSPACE.rides(adjacency.indptr.shape[0])
    found, path, edges, cost, expanded, settled, route = _search(
        inputs.factor, grid.passable, inputs.moves, grid.corner_cutting, inputs.uniform,
        inputs.scale, int(start[0]), int(start[1]), int(goal[0]), int(goal[1]), marks, before,
        order, adjacency.indptr, adjacency.target, adjacency.weight, adjacency.edge,
        adjacency.xy,
        float(epsilon), float(experience_factor), int(route_vertices), stamp, dist,
        dist.view(np.int64), parent, ride_from, ride_edge, generation)
    if not found:
        return None
    detail = {"expanded": int(expanded), "vertices_settled": int(settled),
              "route_vertices": int(route), "shortcuts": len(edges)}
    return ExperiencePath(path, float(cost), tuple(dict.fromkeys(edges.tolist())),
                          float(epsilon * experience_factor), detail)
