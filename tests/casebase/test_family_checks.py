"""``cbr casebase check`` checks each grid family's invariants (``cbr_check_casebase``).

Sound case bases are written by the families' own code (the case graph cutting crossing paths,
the path index, the risk map's meta); broken ones are written directly with the store API, as a
second writer working from a stale index would have written them.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cbr_casegraph.graph import SEGMENT, CaseGraph
from cbr_casegraph.invariants import graph_problems
from cbr_grid.grid import Grid
from cbr_grid.risk import LEARNED_RISK, MAP, record_map, risk_problems
from cbr_pathcases.base import PATH, PathBase, path_problems
from cbr_stores.sqlite import SQLiteStore
from cbrcore.model import Case
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult

GRID = Grid(np.zeros((10, 12)))
"""A free map 12 cells wide and 10 high."""


@pytest.fixture(autouse=True)
def installed(cbr_plugins: Callable[..., Plugins]) -> Plugins:
    return cbr_plugins(entry_points=True, environ={})


@pytest.fixture
def path(tmp_path: Path) -> Path:
    return tmp_path / "cb.sqlite"


def check(invoke_cbr: Callable[..., CliResult], path: Path) -> CliResult:
    return invoke_cbr("casebase", "check", str(path))


def segment(a: tuple[int, int], b: tuple[int, int]) -> Case:
    return Case({"a": list(a), "b": list(b)}, {"cost": 1.0, "risk": 0.0}, kind=SEGMENT)


def path_case(cells: Any, **meta: Any) -> Case:
    ends = {"start": cells[0], "goal": cells[-1]} if cells else {}
    return Case(ends, cells, kind=PATH,
                meta={"cost": 1.0, "length": 2.0, "risk": 0.0, "ideal": 2.0, "traversals": 1,
                      **meta})


def sound(path: Path) -> None:
    """A case base all three families wrote: two crossing paths in the case graph, a path case,
    learned risks, and the map's size."""
    with SQLiteStore(path) as store, store.transaction():
        graph = CaseGraph(GRID, store)
        graph.add_path([(x, 4) for x in range(0, 9)])
        graph.add_path([(5, y) for y in range(0, 9)])  # crosses the first at (5, 4)
        PathBase.load(store).add(np.array([[1, 1], [2, 2], [3, 2]]),
                                 {"cost": 1.5, "length": 2.4, "risk": 0.0, "ideal": 2.4,
                                  "traversals": 1})
        store.set_meta(LEARNED_RISK, {"3,2": 0.5, "11,9": 1.0})
        record_map(store, GRID)


def test_a_sound_case_base_of_every_family_is_ok(invoke_cbr: Callable[..., CliResult],
                                                 path: Path) -> None:
    sound(path)
    with SQLiteStore(path) as store:
        # the second path split the first where they cross: 4 segments meeting at (5, 4)
        ends = sorted(sorted(map(tuple, (c.problem["a"], c.problem["b"])))
                      for c in store.cases(SEGMENT))
        assert ends == [[(0, 4), (5, 4)], [(5, 0), (5, 4)], [(5, 4), (5, 8)], [(5, 4), (8, 4)]]
        assert store.get_meta(MAP) == {"width": 12, "height": 10}
    result = check(invoke_cbr, path)
    assert (result.exit_code, result.stdout) == (0, "ok\n")


@pytest.mark.parametrize(("cases", "problem"), [
    ([((0, 2), (4, 2)), ((2, 0), (2, 4))],
     "casegraph: segment cases 1 and 2 overlap at cell (2, 2): segments may meet only at a "
     "vertex"),
    ([((0, 2), (4, 2)), ((2, 2), (2, 5))], "segment cases 1 and 2 overlap at cell (2, 2)"),
    ([((0, 0), (4, 4)), ((1, 1), (2, 2))], "segment cases 1 and 2 overlap at cell (1, 1)"),
    ([((3, 3), (4, 3)), ((4, 3), (3, 3))], "segment cases 1 and 2 both join (4, 3) and (3, 3)"),
    ([((0, 0), (2, 1))], "segment case 1: from (0, 0) to (2, 1) is not a straight run"),
    ([((0, 0), (0, 0))], "segment case 1: from (0, 0) to (0, 0) is not a straight run"),
    ([((10, 9), (12, 9))], "segment case 1: end (12, 9) is outside the recorded 12x10 map"),
])
def test_a_broken_case_graph_fails_the_check(invoke_cbr: Callable[..., CliResult], path: Path,
                                             cases: list[Any], problem: str) -> None:
    with SQLiteStore(path) as store:
        record_map(store, GRID)
        for a, b in cases:
            store.add(segment(a, b))
    result = check(invoke_cbr, path)
    assert result.exit_code == 1
    assert problem in result.stdout


def test_segments_meeting_at_their_ends_are_sound(path: Path) -> None:
    """A star of segments ending at one cell, and two diagonal steps crossing between cells
    (which share no cell), keep the invariants."""
    with SQLiteStore(path) as store:
        for a, b in [((5, 5), (9, 5)), ((5, 5), (5, 0)), ((5, 5), (1, 1)), ((1, 8), (2, 9)),
                     ((2, 8), (1, 9))]:
            store.add(segment(a, b))
        assert graph_problems(store) == []


