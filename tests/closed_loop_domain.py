"""A small test-only closed-loop domain: a robot drives along a lane, swerving around obstacles.

The robot drives the lane ``LENGTH`` units long, one unit per tick, ``laps`` times. The obstacles
of ``COURSE`` lie along it; an obstacle of size n comes into view when the robot is ``sight`` x n
units before it (bigger obstacles are seen from farther), and the agent is consulted then for
the swerve: how far to the side the robot moves (``{"lap", "at", "size"}`` is the problem, the
offset the solution). The swerve's outcome is known when the robot has passed the obstacle's far
end; a swerve still under way when the lap ends failed (the robot stopped at the end of the
lane, beside the obstacle). Several swerves may be under way at once, and their outcomes come in
another order than their consultations.

The case base remembers the offset of each size the robot has passed; a stored size answers later
consultations, in the same lap or a later one, while a size still being swerved around and not
yet passed goes to the solver again.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import attrs

from cbrcore import Case, Match, Outcome, Retrieval, Solution, hookimpl
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.options import option
from cbrcore.registry import Registry
from cbrcore.workload import Decision, Session

KIND = "swerve"
LENGTH = 14
COURSE = ((2, 1), (4, 1), (6, 3), (10, 1), (12, 3))
"""The obstacles along the lane, in the order the robot meets them: where each starts, its size."""

Swerve = dict[str, int]


@attrs.frozen
class LaneOptions:
    laps: int = option(2, "How many times the robot drives the lane.",
                       validator=attrs.validators.ge(0))
    sight: int = option(2, "An obstacle of size n comes into view sight x n units before it.",
                        validator=attrs.validators.ge(0))


class Lane:
    """Laps along the lane; the agent is consulted for a swerve when an obstacle comes into
    view, and learns it when the robot has passed the obstacle or the lap is over."""

    def __init__(self, options: LaneOptions, ctx: Context) -> None:
        self.options = options

    def __len__(self) -> int:
        return self.options.laps * len(COURSE)

    def describe(self, problem: Swerve) -> Mapping[str, Any]:
        return problem

    def run(self, session: Session) -> None:
        for lap in range(self.options.laps):
            swerving: dict[int, Decision] = {}  # obstacle index -> the decision under way
            for x in range(LENGTH + 1):
                for k, decision in list(swerving.items()):
                    at, size = COURSE[k]
                    if x == at + size:
                        offset = float(decision.proposal.solution.value)
                        session.learn(swerving.pop(k), Outcome(True, cost=offset))
                for k, (at, size) in enumerate(COURSE):
                    if x == max(at - self.options.sight * size, 0):
                        decision = session.consult({"lap": lap, "at": at, "size": size})
                        if decision.proposal.solution is None:
                            session.learn(decision, Outcome(False))  # no swerve: it stopped
                        else:
                            swerving[k] = decision
            for decision in session.pending:
                session.learn(decision, Outcome(False))


class SameSize:
    """The remembered swerve of an obstacle of the same size."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_retrieve(self, problem: Swerve, casebase: CaseStore) -> Retrieval:
        return Retrieval(tuple(Match(c, 1.0) for c in casebase.cases(KIND)
                               if c.problem["size"] == problem["size"]))


class SameOffset:
    """Swerve by the remembered offset."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_reuse(self, retrieval: Retrieval) -> Solution:
        case = retrieval.matches[0].case
        return Solution(case.solution, cost=float(case.solution), cases=(case.id,))


class Margin:
    """The model-based method: swerve by the obstacle's size plus one unit of margin."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_solve(self, problem: Swerve) -> Solution:
        offset = problem["size"] + 1
        return Solution(offset, cost=float(offset))


class RememberPassed:
    """Remember the offset of a passed obstacle whose size is not remembered yet."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_retain(self, problem: Swerve, solution: Solution, outcome: Outcome,
                   casebase: CaseStore) -> None:
        sizes = {c.problem["size"] for c in casebase.cases(KIND)}
        if outcome.success and problem["size"] not in sizes:
            casebase.add(Case({"size": problem["size"]}, solution.value, kind=KIND))


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("workload", "lane", Lane, options=LaneOptions)
    registry.add("retriever", "same_size", SameSize)
    registry.add("reuser", "same_offset", SameOffset)
    registry.add("solver", "margin", Margin)
    registry.add("retainer", "remember_passed", RememberPassed)


LANE_CONFIG = """\
seed: 0
casebase: memory
workload: {use: lane, laps: 2, sight: 2}
retrieve: same_size
reuse: same_offset
solver: margin
retain: [remember_passed]
"""
