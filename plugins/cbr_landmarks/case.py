"""A case of 002, ``<L, O, delta, alpha, a>``, as plain data in the case base.

Kind :data:`SITUATION`. ``problem`` is the landmark graph (:meth:`LandmarkGraph.to_data`:
``landmarks``, ``obstacles``, ``delta``, ``alpha``); ``solution`` the action
(:class:`~cbr_landmarks.action.DivertAction` data), or null for a *positive* case, a situation
that needed nothing; ``meta`` holds ``sign`` (``negative``: a situation to avoid, 002's cases;
``positive``: a safe one), ``origin`` (``hand-made`` or ``learned``) and how the case fared when
it was reused: ``helped`` and ``failed`` counts (:mod:`cbr_landmarks.components`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Literal

import attrs

from cbr_landmarks.action import DivertAction
from cbr_landmarks.graph import GraphError, LandmarkGraph
from cbrcore.model import Case

SITUATION = "landmark_situation"
"""The case kind of a landmark situation."""

Sign = Literal["negative", "positive"]


@attrs.frozen(eq=False)
class LandmarkCase:
    """A landmark graph, what to do there and how that went."""

    graph: LandmarkGraph
    action: DivertAction | None
    sign: Sign = "negative"
    origin: str = "learned"
    helped: int = 0
    failed: int = 0
    id: int | None = None

    def __attrs_post_init__(self) -> None:
        if (self.action is None) != (self.sign == "positive"):
            raise GraphError(f"{self.graph.where}: a negative case needs an action and a "
                             "positive case has none")
        if self.action is not None:
            for landmark in (self.action.anchor, self.action.base):
                if landmark not in self.graph.ids:
                    raise GraphError(f"{self.graph.where}: action: {landmark!r} is not one of "
                                     f"the case's landmarks {list(self.graph.ids)}")

    def to_case(self) -> Case:
        return Case(self.graph.to_data(),
                    None if self.action is None else self.action.to_data(), kind=SITUATION,
                    meta={"sign": self.sign, "origin": self.origin, "helped": self.helped,
                          "failed": self.failed},
                    id=self.id)

    @classmethod
    def from_case(cls, case: Case, source: str = "case base") -> LandmarkCase:
        """The landmark case stored in ``case``; :class:`GraphError` naming the case and the
        field when it is malformed."""
        where = f"{source}, {SITUATION} case {case.id}"
        graph = LandmarkGraph.from_data(case.problem, where)
        meta: Mapping[str, Any] = case.meta
        sign = meta.get("sign", "negative")
        if sign not in ("negative", "positive"):
            raise GraphError(f"{where}: meta.sign: expected 'negative' or 'positive', got "
                             f"{sign!r}")
        counts = {}
        for key in ("helped", "failed"):
            value = meta.get(key, 0)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise GraphError(f"{where}: meta.{key}: expected a count >= 0, got {value!r}")
            counts[key] = value
        action = (None if case.solution is None
                  else DivertAction.from_data(case.solution, graph.ids, where))
        return cls(graph, action, sign, str(meta.get("origin", "learned")), counts["helped"],
                   counts["failed"], case.id)
