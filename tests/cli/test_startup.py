"""The command line starts without the heavy libraries: ``cbr --help`` and TAB completion load
every plugin to list its commands and components, and the built-in plugins register their
components by name, so that NumPy, numba, matplotlib and scipy load only where a component is
used (benchmarks/cli_startup.py times it)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from repo_paths import ROOT

HEAVY = ("numpy", "numba", "matplotlib", "scipy", "networkx")

PROBE = """
import contextlib, io, json, sys
from cbrcore.cli import main
from cbrcore.plugins import current
with contextlib.redirect_stdout(io.StringIO()) as out:
    try:
        code = main(sys.argv[1:])
    except SystemExit as exc:  # completion answers and exits, as click's protocol has it
        code = exc.code
print(json.dumps({"code": code, "out": out.getvalue(),
                  "plugins": [p.name for p in current().loaded],
                  "modules": sorted({name.split(".")[0] for name in sys.modules})}))
"""
"""Runs ``cbr`` in-process with the given arguments, then reports what it imported."""


def _cbr(args: list[str], **env: str) -> dict:
    environ = {**os.environ, "CBR_STRICT_PLUGINS": "1", **env,
               "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "plugins")])}
    done = subprocess.run([sys.executable, "-c", PROBE, *args], env=environ, cwd=ROOT,
                          capture_output=True, text=True, timeout=120, check=True)
    return json.loads(done.stdout)


@pytest.mark.parametrize(("case", "args", "env", "shown"), [
    ("help", ["--help"], {}, "experiment"),
    ("completion", [], {"_CBR_COMPLETE": "complete_bash",
                        "COMP_WORDS": "cbr\nrun\nx.yaml\n--set\nretrieve\n=",
                        "COMP_CWORD": "5"}, "landmarks"),
    ("store completion", [], {"_CBR_COMPLETE": "complete_bash",
                              "COMP_WORDS": "cbr\nrun\nx.yaml\n--set\ncasebase\n=",
                              "COMP_CWORD": "5"}, "sqlite"),
])
def test_the_command_line_starts_without_heavy_libraries(
        case: str, args: list[str], env: dict[str, str], shown: str) -> None:
    report = _cbr(args, **env)
    assert report["code"] == 0, case
    assert shown in report["out"].split(), report["out"]
    # every built-in plugin loaded, the families that use the heavy libraries among them
    assert {"grid", "solvers", "landmarks", "world2d", "casegraph"} <= set(report["plugins"])
    assert not set(HEAVY) & set(report["modules"])
