"""A forgetter holding the case base to a capacity, dropping the cases used least:
`forget: [{use: capacity, max_cases: 100}]`."""

import attrs

from cbrcore import hookimpl
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.options import option
from cbrcore.registry import Registry


@attrs.frozen
class CapacityOptions:
    max_cases: int = option(100, "The most cases kept.", validator=attrs.validators.ge(1))


class Capacity:
    def __init__(self, options: CapacityOptions, ctx: Context) -> None:
        self.max_cases = options.max_cases

    @hookimpl
    def cbr_forget(self, casebase: CaseStore) -> None:
        cases = casebase.cases()
        if len(cases) > self.max_cases:
            # least used first, the oldest first among equals
            cases.sort(key=lambda case: (case.uses, case.created))
            casebase.remove(case.id for case in cases[:len(cases) - self.max_cases])


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("forgetter", "capacity", Capacity, options=CapacityOptions)
