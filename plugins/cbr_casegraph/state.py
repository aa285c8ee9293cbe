"""The case graph of a run, shared by the plugin's components and kept in step with the store.

The graph is loaded from the case base when the first component of the family is built and
written through to it as it changes (:mod:`cbr_casegraph.graph`). The engine commits those
writes with the learn step; if a learn step fails, its transaction rolls back while the graph
in memory already changed, so each query first checks the store's revision: a learn step that
wrote must have committed exactly one revision, anything else (a rollback, another process
writing) reloads the graph from the store.
"""

from __future__ import annotations

import attrs

from cbr_casegraph.graph import CaseGraph
from cbr_grid.grid import Grid
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.errors import CbrError

KEY = "casegraph"


@attrs.define
class GraphState:
    """The run's case graph and what is known of the store's revision."""

    graph: CaseGraph
    store: CaseStore
    revision: int
    wrote: bool = False

    def sync(self, world: Grid) -> CaseGraph:
        """The graph, reloaded if the store moved on without it, on the current map."""
        now = self.store.revision
        expected = {self.revision + 1} if self.wrote else {self.revision, self.revision + 1}
        if now not in expected:
            self.graph = CaseGraph.load(world, self.store)
        elif world is not self.graph.grid:
            self.graph.set_grid(world)
        self.revision, self.wrote = now, False
        return self.graph

    def changing(self) -> CaseGraph:
        """The graph, about to be changed inside the learn transaction."""
        self.wrote = True
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
