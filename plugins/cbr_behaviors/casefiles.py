"""RUPART's case files (004): the cases of :mod:`cbr_behaviors.casetypes` in 004's s-expression
form or in YAML, read with the line of every problem (each form read into a located tree that
:func:`cbr_behaviors.casedata.build_case` makes a case of), and written.

A case file is a sequence of forms. In the s-expression form (``.sexp``)::

    ; 004 Figure 4 (a): an open area with few obstacles
    (behavior-case open-area
      (plan-index (sonar 3.0) (behaviors goToPos avoidCollision))
      (((goStraight mod-fast curr-head) med)
       ((avoidObstacle 150 moderate) med)
       ((goToPos curr-goal mod-fast 100) high)
       ((avoidCollision 50 mod-fast) high)))

    (meta-plan move-away (plan-index (behav-conf 0.1)) (((moveForward slow) high)))

    (plan-case west-to-east
      (plan-index (location 0.75 5.0) (task-loc 15.25 5.0))
      (route hall_west hall_east)
      (localize))

    (alter-strategy slow-when-closer
      (adapts behavior) (feature sonar) (sense closer) (min 0.05)
      (change (moveForward goStraight goToPos) speed -1.0))

    (merge-strategy merge-mismatch (adapts behavior) (high 0.6) (low 0.2))

``(plan-index ...)`` holds one ``(FEATURE VALUE ...)`` clause per specified feature (Figure 5's
names; a sonar of one number stands for all 16 beams); the behavior list holds Figure 4's
items ``((NAME ARG ...) PRIORITY)`` (centimetres, symbolic values as
:mod:`cbr_world2d.pilots.behaviors` names them; a position ``(x y)``). Every form may end with
``(origin NAME)``; ``(localize)`` marks a plan that localizes first; a change is
``(change BEHAVIORS TARGET SCALE)`` with BEHAVIORS a list of behavior names or ``*`` (all).

In YAML (``.yaml``) the same cases are a list of mappings, the form's name as the first key::

    - behavior-case: open-area
      index: {sonar: 3.0, behaviors: [goToPos, avoidCollision]}
      behaviors:
      - [[goStraight, mod-fast, curr-head], med]
      - [[avoidObstacle, 150, moderate], med]
    - plan-case: west-to-east
      index: {location: [0.75, 5.0], task-loc: [15.25, 5.0]}
      route: [hall_west, hall_east]
      localize: true
    - alter-strategy: slow-when-closer
      adapts: behavior
      feature: sonar
      sense: closer
      min: 0.05
      changes:
      - {behaviors: [moveForward, goStraight, goToPos], target: speed, scale: -1.0}
    - merge-strategy: merge-mismatch
      high: 0.6
      low: 0.2

(``adapts`` defaults to ``behavior``, ``sense`` to ``any``, ``min`` to 0, ``origin`` to
``hand-made``, the index to none.) A file is validated whole before anything is returned:
:class:`CaseFormatError` lists every problem with its line (and in YAML its path) and the item
it is about. An exported case base (:mod:`cbrcore.casebase.exchange`) reads as a case file too.

The shipped initial memory is ``cases/rupart.sexp``; ``cases/rupart.yaml`` is the same as an
exported case base for a store's ``initial`` option, written by :func:`export`
(``python -c "from cbr_behaviors.casefiles import export; export()"``).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import yaml

from cbr_behaviors import sexpr
from cbr_behaviors.casedata import FORMS, Located, build_case, document, from_case
from cbr_behaviors.casetypes import (
    ALL,
    HAND_MADE,
    KINDS,
    AnyCase,
    CaseFormatError,
    PlanCase,
    Strategy,
    index_data,
)
from cbr_behaviors.index import FRACTIONS
from cbrcore import files
from cbrcore.casebase.exchange import document_from_data, dump_document
from cbrcore.documents import DocumentError, compose_yaml, construct_yaml, found, read_text

# --- reading files -------------------------------------------------------------------------------


def _parse_cases(trees: Sequence[Located], source: str) -> tuple[AnyCase, ...]:
    problems: list[str] = []
    cases: list[AnyCase] = []
    named: dict[str, str] = {}
    for tree in trees:
        case = build_case(tree, problems)
        if case is None:
            continue
        if case.name in named:
            problems.append(f"{tree.where}: a second case named {case.name!r} (the first is at "
                            f"{named[case.name]})")
        named.setdefault(case.name, tree.where)
        cases.append(case)
    if problems:
        raise CaseFormatError(source, problems)
    return tuple(cases)


# s-expressions

_CLAUSES: dict[str, tuple[str, ...]] = {
    "behavior-case": ("plan-index", "origin"),
    "meta-plan": ("plan-index", "origin"),
    "plan-case": ("plan-index", "route", "localize", "origin"),
    "alter-strategy": ("adapts", "feature", "sense", "min", "change", "origin"),
    "merge-strategy": ("adapts", "high", "low", "origin"),
}


def _line(node: sexpr.Node) -> str:
    return f"line {node.line}"


class _SexpForm:
    """Turns one form of a ``.sexp`` file into the located mapping :func:`_build` reads, or
    records why it cannot."""

    def __init__(self, node: sexpr.Node, problems: list[str]) -> None:
        self.node = node
        self.problems = problems

    def problem(self, at: sexpr.Node, message: str) -> None:
        self.problems.append(f"{_line(at)}: {message}")

    def tree(self) -> Located | None:
        node = self.node
        head = node.items[0].symbol if node.items else None
        if head not in FORMS:
            # a file that is not a case file may be a secret: its text is not quoted, and the
            # column tells apart the words of one line
            self.problems.append(f"{_line(node)}, column {node.column}: expected a case form, "
                                 f"one of ({' ...), ('.join(FORMS)} ...), got "
                                 f"{found(node.plain())}")
            return None
        if len(node.items) < 2 or node.items[1].is_list:
            self.problem(node, f"{head}: expected a name after {head}")
            return None
        name = node.items[1]
        subject = f"{head} {name.plain()}"
        fields: dict[str, Any] = {head: name.plain()}
        parts: dict[str, Located] = {head: Located(name.plain(), _line(name))}
        seen: dict[str, sexpr.Node] = {}
        changes: list[Located] = []
        for clause in node.items[2:]:
            items = clause.items
            listed = head in ("behavior-case", "meta-plan")
            if listed and clause.is_list and (not items or items[0].is_list):
                key, located = "behaviors", self._behaviors(clause)
            elif clause.is_list and items and items[0].symbol in _CLAUSES[head]:
                key = items[0].symbol or ""
                located = self._clause(key, clause, subject)
                if located is None:
                    continue
            else:
                known = ", ".join(f"({c} ...)" for c in _CLAUSES[head])
                extra = " or the behavior list" if listed else ""
                self.problem(clause, f"{subject}: unexpected {clause.text()}; expected {known}"
                                     f"{extra}")
                continue
            if key == "change":
                changes.append(located)
                continue
            key = "index" if key == "plan-index" else key
            if key in seen:
                what = "behavior list" if key == "behaviors" else f"({items[0].text()} ...) clause"
                self.problem(clause, f"{subject}: a second {what} (the first at line "
                                     f"{seen[key].line})")
                continue
            seen[key] = clause
            fields[key] = located.value
            parts[key] = located
        if changes:
            fields["changes"] = [c.value for c in changes]
            parts["changes"] = Located(fields["changes"], changes[0].where,
                                        dict(enumerate(changes)))
        return Located(fields, _line(node), parts, node.text())

    def _behaviors(self, clause: sexpr.Node) -> Located:
        parts = {k: Located(item.plain(), _line(item), text=item.text())
                 for k, item in enumerate(clause.items)}
        return Located(clause.plain(), _line(clause), parts, clause.text())

    def _clause(self, key: str, clause: sexpr.Node, subject: str) -> Located | None:
        args = clause.items[1:]
        where = _line(clause)
        if key == "plan-index":
            return self._index(clause, subject)
        if key == "localize":
            if args:
                self.problem(clause, f"{subject}: (localize) takes nothing, got {clause.text()}")
                return None
            return Located(True, where, text=clause.text())
        if key == "route":
            return Located([a.plain() for a in args], where, text=clause.text())
        if key == "change":
            if len(args) != 3:
                self.problem(clause, f"{subject}: expected (change BEHAVIORS TARGET SCALE), got "
                                     f"{clause.text()}")
                return None
            behaviors, target, scale = (a.plain() for a in args)
            return Located({"behaviors": behaviors, "target": target, "scale": scale}, where,
                            text=clause.text())
        if len(args) != 1 or args[0].is_list:
            self.problem(clause, f"{subject}: expected ({key} VALUE), got {clause.text()}")
            return None
        return Located(args[0].plain(), where, text=clause.text())

    def _index(self, clause: sexpr.Node, subject: str) -> Located | None:
        data: dict[str, Any] = {}
        parts: dict[str, Located] = {}
        for entry in clause.items[1:]:
            feature = entry.items[0].symbol if entry.items else None
            if feature is None:
                self.problem(entry, f"{subject}: index: expected (FEATURE VALUE ...), got "
                                    f"{entry.text()}")
                continue
            if feature in data:
                self.problem(entry, f"{subject}: index: a second {feature} clause (the first "
                                    f"at {parts[feature].where})")
                continue
            values = [v.plain() for v in entry.items[1:]]
            # a fraction is one number, and so is the sonar shorthand; the rest are lists
            one = feature in FRACTIONS or (feature == "sonar" and len(values) == 1)
            data[feature] = values[0] if one and len(values) == 1 else values
            parts[feature] = Located(data[feature], _line(entry), text=entry.text())
        return Located(data, _line(clause), parts, clause.text())


def parse_sexp(text: str, source: str = "<text>") -> tuple[AnyCase, ...]:
    """The cases of a ``.sexp`` file's text; :class:`CaseFormatError` naming ``source``, the
    line and the item of every problem."""
    try:
        nodes = sexpr.read(text, source)
    except sexpr.SexprError as exc:
        raise CaseFormatError(source, [f"line {exc.line}: {exc.problem}"]) from None
    problems: list[str] = []
    trees = [t for t in (_SexpForm(n, problems).tree() for n in nodes) if t is not None]
    try:
        cases = _parse_cases(trees, source)
    except CaseFormatError as exc:
        problems += exc.problems
    if problems:
        raise CaseFormatError(source, sorted(problems, key=_line_number))
    return cases


def _line_number(problem: str) -> int:
    return int(problem.split(":", 1)[0].split()[1].rstrip(","))


# YAML


def _path(path: str, key: Any) -> str:
    return f"{path}[{key}]" if isinstance(key, int) else f"{path}.{key}" if path else str(key)


def _yaml_tree(node: yaml.Node, path: str, source: str, problems: list[str]) -> Located:
    where = f"line {node.start_mark.line + 1} ({path or 'the document'})"
    if isinstance(node, yaml.SequenceNode):
        parts = {k: _yaml_tree(n, _path(path, k), source, problems)
                 for k, n in enumerate(node.value)}
        return Located([p.value for p in parts.values()], where, parts)
    if isinstance(node, yaml.MappingNode):
        parts: dict[Any, Located] = {}
        for key_node, value_node in node.value:
            key = construct_yaml(key_node, source)
            if not isinstance(key, str):
                problems.append(f"line {key_node.start_mark.line + 1} ({path}): expected a "
                                f"name as the key, got {found(key)}")
                continue
            if key in parts:
                problems.append(f"line {key_node.start_mark.line + 1} ({_path(path, key)}): "
                                f"the key {key!r} is given twice")
                continue
            parts[key] = _yaml_tree(value_node, _path(path, key), source, problems)
        return Located({k: p.value for k, p in parts.items()}, where, parts)
    return Located(construct_yaml(node, source), where)


def parse_yaml(text: str, source: str = "<text>") -> tuple[AnyCase, ...]:
    """The cases of a YAML case file's text (a list of cases, or an exported case base);
    :class:`CaseFormatError` naming ``source``, the line, the path and the item of every
    problem."""
    try:
        root = compose_yaml(text, source)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = f"line {mark.line + 1}" if mark is not None else "line 1"
        raise CaseFormatError(source, [f"{line}: not valid YAML: "
                                       f"{getattr(exc, 'problem', None) or exc}"]) from None
    except DocumentError as exc:
        raise CaseFormatError(source, [exc.problem]) from None
    if isinstance(root, yaml.MappingNode):
        data = construct_yaml(root, source)
        if isinstance(data, Mapping) and "format" in data:
            return _exported(data, source, root)
    problems: list[str] = []
    if root is None:
        return ()
    if not isinstance(root, yaml.SequenceNode):
        # checked before anything inside is read: any file may be given, a secret, and none
        # of its text is quoted
        kind = "a mapping" if isinstance(root, yaml.MappingNode) else found(
            construct_yaml(root, source))
        mark = root.start_mark
        raise CaseFormatError(source, [f"line {mark.line + 1}, column {mark.column + 1} (the "
                                       f"document): expected a list of cases (or an exported "
                                       f"case base), got {kind}"])
    tree = _yaml_tree(root, "", source, problems)
    if problems:
        raise CaseFormatError(source, problems)
    return _parse_cases([tree.part(k) for k in range(len(tree.value))], source)


def _exported(data: Mapping[str, Any], source: str, root: yaml.Node) -> tuple[AnyCase, ...]:
    exported = document_from_data(data, source, root)
    problems: list[str] = []
    cases: list[AnyCase] = []
    for k, case in enumerate(exported.cases):
        if case.kind not in KINDS:
            continue
        try:
            cases.append(from_case(case, f"cases[{k}]"))
        except CaseFormatError as exc:
            problems += [f"{exc.source}: {p}" for p in exc.problems]
    if problems:
        raise CaseFormatError(source, problems)
    return tuple(cases)


Format = Literal["sexp", "yaml"]
_SUFFIXES: dict[str, Format] = {".sexp": "sexp", ".yaml": "yaml", ".yml": "yaml"}


def format_of(path: str | os.PathLike[str]) -> Format:
    """The case file format its extension calls for."""
    suffix = Path(path).suffix.lower()
    if suffix not in _SUFFIXES:
        raise CaseFormatError(str(path), [f"cannot tell the format from the extension "
                                          f"{suffix!r}; name the file .sexp, .yaml or .yml"])
    return _SUFFIXES[suffix]


def read_cases(path: str | os.PathLike[str], format: Format | None = None
               ) -> tuple[AnyCase, ...]:
    """The cases of the file at ``path`` (format from the extension unless given), all
    validated before any is returned."""
    fmt = format or format_of(path)
    try:
        text = read_text(path)
    except DocumentError as exc:
        raise CaseFormatError(str(path), [exc.problem]) from None
    except FileNotFoundError:
        raise CaseFormatError(str(path), ["no such file"]) from None
    except UnicodeDecodeError as exc:
        raise CaseFormatError(str(path), [f"not UTF-8 text ({exc.reason} at byte "
                                          f"{exc.start})"]) from None
    except OSError as exc:
        raise CaseFormatError(str(path), [f"cannot read it: {exc.strerror}"]) from None
    return parse_sexp(text, str(path)) if fmt == "sexp" else parse_yaml(text, str(path))


# --- writing files -------------------------------------------------------------------------------


def _sexp_value(feature: str, value: Any) -> list[Any]:
    return [feature, *value] if isinstance(value, list) else [feature, value]


def _sexp_form(case: AnyCase) -> list[Any]:
    if isinstance(case, Strategy):
        form: list[Any] = [f"{case.kind}-strategy", case.name, ["adapts", case.adapts]]
        if case.kind == "alter":
            form += [["feature", case.feature], ["sense", case.sense], ["min", case.min]]
            form += [["change", c.to_data()["behaviors"], c.target, c.scale]
                     for c in case.changes]
        else:
            form += [["high", case.high], ["low", case.low]]
    else:
        head = ("plan-case" if isinstance(case, PlanCase)
                else "meta-plan" if case.meta_plan else "behavior-case")
        form = [head, case.name]
        data = index_data(case.index)
        if data:
            form.append(["plan-index", *(_sexp_value(f, v) for f, v in data.items())])
        if isinstance(case, PlanCase):
            form.append(["route", *case.route])
            if case.localize:
                form.append(["localize"])
        else:
            form.append(case.items())
    if case.origin != HAND_MADE:
        form.append(["origin", case.origin])
    return form


def to_sexp(cases: Iterable[AnyCase]) -> str:
    """``cases`` as the text of a ``.sexp`` file, forms one blank line apart."""
    return "\n\n".join(sexpr.write(_sexp_form(c)) for c in cases) + "\n"


class _Flow(list):
    """A list written in YAML's flow style."""


