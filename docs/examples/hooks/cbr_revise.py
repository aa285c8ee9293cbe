"""A reviser rejecting a reused route much longer than the straight line:
`revise: {use: detour_limit, max_ratio: 1.5}`."""

import math

import attrs

from cbrcore import Revision, Solution, hookimpl
from cbrcore.context import Context
from cbrcore.options import option
from cbrcore.registry import Registry


@attrs.frozen
class DetourLimitOptions:
    max_ratio: float = option(1.5, "The longest route accepted, as a multiple of the straight "
                              "line.", validator=attrs.validators.ge(1))


class DetourLimit:
    def __init__(self, options: DetourLimitOptions, ctx: Context) -> None:
        self.max_ratio = options.max_ratio

    @hookimpl
    def cbr_revise(self, problem: dict, solution: Solution) -> Revision:
        straight = math.dist(problem["start"], problem["goal"])
        if solution.cost > self.max_ratio * straight:
            return Revision(False, f"route {solution.cost / straight:.2f} x the straight line")
        return Revision(True)


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("reviser", "detour_limit", DetourLimit, options=DetourLimitOptions)
