"""What a consultation asks and what the agent answers in the delivery world.

A :class:`Moment` is the problem: the robot's situation when re-planning was triggered, as the
index of 004 Figure 5 (:class:`~cbr_behaviors.index.Index`, every feature filled in from the
simulation) with what the robot is doing. The proposal's ``solution.value`` is one of two
actions: :class:`InstallBehaviors` (a behavior case or meta-plan: install its behaviors at
once) or :class:`InstallPlan` (a plan case: route through its places, planned deliberatively
on the global map). The kind of case retrieved decides which (004: "the kind of case retrieved
determines whether to plan deliberatively"). The solution's ``payload`` is a :class:`CaseChoice`:
how the reuser chose the case, for the learn step and the day's log.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import attrs

from cbr_behaviors.index import Index

Point = tuple[float, float]

GOOD_PROGRESS = 0.5
"""Metres nearer its goal (along the route) a spell must get the robot to count as good (with no
collision and no impasse): a few seconds of driving, more than the sway of a robot standing
still."""
GOOD_RATE = 0.1
"""m/s toward the goal a spell must average to count as good: half the ``moderate`` speed,
so that a case that keeps the robot crawling proves worse than one that gets it on."""


@attrs.frozen(eq=False)
class Moment:
    """One re-planning retrieval's problem.

    ``triggers`` are the re-planning triggers that fired (:mod:`cbr_behaviors.triggers`),
    ``index`` the situation, ``target`` the point the behaviors are steering for now (None when
    idle) and ``goal`` the current message goal's point; ``behaviors`` the behavior set in
    force (plain data items) and ``plan`` the name of the plan case in force for this goal
    (None: the route was planned directly); ``excluded`` the behavior sets (each a tuple of
    plain data items) that reached an impasse lately and are not to be installed again yet.
    """

    t: float
    triggers: tuple[str, ...]
    index: Index
    target: Point | None
    goal: Point | None
    behaviors: tuple[Any, ...]
    plan: str | None = None
    excluded: tuple[Any, ...] = ()


@attrs.frozen
class InstallBehaviors:
    """Install ``behaviors`` (004 Figure 4 items, centimetres) on the robot now. ``adapted``
    holds the case the reuser adapted them into (retained when the spell goes well), None
    when the retrieved case is installed as it is."""

    behaviors: tuple[Any, ...]
    name: str
    adapted: Any = None


@attrs.frozen
class InstallPlan:
    """Route to the current goal through the places ``route`` (a plan case), planned on the
    global map; ``localize`` first when the plan says so."""

    route: tuple[str, ...]
    name: str
    localize: bool = False


@attrs.frozen
class CaseChoice:
    """How the reuser chose the case it installs: the ``payload`` of its solution, which the
    retainers learn from and the workload logs.

    ``kind`` is the installed case's kind (``behavior_case``, ``plan_case`` or ``meta_plan``),
    ``distance`` its overall index distance to the situation and ``features`` its distance
    per feature (the weights learn from these); ``retrieved`` the ids of every case retrieved
    (None for a case not stored) and ``rivals`` those within the quality band of the installed
    case, whose records against it the spell adds to."""

    kind: str
    distance: float
    features: Mapping[str, float]
    retrieved: tuple[int | None, ...]
    rivals: tuple[int, ...]


@attrs.frozen
class SpellReport:
    """How the installed case fared until the next retrieval (or the day's end): seconds it
    stayed active, metres of route gained toward the goal the robot was sent to when it began
    (home when it had none), collisions and impasses meanwhile,
    messages delivered, and seconds spent waiting before a shut door on the route."""

    active: float
    progress: float
    collisions: int
    impasses: int
    delivered: int
    waited: float = 0.0

    @property
    def good(self) -> bool:
        """A spell went well when it had no collision and no impasse and got the robot on: at
        least :data:`GOOD_PROGRESS` metres nearer its goal, and at least
        :data:`GOOD_RATE` m/s over the time it did not wait before a shut door, or a message
        delivered. A spell with nothing to do (the robot waiting at home) is not good: what it
        installed proved nothing; nor is one that crawled."""
        needed = max(GOOD_PROGRESS, GOOD_RATE * max(0.0, self.active - self.waited))
        return (self.collisions == 0 and self.impasses == 0
                and (self.progress >= needed or self.delivered > 0))
