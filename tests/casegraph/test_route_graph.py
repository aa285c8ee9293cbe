"""The case graph as a Nav2 route graph: ``--format nav2-route`` and ``casebase.initial``.

Nav2's own route graphs (tests/data/ros: the depot's, and the sample with metadata and
operations) import into a case graph and export back equal; a graph learned on the depot
exports as a route graph that seeds a fresh run. Bad route graphs are rows of
tests/cli/test_bad_inputs.py.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cbr_casegraph.route_graph import OWN
from cbr_stores.sqlite import SQLiteStore
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult
from repo_paths import ROOT

Cli = Callable[..., CliResult]

ROS = ROOT / "tests" / "data" / "ros"
CONFIG = ROOT / "configs" / "ros_depot_route.yaml"
DEPOT_WORLD = f"{{use: map_file, path: {ROS / 'depot.yaml'}}}"
RESOLUTION = 0.05
OCTILE = math.sqrt(4 - 2 * math.sqrt(2))  # the most an octile length exceeds a Euclidean one


@pytest.fixture(autouse=True)
def installed(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    return cbr_plugins(entry_points=True)


def _open_world(tmp: Path) -> str:
    """A free 30x30 map of 0.1 m cells from (-0.5, -0.5) m: the sample graph's 0..2 m and
    room around them (the sample comes with no map of its own)."""
    path = tmp / "open.map"
    path.write_text("type octile\nheight 30\nwidth 30\nmap\n" + ("." * 30 + "\n") * 30,
                    encoding="ascii")
    return f"{{use: map_file, path: {path}, frame: {{resolution: 0.1, origin: [-0.5, -0.5, 0]}}}}"


def _without_own(feature: dict[str, Any]) -> dict[str, Any]:
    """A feature without the case graph's facts, which export adds to each edge's metadata."""
    feature = json.loads(json.dumps(feature))
    metadata = feature["properties"].get("metadata")
    if metadata is not None:
        metadata.pop(OWN, None)
        if not metadata:
            del feature["properties"]["metadata"]
    return feature


def _points(data: dict[str, Any]) -> dict[int, tuple[float, float]]:
    return {f["properties"]["id"]: tuple(f["geometry"]["coordinates"][:2])
            for f in data["features"] if f["geometry"]["type"] == "Point"}


def _edges(data: dict[str, Any]) -> list[dict[str, Any]]:
    return [f for f in data["features"] if f["geometry"]["type"] != "Point"]


@pytest.mark.parametrize("name", ["depot_graph", "sample_graph"])
def test_nav2_route_graphs_import_and_export_back_equal(invoke_cbr: Cli, tmp_path: Path,
                                                        name: str) -> None:
    """Every node, edge, id, cost, metadata, operation and coordinate comes back; each edge
    gains the case graph's facts, a cost that is the octile length of its line of cells."""
    world = DEPOT_WORLD if name == "depot_graph" else _open_world(tmp_path)
    resolution = RESOLUTION if name == "depot_graph" else 0.1
    source = ROS / f"{name}.geojson"
    casebase, back = tmp_path / "cb.sqlite", tmp_path / "back.geojson"

    imported = invoke_cbr("casebase", "import", str(casebase), str(source), "--world", world)
    assert imported.exit_code == 0, imported
    assert invoke_cbr("casebase", "check", str(casebase)).stdout == "ok\n"
    exported = invoke_cbr("casebase", "export", str(casebase), "--world", world, "-o", str(back))
    assert exported.exit_code == 0, exported

    original = json.loads(source.read_text(encoding="utf-8"))
    written = json.loads(back.read_text(encoding="utf-8"))
    assert [_without_own(f) for f in written["features"]] == original["features"]
    assert {k: v for k, v in written.items() if k != "features"} == {
        k: v for k, v in original.items() if k != "features"}
    points = _points(original)
    for edge in _edges(written):
        facts = edge["properties"]["metadata"][OWN]
        start, end = (points[edge["properties"][k]] for k in ("startid", "endid"))
        euclid = math.dist(start, end)
        # the nodes' cells' centres are within half a diagonal of a cell of their points
        slack = math.sqrt(2) * resolution
        assert euclid - slack <= facts["cost"] <= OCTILE * (euclid + slack)
        assert (facts["risk"], facts["uses"]) == (0.0, 0)


