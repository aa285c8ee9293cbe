"""The case graph family in the engine: configs/hybrid_grid.yaml at a reduced size.

A run stores its graph in casebase.sqlite and the next run into the same folder starts from it;
a run killed mid-way leaves a case base that checks out and loads as a consistent graph; every
component of the family is called through the engine.
"""

from __future__ import annotations

import csv
import functools
import gc
import os
import signal
import subprocess
import sys
import time
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from numba.core.registry import CPUDispatcher

from cbr_casegraph import components
from cbr_casegraph.graph import SEGMENT, CaseGraph
from cbr_casegraph.state import graph_of
from cbr_grid import grid as grid_module
from cbr_grid.grid import Grid
from cbr_grid.query import GridQuery
from cbr_pathquality.reviser import QualityTest
from cbr_stores.sqlite import SQLiteStore
from cbrcore.engine import Engine
from cbrcore.model import Outcome
from cbrcore.run import run_workload
from repo_paths import ROOT

from .test_casegraph import check_consistent, edge_set

CONFIG = ROOT / "configs" / "hybrid_grid.yaml"
# a smaller office keeps each run to a second or two; the trips stay long enough for the case
# graph (delta 8) to be worth using
SMALL = ["world.width=60", "world.height=60", "workload.count=60"]


def read_rows(out_dir: Path) -> list[dict[str, str]]:
    with (out_dir / "results.csv").open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def run(out_dir: Path, overrides: Sequence[str] = SMALL) -> tuple[dict[str, Any], int]:
    """One run into ``out_dir``; its summary and how many segments its graph started with."""
    with Engine.from_yaml(CONFIG, overrides=overrides, out_dir=out_dir) as engine:
        start = graph_of(engine.ctx).edge_count
        return run_workload(engine, out_dir), start


def the_map(overrides: Sequence[str] = SMALL) -> Grid:
    """The configured map as a run starts with it (before the robot learns any risk)."""
    with Engine.from_yaml(CONFIG, overrides=[*overrides, "casebase=memory"]) as engine:
        return engine.world


def test_a_second_run_starts_from_the_stored_graph(tmp_path: Path) -> None:
    first, started = run(tmp_path)
    assert started == 0
    path = tmp_path / "casebase.sqlite"
    with SQLiteStore(path, create=False) as store:
        stored = store.count(SEGMENT)
        graph = CaseGraph.load(the_map(), store)
    assert stored > 0
    check_consistent(graph)
    rows = read_rows(tmp_path)
    # the first trip of the first run found an empty graph
    assert rows[0]["retrieved"] == "0" and rows[0]["source"].startswith("solver")

    with Engine.from_yaml(CONFIG, overrides=SMALL, out_dir=tmp_path) as engine:
        loaded = graph_of(engine.ctx)
        assert loaded.edge_count == stored
        assert edge_set(loaded) == edge_set(graph)
        # the graph follows the learned map without writing at a query: only learn steps write
        revision = engine.casebase.revision
        problem = next(iter(engine.workload.queries(engine.ctx)))
        engine.solve(problem)
        assert engine.casebase.revision == revision and engine.ctx.mirror.reloads == 0
        assert graph_of(engine.ctx).grid is engine.ctx.world
    with Engine.from_yaml(CONFIG, overrides=SMALL, out_dir=tmp_path) as engine:
        second = run_workload(engine, tmp_path)
    # the second run's rows follow the first's
    rows = read_rows(tmp_path)[first["queries"]:]
    # the same first trip (same seed) now retrieves stored segments
    assert int(rows[0]["retrieved"]) > 0
    assert first["queries"] == second["queries"] == 60
    assert second["from_casebase"] > 0


def test_a_second_run_answers_at_least_as_many_trips_from_the_case_base(tmp_path: Path
                                                                          ) -> None:
    first, _ = run(tmp_path)
    second, started = run(tmp_path)
    assert started > 0
    assert second["cbr_share"] >= first["cbr_share"]


def counting(calls: Counter[str], name: str, method: Callable[..., Any]) -> Callable[..., Any]:
    # functools.wraps copies the hook marker too, so the engine registers the wrapper as the hook
    @functools.wraps(method)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        calls[name] += 1
        return method(*args, **kwargs)

    return wrapper


HOOKS = [
    (components.CaseGraphRetriever, "cbr_retrieve"),
    (components.CaseGraphReuser, "cbr_reuse"),
    (QualityTest, "cbr_revise"),
    (components.CaseGraphRetainer, "cbr_retain"),
    (components.RedundantVertices, "cbr_forget"),
    (components.RiskySegments, "cbr_forget"),
    (components.VertexLimit, "cbr_forget"),
]


