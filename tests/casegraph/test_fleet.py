"""``cbr experiment fleet``: robots learning into one case base at once, at size ci.

The experiment itself is run once, through the CLI, and its report checked for every field and
for a sound case base; the checks it reports are tested on their own against case bases whose
faults are known (a lost learn step, a path that never reached the store).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from cbr_casegraph.experiments.fleet import (
    PG_VARIABLES,
    STALL_SKIPS,
    audit,
    curve,
    first_reaching,
    journal_key,
    postgres_dsn,
)
from cbr_casegraph.graph import CaseGraph
from cbr_grid.generate import generate
from cbrcore.casebase.memory import MemoryStore
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult

PNG = b"\x89PNG\r\n\x1a\n"

ROW_FIELDS = {"store", "mode", "robots", "trips_per_robot", "learn_steps", "wall_seconds",
              "steps_per_second", "catch_ups", "reloads", "conflicts_retried", "mean_learn_ms",
              "cbr_share", "trips_to_share", "curve", "integrity", "seconds_with_start_and_audit",
              "learn_skipped", "frozen_seconds"}
INTEGRITY_FIELDS = {"case_bases", "lost_steps", "uncovered_steps", "check_problems",
                    "replay_equal", "serialised", "vertices", "segments"}


@pytest.fixture
def plugins(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    return cbr_plugins(entry_points=True)


def test_the_ci_run_reports_every_fleet_and_loses_nothing(
        invoke_cbr: Callable[..., CliResult], plugins: Plugins, tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch) -> None:
    for name in PG_VARIABLES:  # no PostgreSQL server named: its rows are absent, and why
        monkeypatch.delenv(name, raising=False)
    result = invoke_cbr("experiment", "fleet", "--size", "ci", "--out", str(tmp_path))
    assert result.exit_code == 0, result.stderr
    for file in ("results.json", "results.md", "manifest.json"):
        assert (tmp_path / file).stat().st_size > 0
    assert (tmp_path / "fleet_share.png").read_bytes()[:8] == PNG
    assert "PostgreSQL rows absent" in (tmp_path / "results.md").read_text(encoding="utf-8")
    results = json.loads((tmp_path / "results.json").read_text(encoding="utf-8"))
    check_fields(results)
    for row in results["rows"]:
        check_sound(row)
    check_stalled(results["rows"][-1])


def test_the_ci_run_learns_into_postgres_when_the_environment_names_a_server(
        invoke_cbr: Callable[..., CliResult], plugins: Plugins, postgres_database: str,
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from psycopg.conninfo import conninfo_to_dict

    for name in PG_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    server = conninfo_to_dict(postgres_database)
    for key, name in (("host", "PGHOST"), ("port", "PGPORT"), ("dbname", "PGDATABASE"),
                      ("user", "PGUSER")):
        if server.get(key):
            monkeypatch.setenv(name, str(server[key]))
    result = invoke_cbr("experiment", "fleet", "--size", "ci", "--out", str(tmp_path))
    assert result.exit_code == 0, result.stderr
    results = json.loads((tmp_path / "results.json").read_text(encoding="utf-8"))
    assert results["stores"] == ["sqlite", "postgres"]
    assert results["postgres_absent"] is None
    rows = [row for row in results["rows"] if row["store"] == "postgres"]
    assert [(row["robots"], row["mode"]) for row in rows] == [
        (1, "shared"), (2, "shared"), (2, "separate"), (2, "frozen")]
    for row in rows:
        check_sound(row)
    check_stalled(rows[-1])


def check_stalled(row: dict[str, Any]) -> None:
    """The robots beside a frozen learner skipped learn steps and still lost none: every trip
    they drove was learned (the audit found every committed step in the store)."""
    assert row["mode"] == "frozen"
    assert row["learn_skipped"] >= STALL_SKIPS * row["robots"]
    assert row["learn_steps"] == sum(row["trips_per_robot"])
    assert row["frozen_seconds"] > 0


def check_fields(results: dict[str, Any]) -> None:
    rows = results["rows"]
    assert [(row["store"], row["robots"], row["mode"]) for row in rows] == [
        ("sqlite", 1, "shared"), ("sqlite", 2, "shared"), ("sqlite", 2, "separate"),
        ("sqlite", 2, "frozen")]
    assert results["stores"] == ["sqlite"]
    assert "PGHOST" in results["postgres_absent"]
    for row in rows:
        assert set(row) == ROW_FIELDS
        assert set(row["integrity"]) == INTEGRITY_FIELDS
        assert sum(row["trips_per_robot"]) == row["learn_steps"] == results["trips_per_fleet"]
        assert row["steps_per_second"] == pytest.approx(row["learn_steps"]
                                                        / row["wall_seconds"])
        assert row["conflicts_retried"] == 0
        assert 0 <= row["cbr_share"] <= 1
        assert row["curve"][-1]["trips"] == row["learn_steps"]
        assert row["integrity"]["case_bases"] == (row["robots"] if row["mode"] == "separate"
                                                  else 1)
        assert (row["learn_skipped"] > 0) == (row["mode"] == "frozen")
    # one robot alone never finds the case base moved by another
    assert rows[0]["catch_ups"] == 0
    # two robots sharing one do, and their case graphs follow each other's commits
    assert rows[1]["catch_ups"] > 0 and rows[1]["reloads"] == 0
    assert set(results["targets"]) == {"integrity", "throughput"}
    assert results["targets"]["throughput"]["sqlite_2_over_1_robot"] == pytest.approx(
        rows[1]["steps_per_second"] / rows[0]["steps_per_second"])


def check_sound(row: dict[str, Any]) -> None:
    integrity = row["integrity"]
    assert integrity["lost_steps"] == 0
    assert integrity["uncovered_steps"] == 0
    assert integrity["check_problems"] == []
    assert integrity["replay_equal"]
    assert integrity["serialised"]
    assert all(count > 0 for count in integrity["segments"])


# -- the checks on their own ---------------------------------------------------------------------

GRID = generate("random", 24, 24, 3, density=0.0)
ALONG = [(x, 2) for x in range(2, 12)]
DOWN = [(11, y) for y in range(2, 10)]


def learned(store: MemoryStore, *paths: list[tuple[int, int]]) -> None:
    """Learn ``paths`` into ``store`` as robot 0's learn steps do, one transaction each."""
    for path in paths:
        with store.transaction():
            graph = CaseGraph.load(GRID, store)
            graph.add_path(path)
            graph.merge_redundant()
            store.set_meta(journal_key(0), store.get_meta(journal_key(0), 0) + 1)


