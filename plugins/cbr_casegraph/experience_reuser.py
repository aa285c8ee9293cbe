"""The ``experience_graph`` reuser: the case graph reused by an experience-graph search.

Beside the 9-step algorithm of the papers (``reuse: casegraph``), this reuser plans on the whole
grid by weighted A* whose heuristic draws it along the stored segments and which rides a
segment in one step (:mod:`cbr_casegraph.experience`). Every path it returns costs at most
``epsilon · experience_factor`` times the cheapest path on the map; it says so in
``Solution.bound``, which the ``path_quality`` reviser takes as a guarantee.

It works with the ``casegraph`` retriever: when no case meets the neighbourhood of start or goal,
or the two lie within delta of each other, the retrieval is not usable and the fallback solver
plans, as with the 9-step reuser. The experience search would still find a path there, but
without a case to follow it is only a weighted A*, and the fallback gives the optimum.
"""

from __future__ import annotations

import importlib
from types import ModuleType

import attrs

from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.recording import record_reuse
from cbr_casegraph.state import graph_of
from cbr_grid.grid import grid_world
from cbr_grid.query import GridQuery
from cbr_kinematics import require_any_move, robot_kinematics
from cbr_solvers import warm_grid
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Retrieval, Solution
from cbrcore.options import option

_AT_LEAST_ONE = attrs.validators.ge(1.0)


def _experience() -> ModuleType:
    """The search module; it loads numba, so only when a query is planned."""
    return importlib.import_module("cbr_casegraph.experience")


@attrs.frozen
class ExperienceOptions:
    epsilon: float = option(
        1.35, "Inflation of the experience heuristic (weighted A*'s weight, at least 1). The "
        "path's cost is at most epsilon · experience_factor times the optimum.",
        validator=_AT_LEAST_ONE)
    experience_factor: float = option(
        1.1, "eps_E, at least 1: how much dearer a step off the stored segments looks than a "
        "step along them; 1 ignores the case graph (weighted A* with shortcuts), larger values "
        "follow the cases further. The path's cost is at most epsilon · experience_factor "
        "times the optimum.", validator=_AT_LEAST_ONE)

    def __attrs_post_init__(self) -> None:
        require_any_move("the experience-graph search", "reuse 'casegraph' plans for it")

    @property
    def bound(self) -> float:
        """The guaranteed ratio of a returned path's cost to the optimum."""
        return self.epsilon * self.experience_factor


_WARM_SIZE = 24
_WARM_PATH = [(x, 2) for x in range(2, 21)] + [(20, y) for y in range(3, 21)]
"""The path learned on the warm-up grid: along the top, then down the right side."""


class ExperienceGraphReuser:
    """Adaptation by the experience-graph search over the map and the stored segments."""

    def __init__(self, options: ExperienceOptions, ctx: Context) -> None:
        self.options = options
        kinematics = robot_kinematics(ctx, "reuse 'experience_graph'")
        if kinematics is not None:
            raise CbrError(f"reuse 'experience_graph': the robot's kinematics "
                           f"{type(kinematics).__name__} constrains its turns, which the "
                           f"experience-graph search does not model; use reuse 'casegraph'")
        graph_of(ctx)

    @hookimpl
    def cbr_warm(self, ctx: Context) -> None:
        """Search once on a small graph of its own, so the kernel is compiled before a query."""
        graph = CaseGraph(warm_grid(grid_world(ctx, "the case graph"), _WARM_SIZE, wall=False))
        graph.add_path(_WARM_PATH)
        _experience().plan(graph, (3, 4), (18, 19), self.options.epsilon,
                           self.options.experience_factor)

    @hookimpl
    def cbr_reuse(self, problem: GridQuery, retrieval: Retrieval, ctx: Context
                  ) -> Solution | None:
        return self.reuse(problem, retrieval, ctx)

    def reuse(self, problem: GridQuery, retrieval: Retrieval, ctx: Context) -> Solution | None:
        """The experience-graph path of ``problem`` in the case graph of ``ctx``, or None when
        the map does not connect start and goal. The retrieval has only decided that the case
        graph is worth searching: the search itself uses every stored segment."""
        graph = graph_of(ctx)
        found = _experience().plan(graph, tuple(problem.start), tuple(problem.goal),
                                   self.options.epsilon, self.options.experience_factor)
        if found is None:
            return None
        record_reuse(ctx, graph, found.edges)
        return Solution(found.path.tolist(), cost=found.cost, cases=found.edges,
                        detail=found.detail, bound=found.bound)
