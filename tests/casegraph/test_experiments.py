"""The case graph reproductions (``cbr_casegraph.experiments``) at size ci, through the CLI.

Each test runs one experiment as ``cbr experiment NAME --size ci`` and checks that it wrote its
files and that its numbers are possible ones; the numbers themselves are discussed in
docs/reproductions.md.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cbr_casegraph.build import grow
from cbr_casegraph.experiments.common import make_map
from cbr_casegraph.experiments.deviation import deviations
from cbr_casegraph.graph import CaseGraph
from cbr_experiments.experiment import run_experiment
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(autouse=True)
def _installed(cbr_plugins: Callable[..., Plugins]) -> None:
    cbr_plugins(entry_points=True)


def run(invoke_cbr: Callable[..., CliResult], out: Path, name: str, figure: str) -> dict[str, Any]:
    """Run ``name`` at size ci into ``out``; its results, once its files are checked."""
    result = invoke_cbr("experiment", name, "--size", "ci", "--out", str(out))
    assert result.exit_code == 0, result.stderr
    for file in ("results.json", "results.md", "manifest.json"):
        assert (out / file).stat().st_size > 0
    assert (out / f"{figure}.png").read_bytes()[:8] == PNG
    assert "paper" in (out / "results.md").read_text(encoding="utf-8")
    return json.loads((out / "results.json").read_text(encoding="utf-8"))


def test_share_grows_with_coverage_and_stays_a_share(invoke_cbr: Callable[..., CliResult],
                                                     tmp_path: Path) -> None:
    results = run(invoke_cbr, tmp_path, "cbr-share", "cbr_share")
    rows = results["rows"]
    assert [row["coverage_percent"] for row in rows] == [5, 10, 15]
    for row in rows:
        assert 0 <= row["share"] <= 1
        assert sum(row["outcomes"].values()) == row["queries"]
        assert row["share"] == row["outcomes"].get("cbr", 0) / row["queries"]
    vertices = [row["vertices"] for row in rows]
    assert vertices == sorted(vertices)
    assert rows[-1]["share"] > 0


class ByPriority:
    """Runs the tasks one by one, those of highest priority first (ties in reverse), and gives
    each a copy of a shared value: as a cluster may, and as no serial run does."""

    description = "by priority"

    def __init__(self) -> None:
        self.priorities: list[float] = []

    def map(self, function: Callable[[Any], Any], items: Iterable[Any], *,
            progress: Callable[[int, int], None] | None = None, processes: int = 1,
            priority: Callable[[Any], float] | None = None) -> Iterator[Any]:
        work = list(items)
        self.priorities = [0.0 if priority is None else priority(item) for item in work]
        order = sorted(range(len(work)), key=lambda k: (self.priorities[k], k), reverse=True)
        done = {k: function(work[k]) for k in order}
        return iter([done[k] for k in range(len(work))])

    def share(self, value: Any) -> Any:
        return copy.deepcopy(value)


def test_share_is_the_same_whatever_order_its_chunks_run_in(
        cbr_plugins: Callable[..., Plugins], tmp_path: Path) -> None:
    plugins = cbr_plugins(entry_points=True)
    run_experiment("cbr-share", plugins, size="ci", out_dir=tmp_path / "serial")
    runner = ByPriority()
    run_experiment("cbr-share", plugins, size="ci", out_dir=tmp_path / "reordered",
                   tasks=runner)
    serial, reordered = (json.loads((tmp_path / name / "results.json").read_text("utf-8"))
                         for name in ("serial", "reordered"))
    for row in serial["rows"] + reordered["rows"]:
        del row["median_plan_ms"]  # a measured time: no two runs share it
    assert reordered == serial
    # ci: one chunk per coverage, larger coverages (larger graphs, slower queries) first
    assert runner.priorities == sorted(runner.priorities) and len(set(runner.priorities)) == 3


def test_deviation_table_is_relative_to_the_best(invoke_cbr: Callable[..., CliResult],
                                                 tmp_path: Path) -> None:
    rows = run(invoke_cbr, tmp_path, "deviation-table", "deviation_cost")["rows"]
    assert len(rows) == 2
    for row in rows:
        assert set(row["deviation"]) == {"CBR", "Dijkstra", "A*", "Ai*"}
        for by_parameter in row["deviation"].values():
            assert all(value >= 0 for value in by_parameter.values())
        # Dijkstra is optimal in cost: it is always the best or tied with it
        assert row["deviation"]["Dijkstra"]["cost"] == 0
        assert 0 <= row["cbr_share"] <= 1


def test_time_vs_map_size_times_are_positive(invoke_cbr: Callable[..., CliResult],
                                             tmp_path: Path) -> None:
    rows = run(invoke_cbr, tmp_path, "time-vs-map-size", "time_vs_map_size")["rows"]
    assert [row["size"] for row in rows] == [50, 100, 200]
    for row in rows:
        for method in ("dijkstra", "astar", "aistar"):
            assert row[f"{method}_ms"] > 0
        assert any(ms is not None for ms in row["cbr_ms"].values())
        assert all(ms > 0 for ms in row["cbr_ms"].values() if ms is not None)
    # a 3000-vertex graph does not fit a 50x50 map, and fits a 200x200 one
    assert rows[0]["cbr_ms"]["3000"] is None
    assert rows[-1]["cbr_ms"]["3000"] > 0


def test_time_vs_vertices_plans_every_task_both_ways(invoke_cbr: Callable[..., CliResult],
                                                     tmp_path: Path) -> None:
    rows = run(invoke_cbr, tmp_path, "time-vs-vertices", "time_vs_vertices")["rows"]
    assert len(rows) == 3
    for row in rows:
        assert row["tasks"] > 0
        assert row["full_ms"] > 0 and row["selective_ms"] > 0
        assert row["full_planned"] == row["tasks"]
        assert 0 <= row["selective_planned"] <= row["tasks"]


def test_grow_reaches_the_vertex_count_and_counts_its_paths() -> None:
    grid = make_map(40, 3)
    graph = CaseGraph(grid)
    rng = np.random.default_rng(3)
    paths = grow(graph, 150, rng)
    assert graph.vertex_count >= 150
    assert paths > 0
    assert grow(graph, 150, rng) == 0


def test_a_best_of_zero_turns_counts_each_turn_as_100_percent() -> None:
    assert deviations({"a": 0.0, "b": 2.0}) == {"a": 0.0, "b": 200.0}
    assert deviations({"a": 4.0, "b": 5.0, "c": 4.0 * (1 + 1e-12)}) == {
        "a": 0.0, "b": 25.0, "c": 0.0}
