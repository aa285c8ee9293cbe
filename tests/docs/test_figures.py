"""The figures the docs quote from benchmarks and experiments: rendered from committed results,
and a page that differs from its results fails ``benchmarks/figures.py --check``."""

from __future__ import annotations

from repo_paths import ROOT

import csv
import importlib
import json
import re
import shlex
import shutil
import statistics
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult

SCRIPT = ROOT / "benchmarks" / "figures.py"


#: the modules of the docfigures package the tests reach
MODULES = ("results", "wording", "catalogue", "pages", "keep", "provenance", "case_benchmarks",
           "ros2005_baseline", "pathcases_experiments", "rupart_experiments")


@pytest.fixture(scope="module")
def figures() -> Iterator[ModuleType]:
    """The docfigures package, imported as the script imports it: from the script's folder."""
    with pytest.MonkeyPatch.context() as patch:
        patch.syspath_prepend(str(SCRIPT.parent))
        package = importlib.import_module("docfigures")
        for name in MODULES:
            importlib.import_module(f"docfigures.{name}")
        yield package


def test_the_pages_hold_what_the_results_say(figures: ModuleType) -> None:
    """The blocks against the results; whether the results are older than their source is
    ``figures.py --check``'s to say: a change to the code makes them so until they are rerun."""
    assert figures.pages.check() == []


def test_every_results_file_records_its_command_commit_and_source(figures: ModuleType) -> None:
    provenance = figures.provenance
    files = provenance.result_files()
    assert {file.parent.relative_to(ROOT).as_posix() for file in files} == set(
        provenance.RESULT_FOLDERS)
    for file in files:
        data = json.loads(file.read_text(encoding="utf-8"))
        assert data["command"].startswith(("python benchmarks/", "cbr experiment ")), file
        assert re.fullmatch(r"[0-9a-f]{40}", data["commit"]), file
        assert data["source"], file
        for unit, digest in data["source"].items():
            assert (ROOT / unit).exists(), (file, unit)
            # None: a unit that did not exist at the commit that made the results
            assert digest is None or re.fullmatch(r"[0-9a-f]{64}", digest), (file, unit)


def test_a_unit_is_a_plugin_a_part_of_cbrcore_or_a_benchmark_script(figures: ModuleType) -> None:
    unit_of = figures.provenance.unit_of
    assert unit_of(ROOT / "plugins" / "cbr_grid" / "grid.py") == "plugins/cbr_grid"
    assert unit_of(ROOT / "cbrcore" / "casebase" / "memory.py") == "cbrcore/casebase"
    assert unit_of(ROOT / "cbrcore" / "engine.py") == "cbrcore/engine.py"
    assert unit_of(ROOT / "benchmarks" / "solvers.py") == "benchmarks/solvers.py"
    for outside in (ROOT / "benchmarks" / "docfigures" / "keep.py",
                    ROOT / "tests" / "toy_domain.py", Path(json.__file__)):
        assert unit_of(outside) is None, outside


def _current(root: Path, provenance: ModuleType) -> None:
    """Record in every results file under ``root`` the source ``root`` holds, as a rerun at
    that source would."""
    for file in provenance.result_files(root):
        data = json.loads(file.read_text(encoding="utf-8"))
        data["source"] = {unit: provenance.unit_sha256(unit, root) for unit in data["source"]}
        file.write_text(json.dumps(data), encoding="utf-8")


