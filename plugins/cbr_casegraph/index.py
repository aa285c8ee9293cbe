"""The case graph's index: its vertices and edges in arrays, and the two cell layers over them.

Vertices are cells; an edge is a straight segment (see :mod:`cbr_casegraph.geometry`) between
two vertices whose interior cells belong to no other edge and are no vertex. Two cell layers
index it, kept in tiles made where the graph has cells (:mod:`cbr_casegraph.tiles`): the vertex
on each cell (or -1) and the edge whose interior covers each cell (its owner, or -1), so "which
cases does this cell touch" costs one lookup and a path is cut into new segments with array
operations; a table of the edge leaving each vertex in each of the 8 directions answers "which
cases meet at this vertex". Together they are the spatial index of the segments' ends that eq.
(12) needs (:mod:`cbr_casegraph.retention`).

Ids are int32 (vertices, edges, cell coordinates): a map of up to 2^31 cells has fewer vertices
and live edges than cells, and an edge id from a store that ran past 2^31 - 1 is refused with a
CbrError rather than wrapped. The index keeps 1/16 byte per map cell, 512 bytes per 8 x 8 tile
the graph touches, 40 per vertex and 41 per edge id (see docs/casegraph.md, "Memory").

The index knows nothing of the map's costs or of the store: it holds what it is given
(:mod:`cbr_casegraph.costs` prices the edges, :mod:`cbr_casegraph.writes` keeps the store in
step).
"""

from __future__ import annotations

import attrs
import numpy as np
from numpy.typing import ArrayLike

from cbr_casegraph.geometry import segment_cells, square
from cbr_casegraph.tiles import OWNER, VERTEX, CellTiles
from cbrcore.errors import CbrError

Cell = tuple[int, int]

ID = np.int32
"""The dtype of vertex and edge ids and of vertex coordinates in the index's arrays."""
ID_LIMIT = int(np.iinfo(ID).max)
"""The most cells of a map, and one more than the largest edge id, the index takes."""


def grown(array: np.ndarray, size: int, fill: float | int | bool) -> np.ndarray:
    """``array`` with room for at least ``size`` rows, new ones set to ``fill``."""
    if size <= len(array):
        return array
    bigger = np.full((max(size, 2 * len(array), 64), *array.shape[1:]), fill, dtype=array.dtype)
    bigger[:len(array)] = array
    return bigger


def slot(dx: ArrayLike, dy: ArrayLike) -> np.ndarray:
    """The column of the leaving-edge table for the direction of the steps (dx, dy) (any
    lengths, not both 0): 0..7 for the 8 directions."""
    code = (np.sign(dy) + 1) * 3 + np.sign(dx) + 1
    return code - (code > 4)


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


