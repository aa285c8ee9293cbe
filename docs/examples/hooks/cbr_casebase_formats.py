"""A plugin offering a CSV format of routes, `.routes` files (`cbr casebase export --format
routes-csv`):
one line per case, start, goal and the waypoints as x y pairs."""

from typing import Any

from cbrcore import Case, hookimpl
from cbrcore.casebase import Document
from cbrcore.casebase.exchange import refusal
from cbrcore.casebase.formats import DocumentFormat


def dump(document: Document, world: Any) -> str:
    lines = []
    for case in document.cases:
        points = [case.problem["start"], case.problem["goal"], *case.solution]
        lines.append(",".join(f"{x:g} {y:g}" for x, y in points))
    return "\n".join(lines) + "\n"


def parse(text: str, source: str, world: Any) -> Document:
    cases, problems = [], []
    for number, line in enumerate(text.splitlines(), 1):
        try:
            points = [[float(v) for v in cell.split()] for cell in line.split(",")]
            start, goal, *route = points
            cases.append(Case({"start": start, "goal": goal}, route, kind="route"))
        except ValueError:
            problems.append(f"line {number}: expected at least two points 'x y', comma-separated")
    if problems:
        raise refusal(source, "a routes CSV", problems)
    return Document(cases=tuple(cases))


@hookimpl
def cbr_casebase_formats() -> list[DocumentFormat]:
    return [DocumentFormat("routes-csv", (".routes",), "routes as CSV lines", dump, parse)]
