"""The run's whole-path cases as numpy arrays, written through to the case base.

A case is one traversed path (Kruusmaa & Svensson; Šeda & Dvořák eq. 5): kind ``path``, problem
``{"start": [x, y], "goal": [x, y]}``, solution the ordered cells ``[[x, y], ...]`` and meta
``{"cost": F, "length": l, "risk": r, "ideal": g, "traversals": n}`` (:mod:`cbr_pathcases.cost`).
Retrieval compares a query with every stored end point and retention compares a path with every
stored path, so both work on the arrays kept here rather than on the store's rows: the end
points, costs and use stamps as arrays, the cells of all paths concatenated.

Every change goes to the store at once, inside the engine's learn transaction. The arrays are a
view of the case base held by the core's store mirror (:mod:`cbrcore.casebase.mirror`), which
loads them anew after a learn step that rolled back or when another writer moved the store.
"""

from __future__ import annotations

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

_META = ("cost", "length", "risk", "ideal", "traversals")


def _int_array(values: Iterable[int]) -> np.ndarray:
    return np.fromiter(values, dtype=np.int64)


def path_case(path: np.ndarray, meta: Mapping[str, Any]) -> Case:
    """The case of a traversed ``path`` ((n, 2) cells) with its cost ``meta``."""
    return Case({"start": path[0].tolist(), "goal": path[-1].tolist()}, path.tolist(),
                kind=PATH, meta=dict(meta))


@attrs.define
class PathBase:
    """The stored paths, their end points, costs and use stamps, in step with the store.

    Row ``i`` of every array describes the case ``ids[i]``; ``paths[i]`` holds its cells.
    ``last_used`` is -1 for a case never reused.
    """

    store: CaseStore
    ids: np.ndarray
    starts: np.ndarray
    goals: np.ndarray
    costs: np.ndarray
    traversals: np.ndarray
    uses: np.ndarray
    created: np.ndarray
    last_used: np.ndarray
    paths: list[np.ndarray]
    _concatenated: tuple[np.ndarray, np.ndarray] | None = None

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
        *fields, paths = _columns([case for case in changes.cases if case.kind == PATH],
                                  self.store)
        ids = fields[0]
        at = np.searchsorted(self.ids, ids)
        stored = at < len(self.ids)
        stored[stored] = self.ids[at[stored]] == ids[stored]
        for row, path in zip(at[stored].tolist(), np.flatnonzero(stored).tolist(), strict=True):
            if not np.array_equal(self.paths[row], paths[path]):
                self._concatenated = None
            self.paths[row] = paths[path]
        new = ~stored
        ordered = not new.any() or not len(self.ids) or ids[new].min() > self.ids[-1]
        for name, values in zip(_FIELDS, fields, strict=True):
            column = getattr(self, name)
            column[at[stored]] = values[stored]
            if new.any():
                setattr(self, name, np.concatenate((column, values[new])))
        if new.any():
            self._concatenated = None
            self.paths += [paths[k] for k in np.flatnonzero(new).tolist()]
            if not ordered:
                # the protocol promises ids never reused, not ids that grow: rows stay ordered
                # by id, as loading orders them, whatever id a store gives a new case
                self._sort()
        return True

    def _sort(self) -> None:
        order = np.argsort(self.ids, kind="stable")
        for name in _FIELDS:
            setattr(self, name, getattr(self, name)[order])
        self.paths = [self.paths[i] for i in order.tolist()]

    def __len__(self) -> int:
        return len(self.ids)

    def rows(self, ids: Iterable[int]) -> np.ndarray:
        """The rows of the cases ``ids`` that are stored (others are left out)."""
        wanted = _int_array(ids)
        return np.flatnonzero(np.isin(self.ids, wanted))

    def concatenated(self) -> tuple[np.ndarray, np.ndarray]:
        """All cells as one (M, 2) array and the (k + 1,) offsets of each path in it."""
        if self._concatenated is None:
            lengths = _int_array(len(p) for p in self.paths)
            offsets = np.concatenate(([0], np.cumsum(lengths))).astype(np.int64)
            cells = (np.concatenate(self.paths) if self.paths
                     else np.zeros((0, 2), dtype=np.int64))
            self._concatenated = (np.ascontiguousarray(cells), offsets)
        return self._concatenated

    def add(self, path: np.ndarray, meta: Mapping[str, Any]) -> int:
        """Store ``path`` with its cost ``meta``; return its id."""
        case = self.store.add(path_case(path, meta))
        self._concatenated = None
        self.ids = np.append(self.ids, case.id)
        self.starts = np.vstack((self.starts, path[:1]))
        self.goals = np.vstack((self.goals, path[-1:]))
        self.costs = np.append(self.costs, float(meta["cost"]))
        self.traversals = np.append(self.traversals, int(meta["traversals"]))
        self.uses = np.append(self.uses, case.uses)
        self.created = np.append(self.created, case.created)
        self.last_used = np.append(self.last_used, -1)
        self.paths.append(path)
        return int(case.id or 0)

    def remove(self, ids: Iterable[int]) -> None:
        """Forget the cases ``ids``."""
        rows = self.rows(ids)
        if not len(rows):
            return
        self.store.remove(self.ids[rows].tolist())
        self._drop(rows)

    def _drop(self, rows: np.ndarray) -> None:
        """Forget the rows ``rows`` of the arrays (the store is not written)."""
        if not len(rows):
            return
        self._concatenated = None
        keep = np.ones(len(self.ids), dtype=bool)
        keep[rows] = False
        for name in _FIELDS:
            setattr(self, name, getattr(self, name)[keep])
        self.paths = [p for p, k in zip(self.paths, keep.tolist(), strict=True) if k]

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


_FIELDS = ("ids", "starts", "goals", "costs", "traversals", "uses", "created", "last_used")
"""The array fields of :class:`PathBase`, a row per case."""


def _columns(cases: list[Case], store: CaseStore) -> tuple[Any, ...]:
    """The :data:`_FIELDS` arrays of ``cases``, then their paths."""
    paths, metas = [], []
    for case in cases:
        paths.append(_cells(case, store))
        metas.append(_meta(case, store))
    ends = np.array([[p[0], p[-1]] for p in paths], dtype=np.int64).reshape(-1, 2, 2)
    return (_int_array(c.id or 0 for c in cases), ends[:, 0].copy(), ends[:, 1].copy(),
            np.array([m["cost"] for m in metas], dtype=float),
            _int_array(int(m["traversals"]) for m in metas),
            _int_array(c.uses for c in cases), _int_array(c.created or 0 for c in cases),
            _int_array(-1 if c.last_used is None else c.last_used for c in cases), paths)


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
