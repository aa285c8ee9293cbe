"""The ``rescuer`` solver: the navigation system's own answer when the case base has none.

Given a :class:`~cbr_world2d.workload.Situation` in which the robot is blocked (its trigger is
``blocked``), it proposes the diverting target the Rescuer would compute from the sonar alone
(:meth:`cbr_world2d.pilots.rescuer.Rescuer.escape`, 002 section 2), or nothing when the sonar
shows no way out worth taking. Consulted on any other trigger it proposes nothing: the Rescuer
"recovers the robot from blocked situations" (002 section 2), and a robot that is not blocked
drives on. A run with this solver and no case base components is the navigation system without
CBR.
"""

from __future__ import annotations

from cbr_world2d.actions import Divert
from cbr_world2d.pilots.rescuer import Rescuer, RescuerOptions
from cbr_world2d.workload import Situation
from cbrcore.context import Context
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Solution


class RescuerSolver:
    """Divert to the sonar's way out, as the Rescuer does on its own."""

    def __init__(self, options: RescuerOptions, ctx: Context) -> None:
        self.options = options

    @hookimpl
    def cbr_solve(self, problem: Situation) -> Solution | None:
        if problem.trigger != "blocked":
            return None
        point = Rescuer(self.options, problem.target).escape(problem)
        return None if point is None else Solution(Divert(*point))
