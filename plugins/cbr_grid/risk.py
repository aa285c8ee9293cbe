"""Map learning: the robot's map learns the risk of the cells its trips showed it.

Reading of the paper (sections 4.1 and 4.5): when the robot meets an obstacle in a cell, the
cell's risk in its map rises by ``hit_risk`` (capped at 1, an obstacle), so an obstacle met again
and again becomes one for later planning; a cell passed safely loses ``pass_relief`` of its risk
(floored at 0).

Learning is retention: the ``risk_map`` retainer learns from the drive report of the ``trips``
workload inside the engine's learn step, writes the learned risks into the case base (meta key
``grid.learned_risk``, ``{"x,y": risk}``, only cells whose risk differs from the configured map)
and makes the learned map the run's world. The learned map is a view of the case base kept by
the core's store mirror (``ctx.learn_world``): a learn step that rolls back drops it, so the map
is never ahead of the case base, and what another process sharing the case base learned reaches
the planners at the next query.

A grid family that writes cases records the size of the map they were learned on (meta key
``grid.map``, :func:`record_map`), so that ``cbr casebase check`` can tell a case or learned cell
off the map without loading the world (:func:`risk_problems`, the risk map's invariants).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import attrs
import numpy as np

from cbr_grid.drive import DriveReport
from cbr_grid.grid import Grid, grid_world
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Outcome
from cbrcore.options import option
from cbrcore.stash import StashKey

LEARNED_RISK = "grid.learned_risk"
"""Case base meta key of the risks the robot learned: ``{"x,y": risk}``."""

CONFIGURED_WORLD = StashKey[Grid]()
"""The world as configured, before learned risks were applied to it."""

MAP = "grid.map"
"""Case base meta key of the map the cases were learned on: ``{"width": w, "height": h}``."""

_DECIMALS = 12
"""Learned risks are rounded so that rises and reliefs that cancel out return exactly."""

_UNIT = attrs.validators.and_(attrs.validators.instance_of(float), attrs.validators.ge(0.0),
                              attrs.validators.le(1.0))


_LEARNED = StashKey[Grid]()
"""The map as learned so far: the configured map with the stored risks applied."""


@attrs.frozen
class RiskOptions:
    hit_risk: float = option(
        0.5, "Risk added to a cell where the robot met an obstacle (capped at 1, an obstacle).",
        validator=_UNIT)
    pass_relief: float = option(
        0.05, "Risk removed from each cell the robot passed safely (floored at 0).",
        validator=_UNIT)


def risk_changes(grid: Grid, report: DriveReport, hit_risk: float, pass_relief: float
                 ) -> list[list[Any]]:
    """The cells whose risk one trip changes on ``grid``, as [x, y, new risk] in row-major
    order: passed cells relieved, met cells raised."""
    # only the cells the trip touched are looked at, so a trip costs in proportion to its path
    flat = np.unique(report.driven[:, 1] * grid.width + report.driven[:, 0])
    passed = np.column_stack((flat % grid.width, flat // grid.width))
    met = np.array(report.met, dtype=np.int64).reshape(-1, 2)
    cells = np.concatenate((passed, met))
    old = grid.risk[cells[:, 1], cells[:, 0]]
    # a met cell is never passed, so no cell is both relieved and raised; rounding lets rises
    # and reliefs that cancel out return exactly to where they started
    new = np.concatenate((
        np.maximum(np.round(old[:len(passed)] - pass_relief, _DECIMALS), 0.0),
        np.minimum(np.round(old[len(passed):] + hit_risk, _DECIMALS), 1.0)))
    # a hit or relief of 0 leaves a cell alone rather than rounding its configured risk
    amounts = np.repeat([pass_relief, hit_risk], [len(passed), len(met)])
    changed = (new != old) & (amounts > 0)
    order = np.lexsort((cells[changed, 0], cells[changed, 1]))
    return [[int(x), int(y), float(v)] for (x, y), v in zip(
        cells[changed][order].tolist(), new[changed][order].tolist(), strict=True)]


def _key(x: int, y: int) -> str:
    return f"{x},{y}"


class RiskMap:
    """Learn the risk of the cells a trip met or passed, keep it in the case base and plan on it.

    Built, it applies the risks stored in the case base (meta key ``grid.learned_risk``, a mapping
    ``{"x,y": risk}``) to the run's world. Each retain learns from the outcome's drive report (of
    the ``trips`` workload): a met cell's risk rises by ``hit_risk``, a passed cell's falls by
    ``pass_relief``; the changed risks go into the stored mapping, which keeps only cells whose
    risk differs from the configured map, and the learned map becomes the run's world, both
    inside the learn step's transaction.
    """

    def __init__(self, options: RiskOptions, ctx: Context) -> None:
        self.options = options
        grid = grid_world(ctx, "retainer 'risk_map'")
        self.configured = ctx.stash.setdefault(CONFIGURED_WORLD, grid)
        ctx.learn_world(_LEARNED, self._load)
        grid_world(ctx, "retainer 'risk_map'")  # the stored risks are checked now, not later

    def _load(self, casebase: CaseStore) -> Grid:
        learned = stored_risks(casebase, self.configured)
        if not learned:
            return self.configured
        risk = self.configured.risk.copy()
        for (x, y), value in learned.items():
            risk[y, x] = value
        return attrs.evolve(self.configured, risk=risk)

    @hookimpl
    def cbr_retain(self, outcome: Outcome, casebase: CaseStore, ctx: Context) -> None:
        if not isinstance(outcome.report, DriveReport):
            return
        learned: Grid = ctx.world
        changes = risk_changes(learned, outcome.report, self.options.hit_risk,
                               self.options.pass_relief)
        if not changes:
            return
        risk = learned.risk.copy()
        stored = dict(casebase.get_meta(LEARNED_RISK, {}))
        for x, y, value in changes:
            risk[y, x] = value
            if value == self.configured.risk[y, x]:
                stored.pop(_key(x, y), None)
            else:
                stored[_key(x, y)] = float(value)
        casebase.set_meta(LEARNED_RISK, stored)
        record_map(casebase, learned)
        ctx.mirror.put(_LEARNED, attrs.evolve(learned, risk=risk))


def record_map(casebase: CaseStore, grid: Grid) -> None:
    """Record the size of ``grid`` as the map of ``casebase``'s cases, inside the learn step that
    writes them; a case base that already records it is left alone."""
    size = {"width": grid.width, "height": grid.height}
    if casebase.get_meta(MAP) != size:
        casebase.set_meta(MAP, size)


def recorded_map(casebase: CaseStore) -> tuple[tuple[int, int] | None, list[str]]:
    """The (width, height) the case base records for its map (None when it records none), and
    what is wrong with the record."""
    value = casebase.get_meta(MAP)
    if value is None:
        return None, []
    if (isinstance(value, Mapping) and set(value) == {"width", "height"}
            and all(isinstance(value[k], int) and not isinstance(value[k], bool) and value[k] > 0
                    for k in ("width", "height"))):
        return (value["width"], value["height"]), []
    return None, [f"meta {MAP!r} is {value!r}; expected {{'width': w, 'height': h}} with "
                  "positive integers"]


def risk_problems(casebase: CaseStore) -> list[str]:
    """The broken invariants of the learned risks in ``casebase``: each entry names a cell once,
    as 'x,y', on the recorded map, with a risk in [0, 1]."""
    size, problems = recorded_map(casebase)
    stored = casebase.get_meta(LEARNED_RISK)
    if stored is None:
        return problems
    if not isinstance(stored, Mapping):
        return [*problems, f"meta {LEARNED_RISK!r} is a {type(stored).__name__}; expected a "
                           "mapping of 'x,y' cells to risks"]
    seen: dict[tuple[int, int], str] = {}
    for key, value in stored.items():
        where = f"meta {LEARNED_RISK!r} entry {key!r}"
        try:
            x, y = (int(part) for part in str(key).split(","))
        except ValueError:
            problems.append(f"{where}: expected a cell 'x,y' of two integers")
            continue
        if (x, y) in seen:
            problems.append(f"{where}: cell ({x}, {y}) is listed twice (also as "
                            f"{seen[x, y]!r})")
        seen[x, y] = str(key)
        if x < 0 or y < 0 or (size is not None and not (x < size[0] and y < size[1])):
            shape = f"the recorded {size[0]}x{size[1]} map" if size else "the map"
            problems.append(f"{where}: cell ({x}, {y}) is outside {shape}")
        if (isinstance(value, bool) or not isinstance(value, int | float)
                or not 0 <= value <= 1):
            problems.append(f"{where}: risk {value!r}; expected a number in [0, 1]")
    return problems


def stored_risks(casebase: CaseStore, grid: Grid) -> dict[tuple[int, int], float]:
    """The learned risks stored in ``casebase``, checked against ``grid``; a CbrError naming the
    case base and the entry when one is malformed or off the map."""
    stored = casebase.get_meta(LEARNED_RISK, {})
    where = f"case base {getattr(casebase, 'path', type(casebase).__name__)}"
    if not isinstance(stored, Mapping):
        raise CbrError(f"{where}: meta {LEARNED_RISK!r} must map 'x,y' to a risk, got "
                       f"{type(stored).__name__}")
    learned: dict[tuple[int, int], float] = {}
    for key, value in stored.items():
        try:
            x, y = (int(part) for part in str(key).split(","))
        except ValueError:
            raise CbrError(f"{where}: meta {LEARNED_RISK!r} has key {key!r}, expected a "
                           f"cell 'x,y'") from None
        if not grid.in_bounds((x, y)):
            raise CbrError(f"{where}: learned cell ({x}, {y}) is outside the "
                           f"{grid.width}x{grid.height} world; the case base was learned "
                           f"on another map")
        if isinstance(value, bool) or not isinstance(value, int | float) or not (0 <= value <= 1):
            raise CbrError(f"{where}: learned risk of cell ({x}, {y}) must be a number in "
                           f"[0, 1], got {value!r}")
        learned[x, y] = float(value)
    return learned
