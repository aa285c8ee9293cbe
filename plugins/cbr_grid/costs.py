"""What a path on a grid costs: the step cost factor planners use, and the paper's path costs.

**The step cost contract.** A grid's cost model yields a per-cell float64 array ``factor``
(``Grid.factor``, shape (height, width), at least 1 everywhere). On a large grid whose passable
cells all have one factor, ``factor`` holds that one value, broadcast over every cell (zero
strides, :func:`uniform_factor` reads it): no planner reads an obstacle's factor. One step
between 8-neighbour cells a and b costs ``step_length(a, b) * (factor[a] + factor[b]) / 2``,
with step length 1 orthogonally and sqrt(2) diagonally. Planners search with this cost;
``step_costs`` and ``path_cost(grid, path)`` evaluate it on a path.

**Reading eqs. (4)-(5).** The paper weights a linear segment (c_i, c_j) by F = l·r (4), with r the
sum of the risks of its cells, the two end cells counted half (5). Taken literally, F is 0 on a
risk-free map, so it cannot rank paths by length there, and a product is not additive: the cost
of a straight run depends on where it is cut into segments. The default model therefore takes
the paper's other suggestion, a weighted sum of length and risk: ``factor = 1 + w·risk`` with
``w = CostModel.risk_weight``. Summed over the steps of a straight segment, the averaged end
factors give l + w·s·r, where r is exactly the half-counted end cells of eq. (5) and s the step
length (1 or sqrt(2)): a diagonal run's risk weighs by the distance travelled through it. On a
risk-free map the cost is the path's octile length, and it grows with every cell's risk.

**The literal variants** remain available as path metrics over a path's linear segments (maximal
runs of equal steps, split where the direction changes), by name in :data:`PATH_COSTS`:

- ``length_x_risk``: sum over segments of l·r, eqs. (4)-(5);
- ``length_x_max_risk``: sum over segments of l·max risk, eq. (4) with the maximum risk of the
  segment's cells ("to avoid high risks in individual cells");
- ``risk_sum``: sum over segments of r (eq. (5)), the risk alone;
- ``length_plus_risk``: sum over segments of l + w·r, the weighted sum with eq. (5)'s cell-count
  risk.

Paths are sequences of (x, y) cells in 8-neighbour steps (see ``Grid.path_problems``); the
length and turn counts also accept any polyline of cells.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import attrs
import numpy as np
from numpy.typing import ArrayLike

from cbr_grid.query import path_array
from cbrcore.errors import CbrError

if TYPE_CHECKING:
    from cbr_grid.grid import Grid

SQRT2 = math.sqrt(2)


def _finite_non_negative(_: object, attribute: attrs.Attribute, value: float) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float) or not (
            math.isfinite(value) and value >= 0):
        raise ValueError(f"'{attribute.name}' must be a finite number >= 0, got {value!r}")


@attrs.frozen
class CostModel:
    """Step cost factor ``1 + risk_weight·risk``: length on a risk-free map, more with risk."""

    risk_weight: float = attrs.field(default=1.0, validator=_finite_non_negative)

    def factor(self, risk: np.ndarray) -> np.ndarray:
        """The per-cell factor of the step cost contract for a risk array."""
        return 1.0 + self.risk_weight * np.asarray(risk, dtype=np.float64)


def broadcast_factor(value: float, shape: tuple[int, int]) -> np.ndarray:
    """A read-only float64 array of ``shape`` holding ``value`` in every cell, in 8 bytes."""
    one = np.full((1, 1), value, dtype=np.float64)
    one.setflags(write=False)
    return np.broadcast_to(one, shape)


def uniform_factor(factor: np.ndarray) -> float | None:
    """The one value of a factor array made by :func:`broadcast_factor` (zero strides), else
    None: planners that handle it read that value instead of copying the array cell by cell."""
    if (isinstance(factor, np.ndarray) and factor.ndim == 2 and factor.size
            and factor.dtype == np.float64 and factor.strides == (0, 0)):
        return float(factor[0, 0])
    return None


def _cells(path: ArrayLike) -> np.ndarray:
    cells = path_array(path)
    if len(cells) == 0:
        raise CbrError("a path needs at least one cell")
    return cells


def _moves(grid: Grid, path: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """The path's cells and steps, checked to be on the grid and 8-connected."""
    cells = _cells(path)
    outside = ~grid.inside(cells)
    if outside.any():
        i = int(np.argmax(outside))
        raise CbrError(f"path cell {i} ({cells[i, 0]}, {cells[i, 1]}) is outside the "
                       f"{grid.width}x{grid.height} grid")
    steps = np.diff(cells, axis=0)
    jumps = np.abs(steps).max(axis=1, initial=0) != 1
    if jumps.any():
        i = int(np.argmax(jumps))
        raise CbrError(f"path step {i} from ({cells[i, 0]}, {cells[i, 1]}) to "
                       f"({cells[i + 1, 0]}, {cells[i + 1, 1]}) is not a move to an 8-neighbour")
    return cells, steps


def _step_lengths(steps: np.ndarray) -> np.ndarray:
    return np.where(np.abs(steps).sum(axis=1) == 2, SQRT2, 1.0)


