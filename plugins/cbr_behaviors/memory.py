"""RUPART's one case memory: behavior cases, plan cases, meta-plans and adaptation strategies
in one case base, read through one retrieval (004, "unified" CBR).

Behavior cases, plan cases and meta-plans share the index of Figure 5 and one
:class:`~cbr_behaviors.index.IndexTable` over all of them; a retrieval names the kinds it
wants and gets the nearest of those rows. Adaptation strategies are kept beside them (they are
indexed by the kind of case they adapt and by per-feature distances, see
:mod:`cbr_behaviors.adaptation`). The memory is a view of the case base held by the core's
store mirror: loaded on first use, loaded anew after a learn step that rolled back or when
another process sharing the case base committed; the learn steps write through to the store.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from typing import TYPE_CHECKING

import attrs
import numpy as np

from cbr_behaviors.casedata import case_of, strategy_of
from cbr_behaviors.casetypes import (
    BEHAVIOR,
    META,
    PLAN,
    STRATEGY,
    BehaviorCase,
    PlanCase,
    Strategy,
    freeze,
)
from cbr_behaviors.index import Index, Scales
from cbr_behaviors.quality import TIE, against, better, margin
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.model import Case
from cbrcore.stash import StashKey

if TYPE_CHECKING:
    from cbr_behaviors.index import Hit, IndexTable

INDEXED = (BEHAVIOR, PLAN, META)
"""The kinds that share the index of Figure 5."""

Stored = BehaviorCase | PlanCase


def _source(store: CaseStore) -> str:
    return f"case base {getattr(store, 'path', type(store).__name__)}"


@attrs.frozen
class Found:
    """A retrieved case: the stored case, its decoded form, its overall index distance and the
    per-feature distances (features both sides specify)."""

    case: Case
    stored: Stored
    distance: float
    features: dict[str, float]


@attrs.define
class CaseMemory:
    """The indexed cases of a case base (in the store's order), its strategies and the index
    table over the indexed cases, built on first use after a change."""

    store: CaseStore
    cases: list[Case]
    decoded: list[Stored]
    strategies: list[Strategy]
    _table: IndexTable | None = None
    _scales: Scales | None = None

    @classmethod
    def load(cls, store: CaseStore) -> CaseMemory:
        """The RUPART cases of ``store``; a CaseFormatError naming the case if one is
        malformed."""
        source = _source(store)
        cases = [c for kind in INDEXED for c in store.cases(kind)]
        cases.sort(key=lambda c: c.id or 0)
        decoded = [case_of(c, source) for c in cases]
        strategies = [strategy_of(c, source) for c in store.cases(STRATEGY)]
        return cls(store, cases, decoded, strategies)  # type: ignore[arg-type]

    def __len__(self) -> int:
        return len(self.cases)

    def table(self, scales: Scales) -> IndexTable:
        # compiled: loaded when a run first retrieves, not with the plugin
        from cbr_behaviors.index import IndexTable

        if self._table is None or self._scales != scales:
            self._table = IndexTable.build([d.index for d in self.decoded], scales)
            self._scales = scales
        return self._table

    @property
    def scales(self) -> Scales:
        """The scales the index table was last built with (the retriever's), else the
        defaults."""
        return self._scales if self._scales is not None else Scales()

    def rows(self, kinds: Collection[str], exclude: Collection[int] = ()) -> np.ndarray:
        """The row numbers of the cases of ``kinds``, leaving out the case ids ``exclude``."""
        return np.array([k for k, c in enumerate(self.cases)
                         if c.kind in kinds and c.id not in exclude], dtype=np.int64)

    def nearest(self, query: Index, weights: np.ndarray, kinds: Collection[str], k: int,
                scales: Scales, exclude: Collection[int] = (), tie: float = TIE
                ) -> list[Found]:
        """The ``k`` cases of ``kinds`` nearest ``query`` under ``weights``, best first; near
        ties (distances within ``tie``, default :data:`~cbr_behaviors.quality.TIE`) go to a case
        whose record shows it better than the nearest one's (:func:`_by_record`)."""
        rows = self.rows(kinds, exclude)
        if not len(rows):
            return []
        hits = self.table(scales).nearest(query, weights, k + 8, rows=rows)
        return [self._found(h) for h in _by_record(hits, self.cases, tie)][:k]

    def ids_with(self, behaviors: Sequence[object]) -> tuple[int, ...]:
        """The ids of the behavior cases and meta-plans whose behavior set is ``behaviors``."""
        wanted = freeze(behaviors)
        return tuple(c.id for c, d in zip(self.cases, self.decoded, strict=True)
                     if c.id is not None and isinstance(d, BehaviorCase)
                     and d.behaviors == wanted)

    def _found(self, hit: Hit) -> Found:
        return Found(self.cases[hit.row], self.decoded[hit.row], hit.distance,
                     dict(hit.features))

    def stored(self, case_id: int) -> Stored | None:
        """The decoded form of the case ``case_id``, None when the memory has none."""
        for case, decoded in zip(self.cases, self.decoded, strict=True):
            if case.id == case_id:
                return decoded
        return None

    def get(self, case_id: int) -> Case | None:
        for case in self.cases:
            if case.id == case_id:
                return case
        return None

    def add(self, case: Case) -> Case:
        """Store ``case`` (an indexed kind); the stored case, with its id."""
        stored = self.store.add(case)
        self.cases.append(stored)
        self.decoded.append(case_of(stored, _source(self.store)))
        self._table = None
        return stored

    def update_meta(self, case_id: int, meta: dict[str, object]) -> None:
        """Merge ``meta`` into the stored case ``case_id``'s metadata."""
        fresh = self.store.get(case_id)
        changed = attrs.evolve(fresh, meta={**fresh.meta, **meta})
        self.store.replace(changed)
        self.cases = [changed if c.id == case_id else c for c in self.cases]

    def remove(self, ids: Sequence[int]) -> None:
        gone = set(ids) & {c.id for c in self.cases}
        if not gone:
            return
        self.store.remove(sorted(gone))
        kept = [(c, d) for c, d in zip(self.cases, self.decoded, strict=True)
                if c.id not in gone]
        self.cases = [c for c, _ in kept]
        self.decoded = [d for _, d in kept]
        self._table = None


def _by_record(hits: Sequence[Hit], cases: Sequence[Case], tie: float) -> list[Hit]:
    """``hits`` (best first) with, in each run of distances within ``tie`` of the run's first,
    the case whose record against that first one shows it better than the first one's record
    against it (:func:`~cbr_behaviors.quality.better`, the largest margin winning) moved to the
    front; the others keep their order."""
    out: list[Hit] = []
    group: list[Hit] = []
    for hit in hits:
        if group and hit.distance - group[0].distance > tie:
            out += _preferred(group, cases)
            group = []
        group.append(hit)
    return out + _preferred(group, cases)


def _preferred(group: list[Hit], cases: Sequence[Case]) -> list[Hit]:
    """One run of :func:`_by_record`."""
    if len(group) < 2:
        return group
    nearest = cases[group[0].row]
    proven = []
    for k, hit in enumerate(group[1:], start=1):
        challenger = cases[hit.row]
        mine, theirs = against(challenger.meta, nearest.id), against(nearest.meta, challenger.id)
        if better(mine, theirs):
            proven.append((margin(mine, theirs), k))
    if not proven:
        return group
    _, k = max(proven, key=lambda mk: (mk[0], -mk[1]))
    return [group[k], *group[:k], *group[k + 1:]]


_MEMORY = StashKey[CaseMemory]()


def memory_of(ctx: Context) -> CaseMemory:
    """The run's RUPART case memory, loaded from the case base on first use and kept in step
    with it."""
    return ctx.mirror.view(_MEMORY, CaseMemory.load)
