"""Sharing a value among tasks, task priorities, and the LocalCluster's configuration
(:mod:`cbr_experiments.tasks`); running tasks in order and on every runner is tested with the
sweeps in test_dask_sweeps.py."""

from __future__ import annotations

import importlib.util
import math
import os
import warnings
from typing import Any

import pytest

from cbr_experiments.tasks import DaskTasks, LocalTasks, TaskRunner, open_tasks

if importlib.util.find_spec("distributed") is None:
    pytest.skip("distributed is not installed", allow_module_level=True)

import dask.config


def test_in_this_process_a_shared_value_is_the_value_itself() -> None:
    value = {"graph": [1, 2, 3]}
    assert LocalTasks().share(value) is value


@pytest.mark.parametrize("value", [[3, 4, 5], {"a": 1, "b": 2, "c": 9}],
                         ids=["list", "dict"])
def test_a_shared_value_reaches_each_task_whole(cluster: TaskRunner, value: Any) -> None:
    # a list or a dict is what Dask would scatter element by element unless told otherwise
    shared = cluster.share(value)
    expected = sum(value) if isinstance(value, list) else len(value)
    function = sum if isinstance(value, list) else len
    assert list(cluster.map(function, [shared] * 5)) == [expected] * 5


def test_a_shared_value_is_held_by_every_worker_before_any_task(cluster: TaskRunner) -> None:
    assert isinstance(cluster, DaskTasks)
    shared: Any = cluster.share(list(range(1000)))
    workers = set(cluster.client.scheduler_info()["workers"])
    assert set(cluster.client.who_has([shared])[shared.key]) == workers


def test_a_cluster_is_given_each_task_s_priority(cluster: TaskRunner,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    # Dask starts the waiting task of highest priority first: what matters here is that each
    # task is submitted with its item's
    assert isinstance(cluster, DaskTasks)
    submitted: list[tuple[Any, Any]] = []
    submit = cluster.client.submit

    def recording(function: Any, item: Any, **options: Any) -> Any:
        submitted.append((item, options.get("priority")))
        return submit(function, item, **options)

    monkeypatch.setattr(cluster.client, "submit", recording)
    items = [4, 1, 7, 2]
    assert list(cluster.map(math.factorial, items, priority=lambda n: 10 * n)) == [
        24, 1, 5040, 2]
    assert submitted == [(4, 40), (1, 10), (7, 70), (2, 20)]
    submitted.clear()
    assert list(cluster.map(math.factorial, items)) == [24, 1, 5040, 2]
    assert submitted == [(4, 0), (1, 0), (7, 0), (2, 0)]


@pytest.mark.parametrize("processes", [1, 2])
def test_priorities_change_no_result_nor_its_place(processes: int) -> None:
    items = [5, 3, 0, 6, 4]
    found = list(LocalTasks().map(math.factorial, items, processes=processes,
                                  priority=lambda n: float(n)))
    assert found == [120, 6, 1, 720, 24]


def test_a_local_cluster_s_workers_allocate_and_run_as_a_serial_run(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
    with open_tasks("local", workers=1) as runner:
        assert isinstance(runner, DaskTasks)
        client = runner.client
        assert set(client.run(os.getenv, "MALLOC_TRIM_THRESHOLD_").values()) == {None}
        assert set(client.run(dask.config.get, "distributed.worker.profile.enabled"
                              ).values()) == {False}
        assert set(client.run(dask.config.get, "distributed.admin.tick.interval"
                              ).values()) == {"1s"}
    # the configuration was the cluster's only
    assert dask.config.get("distributed.worker.profile.enabled") is True


def test_a_variable_the_user_set_reaches_the_workers(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "131072")
    with open_tasks("local", workers=1) as runner:
        assert isinstance(runner, DaskTasks)
        found = runner.client.run(os.getenv, "MALLOC_TRIM_THRESHOLD_")
        assert set(found.values()) == {"131072"}


def test_two_local_clusters_at_once_start_without_a_warning(cluster: TaskRunner) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with open_tasks("local", workers=1) as second:
            assert list(second.map(abs, [-1, 2])) == [1, 2]
    assert list(cluster.map(abs, [-3])) == [3]
