"""Nav2 route graphs as GeoJSON: the nodes and edges of a file, checked as Nav2's Route Server
reads them.

A route graph is a GeoJSON ``FeatureCollection``. A node is a ``Point`` feature whose properties
hold an ``id`` and may hold a ``frame``, ``metadata`` and ``operations``; an edge is a
``LineString`` or ``MultiLineString`` feature whose properties hold an ``id``, the ``startid``
and ``endid`` of its nodes and may hold a ``cost``, ``overridable``, ``metadata`` and
``operations``. Coordinates are metres in the map frame; the route server reads an edge's ends
from its nodes, not from its geometry. Ids are unsigned 32-bit integers. Node ids are unique
among nodes, since edges name their nodes by them. Edge ids may repeat, as they do in Nav2's
own depot graph (its loader keeps an edge with its start node, and nothing in the file names an
edge by its id), but not on one edge: the same id from the same start to the same end twice is
a duplicate.

Every problem of a file is listed with the feature it is in, by index and id:
``features[40] (edge 10002): startid 99 names no node``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import attrs

from cbrcore.documents import found

MAX_ID = 2**32 - 1
"""The largest id Nav2 reads (an unsigned int)."""

NODE_TYPES = ("Point",)
EDGE_TYPES = ("LineString", "MultiLineString")


@attrs.frozen
class Node:
    """A node: its id, its point in metres, and the feature it was read from as it was."""

    index: int
    id: int
    point: tuple[float, float]
    feature: Mapping[str, Any]

    @property
    def label(self) -> str:
        return f"features[{self.index}] (node {self.id})"


@attrs.frozen
class Edge:
    """An edge: its id, the ids of its start and end nodes, and the feature as it was."""

    index: int
    id: int
    start: int
    end: int
    feature: Mapping[str, Any]

    @property
    def label(self) -> str:
        return f"features[{self.index}] (edge {self.id})"


@attrs.frozen
class RouteGraph:
    """A checked route graph: its features in file order, and the collection's other keys
    (``name``, ``crs``, ...)."""

    nodes: tuple[Node, ...]
    edges: tuple[Edge, ...]
    collection: Mapping[str, Any]
    features: tuple[Mapping[str, Any], ...]


def _number(value: Any) -> bool:
    return (isinstance(value, int | float) and not isinstance(value, bool)
            and math.isfinite(value))


def _an_id(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= MAX_ID


def _kind(index: int, geometry: Any) -> tuple[str | None, str | None]:
    """``node`` or ``edge`` for a feature's geometry, or the problem that it is neither."""
    if not isinstance(geometry, Mapping):
        return None, f"features[{index}]: geometry: expected a GeoJSON geometry (a mapping), " \
                     f"got {found(geometry)}"
    kind = geometry.get("type")
    if kind in NODE_TYPES:
        return "node", None
    if kind in EDGE_TYPES:
        return "edge", None
    return None, (f"features[{index}]: geometry type {found(kind, setting=True)}; expected "
                  f"{', '.join(NODE_TYPES + EDGE_TYPES[:-1])} or {EDGE_TYPES[-1]}")


