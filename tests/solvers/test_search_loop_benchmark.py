"""benchmarks/search_loop.py at a small size: the loop written once finds every query's cost the
kernels find, and the results say so."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

from repo_paths import ROOT

SCRIPT = ROOT / "benchmarks" / "search_loop.py"


def test_small_run_agrees_with_the_kernels(tmp_path: Path) -> None:
    spec = importlib.util.spec_from_file_location("search_loop", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)

    # the run raises when a cost differs from the kernel's
    result = module.main(["--side", "30", "--queries", "4", "--repeats", "1",
                          "--out", str(tmp_path)])

    assert {(row["search"], row["against"]) for row in result["rows"]} == {
        (search, against) for search in ("Dijkstra", "A*")
        for against in ("case graph kernel", "grid kernel")}
    assert all(row["queries"] == 4 and row["one_loop_over_kernel"] > 0 for row in result["rows"])
    written = json.loads((tmp_path / "search_loop.json").read_text())
    assert written["rows"] == result["rows"] and written["command"].startswith(
        "python benchmarks/search_loop.py")
    assert "| A* | case graph kernel | 4 |" in (tmp_path / "search_loop.md").read_text()
