"""The run's whole-path cases as numpy arrays and a spatial index, written through to the case base.

A case is one traversed path (Kruusmaa & Svensson; Šeda & Dvořák eq. 5): kind ``path``, problem
``{"start": [x, y], "goal": [x, y]}``, solution the ordered cells ``[[x, y], ...]`` and meta
``{"cost": F, "length": l, "risk": r, "ideal": g, "traversals": n}`` (:mod:`cbr_pathcases.cost`).
Retrieval compares a query with every stored end point, so the end points, costs and use stamps
are kept as arrays (a row per case, in growing buffers, so that adding a case does not copy the
others). Retention compares a new path with the stored paths that can be near it: a path within
Hausdorff distance t of the new one has a cell within t of the new path's first cell and one
within t of its last cell (every cell of the new path lies within t of the old one), so an index
of the squares of ``BUCKET`` x ``BUCKET`` cells each stored path passes through, probed around
those two cells, gives every candidate, and the candidates' bounding boxes (kept per case) drop
those farther away. What a retain costs then grows with the paths near the new one, not with
the case base.

Every change goes to the store at once, inside the engine's learn transaction. The arrays are a
view of the case base held by the core's store mirror (:mod:`cbrcore.casebase.mirror`), which
loads them anew after a learn step that rolled back or when another writer moved the store; the
index follows every change in place (adding, forgetting, catching up with another writer).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping
from typing import Any

import attrs
import numpy as np

from cbr_grid.grid import grid_world
from cbr_grid.risk import recorded_map
from cbrcore.casebase.store import CaseStore, Changes
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.model import Case
from cbrcore.stash import StashKey

PATH = "path"
"""The case kind of a whole traversed path."""

BUCKET = 8
"""The side, in cells, of the squares by which the index lists the paths through them: large
enough that a path is listed in few squares (a 250-cell path in about 35), small enough that the
squares near a new path's ends hold few of the paths that are not near it."""

_META = ("cost", "length", "risk", "ideal", "traversals")

_SHIFTED_DROPS = 16
"""Up to this many rows dropped at once, the rows between them are moved up slice by slice (a
retain replaces a few similar paths); more (forgetting, another writer's removals), the kept
rows are gathered through a mask in one pass."""


def _int_array(values: Iterable[int]) -> np.ndarray:
    return np.fromiter(values, dtype=np.int64)


def path_case(path: np.ndarray, meta: Mapping[str, Any]) -> Case:
    """The case of a traversed ``path`` ((n, 2) cells) with its cost ``meta``."""
    return Case({"start": path[0].tolist(), "goal": path[-1].tolist()}, path.tolist(),
                kind=PATH, meta=dict(meta))


def _row_array(name: str, doc: str) -> property:
    def rows(self: PathBase) -> np.ndarray:
        return self._columns[name][:self._size]
    return property(rows, doc=doc)


def _squares(path: np.ndarray) -> list[int]:
    """The keys of the index squares ``path``'s cells lie in."""
    square = path // BUCKET
    return np.unique((square[:, 0] << 32) | square[:, 1]).tolist()


