"""RUPART's cases (004): behavior cases, plan cases, meta-plans and adaptation strategies, in one
case memory; :mod:`cbr_behaviors.casefiles` reads and writes them as case files.

The kinds (``Case.kind`` in the case base): :data:`BEHAVIOR`, :data:`PLAN`, :data:`META` (a
meta-plan: a generic behavior case retrieved when nothing matches well) and :data:`STRATEGY`.
A behavior case, plan case or meta-plan stores its index (:class:`~cbr_behaviors.index.Index`,
Figure 5) as ``problem`` and its content as ``solution``; ``meta`` holds ``name`` and
``origin`` (``hand-made``, ``adapted``, ...) beside the quality counters the learn steps keep
(:mod:`cbr_behaviors.quality`). A strategy stores what it is indexed by (the kind of case it
adapts and the per-feature distances it answers) as ``problem``, its changes as ``solution``.

A case is built from plain data (a mapping of its fields, one key naming its form and the case,
as a YAML case file writes it) by :func:`cbr_behaviors.casedata.build_case`, which reports every
problem with where it was read; a stored case is read back by
:func:`cbr_behaviors.casedata.from_case`. The checks below raise ValueError saying what was
expected; the classes and the readers add where.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Literal

import attrs

from cbr_behaviors.index import FEATURES, Index
from cbr_world2d.pilots.behaviors import BEHAVIORS, LENGTH_UNITS, parse_behavior
from cbrcore.errors import CbrError
from cbrcore.model import Case
from cbrcore.names import name_problem

BEHAVIOR = "behavior_case"
"""The case kind of a behavior case."""
PLAN = "plan_case"
"""The case kind of a plan case."""
META = "meta_plan"
"""The case kind of a meta-plan (a behavior case of generic, fall-back behaviors)."""
STRATEGY = "adaptation_strategy"
"""The case kind of an adaptation strategy."""
KINDS = (BEHAVIOR, PLAN, META, STRATEGY)

HAND_MADE = "hand-made"
"""The origin of an authored case."""

TARGETS = ("speed", "distance", "turn_rate", "priority")
"""What a :class:`Change` alters: the arguments of a kind (as
:data:`cbr_world2d.pilots.behaviors.ARGUMENTS` names them) or the priority."""
SENSES = ("closer", "farther", "any")
"""When an alter strategy holds: the query's objects closer than the case's, farther, or
either way."""
SENSED = ("sonar", "map", "front", "left", "right", "rear", "width", "person", "closing",
          "door")
"""The features whose closeness a sense other than ``any`` compares: the sonar's ranges, the
names near the robot, the sectors' nearest readings, the free width, the nearest person's
distance and closing speed, the doorway's distance."""
ALL = "*"
"""A change's behaviors meaning every behavior of the set."""

Item = tuple[tuple[Any, ...], Any]
"""One behavior of a set, 004 Figure 4's ``((name arg ...) priority)`` as tuples."""


class CaseFormatError(CbrError):
    """Case data that cannot be used; ``problems`` holds one line per problem, each naming
    where it is (line, path) and the item."""

    def __init__(self, source: str, problems: Sequence[str]) -> None:
        self.source = source
        self.problems = list(problems)
        if len(self.problems) == 1:
            message = f"{source}, {self.problems[0]}"
        else:
            lines = "\n".join(f"  - {p}" for p in self.problems)
            message = f"{source}: {len(self.problems)} problems:\n{lines}"
        super().__init__(message)


# --- checks shared by the classes and the file readers -----------------------------------------
# each raises ValueError saying what was expected; the readers add where


def freeze(value: Any) -> Any:
    """``value`` with every list made a tuple, nested ones too: behavior items compare and
    hash alike however they were written."""
    if isinstance(value, list | tuple):
        return tuple(freeze(v) for v in value)
    return value


def _thaw(value: Any) -> Any:
    if isinstance(value, tuple | list):
        return [_thaw(v) for v in value]
    return value


def check_name(value: Any) -> str:
    if not isinstance(value, str) or not value:
        raise ValueError(f"expected a name (a non-empty string), got {value!r}")
    problem = name_problem(value)
    if problem is not None:
        raise ValueError(f"expected a name, but {problem}")
    return value


def _number(value: Any, expected: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"expected {expected}, got {value!r}")
    return float(value)


def _fraction(value: Any) -> float:
    number = _number(value, "a number in [0, 1]")
    if not 0.0 <= number <= 1.0:
        raise ValueError(f"expected a number in [0, 1], got {value!r}")
    return number


def _choice(value: Any, choices: Sequence[str]) -> str:
    if value not in choices:
        raise ValueError(f"expected one of {', '.join(choices)}, got {value!r}")
    return value


def check_item(item: Any) -> Item:
    """One behavior item, checked by parsing it as the ``behaviors`` pilot does."""
    parse_behavior(item, LENGTH_UNITS["cm"])
    return freeze(item)