@attrs.frozen
class EdgeTables:
    """The index as the compiled query reads it: the CSR adjacency and, by edge id, the
    vertices at the edge's ends a and b and its cost (infinite for an id not in use)."""

    adjacency: Adjacency
    a: np.ndarray
    b: np.ndarray
    cost: np.ndarray

    def ends(self, edges: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """The (n, 2) end cells a and b of the given edges."""
        edges = np.asarray(edges, dtype=np.int64)
        xy = self.adjacency.xy
        return xy[self.a[edges]], xy[self.b[edges]]


class SegmentIndex:
    """The vertices and edges of a case graph on a map of ``shape`` (rows, columns).

    ``source`` names where the edges come from (the case base) in the errors it raises.
    """

    def __init__(self, shape: tuple[int, int], source: str) -> None:
        self.source = source
        self.shape = shape
        self.cells = CellTiles(shape)
        self.vx = np.zeros(0, dtype=ID)
        self.vy = np.zeros(0, dtype=ID)
        self.slots = 0
        self.free: list[int] = []
        # the edge leaving each vertex in each of the 8 directions, or -1: two edges cannot
        # leave a vertex the same way, as they would share the next cell
        self.leaving = np.full((0, 8), -1, dtype=ID)
        # vertices whose edges changed since the last take_changed: the only candidates for
        # a merge of collinear edges
        self.changed: set[int] = set()
        # edges by id: end vertices, cost, risk, uses, creation stamp, liveness
        self.ea = np.zeros(0, dtype=ID)
        self.eb = np.zeros(0, dtype=ID)
        self.cost = np.zeros(0)
        self.risk = np.zeros(0)
        self.uses = np.zeros(0, dtype=np.int64)
        self.created = np.zeros(0, dtype=np.int64)
        self.alive = np.zeros(0, dtype=bool)
        self.next_id = 0
        self._adjacency: Adjacency | None = None
        self._tables: EdgeTables | None = None

    # -- reading ---------------------------------------------------------------------------

    @property
    def vertex_count(self) -> int:
        return self.slots - len(self.free)

    @property
    def edge_count(self) -> int:
        return int(self.alive[:self.next_id].sum())

    def has(self, edge: int) -> bool:
        return 0 <= edge < self.next_id and bool(self.alive[edge])

    def edge_ids(self) -> np.ndarray:
        """The ids of the edges, ascending."""
        return np.flatnonzero(self.alive[:self.next_id])

    def cell(self, vertex: int) -> Cell:
        return int(self.vx[vertex]), int(self.vy[vertex])

    def vertex_cells(self, vertices: np.ndarray) -> np.ndarray:
        """The (n, 2) cells of ``vertices``."""
        return np.stack([self.vx[vertices], self.vy[vertices]], axis=1).astype(np.int64)

    def ends(self, edges: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """The (n, 2) end cells a and b of the given edges."""
        edges = np.asarray(edges, dtype=np.int64)
        return self.vertex_cells(self.ea[edges]), self.vertex_cells(self.eb[edges])

    def vertex_at(self, cell: Cell) -> int:
        """The vertex on ``cell``, or -1."""
        return self.cells.value(VERTEX, int(cell[0]), int(cell[1]))

    def owner(self, cell: Cell) -> int:
        """The edge whose interior covers ``cell``, or -1."""
        return self.cells.value(OWNER, int(cell[0]), int(cell[1]))

    def other(self, edge: int, vertex: int) -> int:
        """The vertex at the other end of ``edge`` from ``vertex``."""
        a = int(self.ea[edge])
        return int(self.eb[edge]) if a == vertex else a

    def leaving_towards(self, vertex: int, dx: int, dy: int) -> int:
        """The edge leaving ``vertex`` in the direction of (dx, dy), or -1."""
        return int(self.leaving[vertex, slot(dx, dy)])

    def incident(self, vertex: int) -> np.ndarray:
        """The edges meeting at ``vertex``, ascending."""
        row = self.leaving[vertex]
        return np.sort(row[row >= 0])

    def edges_at(self, cell: Cell) -> list[int]:
        """The edges containing ``cell``: the one it is inside of, or those meeting at it."""
        inside = self.owner(cell)
        if inside >= 0:
            return [inside]
        vertex = self.vertex_at(cell)
        return self.incident(vertex).tolist() if vertex >= 0 else []

    def vertices(self) -> np.ndarray:
        """The (n, 2) cells of the vertices, row by row."""
        live = np.ones(self.slots, dtype=bool)
        live[self.free] = False
        vertices = np.flatnonzero(live)
        return self.vertex_cells(vertices[np.lexsort((self.vx[vertices], self.vy[vertices]))])

    def degree(self, cell: Cell) -> int:
        vertex = self.vertex_at(cell)
        return int((self.leaving[vertex] >= 0).sum()) if vertex >= 0 else 0

    def square(self, cell: Cell, radius: int) -> tuple[int, int, int, int]:
        """The square N(cell, radius) clipped to the map: (x0, y0, x1, y1), inclusive."""
        h, w = self.shape
        return square(cell, radius, w, h)

    def meeting(self, cell: Cell, delta: int, *, selective: bool = False) -> np.ndarray:
        """The edges that meet the neighbourhood N(cell, delta), eqs. (9)-(11).

        The neighbourhood is the square of cells within Chebyshev distance ``delta``. Full
        adaptation takes every edge with a cell in it; selective adaptation only those of them
        with an end point within ``3·delta`` (the triple extended neighbourhood). The cell
        grids answer both by looking at the square's cells, not at every edge. Returns edge
        ids, ascending.
        """
        x0, y0, x1, y1 = self.square(cell, delta)
        inside = self.cells.window(OWNER, x0, y0, x1, y1)
        corners = self.cells.window(VERTEX, x0, y0, x1, y1)
        leaving = self.leaving[corners[corners >= 0]]
        edges = np.unique(np.concatenate([inside[inside >= 0], leaving[leaving >= 0]])
                          ).astype(np.int64)
        if selective and len(edges):
            a, b = self.ends(edges)
            reach = 3 * delta
            near = ((np.abs(a - cell).max(axis=1) <= reach)
                    | (np.abs(b - cell).max(axis=1) <= reach))
            edges = edges[near]
        return edges

    def adjacency(self) -> Adjacency:
        """The graph in CSR form, cached until the index changes."""
        if self._adjacency is None:
            edges = self.edge_ids()
            a = self.ea[edges].astype(np.int64)
            b = self.eb[edges].astype(np.int64)
            source = np.concatenate([a, b])
            order = np.argsort(source, kind="stable")
            indptr = np.zeros(self.slots + 1, dtype=np.int64)
            np.cumsum(np.bincount(source, minlength=self.slots), out=indptr[1:])
            self._adjacency = Adjacency(
                indptr, np.concatenate([b, a])[order], np.tile(self.cost[edges], 2)[order],
                np.tile(edges, 2)[order], self.vertex_cells(np.arange(self.slots)))
        return self._adjacency

    def tables(self) -> EdgeTables:
        """The tables for the compiled query, made again only when the adjacency changed."""
        adjacency = self.adjacency()
        if self._tables is None or self._tables.adjacency is not adjacency:
            ids = self.edge_ids()
            size = int(ids[-1]) + 1 if len(ids) else 0
            ends = [np.full(size, -1, dtype=np.int64) for _ in range(2)]
            ends[0][ids], ends[1][ids] = self.ea[ids], self.eb[ids]
            cost = np.full(size, np.inf)
            cost[ids] = self.cost[ids]
            self._tables = EdgeTables(adjacency, ends[0], ends[1], cost)
        return self._tables

    # -- changing --------------------------------------------------------------------------

    def add_vertex(self, cell: Cell) -> tuple[int, int]:
        """The vertex on ``cell``, made if needed, and the edge whose interior held the cell
        (-1 if none), which the caller splits there."""
        x, y = int(cell[0]), int(cell[1])
        vertex = self.cells.value(VERTEX, x, y)
        if vertex >= 0:
            return vertex, -1
        through = self.cells.value(OWNER, x, y)
        if self.free:
            vertex = self.free.pop()
        else:
            vertex = self.slots
            self.slots += 1
            self._room_for_vertices(self.slots)
        self.vx[vertex], self.vy[vertex] = x, y
        self.cells.set(VERTEX, x, y, vertex)
        self._adjacency = None
        return vertex, through

    def insert(self, edge: int, va: int, vb: int, *, uses: int, created: int, cost: float,
               risk: float) -> int:
        """Put edge ``edge`` between vertices ``va`` and ``vb``; CbrError for an id outside
        the index's range."""
        if not 0 <= edge < ID_LIMIT:
            raise CbrError(f"case base {self.source}: segment case id {edge} is outside "
                           f"the case graph's ids 0..{ID_LIMIT - 1}")
        size = edge + 1
        self._room_for_edges(size)
        self.ea[edge], self.eb[edge] = va, vb
        self.cost[edge], self.risk[edge] = cost, risk
        self.uses[edge], self.created[edge] = uses, created
        self.alive[edge] = True
        self.next_id = max(self.next_id, size)
        dx, dy = int(self.vx[vb] - self.vx[va]), int(self.vy[vb] - self.vy[va])
        self.leaving[va, slot(dx, dy)] = edge
        self.leaving[vb, slot(-dx, -dy)] = edge
        self.changed.update((va, vb))
        cells = segment_cells(self.cell(va), self.cell(vb))[1:-1]
        self.cells.set(OWNER, cells[:, 0], cells[:, 1], edge)
        self._adjacency = None
        return edge

    def reserve(self, *, vertices: int, edges: int) -> None:
        """Make room for ``vertices`` more vertex slots and ``edges`` more edge ids, which a
        compiled writer fills in place; CbrError when the ids would pass the index's range."""
        if self.next_id + edges > ID_LIMIT:
            raise CbrError(f"case base {self.source}: segment case ids would pass the case "
                           f"graph's ids 0..{ID_LIMIT - 1}")
        self._room_for_vertices(self.slots + vertices)
        self._room_for_edges(self.next_id + edges)

    def _room_for_vertices(self, size: int) -> None:
        """Grow the vertex arrays to hold at least ``size`` slots."""
        self.vx = grown(self.vx, size, 0)
        self.vy = grown(self.vy, size, 0)
        self.leaving = grown(self.leaving, size, -1)

    def _room_for_edges(self, size: int) -> None:
        """Grow the edge arrays to hold at least ``size`` ids."""
        self.ea = grown(self.ea, size, -1)
        self.eb = grown(self.eb, size, -1)
        self.cost = grown(self.cost, size, np.inf)
        self.risk = grown(self.risk, size, 0.0)
        self.uses = grown(self.uses, size, 0)
        self.created = grown(self.created, size, 0)
        self.alive = grown(self.alive, size, False)

    def touched(self) -> None:
        """Note that a compiled writer changed the index: the cached adjacency is stale."""
        self._adjacency = None

    def renumber(self, ids: dict[int, int]) -> None:
        """Move the live edges among the keys of ``ids`` to the ids they map to (a case
        base's), which no other edge has; CbrError for an id outside the index's range."""
        pairs = np.array([(old, new) for old, new in ids.items() if self.alive[old]],
                         dtype=np.int64).reshape(-1, 2)
        if len(pairs) and pairs[:, 1].max() >= ID_LIMIT:
            raise CbrError(f"case base {self.source}: segment case id {pairs[:, 1].max()} is "
                           f"outside the case graph's ids 0..{ID_LIMIT - 1}")
        pairs = pairs[pairs[:, 0] != pairs[:, 1]]
        if len(pairs) == 0:
            return
        old, new = pairs[:, 0], pairs[:, 1]
        va, vb = self.ea[old], self.eb[old]
        values = [self.cost[old], self.risk[old], self.uses[old], self.created[old]]
        self.alive[old] = False
        for edge, a, b, cost, risk, uses, created in zip(
                new.tolist(), va.tolist(), vb.tolist(), *(v.tolist() for v in values),
                strict=True):
            self.insert(edge, a, b, uses=uses, created=created, cost=cost, risk=risk)

    def drop(self, edge: int, *, keep_vertices: bool = False) -> tuple[Cell, Cell]:
        """Take ``edge`` out; its ends stop being vertices when it was their last edge, unless
        ``keep_vertices``. Returns the end cells it had."""
        va, vb = int(self.ea[edge]), int(self.eb[edge])
        a, b = self.cell(va), self.cell(vb)
        cells = segment_cells(a, b)[1:-1]
        self.cells.set(OWNER, cells[:, 0], cells[:, 1], -1)
        self.alive[edge] = False
        self.changed.update((va, vb))
        self.leaving[va, slot(b[0] - a[0], b[1] - a[1])] = -1
        self.leaving[vb, slot(a[0] - b[0], a[1] - b[1])] = -1
        for vertex in (va, vb):
            if not keep_vertices and (self.leaving[vertex] < 0).all():
                self.cells.set(VERTEX, self.vx[vertex], self.vy[vertex], -1)
                self.free.append(vertex)
        self._adjacency = None
        return a, b

    def price(self, edges: np.ndarray, cost: np.ndarray, risk: np.ndarray) -> np.ndarray:
        """Set the cost and risk of ``edges``; returns which of them changed."""
        changed = (cost != self.cost[edges]) | (risk != self.risk[edges])
        self.cost[edges], self.risk[edges] = cost, risk
        if changed.any():
            self._adjacency = None
        return changed

    def take_changed(self) -> set[int]:
        """The vertices whose edges changed since the last call."""
        changed, self.changed = self.changed, set()
        return changed
