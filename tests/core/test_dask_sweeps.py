"""Experiments' tasks on Dask distributed (``cbr experiment NAME --scheduler local|ADDRESS``) and
the task runners of :mod:`cbr_experiments.tasks`.

The results of a run on a cluster must be those of a serial run with the same seed; a run's
measured times (``median_plan_ms``) are the only fields that differ between any two runs.
"""

from __future__ import annotations

import importlib.util
import json
import math
import socket
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from cbr_experiments import tasks as tasks_module
from cbr_experiments.experiment import run_experiment
from cbr_experiments.tasks import DaskTasks, LocalTasks, TaskRunner, open_tasks
from cbrcore.errors import CbrError
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult
from repo_paths import ROOT

if importlib.util.find_spec("distributed") is None:
    pytest.skip("distributed is not installed", allow_module_level=True)

_SWEEP = importlib.util.spec_from_file_location(
    "experiment_sweep", ROOT / "benchmarks" / "experiment_sweep.py")
assert _SWEEP is not None and _SWEEP.loader is not None
sweep = importlib.util.module_from_spec(_SWEEP)
with pytest.MonkeyPatch.context() as _patch:
    _patch.syspath_prepend(str(Path(_SWEEP.origin).parent))  # a script has its folder on the path
    _SWEEP.loader.exec_module(sweep)
untimed = sweep.untimed
"""A results.json without its measured times, as the sweep benchmark compares them."""


@pytest.fixture(autouse=True)
def _installed(cbr_plugins: Callable[..., Plugins]) -> None:
    cbr_plugins(entry_points=True)


def results(out: Path) -> dict[str, Any]:
    return json.loads((out / "results.json").read_text(encoding="utf-8"))


def test_ci_share_on_a_local_cluster_equals_the_serial_run(
        invoke_cbr: Callable[..., CliResult], tmp_path: Path) -> None:
    serial = invoke_cbr("experiment", "cbr-share", "--out", str(tmp_path / "serial"))
    assert serial.exit_code == 0, serial.stderr
    dask = invoke_cbr("experiment", "cbr-share", "--out", str(tmp_path / "dask"),
                   "--scheduler", "local", "--workers", "2")
    assert dask.exit_code == 0, dask.stderr
    expected, found = results(tmp_path / "serial"), results(tmp_path / "dask")
    assert untimed(found) == untimed(expected)
    # the measured times are there, one per coverage, in both
    assert all(row["median_plan_ms"] > 0 for row in found["rows"])
    manifest = json.loads((tmp_path / "dask" / "manifest.json").read_text(encoding="utf-8"))
    assert manifest["tasks"] == "dask LocalCluster of 2 workers"


def test_a_running_scheduler_by_its_address(invoke_cbr: Callable[..., CliResult], tmp_path: Path,
                                            cluster: TaskRunner) -> None:
    # deviation-table measures no time: its whole results.json must be equal
    assert isinstance(cluster, DaskTasks)
    address = cluster.client.scheduler.address
    serial = invoke_cbr("experiment", "deviation-table", "--out", str(tmp_path / "serial"))
    assert serial.exit_code == 0, serial.stderr
    remote = invoke_cbr("experiment", "deviation-table", "--out", str(tmp_path / "remote"),
                     "--scheduler", address)
    assert remote.exit_code == 0, remote.stderr
    assert results(tmp_path / "remote") == results(tmp_path / "serial")
    assert (tmp_path / "remote" / "results.md").read_text(encoding="utf-8") == (
        tmp_path / "serial" / "results.md").read_text(encoding="utf-8")


@pytest.mark.parametrize("address", ["not an address", "nonsense://host:8786"])
def test_a_malformed_address_is_a_usage_error(invoke_cbr: Callable[..., CliResult],
                                              tmp_path: Path, address: str) -> None:
    result = invoke_cbr("experiment", "cbr-share", "--out", str(tmp_path), "--scheduler", address)
    assert result.exit_code == 2
    assert "--scheduler" in result.stderr and repr(address) in result.stderr
    assert "tcp://host:8786" in result.stderr
    assert "Traceback" not in result.stderr
    assert not (tmp_path / "results.json").exists()


