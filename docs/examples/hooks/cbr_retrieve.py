"""A retriever of stored routes whose start and goal both lie near the query's:
`retrieve: {use: near_ends, radius: 2}`."""

import math

import attrs

from cbrcore import Match, Retrieval, hookimpl
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.options import option
from cbrcore.registry import Registry


@attrs.frozen
class NearEndsOptions:
    radius: float = option(2.0, "How far, in metres, a route's ends may lie from the query's.")


class NearEnds:
    def __init__(self, options: NearEndsOptions, ctx: Context) -> None:
        self.radius = options.radius

    @hookimpl
    def cbr_retrieve(self, problem: dict, casebase: CaseStore) -> Retrieval:
        matches = []
        for case in casebase.cases(kind="route"):
            start = math.dist(case.problem["start"], problem["start"])
            goal = math.dist(case.problem["goal"], problem["goal"])
            if max(start, goal) <= self.radius:
                similarity = 1 - max(start, goal) / self.radius
                matches.append(Match(case, similarity, {"start": start, "goal": goal}))
        matches.sort(key=lambda match: -match.similarity)
        return Retrieval(tuple(matches))  # no matches: the solver answers


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("retriever", "near_ends", NearEnds, options=NearEndsOptions)
