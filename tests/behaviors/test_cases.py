"""RUPART's case files (``cbr_behaviors.sexpr``, ``cbr_behaviors.casetypes``,
``cbr_behaviors.casedata``, ``cbr_behaviors.casefiles``, ``cbr rupart``).

004 Figure 4's two behavior sets are read as printed (with the typos of the text fixed:
``curt-head`` is ``curr-head``, ``i00`` is ``100``, and the priorities the extraction lost at
the end of each first line, ``med``) and checked against the same sets written by hand as
Python data. Round trips (s-expressions -> cases -> s-expressions, -> YAML -> cases, -> stored
case -> case) must give back what they started from; the s-expression writer against the
reader on random data (hypothesis). Every kind of bad input is checked for the exact file,
line (YAML: line and path) and item its message names.
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_behaviors import sexpr
from cbr_behaviors.casedata import case_of, document, from_case
from cbr_behaviors.casefiles import (
    export,
    parse_sexp,
    parse_yaml,
    read_cases,
    shipped_cases,
    shipped_path,
    to_sexp,
    to_yaml,
    write_cases,
)
from cbr_behaviors.casetypes import (
    BEHAVIOR,
    META,
    PLAN,
    STRATEGY,
    BehaviorCase,
    CaseFormatError,
    Change,
    PlanCase,
    Strategy,
)
from cbr_behaviors.index import Index
from cbr_stores.sqlite import SQLiteStore
from cbr_world2d.generate import office
from cbrcore.casebase.exchange import document_to_data, read_document
from cbrcore.model import Case
from cbrcore.plugins import Plugins
from cbrcore.testing import CliResult

FIGURE_4A = """\
(((goStraight mod-fast curr-head) med)
 ((avoidObstacle 150 moderate) med)
 ((goToPos curr-goal mod-fast 100) high)
 ((avoidCollision 50 mod-fast) high))"""

FIGURE_4B = """\
(((followWall curr-head) med)
 ((moveForward slow) med)
 ((slowAvoid 50 very-slow) med-high)
 ((avoidCollision 20 fast) high)
 ((goToPos curr-goal slow 100) med))"""

SET_4A = [[["goStraight", "mod-fast", "curr-head"], "med"],
          [["avoidObstacle", 150, "moderate"], "med"],
          [["goToPos", "curr-goal", "mod-fast", 100], "high"],
          [["avoidCollision", 50, "mod-fast"], "high"]]
SET_4B = [[["followWall", "curr-head"], "med"],
          [["moveForward", "slow"], "med"],
          [["slowAvoid", 50, "very-slow"], "med-high"],
          [["avoidCollision", 20, "fast"], "high"],
          [["goToPos", "curr-goal", "slow", 100], "med"]]


def behavior_case(name: str, index: str, figure: str) -> str:
    """A behavior-case form around a behavior set, laid out as the writer lays it out."""
    return (f"(behavior-case {name}\n  (plan-index {index})\n  "
            + figure.replace("\n", "\n  ") + ")")


FIGURES = "\n\n".join([
    behavior_case("open-area", "(sonar 3.0) (behaviors avoidCollision goToPos)", FIGURE_4A),
    behavior_case("crowded-hallway", "(sonar 1.0) (map object)", FIGURE_4B),
]) + "\n"


# --- s-expressions -------------------------------------------------------------------------------


def test_figure_4_sets_read_as_printed() -> None:
    assert [n.plain() for n in sexpr.read(FIGURE_4A)] == [SET_4A]
    assert [n.plain() for n in sexpr.read(FIGURE_4B)] == [SET_4B]


def test_reader_keeps_lines_and_kinds_of_atom() -> None:
    text = '; a comment (with a paren\n(a "b c" -3 2.5 .5 1e-05\n  ?x (\n"d\ne") f)'
    (node,) = sexpr.read(text)
    assert (node.line, node.column) == (2, 1)
    values = [item.value for item in node.items]
    assert values[:6] == [sexpr.Symbol("a"), "b c", -3, 2.5, 0.5, 1e-05]
    assert values[6] == sexpr.Symbol("?x")
    inner = node.items[7]
    assert (inner.line, inner.column) == (3, 6)
    assert (inner.items[0].value, inner.items[0].line) == ("d\ne", 4)
    # the line break inside the string counts
    assert (node.items[8].line, node.items[8].column) == (5, 5)


@pytest.mark.parametrize(("text", "message"), [
    ("(a\n (b c)\n", "f.sexp, line 1: the list opened at column 1 is never closed"),
    ("(a)\n  b)", "f.sexp, line 2: the ')' at column 4 closes nothing"),
    ('(a\n "b)', "f.sexp, line 2: a string opened here is never closed"),
    ('("a\\qb")', "f.sexp, line 1: unknown escape \\q in a string; known: "
                  '\\" \\\\ \\n \\t'),
])
def test_reader_names_the_line_of_a_parse_error(text: str, message: str) -> None:
    with pytest.raises(sexpr.SexprError) as raised:
        sexpr.read(text, "f.sexp")
    assert str(raised.value) == message


_atoms = (st.integers() | st.floats(allow_nan=False, allow_infinity=False)
          | st.text(max_size=8))
_data = st.recursive(_atoms, lambda inner: st.lists(inner, max_size=5), max_leaves=30)


@settings(max_examples=100, deadline=None)
@given(_data, st.integers(10, 100))
def test_writer_output_reads_back_as_the_same_data(value: object, width: int) -> None:
    (node,) = sexpr.read(sexpr.write(value, width))
    assert node.plain() == value


# --- the cases and their two forms ---------------------------------------------------------------


def test_figure_4_round_trips_through_both_forms() -> None:
    cases = parse_sexp(FIGURES, "figures.sexp")
    assert [c.items() for c in cases] == [SET_4A, SET_4B]
    assert cases[0].index == Index(sonar=3.0, behaviors=["goToPos", "avoidCollision"])
    assert to_sexp(cases) == FIGURES
    assert parse_yaml(to_yaml(cases), "figures.yaml") == cases
    assert tuple(case_of(c.to_case()) for c in cases) == cases


def test_every_form_round_trips() -> None:
    cases = (
        BehaviorCase("stuck", Index(behav_conf=0.0, motors=(0.0, 0.0)),
                     [[["turnTo", "curr-head", -90], "high"], [["turnTo", [300, 120.5]], 0.35]],
                     meta_plan=True, origin="adapted"),
        PlanCase("via west", Index(goal=["deliver", "room_1", "?p"], plan=[]),
                 ["hall_west", "room_1"], localize=True),
        Strategy("slow", "behavior", "alter", "sonar", "closer", 0.05,
                 [Change(("moveForward", "goToPos"), "speed", -1.5), Change("*", "priority", 0.5)]),
        Strategy("merge", "plan", "merge", high=0.7, low=0.1),
    )
    assert parse_sexp(to_sexp(cases)) == cases
    assert parse_yaml(to_yaml(cases)) == cases
    assert tuple(from_case(c.to_case()) for c in cases) == cases
    assert [c.to_case().kind for c in cases] == [META, PLAN, STRATEGY, STRATEGY]
    # a name that is no symbol is written in double quotes
    assert '(plan-case "via west"' in to_sexp(cases)


def test_files_are_read_and_written_by_their_extension(tmp_path: Path) -> None:
    cases = parse_sexp(FIGURES)
    write_cases(cases, tmp_path / "f.yml")
    write_cases(cases, tmp_path / "f.sexp")
    assert (tmp_path / "f.sexp").read_text() == FIGURES
    assert read_cases(tmp_path / "f.yml") == read_cases(tmp_path / "f.sexp") == cases
    with pytest.raises(CaseFormatError, match=r"f\.txt, cannot tell the format"):
        read_cases(tmp_path / "f.txt")
    with pytest.raises(CaseFormatError, match=r"missing\.sexp, no such file"):
        read_cases(tmp_path / "missing.sexp")


BAD_SEXP = [
    ("(behavior-case a (((goStraight mod-fast curr-head) med))", "line 1: the list opened at "
     "column 1 is never closed"),
    # what is not a case form may be any file's text, a secret's: it is not quoted
    ("(behavior-case a (((stop) high)))\nstray", "line 2, column 1: expected a case form, one "
     "of (behavior-case ...), (meta-plan ...), (plan-case ...), (alter-strategy ...), "
     "(merge-strategy ...), got a string"),
    ("(behavior-case a\n  (((stop) high)\n   ((flyAway 50) high)))",
     "line 3: behavior-case a, item 1 ((flyAway 50) high): unknown behavior 'flyAway'"),
    ("(behavior-case a\n  (((avoidObstacle 150 moderat) med)))",
     "line 2: behavior-case a, item 0 ((avoidObstacle 150 moderat) med): avoidObstacle "
     "speed: unknown speed 'moderat'"),
    ("(behavior-case a\n  (((stop) high)\n   ((goToPos curr-goal slow -100) high)))",
     "line 3: behavior-case a, item 1 ((goToPos curr-goal slow -100) high): goToPos accuracy: "
     "expected a distance > 0, got -100"),
    ("(behavior-case a (((stop) 1.5)))",
     "line 1: behavior-case a, item 0 ((stop) 1.5): stop priority: expected a priority in "
     "(0, 1], got 1.5"),
    ("(behavior-case a\n  (plan-index\n    (sonar 2.0)\n    (speed 3))\n  (((stop) high)))",
     "line 4: behavior-case a, index feature speed: unknown feature; expected one of sonar, "
     "motors, map, location, behaviors, task-loc, task-urgency, plan, goal, goal-urgency, "
     "pending-goals, loc-conf, plan-conf, behav-conf"),
    ("(behavior-case a (plan-index (loc-conf 2)) (((stop) high)))",
     "line 1: behavior-case a, index feature loc-conf: expected a number in [0, 1], got 2.0"),
    ("(behavior-case a (plan-index (sonar 1.0) (sonar 2.0)) (((stop) high)))",
     "line 1: behavior-case a: index: a second sonar clause (the first at line 1)"),
    ("(behavior-case a\n  (plan-index (sonar 1.0)))", "line 1: behavior-case a: behaviors is "
     "missing"),
    ("(plan-case p\n  (route hall_west)\n  (color red))", "line 3: plan-case p: unexpected "
     "(color red); expected (plan-index ...), (route ...), (localize ...), (origin ...)"),
    ("(plan-case p (route hall_west) (localize now))", "line 1: plan-case p: (localize) "
     "takes nothing, got (localize now)"),
    ("(alter-strategy s\n  (feature location) (sense closer)\n  (change * speed 1.0))",
     "line 2: alter-strategy s, sense: 'closer' compares the closeness of objects, which "
     "only sonar, map, front, left, right, rear, width, person, closing, door tell; use "
     "'any' for location"),
    ("(alter-strategy s (feature sonar)\n  (change (moveForward) distance 1.0))",
     "line 2: alter-strategy s, change 0 (change (moveForward) distance 1.0): moveForward has "
     "no distance argument"),
    ("(alter-strategy s (feature sonar) (min 2) (change * speed 1.0))",
     "line 1: alter-strategy s, min: expected a number in [0, 1], got 2"),
    ("(merge-strategy m (high 0.2) (low 0.6))",
     "line 1: merge-strategy m, low: expected low < high, got low 0.6 and high 0.2"),
    ("(behavior-case a (((stop) high)))\n(plan-case a (route hall_west))",
     "line 2: a second case named 'a' (the first is at line 1)"),
]


@pytest.mark.parametrize(("text", "message"), BAD_SEXP)
def test_a_bad_sexp_file_names_line_and_item(text: str, message: str) -> None:
    with pytest.raises(CaseFormatError) as raised:
        parse_sexp(text, "bad.sexp")
    assert str(raised.value).startswith(f"bad.sexp, {message}")


def test_a_bad_file_lists_every_problem_in_line_order() -> None:
    text = "\n".join(f"(behavior-case b{k} (((stop) {k + 1}.5)))" for k in range(3))
    with pytest.raises(CaseFormatError) as raised:
        parse_sexp(text + "\n(oops)", "bad.sexp")
    lines = str(raised.value).splitlines()
    assert lines[0] == "bad.sexp: 4 problems:"
    assert [line.split(":")[0] for line in lines[1:]] == [
        "  - line 1", "  - line 2", "  - line 3", "  - line 4, column 1"]


YAML_CASES = """\
- behavior-case: a
  index:
    sonar: 2.0
    speed: 3
  behaviors:
  - [[stop], high]
  - [[avoidObstacle, 150, moderat], med]