def test_a_result_older_than_its_source_fails_the_check_naming_its_blocks_and_command(
        figures: ModuleType, tmp_path: Path) -> None:
    """On a copy of the repository's results and source: current, then a solver changed."""
    provenance, pages = figures.provenance, figures.pages
    for folder in (*provenance.RESULT_FOLDERS, "cbrcore", "plugins"):
        shutil.copytree(ROOT / folder, tmp_path / folder,
                        ignore=shutil.ignore_patterns("__pycache__", "*.png", "*.grid"))
    _current(tmp_path, provenance)
    assert pages.stale_results(tmp_path) == []
    search = tmp_path / "plugins" / "cbr_solvers" / "search.py"
    text = search.read_text(encoding="utf-8")
    # comments, docstrings and layout are not what a result comes from
    search.write_text(text.replace('"""', '"""Reworded. ', 1) + "\n\n# a comment\n",
                      encoding="utf-8")
    assert pages.stale_results(tmp_path) == []
    search.write_text(text + "\nCHANGED = True\n", encoding="utf-8")
    stale = pages.stale_results(tmp_path)
    [genetic] = [line for line in stale if line.startswith("benchmarks/results/genetic.json")]
    assert genetic.startswith("benchmarks/results/genetic.json (blocks genetic, genetic-reading): "
                              "source changed since commit ")
    assert genetic.endswith(": plugins/cbr_solvers; rerun `python benchmarks/solvers.py "
                            "--genetic`")
    # results whose producers never imported the solvers stay current ("plugins" is every one)
    using = {file.relative_to(tmp_path).as_posix() for file in provenance.result_files(tmp_path)
             if {"plugins/cbr_solvers", "plugins"} & set(
                 json.loads(file.read_text(encoding="utf-8"))["source"])}
    assert {line.split(" ")[0] for line in stale} == using
    assert "docs/figures/landmark-learning.json" not in using
    [share] = [line for line in stale if line.startswith("docs/figures/cbr-share.json")]
    assert share.endswith("; rerun `cbr experiment cbr-share --size full --seed 0 --out DIR`, "
                          "then `python benchmarks/figures.py --keep-experiment cbr-share DIR`")
    search.unlink()
    assert "plugins/cbr_solvers" in pages.stale_results(tmp_path)[0]


def test_a_result_without_source_fails_the_check(figures: ModuleType, tmp_path: Path) -> None:
    results = tmp_path / "benchmarks" / "results"
    results.mkdir(parents=True)
    (results / "solvers.json").write_text(json.dumps({"command": "python benchmarks/solvers.py"}),
                                          encoding="utf-8")
    assert figures.pages.stale_results(tmp_path) == [
        "benchmarks/results/solvers.json (blocks solvers-maps, solvers-pooled, solvers-targets): "
        "records no source; rerun `python benchmarks/solvers.py`"]


def test_every_block_is_on_a_page_and_every_page_block_is_known(figures: ModuleType) -> None:
    used = figures.pages.used()
    assert set(used) == set(figures.catalogue.BLOCKS)
    for block in figures.catalogue.BLOCKS.values():
        assert block.source.is_file(), block.source


def test_a_changed_figure_is_reported_with_its_page_and_block(figures: ModuleType,
                                                              tmp_path: Path) -> None:
    docs = tmp_path / "docs"
    shutil.copytree(ROOT / "docs", docs)
    page = docs / "benchmarks.md"
    text = page.read_text(encoding="utf-8")
    start = text.index("<!-- figures: genetic -->")
    cell = re.compile(r"\| 0\.90 \|")
    assert cell.search(text, start), "the genetic table holds a success rate of 0.90"
    page.write_text(text[:start] + cell.sub("| 0.95 |", text[start:], count=1),
                    encoding="utf-8")
    stale = figures.pages.check(docs)
    assert len(stale) == 1
    assert stale[0].startswith("docs/benchmarks.md: block genetic differs")
    assert figures.pages.write(docs) == ["docs/benchmarks.md: block genetic rewritten"]
    assert page.read_text(encoding="utf-8") == text
    assert figures.pages.check(docs) == []


def test_an_unknown_block_names_its_page(figures: ModuleType, tmp_path: Path) -> None:
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "page.md").write_text("# P\n\n<!-- figures: nowhere -->\n<!-- /figures -->\n",
                                  encoding="utf-8")
    with pytest.raises(figures.results.FiguresError,
                       match=r"docs/page\.md: block nowhere: unknown"):
        figures.pages.check(docs)


def test_table_selects_columns_and_rows_by_name(figures: ModuleType) -> None:
    text = ("intro\n\n| map | a | b |\n|---|---|---|\n| x 1 | 1 | 2 |\n| y 2 | 3 | 4 |\n\n"
            "| k |\n|---|\n| v |\n")
    results = figures.results
    assert results.table(text, 0, ["b", "map"], where="y") == (
        "| b | map |\n| --- | --- |\n| 4 | y 2 |")
    assert results.table(text, 1) == "| k |\n| --- |\n| v |"
    with pytest.raises(results.FiguresError, match="no column 'c'"):
        results.table(text, 0, ["c"])
    with pytest.raises(results.FiguresError, match="2 tables, not table 3"):
        results.table(text, 2)