def _behaviors(items: Any) -> tuple[Item, ...]:
    if isinstance(items, str) or not isinstance(items, Sequence) or not items:
        raise ValueError(f"expected a list of one or more behaviors, got {items!r}")
    checked = []
    for k, item in enumerate(items):
        try:
            checked.append(check_item(item))
        except ValueError as exc:
            raise ValueError(f"item {k}: {exc}") from None
    return tuple(checked)


def check_route(value: Any) -> tuple[str, ...]:
    if isinstance(value, str) or not isinstance(value, Sequence) or not value:
        raise ValueError(f"expected a list of one or more place names, got {value!r}")
    return tuple(check_name(v) for v in value)


def check_flag(value: Any) -> bool:
    if not isinstance(value, bool):
        raise ValueError(f"expected true or false, got {value!r}")
    return value


def params_of(name: str, arity: int) -> tuple[tuple[str, str], ...] | None:
    """The arguments ``(keyword, kind)`` of the behavior ``name`` taking ``arity`` arguments,
    None when there is no such behavior."""
    signature = BEHAVIORS.get(name, {}).get(arity)
    return None if signature is None else signature.params


def _kinds_of(name: str) -> set[str]:
    """The argument kinds of the behavior ``name``, over all its signatures."""
    return {kind for signature in BEHAVIORS.get(name, {}).values()
            for _, kind in signature.params}


# --- the cases ---------------------------------------------------------------------------------


def _validated(check: Callable[[Any], Any]) -> Callable[[Any, attrs.Attribute, Any], None]:
    def validate(instance: Any, attribute: attrs.Attribute, value: Any) -> None:
        try:
            check(value)
        except ValueError as exc:
            raise CaseFormatError(f"{type(instance).__name__} {instance.name!r}",
                                  [f"{attribute.name}: {exc}"]) from None
    return validate


@attrs.frozen
class BehaviorCase:
    """A behavior case (004 Figure 4): which behaviors to activate, with their parameters
    (centimetres, symbolic values allowed) and priorities, in the situation ``index``
    describes. A meta-plan is a behavior case with ``meta_plan`` set."""

    name: str = attrs.field(validator=_validated(check_name))
    index: Index
    behaviors: tuple[Item, ...] = attrs.field(converter=freeze,
                                              validator=_validated(_behaviors))
    meta_plan: bool = attrs.field(default=False, validator=_validated(check_flag))
    origin: str = attrs.field(default=HAND_MADE, validator=_validated(check_name))

    @property
    def kind(self) -> str:
        return META if self.meta_plan else BEHAVIOR

    def items(self) -> list[Any]:
        """The behavior set as plain data (lists), as the ``behaviors`` pilot reads it."""
        return _thaw(self.behaviors)

    def to_case(self) -> Case:
        return Case(index_data(self.index), {"behaviors": self.items()}, kind=self.kind,
                    meta={"name": self.name, "origin": self.origin})


@attrs.frozen
class PlanCase:
    """A plan case: a route through places of the world (waypoints, by name, checked against
    a world only when used), localizing first when ``localize``."""

    name: str = attrs.field(validator=_validated(check_name))
    index: Index
    route: tuple[str, ...] = attrs.field(converter=freeze, validator=_validated(check_route))
    localize: bool = attrs.field(default=False, validator=_validated(check_flag))
    origin: str = attrs.field(default=HAND_MADE, validator=_validated(check_name))

    kind = PLAN

    def to_case(self) -> Case:
        return Case(index_data(self.index), {"route": list(self.route),
                                             "localize": self.localize},
                    kind=PLAN, meta={"name": self.name, "origin": self.origin})


def _change_behaviors(value: Any) -> tuple[str, ...] | Literal["*"]:
    if value == ALL:
        return ALL
    names = (value,) if isinstance(value, str) else value
    if not isinstance(names, Sequence) or not names:
        raise ValueError(f"expected {ALL!r}, a behavior name or a list of them, got {value!r}")
    for name in names:
        if name not in BEHAVIORS:
            raise ValueError(f"unknown behavior {name!r}; known: {', '.join(sorted(BEHAVIORS))}")
    return tuple(names)


def _change(behaviors: Any, target: Any, scale: Any
            ) -> tuple[tuple[str, ...] | Literal["*"], str, float]:
    """The fields of a :class:`Change`, checked; ValueError saying what is wrong."""
    names = _change_behaviors(behaviors)
    try:
        _choice(target, TARGETS)
    except ValueError as exc:
        raise ValueError(f"target: {exc}") from None
    number = _number(scale, "a finite number as the scale")
    if names != ALL and target != "priority":
        for name in names:
            if target not in _kinds_of(name):
                raise ValueError(f"{name} has no {target} argument")
    return names, target, number


