"""The workload contract: what a run asks of the domain that poses its queries.

A workload poses the queries of a run in one of two ways.

A **query workload** (:class:`QueryWorkload`) yields its queries one by one and carries out each
proposal in ``execute``; the run's loop solves a query, has it executed and learns from the
outcome before it asks for the next.

A **closed-loop workload** (:class:`ClosedLoopWorkload`) runs its own loop in ``run(session)``: a
simulation in which the robot drives on and consults the engine when something triggers it. Each
:meth:`Session.consult` answers one query and returns a :class:`Decision`, open until the
workload reports its outcome with :meth:`Session.learn`, when the outcome becomes known (a
diverting target reached, the trial over). Several decisions may be open at once; each is
learned exactly once, and none may be open when ``run`` returns.

Metrics (:class:`Metric`) measure every learned decision, whichever way it was posed.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any, Protocol, runtime_checkable

import attrs

from cbrcore.context import Context
from cbrcore.engine import Engine
from cbrcore.errors import ConfigError, PluginError
from cbrcore.model import Outcome, Proposal


@runtime_checkable
class Workload(Protocol):
    """What every workload provides (the ``workload`` component), whichever loop it uses."""

    def __len__(self) -> int:
        """How many queries the run is expected to pose (the progress total)."""
        ...

    def describe(self, problem: Any) -> Mapping[str, Any]:
        """Scalar columns that identify the query in ``results.csv`` (start and goal cells...)."""
        ...


@runtime_checkable
class QueryWorkload(Workload, Protocol):
    """A workload driven by the run's loop: solve a query, execute it, learn, then the next."""

    def queries(self, ctx: Context) -> Iterable[Any]:
        """The problems to solve, in order."""
        ...

    def execute(self, problem: Any, proposal: Proposal, ctx: Context) -> Outcome:
        """Carry out the proposal (a simulated robot drives the path) and report what happened."""
        ...


@runtime_checkable
class ClosedLoopWorkload(Workload, Protocol):
    """A workload that runs its own loop, consulting the engine through a :class:`Session`."""

    def run(self, session: Session) -> None:
        """Run the trials: ``session.consult(problem)`` when the agent is needed,
        ``session.learn(decision, outcome)`` when a decision's outcome is known. Every decision
        must be learned before returning."""
        ...


@runtime_checkable
class Metric(Protocol):
    """Per-query figures beyond the built-in columns (a ``metrics`` component)."""

    def measure(self, problem: Any, proposal: Proposal, outcome: Outcome,
                ctx: Context) -> Mapping[str, float]:
        """Named numbers for one query; the same names every time."""
        ...


@attrs.frozen(eq=False)
class Decision:
    """One consultation of a session, open until its outcome is learned.

    ``index`` counts the session's consultations from 0 (the ``query`` column of
    ``results.csv``); ``proposal`` is the engine's answer to ``problem``. Decisions compare by
    identity: only the session that made one can learn it.
    """

    index: int
    problem: Any
    proposal: Proposal
    _session: Session = attrs.field(repr=False)
    _step: int = attrs.field(repr=False)


Write = Callable[[Mapping[str, float]], None]
"""What a session calls once a decision's learn step has committed, with the step's timings."""

Record = Callable[[Decision, Outcome], Write]
"""What a session does with each decision it learns, in two steps around the learn step.

Called with the decision and its outcome before the step (``cbr run`` measures the metrics and
checks the row's columns), it returns what to call once the step has committed (``cbr run``
writes the row). A failure before the step leaves the case base as it was; a failed step
writes nothing. So the case base and what was recorded learn the same decisions.
"""


