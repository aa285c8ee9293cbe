"""The case graph as a Nav2 route graph: the case base format ``nav2-route``.

Export writes the case graph of a case base on the map of its run (a grid with a metric frame)
as the GeoJSON that Nav2's Route Server reads: every vertex a ``Point`` node, every segment two
edges, one each way (a segment is driven both ways, a route graph's edge one way), whose
``cost`` is the segment's cost in metres (its length weighted by its cells' risk, under the
grid's step cost contract, on the map with the risks the run learned). Each edge's ``metadata``
holds the case graph's own facts under the key ``cbr``: ``cost`` (metres), ``risk`` (the mean
risk of its cells) and ``uses`` (how many reused paths ran along it). A segment blocked on the
map is left out: no search of the case graph takes it either.

Import reads a route graph into an initial case graph: each node falls in the cell holding its
point, each edge becomes the straight line of cells between its nodes' cells, cut at its turns
into segments (a segment runs in one of the 8 grid directions), and where two lines share cells
they share segments. A node outside the map or on an obstacle, two nodes in one cell, or an edge
whose line crosses an obstacle (or cuts a blocked corner) is refused, and nothing is imported.
The route graph's own features are kept in the case base (meta key ``casegraph.route``) as they
were, with what the case graph has no use for (ids, exact coordinates, frames, costs,
``overridable``, ``metadata``, ``operations``, the collection's ``name`` and ``crs``): export
gives them back, each node as it was and each edge as it was plus its ``cbr`` facts, as long as
the case graph still holds its line, unblocked; then it adds what the case graph learned beyond
them, with ids above the route graph's: the learned segments, and where one meets a given edge
inside its line, the two parts of that edge from and to the meeting node, so that the learned
ways are reached from the given ones. The ``cbr`` key of an edge's metadata is the case
graph's: import drops it, so an exported graph imports back to the same case graph.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

import attrs
import numpy as np

from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.route_geojson import RouteGraph, read_route_graph
from cbr_grid.costs import step_costs
from cbr_grid.frame import in_metres
from cbr_grid.grid import Grid, grid_fingerprint
from cbr_grid.risk import record_map, stored_risks
from cbrcore.casebase.exchange import Document, document_of, refusal
from cbrcore.casebase.formats import DocumentFormat
from cbrcore.casebase.memory import MemoryStore
from cbrcore.casebase.worlds import record_world
from cbrcore.documents import DocumentError, load_json
from cbrcore.errors import CaseBaseError

ROUTE_KEY = "casegraph.route"
"""Case base meta key of the imported route graph: ``{"collection": {...}, "features": [...]}``,
the file's features as they were."""

OWN = "cbr"
"""The key of an edge's ``metadata`` that holds the case graph's facts of it."""

Cell = tuple[int, int]


def line_cells(a: Cell, b: Cell) -> np.ndarray:
    """The (n, 2) cells of the straight line from cell ``a`` to cell ``b``, 8-connected, each
    the cell nearest the line at its step: the same cells whichever end it is drawn from."""
    first, last = sorted((a, b))
    start = np.asarray(first, dtype=np.int64)
    delta = np.asarray(last, dtype=np.int64) - start
    steps = int(np.abs(delta).max())
    i = np.arange(steps + 1, dtype=np.int64)[:, None]
    # floor(i·d/n + 1/2) in integers: exact for any map size
    cells = start + (2 * i * delta + steps) // (2 * steps)
    return cells if first == a else cells[::-1]


def _grid(world: Any) -> Grid:
    """The run's map, which must be a grid in a metric frame."""
    if not isinstance(world, Grid):
        raise CaseBaseError(f"a Nav2 route graph lies on a grid map with a metric frame; the "
                            f"world is a {type(world).__name__}")
    if world.frame is None:
        raise CaseBaseError(f"a Nav2 route graph is in metres, and the {world.width}x"
                            f"{world.height} map has no metric frame: give it one (a ROS map, "
                            "or the map_file world's frame option)")
    return world


