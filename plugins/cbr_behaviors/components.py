"""Retrieve, reuse, retain and forget RUPART's cases (004 sections "Behavior Case Retrieval"
and "Adaptation and Learning of Behavior Cases").

- :class:`RupartRetriever`: one retrieval over the one case memory. The nearest behavior and
  plan cases under the weighted index distance, each with its per-feature distances in
  ``Match.features``; when even the best is farther than ``meta_threshold`` (nothing matches
  well), the nearest meta-plans instead (004: "'fall-back' cases that are retrieved when no
  case matches the current situation well"). At an impasse the cases whose behaviors are in
  force are left out: they are what got the robot stuck.
- :class:`RupartReuser`: the best case made into an action. A plan case becomes an
  :class:`~cbr_behaviors.moment.InstallPlan`; a behavior case or meta-plan farther than
  ``threshold`` is adapted by the strategies the memory holds for it (alter its parameters,
  or merge it with a second case that matches its worst features) and becomes an
  :class:`~cbr_behaviors.moment.InstallBehaviors`. A learned case is passed over for a
  hand-made behavior case among the matches that lies within ``threshold``.
- :class:`CaseLearner` (retainer ``rupart_cases``): the quality counters of the cases
  retrieved and used, and the adapted cases whose spell went well while the case they were
  adapted from is failing (:func:`~cbr_behaviors.quality.failing`), stored under the index of
  the situation they started in, cut to the features of the cases they were adapted from
  (:func:`retained_index`); and each installed case's record against its rivals in the band
  (:func:`~cbr_behaviors.quality.against`).
- :class:`WeightLearner` (retainer ``rupart_weights``): the index weights learned from
  outcomes (:mod:`cbr_behaviors.weights`).
- :class:`QualityForgetter` (forgetter ``rupart_quality``): keeps at most ``capacity``
  learned cases, dropping the lowest quality first, and drops a learned case whose spells
  mostly went badly.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import attrs
import numpy as np

from cbr_behaviors.casetypes import BEHAVIOR, HAND_MADE, META, PLAN, BehaviorCase, PlanCase
from cbr_behaviors.index import (
    ATTRIBUTES,
    FEATURES,
    Index,
    IndexDataError,
    Scales,
    weight_vector,
)
from cbr_behaviors.memory import Found, memory_of
from cbr_behaviors.moment import CaseChoice, InstallBehaviors, InstallPlan, Moment, SpellReport
from cbr_behaviors.quality import RIVALS, TIE, Quality, failing, with_rivals
from cbr_behaviors.weights import store_weights, stored_weights, updated
from cbrcore.casebase.store import CaseStore
from cbrcore.context import Context
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Case, Match, Outcome, Retrieval, Solution
from cbrcore.options import option

_UNIT = attrs.validators.and_(attrs.validators.ge(0.0), attrs.validators.le(1.0))
_POSITIVE = attrs.validators.gt(0.0)


def _weights(instance: Any, attribute: attrs.Attribute, value: dict[str, float]) -> None:
    try:
        weight_vector(value, f"'{attribute.name}'")
    except IndexDataError as exc:
        # a plain ValueError, as every option's check raises, so the message reads alike
        raise ValueError(str(exc)) from None


@attrs.frozen
class RetrieveOptions:
    weights: dict[str, float] = option(
        doc="w_f per feature of the index (004 Figure 5 names: sonar, motors, map, location, "
        "behaviors, task-loc, task-urgency, plan, goal, goal-urgency, pending-goals, loc-conf, "
        "plan-conf, behav-conf); a feature left out weighs 1.", factory=dict,
        validator=_weights)
    learned_weights: bool = option(
        False, "Use the weights learned into the case base (retainer rupart_weights) once "
        "there are some, instead of 'weights'.")
    meta_threshold: float = option(
        0.35, "The overall distance beyond which no behavior or plan case matches well and the "
        "nearest meta-plans are retrieved instead.", validator=_UNIT)
    candidates: int = option(3, "How many matches, best first, a retrieval returns.",
                             validator=attrs.validators.ge(1))
    location_scale: float = option(
        10.0, "Metres at which the location and task-loc distances reach 1.",
        validator=_POSITIVE)
    quality_band: float = option(
        0.01, "Within this of the nearest case's distance, a case whose spells installed "
        "with the nearest in its band went better than the nearest's with it (at least 3 of "
        "them, Newcombe's 95% bound on the difference of the success rates above 0; see "
        "docs/rupart.md) is installed instead: 0.01 decides near ties only; wider, the "
        "robot's experience of which case works chooses among the cases that match about as "
        "well.", validator=_UNIT)

    @property
    def scales(self) -> Scales:
        return Scales(location=self.location_scale)


def _match(found: Found) -> Match:
    return Match(found.case, 1.0 - found.distance, found.features)


@attrs.frozen(eq=False)
class Retrieved:
    """The retriever's payload: the found cases in the order of the matches, the weights and
    scales they were found with (the reuser's second retrieval uses the same) and the quality
    band (the installed case's rivals are the found cases within it)."""

    found: tuple[Found, ...]
    weights: np.ndarray
    scales: Scales
    band: float = TIE


def weights_of(options: RetrieveOptions, ctx: Context) -> np.ndarray:
    """The weights a retrieval uses now: the learned ones when asked for and present."""
    if options.learned_weights:
        learned = stored_weights(ctx.mirror.store)
        if learned is not None:
            return learned
    return weight_vector(options.weights, "retrieve.weights")


class RupartRetriever:
    """004: the nearest cases under D = sum of w_f D_f; meta-plans when none is near."""

    def __init__(self, options: RetrieveOptions, ctx: Context) -> None:
        self.options = options

    @hookimpl
    def cbr_retrieve(self, problem: Moment, ctx: Context) -> Retrieval:
        o = self.options
        memory = memory_of(ctx)
        weights = weights_of(o, ctx)
        scales = o.scales
        # at an impasse the behaviors in force are the ones that failed: not retrieved again,
        # nor those that failed lately (the workload keeps them out for a while)
        failed = tuple(i for behaviors in problem.excluded for i in memory.ids_with(behaviors))
        if "impasse" in problem.triggers:
            failed += memory.ids_with(problem.behaviors)
        band = o.quality_band
        found = memory.nearest(problem.index, weights, (BEHAVIOR, PLAN), o.candidates, scales,
                               exclude=failed, tie=band)
        if found and all(f.case.kind == PLAN for f in found):
            # the reuser falls back on the nearest behavior case when the plan is in force
            found += memory.nearest(problem.index, weights, (BEHAVIOR,), 1, scales,
                                    exclude=failed, tie=band)
        if not found or found[0].distance > o.meta_threshold:
            fallback = memory.nearest(problem.index, weights, (META,), o.candidates, scales,
                                      exclude=failed, tie=band)
            if fallback:
                found = fallback
        if not found:
            return Retrieval((), reason="no RUPART case stored")
        return Retrieval(tuple(_match(f) for f in found),
                         payload=Retrieved(tuple(found), weights, scales, band))


@attrs.frozen
class ReuseOptions:
    adapt: bool = option(True, "Adapt a retrieved behavior case farther than 'threshold' with "
                               "the adaptation strategies of the case memory.")
    threshold: float = option(
        0.15, "The overall distance beyond which a behavior case is adapted rather than used "
        "as it is (004).", validator=_UNIT)
    plan_trust: float = option(
        0.5, "While a plan case is in force and the plan confidence is at least this, a "
        "retrieved plan case is passed over for the nearest behavior case.", validator=_UNIT)


class RupartReuser:
    """004: install the best case: a plan deliberatively, behaviors at once, adapted when the
    case is not near enough."""

    def __init__(self, options: ReuseOptions, ctx: Context) -> None:
        self.options = options

    @hookimpl
    def cbr_reuse(self, problem: Moment, retrieval: Retrieval, ctx: Context) -> Solution:
        found: Retrieved = retrieval.payload
        # with a plan in force that the robot still trusts, no plan case re-plans: the
        # nearest behavior case is installed instead
        trusted = (problem.plan is not None
                   and (problem.index.plan_conf or 0.0) >= self.options.plan_trust)
        best = next((f for f in found.found
                     if not (trusted and isinstance(f.stored, PlanCase))), found.found[0])
        if best.stored.origin != HAND_MADE:
            # a learned case fills a gap where no authored case matched well; where one does
            # (near enough to be used as it is), the learned one does not take its place
            authored = next((f for f in found.found if isinstance(f.stored, BehaviorCase)
                             and f.stored.origin == HAND_MADE
                             and f.distance <= self.options.threshold), None)
            best = authored if authored is not None else best
        stored = best.stored
        ids = (best.case.id,) if best.case.id is not None else ()
        # the learn step sees the solution, not the retrieval: what it needs travels here
        rivals = tuple(f.case.id for f in found.found if f is not best and f.case.id is not None
                       and abs(f.distance - best.distance) <= found.band)
        choice = CaseChoice(best.case.kind, best.distance, best.features,
                            tuple(f.case.id for f in found.found), rivals)
        if isinstance(stored, PlanCase):
            return Solution(InstallPlan(stored.route, stored.name, stored.localize), cases=ids,
                            payload=choice)
        if not self.options.adapt or best.distance <= self.options.threshold:
            return Solution(InstallBehaviors(tuple(stored.behaviors), stored.name), cases=ids,
                            payload=choice)
        from cbr_behaviors.adaptation import adapt_case

        adapted, changes, second = adapt_case(stored, best.features, problem.index,
                                              memory_of(ctx), found.weights, found.scales,
                                              exclude=ids)
        if adapted is None:
            return Solution(InstallBehaviors(tuple(stored.behaviors), stored.name), cases=ids,
                            payload=choice)
        used = ids + ((second.case.id,) if second is not None and second.case.id else ())
        return Solution(InstallBehaviors(tuple(adapted.behaviors), adapted.name, adapted),
                        cases=used, detail={"adapted": changes}, payload=choice)


@attrs.frozen
class RetainOptions:
    retain_adapted: bool = option(
        True, "Store an adapted behavior case when its spell went well and the case it was "
        "adapted from is failing, used at least 3 times and fewer than half of them well (004: "
        "adapted cases are retained).")
    duplicate: float = option(
        0.02, "An adapted case this near (overall distance) an existing behavior case with the "
        "same behaviors is not stored again.", validator=_UNIT)


def _spell(outcome: Outcome) -> SpellReport | None:
    return outcome.report if isinstance(outcome.report, SpellReport) else None


def _choice(solution: Solution) -> CaseChoice | None:
    return solution.payload if isinstance(solution.payload, CaseChoice) else None


class CaseLearner:
    """004: quality counters of the retrieved and used cases; adapted cases of failing cases
    retained."""

    def __init__(self, options: RetainOptions, ctx: Context) -> None:
        self.options = options

    @hookimpl
    def cbr_retain(self, problem: Moment, solution: Solution, outcome: Outcome,
                   casebase: CaseStore, ctx: Context) -> None:
        report = _spell(outcome)
        if report is None:
            return
        memory = memory_of(ctx)
        choice = _choice(solution)
        matched = choice.retrieved if choice is not None else ()
        used = set(solution.cases)
        installed = solution.cases[0] if solution.cases else None
        parent = None if installed is None else memory.get(installed)
        # the record the adapted case is judged against leaves out the spell it was in
        record = Quality.of(parent.meta) if parent is not None else None
        for case_id in dict.fromkeys((*matched, *solution.cases)):
            case = None if case_id is None else memory.get(case_id)
            if case is None:
                continue  # forgotten meanwhile, here or by another process
            q = Quality.of(case.meta)
            q = attrs.evolve(q, retrieved=q.retrieved + (case_id in matched))
            if case_id in used:
                q = attrs.evolve(q, used=q.used + 1, good=q.good + report.good,
                                 active=q.active + report.active)
            meta: dict[str, Any] = q.to_meta()
            rivals = choice.rivals if choice is not None else ()
            if case_id == installed and rivals:
                meta[RIVALS] = with_rivals(case.meta, rivals, report.good)
            memory.update_meta(case_id, meta)
        value = solution.value
        if (self.options.retain_adapted and report.good and isinstance(value, InstallBehaviors)
                and value.adapted is not None and record is not None and failing(record)):
            sources = [memory.stored(i) for i in solution.cases]
            self._retain(memory, value.adapted, retained_index(problem.index, sources))

    def _retain(self, memory: Any, adapted: BehaviorCase, index: Index) -> None:
        near = memory.nearest(index, np.ones(len(FEATURES)), (BEHAVIOR,), 1, memory.scales)
        if (near and near[0].distance <= self.options.duplicate
                and near[0].stored.behaviors == adapted.behaviors):
            return
        stored = attrs.evolve(adapted, index=index, origin="adapted")
        memory.add(stored.to_case())


def retained_index(situation: Index, sources: Sequence[object]) -> Index:
    """The index an adapted case is retained under: the values of ``situation`` (where its
    spell began) for the features the cases it was adapted from (``sources``) specify. A case
    indexed by every feature of a situation would be compared with every later query on all
    of them, most of which (the confidences, the urgencies, the goal) agree between unrelated
    situations, so it would lie near situations its parent does not speak of; indexed by its
    parent's features it is that case where it went well."""
    keep = {f for source in sources if isinstance(source, BehaviorCase)
            for f in source.index.specified()}
    if not keep:
        return situation
    return attrs.evolve(situation, **{ATTRIBUTES[f]: None for f in FEATURES if f not in keep})


@attrs.frozen
class WeightOptions:
    rate: float = option(0.5, "The learning rate of the weights (see docs/rupart.md).",
                         validator=_POSITIVE)


class WeightLearner:
    """The introspective step: weights moved by which retrieved cases led to good spells."""

    def __init__(self, options: WeightOptions, ctx: Context) -> None:
        self.options = options

    @hookimpl
    def cbr_retain(self, problem: Moment, solution: Solution, outcome: Outcome,
                   casebase: CaseStore, ctx: Context) -> None:
        report = _spell(outcome)
        choice = _choice(solution)
        if report is None or choice is None or choice.kind != BEHAVIOR:
            return
        current = stored_weights(casebase)
        start = current if current is not None else np.ones(len(FEATURES))
        store_weights(casebase, updated(start, choice.features, report.good, self.options.rate))


@attrs.frozen
class ForgetOptions:
    capacity: int = option(60, "The most learned (adapted) behavior cases kept; hand-made "
                               "cases are never forgotten.", validator=attrs.validators.ge(0))
    failing: int = option(3, "A learned case used this often whose spells went badly more "
                             "often than well is forgotten.", validator=attrs.validators.ge(1))


class QualityForgetter:
    """Forget learned behavior cases by quality (:mod:`cbr_behaviors.quality`)."""

    def __init__(self, options: ForgetOptions, ctx: Context) -> None:
        self.options = options

    @hookimpl
    def cbr_forget(self, casebase: CaseStore, ctx: Context) -> None:
        memory = memory_of(ctx)
        learned = [(c, d) for c, d in zip(memory.cases, memory.decoded, strict=True)
                   if c.kind == BEHAVIOR and getattr(d, "origin", "") != "hand-made"]
        drop = []
        for case, _ in learned:
            q = Quality.of(case.meta)
            if q.used >= self.options.failing and q.good * 2 < q.used:
                drop.append(case.id)
        kept = [(c, d) for c, d in learned if c.id not in drop]
        excess = len(kept) - self.options.capacity
        if excess > 0:
            ranked = sorted(kept, key=lambda cd: (_score(memory, *cd), cd[0].id))
            drop += [c.id for c, _ in ranked[:excess]]
        if drop:
            memory.remove([i for i in drop if i is not None])


def _score(memory: Any, case: Case, decoded: BehaviorCase) -> float:
    near = memory.nearest(decoded.index, np.ones(len(FEATURES)), (BEHAVIOR,), 1, Scales(),
                          exclude=(case.id,))
    return Quality.of(case.meta).score(near[0].distance if near else 1.0)
