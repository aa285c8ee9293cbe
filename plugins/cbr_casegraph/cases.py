"""The case form of a case graph edge: a case of kind ``segment`` in the case base.

Every edge is a case whose id is the edge's id, its problem the two end cells
``{"a": [x, y], "b": [x, y]}``, its solution the cost (None while a cell is an obstacle), the
mean risk and the length. A stored segment that does not fit the map is refused with a CbrError
naming the case base and the case.
"""

from __future__ import annotations

import math

import numpy as np

from cbr_casegraph.geometry import is_straight
from cbr_grid.grid import Grid
from cbrcore.casebase.store import CaseStore
from cbrcore.errors import CbrError
from cbrcore.model import Case

SEGMENT = "segment"
"""The case kind of a case graph edge."""

Cell = tuple[int, int]


def segment_case(a: Cell, b: Cell, cost: float, risk: float, uses: int) -> Case:
    """The case of the edge a-b, without its id (the store gives it)."""
    length = float(np.hypot(b[0] - a[0], b[1] - a[1]))
    return Case({"a": list(a), "b": list(b)},
                {"cost": cost if math.isfinite(cost) else None, "risk": risk,
                 "length": length}, kind=SEGMENT, uses=uses)


def segment_ends(case: Case, grid: Grid, source: str) -> tuple[Cell, Cell]:
    """The end cells of a stored segment case, checked against ``grid``; CbrError naming the
    case base ``source`` and the case when they are malformed, off the map or not straight."""
    try:
        a = (int(case.problem["a"][0]), int(case.problem["a"][1]))
        b = (int(case.problem["b"][0]), int(case.problem["b"][1]))
    except (KeyError, IndexError, TypeError, ValueError):
        raise CbrError(f"case base {source}: segment case {case.id} has problem "
                       f"{case.problem!r}; expected {{'a': [x, y], 'b': [x, y]}}") from None
    w, h = grid.width, grid.height
    for cell in (a, b):
        if not (0 <= cell[0] < w and 0 <= cell[1] < h):
            raise CbrError(f"case base {source}: segment case {case.id} has end "
                           f"{cell} outside the {w}x{h} map; the case base belongs to "
                           "another map")
    if not is_straight(a, b):
        raise CbrError(f"case base {source}: segment case {case.id} from {a} to "
                       f"{b} is not a straight line in one of the 8 grid directions")
    return a, b


def same_ends(case: Case, ends: set[Cell]) -> bool:
    """Whether ``case`` still joins the two cells ``ends``."""
    problem = case.problem
    return isinstance(problem, dict) and ends == {
        tuple(problem.get("a") or ()), tuple(problem.get("b") or ())}


def store_name(store: CaseStore | None) -> str:
    """The case base as errors name it: its path, or its type."""
    path = getattr(store, "path", None)
    return str(path) if path is not None else type(store).__name__
