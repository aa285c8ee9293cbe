"""The case graph of a run, shared by the plugin's components and kept in step with the store.

The graph is a view of the case base held by the core's store mirror
(:mod:`cbrcore.casebase.mirror`): loaded from the case base when a component of the family first
asks for it, written through to the store as it changes (:mod:`cbr_casegraph.writes`), and loaded
anew after a learn step that rolled back or when another writer moved the store.
"""

from __future__ import annotations

from cbr_casegraph.graph import CaseGraph
from cbr_grid.grid import grid_world
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.stash import StashKey

_GRAPH = StashKey[CaseGraph]()


def graph_of(ctx: Context) -> CaseGraph:
    """The run's case graph, on the run's current map.

    When the map changed since the graph last saw it, a learn step (the ``risk_map`` retainer
    learned cell risks) updates the costs of the segments through the changed cells and writes
    them to the store; at a query, which must not write, the graph is loaded anew on the map.
    """
    world = grid_world(ctx, "the case graph")

    def load(store: CaseStore) -> CaseGraph:
        return CaseGraph.load(world, store)

    graph = ctx.mirror.view(_GRAPH, load)
    if graph.grid is world:
        return graph
    if ctx.mirror.learning:
        graph.set_grid(world, graph.grid.changed_cells(world))
        return graph
    graph = load(ctx.mirror.store)
    ctx.mirror.put(_GRAPH, graph)
    return graph
