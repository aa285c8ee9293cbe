"""benchmarks/rupart_retrieval.py: its cases and queries are full indices (all 25 features) as
its docstring says, every feature is weighted, a moved query stays near its source, ``nearest``
agrees with the plain Python reference, and a tiny run (when CBRkit is installed) writes its
outputs, both tables, with the rankings equal, which the docs' blocks render. No timing is
asserted."""

from __future__ import annotations

import importlib
import importlib.util
import json
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from cbr_behaviors.index import (
    FEATURES,
    FRACTIONS,
    SETS,
    SITUATION,
    Index,
    IndexTable,
    Scales,
    feature_distances,
    weight_vector,
)
from repo_paths import ROOT

BENCHMARKS = ROOT / "benchmarks"
SCRIPT = BENCHMARKS / "rupart_retrieval.py"
CASES, QUERIES, SEED = 120, 8, 3
SIZES = [24, 50, 100]


@pytest.fixture(scope="module")
def bench() -> ModuleType:
    spec = importlib.util.spec_from_file_location("rupart_retrieval", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    with pytest.MonkeyPatch.context() as patch:
        patch.syspath_prepend(str(BENCHMARKS))  # as a script, its folder is on the path
        spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def generated(bench: ModuleType) -> tuple[list[dict], list[dict]]:
    return bench.cases_and_queries(CASES, QUERIES, SEED)


def _has_variable(data: dict) -> bool:
    return any(a.startswith("?") for f in ("plan", "goal") for a in data[f])


def test_cases_and_queries_are_full_indices(bench: ModuleType,
                                            generated: tuple[list[dict], list[dict]]) -> None:
    stored, asked = generated
    assert (len(stored), len(asked)) == (CASES, QUERIES)
    assert generated == bench.cases_and_queries(CASES, QUERIES, SEED)
    for k, data in enumerate(stored + asked):
        index = Index.from_data(data, f"index {k}")
        assert set(index.to_data()) == set(FEATURES)
        assert data["goal"][0] == "deliver" and len(data["goal"]) == 3
        assert 1 <= len(data["plan"]) <= 6 and 2 <= len(data["behaviors"]) <= 5
    # only stored cases hold variables, as hand-made ones may; a query never does
    assert not any(_has_variable(q) for q in asked)
    assert 0 < sum(map(_has_variable, stored)) < CASES // 2
    # the situation features are drawn, not left at one value
    for feature in SITUATION:
        assert len({data[feature] for data in stored}) == CASES, feature


def test_every_feature_is_weighted(bench: ModuleType) -> None:
    assert set(bench.WEIGHTS) == set(FEATURES)
    assert all(bench.WEIGHTS[f] == 1.0 for f in SITUATION)
    assert len(set(bench.WEIGHTS.values())) > 1  # Figure 5's are unequal


def test_a_moved_case_stays_near_its_source(bench: ModuleType,
                                            generated: tuple[list[dict], list[dict]]) -> None:
    stored, _ = generated
    rng = np.random.default_rng(SEED)
    scales = Scales()
    for k, data in enumerate(stored[:30]):
        source = Index.from_data(data, f"case {k}")
        near = Index.from_data(bench.moved(data, rng), f"moved {k}")
        assert near != source
        by_feature = feature_distances(near, source, scales)
        assert set(by_feature) == set(FEATURES)
        # a variable unifies with the atom that replaced it; no other name of a term moves
        assert by_feature["plan"] == by_feature["goal"] == 0.0
        # one name of one set swapped at most
        assert sum(by_feature[f] > 0 for f in SETS) <= 1
        # the numbers move by a few percent of their range
        for feature in (*FRACTIONS, "sonar", "motors", "location", "task-loc"):
            assert by_feature[feature] < 0.2, feature


def test_nearest_agrees_with_the_plain_python_reference(
        bench: ModuleType, generated: tuple[list[dict], list[dict]]) -> None:
    stored_data, query_data = generated
    stored = [Index.from_data(d, f"case {k}") for k, d in enumerate(stored_data)]
    asked = [Index.from_data(d, f"query {k}") for k, d in enumerate(query_data)]
    scales = Scales()
    table = IndexTable.build(stored, scales)
    found = bench.against_reference(table, stored, asked, weight_vector(bench.WEIGHTS), scales)
    assert found["queries"] == QUERIES
    assert found["top5_equal"] == f"{QUERIES}/{QUERIES}"
    assert found["max_distance_difference"] <= 1e-12
    assert found["ms_median"] > 0


@pytest.fixture(scope="module")
def tiny(bench: ModuleType, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The folder a tiny run wrote its outputs to (CBRkit needed)."""
    pytest.importorskip("cbrkit")
    out = tmp_path_factory.mktemp("rupart_retrieval")
    bench.main(["--cases", str(CASES), "--queries", "6", "--repeats", "1",
                "--reference-queries", "3", "--seed", str(SEED),
                "--sizes", *map(str, SIZES), "--out", str(out)])
    return out


def test_tiny_run_writes_outputs(tiny: Path) -> None:
    written = json.loads((tiny / "rupart_retrieval.json").read_text())
    assert written["cases"] == CASES and written["queries"] == 6
    assert set(written["weights"]) == set(FEATURES)
    agreement = written["agreement"]
    assert agreement["best_case_equal"] == agreement["top5_equal"] == "6/6"
    assert agreement["max_similarity_difference"] <= 1e-9
    assert written["reference"]["top5_equal"] == "3/3"
    assert written["reference"]["max_distance_difference"] <= 1e-12
    best = written["best_distance"]
    assert 0.0 <= best["min"] <= best["median"] <= best["max"] <= 1.0
    assert written["target"]["met"] is False  # 120 cases are not the target's 10,000
    assert written["nearest_ms"]["median"] > 0
    assert [row["cases"] for row in written["by_size"]] == SIZES
    for row in written["by_size"]:
        assert row["top5_equal"] == "6/6"
        assert row["nearest_ms"]["median"] > 0 and row["reference_ms"]["median"] > 0
    text = (tiny / "rupart_retrieval.md").read_text()
    assert "`IndexTable.nearest`" in text and "CBRkit" in text
    tables = [block for block in text.split("\n\n") if block.startswith("|")]
    assert len(tables) == 2
    # header, rule, the small sizes, then the whole case base with CBRkit's ratio
    rows = tables[1].splitlines()[2:]
    assert [row.split("|")[1].strip() for row in rows] == [*map(str, SIZES), str(CASES)]
    assert rows[-1].rstrip(" |").endswith("x") and rows[0].rstrip(" |").endswith("-")


def test_a_size_at_or_over_the_cases_is_left_to_the_whole_row(bench: ModuleType,
                                                              tmp_path: Path) -> None:
    pytest.importorskip("cbrkit")
    result = bench.main(["--cases", "30", "--queries", "2", "--repeats", "1",
                         "--reference-queries", "1", "--sizes", "24", "30", "50",
                         "--out", str(tmp_path)])
    assert [row["cases"] for row in result["by_size"]] == [24]


@pytest.fixture
def pages(tiny: Path) -> Iterator[ModuleType]:
    """The docs' figures pages module (what renders a block) reading the tiny run's
    results."""
    with pytest.MonkeyPatch.context() as patch:
        patch.syspath_prepend(str(BENCHMARKS))
        module = importlib.import_module("docfigures.pages")
        patch.setattr(importlib.import_module("docfigures.results"), "RESULTS", tiny)
        yield module


def test_the_blocks_render_the_tiny_run(pages: ModuleType) -> None:
    by_size = pages.render("rupart-retrieval-by-size")
    assert by_size.startswith("| cases | `nearest` median ms |")
    assert "At the 24, 50 and 100 cases the robot's memory holds" in by_size
    assert "both find the same five cases on all 6 queries at each size" in by_size
    for name in ("rupart-retrieval", "rupart-retrieval-reading", "rupart-retrieval-agreement"):
        assert pages.render(name).strip(), name
