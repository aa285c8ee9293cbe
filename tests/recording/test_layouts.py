"""The Foxglove layouts shipped for each family name topics the recordings carry."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest

from repo_paths import ROOT

LAYOUTS = sorted((ROOT / "docs" / "foxglove").glob("*.json"))
DOCUMENTED = set(re.findall(r"^\| `(/[a-z_/]+)` \|", (ROOT / "docs" / "recording.md").read_text(
    encoding="utf-8"), flags=re.MULTILINE))


def _topics(value: Any) -> set[str]:
    """Every topic a layout names: a topics key of the 3D panel, or a message path's topic."""
    if isinstance(value, dict):
        found = {key for key in value.get("topics", {}) if key.startswith("/")}
        return found.union(*(_topics(v) for v in value.values()))
    if isinstance(value, list):
        return set().union(*(_topics(v) for v in value))
    if isinstance(value, str) and value.startswith("/"):
        return {value.split(".")[0]}
    return set()


def test_a_layout_for_each_family() -> None:
    assert [path.stem for path in LAYOUTS] == ["delivery_day", "grid_trips", "world2d_trials"]


@pytest.mark.parametrize("path", LAYOUTS, ids=lambda path: path.stem)
def test_layouts_name_recorded_topics(path: Path) -> None:
    layout = json.loads(path.read_text(encoding="utf-8"))
    assert set(layout) >= {"configById", "layout"}
    topics = _topics(layout["configById"])
    assert "/cbr/decision" in topics
    assert topics <= DOCUMENTED, topics - DOCUMENTED
