"""The case graph: straight path segments as cases, meeting only at their end points.

Vertices are cells; an edge is a straight segment (see :mod:`cbr_casegraph.geometry`) between
two vertices whose interior cells belong to no other edge and are no vertex. Two grids of the map's
size index it: ``vertex_at`` (the vertex on each cell, or -1) and ``owner`` (the edge whose
interior covers each cell, or -1), so "which cases does this cell touch" costs one lookup and a
path is cut into new segments with array operations; a table of the edge leaving each vertex in
each of the 8 directions answers "which cases meet at this vertex". Together they are the spatial
index of the segments' ends that eq. (12) needs: the stored segments similar to a new one have an
end in a small square around the new one's first end, so retaining a path costs in proportion to
the path, not to the graph.

Ids are int32 (vertices, edges, cell coordinates): a map of up to 2^31 cells has fewer vertices
and live edges than cells, and an edge id from a store that ran past 2^31 - 1 is refused with a
CbrError rather than wrapped. The graph keeps 8 bytes per map cell, 40 per vertex and 41 per
edge id (see docs/casegraph.md, "Memory").

A segment is never stored twice over the same cells: where a retained path runs along a stored
edge it reuses that edge, where it crosses or leaves one the edge is split there, and the path's
own new stretches are cut at their turns (eq. 7 of the papers). Each edge carries its cost under
the grid's step cost contract (``cbr_grid.costs``), the mean risk of its cells, its use count and
its creation stamp. The cost is infinite while a cell of the edge is an obstacle on the current
map, which keeps the edge out of every search until the map clears or the edge is forgotten.

The graph writes through to a case base (:class:`cbrcore.casebase.store.CaseStore`) when it has
one: every edge is a case of kind ``segment`` whose id is the edge's id, so the graph survives
across runs and commits with the engine's learn transaction. Without a store (experiments that
build graphs in bulk) edges are numbered by the graph itself.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence

import attrs
import numpy as np
from numpy.typing import ArrayLike

from cbr_casegraph.geometry import (
    direction,
    is_straight,
    segment_cells,
)
from cbr_grid.distances import Distance
from cbr_grid.distances import distance as distance_function
from cbr_grid.grid import Grid
from cbr_grid.query import without_loops
from cbrcore.casebase.store import CaseStore, Changes
from cbrcore.errors import CbrError
from cbrcore.model import Case

SEGMENT = "segment"
"""The case kind of a case graph edge."""

Cell = tuple[int, int]

ID = np.int32
"""The dtype of vertex and edge ids and of vertex coordinates in the graph's arrays."""
_ID_LIMIT = int(np.iinfo(ID).max)


def _grown(array: np.ndarray, size: int, fill: float | int | bool) -> np.ndarray:
    """``array`` with room for at least ``size`` rows, new ones set to ``fill``."""
    if size <= len(array):
        return array
    bigger = np.full((max(size, 2 * len(array), 64), *array.shape[1:]), fill, dtype=array.dtype)
    bigger[:len(array)] = array
    return bigger


def _slot(dx: ArrayLike, dy: ArrayLike) -> np.ndarray:
    """The column of the leaving-edge table for the direction of the steps (dx, dy) (any
    lengths, not both 0): 0..7 for the 8 directions."""
    code = (np.sign(dy) + 1) * 3 + np.sign(dx) + 1
    return code - (code > 4)


