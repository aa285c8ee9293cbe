"""benchmarks/kinematics_speed.py runs in quick mode: outputs written, no correctness mismatch."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

import repo_paths
from repo_paths import ROOT

SCRIPT = ROOT / "benchmarks" / "kinematics_speed.py"
DATA = repo_paths.DATA / "movingai"


def test_quick_run_writes_outputs_without_mismatches(tmp_path: Path) -> None:
    spec = importlib.util.spec_from_file_location("kinematics_speed", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)

    result = module.main(["--quick", "--data", str(DATA), "--out", str(tmp_path)])

    assert result["mismatches"] == {"astar_vs_dijkstra": 0, "holonomic_vs_ordinary": 0,
                                    "below_optimum": 0, "ordinary_vs_scen": 0}
    written = json.loads((tmp_path / "kinematics_speed.json").read_text())
    assert written["mismatches"] == result["mismatches"]
    assert written["quick"] is True
    models = {"holonomic", "forward", "forward_backward"}
    assert {row["model"] for row in written["rows"]} == models
    assert {row["model"] for row in written["pooled"]} == models
    # every model solved something, and the holonomic searches every query at the optimum
    for row in written["pooled"]:
        assert row["solved"] > 0
        assert row["cost_ratio_median"] >= 1 - 1e-9
        assert row["astar_over_ordinary"] > 0
    holonomic = next(r for r in written["pooled"] if r["model"] == "holonomic")
    assert holonomic["solved"] == holonomic["queries"] > 0
    assert holonomic["cost_ratio_max"] == pytest.approx(1.0, abs=1e-3)
    text = (tmp_path / "kinematics_speed.md").read_text()
    assert "| all maps (pooled) | forward_backward |" in text
    assert "Mismatch totals: astar_vs_dijkstra 0, holonomic_vs_ordinary 0" in text
