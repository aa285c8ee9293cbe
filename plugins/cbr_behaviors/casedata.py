"""RUPART's cases from plain data and back: a case file's located tree, each part with where
it was read (:func:`build_case`, every problem reported with its line), a case stored in the
case base (:func:`from_case`, :func:`case_of`), and a set of cases as an exported case base
(:func:`document`).

A case's plain data is a mapping of its fields, one key naming its form and the case, as a
YAML case file writes it (:mod:`cbr_behaviors.casefiles` turns both file forms into such
trees); the cases themselves are :mod:`cbr_behaviors.casetypes`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import attrs
import yaml

from cbr_behaviors.casetypes import (
    BEHAVIOR,
    HAND_MADE,
    KINDS,
    META,
    PLAN,
    STRATEGY,
    AnyCase,
    BehaviorCase,
    CaseFormatError,
    Change,
    Item,
    PlanCase,
    Strategy,
    check_flag,
    check_item,
    check_name,
    check_route,
    strategy_problems,
)
from cbr_behaviors.index import Index, IndexDataError
from cbrcore.casebase.exchange import Document
from cbrcore.documents import found
from cbrcore.errors import CbrError
from cbrcore.model import Case
from cbrcore.names import name_problem

# --- from and to the case base ------------------------------------------------------------------


def _where(case: Case, source: str) -> str:
    return f"{source}, {case.kind} case {case.id}"


def from_case(case: Case, source: str = "case base") -> AnyCase:
    """The RUPART case stored in ``case`` (any of :data:`KINDS`); :class:`CaseFormatError`
    naming the case and what is wrong when it is malformed."""
    if case.kind not in KINDS:
        raise CaseFormatError(_where(case, source),
                              [f"not a RUPART case; expected a kind of {', '.join(KINDS)}"])
    meta = case.meta if isinstance(case.meta, Mapping) else {}
    fields: dict[str, Any] = {"origin": meta.get("origin", HAND_MADE)}
    if case.kind == STRATEGY:
        fields.update(case.problem if isinstance(case.problem, Mapping) else {})
        fields.update(case.solution if isinstance(case.solution, Mapping) else {})
        form = "alter-strategy" if fields.get("kind") == "alter" else "merge-strategy"
        fields.pop("kind", None)
    else:
        form = {BEHAVIOR: "behavior-case", META: "meta-plan", PLAN: "plan-case"}[case.kind]
        fields["index"] = case.problem
        fields.update(case.solution if isinstance(case.solution, Mapping) else {})
    fields = {form: meta.get("name"), **fields}
    try:
        return _direct(form, fields)
    except (CbrError, ValueError, KeyError, TypeError):
        # read again the way a file is, for a message that names the field and the item
        problems: list[str] = []
        if build_case(_unlocated(fields, f"{case.kind} case {case.id}"), problems) is not None:
            raise
        raise CaseFormatError(source, problems) from None


def _unlocated(value: Any, where: str) -> Located:
    """Plain data as :func:`_build` reads it, every part at ``where``."""
    if isinstance(value, Mapping):
        return Located(value, where, {k: _unlocated(v, where) for k, v in value.items()})
    if isinstance(value, list | tuple):
        return Located(value, where, {k: _unlocated(v, where) for k, v in enumerate(value)})
    return Located(value, where)


def _direct(form: str, fields: Mapping[str, Any]) -> AnyCase:
    """The case of a case base's fields, built without locating problems (a case base holds
    many cases, nearly always sound ones); raises on the first problem."""
    unknown = set(fields) - {form, *_KEYS[form]}
    if unknown:
        raise ValueError(f"unknown keys {sorted(unknown)}")
    name, origin = fields[form], fields.get("origin", HAND_MADE)
    if form == "merge-strategy":
        return Strategy(name, fields.get("adapts", "behavior"), "merge", high=fields["high"],
                        low=fields["low"], origin=origin)
    if form == "alter-strategy":
        return Strategy(name, fields.get("adapts", "behavior"), "alter", fields["feature"],
                        fields.get("sense", "any"), fields.get("min", 0.0),
                        [Change.from_data(c) for c in fields["changes"]], origin=origin)
    index = Index.from_data(fields.get("index", {}), "index")
    if form == "plan-case":
        return PlanCase(name, index, fields["route"], fields.get("localize", False), origin)
    return BehaviorCase(name, index, fields["behaviors"], form == "meta-plan", origin)


def case_of(case: Case, source: str = "case base") -> BehaviorCase | PlanCase:
    """The behavior case, meta-plan or plan case stored in ``case``."""
    decoded = from_case(case, source)
    if isinstance(decoded, Strategy):
        raise CaseFormatError(_where(case, source),
                              ["expected a behavior case, meta-plan or plan case"])
    return decoded


def strategy_of(case: Case, source: str = "case base") -> Strategy:
    """The strategy stored in ``case``; :class:`CaseFormatError` naming the case and what is
    wrong when it is malformed."""
    decoded = from_case(case, source)
    if not isinstance(decoded, Strategy):
        raise CaseFormatError(_where(case, source), [f"expected a {STRATEGY} case"])
    return decoded


def document(cases: Iterable[AnyCase]) -> Document:
    """``cases`` as an exported case base (ids from 1, all created at revision 1)."""
    stored = tuple(attrs.evolve(c.to_case(), id=k, created=1)
                   for k, c in enumerate(cases, start=1))
    return Document(revision=1, cases=stored)


# --- cases from plain data, each part with where it was read -------------------------------------


@attrs.frozen
class Located:
    """A value read from a file with where it was: ``where`` (``line N``, with the YAML path)
    and ``text`` (the value as the file wrote it); ``parts`` the located elements of a list
    (by position) or mapping (by key)."""

    value: Any
    where: str
    parts: Mapping[Any, Located] = attrs.field(factory=dict)
    text: str = ""

    def part(self, key: Any) -> Located:
        return self.parts.get(key, self)

    @property
    def shown(self) -> str:
        return self.text or flow_text(self.value)


def flow_text(value: Any) -> str:
    """``value`` as one line of YAML flow style, the way problems show data."""
    text = yaml.safe_dump(value, default_flow_style=True, width=math.inf, sort_keys=False)
    return text.removesuffix("...\n").strip()


FORMS = ("behavior-case", "meta-plan", "plan-case", "alter-strategy", "merge-strategy")
"""The forms of a case file."""
_KEYS: dict[str, tuple[str, ...]] = {
    "behavior-case": ("index", "behaviors", "origin"),
    "meta-plan": ("index", "behaviors", "origin"),
    "plan-case": ("index", "route", "localize", "origin"),
    "alter-strategy": ("adapts", "feature", "sense", "min", "changes", "origin"),
    "merge-strategy": ("adapts", "high", "low", "origin"),
}
_REQUIRED: dict[str, tuple[str, ...]] = {
    "behavior-case": ("behaviors",), "meta-plan": ("behaviors",), "plan-case": ("route",),
    "alter-strategy": ("feature", "changes"), "merge-strategy": ("high", "low"),
}


class _Problems:
    """Collects the problems of one case, each with where it is and what it is about."""

    def __init__(self, out: list[str], subject: str) -> None:
        self.out = out
        self.subject = subject
        self.count = 0

    def add(self, at: Located, problem: str, about: str = "") -> None:
        self.out.append(f"{at.where}: {self.subject}{about}: {problem}")
        self.count += 1

    def check(self, at: Located, check: Callable[[Any], Any], about: str = "") -> Any:
        try:
            return check(at.value)
        except ValueError as exc:
            self.add(at, str(exc), about)
            return None


def build_case(tree: Located, out: list[str]) -> AnyCase | None:
    """The case a located mapping describes, or None with its problems added to ``out``."""
    fields = tree.value
    # an item that is not a case may be any file's line, a secret's: it is not quoted, nor are
    # keys that are not the forms' (the rule of cbrcore.documents.found)
    if not isinstance(fields, Mapping):
        out.append(f"{tree.where}: expected a case (a mapping whose first key is one of "
                   f"{', '.join(FORMS)}), got {found(fields)}")
        return None
    forms = [k for k in fields if k in FORMS]
    if len(forms) != 1:
        got = " and ".join(forms) if forms else "none"
        out.append(f"{tree.where}: expected exactly one of {', '.join(FORMS)} naming the case, "
                   f"got {got}")
        return None
    form = forms[0]
    name = fields[form]
    problems = _Problems(out, f"{form} {name}")
    if not isinstance(name, str) or not name:
        problems.subject = form
        problems.add(tree.part(form), f"expected a name (a non-empty string), got {name!r}")
    elif name_problem(name) is not None:
        problems.subject = form  # the name itself would print the character
        problems.add(tree.part(form), f"expected a name, but {name_problem(name)}")
    for key in fields:
        if key != form and key not in _KEYS[form]:
            problems.add(tree.part(key), f"unknown key {key!r}; expected {', '.join(_KEYS[form])}")
    for key in _REQUIRED[form]:
        if key not in fields:
            problems.add(tree, f"{key} is missing")
    if problems.count:
        return None
    origin = problems.check(tree.part("origin"), check_name, ", origin") if "origin" in fields \
        else HAND_MADE
    if form in ("alter-strategy", "merge-strategy"):
        return _strategy(form, name, origin, tree, problems)
    index = _index(tree.part("index"), fields.get("index", {}), problems)
    if form == "plan-case":
        route = problems.check(tree.part("route"), check_route, ", route")
        localize = (problems.check(tree.part("localize"), check_flag, ", localize")
                    if "localize" in fields else False)
        if problems.count:
            return None
        return PlanCase(name, index, route, bool(localize), origin)
    behaviors = _items(tree.part("behaviors"), problems)
    if problems.count:
        return None
    return BehaviorCase(name, index, behaviors, form == "meta-plan", origin)


def _index(at: Located, data: Any, problems: _Problems) -> Index:
    if not isinstance(data, Mapping):
        problems.add(at, f"expected a mapping of feature -> value, got {at.shown}", ", index")
        return Index()
    for feature, value in data.items():
        try:
            Index.from_data({feature: value}, "index")
        except IndexDataError as exc:
            problems.add(at.part(feature), exc.problem, f", index feature {feature}")
    if problems.count:
        return Index()
    return Index.from_data(data, "index")


def _items(at: Located, problems: _Problems) -> tuple[Item, ...]:
    items = at.value
    if isinstance(items, str) or not isinstance(items, Sequence) or not items:
        problems.add(at, f"expected a list of one or more behaviors, got {at.shown}",
                     ", behaviors")
        return ()
    checked = []
    for k, item in enumerate(items):
        where = at.part(k)
        try:
            checked.append(check_item(item))
        except ValueError as exc:
            problems.add(where, str(exc), f", item {k} {where.shown}")
    return tuple(checked)


def _strategy(form: str, name: str, origin: str, tree: Located,
              problems: _Problems) -> Strategy | None:
    kind = form.removesuffix("-strategy")
    fields = {**tree.value, "kind": kind}
    for key, problem in strategy_problems(fields):
        problems.add(tree.part(key), problem, f", {key}")
    changes: list[Change] = []
    if kind == "alter":
        at = tree.part("changes")
        if isinstance(at.value, str) or not isinstance(at.value, Sequence) or not at.value:
            problems.add(at, f"expected a list of one or more changes, got {at.shown}",
                         ", changes")
        else:
            for k, data in enumerate(at.value):
                where = at.part(k)
                try:
                    changes.append(Change.from_data(data))
                except ValueError as exc:
                    problems.add(where, str(exc), f", change {k} {where.shown}")
    if problems.count:
        return None
    adapts = fields.get("adapts", "behavior")
    if kind == "merge":
        return Strategy(name, adapts, "merge", high=fields["high"], low=fields["low"],
                        origin=origin)
    return Strategy(name, adapts, "alter", fields["feature"], fields.get("sense", "any"),
                    fields.get("min", 0.0), changes, origin=origin)
