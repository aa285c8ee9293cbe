"""A command about to compile kernels missing from the cache says so on stderr first; a warm
cache says nothing."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

import cbrcore.builtins
import closed_loop_domain
from cbrcore import Solution, hookimpl
from cbrcore.context import Context
from cbrcore.registry import Registry
from cbrcore.testing import CliResult

KERNEL_MODULE = "notice_kernel"
KERNEL = """\
from cbr_kernels import njit


@njit
def margin(size):
    return size + 1
"""
OTHER_KERNEL = """\
from cbr_kernels import njit


@njit
def double(size):
    return 2 * size
"""
CONFIG = closed_loop_domain.LANE_CONFIG.replace("solver: margin", "solver: compiled_margin")
NOTICE = "cbr: compiling the kernels this command uses, once"


class CompiledMargin:
    """The lane's margin solver, computed by a kernel imported when the solver is built (so
    that numba decorates it, and looks for it in the cache, under the test's cache folder)."""

    def __init__(self, options: object, ctx: Context) -> None:
        sys.modules.pop(KERNEL_MODULE, None)  # a new dispatcher: the disk cache or a compile
        self.kernel = importlib.import_module(KERNEL_MODULE).margin

    @hookimpl
    def cbr_solve(self, problem: closed_loop_domain.Swerve) -> Solution:
        offset = int(self.kernel(problem["size"]))
        return Solution(offset, cost=float(offset))


class NoticePlugin:
    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("solver", "compiled_margin", CompiledMargin)


@pytest.fixture
def lane(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, cbr_plugins: Callable[..., object],
         invoke_cbr: Callable[..., CliResult]) -> Iterator[Callable[[], CliResult]]:
    """``lane()`` runs the lane with the compiled solver, its kernel cached in tmp_path/cache
    (empty at first), a progress line after every query."""
    source = tmp_path / "src"
    source.mkdir()
    (source / f"{KERNEL_MODULE}.py").write_text(KERNEL, encoding="utf-8")
    monkeypatch.syspath_prepend(str(source))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("CBR_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("CBR_PROGRESS_SECONDS", "0")
    config = tmp_path / "lane.yaml"
    config.write_text(CONFIG, encoding="utf-8")
    cbr_plugins(("lane", closed_loop_domain), ("core", cbrcore.builtins),
                ("notice", NoticePlugin()))
    runs = iter(range(100))

    def run() -> CliResult:
        return invoke_cbr("run", str(config), "--out", str(tmp_path / f"run{next(runs)}"))

    yield run
    sys.modules.pop(KERNEL_MODULE, None)


def _notices(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("cbr: compil")]


def test_a_kernel_compiled_into_an_empty_cache_is_announced_before_the_first_result(
        lane: Callable[[], CliResult], tmp_path: Path) -> None:
    done = lane()
    assert done.exit_code == 0, done.stderr
    lines = done.stderr.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith(NOTICE))
    assert f"cached in {tmp_path / 'cache' / 'numba'} for later runs" in lines[first]
    # written at once, the cache folder being missing, and not again at the compile
    assert first == 0, done.stderr
    assert [line for line in lines if line.startswith(NOTICE)] == [lines[first]]
    # numba compiles the kernel at the first query, so before that query's progress line
    first_query = next(i for i, line in enumerate(lines) if line.startswith("cbr run: 1/"))
    assert first < first_query, done.stderr
    assert "cbr: compiled 1 kernel in " in done.stderr
    assert "answered by the fallback solver" in done.stdout
    assert list((tmp_path / "cache" / "numba").rglob("notice_kernel.margin-*.nbi"))


def test_a_warm_cache_is_not_announced(lane: Callable[[], CliResult]) -> None:
    assert _notices(lane().stderr)
    again = lane()
    assert again.exit_code == 0, again.stderr
    assert _notices(again.stderr) == []
    assert "answered by the fallback solver" in again.stdout


def test_a_kernel_missing_from_a_filled_cache_is_announced_when_it_compiles(
        lane: Callable[[], CliResult], tmp_path: Path) -> None:
    # another kernel in the cache, not the lane's
    (tmp_path / "src" / "other_kernel.py").write_text(OTHER_KERNEL, encoding="utf-8")
    sys.modules.pop("other_kernel", None)
    assert importlib.import_module("other_kernel").double(2) == 4
    sys.modules.pop("other_kernel", None)
    assert list((tmp_path / "cache" / "numba").rglob("*.nbi"))
    done = lane()
    assert done.exit_code == 0, done.stderr
    lines = done.stderr.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith(NOTICE))
    # numba compiles it at the first query, so before that query's progress line
    first_query = next(i for i, line in enumerate(lines) if line.startswith("cbr run: 1/"))
    assert first < first_query, done.stderr


def test_a_configuration_without_kernels_is_announced_once_on_an_empty_cache(
        lane: Callable[[], CliResult], tmp_path: Path,
        invoke_cbr: Callable[..., CliResult]) -> None:
    plain = tmp_path / "plain.yaml"
    plain.write_text(closed_loop_domain.LANE_CONFIG, encoding="utf-8")

    def run(name: str) -> CliResult:
        done = invoke_cbr("run", str(plain), "--out", str(tmp_path / name))
        assert done.exit_code == 0, done.stderr
        return done

    # no cache folder: the first line comes before the components load, and nothing follows
    first = run("plain")
    assert [line[:len(NOTICE)] for line in _notices(first.stderr)] == [NOTICE]
    # the folder it made says that the cache is not cold any more
    assert (tmp_path / "cache" / "numba").is_dir()
    assert not list((tmp_path / "cache" / "numba").iterdir())
    assert _notices(run("again").stderr) == []


def test_an_invalid_configuration_on_an_empty_cache_is_announced_before_its_error(
        lane: Callable[[], CliResult], tmp_path: Path,
        invoke_cbr: Callable[..., CliResult]) -> None:
    broken = tmp_path / "broken.yaml"
    broken.write_text(CONFIG.replace("solver: compiled_margin", "solver: no_such_solver"),
                      encoding="utf-8")
    done = invoke_cbr("run", str(broken), "--out", str(tmp_path / "broken"))
    assert done.exit_code == 2
    lines = done.stderr.splitlines()
    assert lines[0].startswith(NOTICE) and "no_such_solver" in done.stderr
    # it compiled nothing and ran nothing: the cache stays cold for the next run
    assert not (tmp_path / "cache").exists()
