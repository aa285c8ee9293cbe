"""The ``divert_target`` metric: where a proposal sends the robot, for pictures and tables that
show the diverting targets of a run of the ``trials`` workload."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from cbr_world2d.actions import Divert
from cbrcore.context import Context
from cbrcore.model import Outcome, Proposal


class DivertTarget:
    """``divert_x`` and ``divert_y``: the diverting target a proposal asks the Rescuer for, in
    metres in the world's frame; NaN when the proposal is no :class:`Divert` (no solution, or
    another action)."""

    def __init__(self, options: object, ctx: Context) -> None:
        pass

    def measure(self, problem: Any, proposal: Proposal, outcome: Outcome, ctx: Context
                ) -> Mapping[str, float]:
        value = proposal.solution.value if proposal.solution is not None else None
        if isinstance(value, Divert):
            return {"divert_x": float(value.x), "divert_y": float(value.y)}
        return {"divert_x": float("nan"), "divert_y": float("nan")}
