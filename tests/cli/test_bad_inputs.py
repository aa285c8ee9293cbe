"""Bad inputs to ``cbr run``, ``cbr plan`` and ``cbr casebase``: one clear error, exit code 2, no
leaked content.

A configuration or command that names a file of the wrong kind (a secret, say) must not get that
file's text printed: the error names the file and line and says what was expected there. Output
paths that would leave the run folder are refused unless given absolute.
"""

from __future__ import annotations

import importlib.util
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any
from unittest import mock

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_stores.sqlite import SQLiteStore
from cbrcore.casebase.worlds import record_world
from cbrcore.fingerprint import fingerprint
from cbrcore.model import Case as StoredCase
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult
from repo_paths import DATA, ROOT

Cli = Callable[..., CliResult]

HYBRID = ROOT / "configs" / "hybrid_grid.yaml"
# 604x307 cells of 0.05 m from the origin (0, 0): x 0 to 30.2 m, y 0 to 15.35 m
DEPOT = DATA / "ros" / "depot.yaml"
DEPOT_SPAN = "did you mean --frame map? (the map's frame spans x 0 to 30.2 m and y 0 to 15.35 m)"
ROS_WORLD = f"world: {{use: map_file, path: {DEPOT}"
SECRET = "TOPSECRET password=hunter2\nTOPSECRET: second line\n"
MARKER = "TOPSECRET"

# 3x2, with an obstacle at (2, 0)
SMALL_MAP = "type octile\nheight 2\nwidth 3\nmap\n..@\n...\n"
ROS_YAML = ("image: secret.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
            "occupied_thresh: 0.65\nfree_thresh: 0.2\n")