def test_sample_graph_keeps_what_the_case_graph_has_no_use_for(invoke_cbr: Cli,
                                                               tmp_path: Path) -> None:
    """Frames, costs, overridable, metadata and operations live in the case base, beside the
    segments, and the segments cover the straight line of every edge."""
    casebase = tmp_path / "cb.sqlite"
    assert invoke_cbr("casebase", "import", str(casebase), str(ROS / "sample_graph.geojson"),
                   "--world", _open_world(tmp_path)).exit_code == 0
    with SQLiteStore(casebase) as store:
        record = store.get_meta("casegraph.route")
        segments = list(store.cases("segment"))
    first = next(f for f in record["features"] if f["properties"]["id"] == 9)
    assert first["properties"]["cost"] == 10.0
    assert first["properties"]["operations"]["open_door"]["metadata"]["door_id"] == 54
    assert record["features"][0]["properties"]["frame"] == "map"
    # the 3x3 lattice of 1 m: 12 lines of 10 cells each way, cut at the nodes' cells
    covered = set()
    for case in segments:
        a, b = np.array(case.problem["a"]), np.array(case.problem["b"])
        steps = int(np.abs(b - a).max())
        covered |= {tuple(a + i * np.sign(b - a)) for i in range(steps + 1)}
    # cell (x, y) of the 30-row map holds the point (x·0.1 - 0.45, (29 - y)·0.1 - 0.45) m
    lattice = {(5 + 10 * i + k, 24 - 10 * j) for i in range(2) for j in range(3)
               for k in range(11)} | {(5 + 10 * i, 24 - 10 * j - k) for i in range(3)
                                      for j in range(2) for k in range(11)}
    assert covered == lattice
    assert len(segments) == 12


def test_a_route_graph_seeds_a_run_as_its_initial_case_base(invoke_cbr: Cli,
                                                             tmp_path: Path) -> None:
    """``casebase.initial`` reads a route graph on the run's map: trips between its nodes are
    planned through its segments from the first on."""
    out = tmp_path / "run"
    # beside the depot graph's nodes 1, 3 and 0
    places = "workload.places=[[0.6, 7.8], [7.6, 7.9], [0.6, 12.9]]"
    result = invoke_cbr("run", str(CONFIG), "--out", str(out), "--set", "workload.count=3",
                     "--set", places,
                     "--set", f"casebase.initial={ROS / 'depot_graph.geojson'}")
    assert result.exit_code == 0, result
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert summary["cases_at_start"] > 0
    assert summary["from_casebase"] == summary["queries"] == 3


