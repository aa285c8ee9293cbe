"""A retainer keeping every route the robot completed as a case: `retain: [keep_routes]`."""

from cbrcore import Case, Outcome, Solution, hookimpl
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.registry import Registry


class KeepRoutes:
    def __init__(self, options: None, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_retain(self, problem: dict, solution: Solution, outcome: Outcome,
                   casebase: CaseStore) -> None:
        if solution.no_action or not outcome.success:
            return  # nothing was driven, or it failed: not worth keeping
        casebase.add(Case(problem, solution.value, kind="route"))


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("retainer", "keep_routes", KeepRoutes)