@pytest.fixture(autouse=True)
def installed(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    """The installed plugins, grid and solvers among them, made current for every test."""
    return cbr_plugins(entry_points=True)


def _config(folder: Path, extra: str) -> Path:
    """The hybrid grid configuration in ``folder`` with the line ``extra`` first, in place of
    the file's own line for that key (so errors about it are on line 1)."""
    key = extra.split(":", 1)[0]
    kept = [line for line in HYBRID.read_text(encoding="utf-8").splitlines()
            if line.split(":", 1)[0] != key]
    path = folder / "run.yaml"
    path.write_text("\n".join([extra, *kept]) + "\n", encoding="utf-8")
    return path


Case = Callable[[Path, Cli], CliResult]


def _run(extra: str) -> Case:
    """``cbr run`` of the hybrid configuration in tmp/a/b with the line ``extra``."""
    def case(tmp: Path, invoke_cbr: Cli) -> CliResult:
        return invoke_cbr("run", str(_config(tmp / "a" / "b", extra)), "--out", str(tmp / "out"))

    return case


def _plan(*args: str) -> Case:
    """``cbr plan`` with ``args``, file names taken in tmp."""
    def case(tmp: Path, invoke_cbr: Cli) -> CliResult:
        return invoke_cbr("plan", *(str(tmp / a) if a.endswith((".txt", ".map", ".scen")) else a
                                 for a in args))

    return case


def _plan_depot(*args: str) -> Case:
    """``cbr plan`` on the depot, a ROS map with a metric frame, with ``args``, file names
    ending in .txt taken in tmp."""
    def case(tmp: Path, invoke_cbr: Cli) -> CliResult:
        return invoke_cbr("plan", str(DEPOT), *(str(tmp / a) if a.endswith(".txt") else a
                                             for a in args))

    return case


def _cbr(*args: str) -> Case:
    """``cbr`` with ``args``, a map named ``small.map`` taken in tmp."""
    def case(tmp: Path, invoke_cbr: Cli) -> CliResult:
        return invoke_cbr(*(str(tmp / a) if a == "small.map" else a for a in args))

    return case


def _scen(*lines: str) -> str:
    return "version 1\n" + "".join(f"0\tsmall.map\t3\t2\t{line}\n" for line in lines)


def _of_world(tmp: Path, description: str) -> Path:
    """A case base in ``tmp`` whose cases belong to a world ``description`` stands for."""
    path = tmp / "worlds.sqlite"
    with SQLiteStore(path) as store:
        record_world(store, fingerprint("test", description, description), "one")
    return path


def _run_in_another_world(tmp: Path, invoke_cbr: Cli) -> CliResult:
    """The hybrid configuration (office 100x100, seed 7) on a case base of another office."""
    path = _of_world(tmp, "office 100x100, seed 1")
    return _run(f"casebase: {{use: sqlite, path: {path}}}")(tmp, invoke_cbr)


def _import_from_another_world(tmp: Path, invoke_cbr: Cli) -> CliResult:
    """``import --append`` of a document recording another world than the case base's."""
    path = _of_world(tmp, "office 100x100, seed 1")
    other = fingerprint("test", "maze", "maze 64x64, seed 3")
    document = tmp / "maze.yaml"
    document.write_text(yaml.safe_dump({
        "format": "cbrcore-casebase", "schema": 1, "revision": 1,
        "meta": {"cbrcore.worlds": [other.to_data()]}, "cases": [{"problem": 1, "solution": 1}]}))
    return invoke_cbr("casebase", "import", str(path), str(document), "--append")


def _export_over_the_case_base(tmp: Path, invoke_cbr: Cli) -> CliResult:
    """``export`` to the case base's own file, through a link; the case base keeps its case."""
    path = tmp / "cb.sqlite"
    with SQLiteStore(path) as store:
        store.add(StoredCase({"a": 1}, {"b": 2}))
    (tmp / "cb.json").symlink_to(path)
    result = invoke_cbr("casebase", "export", str(path), "-o", str(tmp / "cb.json"))
    with SQLiteStore(path) as store:
        assert store.count() == 1
    path.unlink()  # the common check asserts that no case base is left behind
    return result


DEPOT_WORLD = f"{{use: map_file, path: {DEPOT}}}"


def _node(node: Any, x: Any, y: Any) -> dict[str, Any]:
    """A route graph node, ``node`` its id (None: without one)."""
    properties = {} if node is None else {"id": node}
    return {"type": "Feature", "properties": properties,
            "geometry": {"type": "Point", "coordinates": [x, y]}}


def _edge(edge: int, start: int, end: int) -> dict[str, Any]:
    return {"type": "Feature", "properties": {"id": edge, "startid": start, "endid": end},
            "geometry": {"type": "MultiLineString", "coordinates": [[[0, 0], [1, 1]]]}}


# two nodes in the depot's open floor, and an edge each way
ROUTE = [_node(0, 2, 2), _node(1, 2, 12), _edge(5, 0, 1), _edge(6, 1, 0)]


def _route(features: list[dict[str, Any]] | str, *args: str, document: str = "graph.geojson",
           environ: dict[str, str] | None = None) -> Case:
    """``cbr casebase import`` into tmp's cb.sqlite of a route graph of ``features`` (or the
    text) written to ``document`` in tmp (a file already there is left as it is), on the depot
    or with ``args`` instead of ``--world``, with ``environ`` set."""
    def case(tmp: Path, invoke_cbr: Cli) -> CliResult:
        path = tmp / document
        if not path.exists():
            path.write_text(features if isinstance(features, str) else json.dumps(
                {"type": "FeatureCollection", "features": features}), encoding="utf-8")
        given = [a.replace("small.map", str(tmp / "small.map")) for a in args]
        with mock.patch.dict(os.environ, environ or {}):
            return invoke_cbr("casebase", "import", str(tmp / "cb.sqlite"), str(path),
                           *(given or ("--world", DEPOT_WORLD)))

    return case


def _route_export_without_a_map(tmp: Path, invoke_cbr: Cli) -> CliResult:
    """``cbr casebase export --format nav2-route`` of a case base, no map given."""
    return invoke_cbr("casebase", "export", str(tmp / "other.sqlite"), "--format", "nav2-route")


CASES = {
    "movingai map": (_run("world: {use: movingai, map: ../../secret.txt}"),
                     "secret.txt, line 1: expected the Moving AI header 'type octile'"),
    "map_file .map": (_run("world: {use: map_file, path: ../../secret.map}"),
                      "secret.map, line 1: expected the Moving AI header 'type octile'"),
    "map_file .grid": (_run("world: {use: map_file, path: ../../secret.grid}"),
                       "secret.grid, line 2: expected a row of 26 cells like line 1"),
    "map_file ROS yaml": (_run("world: {use: map_file, path: ../../secret.yaml}"),
                          "secret.yaml, line 2: expected only the keys"),
    "ROS image .pgm": (_run("world: {use: map_file, path: ../../ros.yaml}"),
                       "secret.pgm: cannot read the image; expected a PGM (P2 or P5), PNG or "
                       "another image format Pillow reads"),
    "map_file .npy text": (_run("world: {use: map_file, path: ../../secret.npy}"),
                           "secret.npy: expected a NumPy array file"),
    "map_file .npy complex": (_run("world: {use: map_file, path: ../../complex.npy}"),
                              "complex.npy: expected real risk values, got a complex array"),
    "plan a secret as map": (_plan("secret.map", "--start", "0,0", "--goal", "1,1"),
                             "secret.map, line 1: expected the Moving AI header 'type octile'"),
    "plan a secret as scen": (_plan("small.map", "--scen", "secret.txt"),
                              "secret.txt, line 1: expected 'version 1' or 'version 1.0'"),
    "scen start on an obstacle": (_plan("small.map", "--scen", "obstacle.scen"),
                                  "obstacle.scen, line 3: start (2, 0) is on an obstacle"),
    "scen optimum 1e400": (_plan("small.map", "--scen", "huge.scen"),
                           "huge.scen, line 2: expected an optimal length below 1e300"),
    "map that never ends": (_plan("endless.map", "--start", "0,0", "--goal", "1,1"),
                            "endless.map: cannot read: a character device, not a regular file"),
    "plan with a solver nobody registered": (
        _plan("small.map", "--start", "0,0", "--goal", "1,1", "--solver", "bfs"),
        "--solver: 'bfs' is no registered solver; the grid planners registered: aistar (plugin "
        "solvers), astar (plugin solvers)"),
    "plan with a solver that is no grid planner": (
        _plan("small.map", "--start", "0,0", "--goal", "1,1", "--solver", "rescuer"),
        "--solver: 'rescuer' is a solver of plugin 'world2d' that does not plan on a given "
        "passable mask (the solver protocol, cbr_grid.planning.GridPlanner); the grid planners "
        "registered: aistar"),
    "connector that is no grid planner": (
        _run("reuse: {use: casegraph, connector: rescuer}"),
        "reuse.connector (line 1, column 36): 'rescuer' is a solver of plugin 'world2d' that "
        "does not plan on a given passable mask"),
    "replanner nobody registered": (
        _run("workload: {use: trips, replanner: astr}"),
        "workload.replanner (line 1, column 35): 'astr' is no registered solver; the grid "
        "planners registered: aistar (plugin solvers)"),
    "ROS yaml 20,000 lists deep": (_run("world: {use: map_file, path: ../../deep.yaml}"),
                                   "deep.yaml: line 1, column 107: collections nested more "
                                   "than 100 levels deep"),
    "trace file escaping the run folder": (
        _run("observers: [{use: trace, file: ../trace.jsonl}]"),
        "observers.0.file (line 1, column 32): expected a file inside the run's output folder, "
        "got '../trace.jsonl'; give an absolute path to write outside it"),
    "case base escaping the run folder": (
        _run("casebase: {use: sqlite, path: sub/../../cb.sqlite}"),
        "casebase.path (line 1, column 31): expected a file inside the run's output folder"),
    "run on a case base of another world": (
        _run_in_another_world,
        "holds the cases of another world: it records the world office 100x100, seed 1 (world "
        f"{fingerprint('test', 'office 100x100, seed 1', '').short}); this run's world is office "
        "100x100, seed 7 (world "),
    "import of another world's cases": (
        _import_from_another_world,
        "the document's cases belong to maze 64x64, seed 3 (world "
        f"{fingerprint('test', 'maze', '').short})"),
    "export over the case base itself": (
        _export_over_the_case_base,
        "cb.json: it is the case base being exported; expected another file (.yaml, .yml or "
        ".json)"),
    "payoff choice of an unknown value": (
        _run("retrieve: {use: casegraph, payoff: sometimes}"),
        "retrieve.payoff (line 1, column 36): expected one of 'always', 'learned', got "
        "'sometimes'"),
    "jump point search for a robot that cannot make every move": (
        _run("solver: jps\nkinematics: forward"),
        "solver (line 1, column 9): jump point search plans for robots that may make any move, "
        "not for kinematics 'forward'"),
    "worlds option of an unknown value": (
        _run("casebase: {use: sqlite, worlds: some}"),
        "casebase.worlds (line 1, column 33): expected one of 'one', 'any', got 'some'"),
    "map_file unknown_risk, now Nav2's allow_unknown": (
        _run(f"{ROS_WORLD}, unknown_risk: 1}}"),
        # the column of the value
        f"world.unknown_risk (line 1, column {len(ROS_WORLD + ', unknown_risk: ') + 1}): "
        "unknown key; expected one "
        "of: path, corner_cutting, allow_unknown"),
    "map_file allow_unknown given a risk": (
        _run(f"{ROS_WORLD}, allow_unknown: 0.5}}"),
        f"world.allow_unknown (line 1, column {len(ROS_WORLD + ', allow_unknown: ') + 1}): "
        "expected true or false, got 0.5"),
    "plan --unknown-risk, now Nav2's --allow-unknown": (
        _plan_depot("--start", "40,266", "--goal", "400,236", "--unknown-risk", "1"),
        "No such option: --unknown-risk (Possible options: --allow-unknown)"),
    "plan metres given as cells": (
        _plan_depot("--start", "2,2", "--goal", "20,3.5"),
        f"Invalid value for '--goal': expected a cell of two integers X,Y, got '20,3.5'; "
        f"{DEPOT_SPAN}"),
    "plan a cell off a map with a metric frame": (
        _plan_depot("--start", "40,266", "--goal", "400,2360"),
        f"goal (400, 2360) is outside the 604x307 grid (x in 0..603, y in 0..306); "
        f"{DEPOT_SPAN}"),
    "plan metres off the map": (
        _plan_depot("--frame", "map", "--start", "2,2", "--goal", "40,3.5"),
        "--goal (40, 3.5) m [cell 800, 236] is outside the 604x307 grid, which covers x 0 to "
        "30.2 m and y 0 to 15.35 m"),
    "plan metres on an obstacle": (
        _plan_depot("--frame", "map", "--start", "7.525,11.575", "--goal", "20,3.5"),
        "--start (7.525, 11.575) m [cell 150, 75] is on an obstacle"),
    "plan metres within the robot radius": (
        _plan_depot("--frame", "map", "--start", "2,2", "--goal", "20,3.5",
                    "--robot-radius", "0.6"),
        "--goal (20, 3.5) m [cell 400, 236] is within the robot radius (0.6 m) of an "
        "obstacle"),
    "plan path written over a secret text file": (
        _plan_depot("--start", "40,266", "--goal", "400,236", "--path-out", "secret.txt"),
        "a path file is CSV or GeoJSON; expected the extension .csv, .geojson, .json, got "
        "'.txt'"),
    "plan path of scenarios": (
        _plan("small.map", "--scen", "obstacle.scen", "--path-out", "path.csv"),
        "--path-out writes one path, not the scenarios of --scen"),
    "plan frame not among the choices": (
        _cbr("plan", "small.map", "--frame", "metres"),
        "--frame: 'metres' is not one of cell, map"),
    "sim run robot not among the choices": (
        _cbr("sim", "run", "generated:office:1", "--start", "1,1", "--target", "2,2",
             "--robot", "nosuch"),
        "--robot: 'nosuch' is not one of pioneer2dx, ros2005"),
    "sim batch rescue not among the choices": (
        _cbr("sim", "batch", "generated:office:1", "--rescue", "sometimes"),
        "--rescue: 'sometimes' is not one of off, blocked, stuck"),
    "experiment size not among the choices": (
        _cbr("experiment", "cbr-share", "--size", "huge"),
        "--size: 'huge' is not one of ci, full"),
    "reference not among the choices": (
        _cbr("reference", "everything"), "WHAT: 'everything' is not one of config, hooks, cli"),
}
if importlib.util.find_spec("psycopg") is not None:
    CASES |= {
        "DSN with a password typed as sslmode": (
            _run("casebase: {use: postgres, dsn: 'host=/a/b sslmode=TOPSECRET password=hunter2'}"),
            "cannot connect to schema cbrcore on the server of casebase dsn with password, host, "
            "sslmode (values not shown): connection is bad: invalid sslmode value: \"***\""),
        "DSN of the wrong type": (
            _run("casebase: {use: postgres, dsn: {TOPSECRET: hunter2}}"),
            "casebase.dsn (line 1, column 32): expected a string (the value given is not shown)"),
        "DSN that is not one": (
            _run("casebase: {use: postgres, dsn: 'postgresql://u:hunter2@db/x?TOPSECRET'}"),
            "casebase dsn: not a PostgreSQL connection string"),
    }
CASES |= {
    "route graph node without an id": (
        _route([_node(None, 2, 2), *ROUTE[1:]]),
        "features[0] (a node): required property 'id' is missing"),
    "route graph edge naming an unknown node": (
        _route([*ROUTE, _edge(7, 1, 9)]), "features[4] (edge 7): endid 9 names no node"),
    "route graph node outside the map": (
        _route([ROUTE[0], _node(1, 40, 2), *ROUTE[2:]]),
        "features[1] (node 1) at (40, 2) m [cell 800, 266] lies outside the map (x 0 to 30.2 m "
        "and y 0 to 15.35 m)"),
    "route graph node ids twice": (
        _route([*ROUTE, _node(1, 10, 2)]),
        "features[4] (node 1): node id 1 is also that of features[1] (node 1)"),
    "route graph edge twice": (
        _route([*ROUTE, _edge(5, 0, 1)]),
        "features[4] (edge 5): repeats features[2] (edge 5), from node 0 to node 1"),
    "route graph coordinates not numbers": (
        _route([_node(0, "2", 2), *ROUTE[1:]]),
        "features[0] (node 0): coordinates: expected [x, y] in metres (finite numbers), got "
        "['2', 2]"),
    "route graph 20,000 lists deep": (
        _route('{"type": "FeatureCollection", "features": ' + "[" * 20_000 + "]" * 20_000 + "}"),
        "graph.geojson: line 1, column 142: collections nested more than 100 levels deep"),
    "route graph of too many values": (
        _route(ROUTE * 50, environ={"CBR_MAX_DOCUMENT_NODES": "1000"}),
        "graph.geojson: the document holds more than 1000 values"),
    "route graph edge through a wall": (
        _route([ROUTE[0], _node(1, 12, 6), *ROUTE[2:]]),
        "features[2] (edge 5) from node 0 to node 1 crosses an obstacle at (7.425, 4.175) m "
        "[cell 148, 223]"),
    "route graph without a map": (
        _route(ROUTE, "--format", "nav2-route"),
        "the nav2-route format needs the world the cases belong to (a grid map with a metric "
        "frame); name it with --world or with a --config whose world slot names it"),
    "route graph on a map without a frame": (
        _route(ROUTE, "--world", "{use: map_file, path: small.map}"),
        "a Nav2 route graph is in metres, and the 3x2 map has no metric frame"),
    "a secret as a route graph": (
        _route(ROUTE, "--world", DEPOT_WORLD, "--format", "nav2-route", document="secret.txt"),
        "secret.txt: not valid JSON: Expecting value: line 1 column 1"),
    "route graph export without a map": (
        _route_export_without_a_map,
        "the nav2-route format needs the world the cases belong to"),
}


@pytest.mark.parametrize(("case", "message"), CASES.values(), ids=list(CASES))
def test_a_bad_input_is_one_error_naming_the_place_without_its_content(
        invoke_cbr: Cli, tmp_path: Path, case: Case, message: str) -> None:
    (tmp_path / "a" / "b").mkdir(parents=True)
    for name in ("secret.txt", "secret.map", "secret.grid", "secret.pgm", "secret.npy"):
        (tmp_path / name).write_text(SECRET, encoding="utf-8")
    # a YAML mapping whose second key is the secret
    (tmp_path / "secret.yaml").write_text("resolution: 0.05\nTOPSECRET password: hunter2\n",
                                          encoding="utf-8")
    (tmp_path / "ros.yaml").write_text(ROS_YAML, encoding="utf-8")
    np.save(tmp_path / "complex.npy", np.zeros((2, 2)) + 0.5j)
    (tmp_path / "small.map").write_text(SMALL_MAP, encoding="ascii")
    (tmp_path / "obstacle.scen").write_text(_scen("0 0 1 1 1.41421356", "2 0 0 0 2"),
                                            encoding="ascii")
    (tmp_path / "huge.scen").write_text(_scen("0 0 1 1 1e400"), encoding="ascii")
    (tmp_path / "endless.map").symlink_to("/dev/zero")
    (tmp_path / "deep.yaml").write_text("image: " + "[" * 20_000 + "]" * 20_000 + "\n",
                                        encoding="ascii")

    result = case(tmp_path, invoke_cbr)

    assert result.exit_code == 2, result
    assert "Traceback" not in result.stderr
    assert MARKER not in result.stdout + result.stderr
    assert "hunter2" not in result.stdout + result.stderr
    assert message in result.stderr
    assert "Value error" not in result.stderr
    assert not (tmp_path / "trace.jsonl").exists() and not (tmp_path / "cb.sqlite").exists()


def test_an_absolute_output_path_may_leave_the_run_folder(invoke_cbr: Cli, tmp_path: Path) -> None:
    """Writing elsewhere is allowed when said explicitly, by an absolute path."""
    (tmp_path / "a" / "b").mkdir(parents=True)
    trace = tmp_path / "trace.jsonl"
    config = _config(tmp_path / "a" / "b", f"observers: [{{use: trace, file: {trace}}}]")

    result = invoke_cbr("validate", str(config))

    assert result.exit_code == 0, result


@pytest.mark.parametrize("args", [
    # a YAML alias copies the DSN under a key whose error quotes its value
    ("validate", "{tmp}/alias.yaml"),
    ("experiment", "cbr-share", "--scheduler", "tcp://robot:hunter2@127.0.0.1:1"),
    ("validate", str(HYBRID), "--set", "seed=host=db user=robot password='hunter2 x'"),
], ids=["dsn alias under seed", "scheduler address", "conninfo under seed"])
def test_no_message_shows_a_password(tmp_path: Path, invoke_cbr: Cli, args: tuple[str, ...]
                                     ) -> None:
    (tmp_path / "alias.yaml").write_text(
        "casebase: {use: postgres, dsn: &x 'postgresql://robot:hunter2@db/cases'}\nseed: *x\n",
        encoding="utf-8")
    result = invoke_cbr(*(arg.format(tmp=tmp_path) for arg in args))
    assert result.exit_code == 2
    assert "hunter2" not in result.stdout + result.stderr
    assert "***" in result.stderr


@settings(max_examples=200, deadline=None)
@given(st.from_regex(r"[a-z]{1,8}", fullmatch=True), st.from_regex(r"[!-~]{1,12}", fullmatch=True)
       .filter(lambda p: not set(p) & set("@/'\" ")))
def test_an_address_keeps_its_user_and_host_and_loses_its_password(user: str,
                                                                   password: str) -> None:
    from cbrcore.errors import without_credentials

    shown = without_credentials(f"got 'postgresql://{user}:{password}@db:5432/cases'")
    assert shown == f"got 'postgresql://{user}:***@db:5432/cases'"


def test_a_trace_never_appends_to_a_file_that_is_not_a_trace(invoke_cbr: Cli,
                                                              tmp_path: Path) -> None:
    """A trace named like the run's own case base is refused before the run starts, and the case
    base is left as it was; an earlier trace is appended to."""
    (tmp_path / "a" / "b").mkdir(parents=True)
    casebase = tmp_path / "cb.sqlite"
    with SQLiteStore(casebase) as store, store.transaction():
        store.add(StoredCase({"a": 1}, {"b": 2}))
    before = casebase.read_bytes()
    config = _config(tmp_path / "a" / "b", f"observers: [{{use: trace, file: {casebase}}}]")

    result = invoke_cbr("run", str(config), "--out", str(tmp_path / "out"),
                     "--set", f"casebase.path={casebase}")

    assert result.exit_code == 2, result
    assert f"trace file: {casebase} exists and is not a trace" in result.stderr
    assert casebase.read_bytes() == before
    trace = tmp_path / "earlier.jsonl"
    trace.write_text('{"step": 0}\n', encoding="utf-8")
    config = _config(tmp_path / "a" / "b", f"observers: [{{use: trace, file: {trace}}}]")
    assert invoke_cbr("validate", str(config)).exit_code == 0