class Session:
    """The engine as a closed-loop workload consults it during one run.

    ``consult`` answers a query and opens a :class:`Decision`; ``learn`` learns it, in one case
    base transaction, when its outcome is known, and hands it to ``record`` around that
    transaction (``cbr run`` measures it first and writes its ``results.csv`` row once the
    transaction has committed; see :data:`Record`). A learn step that another process's write
    lock keeps out is skipped and retried by the engine (:meth:`~cbrcore.engine.Engine.learn`):
    the decision is no longer open, and is recorded when the retry commits. While a decision
    is learned, retainers, forgetters, observers and metrics see ``ctx.step`` as it was when
    the decision was consulted. Misuse is a :class:`~cbrcore.errors.PluginError` naming the
    workload: learning a decision twice, a decision of another session, anything but a decision
    and an outcome, using the session after it was closed, and closing it with decisions still
    open.
    """

    def __init__(self, engine: Engine, *, record: Record | None = None) -> None:
        if engine.workload is None:
            raise ConfigError(str(engine.config.source or "configuration"),
                              ["workload: required for a session; name the workload component "
                               "that consults the engine"])
        self._engine = engine
        self._name = engine.config.workload.name
        self._record = record
        self._open: dict[int, Decision] = {}
        self._consulted = 0
        self._closed = False

    @property
    def ctx(self) -> Context:
        """The run's context: its seeded generator, world and output folder."""
        return self._engine.ctx

    @property
    def consulted(self) -> int:
        """How many consultations the session has made."""
        return self._consulted

    @property
    def pending(self) -> tuple[Decision, ...]:
        """The decisions not yet learned, in the order they were consulted."""
        return tuple(self._open.values())

    def consult(self, problem: Any) -> Decision:
        """Answer one query (``engine.solve``) and open a decision for it."""
        self._refuse_if_closed("consult")
        proposal = self._engine.solve(problem)
        decision = Decision(self._consulted, problem, proposal, self, self.ctx.step)
        self._open[decision.index] = decision
        self._consulted += 1
        return decision

    def learn(self, decision: Decision, outcome: Outcome) -> None:
        """Learn ``decision`` from its ``outcome`` (``engine.learn``) and record it."""
        self._refuse_if_closed("learn")
        if not isinstance(decision, Decision):
            raise PluginError(f"workload {self._name!r} passed {type(decision).__name__} to "
                              "session.learn(), expected the Decision session.consult() "
                              "returned")
        if decision._session is not self:
            raise PluginError(f"workload {self._name!r} passed consultation {decision.index} "
                              "of another session to session.learn(); a decision is learned "
                              "by the session that consulted it")
        if decision.index not in self._open:
            raise PluginError(f"workload {self._name!r} learned consultation {decision.index} "
                              "a second time; each decision is learned once")
        if not isinstance(outcome, Outcome):
            raise PluginError(f"workload {self._name!r} passed {type(outcome).__name__} to "
                              f"session.learn() for consultation {decision.index}, expected "
                              "Outcome")
        ctx = self.ctx
        current, ctx.step = ctx.step, decision._step
        try:
            write = self._record(decision, outcome) if self._record is not None else None

            def learned(timings: dict[str, float]) -> None:
                # learned: whatever writing does, the decision is no longer open
                self._open.pop(decision.index, None)
                if write is not None:
                    write(timings)

            if self._engine.learn(decision.problem, decision.proposal, outcome,
                                  then=learned) is None:
                # skipped for another process's write lock: the engine keeps it, and its
                # record is written when a retry commits it
                del self._open[decision.index]
        finally:
            ctx.step = current

    def close(self) -> None:
        """End the session; the run closes it when the workload's loop returns.

        A PluginError names the workload and the consultations still open, if any.
        """
        self._closed = True
        if self._open:
            count = len(self._open)
            listed = ", ".join(str(index) for index in self._open)
            noun = "consultation" if count == 1 else "consultations"
            queries = "query" if count == 1 else "queries"
            raise PluginError(f"workload {self._name!r} returned from run() with {count} {noun} "
                              f"still open ({queries} {listed}): learn each decision with "
                              "session.learn(decision, outcome) before returning")

    def _refuse_if_closed(self, method: str) -> None:
        if self._closed:
            raise PluginError(f"workload {self._name!r} called session.{method}() after its "
                              "session was closed; a session is used only while run(session) "
                              "runs")
