"""Warming up in two processes on an empty kernel cache: a forked helper takes components from
the front of the list, the engine from the back, and the engine then warms the helper's itself."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

import cbrcore.builtins
import cbrcore.engine
import toy_domain
from cbrcore import Engine, hookimpl
from cbrcore.context import Context
from cbrcore.errors import PhaseError
from cbrcore.kernel_cache import holds_no_kernels
from cbrcore.plugins import Plugins, load_plugins
from cbrcore.registry import Registry
from cbrcore.warm_split import _Ends, can_fork, warm_in_turn
from repo_paths import ROOT


@pytest.fixture
def single_threaded() -> None:
    """Skip unless a helper may be forked now: asked at run time, since a test run earlier in
    the same process may leave threads behind (a Dask cluster's, for one)."""
    if not can_fork():
        pytest.skip("forks a helper on Linux, in a single-threaded process")


forking = pytest.mark.usefixtures("single_threaded")


def test_the_forking_tests_run_in_a_fresh_process_where_this_one_has_threads() -> None:
    """Where an earlier test left threads behind, the forking tests skip here: run this module
    again in a fresh, single-threaded interpreter, so that they run in every test session."""
    if can_fork():
        pytest.skip("the forking tests run in this process")
    found = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-n0", "-p", "no:cacheprovider", __file__,
         "-k", "not in_a_fresh_process"],
        capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert found.returncode == 0, found.stdout[-3000:]
    assert "skipped" not in found.stdout, found.stdout[-3000:]


def _records(path: Path) -> list[tuple[int, str]]:
    """(pid, job) lines written so far."""
    if not path.exists():
        return []
    return [(int(pid), job) for pid, job in
            (line.split(" ", 1) for line in path.read_text().splitlines())]


def _recording(path: Path, name: str, *, wait_for_helper: bool = False,
               fail_in_helper: bool = False) -> Callable[[], None]:
    """A job that appends (pid, name) to ``path``; in the engine's process it first waits until
    the helper has recorded a job, so that the helper certainly takes one."""
    engine = os.getpid()

    def job() -> None:
        if os.getpid() != engine and fail_in_helper:
            raise RuntimeError("the helper's compiler is missing")
        if os.getpid() == engine and wait_for_helper:
            deadline = time.monotonic() + 60
            while (not any(pid != engine for pid, _ in _records(path))
                   and time.monotonic() < deadline):
                time.sleep(0.01)
        with path.open("a") as out:
            out.write(f"{os.getpid()} {name}\n")

    return job


def test_the_ends_hand_out_every_job_once() -> None:
    ends = _Ends(5)
    taken = [ends.take(front=True), ends.take(front=False), ends.take(front=False),
             ends.take(front=True), ends.take(front=False), ends.take(front=True)]
    assert taken == [0, 4, 3, 1, 2, None]
    assert ends.front() == 2
    ends.close()


def test_without_a_helper_the_jobs_run_in_turn(tmp_path: Path) -> None:
    log = tmp_path / "log"
    warm_in_turn([_recording(log, name) for name in "abc"], helper=False)
    assert _records(log) == [(os.getpid(), name) for name in "abc"]


@forking
def test_a_helper_runs_jobs_from_the_front_and_the_engine_runs_every_job(
        tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "log"
    names = "abcd"
    jobs = [lambda: print("said once")]  # the helper's first job: it says nothing
    jobs += [_recording(log, name, wait_for_helper=True) for name in names]
    warm_in_turn(jobs, helper=True)
    records = _records(log)
    mine = [name for pid, name in records if pid == os.getpid()]
    helper = [name for pid, name in records if pid != os.getpid()]
    assert sorted(mine) == list(names)
    # the helper took a first part of the list, which the engine ran again after it
    assert helper and helper == list(names[:len(helper)])
    assert mine[-len(helper):] == helper
    assert capfd.readouterr().out == "said once\n"  # the helper writes nothing


@forking
def test_a_failing_helper_leaves_its_jobs_to_the_engine(tmp_path: Path) -> None:
    log = tmp_path / "log"
    jobs = [_recording(log, name, fail_in_helper=True) for name in "abc"]
    warm_in_turn(jobs, helper=True)
    assert sorted(name for pid, name in _records(log) if pid == os.getpid()) == list("abc")
    assert all(pid == os.getpid() for pid, _ in _records(log))


@forking
def test_a_job_failing_in_the_engine_stops_the_helper_and_is_raised(tmp_path: Path) -> None:
    log = tmp_path / "log"

    def broken() -> None:
        raise RuntimeError("no compiler")

    with pytest.raises(RuntimeError, match="no compiler"):
        warm_in_turn([_recording(log, "a"), broken], helper=True)
    assert all(name == "a" for _, name in _records(log))


class NotedRetainer:
    """Records where and how often it warms up, in the file ``NotedRetainer.log``."""

    log: Path

    def __init__(self, options: object, ctx: Context) -> None:
        self.job = _recording(NotedRetainer.log, str(id(self)), wait_for_helper=True)

    @hookimpl
    def cbr_warm(self, ctx: Context) -> None:
        self.job()

    @hookimpl
    def cbr_retain(self) -> None:
        return None


class BrokenRetainer(NotedRetainer):
    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_warm(self, ctx: Context) -> None:
        raise RuntimeError("the compiler is missing")


class NotingPlugin:
    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("retainer", "noted", NotedRetainer)
        registry.add("retainer", "broken", BrokenRetainer)


def _plugins() -> Plugins:
    return load_plugins(extra=[("toy", toy_domain), ("core", cbrcore.builtins),
                               ("noting", NotingPlugin())], entry_points=False, environ={})


@forking
def test_an_engine_on_an_empty_cache_warms_each_component_itself_once(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cbrcore.engine, "holds_no_kernels", lambda: True)
    monkeypatch.setattr(NotedRetainer, "log", tmp_path / "log", raising=False)
    with Engine.from_dict({"retain": ["noted", "noted", "noted"]}, plugins=_plugins()) as engine:
        built = {str(id(engine.components[f"retain.{i}"])) for i in range(3)}
    records = _records(tmp_path / "log")
    mine = [name for pid, name in records if pid == os.getpid()]
    assert sorted(mine) == sorted(built)
    assert any(pid != os.getpid() for pid, _ in records)


@pytest.mark.parametrize("empty_cache", [False, True])
def test_a_warm_up_failing_with_a_helper_or_without_names_the_plugin(
        empty_cache: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cbrcore.engine, "holds_no_kernels", lambda: empty_cache)
    with pytest.raises(PhaseError, match=r"plugin 'broken \(noting\)' failed in phase 'warm': "
                                         r"RuntimeError: the compiler is missing"):
        Engine.from_dict({"retain": ["broken", "broken"]}, plugins=_plugins())


def test_a_cache_without_an_index_holds_no_kernels(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("CBR_CACHE_DIR", str(tmp_path / "cache"))
    assert holds_no_kernels()  # no folder yet
    kernels = tmp_path / "cache" / "numba" / "cbr_grid"
    kernels.mkdir(parents=True)
    (kernels / "search_base.push-67.py311.1.nbc").write_bytes(b"")
    assert holds_no_kernels()  # data without an index is not a kernel numba would load
    (kernels / "search_base.push-67.py311.nbi").write_bytes(b"")
    assert not holds_no_kernels()
