"""The modified Dijkstra and A* of section 5 on a weighted directed graph, compiled.

Each edge e = (i, j) has a weight F(i, j), the direction in which the robot leaves i along it
and the one in which it arrives at j (equal for a straight edge: the paper's δ(i, j)), and the
cost of the part of it a manoeuvre at i uses, out and back. A departure direction of -1 puts no
condition on the turn into the edge (an edge whose own search already started from the robot's
heading), an arrival direction of -1 none on the turn out of it. The search itself is the one of
:mod:`cbr_solvers.kinematic_search`, over explicit edges: the case graph's, or a hand-made graph.
"""

from __future__ import annotations

import attrs
import numpy as np
from numpy.typing import ArrayLike

from cbr_grid.costs import SQRT2
from cbr_grid.directions import between, check_heading
from cbr_grid.search_base import pop, push_grown
from cbr_kernels import njit
from cbr_kinematics.models import Kinematics
from cbr_solvers.manoeuvres import CODES, leave_costs


def _int_array(values: ArrayLike) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(values, dtype=np.int64).reshape(-1))


def _float_array(values: ArrayLike) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(values, dtype=np.float64).reshape(-1))


def _check_ends(tails: np.ndarray, heads: np.ndarray, n: int) -> None:
    """ValueError unless every edge's tail and head is a vertex 0..n-1."""
    for name, ends in (("tails", tails), ("heads", heads)):
        if len(ends) and not (ends.min() >= 0 and ends.max() < n):
            raise ValueError(f"{name} must be vertices 0..{n - 1}")


@attrs.frozen
class DirectedGraph:
    """A weighted directed graph whose edges carry directions, for the edge-based searches.

    ``tails``, ``heads``, ``weights``, ``departures``, ``arrivals`` and ``parts`` hold one
    entry per edge; ``xy`` one (x, y) position per vertex, for A*'s octile heuristic, which
    ``scale`` multiplies (it must not exceed the cost of a unit of octile distance in the
    graph). Build one with :meth:`of`.
    """

    tails: np.ndarray
    heads: np.ndarray
    weights: np.ndarray
    departures: np.ndarray
    arrivals: np.ndarray
    parts: np.ndarray
    xy: np.ndarray
    scale: float = 1.0
    # edges by tail: the order and the CSR offsets into it
    order: np.ndarray = attrs.field(init=False)
    indptr: np.ndarray = attrs.field(init=False)

    def __attrs_post_init__(self) -> None:
        m, n = len(self.tails), len(self.xy)
        for name in ("heads", "weights", "departures", "arrivals", "parts"):
            if len(getattr(self, name)) != m:
                raise ValueError(f"{name} has {len(getattr(self, name))} entries for {m} edges")
        _check_ends(self.tails, self.heads, n)
        for name in ("departures", "arrivals"):
            values = getattr(self, name)
            if m and not ((values >= -1) & (values < 8)).all():
                raise ValueError(f"{name} must be directions 0-7 or -1")
        if m and not ((self.weights > 0) & ~np.isnan(self.weights)).all():
            raise ValueError("weights must be positive (inf for an edge that cannot be used)")
        if m and not (self.parts > 0).all():
            raise ValueError("parts must be positive (inf for an edge no manoeuvre may use)")
        order = np.argsort(self.tails, kind="stable")
        indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(self.tails, minlength=n), out=indptr[1:])
        object.__setattr__(self, "order", order.astype(np.int64))
        object.__setattr__(self, "indptr", indptr)

    @classmethod
    def of(cls, xy: ArrayLike, tails: ArrayLike, heads: ArrayLike, weights: ArrayLike, *,
           departures: ArrayLike | None = None, arrivals: ArrayLike | None = None,
           parts: ArrayLike | None = None, scale: float = 1.0) -> DirectedGraph:
        """A graph of the vertices at ``xy`` and the edges tails[k] -> heads[k].

        Without ``departures`` every edge is straight: its direction is that of the step from
        its tail's position towards its head's (which must lie on one of the 8 grid
        directions), and ``arrivals`` defaults to ``departures``. ``parts`` defaults to twice
        each edge's weight: a manoeuvre drives the whole edge out and back.
        """
        xy = np.ascontiguousarray(np.asarray(xy, dtype=np.int64).reshape(-1, 2))
        tails, heads = _int_array(tails), _int_array(heads)
        weights = _float_array(weights)
        if departures is None:
            _check_ends(tails, heads, len(xy))  # before they index xy
            departures = between(xy[tails], xy[heads])
        departures = _int_array(departures)
        arrivals = departures if arrivals is None else _int_array(arrivals)
        parts = 2.0 * weights if parts is None else _float_array(parts)
        return cls(tails, heads, weights, departures, arrivals, parts, xy, float(scale))


@attrs.frozen
class GraphPath:
    """A path found by :func:`graph_search`.

    ``edges`` are the edge indices from the start to the goal; ``manoeuvres[k]`` is the code
    (:mod:`cbr_solvers.manoeuvres`) of the manoeuvre made at the tail of ``edges[k]`` before
    driving it, ``final`` the one made at the goal to leave in the required final heading.
    ``cost`` includes every manoeuvre; ``expanded`` counts the edges settled.
    """

    edges: tuple[int, ...]
    manoeuvres: tuple[int, ...]
    final: int
    cost: float
    expanded: int


