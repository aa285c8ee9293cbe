"""The Moving AI benchmark of the case graph: how it prices each decided hybrid's queries, and
one small run of its protocol (no time is asserted, only what the figures are made of)."""

from __future__ import annotations

import pytest
from casegraph_movingai import DATA, HYBRIDS, Query, decided, run_map, speed_table, table


def _query(*, tried: bool, answered: bool) -> Query:
    """A query where CBR takes 1 s, A* 4 s and jps 0.5 s, each choice 0.1 s."""
    return Query(cbr_s=1.0, astar_s=4.0, jps_s=0.5, planned=answered, octile_ok=answered,
                 landmark_ok=answered, cbr_length=12.0, astar_length=10.0, optimal=10.0,
                 octile=9.0, landmark_bound=10.0, tried=dict.fromkeys(HYBRIDS, tried),
                 decide_s=dict.fromkeys(HYBRIDS, 0.1))


@pytest.mark.parametrize(("tried", "answered", "over_astar", "over_jps", "deviation"), [
    (True, True, 1.1 / 4.0, 1.1 / 0.5, 20.0),     # the choice and CBR
    (True, False, 5.1 / 4.0, 1.6 / 0.5, 0.0),     # the choice, CBR and the solver after it
    (False, True, 4.1 / 4.0, 0.6 / 0.5, 0.0),     # the choice and the solver
])
def test_a_decided_hybrid_pays_what_it_ran(tried: bool, answered: bool, over_astar: float,
                                            over_jps: float, deviation: float) -> None:
    queries = [_query(tried=tried, answered=answered)]
    for name, expected in (("learned_astar", over_astar), ("learned_jps", over_jps)):
        figures = decided(queries, name)
        assert figures["over_solver_median"] == pytest.approx(expected)
        assert figures["deviation_mean_pct"] == pytest.approx(deviation)
        assert figures["tried_share"] == float(tried)
        assert figures["share"] == float(tried and answered)


def test_a_small_run_reports_every_hybrid_against_its_solver() -> None:
    row = run_map(DATA / "maps/dao/arena.map", DATA / "scenarios/dao/arena.map.scen", 24)
    assert row["set"] == "tuning" and 0 < row["queries"] <= 24 - row["retained_paths"]
    assert set(row["decided"]) == set(HYBRIDS)
    for name, figures in row["decided"].items():
        assert figures["solver"] == HYBRIDS[name][0]
        assert 0 <= figures["share"] <= figures["tried_share"] <= 1
    assert row["jps_ms_median"] > 0 and row["astar_ms_median"] > 0
    lines = table([row]) + speed_table([row])
    assert all(line.count("|") == lines[0].count("|") for line in lines[:3])
    assert all(line.count("|") == lines[3].count("|") for line in lines[3:])
