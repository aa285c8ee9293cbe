"""A small test-only domain that exercises every phase: learning the squares of integers.

A query is an integer x; the right answer is x². The case base stores solved (x, x²) pairs; reuse
adapts a neighbour's answer along the tangent y0 + 2·x0·(x - x0), which is exact only when the
neighbour is x itself, so revision with a tolerance decides how much of the work the case base
can take. The fallback solver computes x² directly.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Generator, Iterator, Mapping
from typing import Any

import attrs

from cbrcore import Case, Match, Outcome, Proposal, Retrieval, Revision, Solution, hookimpl
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.options import option
from cbrcore.registry import Registry

KIND = "square"


@attrs.frozen
class SquaresOptions:
    count: int = option(20, "How many queries.", validator=attrs.validators.ge(0))
    high: int = option(10, "Queries are drawn from 0 .. high-1.", validator=attrs.validators.ge(1))


class Squares:
    """Queries x drawn uniformly; executing a proposal checks it against x²."""

    def __init__(self, options: SquaresOptions, ctx: Context) -> None:
        self.options = options

    def __len__(self) -> int:
        return self.options.count

    def queries(self, ctx: Context) -> Iterator[int]:
        for value in ctx.rng.integers(0, self.options.high, size=self.options.count):
            yield int(value)

    def execute(self, problem: int, proposal: Proposal, ctx: Context) -> Outcome:
        if proposal.solution is None:
            return Outcome(success=False)
        error = abs(proposal.solution.value - problem * problem)
        return Outcome(success=error == 0, cost=float(error))

    def describe(self, problem: int) -> Mapping[str, Any]:
        return {"x": problem}


@attrs.frozen
class NearestOptions:
    radius: int = option(2, "Largest |x - x0| of a retrieved case.",
                         validator=attrs.validators.ge(0))


class Nearest:
    """Stored cases within the radius, nearest first."""

    def __init__(self, options: NearestOptions, ctx: Context) -> None:
        self.radius = options.radius

    @hookimpl
    def cbr_retrieve(self, problem: int, casebase: CaseStore) -> Retrieval:
        found = [(abs(c.problem - problem), c) for c in casebase.cases(KIND)
                 if abs(c.problem - problem) <= self.radius]
        found.sort(key=lambda pair: (pair[0], pair[1].id))
        return Retrieval(tuple(Match(c, 1 / (1 + d), {"dx": float(d)}) for d, c in found))


class Tangent:
    """Adapt the best match along the tangent of x²."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_reuse(self, problem: int, retrieval: Retrieval) -> Solution:
        case = retrieval.matches[0].case
        x0, y0 = case.problem, case.solution
        return Solution(y0 + 2 * x0 * (problem - x0), cases=(case.id,))


@attrs.frozen
class ToleranceOptions:
    tolerance: float = option(0.0, "Largest accepted error.", validator=attrs.validators.ge(0))


class Tolerance:
    """Accept a reused answer whose error is within the tolerance."""

    def __init__(self, options: ToleranceOptions, ctx: Context) -> None:
        self.tolerance = options.tolerance

    @hookimpl
    def cbr_revise(self, problem: int, solution: Solution) -> Revision:
        error = abs(solution.value - problem * problem)
        if error <= self.tolerance:
            return Revision(True)
        return Revision(False, f"error {error} above {self.tolerance}")


class Compute:
    """The model-based method: compute x² directly."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_solve(self, problem: int) -> Solution:
        return Solution(problem * problem, cost=0.0)


class Keep:
    """Retain a correct answer unless its x is stored already."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_retain(self, problem: int, solution: Solution, outcome: Outcome,
                   casebase: CaseStore) -> None:
        if outcome.success and all(c.problem != problem for c in casebase.cases(KIND)):
            casebase.add(Case(problem, solution.value, kind=KIND))


@attrs.frozen
class CapacityOptions:
    limit: int = option(5, "Most cases kept.", validator=attrs.validators.ge(0))


class Capacity:
    """Forget the least used, then oldest, cases beyond the limit."""

    def __init__(self, options: CapacityOptions, ctx: Context) -> None:
        self.limit = options.limit

    @hookimpl
    def cbr_forget(self, casebase: CaseStore) -> None:
        cases = sorted(casebase.cases(KIND), key=lambda c: (c.uses, c.created, c.id))
        excess = len(cases) - self.limit
        if excess > 0:
            casebase.remove([c.id for c in cases[:excess]])


class CountCalls:
    """An observer counting calls per phase hook."""

    def __init__(self, options: object, ctx: Context) -> None:
        self.calls: Counter[str] = Counter()

    def _count(self, hook: str) -> Generator[None, Any, Any]:
        self.calls[hook] += 1
        return (yield)

    @hookimpl(wrapper=True)
    def cbr_retrieve(self) -> Generator[None, Any, Any]:
        return (yield from self._count("cbr_retrieve"))

    @hookimpl(wrapper=True)
    def cbr_solve(self) -> Generator[None, Any, Any]:
        return (yield from self._count("cbr_solve"))


class AbsError:
    """The absolute error of the executed answer."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    def measure(self, problem: int, proposal: Proposal, outcome: Outcome,
                ctx: Context) -> Mapping[str, float]:
        return {"abs_error": outcome.cost if outcome.cost is not None else float("nan")}


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("workload", "squares", Squares, options=SquaresOptions)
    registry.add("retriever", "nearest", Nearest, options=NearestOptions)
    registry.add("reuser", "tangent", Tangent)
    registry.add("reviser", "tolerance", Tolerance, options=ToleranceOptions)
    registry.add("solver", "compute", Compute)
    registry.add("retainer", "keep", Keep)
    registry.add("forgetter", "capacity", Capacity, options=CapacityOptions)
    registry.add("observer", "count_calls", CountCalls)
    registry.add("metric", "abs_error", AbsError)


TOY_CONFIG = """\
seed: 3
casebase: memory
workload: {use: squares, count: 30, high: 8}
retrieve: {use: nearest, radius: 1}
reuse: tangent
revise: {use: tolerance, tolerance: 0}
solver: compute
retain: [keep]
forget: [{use: capacity, limit: 6}]
metrics: [abs_error]
"""
