"""A solver that builds its lookup table before anything is timed: `solver: table_lookup`.

`cbr_warm` is called once when the engine is built, so no query pays for the table."""

import math

from cbrcore import Solution, hookimpl
from cbrcore.context import Context
from cbrcore.registry import Registry


class TableLookup:
    def __init__(self, options: None, ctx: Context) -> None:
        self.table: dict[tuple[int, int], float] | None = None

    @hookimpl
    def cbr_warm(self) -> None:
        self.table = {(dx, dy): math.hypot(dx, dy) for dx in range(50) for dy in range(50)}

    @hookimpl
    def cbr_solve(self, problem: dict) -> Solution:
        (x0, y0), (x1, y1) = problem["start"], problem["goal"]
        cost = self.table[abs(x1 - x0), abs(y1 - y0)]
        return Solution([problem["start"], problem["goal"]], cost=cost)


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("solver", "table_lookup", TableLookup)