@pytest.mark.parametrize("connector", ["dijkstra", "astar"])
def test_every_hook_of_the_family_is_called_by_the_engine(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, connector: str) -> None:
    calls: Counter[str] = Counter()
    for cls, hook in HOOKS:
        monkeypatch.setattr(cls, hook, counting(calls, cls.__name__, getattr(cls, hook)))
    merged: list[int] = []
    removed: list[int] = []
    merge, remove = CaseGraph.merge_redundant, CaseGraph.remove

    def merge_counted(self: CaseGraph) -> int:
        merged.append(merge(self))
        return merged[-1]

    def remove_counted(self: CaseGraph, edges: Any) -> None:
        edges = list(edges)
        removed.append(len(edges))
        remove(self, edges)

    monkeypatch.setattr(CaseGraph, "merge_redundant", merge_counted)
    monkeypatch.setattr(CaseGraph, "remove", remove_counted)
    # low limits so that the forgetters have work: 12 vertices on the 60x60 map, and a risk
    # that the cells the robot bumped into reach
    limit = 12 / 3600
    overrides = [*SMALL, "workload.count=40", f"reuse.connector={connector}",
                 "forget=[redundant_vertices, {use: risky_segments, max_risk: 0.01}, "
                 f"{{use: vertex_limit, max_coverage: {limit}}}]"]
    with Engine.from_yaml(CONFIG, overrides=overrides, out_dir=tmp_path) as engine:
        summary = run_workload(engine, tmp_path)
        graph = graph_of(engine.ctx)
        check_consistent(graph)
        assert graph.vertex_count <= 12
        edges = graph.edge_ids()
        assert (graph.risks(edges) < 0.01).all() and np.isfinite(graph.costs(edges)).all()
    queries = summary["queries"]
    assert calls["CaseGraphRetriever"] == queries
    for name in ("RedundantVertices", "RiskySegments", "VertexLimit", "CaseGraphRetainer"):
        assert calls[name] == queries, name
    # reuse and revision only when retrieval (then reuse) gave something
    assert 0 < calls["QualityTest"] <= calls["CaseGraphReuser"] < queries
    assert summary["from_casebase"] > 0
    assert sum(merged) > 0 and sum(removed) > 0
    with SQLiteStore(tmp_path / "casebase.sqlite", create=False) as store:
        assert store.check() == []
        assert edge_set(CaseGraph.load(the_map(), store)) == edge_set(graph)


def test_a_killed_run_leaves_a_readable_case_base(tmp_path: Path) -> None:
    out = tmp_path / "run"
    command = [sys.executable, "-m", "cbrcore", "run", str(CONFIG), "--out", str(out),
               *(arg for value in [*SMALL, "workload.count=5000"] for arg in ("--set", value))]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        done = 0
        while time.monotonic() < deadline and process.poll() is None:
            results = out / "results.csv"
            if (out / "casebase.sqlite").exists() and results.exists():
                done = len(results.read_text(encoding="utf-8").splitlines()) - 1
                if done >= 40:
                    break
            time.sleep(0.05)
        assert process.poll() is None, process.stderr.read() if process.stderr else ""
        assert done >= 40
    finally:
        if process.poll() is None:
            os.kill(process.pid, signal.SIGKILL)
        process.wait()
        if process.stderr:
            process.stderr.close()
    assert process.returncode == -signal.SIGKILL
    check = subprocess.run([sys.executable, "-m", "cbrcore", "casebase", "check",
                            str(out / "casebase.sqlite")], capture_output=True, text=True,
                           check=False)
    assert check.returncode == 0, check.stdout + check.stderr
    with SQLiteStore(out / "casebase.sqlite", create=False) as store:
        assert store.count(SEGMENT) > 0
        graph = CaseGraph.load(the_map(), store)
    check_consistent(graph)


def compiled_signatures() -> set[tuple[str, str]]:
    """Every signature the project's compiled kernels hold in this process."""
    return {(d.py_func.__qualname__, str(s)) for d in gc.get_objects()
            if isinstance(d, CPUDispatcher) and d.py_func.__module__.startswith("cbr")
            for s in d.signatures}


def test_a_world_holding_its_factor_once_compiles_nothing_during_its_trips(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """On a large map of free cells and obstacles the grid holds the cost factor once, a layout
    the kernels compile apart; the warm-up compiles them for it, before the first query."""
    # between the warm-up grid of a small world (24 x 24) and this one
    monkeypatch.setattr(grid_module, "UNIFORM_FACTOR_CELLS", 1000)
    blocked = np.zeros((40, 40), dtype=bool)
    blocked[5:35, 20] = blocked[20, 5:18] = True
    world = Grid.from_array(blocked)
    assert world.factor.strides == (0, 0)
    config = {"casebase": "memory", "retrieve": {"use": "casegraph", "delta": 6},
              "reuse": {"use": "casegraph"}, "solver": "astar", "retain": ["casegraph"],
              "revise": {"use": "path_quality", "ideal": "landmarks", "max_ratio": 1.5}}
    sources = []
    with Engine.from_dict(config, world=world) as engine:
        before = compiled_signatures()
        for trip in range(6):
            start, goal = ((1, 1), (38, 38)) if trip % 2 == 0 else ((1, 38), (38, 1))
            query = GridQuery(start, goal)
            proposal = engine.solve(query)
            sources.append(proposal.source)
            engine.learn(query, proposal, Outcome(success=True))
        assert compiled_signatures() == before
    assert "casebase" in sources  # the reuser and retainer ran on the world's layout
