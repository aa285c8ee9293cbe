"""The plain attrs objects that travel through the cycle.

The engine never looks inside a problem or a solution: a grid query, a landmark situation and a
RUPART behavior index are all just ``problem`` objects chosen by the domain plugin. What the engine
does read is the envelope around them (where a solution came from, how similar a case was, whether
a revision accepted it), so that envelope is typed here once for every domain.

Case contents (``problem``, ``solution``, ``meta``) are stored as JSON, so they must be plain data:
dicts with string keys, lists, strings, numbers, booleans and None.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import attrs

JSON = Any
"""Plain JSON-compatible data: what a case stores."""


@attrs.frozen
class Case:
    """One stored experience.

    ``kind`` lets one case base hold several sorts of case (a case graph keeps vertices and
    segments). ``created`` and ``last_used`` are case base revisions, a logical clock that only
    moves when a transaction commits, so forgetting by age or recency is reproducible.
    """

    problem: JSON
    solution: JSON
    kind: str = "case"
    meta: Mapping[str, JSON] = attrs.field(factory=dict)
    id: int | None = None
    uses: int = 0
    created: int | None = None
    last_used: int | None = None


@attrs.frozen
class Match:
    """A retrieved case and how similar it is to the query.

    ``similarity`` is the retriever's overall score (higher is more similar); ``features`` gives
    the per-feature detail behind it (a distance or a similarity per feature, as the retriever
    documents), so a user can see why a case was or was not chosen.
    """

    case: Case
    similarity: float
    features: Mapping[str, float] = attrs.field(factory=dict)


@attrs.frozen
class Retrieval:
    """What ``cbr_retrieve`` found.

    ``matches`` is ordered best first. ``payload`` carries retriever-specific working data to the
    reuser of the same plugin family (the neighbourhood sets of a case graph, a landmark mapping),
    so the reuser need not compute it again. A retrieval with no matches is not usable and sends
    the query to the fallback solver; its ``reason`` (say, ``"exploring"``, when a retriever
    chooses to plan anew) is added to the recorded fallback reason.
    """

    matches: tuple[Match, ...] = ()
    payload: Any = None
    reason: str = ""

    @property
    def usable(self) -> bool:
        return bool(self.matches)


@attrs.frozen
class Solution:
    """A proposed answer to a problem.

    ``value`` is the domain's answer (a path, a diverting target, a behavior assignment). ``cost``
    is the domain's own figure of merit when it has one. ``cases`` names the stored cases the
    solution was built from; the engine counts their use when the outcome is learned.

    ``detail`` is for people: what the producer reports of how it got here (nodes expanded,
    the way a target was reached), shown and asserted on but never read by another component.
    What a component hands on travels typed: ``bound``, when the producer proves the cost is
    at most ``bound`` times the cheapest solution's (a reviser of any family may take that
    proof for the quality test), and ``payload``, the producer's own typed account for the
    reviser, retainers, workload and metrics of the same family (as ``Retrieval.payload``
    does for the reuser), which the engine passes through untouched.
    """

    value: Any
    cost: float | None = None
    cases: tuple[int, ...] = ()
    detail: Mapping[str, Any] = attrs.field(factory=dict)
    bound: float | None = None
    payload: Any = None

    @property
    def no_action(self) -> bool:
        """Whether the solution asks for nothing (``value`` is None): the robot goes on as it
        was. The learn step passes such a solution to the retainers when the proposal had none
        (see :func:`no_action`)."""
        return self.value is None


def no_action() -> Solution:
    """The solution the learn step hands the retainers for a proposal without one: nothing was
    carried out, and the outcome tells how going on without an action fared."""
    return Solution(None)


@attrs.frozen
class Revision:
    """The verdict of ``cbr_revise`` on a reused solution.

    ``accepted=False`` hands the query to the fallback solver with ``reason`` recorded. An accepted
    revision may carry a repaired ``solution`` that replaces the proposed one.
    """

    accepted: bool
    reason: str = ""
    solution: Solution | None = None


@attrs.frozen
class Outcome:
    """What happened when the solution was carried out (in the world or a simulation of it).

    ``solution`` is what was actually executed when it differs from the proposal (a robot that
    replanned around an obstacle drove another path); None means the proposal as it was.
    ``report`` is the workload's own typed account of what happened (the grid family's
    ``DriveReport``: cells driven, obstacles met, stops), for the retainers and measures of the
    same domain; the engine passes it through untouched.
    """

    success: bool
    cost: float | None = None
    solution: Solution | None = None
    report: Any = None


CASEBASE = "casebase"
"""The ``Proposal.source`` of a solution that came out of retrieve, reuse and revise."""


@attrs.frozen
class Proposal:
    """The engine's answer to one query and the record of how it was reached.

    ``source`` is ``"casebase"`` when the cycle produced the solution, ``"solver:<name>"`` when the
    fallback solver did, and ``"none"`` when neither could. ``fallback_reason`` says why the case
    base did not answer. ``timings`` holds seconds per phase that ran.
    """

    solution: Solution | None
    source: str
    fallback_reason: str | None = None
    retrieval: Retrieval | None = None
    revision: Revision | None = None
    timings: Mapping[str, float] = attrs.field(factory=dict)

    @property
    def from_casebase(self) -> bool:
        return self.source == CASEBASE
