"""A plugin checking, in `cbr casebase check`, that every stored route starts at its problem's
start and ends at its goal."""

from cbrcore import hookimpl
from cbrcore.casebase.store import CaseStore


@hookimpl
def cbr_check_casebase(casebase: CaseStore) -> list[str]:
    problems = []
    for case in casebase.cases(kind="route"):
        route = case.solution
        if route[0] != case.problem["start"] or route[-1] != case.problem["goal"]:
            problems.append(f"case {case.id}: the route does not join its start and goal")
    return problems
