"""A third-party plugin, installed as a distribution, is found through its entry point alone.

``tests/sample_plugin`` is built and installed into a temporary folder once for this module; each
test runs ``python -m cbrcore`` in a subprocess with and without that folder on ``PYTHONPATH``.

The sample plugin plans trips along a corridor. With ``max_offset: 1`` the trips below go, by
hand:

1. 0 -> 5: nothing stored; the direct walk, 5 steps. Remembered.
2. 1 -> 5: trip 1 is 1 + 0 = 1 cell off (similarity 1/2); walk 1 -> 0, then 0..5: 6 steps.
3. 0 -> 4: trip 1 is 0 + 1 = 1 off, trip 2 is 1 + 1 = 2 off; 0..5, then 5 -> 4: 6 steps.
4. 9 -> 2: every stored trip is more than 1 off; the direct walk, 7 steps.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from repo_paths import ROOT

SAMPLE = ROOT / "tests" / "sample_plugin"
CONFIG = """\
seed: 1
workload: {use: corridor_trips, trips: [[0, 5], [1, 5], [0, 4], [9, 2]]}
retrieve: {use: closest_trip, max_offset: 1}
reuse: splice
solver: walk
retain: [remember]
observers: [phase_counter]
"""


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding the installed sample plugin (package and dist-info)."""
    work = tmp_path_factory.mktemp("sample_plugin")
    source = work / "source"
    # build from a copy, so no build/ or egg-info folder lands in the repository
    shutil.copytree(SAMPLE, source,
                    ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    target = work / "site"
    done = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation",
         "--no-index", "--disable-pip-version-check", "--quiet", "--target", str(target),
         str(source)],
        capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stdout + done.stderr
    return target


def cbr(*args: str, cwd: Path, site: Path | None = None,
        env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """``python -m cbrcore ARGS`` in a fresh interpreter, with ``site`` on its path if given."""
    environ = {k: v for k, v in os.environ.items() if not k.startswith("CBR_")}
    if site is not None:
        environ["PYTHONPATH"] = os.pathsep.join(
            p for p in (str(site), environ.get("PYTHONPATH")) if p)
    environ.update(env or {})
    return subprocess.run([sys.executable, "-m", "cbrcore", *args], capture_output=True,
                          text=True, cwd=cwd, env=environ, check=False)


def test_listed_with_its_distribution_hooks_and_components(site: Path, tmp_path: Path) -> None:
    without = cbr("plugins", "--json", cwd=tmp_path)
    assert without.returncode == 0, without.stderr
    assert "sample" not in [p["name"] for p in json.loads(without.stdout)["plugins"]]

    listed = cbr("plugins", "--json", cwd=tmp_path, site=site)

    assert listed.returncode == 0, listed.stderr
    data = json.loads(listed.stdout)
    assert data["failed"] == []
    plugins = {p["name"]: p for p in data["plugins"]}
    assert {"core", "observers", "sample"} <= set(plugins)
    assert plugins["sample"] == {
        "name": "sample",
        "module": "cbr_sample",
        "distribution": "cbr-sample-plugin",
        "version": "0.1.0",
        "hooks": ["cbr_register", "cbr_retain", "cbr_retrieve", "cbr_reuse", "cbr_solve"],
        "components": ["observer:phase_counter", "retainer:remember", "retriever:closest_trip",
                       "reuser:splice", "solver:walk", "workload:corridor_trips"],
        "kinds": [],
    }


def test_validate_accepts_its_components(site: Path, tmp_path: Path) -> None:
    config = tmp_path / "corridor.yaml"
    config.write_text(CONFIG, encoding="utf-8")

    done = cbr("validate", str(config), cwd=tmp_path, site=site)

    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == [
        f"{config}: ok",
        "  seed: 1",
        "  casebase: memory",
        "  retrieve: closest_trip",
        "  reuse: splice",
        "  solver: walk",
        "  workload: corridor_trips",
        "  kinematics: holonomic",
        "  retain: remember",
        "  observers: phase_counter",
    ]


def test_validate_checks_its_options(site: Path, tmp_path: Path) -> None:
    config = tmp_path / "corridor.yaml"
    config.write_text(CONFIG.replace("max_offset: 1", "max_offset: -1"), encoding="utf-8")

    done = cbr("validate", str(config), cwd=tmp_path, site=site)

    assert done.returncode == 2
    assert done.stderr == (f"error: {config}: 1 problem:\n  - retrieve.max_offset "
                           "(line 3, column 43): must be >= 0: -1\n")


def test_disabling_it_removes_its_components(site: Path, tmp_path: Path) -> None:
    config = tmp_path / "corridor.yaml"
    config.write_text(CONFIG, encoding="utf-8")

    done = cbr("validate", str(config), cwd=tmp_path, site=site,
               env={"CBR_DISABLE_PLUGINS": "sample"})

    assert done.returncode == 2
    assert ("workload.use (line 2, column 17): unknown workload 'corridor_trips'; registered: "
            "delivery (plugin rupart), trials (plugin world2d), trips (plugin grid)"
            in done.stderr)


def test_run_goes_through_its_hooks(site: Path, tmp_path: Path) -> None:
    config = tmp_path / "corridor.yaml"
    config.write_text(CONFIG, encoding="utf-8")
    out = tmp_path / "out"

    done = cbr("run", str(config), "--out", str(out), cwd=tmp_path, site=site)

    assert done.returncode == 0, done.stderr
    with (out / "results.csv").open(newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    columns = ("q_start", "q_goal", "source", "fallback_reason", "retrieved", "best_similarity",
               "solution_cost", "success", "outcome_cost")
    assert [tuple(row[c] for c in columns) for row in rows] == [
        ("0", "5", "solver:walk", "no usable retrieval", "0", "", "5.0", "True", "5.0"),
        ("1", "5", "casebase", "", "1", "0.5", "6.0", "True", "6.0"),
        ("0", "4", "casebase", "", "1", "0.5", "6.0", "True", "6.0"),
        ("9", "2", "solver:walk", "no usable retrieval", "0", "", "7.0", "True", "7.0"),
    ]
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert (summary["from_casebase"], summary["from_solver"], summary["cbr_share"]) == (2, 2, 0.5)
    assert summary["mean_outcome_cost"] == 6.0
    # the observer's wrappers saw every phase call the rows imply
    counts = json.loads((out / "phase_counts.json").read_text(encoding="utf-8"))
    assert counts == {"retain": 4, "retrieve": 4, "reuse": 2, "solve": 2}
    manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    assert {"name": "sample", "distribution": "cbr-sample-plugin",
            "version": "0.1.0"} in manifest["plugins"]
    assert manifest["config"]["retrieve"] == {"use": "closest_trip", "max_offset": 1}
    assert manifest["config"]["workload"] == {"use": "corridor_trips",
                                              "trips": [[0, 5], [1, 5], [0, 4], [9, 2]]}