def test_an_address_where_no_scheduler_answers(invoke_cbr: Callable[..., CliResult],
                                               tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(tasks_module, "CONNECT_SECONDS", 1)
    with socket.socket() as probe:  # a port nothing listens on: bound, never listening
        probe.bind(("127.0.0.1", 0))
        address = f"tcp://127.0.0.1:{probe.getsockname()[1]}"
        result = invoke_cbr("experiment", "cbr-share", "--out", str(tmp_path),
                         "--scheduler", address)
    assert result.exit_code == 2
    assert f"--scheduler {address!r}: no Dask scheduler answered within 1 s" in result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize("args", [["--workers", "2"], ["--scheduler", "local", "--workers", "0"],
                                  ["--scheduler", "tcp://127.0.0.1:8786", "--workers", "2"]])
def test_workers_goes_with_a_local_cluster_only(invoke_cbr: Callable[..., CliResult],
                                                tmp_path: Path, args: list[str]) -> None:
    result = invoke_cbr("experiment", "cbr-share", "--out", str(tmp_path), *args)
    assert result.exit_code == 2
    assert "--workers" in result.stderr


def test_the_progress_callback_sees_every_task(cluster: TaskRunner, tmp_path: Path,
                                               cbr_plugins: Callable[..., Plugins]) -> None:
    calls: list[tuple[int, int]] = []
    run_experiment("cbr-share", cbr_plugins(entry_points=True), size="ci", out_dir=tmp_path,
                   progress=lambda done, total: calls.append((done, total)), tasks=cluster)
    # ci: three coverages of 200 queries, one chunk of queries (one task) each
    assert calls == [(0, 3), (1, 3), (2, 3), (3, 3)]


@pytest.mark.parametrize("runner", ["serial", "processes", "dask"])
def test_map_gives_results_in_order_and_reports_each_task(runner: str,
                                                          cluster: TaskRunner) -> None:
    # large items first, so that on a pool the small ones finish before them
    items = [3000, 2500, 2000, 10, 5, 1, 0, 7]
    expected = [math.factorial(n).bit_length() for n in items]
    calls: list[tuple[int, int]] = []
    chosen = cluster if runner == "dask" else LocalTasks()
    results = chosen.map(math.factorial, items,
                         progress=lambda done, total: calls.append((done, total)),
                         processes=2 if runner == "processes" else 1)
    # the total is told on submitting, before any result is read
    assert calls == [(0, len(items))]
    found = list(results)
    assert [value.bit_length() for value in found] == expected
    assert [done for done, _ in calls] == list(range(len(items) + 1))
    assert {total for _, total in calls} == {len(items)}


@pytest.mark.parametrize("runner", ["serial", "processes", "dask"])
def test_a_failing_task_raises_its_own_error(runner: str, cluster: TaskRunner) -> None:
    chosen = cluster if runner == "dask" else LocalTasks()
    with pytest.raises(ValueError, match="factorial"):
        list(chosen.map(math.factorial, [3, -1, 4],
                        processes=2 if runner == "processes" else 1))


def test_items_are_read_when_map_is_called() -> None:
    # a generator of items is drained at once: the caller's state after the call is its own
    drawn: list[int] = []

    def items() -> Iterator[int]:
        for n in range(4):
            drawn.append(n)
            yield n

    results = LocalTasks().map(math.factorial, items())
    assert drawn == [0, 1, 2, 3]
    assert list(results) == [1, 1, 2, 6]


def test_open_tasks_without_a_scheduler_is_local() -> None:
    with open_tasks(None) as runner:
        assert isinstance(runner, LocalTasks)
    with pytest.raises(CbrError, match="--workers: 0"), open_tasks("local", workers=0):
        pass
