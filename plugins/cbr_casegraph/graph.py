"""The case graph: straight path segments as cases, meeting only at their end points.

:class:`CaseGraph` holds one graph's state (its map, its case base, its
:class:`~cbr_casegraph.index.SegmentIndex`) and hands each job to the module that does it:

- :mod:`cbr_casegraph.index`: the vertices, edges, cell grids and CSR adjacency;
- :mod:`cbr_casegraph.costs`: the edges priced on the map, again when the map changes;
- :mod:`cbr_casegraph.retention`: a traversed path retained, with eq. (12);
- :mod:`cbr_casegraph.forgetting`: edges forgotten, redundant vertices merged away;
- :mod:`cbr_casegraph.following`: the stored segments loaded, other writers followed;
- :mod:`cbr_casegraph.writes`: every change written through to the case base, each edge a
  case of the form of :mod:`cbr_casegraph.cases`.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from cbr_casegraph import costs, following, forgetting, retention, writes
from cbr_casegraph.cases import SEGMENT, store_name
from cbr_casegraph.costs import segment_costs
from cbr_casegraph.index import ID_LIMIT, Adjacency, Cell, EdgeTables, SegmentIndex
from cbr_casegraph.potentials import Potentials
from cbr_casegraph.tiles import OWNER, VERTEX
from cbr_grid.grid import Grid
from cbrcore.casebase.store import CaseStore, Changes
from cbrcore.errors import CbrError

# the case kind and the pricing of a segment, named here too for code that uses the graph
__all__ = ["SEGMENT", "CaseGraph", "segment_costs"]


class CaseGraph:
    """A case graph on a grid of ``width`` x ``height`` cells, optionally backed by a store."""

    def __init__(self, grid: Grid, store: CaseStore | None = None) -> None:
        if grid.risk.size > ID_LIMIT:
            raise CbrError(f"the case graph indexes maps of up to {ID_LIMIT} cells; this map "
                           f"is {grid.width}x{grid.height}")
        self.grid = grid
        self.store = store
        self.index = SegmentIndex(grid.risk.shape, store_name(store))
        self._clock = 0
        self._scale: float | None = None
        self._potentials = Potentials()

    @classmethod
    def load(cls, grid: Grid, store: CaseStore, *, priced: bool = True) -> CaseGraph:
        """The graph stored in ``store``, its costs taken from ``grid``.

        ``priced=False`` leaves every edge's cost and risk at 0: the graph's structure alone,
        which the invariant check compares with the store without the compiled cost code.
        Raises CbrError naming the case when a stored segment does not fit the grid (another
        map's case base) or two segments overlap.
        """
        graph = cls(grid, store)
        following.take(graph, store.cases(SEGMENT))
        if priced:
            graph.refresh()
        return graph

    def catch_up(self, changes: Changes) -> bool:
        """Follow another writer's commits (:func:`cbr_casegraph.following.catch_up`)."""
        return following.catch_up(self, changes)

    def stamp(self) -> int:
        """The creation stamp of an edge made now: the store's next revision, or a count."""
        if self.store is not None:
            return self.store.revision + 1
        self._clock += 1
        return self._clock

    # -- reading (the index's) -------------------------------------------------------------

    @property
    def vertex_at(self) -> np.ndarray:
        """The vertex on each cell, or -1, over the whole map: a copy of the index's tiles,
        for inspection (it costs 4 bytes per map cell)."""
        return self.index.cells.dense(VERTEX)

    @property
    def owner(self) -> np.ndarray:
        """The edge whose interior covers each cell, or -1, over the whole map: a copy, as
        :attr:`vertex_at`."""
        return self.index.cells.dense(OWNER)

    @property
    def vertex_count(self) -> int:
        return self.index.vertex_count

    @property
    def edge_count(self) -> int:
        return self.index.edge_count

    def coverage(self) -> float:
        """The share of the map's cells that are vertices (the papers' coverage)."""
        return self.index.vertex_count / self.index.cells.size

    def edge_ids(self) -> np.ndarray:
        """The ids of the edges, ascending."""
        return self.index.edge_ids()

    def ends(self, edges: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """The (n, 2) end cells a and b of the given edges."""
        return self.index.ends(edges)

    def costs(self, edges: ArrayLike) -> np.ndarray:
        return self.index.cost[np.asarray(edges, dtype=np.int64)]

    def risks(self, edges: ArrayLike) -> np.ndarray:
        return self.index.risk[np.asarray(edges, dtype=np.int64)]

    def uses(self, edges: ArrayLike) -> np.ndarray:
        return self.index.uses[np.asarray(edges, dtype=np.int64)]

    def created(self, edges: ArrayLike) -> np.ndarray:
        return self.index.created[np.asarray(edges, dtype=np.int64)]

    def edges_at(self, cell: Cell) -> list[int]:
        """The edges containing ``cell``: the one it is inside of, or those meeting at it."""
        return self.index.edges_at(cell)

    def vertices(self) -> np.ndarray:
        """The (n, 2) cells of the vertices."""
        return self.index.vertices()

    def degree(self, cell: Cell) -> int:
        return self.index.degree(cell)

    def meeting(self, cell: Cell, delta: int, *, selective: bool = False) -> np.ndarray:
        """The edges that meet N(cell, delta) (:meth:`SegmentIndex.meeting`)."""
        return self.index.meeting(cell, delta, selective=selective)

    def adjacency(self) -> Adjacency:
        """The graph in CSR form, cached until the graph changes."""
        return self.index.adjacency()

    def tables(self) -> EdgeTables:
        """The graph as the compiled query reads it, cached until the graph changes."""
        return self.index.tables()

    def cell_tiles(self) -> tuple[np.ndarray, np.ndarray]:
        """The directory and tiles of the cell layers (:mod:`cbr_casegraph.tiles`), as the
        compiled kernels read them."""
        return self.index.cells.directory, self.index.cells.tiles

    def potentials(self) -> np.ndarray:
        """The landmark table of the graph search (:mod:`cbr_casegraph.potentials`), kept
        valid as the graph changes."""
        return self._potentials.of(self.index.adjacency())

    def heuristic_scale(self) -> float:
        """The least cost factor of a passable cell: no step costs less per unit of length.
        Kept until the map changes."""
        if self._scale is None:
            # a grid's factors are finite and positive by its cost contract: nothing to check
            least = float(np.min(self.grid.factor, where=self.grid.passable, initial=np.inf))
            self._scale = least if np.isfinite(least) else 1.0
        return self._scale

    def similar(self, a: Cell, b: Cell, delta: int, distance: str = "chebyshev") -> bool:
        """Eq. (12) (:func:`cbr_casegraph.retention.similar`)."""
        return retention.similar(self.index, a, b, delta, distance)

    # -- changes ---------------------------------------------------------------------------

    def set_grid(self, grid: Grid, cells: ArrayLike | None = None) -> None:
        """Take a changed map; recompute the edges through ``cells`` (all edges when None)."""
        if grid.risk.shape != self.index.shape:
            raise CbrError(f"the map changed size from {self.index.shape[1]}x"
                           f"{self.index.shape[0]} to {grid.width}x{grid.height}")
        self.grid = grid
        self._scale = None
        if cells is None:
            self.refresh()
            return
        writes.write_costs(self, costs.reprice(self.index, grid, costs.edges_through(
            self.index, cells)))

    def refresh(self, edges: Sequence[int] | None = None) -> None:
        """Recompute cost and risk of ``edges`` (all when None) from the current map; the
        changed ones of named ``edges`` are written to the store."""
        ids = self.index.edge_ids() if edges is None else np.asarray(edges, dtype=np.int64)
        changed = costs.reprice(self.index, self.grid, ids)
        if edges is not None:
            writes.write_costs(self, changed)

    def record_use(self, edges: Iterable[int]) -> None:
        """Count one more use of each edge still in the graph (the store counts its own)."""
        retention.record_use(self.index, edges)

    def add_path(self, path: ArrayLike, *, similarity_delta: int = 0,
                 distance: str = "chebyshev") -> list[int]:
        """Retain a traversed path (:func:`cbr_casegraph.retention.add_path`); the ids of
        the new edges."""
        return retention.add_path(self, path, similarity_delta=similarity_delta,
                                  distance=distance)

    def remove(self, edges: Iterable[int]) -> None:
        """Forget these edges; vertices left without edges disappear."""
        forgetting.remove(self, edges)

    def merge_redundant(self) -> int:
        """Delete the vertices in the middle of a straight edge; how many were removed."""
        return forgetting.merge_redundant(self)
