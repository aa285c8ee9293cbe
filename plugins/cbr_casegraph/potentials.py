"""Landmark potentials of the case graph: the ALT bound of its graph search.

On a maze or a map of rooms the straight-line (octile) distance says little about a path's
cost in the case graph, and its A* settles most of the graph (25,000 of 31,500 vertices per
query on the 512x512 maze). ALT (Goldberg & Harrelson, 2005) bounds the cost left by the
triangle inequality over distances from a few landmark vertices. Here the distances are the
graph's own, kept per vertex in a float64 table (count x landmarks).

**What the search needs of the table.** Not exact distances: a table ``D`` whose column for a
landmark changes across every edge of finite cost w by at most w (``|D(u) - D(v)| <= w``) gives
a consistent potential ``D(t) - D(v)`` towards any vertex t, and so does any maximum of such
terms. Exact graph distances have that property, and it survives what retention and forgetting
do to the graph, once repaired:

- an edge removed, or a vertex merged away (its two edges become one of their summed cost),
  leaves every remaining edge's difference as it was;
- an edge added, or made cheaper by a changed map, can break it; :func:`repair` lowers
  the entries across such edges and propagates the decrease, as Dijkstra does from several
  sources, until every edge holds again. It starts from the ends of the edges whose id is new
  or whose cost changed, so its work follows what changed, not the graph's size.

The table is rebuilt from scratch (landmarks chosen again, farthest first) when the graph has
doubled its vertices since the last build, so that new regions get landmarks of their own at an
amortised cost of a few sweeps per vertex; in between it is repaired. The query extends the
table to its virtual vertices (:func:`cbr_casegraph.query.extend`), and
``tests/casegraph/test_query.py`` checks the search against brute force on graphs grown and
pruned in between queries.
"""

from __future__ import annotations

import numpy as np

from cbr_casegraph.index import Adjacency
from cbr_grid.search_base import pop, push_grown
from cbr_kernels import njit

LANDMARKS = 8
"""How many landmark vertices the table holds."""


@njit
def _spread(indptr: np.ndarray, target: np.ndarray, weight: np.ndarray, dist: np.ndarray,
            column: int, seeds: np.ndarray) -> None:
    """Dijkstra over the CSR arrays from the ``seeds`` (their entries in ``dist[:, column]``,
    the infinite ones left out), lowering the column wherever a path through an edge is
    cheaper."""
    keys = np.empty(64, dtype=np.float64)
    items = np.empty(64, dtype=np.int64)
    size = np.int64(0)
    for i in range(seeds.shape[0]):
        v = seeds[i]
        if dist[v, column] < np.inf:
            keys, items = push_grown(keys, items, size, dist[v, column], v)
            size += 1
    while size > 0:
        key = keys[0]
        v = pop(keys, items, size)
        size -= 1
        if key > dist[v, column]:
            continue
        for k in range(indptr[v], indptr[v + 1]):
            u = target[k]
            g = key + weight[k]
            if g < dist[u, column]:
                dist[u, column] = g
                keys, items = push_grown(keys, items, size, g, u)
                size += 1


@njit
def build(indptr: np.ndarray, target: np.ndarray, weight: np.ndarray, count: int
          ) -> np.ndarray:
    """The (vertices, count) table of distances from ``count`` landmarks picked farthest first:
    the first the vertex farthest from the first vertex with edges, each next the one whose
    nearest landmark is farthest. Vertices a landmark does not reach hold inf in its column."""
    n = indptr.shape[0] - 1
    dist = np.full((n, count), np.inf)
    first = -1
    for v in range(n):
        if indptr[v + 1] > indptr[v]:
            first = v
            break
    if first < 0:
        return dist
    dist[first, 0] = 0.0
    _spread(indptr, target, weight, dist, 0, np.array([first]))
    nearest = dist[:, 0].copy()
    for k in range(count):
        chosen, far = first, -1.0
        for v in range(n):
            if nearest[v] < np.inf and nearest[v] > far:
                chosen, far = v, nearest[v]
        for v in range(n):
            dist[v, k] = np.inf
        dist[chosen, k] = 0.0
        _spread(indptr, target, weight, dist, k, np.array([chosen]))
        for v in range(n):
            nearest[v] = dist[v, k] if k == 0 else min(nearest[v], dist[v, k])
    return dist


@njit
def repair(indptr: np.ndarray, target: np.ndarray, weight: np.ndarray, dist: np.ndarray,
           seeds: np.ndarray) -> None:
    """Lower ``dist`` in place until ``dist[u] <= dist[v] + w`` across every edge (v, u), in
    every column, when it held already across every edge but those at the ``seeds``: the
    decreases start there and spread as far as they change anything."""
    for column in range(dist.shape[1]):
        _spread(indptr, target, weight, dist, column, seeds)


class Potentials:
    """The landmark table of one case graph, kept valid as its adjacency changes."""

    def __init__(self) -> None:
        # rows beyond the graph's vertex slots are room to grow into
        self._table = np.zeros((0, LANDMARKS))
        self._slots = 0
        self._cells = np.zeros((0, 2), dtype=np.int64)
        # the cost of each edge id when the table was last made valid (nan: no such edge)
        self._costs = np.zeros(0)
        self._built_for = 0
        self._adjacency: Adjacency | None = None

    def of(self, adjacency: Adjacency) -> np.ndarray:
        """The table for ``adjacency``: rebuilt when the graph has doubled, else repaired."""
        if adjacency is not self._adjacency:
            live = int(np.count_nonzero(np.diff(adjacency.indptr)))
            if live > 2 * self._built_for:
                self._table = build(adjacency.indptr, adjacency.target, adjacency.weight,
                                    LANDMARKS)
                self._built_for = live
            else:
                self._repair(adjacency)
            self._slots = len(adjacency.xy)
            self._costs = np.full(int(adjacency.edge.max(initial=-1)) + 1, np.nan)
            self._costs[adjacency.edge] = adjacency.weight
            self._cells = adjacency.xy
            self._adjacency = adjacency
        return self._table[:self._slots]

    def _repair(self, adjacency: Adjacency) -> None:
        slots = len(adjacency.xy)
        if slots > len(self._table):
            grown = np.full((max(slots, 2 * len(self._table)), LANDMARKS), np.inf)
            grown[:self._slots] = self._table[:self._slots]
            self._table = grown
        self._table[self._slots:slots] = np.inf
        known = adjacency.edge < len(self._costs)
        before = self._costs[np.where(known, adjacency.edge, 0)]
        # new edges and repriced ones, at both ends (the CSR lists each edge both ways)
        seeds = np.unique(adjacency.target[~known | (before != adjacency.weight)])
        # a slot that now holds another cell is a new vertex: its old entries say nothing
        old = seeds[seeds < self._slots]
        moved = old[np.any(self._cells[old] != adjacency.xy[old], axis=1)]
        self._table[moved] = np.inf
        repair(adjacency.indptr, adjacency.target, adjacency.weight, self._table, seeds)
