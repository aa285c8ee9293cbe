"""Warming up: components compile what their hot path uses when the engine is built, before
anything is timed."""

from __future__ import annotations

import json
import subprocess
import sys
from typing import Any

import numpy as np
import pytest

import cbr_grid
import cbr_pathquality
import cbr_solvers
import cbrcore.builtins
import toy_domain
from cbrcore import Engine, hookimpl
from cbrcore.context import Context
from cbrcore.errors import PhaseError
from cbrcore.plugins import Plugins, load_plugins
from cbrcore.registry import Registry


class ColdSolver:
    def __init__(self, options: object, ctx: Context) -> None:
        pass

    @hookimpl
    def cbr_warm(self) -> None:
        raise RuntimeError("the compiler is missing")

    @hookimpl
    def cbr_solve(self) -> None:
        return None


class WarmPlugin:
    @hookimpl
    def cbr_register(self, registry: Registry) -> None:
        registry.add("solver", "cold", ColdSolver)


def toy() -> Plugins:
    return load_plugins(extra=[("toy", toy_domain), ("core", cbrcore.builtins),
                               ("warming", WarmPlugin())], entry_points=False, environ={})


def test_a_failing_warm_up_is_a_phase_error_naming_the_plugin() -> None:
    with pytest.raises(PhaseError, match=r"plugin 'cold \(warming\)' failed in phase 'warm': "
                                         r"RuntimeError: the compiler is missing"):
        Engine.from_dict({"solver": "cold"}, plugins=toy())


BUILD_AND_LOOK = """
import importlib, json, sys
import numpy as np
import cbr_casegraph, cbr_grid, cbr_kinematics, cbr_pathcases, cbr_solvers, cbrcore.builtins
from cbrcore import Engine
from cbrcore.plugins import load_plugins

config, kernels = json.loads(sys.argv[1]), json.loads(sys.argv[2])
plugins = load_plugins(extra=[("core", cbrcore.builtins), ("grid", cbr_grid),
                              ("kinematics", cbr_kinematics), ("solvers", cbr_solvers),
                              ("casegraph", cbr_casegraph), ("pathcases", cbr_pathcases)],
                       entry_points=False, environ={})
def compiled():
    return {f"{m}.{n}": bool(getattr(importlib.import_module(m), n).signatures)
            for m, n in kernels}
before = compiled()
with Engine.from_dict(config, world=np.zeros((30, 30), dtype=bool), plugins=plugins) as engine:
    print(json.dumps({"before": before, "after": compiled(),
                      "cases": engine.casebase.count()}))
"""


def _build_and_look(config: dict[str, Any], *kernels: str) -> dict[str, Any]:
    """In a process of its own: whether each ``module.function`` kernel has a compiled signature
    before and after an engine of ``config`` is built on a free 30 x 30 grid."""
    pairs = [kernel.rsplit(".", 1) for kernel in kernels]
    done = subprocess.run([sys.executable, "-c", BUILD_AND_LOOK, json.dumps(config),
                           json.dumps(pairs)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def _warmed(config: dict[str, Any], *kernels: str) -> int:
    """Build ``config`` and check that its engine compiled ``kernels``, which nothing had
    compiled before; the number of cases the engine's case base holds afterwards."""
    seen = _build_and_look(config, *kernels)
    assert seen["before"] == dict.fromkeys(kernels, False)
    assert seen["after"] == dict.fromkeys(kernels, True)
    return seen["cases"]


@pytest.mark.parametrize(("solver", "kernel"), [
    ("dijkstra", "cbr_solvers.search._search"),
    ("astar", "cbr_solvers.search._search"),
    ("aistar", "cbr_solvers.aistar.wavefront"),
    ({"use": "genetic", "generations": 200}, "cbr_solvers.genetic._evolve"),
    ("randomized", "cbr_solvers.search._search"),
    ("jps", "cbr_solvers.jps._search"),
])
def test_a_built_engine_has_its_solvers_kernels_compiled(solver: Any, kernel: str) -> None:
    _warmed({"solver": solver}, kernel)


def test_a_built_engine_has_the_kinematic_search_compiled() -> None:
    _warmed({"solver": "astar", "kinematics": "forward_backward"},
            "cbr_solvers.kinematic_search._search")


def test_a_built_engine_has_the_case_graphs_kernels_compiled() -> None:
    config = {"retrieve": "casegraph", "reuse": "casegraph", "solver": "astar",
              "retain": ["casegraph"]}
    cases = _warmed(config, "cbr_casegraph.query.cases_near", "cbr_casegraph.query.adapt_swept",
                    "cbr_casegraph.retention_kernel.retain")
    assert cases == 0  # the warm-up learned into a case base of its own


def test_a_built_engine_has_the_experience_graph_kernel_compiled() -> None:
    _warmed({"retrieve": "casegraph", "reuse": "experience_graph", "solver": "astar"},
            "cbr_casegraph.experience._search")


def test_a_built_engine_has_the_path_cases_kernels_compiled() -> None:
    config = {"retrieve": "path_cases", "reuse": "path_cases", "solver": "astar",
              "retain": ["path_cases"]}
    assert _warmed(config, "cbr_pathcases.hausdorff._all") == 0


def test_the_quality_test_builds_its_landmark_tables_before_the_first_query() -> None:
    plugins = load_plugins(extra=[("core", cbrcore.builtins), ("grid", cbr_grid),
                                  ("solvers", cbr_solvers), ("pathquality", cbr_pathquality)],
                           entry_points=False, environ={})
    occupancy = np.zeros((12, 12), dtype=bool)
    occupancy[2:10, 6] = True
    config = {"solver": "astar", "revise": {"use": "path_quality", "ideal": "landmarks",
                                            "landmarks": 3}}
    with Engine.from_dict(config, world=occupancy, plugins=plugins) as engine:
        tables = engine.components["revise"].landmarks.tables
    # three exact distance tables of the 12 x 12 map, each 0 at its own landmark
    assert tables.shape == (3, 12, 12)
    assert (tables.min(axis=(1, 2)) == 0).all()