@attrs.frozen
class _Placed:
    """A route graph on a map: each node's cell by id, each edge's line from its start by the
    index of its feature."""

    cells: dict[int, Cell]
    lines: dict[int, np.ndarray]


def _place(route: RouteGraph, grid: Grid) -> tuple[_Placed, list[str]]:
    """The cells of the route graph's nodes and edges, and what does not fit the map: a node
    outside it or on an obstacle, an edge between two nodes of one cell. Nodes closer than a
    cell share one vertex of the case graph (Nav2's depot graph has two such nodes)."""
    frame = grid.frame
    assert frame is not None
    problems = []
    cells: dict[int, Cell] = {}
    spans = frame.spans(grid.width, grid.height)
    for node in route.nodes:
        x, y = (int(v) for v in frame.to_cells(node.point, grid.height)[0])
        where = f"{node.label} at {in_metres(node.point, (x, y))}"
        if not grid.in_bounds((x, y)):
            problems.append(f"{where} lies outside the map ({spans})")
        elif not grid.passable[y, x]:
            problems.append(f"{where} is {grid.blocked_reason((x, y))}")
        else:
            cells[node.id] = (x, y)
    lines = {}
    for edge in route.edges:
        if edge.start in cells and edge.end in cells:
            if cells[edge.start] == cells[edge.end]:
                problems.append(f"{edge.label} joins node {edge.start} and node {edge.end}, "
                                f"which are in one cell of the map ({frame.resolution:g} m); "
                                "expected nodes at least a cell apart")
            else:
                lines[edge.index] = line_cells(cells[edge.start], cells[edge.end])
    return _Placed(cells, lines), problems


def _blocked(grid: Grid, line: np.ndarray) -> str | None:
    """Where ``line`` leaves the free space of ``grid``, or None when the robot may drive it."""
    allowed = grid.step_allowed(line[:-1], line[1:])
    if allowed.all():
        return None
    i = int(np.argmin(allowed))
    frame = grid.frame
    assert frame is not None
    for cell in (line[i], line[i + 1]):
        x, y = int(cell[0]), int(cell[1])
        if not grid.passable[y, x]:
            return f"crosses an obstacle at {in_metres(frame.to_map(cell, grid.height)[0], (x, y))}"
    x, y = int(line[i + 1][0]), int(line[i + 1][1])
    return (f"cuts a blocked corner at "
            f"{in_metres(frame.to_map(line[i + 1], grid.height)[0], (x, y))}")


def _parsed(text: str, source: str) -> RouteGraph:
    try:
        data = load_json(text, source)
    except json.JSONDecodeError as exc:  # its text names the line and column, quoting nothing
        raise CaseBaseError(f"{source}: not valid JSON: {exc}") from exc
    except DocumentError as exc:
        raise CaseBaseError(str(exc)) from None
    return _checked(data, source)


def _checked(data: Any, source: str) -> RouteGraph:
    route, problems = read_route_graph(data)
    if route is None:
        raise refusal(source, "a Nav2 route graph", problems)
    return route


def _without_own(feature: Mapping[str, Any]) -> dict[str, Any]:
    """An edge feature without the case graph's facts in its metadata; a metadata that held
    nothing else goes too."""
    feature = dict(feature)
    properties = dict(feature["properties"])
    metadata = properties.get("metadata")
    if isinstance(metadata, Mapping) and OWN in metadata:
        rest = {key: value for key, value in metadata.items() if key != OWN}
        if rest:
            properties["metadata"] = rest
        else:
            del properties["metadata"]
    feature["properties"] = properties
    return feature