def trip(read: int, path: list[tuple[int, int]]) -> dict[str, Any]:
    return {"read": read, "cbr": False, "deviation": 0.0, "learn_seconds": 0.0,
            "path": [list(cell) for cell in path]}


def test_a_sound_case_base_passes_the_audit(plugins: Plugins) -> None:
    assert GRID.passable[2, 2:12].all() and GRID.passable[2:10, 11].all()
    store = MemoryStore()
    learned(store, ALONG, DOWN)
    found = audit(store, GRID, [{"robot": 0, "trips": [trip(1, DOWN), trip(0, ALONG)]}],
                  plugins)
    assert found["lost_steps"] == 0 and found["uncovered_steps"] == 0
    assert found["replay_vertices_equal"] and found["replay_segments_equal"]
    # along the top, then down from its end: one straight segment each, meeting at (11, 2)
    assert found["segments"] == 2 and found["vertices"] == 3


def test_the_audit_finds_a_step_that_never_reached_the_store(plugins: Plugins) -> None:
    store = MemoryStore()
    learned(store, ALONG)
    # the robot believes it committed DOWN too: its 7 steps and its learn step are missing
    found = audit(store, GRID, [{"robot": 0, "trips": [trip(0, ALONG), trip(1, DOWN)]}],
                  plugins)
    assert found["lost_steps"] == 1
    assert found["uncovered_steps"] == len(DOWN) - 1
    assert not found["replay_segments_equal"]


def test_the_curve_bins_every_trip_once() -> None:
    trips = [{"cbr": i % 4 != 0, "deviation": 0.1 * (i % 2)} for i in range(100)]
    rows = curve(trips, bins=5)
    assert rows[-1]["trips"] == 100
    ends = [row["trips"] for row in rows]
    assert ends == sorted(set(ends))
    # the last bin, trips 40..99 (geomspace(1, 100, 6) rounds to 1, 3, 6, 16, 40, 100)
    assert ends == [1, 3, 6, 16, 40, 100]
    assert rows[-1]["cbr_share"] == pytest.approx(45 / 60)
    assert rows[-1]["deviation"] == pytest.approx(0.05)
    assert rows[0]["cbr_share"] == 0.0  # trip 0 alone, which the solver planned


def test_a_share_is_reached_over_the_later_half_of_the_trips() -> None:
    trips = [{"cbr": i >= 30} for i in range(120)]
    # after T trips, those in (T/2, T]: at T = 50 trips 25..49, 20 of 25 by CBR = 0.8
    assert first_reaching(trips, 0.8) == 50
    assert first_reaching(trips, 1.0) == 60
    assert first_reaching(trips[:40], 0.8) is None


def test_postgres_is_included_only_when_the_environment_names_a_server() -> None:
    assert postgres_dsn({}) is None
    assert postgres_dsn({"PGHOST": ""}) is None
    assert postgres_dsn({"PGHOST": "/run/postgresql"}) == ""
