"""A reuser that takes the best retrieved route and swaps its ends for the query's:
`reuse: splice`."""

import itertools
import math

from cbrcore import Retrieval, Solution, hookimpl
from cbrcore.context import Context
from cbrcore.registry import Registry


def length(route: list) -> float:
    return sum(math.dist(a, b) for a, b in itertools.pairwise(route))


class Splice:
    def __init__(self, options: None, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_reuse(self, problem: dict, retrieval: Retrieval) -> Solution | None:
        best = retrieval.matches[0].case
        route = [problem["start"], *best.solution[1:-1], problem["goal"]]
        if len(route) < 2:
            return None  # adaptation failed: the solver answers
        return Solution(route, cost=length(route), cases=(best.id,))


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("reuser", "splice", Splice)