def test_a_malformed_segment_is_named_not_raised(path: Path) -> None:
    with SQLiteStore(path) as store:
        store.add(Case({"a": [0, 0]}, None, kind=SEGMENT))
        store.add(Case({"a": [0, 0.5], "b": [0, 3]}, None, kind=SEGMENT))
        problems = graph_problems(store)
    assert len(problems) == 2
    assert all("expected {'a': [x, y], 'b': [x, y]} of integer cells" in p for p in problems)


@pytest.mark.parametrize(("case", "problem"), [
    (path_case([[0, 0], [2, 0]]), "path case 1: the cells must follow each other in "
     "8-neighbour steps"),
    (path_case([[0, 0], [0, 0], [1, 0]]), "8-neighbour steps"),
    (path_case([[10, 9], [11, 9], [12, 9]]), "path case 1: a cell is outside the recorded "
     "12x10 map"),
    (path_case([[0, 0], [1.5, 1]]), "path case 1: the solution must be a non-empty list of "
     "integer [x, y] cells"),
    (path_case([]), "the solution must be a non-empty list"),
    (path_case([[0, 0], [1, 1]], cost=-1.0), "path case 1: meta 'cost' is -1.0; expected a "
     "finite number >= 0"),
    (path_case([[0, 0], [1, 1]], traversals=0), "meta 'traversals' is 0; a stored path was "
     "traversed at least once"),
    (Case({"start": [0, 0], "goal": [5, 5]}, [[0, 0], [1, 1]], kind=PATH,
          meta={"cost": 1, "length": 1.4, "risk": 0, "ideal": 1.4, "traversals": 1}),
     "path case 1: problem {'start': [0, 0], 'goal': [5, 5]}; expected the path's ends"),
])
def test_a_broken_path_case_fails_the_check(invoke_cbr: Callable[..., CliResult], path: Path,
                                            case: Case, problem: str) -> None:
    with SQLiteStore(path) as store:
        record_map(store, GRID)
        store.add(case)
    result = check(invoke_cbr, path)
    assert result.exit_code == 1
    assert "  - pathcases: path case 1: " in result.stdout
    assert problem in result.stdout


def test_sound_path_cases_agree_with_the_family_index(path: Path) -> None:
    with SQLiteStore(path) as store:
        base = PathBase.load(store)
        with store.transaction():
            for y in range(3):
                base.add(np.array([[0, y], [1, y + 1], [2, y + 1]]),
                         {"cost": 1.0 + y, "length": 2.4, "risk": 0.0, "ideal": 2.4,
                          "traversals": 1})
            base.remove([int(base.ids[1])])
        assert path_problems(store) == []


@pytest.mark.parametrize(("risks", "problem"), [
    ({"3,2": 1.5}, "grid: meta 'grid.learned_risk' entry '3,2': risk 1.5; expected a number "
     "in [0, 1]"),
    ({"3,2": -0.1}, "risk -0.1; expected a number in [0, 1]"),
    ({"3,2": True}, "risk True; expected a number in [0, 1]"),
    ({"12,2": 0.5}, "entry '12,2': cell (12, 2) is outside the recorded 12x10 map"),
    ({"3,-1": 0.5}, "cell (3, -1) is outside the recorded 12x10 map"),
    ({"3,2": 0.5, "03,2": 0.5}, "entry '03,2': cell (3, 2) is listed twice (also as '3,2')"),
    ({"three": 0.5}, "entry 'three': expected a cell 'x,y' of two integers"),
    ([0.5], "meta 'grid.learned_risk' is a list; expected a mapping of 'x,y' cells to risks"),
])
def test_broken_learned_risks_fail_the_check(invoke_cbr: Callable[..., CliResult], path: Path,
                                             risks: Any, problem: str) -> None:
    with SQLiteStore(path) as store:
        record_map(store, GRID)
        store.set_meta(LEARNED_RISK, risks)
    result = check(invoke_cbr, path)
    assert result.exit_code == 1
    assert problem in result.stdout


def test_a_bad_map_record_is_named(path: Path) -> None:
    with SQLiteStore(path) as store:
        store.set_meta(MAP, {"width": 0, "height": 3})
        assert risk_problems(store) == [
            "meta 'grid.map' is {'width': 0, 'height': 3}; expected {'width': w, 'height': h} "
            "with positive integers"]


def test_every_broken_family_is_listed_together(invoke_cbr: Callable[..., CliResult],
                                                path: Path) -> None:
    sound(path)
    with SQLiteStore(path) as store:
        store.add(segment((0, 3), (0, 5)))   # a T onto the segment (0, 4)-(5, 4)
        store.add(path_case([[0, 0], [3, 3]]))
        store.set_meta(LEARNED_RISK, {"3,2": 2.0})
    result = check(invoke_cbr, path)
    assert result.exit_code == 1
    assert f"{path}: 3 problems:" in result.stdout
    for family in ("grid", "casegraph", "pathcases"):
        assert f"  - {family}: " in result.stdout