def step_costs(grid: Grid, path: ArrayLike) -> np.ndarray:
    """The contract cost of each step of ``path``: length · mean of the two cells' factors."""
    cells, steps = _moves(grid, path)
    ends = grid.factor[cells[:, 1], cells[:, 0]]
    return _step_lengths(steps) * (ends[:-1] + ends[1:]) / 2


def path_length(path: ArrayLike) -> float:
    """The Euclidean length of the path: the sum of its steps' lengths."""
    steps = np.diff(_cells(path), axis=0)
    return float(np.hypot(steps[:, 0], steps[:, 1]).sum())


def turning_points(path: ArrayLike) -> np.ndarray:
    """Indices of the cells that delimit the path's linear segments: ends and turns.

    A turn is a cell where the direction of motion changes; repeated cells are skipped.
    """
    cells = _cells(path)
    keep = np.ones(len(cells), dtype=bool)
    keep[1:] = np.any(cells[1:] != cells[:-1], axis=1)
    index = np.flatnonzero(keep)
    if len(index) == 1:
        return np.array([0], dtype=np.int64)
    steps = np.diff(cells[index], axis=0)
    # same direction: parallel (zero cross product) and not reversed (positive dot product)
    cross = steps[:-1, 0] * steps[1:, 1] - steps[:-1, 1] * steps[1:, 0]
    dot = (steps[:-1] * steps[1:]).sum(axis=1)
    turn = (cross != 0) | (dot <= 0)
    inner = index[1:-1][turn]
    return np.concatenate(([index[0]], inner, [index[-1]]))


def turns(path: ArrayLike) -> int:
    """How many times the direction of motion changes along the path."""
    return max(len(turning_points(path)) - 2, 0)


def _cell_risk(grid: Grid, path: ArrayLike) -> np.ndarray:
    cells, _ = _moves(grid, path)
    return grid.risk[cells[:, 1], cells[:, 0]]


def risk_sum(grid: Grid, path: ArrayLike) -> float:
    """Eq. (5) over the whole path: its cells' risks, the two end cells counted half.

    This equals the sum of eq. (5) over the path's segments, wherever it turns.
    """
    risk = _cell_risk(grid, path)
    if len(risk) == 1:
        return float(risk[0])
    return float(risk.sum() - (risk[0] + risk[-1]) / 2)


def risk_max(grid: Grid, path: ArrayLike) -> float:
    """The highest risk of any cell on the path."""
    return float(_cell_risk(grid, path).max())


@attrs.frozen
class _Segments:
    """Per linear segment of a path: Euclidean length, eq. (5) risk, maximum cell risk."""

    length: np.ndarray
    risk: np.ndarray
    max_risk: np.ndarray


def _segments(grid: Grid, path: ArrayLike) -> _Segments:
    cells, steps = _moves(grid, path)
    bounds = turning_points(cells)
    if len(bounds) < 2:
        empty = np.zeros(0)
        return _Segments(empty, empty, empty)
    start, end = bounds[:-1], bounds[1:]
    lengths = np.concatenate(([0.0], np.cumsum(_step_lengths(steps))))
    risk = grid.risk[cells[:, 1], cells[:, 0]]
    total = np.concatenate(([0.0], np.cumsum(risk)))
    # cells start..end inclusive, minus half of each end cell
    seg_risk = total[end + 1] - total[start] - (risk[start] + risk[end]) / 2
    seg_max = np.maximum(np.maximum.reduceat(risk, start), risk[end])
    return _Segments(lengths[end] - lengths[start], seg_risk, seg_max)


def _factor_cost(grid: Grid, path: ArrayLike) -> float:
    return float(step_costs(grid, path).sum())


def _length_x_risk(grid: Grid, path: ArrayLike) -> float:
    seg = _segments(grid, path)
    return float((seg.length * seg.risk).sum())


def _length_x_max_risk(grid: Grid, path: ArrayLike) -> float:
    seg = _segments(grid, path)
    return float((seg.length * seg.max_risk).sum())


def _risk_sum(grid: Grid, path: ArrayLike) -> float:
    return float(_segments(grid, path).risk.sum())


def _length_plus_risk(grid: Grid, path: ArrayLike) -> float:
    seg = _segments(grid, path)
    return float((seg.length + grid.cost_model.risk_weight * seg.risk).sum())


PATH_COSTS: dict[str, Callable[[Grid, ArrayLike], float]] = {
    "factor": _factor_cost,
    "length_x_risk": _length_x_risk,
    "length_x_max_risk": _length_x_max_risk,
    "risk_sum": _risk_sum,
    "length_plus_risk": _length_plus_risk,
}
"""Every path cost by name: ``factor`` is the step cost contract, the others the paper's."""


def path_cost(grid: Grid, path: ArrayLike, model: str = "factor") -> float:
    """The cost of ``path`` on ``grid`` under the named model of :data:`PATH_COSTS`."""
    try:
        cost = PATH_COSTS[model]
    except KeyError:
        raise CbrError(f"unknown path cost {model!r}; known: {', '.join(PATH_COSTS)}") from None
    return cost(grid, path)


def path_metrics(grid: Grid, path: ArrayLike) -> dict[str, float]:
    """The path's length, contract cost, risk sum and maximum, and number of turns."""
    return {
        "length": path_length(path),
        "cost": path_cost(grid, path),
        "risk_sum": risk_sum(grid, path),
        "risk_max": risk_max(grid, path),
        "turns": float(turns(path)),
    }
