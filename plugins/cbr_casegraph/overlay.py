"""The overlay of one query: the virtual vertices and temporary edges that extend the stored
graph to G' (steps 1-4 of :mod:`cbr_casegraph.planner`).

A terminal or a link's end that is no stored vertex becomes a virtual vertex, numbered after the
stored ones; one lying inside a stored edge splits that edge virtually, into temporary parts
from vertex to vertex along it. The stored graph is never modified: the overlay exists only for
the query.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable

import attrs
import numpy as np

from cbr_casegraph.index import EdgeTables
from cbr_casegraph.search import run_costs
from cbr_casegraph.tiles import OWNER, VERTEX, CellTiles
from cbr_grid.grid import Grid

Cell = tuple[int, int]
Trace = Callable[[], np.ndarray]
"""The cells of a temporary edge from its tail to its head, made on demand."""


@attrs.define
class Overlay:
    """The virtual vertices and temporary edges of one query on the stored graph whose cell
    layers are ``stored`` and whose vertices number ``base``."""

    stored: CellTiles
    base: int
    cells: list[Cell] = attrs.field(factory=list)
    index: dict[Cell, int] = attrs.field(factory=dict)
    # temporary edges: (u, v, cost, the cells from u to v on demand (None for the part of a
    # split stored edge: a straight run), the stored edge it is a part of or -1)
    edges: list[tuple[int, int, float, Trace | None, int]] = attrs.field(factory=list)
    # stored edge -> cells inside it that became virtual vertices
    splits: dict[int, set[Cell]] = attrs.field(factory=dict)

    def vertex(self, cell: Cell) -> int:
        """The vertex of ``cell`` in G': a stored vertex, or a virtual one (split if inside)."""
        stored = self.stored.value(VERTEX, cell[0], cell[1])
        if stored >= 0:
            return stored
        if cell not in self.index:
            self.index[cell] = self.base + len(self.cells)
            self.cells.append(cell)
            inside = self.stored.value(OWNER, cell[0], cell[1])
            if inside >= 0:
                self.splits.setdefault(inside, set()).add(cell)
        return self.index[cell]

    def xy(self, stored: np.ndarray) -> np.ndarray:
        """The cells of every vertex of G': the ``stored`` ones, then the virtual ones."""
        if not self.cells:
            return stored
        return np.concatenate([stored, np.asarray(self.cells, dtype=np.int64).reshape(-1, 2)])


def split_edges(overlay: Overlay, grid: Grid, tables: EdgeTables) -> None:
    """Temporary parts of every stored edge with virtual vertices inside it, end to end, priced
    on ``grid``."""
    if not overlay.splits:
        return
    split = list(overlay.splits)
    starts, ends = tables.ends(split)
    parts_from: list[Cell] = []
    parts_to: list[Cell] = []
    chains: list[tuple[int, int, int]] = []
    for edge, a, b in zip(split, starts.tolist(), ends.tolist(), strict=True):
        points = sorted(overlay.splits[edge],
                        key=lambda c: max(abs(c[0] - a[0]), abs(c[1] - a[1])))
        chain = [(a[0], a[1]), *points, (b[0], b[1])]
        for p, q in itertools.pairwise(chain):
            parts_from.append(p)
            parts_to.append(q)
            chains.append((overlay.vertex(p), overlay.vertex(q), edge))
    costs = run_costs(grid.factor, grid.passable, grid.corner_cutting,
                      np.asarray(parts_from, dtype=np.int64).reshape(-1, 2),
                      np.asarray(parts_to, dtype=np.int64).reshape(-1, 2))
    for (u, v, edge), cost in zip(chains, costs.tolist(), strict=True):
        overlay.edges.append((u, v, cost, None, edge))
