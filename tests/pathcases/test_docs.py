"""The whole-path cases page describes the robots the learning experiment actually drives."""

from __future__ import annotations

import re
from pathlib import Path

from cbr_pathcases.experiments import CAPACITY, LEARNING_RISK, robot_config
from repo_paths import ROOT

PAGE = ROOT / "docs" / "pathcases.md"


def _bullet(name: str) -> str:
    text = PAGE.read_text(encoding="utf-8")
    match = re.search(rf"^- \*\*{re.escape(name)}\*\*: (.*?)(?=^- |\n\n)", text, re.S | re.M)
    assert match, f"no bullet for {name}"
    return " ".join(match[1].split())


def test_the_cbr_robot_is_the_experiments() -> None:
    config = robot_config("cbr", Path("floor.grid"), 10, 0)
    said = _bullet("cbr")
    assert f"δ = {config['retrieve']['delta']:g}" in said
    assert f"`{config['solver']['use']}` solver (noise {config['solver']['noise']:g})" in said
    revise = config["revise"]
    assert revise["use"] == "path_quality" and revise["ideal"] == "landmarks"
    assert f"`max_ratio` {revise['max_ratio']:g}" in said
    assert f"capacity {config['forget'][0]['capacity']}" in said


def test_the_other_robots_are_the_experiments() -> None:
    learning = robot_config("map-learning", Path("floor.grid"), 10, 0)
    assert learning["solver"] == "astar"
    assert f"`hit_risk` {LEARNING_RISK:g}" in _bullet("map-learning")
    assert robot_config("map-only", Path("floor.grid"), 10, 0)["solver"] == "astar"
    capped = robot_config("worst_paths", Path("floor.grid"), 10, 0)
    assert capped["forget"] == [{"use": "worst_paths", "capacity": CAPACITY}]
    assert f"**capacity of {CAPACITY} paths**" in PAGE.read_text(encoding="utf-8")
