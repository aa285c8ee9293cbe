"""The run's landmark cases and their retrieval index, written through to the case base.

Retrieval compares the problem case with every stored situation in one compiled pass over the
arrays of :class:`~cbr_landmarks.index.SituationIndex`; the index is built from the cases when
it is first needed after a change. Every change goes to the store at once, inside the engine's
learn transaction; the cases are a view of the case base held by the core's store mirror
(:mod:`cbrcore.casebase.mirror`), loaded anew after a learn step that rolled back or when another
process sharing the case base committed.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import attrs

from cbr_landmarks.case import SITUATION, LandmarkCase
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.stash import StashKey

if TYPE_CHECKING:
    from cbr_landmarks.index import SituationIndex


def _source(store: CaseStore) -> str:
    return f"case base {getattr(store, 'path', type(store).__name__)}"


@attrs.define
class SituationBase:
    """The stored landmark cases, in the store's order, and their index."""

    store: CaseStore
    cases: list[LandmarkCase]
    _index: SituationIndex | None = None

    @classmethod
    def load(cls, store: CaseStore) -> SituationBase:
        """The landmark cases of ``store``; GraphError naming the case if one is malformed."""
        source = _source(store)
        return cls(store, [LandmarkCase.from_case(c, source) for c in store.cases(SITUATION)])

    def __len__(self) -> int:
        return len(self.cases)

    @property
    def index(self) -> SituationIndex:
        """The retrieval index of the cases, built on first use after a change."""
        # compiled: loaded when a run first matches situations, not with the plugin
        from cbr_landmarks.index import SituationIndex

        if self._index is None:
            self._index = SituationIndex.build([c.graph for c in self.cases])
        return self._index

    def get(self, case_id: int) -> LandmarkCase | None:
        for case in self.cases:
            if case.id == case_id:
                return case
        return None

    def add(self, case: LandmarkCase) -> LandmarkCase:
        """Store ``case``; the stored case, with its id."""
        stored = attrs.evolve(case, id=self.store.add(case.to_case()).id)
        self.cases.append(stored)
        self._index = None
        return stored

    def replace(self, case: LandmarkCase) -> None:
        """Store the new counts of ``case`` (same id, same graph)."""
        old = self.store.get(case.id or 0)
        self.store.replace(attrs.evolve(old, meta={**old.meta, **case.to_case().meta}))
        self.cases = [case if c.id == case.id else c for c in self.cases]

    def remove(self, ids: Iterable[int]) -> None:
        """Forget the cases ``ids``."""
        gone = set(ids) & {c.id for c in self.cases}
        if gone:
            self.store.remove(sorted(gone))
            self.cases = [c for c in self.cases if c.id not in gone]
            self._index = None


_SITUATIONS = StashKey[SituationBase]()


def base_of(ctx: Context) -> SituationBase:
    """The run's landmark cases, loaded from the case base on first use and kept in step with
    it."""
    return ctx.mirror.view(_SITUATIONS, SituationBase.load)
