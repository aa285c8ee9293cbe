"""The fallback solver of an empty room: the straight line from start to goal,
`solver: straight_line`."""

import math

from cbrcore import Solution, hookimpl
from cbrcore.context import Context
from cbrcore.registry import Registry


class StraightLine:
    def __init__(self, options: None, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_solve(self, problem: dict) -> Solution:
        start, goal = problem["start"], problem["goal"]
        return Solution([start, goal], cost=math.dist(start, goal))


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("solver", "straight_line", StraightLine)