class _FlowMap(dict):
    """A mapping written in YAML's flow style."""


class _Dumper(yaml.SafeDumper):
    def ignore_aliases(self, data: Any) -> bool:
        return True


_Dumper.add_representer(_Flow, lambda d, v: d.represent_sequence(
    "tag:yaml.org,2002:seq", v, flow_style=True))
_Dumper.add_representer(_FlowMap, lambda d, v: d.represent_mapping(
    "tag:yaml.org,2002:map", v, flow_style=True))


def _yaml_entry(case: AnyCase) -> dict[str, Any]:
    if isinstance(case, Strategy):
        entry: dict[str, Any] = {f"{case.kind}-strategy": case.name, "adapts": case.adapts}
        if case.kind == "alter":
            entry.update(feature=case.feature, sense=case.sense, min=case.min,
                         changes=[_FlowMap({**c.to_data(), "behaviors": (
                             ALL if c.behaviors == ALL else _Flow(c.behaviors))})
                             for c in case.changes])
        else:
            entry.update(high=case.high, low=case.low)
    else:
        head = ("plan-case" if isinstance(case, PlanCase)
                else "meta-plan" if case.meta_plan else "behavior-case")
        entry = {head: case.name}
        data = index_data(case.index)
        if data:
            entry["index"] = {f: _Flow(v) if isinstance(v, list) else v
                              for f, v in data.items()}
        if isinstance(case, PlanCase):
            entry["route"] = _Flow(case.route)
            if case.localize:
                entry["localize"] = True
        else:
            entry["behaviors"] = [_Flow(item) for item in case.items()]
    if case.origin != HAND_MADE:
        entry["origin"] = case.origin
    return entry


