"""Trips along a one-dimensional corridor.

A robot moves between the numbered cells of a corridor, one cell per step. A query is a trip
``{"start": s, "goal": g}``; a solution is the list of cells visited. A remembered trip whose ends
lie close to the new one is reused by walking to its start, following it, and walking from its end
to the goal: longer than the direct walk, but no planning is needed. The fallback solver plans the
direct walk.
"""

from __future__ import annotations

import itertools
import json
from collections import Counter
from collections.abc import Generator, Iterator, Mapping
from typing import Any

import attrs

from cbrcore import Case, Match, Outcome, Proposal, Retrieval, Solution, hookimpl
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.options import option

KIND = "trip"
Trip = dict[str, int]


def walk(start: int, goal: int) -> list[int]:
    """The cells of the direct walk from ``start`` to ``goal``, both included."""
    step = 1 if goal >= start else -1
    return list(range(start, goal + step, step))


@attrs.frozen
class TripsOptions:
    trips: tuple[tuple[int, int], ...] = option(
        ((0, 5), (5, 0)), "The trips to make, in order, as [start, goal] cell pairs.")


class Trips:
    """The configured trips; a proposal succeeds when it is a walk from start to goal."""

    def __init__(self, options: TripsOptions, ctx: Context) -> None:
        self.trips = options.trips

    def __len__(self) -> int:
        return len(self.trips)

    def queries(self, ctx: Context) -> Iterator[Trip]:
        for start, goal in self.trips:
            yield {"start": start, "goal": goal}

    def execute(self, problem: Trip, proposal: Proposal, ctx: Context) -> Outcome:
        if proposal.solution is None:
            return Outcome(success=False)
        path = proposal.solution.value
        valid = (path[0] == problem["start"] and path[-1] == problem["goal"]
                 and all(abs(a - b) == 1 for a, b in itertools.pairwise(path)))
        return Outcome(success=valid, cost=float(len(path) - 1))

    def describe(self, problem: Trip) -> Mapping[str, Any]:
        return {"start": problem["start"], "goal": problem["goal"]}


@attrs.frozen
class ClosestTripOptions:
    max_offset: int = option(2, "Largest summed distance between the ends of the query and of a "
                                "retrieved trip.", validator=attrs.validators.ge(0))


class ClosestTrip:
    """Remembered trips whose ends are within ``max_offset`` cells of the query's, closest first."""

    def __init__(self, options: ClosestTripOptions, ctx: Context) -> None:
        self.max_offset = options.max_offset

    @hookimpl
    def cbr_retrieve(self, problem: Trip, casebase: CaseStore) -> Retrieval:
        matches = []
        for case in casebase.cases(KIND):
            start_offset = abs(problem["start"] - case.problem["start"])
            goal_offset = abs(problem["goal"] - case.problem["goal"])
            if start_offset + goal_offset <= self.max_offset:
                features = {"start_offset": float(start_offset), "goal_offset": float(goal_offset)}
                matches.append(Match(case, 1 / (1 + start_offset + goal_offset), features))
        matches.sort(key=lambda m: (-m.similarity, m.case.id))
        return Retrieval(tuple(matches))


class Splice:
    """Walk to the best trip's start, follow it, then walk from its end to the goal."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_reuse(self, problem: Trip, retrieval: Retrieval) -> Solution:
        case = retrieval.matches[0].case
        path = (walk(problem["start"], case.problem["start"])[:-1] + list(case.solution)
                + walk(case.problem["goal"], problem["goal"])[1:])
        return Solution(path, cost=float(len(path) - 1), cases=(case.id,))


class Walk:
    """Plan the direct walk."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_solve(self, problem: Trip) -> Solution:
        path = walk(problem["start"], problem["goal"])
        return Solution(path, cost=float(len(path) - 1))


class Remember:
    """Remember every successful trip whose start and goal are not remembered yet."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_retain(self, problem: Trip, solution: Solution, outcome: Outcome,
                   casebase: CaseStore) -> None:
        if outcome.success and all(c.problem != problem for c in casebase.cases(KIND)):
            casebase.add(Case(dict(problem), list(solution.value), kind=KIND))


class PhaseCounter:
    """Count the calls of each phase; the counts go to phase_counts.json in the run's folder."""

    def __init__(self, options: object, ctx: Context) -> None:
        self.counts: Counter[str] = Counter()
        self.out_dir = ctx.out_dir

    def _count(self, phase: str) -> Generator[None, Any, Any]:
        self.counts[phase] += 1
        return (yield)

    @hookimpl(wrapper=True)
    def cbr_retrieve(self) -> Generator[None, Any, Any]:
        return (yield from self._count("retrieve"))

    @hookimpl(wrapper=True)
    def cbr_reuse(self) -> Generator[None, Any, Any]:
        return (yield from self._count("reuse"))

    @hookimpl(wrapper=True)
    def cbr_solve(self) -> Generator[None, Any, Any]:
        return (yield from self._count("solve"))

    @hookimpl(wrapper=True)
    def cbr_retain(self) -> Generator[None, Any, Any]:
        return (yield from self._count("retain"))

    def close(self) -> None:
        if self.out_dir is not None:
            path = self.out_dir / "phase_counts.json"
            path.write_text(json.dumps(dict(self.counts), sort_keys=True), encoding="utf-8")
