"""Retrieve, reuse, retain and forget landmark situations (002 sections 3.2-3.3 and 5).

- :class:`LandmarkRetriever`: the stored cases whose similarity to the problem case (the
  landmarks in the region in front of the robot) reaches ``threshold`` (002's ``simThr``), best
  first, each with the landmark matching that scored it.
- :class:`LandmarkReuser`: the best case's action carried onto the current landmarks through
  the matching: a :class:`~cbr_world2d.actions.Divert` the Rescuer heads for (002 section 3.3),
  when the robot can reach it as far as it knows (:mod:`cbr_landmarks.reach`), given up after
  the time its way takes; a positive case asks for nothing.
- :class:`TroubleRetainer`: learning (002's future work). A situation in which the robot got
  into trouble (the progress monitor found it blocked or oscillating) and was got out by a
  diverting target becomes a negative case whose action is that target; with ``positive``, a
  situation that needed no action and was followed by none and by no trouble for a while
  becomes a positive case. A reused case is credited when its target was reached (a positive
  case: when the while passed) and blamed when it was not, or when trouble came within
  ``window`` seconds after; a failed target is kept (:data:`FAILED`) so the reuser does not
  send the robot there again in the trial.
- :class:`UnhelpfulSituations`: forgets the cases that were reused and did not help.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import attrs
import numpy as np

from cbr_landmarks.action import DivertAction
from cbr_landmarks.base import SituationBase, base_of
from cbr_landmarks.case import LandmarkCase
from cbr_landmarks.graph import LandmarkGraph
from cbr_landmarks.problem import RegionOptions, View, problem_view, sub_view
from cbr_landmarks.reach import (
    GIVE_UP_MARGIN,
    GIVE_UP_SLACK,
    PASSAGE,
    Way,
    in_sight,
    known_walls,
    sighted_places,
    walls_between,
    way,
)
from cbr_landmarks.similarity import Matching, SimilarityOptions
from cbr_world2d.actions import GIVEN_UP, REACHED, TRIAL_ENDED, ActionReport, Divert, GiveUp
from cbr_world2d.workload import Situation
from cbrcore.context import Context
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Match, Outcome, Retrieval, Solution
from cbrcore.options import option
from cbrcore.stash import StashKey

_UNIT = attrs.validators.and_(attrs.validators.ge(0.0), attrs.validators.le(1.0))


@attrs.frozen(eq=False)
class MatchedView:
    """The retriever's payload: the problem case as seen, and the stored case and its matching
    of each match, in the order of the matches."""

    view: View
    cases: tuple[LandmarkCase, ...]
    matchings: tuple[Matching, ...]


@attrs.frozen
class RetrieveOptions:
    threshold: float = option(
        0.75, "simThr: the least similarity (0-1) of a case that may be reused.",
        validator=_UNIT)
    region: RegionOptions = option(factory=RegionOptions,
                                   doc="The region in front of the robot (002 Figure 5).")
    similarity: SimilarityOptions = option(factory=SimilarityOptions,
                                           doc="How two landmark graphs are compared.")
    candidates: int = option(3, "How many matches, best first, the reuser may try.",
                             validator=attrs.validators.ge(1))
    course: bool = option(
        False, "Measure the angles against the robot's course (x toward its target) rather "
        "than its heading (002's reference axis): a situation then matches only where the "
        "target lies the same way.")


class LandmarkRetriever:
    """002 section 3.3: the cases over ``threshold``, most similar first."""

    def __init__(self, options: RetrieveOptions, ctx: Context) -> None:
        self.options = options

    @hookimpl
    def cbr_retrieve(self, problem: Situation, ctx: Context) -> Retrieval:
        o = self.options
        view = problem_view(problem, o.region, course=o.course)
        if view is None:
            return Retrieval((), reason="fewer than two landmarks in the region in front")
        base = base_of(ctx)
        if not len(base):
            return Retrieval((), reason="no landmark situation stored")
        found = base.index.search(view.graph, o.threshold, o.similarity, limit=o.candidates)
        if not found:
            return Retrieval((), reason=f"no situation with similarity >= {o.threshold}")
        matches, cases = [], []
        for hit in found:
            case = base.cases[hit.row]
            cases.append(case)
            m = hit.matching
            matches.append(Match(case.to_case(), m.similarity, {
                "similarity": m.similarity, "landmarks": float(case.graph.n),
                "matched": float(sum(j >= 0 for j in m.mapping)), "nodes": float(m.nodes),
                "negative": float(case.sign == "negative")}))
        return Retrieval(tuple(matches),
                         payload=MatchedView(view, tuple(cases),
                                             tuple(h.matching for h in found)))


def carried_over(case: LandmarkCase, matching: Matching, found: MatchedView
                 ) -> tuple[float, float] | None:
    """The world point of ``case``'s action laid out on the current landmarks it was matched
    with, or None when its anchor or base has no match."""
    if case.action is None:
        return None
    world = found.view.world_points()
    places = {case.graph.ids[j]: world[i] for i, j in enumerate(matching.mapping) if j >= 0}
    return case.action.point(places)


@attrs.frozen
class ReuseOptions:
    min_detour: float = option(
        1.0, "A carried-over diverting target nearer the robot than this, in metres, is no "
        "detour: the next match is tried instead.", validator=attrs.validators.ge(0.0))
    safe: bool = option(
        True, "Check that a carried-over diverting target can be reached as far as the robot "
        "knows (not inside a known obstacle chain, in line of sight or a short way round the "
        "known walls) and that the case's walls do not stand where the robot has seen the way "
        "open, and try the next match when not.")
    clearance: float = option(
        0.3, "Metres a diverting target must keep from a known wall; the way round the walls "
        "passes their ends this far off and more.", validator=attrs.validators.gt(0.0))
    detour: float = option(
        3.0, "The longest way round the known walls to a diverting target out of sight, as a "
        "multiple of the straight distance.", validator=attrs.validators.ge(1.0))
    slack: float = option(
        GIVE_UP_SLACK, "A diverting target is given up after 'slack' times the time its way "
        "takes at the robot's top speed, plus 'margin'.", validator=attrs.validators.gt(0.0))
    margin: float = option(
        GIVE_UP_MARGIN, "Seconds added to a diverting target's give-up time (the pilot turns, "
        "swerves and slows).", validator=attrs.validators.ge(0.0))
    passage: float = option(
        PASSAGE, "The narrowest gap between the ends of two known walls (centre to centre of "
        "their landmarks), in metres, a way round the walls passes through when there is "
        "another way; the straight way through a narrower one is no line of sight.",
        validator=attrs.validators.ge(0.0))
    needed: bool = option(
        True, "With 'safe': reuse a case only where the straight way to the target meets a "
        "known wall (the case's own, laid on the landmarks it was matched with, included) or "
        "a narrow gap; where it is clear (the robot is past the trap the case describes, or "
        "beside it) the case is not needed.")
    follow: bool = option(
        False, "Lead the robot through the waypoints of a way round the known walls, rather "
        "than straight at the target. Off by default: the potential-field pilot slides along a "
        "wall it meets, and a way planned past the free end of a wall whose other walls are not "
        "known yet can lead into the trap they make.")
    failed_radius: float = option(
        1.0, "A carried-over diverting target within this many metres of one that failed in "
        "the same trial (given up, or trouble soon after) is not used again.",
        validator=attrs.validators.ge(0.0))


@attrs.frozen
class Failure:
    """A diverting target of a reused case that failed: in ``trial``, at ``(x, y)``."""

    trial: int
    x: float
    y: float


FAILED = StashKey[list[Failure]]()
"""The reused diverting targets that failed, as the retainer hears of them; the reuser does
not send the robot near one again in the same trial."""


def _failed(ctx: Context) -> list[Failure]:
    return ctx.stash.setdefault(FAILED, [])


class LandmarkReuser:
    """002 section 3.3: the most similar case's action, through the landmark matching.

    A case whose diverting target was set once in a trial is not reused again in that trial:
    the robot has avoided that situation, and sending it back to the same target would keep it
    going to and fro. Nor is a target within ``failed_radius`` of one that failed in the trial.
    With ``safe``, a target the robot cannot reach as far as it knows
    (:mod:`cbr_landmarks.reach`) is skipped too, and with ``needed`` a case matched where the
    straight way to the target is clear of the walls the robot knows and the case describes;
    the next match is tried, and when none is left the case base has no answer. A diversion
    is given up after the time its way takes (:class:`~cbr_world2d.actions.GiveUp`: ``slack``
    times the way at the robot's top speed, plus ``margin``); with ``follow`` it leads the
    robot through the way's waypoints.
    """

    def __init__(self, options: ReuseOptions, ctx: Context) -> None:
        self.options = options
        self._trial = -1
        self._used: set[int] = set()
        self._failed = _failed(ctx)

    def _near_failure(self, trial: int, point: tuple[float, float]) -> bool:
        r = self.options.failed_radius
        return any(f.trial == trial and math.hypot(point[0] - f.x, point[1] - f.y) <= r
                   for f in self._failed)

    @hookimpl
    def cbr_reuse(self, problem: Situation, retrieval: Retrieval) -> Solution | None:
        o = self.options
        if problem.trial != self._trial:
            self._trial, self._used = problem.trial, set()
            # a failure of an earlier trial says nothing of this one's places
            self._failed[:] = [f for f in self._failed if f.trial == problem.trial]
        found: MatchedView = retrieval.payload
        here = (problem.pose.x, problem.pose.y)
        seen = sighted_places(problem) if o.safe else {}
        seen_open = set(problem.open)
        refused: list[dict[str, Any]] = []
        for match, case, matching in zip(retrieval.matches, found.cases, found.matchings,
                                         strict=True):
            case_id = case.id or 0
            detail: dict[str, Any] = {"case": case_id, "similarity": match.similarity}
            if case.sign == "positive":
                return Solution(None, cases=(case_id,), detail=detail)
            point = carried_over(case, matching, found)
            if point is None or case_id in self._used or math.dist(point, here) < \
                    o.min_detour:
                continue
            if self._near_failure(problem.trial, point):
                refused.append({"case": case_id, "why": "near a target that failed"})
                continue
            current = {case.graph.ids[j]: found.view.graph.ids[i]
                       for i, j in enumerate(matching.mapping) if j >= 0}
            found_way = Way(math.dist(point, here), "unchecked")
            if o.safe:
                # the case's own walls, laid on the landmarks it was matched with: a target
                # inside the trap the case describes is no way out of it
                said = [(current.get(case.graph.ids[a]), current.get(case.graph.ids[b]))
                        for a, b in sorted(case.graph.obstacles)]
                if any(pair in seen_open or pair[::-1] in seen_open for pair in said):
                    refused.append({"case": case_id,
                                    "why": "its walls stand where the robot saw the way open"})
                    continue
                walls, pairs = walls_between(
                    [*problem.obstacles, *((a, b) for a, b in said if a and b)], seen)
                walls = np.concatenate((walls, known_walls(problem)))
                posts = np.array(list(seen.values()), dtype=float).reshape(-1, 2)
                if o.needed and in_sight(here, problem.target, walls, o.passage, posts):
                    refused.append({"case": case_id, "why": "the way to the target is clear"})
                    continue
                found_way = way(here, point, walls, pairs, o.clearance, o.detour, o.passage,
                                posts)
                if found_way.metres is None:
                    refused.append({"case": case_id, "why": found_way.how})
                    continue
            assert case.action is not None and found_way.metres is not None
            detail["way"] = found_way.how
            detail["anchor"] = current[case.action.anchor]
            detail["refused"] = refused
            self._used.add(case_id)
            give_up = GiveUp(round(found_way.metres, 4), o.slack, o.margin)
            via = found_way.via if o.follow else ()
            return Solution(Divert(*point, give_up=give_up, via=via), cases=(case_id,),
                            detail=detail)
        return None


@attrs.frozen
class RetainOptions:
    region: RegionOptions = option(
        factory=RegionOptions, doc="The region in front of the robot whose landmarks make a "
        "new case (keep it the retriever's).")
    similarity: SimilarityOptions = option(factory=SimilarityOptions,
                                           doc="How a new situation is compared with the stored.")
    duplicate: float = option(
        0.9, "A new negative situation at least this similar to a stored negative case, or a "
        "new positive one at least this similar to any stored case, is not stored.",
        validator=_UNIT)
    window: float = option(
        30.0, "Seconds after a reused case's diverting target was reached within which trouble "
        "blames that case.", validator=attrs.validators.gt(0.0))
    course: bool = option(
        True, "Take a new case in the frame of the robot's course (x toward its target) "
        "rather than of its heading when it got into trouble.")
    keep: Literal["obstacles", "all"] = option(
        "obstacles", "Which landmarks of the region make a new case: those a linear obstacle "
        "reaches (the layout that trapped the robot; all of them when fewer than two are), or "
        "all.")
    positive: float | None = option(
        None, "Learn positive cases: a consultation that needed no action (not in trouble) "
        "becomes a positive case when a later decision of its trial comes this many seconds "
        "after it with no trouble and no diversion meanwhile; a reused positive case is "
        "credited then, and blamed when trouble comes sooner. None learns no positive cases.",
        validator=attrs.validators.optional(attrs.validators.gt(0.0)))


def linked(graph: LandmarkGraph) -> dict[str, list[str]]:
    """Each landmark's neighbours through an obstacle."""
    out: dict[str, list[str]] = {i: [] for i in graph.ids}
    for a, b in graph.obstacles:
        out[graph.ids[a]].append(graph.ids[b])
        out[graph.ids[b]].append(graph.ids[a])
    return out


@attrs.define
class _Reused:
    trial: int
    ended: float
    cases: tuple[int, ...]
    target: tuple[float, float]


@attrs.define
class _Quiet:
    """A consultation that needed no action, waiting to be found safe: the situation to learn
    (None when too few landmarks) or the positive cases reused there."""

    trial: int
    t: float
    view: View | None
    cases: tuple[int, ...]


class TroubleRetainer:
    """Learn negative situations from trouble, positive ones (with ``positive``) from
    consultations that needed no action, and how reused cases fared."""

    def __init__(self, options: RetainOptions, ctx: Context) -> None:
        self.options = options
        self._reused: _Reused | None = None
        self._quiet: list[_Quiet] = []
        self._failed = _failed(ctx)

    def _known(self, base: SituationBase, graph: LandmarkGraph, sign: str) -> bool:
        """Whether a case at least ``duplicate`` similar to ``graph`` is stored: a negative
        one for a new negative case, any for a new positive one."""
        o = self.options
        return any(sign == "positive" or base.cases[hit.row].sign == "negative"
                   for hit in base.index.search(graph, o.duplicate, o.similarity))

    def _count(self, base: SituationBase, ids: tuple[int, ...], helped: bool) -> None:
        for case_id in ids:
            case = base.get(case_id)
            if case is not None:  # forgotten meanwhile (by another process, say)
                base.replace(attrs.evolve(case, helped=case.helped + helped,
                                          failed=case.failed + (not helped)))

    @hookimpl
    def cbr_retain(self, problem: Situation, solution: Solution, outcome: Outcome,
                   ctx: Context) -> None:
        base = base_of(ctx)
        o = self.options
        report = outcome.report if isinstance(outcome.report, ActionReport) else None
        trouble = problem.trigger == "blocked"
        blamed = self._settle(base, problem, trouble, solution.no_action)
        reused, self._reused = self._reused, None
        if reused is not None and reused.trial == problem.trial:
            if trouble and problem.t - reused.ended <= o.window:
                self._count(base, reused.cases, helped=False)
                self._failed.append(Failure(reused.trial, *reused.target))
            elif not trouble:
                self._reused = reused
        if solution.no_action:
            if trouble:
                # a positive case said the robot would be fine where it is in trouble (blamed
                # once, if it was blamed for the quiet before too)
                self._count(base, tuple(set(solution.cases) - blamed), helped=False)
            elif o.positive is not None:
                view = None if solution.cases else problem_view(problem, o.region,
                                                                course=o.course)
                self._quiet.append(_Quiet(problem.trial, problem.t, view, solution.cases))
            return
        if solution.cases:
            self._credit(base, solution, report, problem)
            return
        if not (trouble and isinstance(solution.value, Divert) and outcome.success):
            return
        view = problem_view(problem, o.region, course=o.course)
        if view is not None:
            self._learn(base, view, solution.value)

    def _settle(self, base: SituationBase, problem: Situation, trouble: bool,
                quiet: bool) -> set[int]:
        """Decide the consultations that needed no action, now that ``problem`` came: safe
        once ``positive`` seconds of its trial passed without trouble or diversion (a new
        positive case, or credit for the positive cases reused), a trap when trouble came
        sooner (blame for those cases); undecided ones of another trial are dropped, since the
        retainer does not hear how a trial ended without a decision open. A case is credited
        or blamed once per decision, however many quiet consultations reused it; returns the
        cases blamed."""
        horizon = self.options.positive
        if horizon is None:
            return set()
        waiting = []
        credited: set[int] = set()
        blamed: set[int] = set()
        for q in self._quiet:
            if q.trial != problem.trial:
                continue
            if problem.t - q.t >= horizon:
                credited.update(q.cases)
                if q.view is not None:
                    self._learn(base, q.view, None)
            elif trouble:
                blamed.update(q.cases)
            elif quiet:
                waiting.append(q)
        self._quiet = waiting
        self._count(base, tuple(sorted(credited)), helped=True)
        self._count(base, tuple(sorted(blamed)), helped=False)
        return blamed

    def _credit(self, base: SituationBase, solution: Solution, report: ActionReport | None,
                problem: Situation) -> None:
        """Credit or blame the reused cases for how their diverting target went."""
        if report is None or not isinstance(solution.value, Divert):
            return
        target = (solution.value.x, solution.value.y)
        if report.reason == REACHED and report.trial_success is None:
            self._count(base, solution.cases, helped=True)
            # the trial goes on: trouble soon after still blames the case
            self._reused = _Reused(problem.trial, report.ended, solution.cases, target)
        elif report.reason in (REACHED, TRIAL_ENDED):
            self._count(base, solution.cases, helped=bool(report.trial_success))
        elif report.reason == GIVEN_UP:
            self._count(base, solution.cases, helped=False)
            self._failed.append(Failure(problem.trial, *target))

    def _learn(self, base: SituationBase, view: View, divert: Divert | None) -> None:
        """Store ``view`` as a negative case diverting to ``divert``, or as a positive case
        (``divert`` None), unless a like case is stored."""
        if self.options.keep == "obstacles":
            reached = sorted({k for pair in view.graph.obstacles for k in pair})
            if len(reached) >= 2:
                view = sub_view(view, reached)
        graph = view.graph
        sign: Literal["negative", "positive"] = "positive" if divert is None else "negative"
        if self._known(base, graph, sign):
            return
        if divert is None:
            base.add(LandmarkCase(graph, None, "positive"))
            return
        world = view.world_points()
        places = {landmark: world[i] for i, landmark in enumerate(graph.ids)}
        action = DivertAction.toward((divert.x, divert.y), places, linked(graph))
        base.add(LandmarkCase(graph, action, "negative"))


@attrs.frozen
class ForgetOptions:
    failures: int = option(
        2, "Forget a case once it has failed this many times and more often than it helped.",
        validator=attrs.validators.ge(1))


class UnhelpfulSituations:
    """Forget the cases that were reused and did not help."""

    def __init__(self, options: ForgetOptions, ctx: Context) -> None:
        self.options = options

    @hookimpl
    def cbr_forget(self, ctx: Context) -> None:
        base = base_of(ctx)
        n = self.options.failures
        base.remove([c.id for c in base.cases
                     if c.id is not None and c.failed >= n and c.failed > c.helped])