class _Reader:
    """Collects the problems of a route graph's features."""

    def __init__(self) -> None:
        self.problems: list[str] = []
        self.nodes: dict[int, Node] = {}
        self.edges: dict[tuple[int, int, int], Edge] = {}

    def ident(self, properties: Mapping[str, Any], key: str, where: str) -> int | None:
        if key not in properties:
            self.problems.append(f"{where}: required property {key!r} is missing")
            return None
        value = properties[key]
        if not _an_id(value):
            self.problems.append(f"{where}: {key}: expected an integer from 0 to {MAX_ID} (Nav2 "
                                 f"reads ids as unsigned ints), got {found(value, setting=True)}")
            return None
        return value

    def optional(self, properties: Mapping[str, Any], where: str) -> None:
        for key in ("metadata", "operations"):
            if key in properties and not isinstance(properties[key], Mapping):
                self.problems.append(f"{where}: {key}: expected a mapping, got "
                                     f"{found(properties[key])}")

    def node(self, index: int, feature: Mapping[str, Any], properties: Mapping[str, Any]) -> None:
        node_id = self.ident(properties, "id", f"features[{index}] (a node)")
        where = f"features[{index}] (node {node_id})" if node_id is not None else \
            f"features[{index}] (a node)"
        frame = properties.get("frame", "map")
        if frame != "map":
            self.problems.append(f"{where}: frame {found(frame, setting=True)}; expected 'map' "
                                 "(coordinates are read in the map frame)")
        self.optional(properties, where)
        coordinates = feature["geometry"].get("coordinates")
        point = None
        if (isinstance(coordinates, list) and len(coordinates) in (2, 3)
                and all(_number(c) for c in coordinates)):
            point = (float(coordinates[0]), float(coordinates[1]))
        else:
            self.problems.append(f"{where}: coordinates: expected [x, y] in metres (finite "
                                 f"numbers), got {found(coordinates, setting=True)}")
        if node_id is None:
            return
        if node_id in self.nodes:
            self.problems.append(f"{where}: node id {node_id} is also that of "
                                 f"{self.nodes[node_id].label}")
        elif point is not None:
            self.nodes[node_id] = Node(index, node_id, point, feature)

    def edge(self, index: int, feature: Mapping[str, Any], properties: Mapping[str, Any]) -> None:
        edge_id = self.ident(properties, "id", f"features[{index}] (an edge)")
        where = f"features[{index}] (edge {edge_id})" if edge_id is not None else \
            f"features[{index}] (an edge)"
        start = self.ident(properties, "startid", where)
        end = self.ident(properties, "endid", where)
        cost = properties.get("cost", 0.0)
        if not (_number(cost) and cost >= 0):
            self.problems.append(f"{where}: cost: expected a number >= 0, got "
                                 f"{found(cost, setting=True)}")
        if not isinstance(properties.get("overridable", False), bool):
            self.problems.append(f"{where}: overridable: expected true or false, got "
                                 f"{found(properties['overridable'], setting=True)}")
        self.optional(properties, where)
        if start is not None and start == end:
            self.problems.append(f"{where}: starts and ends at node {start}; expected two nodes")
        if edge_id is None or start is None or end is None:
            return
        key = (edge_id, start, end)
        if key in self.edges:
            self.problems.append(f"{where}: repeats {self.edges[key].label}, from node {start} "
                                 f"to node {end}")
        else:
            self.edges[key] = Edge(index, edge_id, start, end, feature)

    def ends(self) -> None:
        """Every edge's nodes exist (checked once all nodes are known: an edge may come
        first)."""
        for edge in self.edges.values():
            for key, node in (("startid", edge.start), ("endid", edge.end)):
                if node not in self.nodes:
                    self.problems.append(f"{edge.label}: {key} {node} names no node")


def read_route_graph(data: Any) -> tuple[RouteGraph | None, list[str]]:
    """The route graph of parsed GeoJSON ``data``, or None and every problem of it.

    Data that is not a ``FeatureCollection`` with a list of features gets that one problem, and
    nothing of it is quoted: it may be any file.
    """
    if not (isinstance(data, Mapping) and data.get("type") == "FeatureCollection"
            and isinstance(data.get("features"), list)):
        return None, [f"the top level: expected a GeoJSON FeatureCollection (a mapping with type "
                      f"FeatureCollection and a list of features), got {found(data)}"]
    reader = _Reader()
    features = data["features"]
    for index, feature in enumerate(features):
        if not isinstance(feature, Mapping):
            reader.problems.append(f"features[{index}]: expected a GeoJSON Feature (a mapping), "
                                   f"got {found(feature)}")
            continue
        kind, problem = _kind(index, feature.get("geometry"))
        properties = feature.get("properties")
        if problem is None and not isinstance(properties, Mapping):
            problem = (f"features[{index}]: properties: expected a mapping holding the "
                       f"{kind}'s id, got {found(properties)}")
        if problem is not None:
            reader.problems.append(problem)
        elif kind == "node":
            reader.node(index, feature, properties)
        else:
            reader.edge(index, feature, properties)
    reader.ends()
    if reader.problems:
        return None, reader.problems
    collection = {key: value for key, value in data.items() if key != "features"}
    return RouteGraph(tuple(reader.nodes.values()), tuple(reader.edges.values()), collection,
                      tuple(features)), []