def to_entries(cases: Iterable[AnyCase]) -> list[dict[str, Any]]:
    """``cases`` as the entries of a YAML case file: plain lists and mappings."""
    return [_yaml_entry(c) for c in cases]


def to_yaml(cases: Iterable[AnyCase]) -> str:
    """``cases`` as the text of a YAML case file."""
    return yaml.dump(to_entries(cases), Dumper=_Dumper, sort_keys=False, allow_unicode=True,
                     width=100)


def write_cases(cases: Iterable[AnyCase], path: str | os.PathLike[str],
                format: Format | None = None) -> None:
    """Write ``cases`` to ``path`` as a case file (format from the extension unless given)."""
    fmt = format or format_of(path)
    text = to_sexp(cases) if fmt == "sexp" else to_yaml(cases)
    try:
        files.write_text(Path(path), text)
    except OSError as exc:
        raise CaseFormatError(str(path), [f"cannot write it: {exc.strerror or exc}"]) from exc


# --- the shipped memory --------------------------------------------------------------------------


def shipped_path(format: Format = "sexp") -> Path:
    """The shipped initial memory: the authored ``rupart.sexp`` or its export ``rupart.yaml``."""
    return Path(str(resources.files("cbr_behaviors") / "cases" / f"rupart.{format}"))


def shipped_cases() -> tuple[AnyCase, ...]:
    """The cases of the shipped initial memory."""
    return read_cases(shipped_path("sexp"))


def export(target: str | os.PathLike[str] | None = None,
           cases: Iterable[AnyCase] | None = None) -> Path:
    """Write ``cases`` (default: the shipped memory) as an exported case base (default:
    ``cases/rupart.yaml``, what a store's ``initial`` option loads); return where."""
    path = Path(target) if target is not None else shipped_path("yaml")
    chosen = shipped_cases() if cases is None else tuple(cases)
    files.write_text(path, dump_document(document(chosen), "yaml"))
    return path