@attrs.frozen
class Change:
    """What an alter strategy does to a behavior set: the arguments of kind ``target`` (or the
    priority) of ``behaviors`` (names, or ``"*"`` for all) become ``old * (1 + scale * D_f)``
    (:mod:`cbr_behaviors.adaptation`)."""

    behaviors: tuple[str, ...] | Literal["*"] = attrs.field(converter=freeze)
    target: str
    scale: float

    def __attrs_post_init__(self) -> None:
        try:
            _change(self.behaviors, self.target, self.scale)
        except ValueError as exc:
            raise CaseFormatError("Change", [str(exc)]) from None

    def applies_to(self, name: str) -> bool:
        return self.behaviors == ALL or name in self.behaviors

    def to_data(self) -> dict[str, Any]:
        return {"behaviors": ALL if self.behaviors == ALL else list(self.behaviors),
                "target": self.target, "scale": self.scale}

    @classmethod
    def from_data(cls, data: Any) -> Change:
        """A change from ``{behaviors, target, scale}``; ValueError saying what is wrong."""
        keys = ("behaviors", "target", "scale")
        if not isinstance(data, Mapping) or sorted(data) != sorted(keys):
            raise ValueError(f"expected a mapping with the keys {', '.join(keys)}, got {data!r}")
        return cls(*_change(data["behaviors"], data["target"], data["scale"]))


@attrs.frozen
class Strategy:
    """An adaptation strategy (004), kept in the case memory and indexed by the kind of case
    it adapts (``adapts``) and the per-feature distances it answers.

    An ``alter`` strategy holds when the distance ``D_f`` on ``feature`` is at least ``min``
    and its ``sense`` holds (for sonar and map: the query's objects are ``closer`` to the
    robot than the case's, or ``farther``; ``any``: either way); it applies its ``changes``.
    A ``merge`` strategy holds when some feature matches very badly (``D_f >= high``) and the
    others, on average, well (mean ``D_f <= low``); the case is then merged with a second case
    retrieved for the badly matching features (:mod:`cbr_behaviors.adaptation`).
    """

    name: str = attrs.field(validator=_validated(check_name))
    adapts: Literal["behavior", "plan"]
    kind: Literal["alter", "merge"]
    feature: str | None = None
    sense: str = "any"
    min: float = 0.0
    changes: tuple[Change, ...] = attrs.field(default=(), converter=tuple)
    high: float = 1.0
    low: float = 0.0
    origin: str = attrs.field(default=HAND_MADE, validator=_validated(check_name))

    def __attrs_post_init__(self) -> None:
        fields = {"adapts": self.adapts, "kind": self.kind, "feature": self.feature,
                  "sense": self.sense, "min": self.min, "high": self.high, "low": self.low}
        problems = strategy_problems(fields)
        if self.kind == "alter" and not self.changes:
            problems.append(("changes", "an alter strategy needs at least one change"))
        if problems:
            key, problem = problems[0]
            raise CaseFormatError(f"Strategy {self.name!r}", [f"{key}: {problem}"])

    def to_case(self) -> Case:
        problem: dict[str, Any] = {"adapts": self.adapts, "kind": self.kind}
        if self.kind == "alter":
            problem.update(feature=self.feature, sense=self.sense, min=self.min)
            solution: Any = {"changes": [c.to_data() for c in self.changes]}
        else:
            problem.update(high=self.high, low=self.low)
            solution = None
        return Case(problem, solution, kind=STRATEGY,
                    meta={"name": self.name, "origin": self.origin})


def strategy_problems(fields: Mapping[str, Any]) -> list[tuple[str, str]]:
    """``(key, problem)`` for each problem of a strategy's fields other than its name, origin
    and changes (defaults for those left out)."""
    checks: list[tuple[str, Any, Callable[[Any], Any]]] = [
        ("adapts", fields.get("adapts", "behavior"), lambda v: _choice(v, ("behavior", "plan"))),
        ("kind", fields.get("kind"), lambda v: _choice(v, ("alter", "merge")))]
    if fields.get("kind") == "alter":
        checks += [("feature", fields.get("feature"), lambda v: _choice(v, FEATURES)),
                   ("sense", fields.get("sense", "any"), lambda v: _choice(v, SENSES)),
                   ("min", fields.get("min", 0.0), _fraction)]
    else:
        checks += [("high", fields.get("high"), _fraction), ("low", fields.get("low"), _fraction)]
    problems = []
    for key, value, check in checks:
        try:
            check(value)
        except ValueError as exc:
            problems.append((key, str(exc)))
    if problems:
        return problems
    if fields["kind"] == "alter":
        sense, feature = fields.get("sense", "any"), fields["feature"]
        if sense != "any" and feature not in SENSED:
            problems.append(("sense", f"{sense!r} compares the closeness of objects, which only "
                                      f"{', '.join(SENSED)} tell; use 'any' for {feature}"))
    elif not fields["low"] < fields["high"]:
        problems.append(("low", f"expected low < high, got low {fields['low']!r} and high "
                                f"{fields['high']!r}"))
    return problems


AnyCase = BehaviorCase | PlanCase | Strategy
"""Any case a case file holds."""


def index_data(index: Index) -> dict[str, Any]:
    """``index`` as plain data, a sonar with every beam alike written as one number (the
    shorthand :meth:`Index.from_data` reads back)."""
    data = index.to_data()
    sonar = data.get("sonar")
    if sonar is not None and len(set(sonar)) == 1:
        data["sonar"] = sonar[0]
    return data