def test_check_fails_naming_the_page_from_the_command_line(tmp_path: Path) -> None:
    """The command line's exit status and message, on a copy of the repository's docs."""
    root = tmp_path / "repo"
    shutil.copytree(ROOT / "docs", root / "docs")
    shutil.copytree(ROOT / "benchmarks", root / "benchmarks",
                    ignore=shutil.ignore_patterns("__pycache__"))
    page = root / "docs" / "benchmarks.md"
    text = page.read_text(encoding="utf-8")
    marker = "<!-- figures: engine-overhead -->\n"
    page.write_text(text.replace(marker, marker + "| stale |\n"), encoding="utf-8")
    done = subprocess.run([sys.executable, str(root / "benchmarks" / "figures.py"), "--check"],
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 1
    assert "docs/benchmarks.md: block engine-overhead differs" in done.stderr


def test_an_experiment_run_is_kept_with_its_command_table_and_trimmed_results(
        figures: ModuleType, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    keep = figures.keep
    monkeypatch.setattr(keep, "KEPT", tmp_path / "kept")
    run = tmp_path / "run"
    run.mkdir()
    curves = {"map-only": [[1.23456, 2.0]], "cbr": [[0.99999, 1.5]], "map-learning": [[3.0]]}
    (run / "results.json").write_text(json.dumps({"curves": curves, "trips": 2}),
                                      encoding="utf-8")
    (run / "results.md").write_text("| a |\n|---|\n| 1 |\n", encoding="utf-8")

    def manifest(experiment: str, seed: int) -> None:
        (run / "manifest.json").write_text(json.dumps(
            {"experiment": experiment, "size": "full", "seed": seed}), encoding="utf-8")

    manifest("path-cases-learning", 0)
    target = keep.keep_experiment("path-cases-learning", run)
    assert target == tmp_path / "kept" / "path-cases-learning.json"
    # the pages quote the curves of two robots only, to four decimals
    head = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                          cwd=Path(__file__).parent, check=False).stdout.strip()
    data = json.loads(target.read_text(encoding="utf-8"))
    # the source of what the plugin's experiments import: the path cases, the grid, cbrcore
    source = data.pop("source")
    assert {"plugins/cbr_pathcases", "plugins/cbr_grid", "cbrcore/engine.py"} <= set(source)
    assert "plugins/cbr_world2d" not in source
    assert source["plugins/cbr_grid"] == figures.provenance.unit_sha256("plugins/cbr_grid")
    assert data == {
        "command": "cbr experiment path-cases-learning --size full --seed 0",
        "commit": head,
        "table": "| a |\n|---|\n| 1 |\n",
        "results": {"curves": {"map-only": [[1.2346, 2.0]], "cbr": [[1.0, 1.5]]}, "trips": 2}}
    manifest("path-cases-learning", 1)
    assert keep.keep_experiment("path-cases-learning", run).name == (
        "path-cases-learning-seed-1.json")
    manifest("cbr-share", 0)
    with pytest.raises(figures.results.FiguresError,
                       match=r"manifest\.json is of experiment 'cbr-share', not 'deviation-table'"):
        keep.keep_experiment("deviation-table", run)
    (run / "manifest.json").write_text("{", encoding="utf-8")
    with pytest.raises(figures.results.FiguresError,
                       match=rf"^{re.escape(str(run))}/manifest\.json: not JSON"):
        keep.keep_experiment("cbr-share", run)


def test_a_run_folder_without_results_is_named_by_the_command_line(tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, str(SCRIPT), "--keep-experiment", "cbr-share",
                           str(tmp_path / "nowhere")], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 1
    assert done.stderr == (f"figures: {tmp_path / 'nowhere' / 'manifest.json'}: no such results "
                           "file\n")


def test_every_experiment_command_on_a_page_names_its_size() -> None:
    """The default size of ``cbr experiment`` is not what a page quoting figures means."""
    missing = []
    for page in sorted((ROOT / "docs").glob("*.md")):
        for line in page.read_text(encoding="utf-8").splitlines():
            for command in re.findall(r"cbr experiment [a-z][\w-]*[^`\n]*", line):
                if "--size" not in command and "--list" not in command:
                    missing.append(f"{page.name}: {command}")
    assert missing == []


# --- the 2D world page: its example runs are small enough to run here --------------------------

WORLD2D_TRIALS = ROOT / "docs" / "world2d-trials.md"
WORLD2D_ENGINE = ROOT / "docs" / "world2d-engine.md"
TEXT_BLOCK = re.compile(r"^```text\n(.*?)^```$", re.S | re.M)
#: rows of the run summary that depend on the machine or on where the output went
VOLATILE_ROWS = ("ms", "wall time s", "output")


def _session_commands() -> list[tuple[str, list[str]]]:
    """Each ``$ cbr sim ...`` command in the 2D world page's text blocks with the lines shown
    after it."""
    found: list[tuple[str, list[str]]] = []
    for block in TEXT_BLOCK.findall(WORLD2D_TRIALS.read_text(encoding="utf-8")):
        for line in block.replace("\\\n    ", "").splitlines():
            if line.startswith("$ "):
                found.append((line[2:], []))
            elif found and block.lstrip().startswith("$ "):
                found[-1][1].append(line)
    return [(command, shown) for command, shown in found if command.startswith("cbr sim ")]


@pytest.fixture
def every_plugin(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    return cbr_plugins(entry_points=True)


@pytest.mark.usefixtures("every_plugin")
@pytest.mark.parametrize(("command", "shown"), _session_commands(),
                         ids=[c for c, _ in _session_commands()])
def test_the_2d_world_page_shows_what_its_sim_commands_print(
        invoke_cbr: Callable[..., CliResult], tmp_path: Path, command: str,
        shown: list[str]) -> None:
    args = shlex.split(command)[1:]
    if "--plot" in args:
        # the picture goes to a scratch folder; the page's picture is not rewritten here
        args[args.index("--plot") + 1] = str(tmp_path / "trial.png")
    done = invoke_cbr(*args)
    printed = (done.stdout + done.stderr).splitlines()
    assert [line for line in printed if not line.startswith("wrote ")] == [
        line for line in shown if not line.startswith("wrote ")]


def _sim(invoke_cbr: Callable[..., CliResult], *args: str) -> dict[str, Any]:
    done = invoke_cbr("sim", "run", *args, "--json")
    assert done.exit_code == 0, done.stderr
    result: dict[str, Any] = json.loads(done.stdout)
    return result


@pytest.mark.usefixtures("every_plugin")
def test_the_2d_world_page_figures_of_the_pilot_alone_and_the_pioneer(
        invoke_cbr: Callable[..., CliResult]) -> None:
    """'With --rescue off the robot times out in both scenarios: in scenario 1 it stays in front
    of the obstacle (2.72 m driven in 300 s). A Pioneer 2 DX passes scenario 1 in 39.4 s and is
    trapped in scenario 2 like 002's robot.'"""
    text = " ".join(WORLD2D_TRIALS.read_text(encoding="utf-8").split())
    worlds = "plugins/cbr_world2d/worlds"
    places = ("--start", "start", "--target", "target")
    alone = [_sim(invoke_cbr, f"{worlds}/scenario{k}.yaml", *places, "--robot", "ros2005",
                  "--rescue", "off") for k in (1, 2)]
    assert [r["success"] for r in alone] == [False, False]
    assert f"({alone[0]['distance']:.2f} m driven in {alone[0]['time']:.0f} s)" in text
    pioneer = [_sim(invoke_cbr, f"{worlds}/scenario{k}.yaml", *places) for k in (1, 2)]
    assert pioneer[0]["success"] and not pioneer[1]["success"]
    assert f"passes scenario 1 in {pioneer[0]['time']:.1f} s" in text


def _summary_rows(block: str) -> dict[str, str]:
    rows = {}
    for line in block.splitlines():
        cells = [cell.strip() for cell in line.strip("│").split("│")]
        if len(cells) == 2 and line.startswith("│"):
            rows[cells[0]] = cells[1]
    return rows


@pytest.mark.usefixtures("every_plugin")
def test_the_2d_world_page_shows_what_its_trials_config_does(
        invoke_cbr: Callable[..., CliResult], tmp_path: Path) -> None:
    """The summary table, the rows of trials.csv and results.csv and the figures of the prose
    about ``cbr run configs/world2d_trials.yaml``."""
    page = WORLD2D_ENGINE.read_text(encoding="utf-8")
    blocks = TEXT_BLOCK.findall(page)
    (summary,) = [b for b in blocks if b.startswith("$ cbr run configs/world2d_trials.yaml")]
    done = invoke_cbr("run", str(ROOT / "configs" / "world2d_trials.yaml"), "--out",
                   str(tmp_path))
    assert done.exit_code == 0, done.stderr
    ours, shown = _summary_rows(done.stdout), _summary_rows(summary)
    steady = [k for k in shown if not any(k.endswith(v) for v in VOLATILE_ROWS)]
    assert {k: ours[k] for k in steady} == {k: shown[k] for k in steady}
    (trials_shown,) = [b for b in blocks if b.startswith("trial,start_x")
                       and "consultations\n0,1.0,3.9,8.0,4.0,False" in b]
    trials = (tmp_path / "trials.csv").read_text(encoding="utf-8").splitlines()
    for line in trials_shown.splitlines():
        if line != "...":
            assert line in trials
    results = list(csv.DictReader((tmp_path / "results.csv").open(encoding="utf-8")))
    reached = [float(r["outcome_cost"]) for r in results if r["success"] == "True"]
    text = " ".join(page.split())
    assert (f"reached (`True`, in {min(reached):g} to {max(reached):g} s)" in text)
    assert f"the {len(reached) / len(results) * 100:.1f} % success rate" in text
    assert all(r["consultations"] == "6" for r in csv.DictReader(
        (tmp_path / "trials.csv").open(encoding="utf-8"))), "six consultations each"


# --- the grid pages' figures of whole configuration runs, small enough to run here -------------


def _words(page: str) -> str:
    return " ".join((ROOT / "docs" / page).read_text(encoding="utf-8").split())


def _run(invoke_cbr: Callable[..., CliResult], out: Path, config: str, *sets: str
         ) -> tuple[dict[str, Any], list[dict[str, str]]]:
    """Run ``configs/<config>`` into ``out``; its summary and the rows of its results.csv."""
    overrides = [arg for value in sets for arg in ("--set", value)]
    done = invoke_cbr("run", str(ROOT / "configs" / config), "--out", str(out), *overrides)
    assert done.exit_code == 0, done.stderr
    summary: dict[str, Any] = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    with (out / "results.csv").open(encoding="utf-8") as rows:
        return summary, list(csv.DictReader(rows))


def _cell(row: dict[str, str], prefix: str) -> tuple[int, int]:
    return int(row[f"q_{prefix}_x"]), int(row[f"q_{prefix}_y"])


def _initial_map(config: str, out: Path) -> Any:
    from cbrcore.engine import Engine

    return Engine.from_yaml(ROOT / "configs" / config, out_dir=out).ctx.world


@pytest.mark.usefixtures("every_plugin")
def test_the_kinematics_page_figures_of_the_nonholonomic_config(
        invoke_cbr: Callable[..., CliResult], tmp_path: Path) -> None:
    from cbr_grid.directions import STEPS

    summary, rows = _run(invoke_cbr, tmp_path / "run", "nonholonomic.yaml")
    grid = _initial_map("nonholonomic.yaml", tmp_path / "map")
    unsolved = [row for row in rows if row["source"] == "none"]

    def facing_a_wall(row: dict[str, str]) -> bool:
        start, heading = _cell(row, "start"), int(row["q_heading"])
        # no first step within 45 degrees of the heading: a robot that turns no more per cell
        # cannot leave, and forward_backward's manoeuvres begin with such a step too
        return not any(grid.step_allowed(start, (start[0] + int(STEPS[(heading + t) % 8][0]),
                                                 start[1] + int(STEPS[(heading + t) % 8][1])))
                       for t in (-1, 0, 1))

    queries = summary["queries"]
    text = _words("kinematics.md")
    assert (f"the case graph plans {summary['cbr_share'] * 100:.0f}% of the trips and the "
            f"fallback {summary['from_solver'] / queries * 100:.0f}%; {len(unsolved)} trips have "
            f"no path the robot can drive, {sum(map(facing_a_wall, unsolved))} of them because "
            "it starts facing a wall") in text
    assert (f"The paths proposed cost {summary['metric_means']['deviation'] * 100:.1f}% more "
            "than the holonomic optimum on average, and "
            f"{summary['success_rate'] * 100:.0f}% of the trips reach their goal") in text


def _octile(row: dict[str, str]) -> float:
    (sx, sy), (gx, gy) = _cell(row, "start"), _cell(row, "goal")
    dx, dy = abs(sx - gx), abs(sy - gy)
    return max(dx, dy) + (2 ** 0.5 - 1) * min(dx, dy)


@pytest.mark.usefixtures("every_plugin")
def test_the_case_graph_page_figures_of_the_ideal_length(
        invoke_cbr: Callable[..., CliResult], tmp_path: Path) -> None:
    """The octile test against the landmark bound on the office of configs/hybrid_grid.yaml."""
    from cbr_pathquality.ideal import Landmarks

    ratio = 2.5
    octile, octile_rows = _run(invoke_cbr, tmp_path / "octile", "hybrid_grid.yaml",
                               "revise.ideal=octile", f"revise.max_ratio={ratio}")
    rejected = [row for row in octile_rows if row["fallback_reason"].startswith("revision")]
    assert rejected, "the octile test rejects some trips"
    above = all(float(row["optimal_cost"]) / _octile(row) > ratio for row in rejected)
    landmarks, rows = _run(invoke_cbr, tmp_path / "landmarks", "hybrid_grid.yaml")
    bound = Landmarks(_initial_map("hybrid_grid.yaml", tmp_path / "map"), 8)
    tight = statistics.median(bound.bound(_cell(row, "start"), _cell(row, "goal"))
                              / float(row["optimal_cost"]) for row in rows)
    text = _words("casegraph.md")
    assert (f"every trip that the octile test (at a ratio of {ratio:g}) rejected had an "
            "optimal path above that ratio too" in text) == above
    assert (f"and the CBR share was {octile['cbr_share'] * 100:.0f}%. The landmark bound is "
            f"within {(1 - tight) * 100:.0f}% of the true length on half of that map's trips; "
            f"with it the same configuration answers {landmarks['cbr_share'] * 100:.0f}% of its "
            f"{landmarks['queries']} trips from the case graph") in text


# --- the prose follows its figures ------------------------------------------------------------


def test_records_reads_a_table_by_its_header(figures: ModuleType) -> None:
    text = "| map | A* ms |\n|---|---|\n| x 1 | 0.5 |\n| y | 2 |\n"
    assert figures.results.records(text, 0) == [{"map": "x 1", "A* ms": "0.5"},
                                                 {"map": "y", "A* ms": "2"}]
    with pytest.raises(figures.results.FiguresError, match="1 tables, not table 2"):
        figures.results.records(text, 1)


def test_ranges_and_lists_read_as_prose(figures: ModuleType) -> None:
    wording = figures.wording
    assert wording.span([0.62, 0.8, 0.7], 2) == "0.62-0.80"
    assert wording.span([3.04, 2.96], 1) == "3.0"
    assert wording.span([5.2, 6.4], 0, "%") == "5-6%"
    assert wording.listed(["a"]) == "a"
    assert wording.listed(["a", "b", "c"]) == "a, b and c"
    with pytest.raises(figures.results.FiguresError, match="nothing to list"):
        wording.listed([])
    # two significant digits: 998 -> 1,000, 872 -> 870, 3.46 -> 3.5
    assert [wording.about(v) for v in (998.0, 872.0, 3.46)] == ["1,000", "870", "3.5"]
    assert [wording.all_of(f) for f in ("50/50", "49/50")] == ["all 50", "49 of 50"]
    assert wording.pm({"mean": 0.125, "std": 0.05}, 100, sign=True) == "+12.5 ± 5.0"
    assert wording.pm({"mean": None, "std": None}) == "-"


def _delivery(delivered: dict[str, float], collisions: dict[str, float], *,
              gain: tuple[float, float], rate: float, stall: float,
              empty: float) -> dict[str, Any]:
    """Results of rupart-delivery: the arms' deliveries and collisions a day, the learning
    arms' paired gain (mean, lower bound), the CBR arms' retrievals a minute and longest stall,
    and what the CBR arms deliver on the empty floor (of 17)."""
    def spread(mean: float) -> dict[str, float]:
        return {"mean": mean, "std": 0.1, "min": mean, "max": mean}

    arms = ("fixed", "best-fixed", "potential-field", "cbr", "cbr-learning", "learned-weights")
    summary = {arm: {"delivered": spread(delivered.get(arm, 1.0)),
                     "collisions": spread(collisions.get(arm, 1.0)),
                     "retrievals_per_minute": spread(rate), "median_install": spread(12.0),
                     "longest_stall": spread(stall)} for arm in arms}
    base = delivered["best-fixed"]
    paired = {arm: {"delivered": {"mean": delivered.get(arm, 1.0) - base,
                                  "low": delivered.get(arm, 1.0) - base - 0.5,
                                  "high": delivered.get(arm, 1.0) - base + 0.5}}
              for arm in arms if arm != "best-fixed"}
    learning = {arm: {"first": spread(10.0), "last": spread(10.0 + gain[0]),
                      "gain": {"mean": gain[0], "low": gain[1], "high": gain[0] + 1.0}}
                for arm in ("cbr-learning", "learned-weights")}
    empty = {arm: {"messages": 17.0, "delivered": empty if arm != "best-fixed" else 16.0,
                   "busy_speed": 0.25} for arm in ("best-fixed", "cbr", "cbr-learning")}
    return {"seeds": list(range(10)), "days": 5, "length": 1800.0, "summary": summary,
            "paired": paired, "learning": learning, "empty": empty,
            "tuning_seeds": [100, 105]}


def test_the_delivery_reading_states_each_target_against_the_figures(
        figures: ModuleType, monkeypatch: pytest.MonkeyPatch) -> None:
    delivery = figures.rupart_experiments
    good = _delivery({"best-fixed": 10.0, "cbr": 12.0, "cbr-learning": 13.0},
                     {"best-fixed": 2.0, "cbr": 1.0, "cbr-learning": 1.5},
                     gain=(1.0, 0.2), rate=5.5, stall=40.0, empty=16.0)
    monkeypatch.setattr(delivery, "delivery", lambda: good)
    reading = delivery.delivery_reading()
    # 13 / 10 = 1.30 >= 1.25 with the interval above 0
    assert "13.00 against 10.00 messages delivered on time a day, 1.30 times" in reading
    assert "**not met**" not in reading
    assert "at most 5.5 retrievals a minute (target 6: met)" in reading
    poor = _delivery({"best-fixed": 10.0, "cbr": 9.0, "cbr-learning": 11.0},
                     {"best-fixed": 1.0, "cbr": 1.0, "cbr-learning": 2.0},
                     gain=(0.4, -0.3), rate=7.0, stall=90.0, empty=12.0)
    monkeypatch.setattr(delivery, "delivery", lambda: poor)
    reading = delivery.delivery_reading()
    assert "1.10 times as many (target 1.25 for `cbr-learning`, above 1 for `cbr`: " \
           "**not met**)" in reading
    assert "collisions of the robot's 2.00 against 1.00 (**not met**)" in reading
    assert "(target 6: **not met**)" in reading and "(target 60: **not met**)" in reading
    assert "(target: above 0, **not met**)" in reading
    assert "15 of 17 at 0.2 m/s: **not met**" in reading


def test_the_first_diversion_is_named_by_the_nearest_landmark(figures: ModuleType) -> None:
    landmarks = {"l1": [3.2, 0.9], "l2": [3.4, 3.79]}
    first_way = figures.ros2005_baseline.first_way
    assert first_way({"diverting": [[2.9, 4.6], [3.0, 0.0]]}, landmarks) == "l2"
    assert first_way({"diverting": [[3.0, 0.2]]}, landmarks) == "l1"
    assert first_way({"diverting": []}, landmarks) is None


def test_a_learning_curve_is_below_from_the_last_crossing(
        figures: ModuleType, monkeypatch: pytest.MonkeyPatch) -> None:
    # with a window of 1 the curves are the costs: b dips below a at trip 2, rises above at
    # trip 3 and stays below from trip 4 on
    learning = figures.pathcases_experiments
    assert learning.mean_curve([[1.0, 3.0], [3.0, 5.0]], 1) == [2.0, 4.0]
    assert learning.mean_curve([[1.0, 3.0, 5.0]], 2) == [1.0, 2.0, 4.0]
    results = {"curves": {"a": [[2.0, 2.0, 2.0, 2.0, 2.0]], "b": [[3.0, 1.0, 3.0, 1.0, 1.0]]}}
    monkeypatch.setattr("cbr_pathcases.experiments.WINDOW", 1)
    assert learning.below_from(results, "b", "a") == 4
    assert learning.below_from(results, "a", "b") is None