@njit
def _search(indptr: np.ndarray, order: np.ndarray, heads: np.ndarray, weights: np.ndarray,
            departures: np.ndarray, arrivals: np.ndarray, parts: np.ndarray, xy: np.ndarray,
            source: int, heading: int, goal: int, final: int, turns: np.ndarray,
            manoeuvres: int, informed: bool, scale: float
            ) -> tuple[bool, float, np.ndarray, np.ndarray, int]:
    """The edge-based search over explicit edges; states are edge indices, then the fictitious
    start edge (s', s) and goal edge (g, g'). Returns (found, cost, chain, codes, expanded):
    the states from the first edge to the last (the goal edge included when ``final`` >= 0)
    and the manoeuvre code before each."""
    m = heads.shape[0]
    src, terminal = m, m + 1
    dist = np.full(m + 2, np.inf)
    parent = np.full(m + 2, -1, dtype=np.int64)
    closed = np.zeros(m + 2, dtype=np.bool_)
    entering = 0
    for e in range(m):
        if heads[e] == goal and weights[e] < np.inf:
            entering += 1
    keys = np.empty(64, dtype=np.float64)
    items = np.empty(64, dtype=np.int64)
    dist[src] = 0.0
    keys[0] = 0.0
    items[0] = src
    size = 1
    expanded = 0
    best = -1
    settled_goal = 0
    out_cost = np.empty(8)
    extra = np.empty(8)
    code = np.zeros(8, dtype=np.int64)
    gx, gy = xy[goal, 0], xy[goal, 1]
    while size > 0:
        state = pop(keys, items, size)
        size -= 1
        if closed[state]:
            continue
        closed[state] = True
        expanded += 1
        if state == terminal:
            best = terminal
            break
        if state == src:
            v, arrival = source, heading
        else:
            v, arrival = heads[state], arrivals[state]
        if v == goal and final < 0:
            if state == src:
                best = src
                break
            if best < 0:
                best = state
            settled_goal += 1
            if settled_goal == entering:
                break
        here = dist[state]
        lo, hi = indptr[v], indptr[v + 1]
        out_cost[:] = np.inf
        for k in range(lo, hi):
            e = order[k]
            d = departures[e]
            if d >= 0 and weights[e] < np.inf and parts[e] < out_cost[d]:
                out_cost[d] = parts[e]
        leave_costs(arrival, out_cost, turns, manoeuvres, extra, code)
        if v == goal and final >= 0 and not closed[terminal]:
            add = extra[final]
            how = code[final]
            if arrival < 0:
                add, how = 0.0, 0
            g = here + add
            if g < dist[terminal]:
                dist[terminal] = g
                parent[terminal] = state * CODES + how
                keys, items = push_grown(keys, items, size, g, terminal)
                size += 1
        for k in range(lo, hi):
            e = order[k]
            if closed[e] or not weights[e] < np.inf:
                continue
            d = departures[e]
            add, how = 0.0, 0
            if d >= 0:
                add, how = extra[d], code[d]
            if add == np.inf:
                continue
            g = here + add + weights[e]
            if g >= dist[e]:
                continue
            dist[e] = g
            parent[e] = state * CODES + how
            key = g
            if informed:
                u = heads[e]
                dx, dy = abs(xy[u, 0] - gx), abs(xy[u, 1] - gy)
                key += (max(dx, dy) + (SQRT2 - 1.0) * min(dx, dy)) * scale
            keys, items = push_grown(keys, items, size, key, e)
            size += 1
    empty = np.zeros(0, dtype=np.int64)
    if best < 0:
        return False, np.inf, empty, empty, expanded
    count = 0
    state = best
    while state != src:
        count += 1
        state = parent[state] // CODES
    chain = np.empty(count, dtype=np.int64)
    codes = np.empty(count, dtype=np.int64)
    state = best
    for i in range(count - 1, -1, -1):
        chain[i] = state
        codes[i] = parent[state] % CODES
        state = parent[state] // CODES
    return True, dist[best], chain, codes, expanded


def graph_search(graph: DirectedGraph, source: int, goal: int, kinematics: Kinematics, *,
                 heading: int | None = None, final_heading: int | None = None,
                 informed: bool = True) -> GraphPath | None:
    """The cheapest path from vertex ``source`` to vertex ``goal`` of ``graph`` that a robot of
    ``kinematics`` can drive, starting in direction ``heading`` (None: any) and able to drive
    on from the goal in direction ``final_heading`` (None: any). ``informed`` selects the
    modified A* over the modified Dijkstra. None when no path exists.
    """
    n = len(graph.xy)
    for name, vertex in (("source", source), ("goal", goal)):
        if not 0 <= vertex < n:
            raise ValueError(f"{name} {vertex} is not a vertex 0..{n - 1}")
    check_heading(heading)
    check_heading(final_heading, "final_heading")
    found, cost, chain, codes, expanded = _search(
        graph.indptr, graph.order, graph.heads, graph.weights, graph.departures,
        graph.arrivals, graph.parts, graph.xy, int(source),
        -1 if heading is None else int(heading), int(goal),
        -1 if final_heading is None else int(final_heading), kinematics.table,
        kinematics.manoeuvres, bool(informed), float(graph.scale))
    if not found:
        return None
    chain, codes = chain.tolist(), codes.tolist()
    final = 0
    if chain and chain[-1] == len(graph.heads) + 1:
        final = codes.pop()
        chain.pop()
    return GraphPath(tuple(chain), tuple(codes), final, float(cost), int(expanded))