def test_a_graph_learned_on_the_depot_is_a_route_graph_that_seeds_a_fresh_run(
        invoke_cbr: Cli, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Run the depot configuration briefly, export its case graph with --config (its world is
    the inflated depot), and start a fresh run from the export: every segment is an edge each
    way between nodes on its end cells, its cost at least its length in metres."""
    monkeypatch.chdir(tmp_path)
    assert invoke_cbr("run", str(CONFIG), "--set", "workload.count=4").exit_code == 0
    learned = tmp_path / "learned.geojson"
    result = invoke_cbr("casebase", "export", "--config", str(CONFIG), "--format", "nav2-route",
                     "-o", str(learned))
    assert result.exit_code == 0, result
    with SQLiteStore(tmp_path / "runs" / "ros_depot_route" / "casebase.sqlite") as store:
        segments = {frozenset((tuple(c.problem["a"]), tuple(c.problem["b"])))
                    for c in store.cases("segment")}
    data = json.loads(learned.read_text(encoding="utf-8"))
    points = _points(data)
    height = 307  # the depot's rows; cell (x, y) holds ((x + 0.5)·0.05, (306.5 - y)·0.05) m

    def cell(node: int) -> tuple[int, int]:
        x, y = points[node]
        return round(x / RESOLUTION - 0.5), round(height - 0.5 - y / RESOLUTION)

    drawn = {}
    for edge in _edges(data):
        properties = edge["properties"]
        start, end = properties["startid"], properties["endid"]
        assert properties["cost"] >= math.dist(points[start], points[end]) - 1e-6
        drawn.setdefault(frozenset((cell(start), cell(end))), set()).add((start, end))
    assert set(drawn) == segments
    assert all(len(ways) == 2 for ways in drawn.values())

    fresh = tmp_path / "fresh"
    result = invoke_cbr("run", str(CONFIG), "--out", str(fresh), "--set", "workload.count=2",
                     "--set", f"casebase.initial={learned}")
    assert result.exit_code == 0, result
    summary = json.loads((fresh / "summary.json").read_text(encoding="utf-8"))
    assert summary["cases_at_start"] == len(segments)
    assert summary["from_casebase"] >= 1


def test_formats_lists_the_route_graph_with_its_plugin(invoke_cbr: Cli) -> None:
    result = invoke_cbr("casebase", "formats")
    assert result.exit_code == 0
    lines = {line.split()[0]: line for line in result.stdout.splitlines()}
    assert list(lines) == ["yaml", "json", "nav2-route"]
    assert ".geojson" in lines["nav2-route"] and "casegraph" in lines["nav2-route"]
    assert "needs a grid map with a metric frame" in lines["nav2-route"]


def test_a_route_graph_is_not_appended(invoke_cbr: Cli, tmp_path: Path) -> None:
    result = invoke_cbr("casebase", "import", str(tmp_path / "cb.sqlite"),
                     str(ROS / "depot_graph.geojson"), "--world", DEPOT_WORLD, "--append")
    assert result.exit_code == 2
    assert "a nav2-route document is a whole case base" in result.stderr
    assert not (tmp_path / "cb.sqlite").exists()


def test_export_to_standard_output_and_an_unknown_format(invoke_cbr: Cli, tmp_path: Path) -> None:
    """Standard output takes any format; a format nobody offers is named with those offered."""
    casebase = tmp_path / "cb.sqlite"
    assert invoke_cbr("casebase", "import", str(casebase), str(ROS / "depot_graph.geojson"),
                   "--world", DEPOT_WORLD).exit_code == 0
    shown = invoke_cbr("casebase", "export", str(casebase), "--format", "nav2-route", "--world",
                    DEPOT_WORLD)
    assert shown.exit_code == 0
    assert len(_points(json.loads(shown.stdout))) == 34
    unknown = invoke_cbr("casebase", "export", str(casebase), "--format", "geojson")
    assert unknown.exit_code == 2
    assert ("no case base format is called 'geojson'; expected one of: yaml, json, nav2-route "
            "(casegraph)") in unknown.stderr
    needless = invoke_cbr("casebase", "export", str(casebase), "--world", DEPOT_WORLD)
    assert needless.exit_code == 2 and "the yaml format needs no world" in needless.stderr


def _components(pairs: list[tuple[Any, Any]]) -> int:
    """How many connected pieces the undirected edges ``pairs`` make."""
    parent: dict[Any, Any] = {}

    def root(x: Any) -> Any:
        parent.setdefault(x, x)
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for a, b in pairs:
        parent[root(a)] = root(b)
    return len({root(x) for x in parent})


def test_what_a_seeded_run_learns_is_reached_from_the_route_graph(invoke_cbr: Cli,
                                                                  tmp_path: Path) -> None:
    """A run seeded with the depot graph learns paths that meet its edges inside their lines;
    the export joins them there, so its route graph is in as many connected pieces as the case
    graph. The given edges come back in their order, but for those whose line the run forgot
    in part (``risky_segments`` forgets the segments of the staircases close to the shelves)."""
    out = tmp_path / "run"
    assert invoke_cbr("run", str(CONFIG), "--out", str(out), "--set",
                   f"casebase.initial={ROS / 'depot_graph.geojson'}").exit_code == 0
    learned = tmp_path / "learned.geojson"
    assert invoke_cbr("casebase", "export", str(out / "casebase.sqlite"), "-o", str(learned),
                   "--world", DEPOT_WORLD).exit_code == 0
    with SQLiteStore(out / "casebase.sqlite") as store:
        segments = [(tuple(c.problem["a"]), tuple(c.problem["b"])) for c in store.cases("segment")]
    data = json.loads(learned.read_text(encoding="utf-8"))
    edges = [(e["properties"]["startid"], e["properties"]["endid"]) for e in _edges(data)]
    original = json.loads((ROS / "depot_graph.geojson").read_text(encoding="utf-8"))
    given = [f["properties"] for f in _edges(original)]
    # the depot graph's largest id is 10077: new edges count on from 10078
    kept = [{k: v for k, v in e["properties"].items() if k != "metadata"}
            for e in _edges(data) if e["properties"]["id"] <= 10077]
    assert kept == [e for e in given if e in kept]
    assert 0 < len(kept) < len(given) < len(edges)
    assert _components(edges) == _components(segments)