def parse_route_graph(text: str, source: str, world: Any) -> Document:
    """The initial case base a route graph file seeds on the map ``world`` (see the module)."""
    grid = _grid(world)
    route = _parsed(text, source)
    placed, problems = _place(route, grid)
    for edge in route.edges:
        line = placed.lines.get(edge.index)
        blocked = None if line is None else _blocked(grid, line)
        if blocked is not None:
            problems.append(f"{edge.label} from node {edge.start} to node {edge.end} {blocked}")
    if problems:
        raise refusal(source, "a Nav2 route graph on this map", problems)
    edges = {edge.index for edge in route.edges}
    record = {"collection": dict(route.collection),
              "features": [_without_own(feature) if index in edges else feature
                           for index, feature in enumerate(route.features)]}
    store = MemoryStore()
    graph = CaseGraph(grid, store)
    with store.transaction():
        drawn: set[frozenset[int]] = set()
        for edge in route.edges:
            # the edges of a pair of nodes, one each way, are one line of cells
            pair = frozenset((edge.start, edge.end))
            if pair not in drawn:
                drawn.add(pair)
                graph.add_path(placed.lines[edge.index])
        record_map(store, grid)
        store.set_meta(ROUTE_KEY, record)
    record_world(store, grid_fingerprint(grid), "one")
    return document_of(store)


def _learned(grid: Grid, store: MemoryStore) -> Grid:
    """``grid`` with the risks the run learned into the case base."""
    learned = stored_risks(store, grid)
    if not learned:
        return grid
    risk = grid.risk.copy()
    for (x, y), value in learned.items():
        risk[y, x] = value
    return attrs.evolve(grid, risk=risk)


class _Writer:
    """Builds the features of an exported route graph."""

    def __init__(self, grid: Grid, graph: CaseGraph) -> None:
        self.grid = grid
        self.graph = graph
        assert grid.frame is not None
        self.resolution = grid.frame.resolution
        self.features: list[dict[str, Any]] = []
        self.covered = np.zeros(grid.risk.shape, dtype=bool)
        self.node_at: dict[Cell, int] = {}
        self.points: dict[int, list[float]] = {}
        self.next_id = 0
        # the directed route graph edges given back: start node, end node, line of cells
        self.lines: list[tuple[int, int, np.ndarray]] = []

    def facts(self, cost: float, risk: float, uses: int) -> dict[str, Any]:
        return {"cost": round(cost * self.resolution, 6), "risk": round(risk, 6),
                "uses": uses}

    def _uses(self, line: np.ndarray) -> int | None:
        """The least use count of the segments the case graph runs ``line`` along; None when
        it no longer holds a step of it."""
        uses = None
        for p, q in zip(line[:-1].tolist(), line[1:].tolist(), strict=True):
            along = set(self.graph.edges_at(tuple(p))) & set(self.graph.edges_at(tuple(q)))
            if not along:
                return None
            least = int(self.graph.uses(sorted(along)).min())
            uses = least if uses is None else min(uses, least)
        return uses

    def recorded(self, route: RouteGraph, placed: _Placed) -> None:
        """The route graph's own features, each node as it was, each edge the case graph still
        holds as it was plus its facts."""
        ids = [node.id for node in route.nodes] + [edge.id for edge in route.edges]
        self.next_id = max(ids, default=-1) + 1
        # of nodes sharing a cell, a learned segment meets the first
        self.node_at = {}
        for node, cell in placed.cells.items():
            self.node_at.setdefault(cell, node)
        self.points = {node.id: list(node.point) for node in route.nodes}
        edges = {edge.index: edge for edge in route.edges}
        for index, feature in enumerate(route.features):
            edge = edges.get(index)
            if edge is None:
                self.features.append(dict(feature))
                continue
            line = placed.lines[index]
            facts = None if _blocked(self.grid, line) else self._line_facts(line)
            if facts is None:
                continue
            self.covered[line[:, 1], line[:, 0]] = True
            self.lines.append((edge.start, edge.end, line))
            properties = dict(feature["properties"])
            properties["metadata"] = {**properties.get("metadata", {}), OWN: facts}
            self.features.append({**feature, "properties": properties})

    def _line_facts(self, line: np.ndarray) -> dict[str, Any] | None:
        """The facts of a line of cells the case graph holds; None when it holds no longer
        every step of it."""
        uses = self._uses(line)
        if uses is None:
            return None
        return self.facts(float(step_costs(self.grid, line).sum()),
                          float(self.grid.risk[line[:, 1], line[:, 0]].mean()), uses)

    def _node(self, cell: Cell) -> int:
        """The id of the node on ``cell``, added when there is none."""
        if cell not in self.node_at:
            assert self.grid.frame is not None
            x, y = self.grid.frame.to_map(cell, self.grid.height)[0]
            self.node_at[cell] = self.next_id
            self.points[self.next_id] = [round(float(x), 6), round(float(y), 6)]
            self.features.append({"type": "Feature", "properties": {"id": self.next_id},
                                  "geometry": {"type": "Point",
                                               "coordinates": self.points[self.next_id]}})
            self.next_id += 1
        return self.node_at[cell]

    def _edge(self, start: int, end: int, facts: dict[str, Any]) -> None:
        """A new edge from node ``start`` to node ``end``, the case graph's cost its cost."""
        self.features.append({"type": "Feature", "properties": {
            "id": self.next_id, "startid": start, "endid": end, "cost": facts["cost"],
            "metadata": {OWN: facts}},
            "geometry": {"type": "MultiLineString",
                         "coordinates": [[self.points[start], self.points[end]]]}})
        self.next_id += 1

    def learned(self) -> None:
        """The segments beyond the route graph's lines, each an edge each way; a learned
        segment that meets a given edge inside its line joins it by the two parts of that
        line, so that the route server finds the way from one to the other too."""
        given = dict(self.node_at)
        edges = self.graph.edge_ids()
        starts, ends = self.graph.ends(edges)
        added = []
        for edge, a, b in zip(edges.tolist(), starts.tolist(), ends.tolist(), strict=True):
            cells = line_cells(tuple(a), tuple(b))
            if self.covered[cells[:, 1], cells[:, 0]].all():
                continue
            if np.isfinite(self.graph.costs([edge])[0]):
                added.append((edge, self._node(tuple(a)), self._node(tuple(b))))
        for edge, na, nb in added:
            facts = self.facts(float(self.graph.costs([edge])[0]),
                               float(self.graph.risks([edge])[0]),
                               int(self.graph.uses([edge])[0]))
            self._edge(na, nb, facts)
            self._edge(nb, na, facts)
        junctions = {cell: node for cell, node in self.node_at.items() if cell not in given}
        for start, end, line in self.lines:
            for i, cell in enumerate(map(tuple, line[1:-1].tolist()), start=1):
                node = junctions.get(cell)
                if node is not None:
                    for a, b, part in ((start, node, line[:i + 1]), (node, end, line[i:])):
                        facts = self._line_facts(part)
                        assert facts is not None  # part of a line the graph holds
                        self._edge(a, b, facts)


