"""The experiments of ``cbr_landmarks`` (Ros et al. 2005, 002), at their ``ci`` size.

``landmark-scenarios`` rebuilds 002's Figures 6 and 7: in scenario 2 the navigation system
alone never reaches the target and with the hand-made cases it always does; in scenario 1 the CBR
agent takes less time and a shorter path. ``landmark-learning``: the robot learning from an
empty case base ends with more successes and less time than the navigation system alone on
worlds it has not seen. Each summary is checked against the per-trial files each robot's run
wrote, and the paper's figures against 002 itself.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from PIL import Image

import cbr_landmarks
import cbr_world2d
import cbrcore.builtins
from cbrcore.experiment import run_experiment
from cbrcore.plugins import Plugins, load_plugins, use_plugins


@pytest.fixture(scope="module")
def plugins() -> Iterator[Plugins]:
    loaded = load_plugins(extra=[("core", cbrcore.builtins), ("world2d", cbr_world2d),
                                 ("landmarks", cbr_landmarks)], entry_points=False, environ={})
    # the experiment builds its engines with the current plugins
    with use_plugins(loaded):
        yield loaded


def trial_rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def mean(values: list[float]) -> float:
    return sum(values) / len(values)


# --- landmark-scenarios ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def scenarios(plugins: Plugins, tmp_path_factory: pytest.TempPathFactory
              ) -> tuple[Path, dict[str, Any], list[Path]]:
    out = tmp_path_factory.mktemp("landmark-scenarios")
    written = run_experiment("landmark-scenarios", plugins, size="ci", out_dir=out, seed=0)
    results = json.loads((out / "results.json").read_text(encoding="utf-8"))
    return out, results, written


def test_in_scenario_2_only_the_cbr_agent_gets_out_of_the_dead_end(
        scenarios: tuple[Path, dict[str, Any], list[Path]]) -> None:
    out, results, _ = scenarios
    n = results["trials"]
    assert n == 4
    summary = results["summary"]["scenario2"]
    assert (summary["no-cbr"]["trials"], summary["no-cbr"]["reached"]) == (n, 0)
    assert (summary["cbr-handmade"]["trials"], summary["cbr-handmade"]["reached"]) == (n, n)
    # as the trials files say: without CBR each trial runs to the timeout
    for row in trial_rows(out / "scenario2" / "no-cbr" / "trials.csv"):
        assert (row["success"], row["reason"]) == ("False", "timeout")
        assert float(row["time"]) == pytest.approx(results["timeout"])
    assert {r["success"] for r in trial_rows(out / "scenario2" / "cbr-handmade" /
                                                  "trials.csv")} == {"True"}
    assert results["cbr_over_no_cbr"]["scenario2"] == {"time": None, "distance": None}


def test_in_scenario_1_the_cbr_agent_is_quicker_and_shorter(
        scenarios: tuple[Path, dict[str, Any], list[Path]]) -> None:
    out, results, _ = scenarios
    summary = results["summary"]["scenario1"]
    means = {}
    for robot in ("no-cbr", "cbr-handmade"):
        rows = trial_rows(out / "scenario1" / robot / "trials.csv")
        assert [r["success"] for r in rows] == ["True"] * results["trials"]
        time = mean([float(r["time"]) for r in rows])
        distance = mean([100.0 * float(r["distance"]) for r in rows])
        assert summary[robot]["time"]["mean"] == pytest.approx(time)
        assert summary[robot]["distance_cm"]["mean"] == pytest.approx(distance)
        means[robot] = time, distance
    assert means["cbr-handmade"][0] < means["no-cbr"][0]
    assert means["cbr-handmade"][1] < means["no-cbr"][1]
    ratios = results["cbr_over_no_cbr"]["scenario1"]
    assert ratios["time"] == pytest.approx(means["cbr-handmade"][0] / means["no-cbr"][0])
    assert ratios["distance"] == pytest.approx(means["cbr-handmade"][1] / means["no-cbr"][1])
    # no robot is faster or shorter than 002's optimum (107 s and 539.82 cm at 5 cm/s)
    for robot in ("no-cbr", "cbr-handmade"):
        assert summary[robot]["time"]["min"] >= 107.0 - 1.0
        assert summary[robot]["distance_cm"]["min"] >= 539.82 - 1.0


def test_the_results_hold_the_papers_figures(
        scenarios: tuple[Path, dict[str, Any], list[Path]]) -> None:
    _, results, _ = scenarios
    # 002 Figure 6 (mean time in s, distance in cm) and section 4's optimal paths
    assert results["paper"] == {
        "scenario1": {"no-cbr": [162.36, 802.13], "cbr-handmade": [147.87, 648.13],
                      "optimal": [107.0, 539.82]},
        "scenario2": {"no-cbr": None, "cbr-handmade": [205.03, 921.51],
                      "optimal": [173.69, 868.46]},
    }


def test_the_table_and_figure_7_are_written(
        scenarios: tuple[Path, dict[str, Any], list[Path]]) -> None:
    out, results, written = scenarios
    names = {p.name for p in written}
    assert names >= {"results.json", "results.md", "manifest.json", "figure7.png"}
    table = (out / "results.md").read_text(encoding="utf-8")
    n = results["trials"]
    assert f"| 2 | no-cbr | 0 of {n} | - | - | - | - |" in table
    assert f"| 2 | cbr-handmade | {n} of {n} |" in table
    assert "| 1 | optimal (002) | | | | 107.00 | 539.82 |" in table
    with Image.open(out / "figure7.png") as image:
        assert image.format == "PNG"
        width, height = image.size
        assert width > height > 300  # two worlds side by side
    # each robot's first trial is drawn from its trajectories
    for scenario in ("scenario1", "scenario2"):
        for robot in ("no-cbr", "cbr-handmade"):
            assert (out / scenario / robot / "trajectories.npz").is_file()


# --- landmark-learning -----------------------------------------------------------------------


def strict_json(path: Path) -> Any:
    def refuse(constant: str) -> None:
        raise ValueError(f"{path.name} holds {constant}, which JSON does not have")

    return json.loads(path.read_text(encoding="utf-8"), parse_constant=refuse)


@pytest.fixture(scope="module")
def learning(plugins: Plugins, tmp_path_factory: pytest.TempPathFactory
             ) -> tuple[Path, dict[str, Any]]:
    out = tmp_path_factory.mktemp("landmark-learning")
    run_experiment("landmark-learning", plugins, size="ci", out_dir=out, seed=0)
    return out, strict_json(out / "results.json")


def test_learning_from_an_empty_case_base_beats_no_cbr_on_unseen_worlds(
        learning: tuple[Path, dict[str, Any]]) -> None:
    _, results = learning
    unseen = {robot: s["unseen"] for robot, s in results["summary"].items()}
    assert unseen["cbr-learning"]["success"]["mean"] > unseen["no-cbr"]["success"]["mean"]
    assert unseen["cbr-learning"]["time_all"]["mean"] < unseen["no-cbr"]["time_all"]["mean"]
    assert results["summary"]["cbr-learning"]["cases_at_end"]["mean"] >= 1
    # the robots without a case base learn nothing
    for robot in ("no-cbr", "detour"):
        assert results["summary"][robot]["cases_at_end"]["mean"] == 0


def test_the_learning_summary_is_what_the_robots_drove(
        learning: tuple[Path, dict[str, Any]]) -> None:
    out, results = learning
    train, test = results["training_worlds"], results["unseen_worlds"]
    trials = results["trials_per_world"]
    for robot, curves in results["curves"].items():
        (curve,) = curves  # one seed at ci size
        assert len(curve["success"]) == (train + test) * trials
        rows = [row for world in sorted((out / f"seed{curve['seed']}" / robot).iterdir(),
                                        key=lambda p: int(p.name.removeprefix("world")))
                for row in trial_rows(world / "trials.csv")]
        assert [row["success"] == "True" for row in rows] == curve["success"]
        unseen = rows[train * trials:]
        success = mean([row["success"] == "True" for row in unseen])
        assert results["summary"][robot]["unseen"]["success"]["mean"] == pytest.approx(success)
        assert results["summary"][robot]["unseen"]["time_all"]["mean"] == pytest.approx(
            mean([float(row["time"]) for row in unseen]))
    assert (out / "learning_curves.png").is_file()
