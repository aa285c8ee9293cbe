"""Compiled kernels are cached in the user's cache folder, never in the source tree."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numba

from cbr_kernels import njit
from cbrcore.kernel_cache import cache_dir, numba_cache_dir

KERNEL = textwrap.dedent("""\
    from cbr_kernels import njit

    @njit
    def total(n):
        s = 0
        for i in range(n):
            s += i
        return s

    print(total(10))
""")


def _run(code: str, cwd: Path, **env: str) -> subprocess.CompletedProcess[str]:
    environ = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "CBR_CACHE_DIR")}
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, env={**environ, **env},
                          capture_output=True, text=True, timeout=300)


def test_a_kernel_is_cached_under_cbr_cache_dir_and_not_beside_its_source(tmp_path: Path) -> None:
    source = tmp_path / "src"
    source.mkdir()
    (source / "kernel.py").write_text(KERNEL, encoding="utf-8")
    cache = tmp_path / "cache"
    done = _run("import kernel", source, CBR_CACHE_DIR=str(cache),
                PYTHONPATH=os.pathsep.join([str(source), *sys.path]))
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "45"
    # numba names an index after the module, the function and its first line (the decorator)
    assert [p.name.split(".py")[0] for p in (cache / "numba").rglob("*.nbi")] == [
        "kernel.total-3"]
    assert list(source.rglob("*.nbi")) == [] and list(source.rglob("*.nbc")) == []


def test_the_project_kernels_cache_in_the_chosen_folder(tmp_path: Path) -> None:
    code = ("import numpy as np\n"
            "from cbr_grid.grid import Grid\n"
            "from cbr_solvers.search import astar\n"
            "g = Grid(np.zeros((4, 4)))\n"
            "print(astar(g.factor, g.passable, False, (0, 0), [(3, 3)]).cost)\n")
    done = _run(code, tmp_path, CBR_CACHE_DIR=str(tmp_path))
    assert done.returncode == 0, done.stderr
    assert float(done.stdout) == 3 * 2 ** 0.5
    indexes = {p.name.split("-")[0] for p in (tmp_path / "numba").rglob("*.nbi")}
    assert {"search._search", "search_base.push4_grown"} <= indexes


def test_numba_cache_dir_wins_over_cbr_cache_dir(tmp_path: Path) -> None:
    (tmp_path / "kernel.py").write_text(KERNEL, encoding="utf-8")
    own, ours = tmp_path / "numba_own", tmp_path / "ours"
    done = _run("import kernel", tmp_path, NUMBA_CACHE_DIR=str(own), CBR_CACHE_DIR=str(ours))
    assert done.returncode == 0, done.stderr
    assert list(own.rglob("*.nbi")) and not ours.exists()


def test_the_cache_folders_follow_the_environment(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("CBR_CACHE_DIR", "/somewhere/cbr")
    assert (cache_dir(), numba_cache_dir()) == (Path("/somewhere/cbr"),
                                                Path("/somewhere/cbr/numba"))
    monkeypatch.setenv("NUMBA_CACHE_DIR", "/elsewhere")
    assert numba_cache_dir() == Path("/elsewhere")
    monkeypatch.delenv("CBR_CACHE_DIR")
    assert cache_dir().name == "cbrcore"


def test_decorating_leaves_numbas_own_setting_as_it_was() -> None:
    before = numba.config.CACHE_DIR

    @njit(inline="always")
    def double(x: int) -> int:
        return 2 * x

    assert before == numba.config.CACHE_DIR
    assert double(4) == 8