def segment_costs(grid: Grid, starts: ArrayLike, ends: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Cost and mean cell risk of straight segments on ``grid``.

    The cost is the sum of the step costs of the segment's cells under the grid's cost contract,
    infinite when a cell is an obstacle or a diagonal step would cut a blocked corner
    (:func:`cbr_casegraph.search.run_costs`).
    """
    # compiled: imported here so that loading the plugin does not load numba
    from cbr_casegraph.search import run_costs, run_risks

    starts = np.ascontiguousarray(np.asarray(starts, dtype=np.int64).reshape(-1, 2))
    ends = np.ascontiguousarray(np.asarray(ends, dtype=np.int64).reshape(-1, 2))
    if len(starts) == 0:
        return np.zeros(0), np.zeros(0)
    return (run_costs(grid.factor, grid.passable, grid.corner_cutting, starts, ends),
            run_risks(grid.risk, starts, ends))


@attrs.frozen
class Adjacency:
    """The graph in compressed sparse row form for the compiled searches.

    ``indptr``/``target``/``weight``/``edge`` list, for each vertex index v, the edges leaving
    it in ``indptr[v]:indptr[v+1]``: the vertex at the other end, the edge's cost and its id.
    ``xy`` holds each vertex's cell.
    """

    indptr: np.ndarray
    target: np.ndarray
    weight: np.ndarray
    edge: np.ndarray
    xy: np.ndarray


class CaseGraph:
    """A case graph on a grid of ``width`` x ``height`` cells, optionally backed by a store."""

    def __init__(self, grid: Grid, store: CaseStore | None = None) -> None:
        self.grid = grid
        self.store = store
        shape = grid.risk.shape
        if grid.risk.size > _ID_LIMIT:
            raise CbrError(f"the case graph indexes maps of up to {_ID_LIMIT} cells; this map "
                           f"is {grid.width}x{grid.height}")
        self.vertex_at = np.full(shape, -1, dtype=ID)
        self.owner = np.full(shape, -1, dtype=ID)
        self._vx = np.zeros(0, dtype=ID)
        self._vy = np.zeros(0, dtype=ID)
        self._vertices = 0
        self._free_vertices: list[int] = []
        # the edge leaving each vertex in each of the 8 directions, or -1: two edges cannot
        # leave a vertex the same way, as they would share the next cell
        self._leaving = np.full((0, 8), -1, dtype=ID)
        # vertices whose edges changed since the last merge_redundant: the only candidates
        self._changed: set[int] = set()
        # edges by id: end vertices, cost, risk, uses, creation stamp, liveness
        self._ea = np.zeros(0, dtype=ID)
        self._eb = np.zeros(0, dtype=ID)
        self._cost = np.zeros(0)
        self._risk = np.zeros(0)
        self._uses = np.zeros(0, dtype=np.int64)
        self._created = np.zeros(0, dtype=np.int64)
        self._alive = np.zeros(0, dtype=bool)
        self._next_id = 0
        self._clock = 0
        self._adjacency: Adjacency | None = None
        self._scale: float | None = None
        # while add_path compares with the segments stored before it (eq. 12): the edges it
        # inserted, and the ends of the earlier edges it split away
        self._fresh: set[int] | None = None
        self._replaced: list[tuple[Cell, Cell]] = []

    # -- loading ---------------------------------------------------------------------------

    @classmethod
    def load(cls, grid: Grid, store: CaseStore, *, priced: bool = True) -> CaseGraph:
        """The graph stored in ``store``, its costs taken from ``grid``.

        ``priced=False`` leaves every edge's cost and risk at 0: the graph's structure alone,
        which the invariant check compares with the store without the compiled cost code.
        Raises CbrError naming the case when a stored segment does not fit the grid (another
        map's case base) or two segments overlap.
        """
        graph = cls(grid, store)
        graph._take(store.cases(SEGMENT))
        if priced:
            graph.refresh()
        return graph

    def _take(self, cases: Iterable[Case]) -> list[int]:
        """Insert stored segment cases, unpriced; return their edges. CbrError naming the case
        when one overlaps another segment."""
        edges = []
        for case in cases:
            a, b = self._segment_of(case)
            cells = segment_cells(a, b)
            taken = (self.owner[cells[:, 1], cells[:, 0]] >= 0)
            taken[1:-1] |= self.vertex_at[cells[1:-1, 1], cells[1:-1, 0]] >= 0
            if taken.any():
                x, y = cells[np.flatnonzero(taken)[0]]
                raise CbrError(f"case base {_name(self.store)}: segment case {case.id} overlaps "
                               f"another segment at cell ({x}, {y}); the case graph is "
                               "inconsistent")
            edges.append(self._insert(case.id, self._vertex(a), self._vertex(b), uses=case.uses,
                                      created=case.created or 0, cost=0.0, risk=0.0))
        return edges

    def catch_up(self, changes: Changes) -> bool:
        """Follow another writer's commits (:class:`~cbrcore.casebase.mirror.FollowsChanges`):
        drop the removed segments, then take the new ones and the new use counts, priced on
        this graph's map. The store's segments meet only at vertices, so a segment removed by
        a split is among the removed ones before its parts are taken. False, with nothing
        changed, when a changed segment moved its ends (no learn step does that)."""
        removed = [edge for edge in changes.removed if self._has(edge)]
        written = [case for case in changes.cases if case.kind == SEGMENT]
        kept = [case for case in written if self._has(case.id or 0)]
        for case in kept:
            # a use counted or a cost written: the ends, checked when the edge was taken, stay
            ends = {(int(self._vx[v]), int(self._vy[v]))
                    for v in (self._ea[case.id], self._eb[case.id])}
            problem = case.problem
            if not (isinstance(problem, dict) and ends == {
                    tuple(problem.get("a") or ()), tuple(problem.get("b") or ())}):
                return False
        for edge in removed:
            self._drop(edge)
        for case in kept:
            self._uses[case.id] = case.uses
        new = self._take(case for case in written if not self._has(case.id or 0))
        if new:
            ids = np.asarray(new, dtype=np.int64)
            a, b = self.ends(ids)
            self._cost[ids], self._risk[ids] = segment_costs(self.grid, a, b)
        return True

    def _has(self, edge: int) -> bool:
        return 0 <= edge < self._next_id and bool(self._alive[edge])

    def _segment_of(self, case: Case) -> tuple[Cell, Cell]:
        try:
            a = (int(case.problem["a"][0]), int(case.problem["a"][1]))
            b = (int(case.problem["b"][0]), int(case.problem["b"][1]))
        except (KeyError, IndexError, TypeError, ValueError):
            raise CbrError(f"case base {_name(self.store)}: segment case {case.id} has problem "
                           f"{case.problem!r}; expected {{'a': [x, y], 'b': [x, y]}}") from None
        w, h = self.grid.width, self.grid.height
        for cell in (a, b):
            if not (0 <= cell[0] < w and 0 <= cell[1] < h):
                raise CbrError(f"case base {_name(self.store)}: segment case {case.id} has end "
                               f"{cell} outside the {w}x{h} map; the case base belongs to "
                               "another map")
        if not is_straight(a, b):
            raise CbrError(f"case base {_name(self.store)}: segment case {case.id} from {a} to "
                           f"{b} is not a straight line in one of the 8 grid directions")
        return a, b

    # -- size and queries ------------------------------------------------------------------

    @property
    def vertex_count(self) -> int:
        return self._vertices - len(self._free_vertices)

    @property
    def edge_count(self) -> int:
        return int(self._alive[:self._next_id].sum())

    def coverage(self) -> float:
        """The share of the map's cells that are vertices (the papers' coverage)."""
        return self.vertex_count / self.vertex_at.size

    def edge_ids(self) -> np.ndarray:
        """The ids of the edges, ascending."""
        return np.flatnonzero(self._alive[:self._next_id])

    def ends(self, edges: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """The (n, 2) end cells a and b of the given edges."""
        edges = np.asarray(edges, dtype=np.int64)
        a, b = self._ea[edges], self._eb[edges]
        return (np.stack([self._vx[a], self._vy[a]], axis=1).astype(np.int64),
                np.stack([self._vx[b], self._vy[b]], axis=1).astype(np.int64))

    def costs(self, edges: ArrayLike) -> np.ndarray:
        return self._cost[np.asarray(edges, dtype=np.int64)]

    def risks(self, edges: ArrayLike) -> np.ndarray:
        return self._risk[np.asarray(edges, dtype=np.int64)]

    def uses(self, edges: ArrayLike) -> np.ndarray:
        return self._uses[np.asarray(edges, dtype=np.int64)]

    def created(self, edges: ArrayLike) -> np.ndarray:
        return self._created[np.asarray(edges, dtype=np.int64)]

    def edges_at(self, cell: Cell) -> list[int]:
        """The edges containing ``cell``: the one it is inside of, or those meeting at it."""
        x, y = cell
        inside = int(self.owner[y, x])
        if inside >= 0:
            return [inside]
        vertex = int(self.vertex_at[y, x])
        return self._incident(vertex).tolist() if vertex >= 0 else []

    def _incident(self, vertex: int) -> np.ndarray:
        """The edges meeting at ``vertex``, ascending."""
        row = self._leaving[vertex]
        return np.sort(row[row >= 0])

    def vertices(self) -> np.ndarray:
        """The (n, 2) cells of the vertices."""
        live = self.vertex_at[self.vertex_at >= 0]
        return np.stack([self._vx[live], self._vy[live]], axis=1).astype(np.int64)

    def degree(self, cell: Cell) -> int:
        vertex = int(self.vertex_at[cell[1], cell[0]])
        return int((self._leaving[vertex] >= 0).sum()) if vertex >= 0 else 0

    def meeting(self, cell: Cell, delta: int, *, selective: bool = False) -> np.ndarray:
        """The edges that meet the neighbourhood N(cell, delta), eqs. (9)-(11).

        The neighbourhood is the square of cells within Chebyshev distance ``delta``. Full
        adaptation takes every edge with a cell in it; selective adaptation only those of them
        with an end point within ``3·delta`` (the triple extended neighbourhood). The cell
        indexes answer both by looking at the square's cells, not at every edge. Returns edge
        ids, ascending.
        """
        x0, y0, x1, y1 = self._square(cell, delta)
        inside = self.owner[y0:y1 + 1, x0:x1 + 1]
        corners = self.vertex_at[y0:y1 + 1, x0:x1 + 1]
        leaving = self._leaving[corners[corners >= 0]]
        edges = np.unique(np.concatenate([inside[inside >= 0], leaving[leaving >= 0]])
                          ).astype(np.int64)
        if selective and len(edges):
            a, b = self.ends(edges)
            reach = 3 * delta
            near = ((np.abs(a - cell).max(axis=1) <= reach)
                    | (np.abs(b - cell).max(axis=1) <= reach))
            edges = edges[near]
        return edges

    def _square(self, cell: Cell, radius: int) -> tuple[int, int, int, int]:
        h, w = self.owner.shape
        return (max(cell[0] - radius, 0), max(cell[1] - radius, 0),
                min(cell[0] + radius, w - 1), min(cell[1] + radius, h - 1))

    def adjacency(self) -> Adjacency:
        """The graph in CSR form, cached until the graph changes."""
        if self._adjacency is None:
            edges = self.edge_ids()
            a = self._ea[edges].astype(np.int64)
            b = self._eb[edges].astype(np.int64)
            source = np.concatenate([a, b])
            order = np.argsort(source, kind="stable")
            indptr = np.zeros(self._vertices + 1, dtype=np.int64)
            np.cumsum(np.bincount(source, minlength=self._vertices), out=indptr[1:])
            self._adjacency = Adjacency(
                indptr, np.concatenate([b, a])[order], np.tile(self._cost[edges], 2)[order],
                np.tile(edges, 2)[order],
                np.stack([self._vx[:self._vertices], self._vy[:self._vertices]],
                         axis=1).astype(np.int64))
        return self._adjacency

    def vertex_index(self, cell: Cell) -> int:
        """The index of the vertex on ``cell`` in :meth:`adjacency`, or -1."""
        return int(self.vertex_at[cell[1], cell[0]])

    def heuristic_scale(self) -> float:
        """The least cost factor of a passable cell: no step costs less per unit of length."""
        if self._scale is None:
            from cbr_solvers.search import least_factor  # compiled: loaded with the first query

            least = least_factor(self.grid.factor, self.grid.passable)
            self._scale = least if np.isfinite(least) else 1.0
        return self._scale

    # -- changes ---------------------------------------------------------------------------

    def set_grid(self, grid: Grid, cells: ArrayLike | None = None) -> None:
        """Take a changed map; recompute the edges through ``cells`` (all edges when None)."""
        if grid.risk.shape != self.owner.shape:
            raise CbrError(f"the map changed size from {self.owner.shape[1]}x"
                           f"{self.owner.shape[0]} to {grid.width}x{grid.height}")
        self.grid = grid
        self._scale = None
        if cells is None:
            self.refresh()
            return
        touched: set[int] = set()
        h, w = self.owner.shape
        for x, y in np.asarray(cells, dtype=np.int64).reshape(-1, 2).tolist():
            # a diagonal step passing beside a cell has its ends on the cell's orthogonal
            # neighbours: the corner rule makes the cell's change theirs too
            for cx, cy in ((x, y), (x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)):
                if 0 <= cx < w and 0 <= cy < h:
                    touched.update(self.edges_at((cx, cy)))
        if touched:
            self.refresh(sorted(touched))

    def refresh(self, edges: Sequence[int] | None = None) -> None:
        """Recompute cost and risk of ``edges`` (all when None) from the current map."""
        ids = self.edge_ids() if edges is None else np.asarray(edges, dtype=np.int64)
        if len(ids) == 0:
            return
        a, b = self.ends(ids)
        cost, risk = segment_costs(self.grid, a, b)
        changed = (cost != self._cost[ids]) | (risk != self._risk[ids])
        self._cost[ids], self._risk[ids] = cost, risk
        if changed.any():
            self._adjacency = None
            if edges is not None:
                self._write_costs(ids[changed])

    def record_use(self, edges: Iterable[int]) -> None:
        """Count one more use of each edge still in the graph (the store counts its own)."""
        for edge in edges:
            if self._has(edge):
                self._uses[edge] += 1

    def add_path(self, path: ArrayLike, *, similarity_delta: int = 0,
                 distance: str = "chebyshev") -> list[int]:
        """Retain a traversed path: store its new straight stretches as edges.

        Where the path runs along stored edges nothing is added; where a new stretch starts,
        ends or crosses the graph, the edge there is split so that segments meet only at
        their end points; new stretches are cut at their turns. A new segment is skipped
        when a stored one is similar to it by eq. (12) with ``similarity_delta`` under the
        named distance. A diagonal step that crosses a stored diagonal step between cells (an X in a
        2x2 block: the paths intersect without sharing a cell) is cut there too and joined to
        the stored segment by a one-step edge. The path must be a valid path on the map.
        Returns the ids of the new edges.
        """
        cells = without_loops(path)
        if len(cells) < 2:
            return []
        new_steps = self._new_steps(cells)
        crossings = self._crossings(cells, new_steps)
        forced = np.zeros(len(cells), dtype=bool)
        forced[[i for i, _ in crossings]] = True
        # eq. (12) compares with the cases stored before this path: its own segments (the
        # steps of a staircase are within one cell of each other) are one new case, not
        # duplicates, and skipping them would cut the path into unconnected pieces. At
        # similarity_delta 0 no comparison is needed: a stored segment with the same two ends
        # would be the same straight run of cells, whose steps are then not new
        similarity = ((similarity_delta, distance_function(distance)) if similarity_delta > 0
                      else None)
        if similarity is not None:
            self._fresh, self._replaced = set(), []
        try:
            return self._add_stretches(cells, new_steps, crossings, forced, similarity)
        finally:
            self._fresh, self._replaced = None, []

    def _add_stretches(self, cells: np.ndarray, new_steps: np.ndarray,
                       crossings: list[tuple[int, Cell]], forced: np.ndarray,
                       similarity: tuple[int, Distance] | None) -> list[int]:
        """The body of :meth:`add_path`: connect the new stretches' segments, then the
        crossings; ``similarity`` is (δr, distance) of eq. (12), None to skip none."""
        added: list[int] = []
        for first, last in _runs(new_steps):
            # the stretch of cells first..last (inclusive) consists of new steps only
            stretch = cells[first:last + 1]
            cuts = _turns(stretch) | forced[first:last + 1]
            cuts[self._taken(stretch)] = True
            points = np.flatnonzero(cuts)
            for i, j in itertools.pairwise(points):
                a = (int(stretch[i, 0]), int(stretch[i, 1]))
                b = (int(stretch[j, 0]), int(stretch[j, 1]))
                if similarity is not None and self._similar(a, b, *similarity):
                    continue
                edge = self._connect(a, b)
                if edge is not None:
                    added.append(edge)
        for i, beside in crossings:
            here = (int(cells[i, 0]), int(cells[i, 1]))
            if self.vertex_at[here[1], here[0]] >= 0:  # not when its segment was skipped
                edge = self._connect(here, beside)
                if edge is not None:
                    added.append(edge)
        return added

    def _taken(self, cells: np.ndarray) -> np.ndarray:
        """For each cell: is it a vertex or inside an edge."""
        x, y = cells[:, 0], cells[:, 1]
        return (self.vertex_at[y, x] >= 0) | (self.owner[y, x] >= 0)

    def _crossings(self, cells: np.ndarray, new_steps: np.ndarray) -> list[tuple[int, Cell]]:
        """The new diagonal steps i -> i+1 that cross a stored diagonal step between cells.

        Returns (i, cell): the step's first cell and the stored cell beside it (same row) that
        a one-step edge joins it to.
        """
        steps = np.diff(cells, axis=0)
        diagonal = new_steps & (np.abs(steps).sum(axis=1) == 2)
        index = np.flatnonzero(diagonal)
        if len(index) == 0:
            return []
        # the two cells beside a diagonal step p -> q: (q.x, p.y) and (p.x, q.y)
        side = np.stack([cells[index + 1, 0], cells[index, 1]], axis=1)
        other = np.stack([cells[index, 0], cells[index + 1, 1]], axis=1)
        both = self._taken(side) & self._taken(other)
        found: list[tuple[int, Cell]] = []
        for k in np.flatnonzero(both).tolist():
            r = (int(side[k, 0]), int(side[k, 1]))
            t = (int(other[k, 0]), int(other[k, 1]))
            if set(self.edges_at(r)) & set(self.edges_at(t)):  # one stored step r -> t
                found.append((int(index[k]), r))
        return found

    def similar(self, a: Cell, b: Cell, delta: int, distance: str = "chebyshev") -> bool:
        """Eq. (12): whether a stored segment has its ends within ``delta`` of a and b (either
        way round) under the named distance. Costs in proportion to the square N(a, delta),
        not to the graph."""
        return self._similar(a, b, delta, distance_function(distance))

    def _similar(self, a: Cell, b: Cell, delta: int, measure: Distance) -> bool:
        """Eq. (12): a segment stored before the current :meth:`add_path` has its ends within
        ``delta`` of a and b (either way round) under ``measure``.

        Every distance of :mod:`cbr_grid.distances` is at least the Chebyshev distance, so one
        end of such a segment is a vertex in the square N(a, delta): the vertices there and
        their edges are every candidate. The edges this add_path inserted are left out and the
        earlier edges it split away are compared as they were.
        """
        x0, y0, x1, y1 = self._square(a, delta)
        near = self.vertex_at[y0:y1 + 1, x0:x1 + 1]
        vertices = near[near >= 0]
        if len(vertices) and self._similar_at(vertices, a, b, delta, measure):
            return True
        for p, q in self._replaced:
            if ((measure(p, a) <= delta and measure(q, b) <= delta)
                    or (measure(q, a) <= delta and measure(p, b) <= delta)):
                return True
        return False

    def _similar_at(self, vertices: np.ndarray, a: Cell, b: Cell, delta: int,
                    measure: Distance) -> bool:
        """Whether a segment leaving one of ``vertices`` within ``delta`` of a, stored before
        the current :meth:`add_path`, ends within ``delta`` of b."""
        vertices = vertices[measure(np.stack([self._vx[vertices], self._vy[vertices]], axis=1),
                                    a) <= delta]
        leaving = self._leaving[vertices]
        mine = leaving >= 0
        edges, here = leaving[mine], np.repeat(vertices, mine.sum(axis=1))
        if self._fresh:
            old = ~np.isin(edges, list(self._fresh))
            edges, here = edges[old], here[old]
        others = np.where(self._ea[edges] == here, self._eb[edges], self._ea[edges])
        return bool((measure(np.stack([self._vx[others], self._vy[others]], axis=1), b)
                     <= delta).any())

    def remove(self, edges: Iterable[int]) -> None:
        """Forget these edges; vertices left without edges disappear."""
        ids = sorted(set(int(e) for e in edges))
        for edge in ids:
            if not (0 <= edge < self._next_id and self._alive[edge]):
                raise KeyError(edge)
        if self.store is not None and ids:
            self._written().remove(ids)
        for edge in ids:
            self._drop(edge)

    def merge_redundant(self) -> int:
        """Delete the vertices in the middle of a straight edge: degree 2, both edges collinear.

        Returns how many vertices were removed.
        """
        merged = 0
        candidates, self._changed = self._changed, set()
        for vertex in sorted(candidates):
            edges = self._incident(vertex).tolist()
            if len(edges) != 2:
                continue
            e1, e2 = edges
            far1 = self._other(e1, vertex)
            far2 = self._other(e2, vertex)
            here = (self._vx[vertex], self._vy[vertex])
            p1, p2 = (self._vx[far1], self._vy[far1]), (self._vx[far2], self._vy[far2])
            if not np.array_equal(direction(p1, here), direction(here, p2)):
                continue
            if far1 == far2:
                continue
            uses = int(max(self._uses[e1], self._uses[e2]))
            created = int(min(self._created[e1], self._created[e2]))
            self.remove([e1, e2])
            self._connect((int(p1[0]), int(p1[1])), (int(p2[0]), int(p2[1])), uses=uses,
                          created=created)
            merged += 1
        return merged

    # -- internals -------------------------------------------------------------------------

    def _new_steps(self, cells: np.ndarray) -> np.ndarray:
        """For each step of the path: True unless it runs along a stored edge."""
        x, y = cells[:, 0], cells[:, 1]
        inside = self.owner[y, x]
        vertex = self.vertex_at[y, x]
        new = np.ones(len(cells) - 1, dtype=bool)
        both = (inside[:-1] >= 0) & (inside[1:] >= 0)
        new[both] = inside[:-1][both] != inside[1:][both]
        # a vertex and a cell inside an edge: along that edge when the vertex is one of its ends
        for at_vertex, at_edge in ((vertex[:-1], inside[1:]), (vertex[1:], inside[:-1])):
            mixed = (at_vertex >= 0) & (at_edge >= 0)
            edge, ends_at = at_edge[mixed], at_vertex[mixed]
            new[mixed] = (self._ea[edge] != ends_at) & (self._eb[edge] != ends_at)
        # two vertices side by side: along the edge leaving the first towards the second, which
        # can only be a one-step edge between them
        pairs = (vertex[:-1] >= 0) & (vertex[1:] >= 0)
        step = np.diff(cells[pairs.nonzero()[0][:, None] + [0, 1]], axis=1)[:, 0]
        new[pairs] = self._leaving[vertex[:-1][pairs], _slot(step[:, 0], step[:, 1])] < 0
        return new

    def _connect(self, a: Cell, b: Cell, *, uses: int = 0, created: int | None = None
                 ) -> int | None:
        """Add the straight edge a-b (splitting edges at its ends); None if it exists."""
        va, vb = self._vertex(a), self._vertex(b)
        joined = int(self._leaving[va, _slot(b[0] - a[0], b[1] - a[1])])
        if joined >= 0 and self._other(joined, va) == vb:
            return None
        cost, risk = segment_costs(self.grid, [a], [b])
        if created is None:
            created = self._stamp()
        case_id = None
        if self.store is not None:
            case_id = self._written().add(self._case(a, b, float(cost[0]), float(risk[0]),
                                                uses)).id
        return self._insert(case_id, va, vb, uses=uses, created=created, cost=float(cost[0]),
                            risk=float(risk[0]))

    def _case(self, a: Cell, b: Cell, cost: float, risk: float, uses: int) -> Case:
        length = float(np.hypot(b[0] - a[0], b[1] - a[1]))
        return Case({"a": list(a), "b": list(b)},
                    {"cost": cost if math.isfinite(cost) else None, "risk": risk,
                     "length": length}, kind=SEGMENT, uses=uses)

    def _written(self) -> CaseStore:
        """The store, for one more write."""
        assert self.store is not None
        return self.store

    def _stamp(self) -> int:
        if self.store is not None:
            return self.store.revision + 1
        self._clock += 1
        return self._clock

    def _insert(self, case_id: int | None, va: int, vb: int, *, uses: int, created: int,
                cost: float, risk: float) -> int:
        edge = self._next_id if case_id is None else case_id
        if not 0 <= edge < _ID_LIMIT:
            raise CbrError(f"case base {_name(self.store)}: segment case id {edge} is outside "
                           f"the case graph's ids 0..{_ID_LIMIT - 1}")
        size = edge + 1
        self._ea = _grown(self._ea, size, -1)
        self._eb = _grown(self._eb, size, -1)
        self._cost = _grown(self._cost, size, np.inf)
        self._risk = _grown(self._risk, size, 0.0)
        self._uses = _grown(self._uses, size, 0)
        self._created = _grown(self._created, size, 0)
        self._alive = _grown(self._alive, size, False)
        self._ea[edge], self._eb[edge] = va, vb
        self._cost[edge], self._risk[edge] = cost, risk
        self._uses[edge], self._created[edge] = uses, created
        self._alive[edge] = True
        self._next_id = max(self._next_id, size)
        dx, dy = int(self._vx[vb] - self._vx[va]), int(self._vy[vb] - self._vy[va])
        self._leaving[va, _slot(dx, dy)] = edge
        self._leaving[vb, _slot(-dx, -dy)] = edge
        self._changed.update((va, vb))
        if self._fresh is not None:
            self._fresh.add(edge)
        cells = segment_cells((self._vx[va], self._vy[va]), (self._vx[vb], self._vy[vb]))[1:-1]
        self.owner[cells[:, 1], cells[:, 0]] = edge
        self._adjacency = None
        return edge

    def _drop(self, edge: int, *, keep_vertices: bool = False) -> None:
        va, vb = int(self._ea[edge]), int(self._eb[edge])
        a = (int(self._vx[va]), int(self._vy[va]))
        b = (int(self._vx[vb]), int(self._vy[vb]))
        if self._fresh is not None and edge not in self._fresh:
            self._replaced.append((a, b))
        cells = segment_cells(a, b)[1:-1]
        self.owner[cells[:, 1], cells[:, 0]] = -1
        self._alive[edge] = False
        self._changed.update((va, vb))
        self._leaving[va, _slot(b[0] - a[0], b[1] - a[1])] = -1
        self._leaving[vb, _slot(a[0] - b[0], a[1] - b[1])] = -1
        for vertex in (va, vb):
            if not keep_vertices and (self._leaving[vertex] < 0).all():
                self.vertex_at[self._vy[vertex], self._vx[vertex]] = -1
                self._free_vertices.append(vertex)
        self._adjacency = None

    def _other(self, edge: int, vertex: int) -> int:
        a = int(self._ea[edge])
        return int(self._eb[edge]) if a == vertex else a

    def _vertex(self, cell: Cell) -> int:
        """The vertex on ``cell``, made if needed (splitting the edge through the cell)."""
        x, y = int(cell[0]), int(cell[1])
        vertex = int(self.vertex_at[y, x])
        if vertex >= 0:
            return vertex
        through = int(self.owner[y, x])
        if self._free_vertices:
            vertex = self._free_vertices.pop()
        else:
            vertex = self._vertices
            self._vertices += 1
            self._vx = _grown(self._vx, self._vertices, 0)
            self._vy = _grown(self._vy, self._vertices, 0)
            self._leaving = _grown(self._leaving, self._vertices, -1)
        self._vx[vertex], self._vy[vertex] = x, y
        self.vertex_at[y, x] = vertex
        self._adjacency = None
        if through >= 0:
            self._split(through, vertex)
        return vertex

    def _split(self, edge: int, vertex: int) -> None:
        """Replace ``edge`` by its two parts on either side of ``vertex``."""
        va, vb = int(self._ea[edge]), int(self._eb[edge])
        uses, created = int(self._uses[edge]), int(self._created[edge])
        a = (int(self._vx[va]), int(self._vy[va]))
        b = (int(self._vx[vb]), int(self._vy[vb]))
        here = (int(self._vx[vertex]), int(self._vy[vertex]))
        if self.store is not None:
            self._written().remove([edge])
        # the ends stay vertices even when this was their only edge: its parts come back now
        self._drop(edge, keep_vertices=True)
        for p, q, vp, vq in ((a, here, va, vertex), (here, b, vertex, vb)):
            cost, risk = segment_costs(self.grid, [p], [q])
            case_id = None
            if self.store is not None:
                case_id = self._written().add(self._case(p, q, float(cost[0]), float(risk[0]),
                                                    uses)).id
            self._insert(case_id, vp, vq, uses=uses, created=created, cost=float(cost[0]),
                         risk=float(risk[0]))

    def _write_costs(self, edges: np.ndarray) -> None:
        if self.store is None:
            return
        for edge in edges.tolist():
            case = self.store.get(edge)
            solution = dict(case.solution)
            cost = float(self._cost[edge])
            solution["cost"] = cost if math.isfinite(cost) else None
            solution["risk"] = float(self._risk[edge])
            self._written().replace(attrs.evolve(case, solution=solution))


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """Maximal runs of True steps as (first cell, last cell) index pairs of the path."""
    padded = np.concatenate([[False], flags, [False]])
    change = np.flatnonzero(padded[1:] != padded[:-1])
    return [(int(s), int(e)) for s, e in zip(change[::2], change[1::2], strict=True)]


def _turns(stretch: np.ndarray) -> np.ndarray:
    """Flags over the cells of a stretch: its ends and the cells where the direction changes."""
    cuts = np.zeros(len(stretch), dtype=bool)
    cuts[0] = cuts[-1] = True
    steps = np.diff(stretch, axis=0)
    cuts[1:-1] = np.any(steps[1:] != steps[:-1], axis=1)
    return cuts


def _name(store: CaseStore | None) -> str:
    path = getattr(store, "path", None)
    return str(path) if path is not None else type(store).__name__