def dump_route_graph(document: Document, world: Any) -> str:
    """The case graph of ``document`` on the map ``world`` as a route graph (see the module)."""
    grid = _grid(world)
    store = MemoryStore()
    store.restore(document.cases, document.meta, document.revision)
    grid = _learned(grid, store)
    writer = _Writer(grid, CaseGraph.load(grid, store))
    record = document.meta.get(ROUTE_KEY)
    collection: dict[str, Any] = {"type": "FeatureCollection", "name": "casegraph"}
    if record is not None:
        where = f"case base meta {ROUTE_KEY!r}"
        if not isinstance(record, Mapping) or not isinstance(record.get("collection"), Mapping):
            raise CaseBaseError(f"{where}: expected a mapping of the route graph's collection "
                                "and features")
        route = _checked({**record["collection"], "features": record.get("features")}, where)
        placed, problems = _place(route, grid)
        if problems:
            raise refusal(where, "a Nav2 route graph on this map", problems)
        writer.recorded(route, placed)
        collection = dict(route.collection)
    writer.learned()
    return json.dumps({**collection, "features": writer.features}, indent=1,
                      allow_nan=False) + "\n"


ROUTE_GRAPH = DocumentFormat(
    "nav2-route", (".geojson",), "a case graph as a Nav2 Route Server graph (GeoJSON)",
    dump_route_graph, parse_route_graph, world="a grid map with a metric frame", append=False)
"""The case base format of Nav2 route graphs."""
