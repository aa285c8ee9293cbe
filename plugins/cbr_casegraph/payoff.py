"""Whether the case graph can pay off for a query: the hybrid's choice between CBR and its solver.

A CBR query of the case graph costs a nearly constant time (two local sweeps of
N(., delta + margin) and a search of the case graph, whose vertices are far fewer than the
map's cells), while an exact solver's time depends on the map and on how far apart start and
goal are: A* settles the cells its heuristic cannot rule out, jump point search only the points
where a path may turn, a few on an open map and many in a maze. Where the solver is cheap, a CBR
attempt costs more than the solver itself, and a failed one (no case near, or a path the quality
test rejects) is paid on top of the solver that plans the query after it.

Two rules make the choice, the ``casegraph`` retriever's options:

- :class:`Payoff`, fixed thresholds (``min_cells``, ``min_distance``): CBR is tried only on a
  map with enough passable cells and between a start and goal far enough apart. They know
  nothing of the solver: how much a map's size and a query's length cost it depends on the map
  (a maze against an open field) and on the solver (A* against jump point search).
- :class:`Learned` (``payoff: learned``), a running estimate per map: the queries are sorted
  into bands of the straight-line distance from start to goal (half an octave wide), and in each
  band the rule keeps the solver's time, CBR's time and the share of CBR attempts that gave an
  accepted path, each over the band's last :data:`WINDOW` queries that measured it. CBR is
  tried when its median time is below :data:`MARGIN` times the share times the solver's median
  time: an attempt that fails costs its time on top of the solver's, so an attempt pays only when
  ``cbr + (1 - share) * solver < solver``. Until a band has :data:`SAMPLES` measurements of
  each kind, its queries go to the solver and to CBR in turn, the solver first (its queries cost
  nothing against it), so that no verdict rests on one stray time. A verdict is revisited every
  :data:`REVISIT` queries in a row that follow it, since the case graph grows and the map's
  costs change: a band left to the solver tries CBR once more, and a band given to CBR leaves
  one query to the solver.

The learned rule measures what the query costs on this machine, with this solver, on this map,
so it carries over to maps and solvers it has never seen; its times come from the engine
(``Context.previous``, the phases of the query before) or, in a benchmark, from the caller. Given
the same times it makes the same choices.
"""

from __future__ import annotations

import statistics
from collections import deque

import attrs
import numpy as np

from cbr_grid.grid import Grid
from cbr_grid.query import Cell
from cbrcore.model import CASEBASE, Proposal

SMALL_MAP = "A* is cheaper here: the map is small"
SHORT_QUERY = "A* is cheaper here: start and goal are near"
SOLVER_CHEAPER = "the solver is cheaper here: measured at this distance on this map"
"""The reasons for leaving a query to the solver, as the engine counts them."""

WINDOW = 8
"""Measurements per band that the learned estimates are medians of: enough to outvote a stray
slow query, few enough to follow a case graph that grows and a map whose costs change."""

REVISIT = 32
"""After this many queries in a row of one band following its verdict, the learned rule makes
one query the other way, to measure again what it no longer measures."""

SAMPLES = 3
"""Measurements of each kind a band needs before its verdict is trusted: until then its queries
go to the solver and to CBR in turn, the solver first."""

MARGIN = 0.8
"""CBR is tried when its median time is below this share of the time it is expected to save;
below 1 so that a band where both take about as long goes to the solver, whose time is the
yardstick."""

_CBR_PHASES = ("retrieve", "reuse", "revise")
"""The phases of the engine a CBR attempt takes; the solver's is ``solve``."""


@attrs.frozen
class Payoff:
    """The thresholds of the choice; a query passing both is tried by CBR."""

    min_cells: int = 0
    min_distance: int = 0

    def reason(self, passable_cells: int, start: Cell, goal: Cell) -> str | None:
        """Why A* should plan this query instead of CBR, or None to try CBR."""
        if passable_cells < self.min_cells:
            return SMALL_MAP
        if max(abs(start[0] - goal[0]), abs(start[1] - goal[1])) < self.min_distance:
            return SHORT_QUERY
        return None


class PassableCells:
    """The number of passable cells of the latest map asked about, counted once per map."""

    def __init__(self) -> None:
        self._grid: Grid | None = None
        self._count = 0

    def of(self, grid: Grid) -> int:
        if grid is not self._grid:
            self._grid, self._count = grid, int(np.count_nonzero(grid.passable))
        return self._count


def band(start: Cell, goal: Cell) -> int:
    """The distance band of a query: bands are half an octave of the straight-line distance
    wide (the bit length of its square), so that the solver's times in one band are alike."""
    # integers only: it is asked before every query, which a solver may plan in microseconds
    dx, dy = start[0] - goal[0], start[1] - goal[1]
    return (dx * dx + dy * dy).bit_length()


class _Band:
    """What the learned rule measured in one band, and its verdict."""

    __slots__ = ("answered", "cbr", "solver", "streak", "verdict")

    def __init__(self) -> None:
        self.solver: deque[float] = deque(maxlen=WINDOW)
        self.cbr: deque[float] = deque(maxlen=WINDOW)
        self.answered: deque[bool] = deque(maxlen=WINDOW)
        self.verdict = False
        self.streak = 0

    def judge(self) -> None:
        if len(self.solver) < SAMPLES or len(self.cbr) < SAMPLES:
            return
        share = sum(self.answered) / len(self.answered)
        verdict = (statistics.median(self.cbr)
                   < MARGIN * share * statistics.median(self.solver))
        if verdict != self.verdict:
            self.verdict, self.streak = verdict, 0


class Learned:
    """The learned choice of one map: per distance band, CBR's time, its share of accepted paths
    and the solver's time, from the queries already planned (see the module's docstring)."""

    def __init__(self) -> None:
        self._bands: dict[int, _Band] = {}

    def tries(self, band: int) -> bool:
        """Whether to try CBR on the next query of ``band`` (:func:`band`); each call counts as
        one query decided."""
        known = self._bands.get(band)
        if known is None:
            return False
        solved, tried = len(known.solver), len(known.cbr)
        if solved < SAMPLES or tried < SAMPLES:
            return tried < SAMPLES and (solved >= SAMPLES or tried < solved)
        known.streak += 1
        if known.streak >= REVISIT:
            known.streak = 0
            return not known.verdict
        return known.verdict

    def solved(self, band: int, seconds: float) -> None:
        """The solver planned a query of ``band`` in ``seconds``."""
        known = self._bands.setdefault(band, _Band())
        known.solver.append(seconds)
        known.judge()

    def attempted(self, band: int, seconds: float, answered: bool) -> None:
        """CBR was tried on a query of ``band`` for ``seconds``; ``answered`` when its path was
        accepted (when not, report the solver's time that followed with :meth:`solved`)."""
        known = self._bands.setdefault(band, _Band())
        known.cbr.append(seconds)
        known.answered.append(answered)
        known.judge()

    def learn(self, band: int, tried: bool, proposal: Proposal) -> None:
        """Learn from the engine's ``proposal`` for a query of ``band``, on which CBR was
        ``tried`` or not: the phases' times it records (``Proposal.timings``)."""
        timings = proposal.timings
        if tried:
            self.attempted(band, sum(timings.get(phase, 0.0) for phase in _CBR_PHASES),
                           proposal.source == CASEBASE)
        if "solve" in timings:
            self.solved(band, timings["solve"])
