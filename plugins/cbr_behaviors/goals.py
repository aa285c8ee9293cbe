"""The goal manager of 004: which message goal the robot serves now.

004: the robot "determines which message goal to achieve first, decides among conflicting goals
when they cannot all be achieved, and achieves pending goals opportunistically while pursuing
its primary goal". :class:`GoalManager` does that from the messages received, the robot's
position, the time and an estimate ``eta(a, b)`` of the seconds from point ``a`` to point
``b`` (a route length over a cruising speed; :func:`cbr_behaviors.messages.straight_line` for
the straight line). It is pure bookkeeping: it never moves the robot. Each
:meth:`GoalManager.update` at the robot's position ``here`` and time ``now``:

1. *arrivals*: the messages received whose arrival time has come become pending goals;
2. *delivery*: every pending goal whose place lies within ``radius`` of ``here`` is delivered,
   unless its deadline has passed;
3. *feasibility*: a goal whose deadline has passed is missed (``expired``); one that cannot be
   reached in time any more, ``now + eta(here, goal) > deadline``, is given up
   (``infeasible``);
4. *primary*: the primary goal ``P`` is the feasible goal of highest priority, then earliest
   deadline (then earliest arrival, then id);
5. *conflicts*: another goal ``g`` is at risk when serving ``P`` first makes it late,
   ``now + eta(here, P) + eta(P, g) > deadline(g)``. It is saved when serving it first still
   gets ``P`` in time, ``now + eta(here, g) + eta(g, P) <= deadline(P)``; otherwise the two
   conflict, and the lower of them in the primary order, always ``g`` since ``P`` heads that
   order, is given up (``conflict``). With an ``eta`` obeying the triangle inequality no order
   serving both exists then: going to ``g`` first makes ``P`` late, going to ``P`` first makes
   ``g`` late, and anything served in between only delays both;
6. *target*: the goal to head for now is the saved goal of earliest deadline if any, else the
   opportunistic goal of least detour, else ``P``. A pending goal is opportunistic when its
   place is within ``near`` metres of ``here`` (straight line), its detour ``eta(here, g) +
   eta(g, P) - eta(here, P)`` is at most ``detour`` seconds and serving it first still gets
   ``P`` in time.

The manager looks one goal ahead of the primary and decides again at every update, so a goal
saved now may conflict later, when it is given up then. Deliveries and misses are kept as
:class:`Delivered` and :class:`Missed` records.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any, Literal

import attrs

from cbr_behaviors.messages import Eta, Message
from cbr_world2d.checks import non_negative
from cbr_world2d.world import Point

Why = Literal["expired", "infeasible", "conflict", "unfinished"]
"""Why a goal was missed: its deadline passed, it could not be reached in time any more, it
was given up for the primary goal it conflicted with, or the day ended with it pending."""

Reason = Literal["primary", "saved", "opportunistic"]
"""Why the target is the target: it is the primary goal, it is served first so that it does
not miss its deadline, or it lies on the way."""


@attrs.frozen
class Delivered:
    """A message delivered ``at`` that time, ``time`` seconds after it arrived."""

    message: Message
    at: float
    time: float


@attrs.frozen
class Missed:
    """A message missed ``at`` that time, and why (:data:`Why`); ``against`` is the id of the
    primary goal a conflict gave it up for ("" otherwise)."""

    message: Message
    at: float
    why: Why
    against: str = ""


@attrs.frozen
class GoalDecision:
    """What one :meth:`GoalManager.update` decided: the goal to head for now (``target``,
    None when there is none) and why, the primary goal, and the messages that arrived, were
    delivered and were missed at this update."""

    target: Message | None
    reason: Reason | None
    primary: Message | None
    arrived: tuple[Message, ...] = ()
    delivered: tuple[Delivered, ...] = ()
    missed: tuple[Missed, ...] = ()


def _order(message: Message) -> tuple[int, float, float, str]:
    """The primary order: highest priority, then earliest deadline, arrival, id."""
    return -message.rank, message.deadline, message.arrives, message.id


@attrs.define
class GoalManager:
    """Keeps the message goals and picks the one to serve (see the module docstring).

    ``radius`` (metres, default 0.5): how near the place delivers a message, a robot's
    width around the place's point. ``detour`` (seconds, default 20): the most extra time an
    opportunistic goal may cost, about 6 m at the 0.3 m/s cruising speed, the walk into an
    office off the hallway and back. ``near`` (metres, default 3): how close an opportunistic
    goal's place must be, the index's ``NEAR``, the surroundings an index describes.
    """

    eta: Eta
    radius: float = attrs.field(default=0.5, validator=non_negative)
    detour: float = attrs.field(default=20.0, validator=non_negative)
    near: float = attrs.field(default=3.0, validator=non_negative)
    delivered: list[Delivered] = attrs.field(factory=list, init=False)
    """The deliveries so far, in order."""
    missed: list[Missed] = attrs.field(factory=list, init=False)
    """The goals missed so far, in order."""
    primary: Message | None = attrs.field(default=None, init=False)
    """The primary goal as of the last update."""
    target: Message | None = attrs.field(default=None, init=False)
    """The goal to head for as of the last update."""
    _waiting: list[Message] = attrs.field(factory=list, init=False)
    _pending: list[Message] = attrs.field(factory=list, init=False)
    _ids: set[str] = attrs.field(factory=set, init=False)

    @property
    def pending(self) -> tuple[Message, ...]:
        """The goals arrived and neither delivered nor missed, in order of arrival."""
        return tuple(self._pending)

    def receive(self, messages: Iterable[Message]) -> None:
        """Take ``messages``; each becomes a goal at the first update at or after its
        arrival time. A ValueError for an id received before."""
        for message in messages:
            if message.id in self._ids:
                raise ValueError(f"message {message.id!r} was received before")
            self._ids.add(message.id)
            self._waiting.append(message)
        self._waiting.sort(key=lambda m: (m.arrives, m.id))

    def update(self, here: Point, now: float) -> GoalDecision:
        """Decide at position ``here`` and time ``now`` (see the module docstring)."""
        arrived = [m for m in self._waiting if m.arrives <= now]
        if arrived:
            self._waiting = self._waiting[len(arrived):]
            self._pending.extend(arrived)
        delivered: list[Delivered] = []
        missed: list[Missed] = []
        keep: list[Message] = []
        for m in self._pending:
            if now > m.deadline:
                missed.append(Missed(m, now, "expired"))
            elif math.dist(here, m.point) <= self.radius:
                delivered.append(Delivered(m, now, now - m.arrives))
            elif now + self.eta(here, m.point) > m.deadline:
                missed.append(Missed(m, now, "infeasible"))
            else:
                keep.append(m)
        primary = min(keep, key=_order) if keep else None
        target: Message | None = primary
        reason: Reason | None = None if primary is None else "primary"
        if primary is not None:
            first = now + self.eta(here, primary.point)
            saved: list[Message] = []
            on_the_way: list[tuple[float, Message]] = []
            for g in sorted(keep, key=_order):
                if g is primary:
                    continue
                to_g = self.eta(here, g.point)
                via_g = now + to_g + self.eta(g.point, primary.point)
                if first + self.eta(primary.point, g.point) > g.deadline:
                    if via_g <= primary.deadline:
                        saved.append(g)
                    else:
                        missed.append(Missed(g, now, "conflict", primary.id))
                        keep.remove(g)
                elif (math.dist(here, g.point) <= self.near and via_g <= primary.deadline
                      and via_g - first <= self.detour):
                    on_the_way.append((via_g - first, g))
            if saved:
                target, reason = min(saved, key=lambda m: (m.deadline, _order(m))), "saved"
            elif on_the_way:
                target = min(on_the_way, key=lambda pair: (pair[0], _order(pair[1])))[1]
                reason = "opportunistic"
        self._pending = keep
        self.delivered.extend(delivered)
        self.missed.extend(missed)
        self.primary, self.target = primary, target
        return GoalDecision(target, reason, primary, tuple(arrived), tuple(delivered),
                        tuple(missed))

    def close(self, now: float) -> tuple[Missed, ...]:
        """End the day at ``now``: every goal still pending or waiting to arrive is missed
        (``unfinished``)."""
        missed = tuple(Missed(m, now, "unfinished") for m in [*self._pending, *self._waiting])
        self._pending, self._waiting = [], []
        self.missed.extend(missed)
        self.primary = self.target = None
        return missed

    def records(self) -> list[dict[str, Any]]:
        """A row per delivered or missed message, in order of arrival: its id, place,
        priority, arrival and deadline, when it was delivered and how long that took (nan if
        not), and why it was missed ("" if not) and for which goal."""
        rows: list[tuple[Message, dict[str, Any]]] = []
        for d in self.delivered:
            rows.append((d.message, {"delivered": d.at, "time": d.time, "missed": "",
                                     "against": ""}))
        for m in self.missed:
            rows.append((m.message, {"delivered": math.nan, "time": math.nan, "missed": m.why,
                                     "against": m.against}))
        rows.sort(key=lambda row: (row[0].arrives, row[0].id))
        return [{"id": m.id, "place": m.place, "priority": m.priority, "arrives": m.arrives,
                 "deadline": m.deadline, **outcome} for m, outcome in rows]
