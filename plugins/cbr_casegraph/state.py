"""The case graph of a run, shared by the plugin's components and kept in step with the store.

The graph is loaded from the case base when the first component of the family is built and
written through to it as it changes (:mod:`cbr_casegraph.graph`). The engine commits those
writes with the learn step; if a learn step fails, its transaction rolls back while the graph
in memory already changed, so each query first checks the store's revision
(:func:`cbrcore.casebase.store.still_current`) and reloads the graph when it moved on without
it. Two processes should not share one case graph.
"""

from __future__ import annotations

import attrs

from cbr_casegraph.graph import CaseGraph
from cbr_grid.grid import Grid
from cbrcore.casebase.store import CaseStore, still_current
from cbrcore.context import Context
from cbrcore.errors import CbrError

KEY = "casegraph"


@attrs.define
class GraphState:
    """The run's case graph and the store revision it was last known to match."""

    graph: CaseGraph
    store: CaseStore
    revision: int
    writes: int = 0

    def sync(self, world: Grid) -> CaseGraph:
        """The graph, reloaded if the store moved on without it, on the current map."""
        now = self.store.revision
        if not still_current(now, self.revision, self.graph.writes != self.writes):
            self.graph = CaseGraph.load(world, self.store)
        elif world is not self.graph.grid:
            self.graph.set_grid(world)
        self.revision, self.writes = now, self.graph.writes
        return self.graph


def state_of(ctx: Context) -> GraphState:
    """The run's graph state, loaded from the case base on first use."""
    state = ctx.shared.get(KEY)
    if state is None:
        if not isinstance(ctx.world, Grid):
            raise CbrError("the case graph plans on a grid world; the configured world is "
                           f"{type(ctx.world).__name__}")
        if ctx.casebase is None:
            raise CbrError("the case graph needs a case base (the 'casebase' slot)")
        state = GraphState(CaseGraph.load(ctx.world, ctx.casebase), ctx.casebase,
                           ctx.casebase.revision)
        ctx.shared[KEY] = state
    return state
