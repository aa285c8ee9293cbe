"""Planning on the case graph for a robot with kinematic constraints (section 5 of the paper).

The extended graph G' of :mod:`cbr_casegraph.planner` is searched by the modified Dijkstra or A*
(:mod:`cbr_solvers.graph_search`) over its directed edges (:mod:`cbr_casegraph.extended_graph`).
The temporary edges come from sweeps of the edge-based grid search
(:func:`cbr_casegraph.links.swept`): forward from the start with the robot's heading, and
backwards from the goal with the final heading. Each case near the start gets one temporary edge
per direction in which the robot can arrive at one of its cells, to the cheapest such cell; each
case near the goal one per direction in which the robot can leave one of its cells for the goal.
The condition P at the joins is then the graph search's, and the whole path, manoeuvres
included, is one the robot can drive. Loops are not cut from it: a manoeuvre drives out and
back over the same cells on purpose.
"""

from __future__ import annotations

from typing import Any

from cbr_casegraph import extended_graph, links
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.overlay import Overlay, split_edges
from cbr_casegraph.planner import Cell, Failure, Neighbourhoods, Plan, Settings
from cbr_casegraph.search import path_cost
from cbr_grid.directions import facing
from cbr_grid.directions import of_steps as step_directions
from cbr_grid.directions import reversing as reversing_steps
from cbr_kinematics.models import Kinematics
from cbr_solvers.graph_search import graph_search


def adapt(graph: CaseGraph, start: Cell, goal: Cell, cases: Neighbourhoods, settings: Settings,
          kinematics: Kinematics, heading: int | None, final_heading: int | None
          ) -> Plan | Failure:
    """Reuse for a robot of ``kinematics``: the cheapest path in G' it can drive from ``start``
    facing ``heading`` to ``goal``, able to drive on in ``final_heading`` (None: any)."""
    grid, tables, scale = graph.grid, graph.tables(), graph.heuristic_scale()
    detail: dict[str, Any] = {"start_cases": len(cases.start), "goal_cases": len(cases.goal)}
    swept = []
    for name, cell, near, on_graph, direction, reverse in (
            ("start", start, cases.start, cases.start_on_graph, heading, False),
            ("goal", goal, cases.goal, cases.goal_on_graph, final_heading, True)):
        made = links.swept(grid, cell, tables.ends(near), settings.delta,
                           settings.window_radius, kinematics, direction, reverse)
        if not made and not on_graph:
            return Failure(f"no local path from the {name} to a case", detail)
        swept.append(made)
    overlay = Overlay(graph.index.cells, base=len(tables.adjacency.indptr) - 1)
    s, g = overlay.vertex(start), overlay.vertex(goal)
    # the sweep already turned from the heading: no condition where a start's edge begins;
    # the goal's edges end under the final heading: none where they end
    temporary: list[extended_graph.Temporary] = [
        (s, overlay.vertex(link.target), link.cost, -1, link.direction, link.trace)
        for link in swept[0]]
    temporary += [(overlay.vertex(link.target), g, link.cost, link.direction, -1, link.trace)
                  for link in swept[1]]
    split_edges(overlay, grid, tables)
    extended = extended_graph.build(grid, tables.adjacency, overlay, temporary, scale)
    found = graph_search(extended.graph, s, g, kinematics, heading=heading,
                         final_heading=final_heading, informed=settings.graph_search == "astar")
    if found is None:
        return Failure("the extended case graph has no path this robot can drive", detail)
    path = extended_graph.driven_cells(extended, found.edges, found.manoeuvres, found.final,
                                       goal)
    used = [extended.stored[e] for e in found.edges if extended.stored[e] >= 0]
    directions = step_directions(path)
    detail.update(temporary_edges=len(overlay.edges) + len(temporary), settled=found.expanded,
                  headings=facing(directions).tolist(),
                  reversing=reversing_steps(directions).tolist())
    return Plan(path, path_cost(grid.factor, path), tuple(dict.fromkeys(used)), detail)
