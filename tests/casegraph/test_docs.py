"""The case graph page: its Python example runs, and its similarity radius figures come from a
run that agrees with the deviation-table experiment."""

from __future__ import annotations

import contextlib
import importlib.util
import io
import json
import re
from pathlib import Path
from types import ModuleType

import pytest

from cbrcore.cli import main
from repo_paths import ROOT

PAGE = ROOT / "docs" / "casegraph.md"


def test_python_example_runs() -> None:
    code = re.search(r"```python\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S)
    assert code is not None
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(code.group(1), str(PAGE), "exec"), {})
    assert printed.getvalue().startswith("cost ")


def _load(name: str) -> ModuleType:
    path = ROOT / "benchmarks" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    with pytest.MonkeyPatch.context() as patch:
        patch.syspath_prepend(str(path.parent))  # as a script, its folder is on the path
        spec.loader.exec_module(module)
    return module


def test_similarity_radius_zero_is_the_deviation_tables_cbr_column(tmp_path: Path) -> None:
    """The δr figures of the case graph and reproductions pages come from a run whose δr = 0 rows
    are the deviation-table experiment's own CBR figures: checked here at ci size, seeded."""
    radius = _load("casegraph_similarity_radius")
    result = radius.main(["--size", "ci", "--radii", "0", "1", "--out", str(tmp_path)])
    written = json.loads((tmp_path / "casegraph_similarity_radius.json").read_text())
    assert written.pop("command") == ("python benchmarks/casegraph_similarity_radius.py --size ci "
                                      f"--radii 0 1 --out {tmp_path}")
    assert {"plugins/cbr_casegraph", "cbrcore/engine.py"} <= set(written["source"])
    assert {key: written[key] for key in result} == json.loads(json.dumps(result))
    assert main(["experiment", "deviation-table", "--size", "ci", "--seed", "0",
                 "--out", str(tmp_path / "table")]) == 0
    table = json.loads((tmp_path / "table" / "results.json").read_text())["rows"]
    zero = [row for row in result["rows"] if row["radius"] == 0]
    assert [row["vertices"] for row in zero] == [row["vertices"] for row in table]
    for ours, theirs in zip(zero, table, strict=True):
        assert ours["cbr_share"] == theirs["cbr_share"]
        assert ours["cost_deviation"] == pytest.approx(theirs["deviation"]["CBR"]["cost"],
                                                       rel=1e-12)
        assert ours["cbr_only_cost_deviation"] == pytest.approx(
            theirs["cbr_only_cost_deviation"], rel=1e-12)
    # another radius grows another graph from the same tasks
    one = [row for row in result["rows"] if row["radius"] == 1]
    assert len(one) == len(zero) and all(row["tasks"] == table[0]["tasks"] for row in one)


def test_the_radius_sweep_on_a_local_cluster_equals_the_serial_run(tmp_path: Path) -> None:
    radius = _load("casegraph_similarity_radius")
    serial = radius.main(["--size", "ci", "--radii", "0", "2", "--out", str(tmp_path / "a")])
    swept = radius.main(["--size", "ci", "--radii", "0", "2", "--scheduler", "local",
                         "--workers", "2", "--out", str(tmp_path / "b")])
    assert swept == serial


def test_the_radius_script_refuses_a_negative_radius(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    radius = _load("casegraph_similarity_radius")
    with pytest.raises(SystemExit) as stopped:
        radius.main(["--size", "ci", "--radii", "-1", "--out", str(tmp_path)])
    assert stopped.value.code == 2
    assert "--radii" in capsys.readouterr().err