- plan-case: p
  route: [hall_west]
  color: red
- alter-strategy: s
  feature: sonar
  changes:
  - {behaviors: [moveForward], target: spd, scale: 1}
- just a string
"""


def test_a_bad_yaml_file_names_line_path_and_item() -> None:
    with pytest.raises(CaseFormatError) as raised:
        parse_yaml(YAML_CASES, "bad.yaml")
    problems = raised.value.problems
    assert problems[0].startswith("line 4 ([0].index.speed): behavior-case a, index feature "
                                  "speed: unknown feature")
    assert problems[1].startswith("line 7 ([0].behaviors[1]): behavior-case a, item 1 "
                                  "[[avoidObstacle, 150, moderat], med]: avoidObstacle speed: "
                                  "unknown speed 'moderat'")
    assert problems[2] == ("line 10 ([1].color): plan-case p: unknown key 'color'; expected "
                           "index, route, localize, origin")
    assert problems[3] == ("line 14 ([2].changes[0]): alter-strategy s, change 0 {behaviors: "
                           "[moveForward], target: spd, scale: 1}: target: expected one of "
                           "speed, distance, turn_rate, priority, got 'spd'")
    assert problems[4] == ("line 15 ([3]): expected a case (a mapping whose first key is one "
                           "of behavior-case, meta-plan, plan-case, alter-strategy, "
                           "merge-strategy), got a string")
    assert len(problems) == 5


@pytest.mark.parametrize(("text", "message"), [
    ("- behavior-case: a\n  behaviors: [[[stop], high]\n", "bad.yaml, line 3: not valid YAML"),
    ("- plan-case: p\n  route: [a]\n  route: [b]\n",
     "bad.yaml, line 3 ([0].route): the key 'route' is given twice"),
    ("plan-case: p\n", "bad.yaml, line 1, column 1 (the document): expected a list of cases "
     "(or an exported case base), got a mapping"),
])
def test_yaml_that_is_no_list_of_cases(text: str, message: str) -> None:
    with pytest.raises(CaseFormatError) as raised:
        parse_yaml(text, "bad.yaml")
    assert str(raised.value).startswith(message)


def test_a_malformed_stored_case_names_the_case() -> None:
    stored = Case({"sonar": 1.0}, {"behaviors": [[["stop"], "urgent"]]}, kind=BEHAVIOR,
                  meta={"name": "x"}, id=7)
    with pytest.raises(CaseFormatError) as raised:
        case_of(stored, "cb.sqlite")
    assert str(raised.value).startswith("cb.sqlite, behavior_case case 7: behavior-case x, "
                                        "item 0 [[stop], urgent]: stop priority: unknown "
                                        "priority 'urgent'")


# --- the shipped memory ---------------------------------------------------------------------------


def test_the_shipped_memory_holds_the_papers_initial_cases() -> None:
    cases = shipped_cases()
    kinds = Counter(c.to_case().kind for c in cases)
    # 004: "10-15 behavior cases, 5 planning cases" and "a small set of meta-plans" and of
    # adaptation strategies
    assert 10 <= kinds[BEHAVIOR] <= 15 and kinds[PLAN] == 5 and kinds[META] == 3
    strategies = Counter(c.kind for c in cases if isinstance(c, Strategy))
    assert strategies["alter"] >= 2 and strategies["merge"] == 1
    places = office(0).places
    for case in cases:
        if isinstance(case, PlanCase):
            assert set(case.route) <= set(places), case.name
    names = {c.name for c in cases}
    assert {"open-area", "crowded-hallway", "move-away", "localize-here",
            "turn-and-look"} <= names


def test_the_shipped_export_is_current(tmp_path: Path) -> None:
    # cases/rupart.yaml is written by cbr_behaviors.casefiles.export
    assert export(tmp_path / "x.yaml").read_text() == shipped_path("yaml").read_text()
    exported = read_document(shipped_path("yaml"))
    assert document_to_data(exported) == document_to_data(document(shipped_cases()))
    assert parse_yaml(shipped_path("yaml").read_text()) == shipped_cases()


# --- cbr rupart ----------------------------------------------------------------------------------

Cli = Callable[..., CliResult]


@pytest.fixture
def cli(cbr_plugins: Callable[..., Plugins], invoke_cbr: Cli) -> Cli:
    """``cbr`` with the installed plugins, ``rupart`` among them."""
    cbr_plugins(entry_points=True)
    return invoke_cbr


def test_add_stores_every_case_of_good_files(cli: Cli, tmp_path: Path) -> None:
    (tmp_path / "figures.yaml").write_text(to_yaml(parse_sexp(FIGURES)))
    store = f"{{use: sqlite, path: {tmp_path / 'cb.sqlite'}}}"
    result = cli("rupart", "add", str(shipped_path()), str(tmp_path / "figures.yaml"),
                     "--store", store)
    assert result.exit_code == 0, result.stderr
    kinds = Counter(c.to_case().kind for c in (*shipped_cases(), *parse_sexp(FIGURES)))
    listed = ", ".join(f"{kinds[k]} {k}" for k in (BEHAVIOR, PLAN, META, STRATEGY))
    assert f"added {kinds.total()} cases ({listed})" in result.stdout
    with SQLiteStore(tmp_path / "cb.sqlite") as sqlite:
        assert sqlite.revision == 1
        stored = [from_case(c) for c in sqlite.cases()]
    assert sorted(c.name for c in stored) == sorted(
        c.name for c in (*shipped_cases(), *parse_sexp(FIGURES)))


def test_add_with_a_bad_file_stores_nothing(cli: Cli, tmp_path: Path) -> None:
    store = f"{{use: sqlite, path: {tmp_path / 'cb.sqlite'}}}"
    assert cli("rupart", "add", str(shipped_path()), "--store", store).exit_code == 0
    bad = tmp_path / "bad.sexp"
    bad.write_text("(behavior-case a\n  (((flyAway) high)))\n")
    result = cli("rupart", "add", str(shipped_path()), str(bad), "--store", store)
    assert result.exit_code == 2
    assert result.stderr.startswith(f"error: {bad}, line 2: behavior-case a, item 0 "
                                    "((flyAway) high): unknown behavior 'flyAway'")
    assert "Traceback" not in result.stderr
    with SQLiteStore(tmp_path / "cb.sqlite") as sqlite:
        assert (sqlite.revision, len(sqlite)) == (1, len(shipped_cases()))


def test_add_needs_one_store(cli: Cli) -> None:
    result = cli("rupart", "add", str(shipped_path()))
    assert result.exit_code == 2
    assert "name the case base with one of them" in result.stderr


@pytest.mark.parametrize("fmt", ["sexp", "yaml"])
def test_show_prints_either_form(cli: Cli, tmp_path: Path, fmt: str) -> None:
    (tmp_path / "figures.sexp").write_text(FIGURES)
    result = cli("rupart", "show", str(tmp_path / "figures.sexp"), "--format", fmt)
    assert result.exit_code == 0, result.stderr
    parse = parse_sexp if fmt == "sexp" else parse_yaml
    assert parse(result.stdout) == parse_sexp(FIGURES)


def test_show_json_holds_the_entries_of_the_yaml_form(cli: Cli, tmp_path: Path) -> None:
    (tmp_path / "figures.sexp").write_text(FIGURES)
    result = cli("rupart", "show", str(tmp_path / "figures.sexp"), "--json")
    assert result.exit_code == 0, result.stderr
    entries = json.loads(result.stdout)["cases"]
    assert entries == yaml.safe_load(cli("rupart", "show", str(tmp_path / "figures.sexp"),
                                         "--format", "yaml").stdout)
    # the entries are a case file in their own right, holding the same cases
    (tmp_path / "again.yaml").write_text(yaml.safe_dump(entries))
    assert parse_yaml((tmp_path / "again.yaml").read_text()) == parse_sexp(FIGURES)