class PathBase:
    """The stored paths, their end points, costs and use stamps, in step with the store.

    Row ``i`` of every array describes the case ``ids[i]`` (rows ordered by id); ``paths[i]``
    holds its cells. ``last_used`` is -1 for a case never reused. The arrays are views of the
    rows in growing buffers: write into them, do not keep them across a change of the base.
    """

    ids = _row_array("ids", "The case ids, ascending.")
    starts = _row_array("starts", "The (k, 2) first cells of the paths.")
    goals = _row_array("goals", "The (k, 2) last cells of the paths.")
    costs = _row_array("costs", "The cost F of each path.")
    traversals = _row_array("traversals", "How many traversals each cost was learned from.")
    uses = _row_array("uses", "The use counts.")
    created = _row_array("created", "The creation stamps.")
    last_used = _row_array("last_used", "The stamps of the last uses, -1 for none.")
    boxes = _row_array("boxes", "The (k, 4) inclusive bounding boxes (x0, y0, x1, y1).")
    spans = _row_array("spans", "Where each path's cells lie in the store of cells: "
                       "[begin, end).")

    def __init__(self, store: CaseStore, columns: dict[str, np.ndarray],
                 paths: list[np.ndarray]) -> None:
        self.store = store
        self._columns = columns
        self._size = len(paths)
        # every path's cells, one after the other; a forgotten path's cells stay until the
        # store is compacted, when they are half of it
        self._cells = np.zeros((0, 2), dtype=np.int64)
        self._end = 0  # where the next path's cells go
        self._garbage = 0
        self._columns["spans"] = np.zeros((self._size, 2), dtype=np.int64)
        self.paths: list[np.ndarray] = paths
        self._compact()
        # index square -> the ids of the paths with a cell in it
        self._squares: dict[int, set[int]] = {}
        for case_id, path in zip(self.ids.tolist(), paths, strict=True):
            self._enter(case_id, path)

    @classmethod
    def load(cls, store: CaseStore) -> PathBase:
        """The path cases of ``store``; CbrError naming the case if one is malformed."""
        return cls(store, *_columns(store.cases(PATH), store))

    def catch_up(self, changes: Changes) -> bool:
        """Follow another writer's commits (:class:`~cbrcore.casebase.mirror.FollowsChanges`):
        drop the removed paths' rows, overwrite the rows of the written ones and append the new
        ones, so that what is unchanged is not copied. CbrError naming the case if a written
        one is malformed."""
        self._drop(self.rows(changes.removed))
        fields, paths = _columns([case for case in changes.cases if case.kind == PATH],
                                 self.store)
        ids = fields["ids"]
        at = np.searchsorted(self.ids, ids)
        stored = at < len(self.ids)
        stored[stored] = self.ids[at[stored]] == ids[stored]
        for row, path in zip(at[stored].tolist(), np.flatnonzero(stored).tolist(), strict=True):
            if not np.array_equal(self.paths[row], paths[path]):
                case_id = int(self.ids[row])
                self._leave(case_id, self.paths[row])
                self._enter(case_id, paths[path])
                self._garbage += len(self.paths[row])
                self.spans[row] = self._keep(paths[path])
                self.paths[row] = self._cells[self.spans[row, 0]:self.spans[row, 1]]
        for name, values in fields.items():
            self._columns[name][at[stored]] = values[stored]
        self._compact_if_half_garbage()
        new = np.flatnonzero(~stored)
        if len(new):
            ordered = not len(self.ids) or ids[new].min() > self.ids[-1]
            for k in new.tolist():
                self._append({name: values[k] for name, values in fields.items()}, paths[k])
            if not ordered:
                # the protocol promises ids never reused, not ids that grow: rows stay ordered
                # by id, as loading orders them, whatever id a store gives a new case
                self._sort()
        return True

    def _sort(self) -> None:
        order = np.argsort(self.ids, kind="stable")
        for column in self._columns.values():
            column[:self._size] = column[:self._size][order]
        self.paths = [self.paths[i] for i in order.tolist()]

    def __len__(self) -> int:
        return self._size

    def rows(self, ids: Iterable[int]) -> np.ndarray:
        """The rows of the cases ``ids`` that are stored (others are left out), ascending."""
        wanted = _int_array(ids)
        at = np.searchsorted(self.ids, wanted)
        found = at < self._size
        found[found] = self.ids[at[found]] == wanted[found]
        return np.unique(at[found])

    def near(self, path: np.ndarray, reach: float) -> np.ndarray:
        """The rows of every stored path P with D(path, P) <= ``reach`` (the directed Hausdorff
        distance under any cell distance of :mod:`cbr_grid.distances`), ascending; some farther
        ones may be among them.

        Each of those distances is at least the Chebyshev one, so P has a cell in the square of
        half side floor(reach) around ``path``'s first cell, and one around its last cell, and
        its bounding box comes that near ``path``'s box.
        """
        if not math.isfinite(reach):
            return np.arange(self._size)
        radius = int(reach)
        found: set[int] | None = None
        for x, y in {tuple(path[0].tolist()), tuple(path[-1].tolist())}:
            x0, y0 = max(x - radius, 0) // BUCKET, max(y - radius, 0) // BUCKET
            x1, y1 = (x + radius) // BUCKET, (y + radius) // BUCKET
            around: set[int] = set().union(*(
                self._squares.get((sx << 32) | sy, ()) for sx in range(x0, x1 + 1)
                for sy in range(y0, y1 + 1)))
            found = around if found is None else found & around
        rows = self.rows(found or ())
        box = self.boxes[rows]
        low, high = path.min(axis=0), path.max(axis=0)
        gap = np.maximum(np.maximum(box[:, :2] - high, low - box[:, 2:]), 0).max(axis=1)
        return rows[gap <= radius]

    def hausdorff(self, path: np.ndarray, *, distance: str, limit: float,
                  symmetric: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(rows, forward, backward)``: the rows of :meth:`near` (``path``, ``limit``) and
        the directed Hausdorff distances D(path, P) and D(P, path) of their paths
        (:func:`cbr_pathcases.hausdorff.hausdorff`: exact up to ``limit``, inf beyond). Every
        stored path with D(path, P) <= ``limit`` is among the rows, and with it every path
        within ``limit`` by the symmetric distance. ``symmetric``: only their maximum is
        wanted, so both are inf for a pair beyond ``limit`` either way."""
        from cbr_pathcases.hausdorff import hausdorff_spans  # compiled: with the first call

        rows = self.near(path, limit)
        spans = self.spans[rows]
        forward, backward = hausdorff_spans(
            np.ascontiguousarray(path, dtype=np.int64), self._cells,
            np.ascontiguousarray(spans[:, 0]), np.ascontiguousarray(spans[:, 1]),
            distance=distance, limit=limit, symmetric=symmetric)
        return rows, forward, backward

    def add(self, path: np.ndarray, meta: Mapping[str, Any]) -> int:
        """Store ``path`` with its cost ``meta``; return its id."""
        path = np.asarray(path, dtype=np.int64)
        case = self.store.add(path_case(path, meta))
        case_id = int(case.id or 0)
        ordered = not self._size or case_id > self.ids[-1]
        self._append({"ids": case_id, "starts": path[0], "goals": path[-1],
                      "costs": float(meta["cost"]), "traversals": int(meta["traversals"]),
                      "uses": case.uses, "created": case.created or 0, "last_used": -1,
                      "boxes": (*path.min(axis=0), *path.max(axis=0))}, path)
        if not ordered:
            self._sort()
        return case_id

    def _append(self, row: Mapping[str, Any], path: np.ndarray) -> None:
        """One more row, after the others; the buffers grow by doubling."""
        if self._size == len(self._columns["ids"]):
            for name, column in self._columns.items():
                bigger = np.empty((max(2 * self._size, 16), *column.shape[1:]), column.dtype)
                bigger[:self._size] = column[:self._size]
                self._columns[name] = bigger
        begin, end = self._keep(path)
        for name, value in {**row, "spans": (begin, end)}.items():
            self._columns[name][self._size] = value
        self._size += 1
        self.paths.append(self._cells[begin:end])
        self._enter(int(row["ids"]), path)

    def _keep(self, path: np.ndarray) -> tuple[int, int]:
        """Copy ``path`` to the end of the store of cells; where it lies there."""
        begin = self._end
        end = self._end = begin + len(path)
        if end > len(self._cells):
            bigger = np.empty((max(2 * end, 1024), 2), dtype=np.int64)
            bigger[:begin] = self._cells[:begin]
            self._cells = bigger
            # the rows' views follow the store to its new buffer
            self.paths = [bigger[b:e] for b, e in self.spans.tolist()]
        self._cells[begin:end] = path
        return begin, end

    def _compact(self) -> None:
        """Rewrite the store of cells with the rows' paths only, in row order."""
        lengths = np.fromiter((len(p) for p in self.paths), dtype=np.int64, count=len(self.paths))
        ends = np.cumsum(lengths)
        cells = np.zeros((max(2 * int(ends[-1]) if len(ends) else 0, 1024), 2), dtype=np.int64)
        if len(self.paths):
            cells[:ends[-1]] = np.concatenate(self.paths)
        self._cells = cells
        self._end = int(ends[-1]) if len(ends) else 0
        self.spans[:] = np.stack([ends - lengths, ends], axis=1)
        self.paths = [cells[b:e] for b, e in self.spans.tolist()]
        self._garbage = 0

    def _compact_if_half_garbage(self) -> None:
        if self._garbage > self._end // 2:
            self._compact()

    def remove(self, ids: Iterable[int]) -> None:
        """Forget the cases ``ids``."""
        rows = self.rows(ids)
        if not len(rows):
            return
        self.store.remove(self.ids[rows].tolist())
        self._drop(rows)

    def _drop(self, rows: np.ndarray) -> None:
        """Forget the rows ``rows`` (ascending, distinct) of the arrays and the index (the store
        is not written)."""
        if not len(rows):
            return
        for row in sorted(rows.tolist(), reverse=True):
            self._leave(int(self.ids[row]), self.paths[row])
            self._garbage += len(self.paths[row])
            del self.paths[row]
        first = int(rows[0])
        if len(rows) <= _SHIFTED_DROPS:
            # the rows between dropped ones move up in place: memory moves of the rows after
            # the first dropped one, many times cheaper than a gather through a mask
            bounds = [*rows.tolist(), self._size]
            for column in self._columns.values():
                to = first
                for row, following in itertools.pairwise(bounds):
                    column[to:to + following - row - 1] = column[row + 1:following]
                    to += following - row - 1
        else:
            keep = np.ones(self._size - first, dtype=bool)
            keep[rows - first] = False
            for column in self._columns.values():
                kept = column[first:self._size][keep]
                column[first:first + len(kept)] = kept
        self._size = len(self.paths)
        self._compact_if_half_garbage()

    def _enter(self, case_id: int, path: np.ndarray) -> None:
        for key in _squares(path):
            self._squares.setdefault(key, set()).add(case_id)

    def _leave(self, case_id: int, path: np.ndarray) -> None:
        for key in _squares(path):
            square = self._squares[key]
            square.discard(case_id)
            if not square:
                del self._squares[key]

    def set_cost(self, case_id: int, cost: float, traversals: int) -> None:
        """Record a new cost of case ``case_id``, learned from ``traversals`` traversals."""
        case = self.store.get(case_id)
        meta = {**case.meta, "cost": float(cost), "traversals": int(traversals)}
        self.store.replace(attrs.evolve(case, meta=meta))
        row = self.rows([case_id])
        self.costs[row], self.traversals[row] = cost, traversals
        self.refresh([case_id])

    def touch(self, ids: Iterable[int]) -> None:
        """Count one more use of each case ``ids``."""
        ids = list(ids)
        if ids:
            self.store.touch(ids)
            self.refresh(ids)

    def refresh(self, ids: Iterable[int]) -> None:
        """Read the use count and stamps of ``ids`` back from the store (the engine counts the
        uses of the cases a solution came from)."""
        for row in self.rows(ids).tolist():
            case = self.store.get(int(self.ids[row]))
            self.uses[row] = case.uses
            self.last_used[row] = -1 if case.last_used is None else case.last_used


def _columns(cases: list[Case], store: CaseStore) -> tuple[dict[str, np.ndarray],
                                                            list[np.ndarray]]:
    """The row arrays of ``cases`` by :class:`PathBase` attribute, and their paths."""
    paths, metas = [], []
    for case in cases:
        paths.append(_cells(case, store))
        metas.append(_meta(case, store))
    ends = np.array([[p[0], p[-1]] for p in paths], dtype=np.int64).reshape(-1, 2, 2)
    boxes = np.array([[*p.min(axis=0), *p.max(axis=0)] for p in paths],
                     dtype=np.int64).reshape(-1, 4)
    return {"ids": _int_array(c.id or 0 for c in cases),
            "starts": ends[:, 0].copy(), "goals": ends[:, 1].copy(),
            "costs": np.array([m["cost"] for m in metas], dtype=float),
            "traversals": _int_array(int(m["traversals"]) for m in metas),
            "uses": _int_array(c.uses for c in cases),
            "created": _int_array(c.created or 0 for c in cases),
            "last_used": _int_array(-1 if c.last_used is None else c.last_used for c in cases),
            "boxes": boxes}, paths


def _cells(case: Case, store: CaseStore) -> np.ndarray:
    where = f"case base {getattr(store, 'path', type(store).__name__)}, path case {case.id}"
    try:
        path = np.asarray(case.solution, dtype=np.int64)
    except (TypeError, ValueError):
        path = np.zeros(0)
    if path.ndim != 2 or path.shape[1] != 2 or len(path) == 0:
        raise CbrError(f"{where}: the solution must be a non-empty list of [x, y] cells")
    if (np.abs(np.diff(path, axis=0)).max(axis=1, initial=0) != 1).any():
        raise CbrError(f"{where}: the cells must follow each other in 8-neighbour steps")
    return path


def _meta(case: Case, store: CaseStore) -> Mapping[str, Any]:
    missing = [key for key in _META if not isinstance(case.meta.get(key), int | float)]
    if missing:
        where = f"case base {getattr(store, 'path', type(store).__name__)}, path case {case.id}"
        raise CbrError(f"{where}: meta needs numbers {', '.join(_META)}; missing or not a "
                       f"number: {', '.join(missing)}")
    return case.meta


def path_problems(casebase: CaseStore) -> list[str]:
    """The broken invariants of the path cases in ``casebase``; empty when they are sound.

    Each path is a non-empty list of integer [x, y] cells in 8-neighbour steps, on the map the
    case base records, starting and ending where its problem says; its meta holds finite,
    non-negative numbers (at least one traversal); the arrays the family loads from the store
    agree with the stored cases.
    """
    size, problems = recorded_map(casebase)
    cases = casebase.cases(PATH)
    for case in cases:
        problems += _case_problems(case, size)
    if problems or not cases:
        return problems
    try:
        base = PathBase.load(casebase)
    except CbrError as exc:
        return [f"the path cases cannot be loaded from the case base: {exc}"]
    loaded = {int(i): (p.tolist(), float(c), int(u)) for i, p, c, u in zip(
        base.ids.tolist(), base.paths, base.costs.tolist(), base.uses.tolist(), strict=True)}
    stored = {int(c.id or 0): (c.solution, float(c.meta["cost"]), c.uses) for c in cases}
    differ = sorted(i for i in set(loaded) | set(stored) if loaded.get(i) != stored.get(i))
    if differ:
        problems.append(f"the loaded path index differs from the path cases "
                        f"{', '.join(map(str, differ[:10]))}")
    return problems


def _case_problems(case: Case, size: tuple[int, int] | None) -> list[str]:
    where = f"path case {case.id}"
    path = case.solution
    if not (isinstance(path, list) and path and all(
            isinstance(cell, list) and len(cell) == 2
            and all(isinstance(v, int) and not isinstance(v, bool) for v in cell)
            for cell in path)):
        return [f"{where}: the solution must be a non-empty list of integer [x, y] cells"]
    problems = []
    cells = np.array(path, dtype=np.int64)
    if (np.abs(np.diff(cells, axis=0)).max(axis=1, initial=0) != 1).any():
        problems.append(f"{where}: the cells must follow each other in 8-neighbour steps")
    if cells.min() < 0 or (size is not None and ((cells[:, 0] >= size[0]).any()
                                                 or (cells[:, 1] >= size[1]).any())):
        shape = f"the recorded {size[0]}x{size[1]} map" if size else "the map"
        problems.append(f"{where}: a cell is outside {shape}")
    if case.problem != {"start": path[0], "goal": path[-1]}:
        problems.append(f"{where}: problem {case.problem!r}; expected the path's ends "
                        f"{{'start': {path[0]}, 'goal': {path[-1]}}}")
    for key in _META:
        value = case.meta.get(key)
        if (isinstance(value, bool) or not isinstance(value, int | float)
                or not math.isfinite(value) or value < 0):
            problems.append(f"{where}: meta {key!r} is {value!r}; expected a finite number "
                            ">= 0")
    traversals = case.meta.get("traversals")
    if isinstance(traversals, int | float) and 0 <= traversals < 1:
        problems.append(f"{where}: meta 'traversals' is {traversals!r}; a stored path was "
                        "traversed at least once")
    if case.uses < 0:
        problems.append(f"{where}: use count {case.uses}; expected a non-negative count")
    return problems


_PATHS = StashKey[PathBase]()


def base_of(ctx: Context) -> PathBase:
    """The run's path cases, loaded from the case base on first use and kept in step with it."""
    grid_world(ctx, "the index of whole-path cases")
    return ctx.mirror.view(_PATHS, PathBase.load)
