"""The record of one delivery day that ``cbr rupart day`` draws: why was the robot slow?

The ``delivery`` workload (``log: true``) calls :meth:`DayLog.step` on every simulation step,
:meth:`DayLog.retrieval` on every consultation of the case memory and :meth:`DayLog.event` when
a message arrives, is delivered or missed, or the robot hits an impasse, a collision or a stall;
at the day's end it saves the log as ``day_N.npz`` in the run folder. :mod:`cbr_behaviors.dayplot`
draws it over the day's world.

A day is 18,000 steps of 0.1 s, so :meth:`~DayLog.step` only appends one tuple to a list (a
case name is stored as its index into :attr:`DayLog.cases`); the lists become arrays when the
log is saved. The file is a compressed NumPy archive of plain arrays (no pickles), tagged with
:data:`FORMAT` so that another ``.npz`` is refused by name rather than misread.
"""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Any

import attrs
import numpy as np

from cbrcore import files
from cbrcore.errors import CbrError

FORMAT = "cbr_behaviors.daylog"
"""The tag a day log file carries in its ``format`` array."""
VERSION = 1
"""The layout of the arrays this module writes; a file of a later one is refused."""
EVENT_KINDS = ("message", "delivered", "missed", "unfinished", "impasse", "collision", "stall")
"""What :meth:`DayLog.event` records: a message arrived, was delivered, missed its deadline or
was still open at the day's end (each with the place as its text), the robot met an impasse,
drove into something, or stalled."""
GOAL_EVENTS = ("message", "delivered", "missed", "unfinished")
"""The event kinds about a message, whose text is the message's place."""
RETRIEVAL_KINDS = ("behavior_case", "meta_plan", "plan_case", "")
"""The kinds of case a retrieval installs (:data:`cbr_behaviors.casetypes.KINDS` less the
adaptation strategies, which are never installed), and ``""`` for a consultation that
installed none."""

_STEP_COLUMNS = ("t", "x", "y", "theta", "v", "w", "target_x", "target_y")
"""The float columns of the ``steps`` array; an idle robot's target is NaN."""


@attrs.frozen
class Track:
    """A day's steps as arrays, one row per simulation step: the true pose, the measured
    speed ``v`` (m/s) and turn rate ``w`` (rad/s), the target steered for (``(n, 2)``, NaN
    while idle), the installed case as an index into :attr:`DayLog.cases`, and whether the
    robot had a message goal."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    theta: np.ndarray
    v: np.ndarray
    w: np.ndarray
    target: np.ndarray
    case: np.ndarray
    busy: np.ndarray

    def __len__(self) -> int:
        return int(self.t.shape[0])


@attrs.frozen
class Retrieval:
    """One consultation of the case memory (see :meth:`DayLog.retrieval`)."""

    t: float
    case: str
    kind: str
    triggers: tuple[str, ...]
    similarity: float
    adapted: bool


@attrs.frozen
class Event:
    """Something that happened at ``(x, y)`` at time ``t`` (see :meth:`DayLog.event`)."""

    t: float
    kind: str
    x: float
    y: float
    text: str = ""


@attrs.define
class DayLog:
    """Everything of one delivery day a viewer needs."""

    day: int
    cases: list[str] = attrs.field(factory=list)
    """The names of the installed cases, in the order first seen; steps refer to them by
    index."""
    retrievals: list[Retrieval] = attrs.field(factory=list)
    events: list[Event] = attrs.field(factory=list)
    _steps: list[tuple[Any, ...]] = attrs.field(factory=list, alias="steps")
    clocks: np.ndarray | None = attrs.field(default=None, eq=False)
    """Each mover's own clock at each step, ``(steps, movers)``, when people yielded to the
    robot (None: every mover's clock was the time); the day's GIF draws them from it."""
    _index: dict[str, int] = attrs.field(factory=dict, init=False, repr=False, eq=False)

    def __attrs_post_init__(self) -> None:
        self._index.update((name, i) for i, name in enumerate(self.cases))

    def _case(self, name: str) -> int:
        index = self._index.get(name)
        if index is None:
            index = self._index[name] = len(self.cases)
            self.cases.append(name)
        return index

    def step(self, t: float, x: float, y: float, theta: float, v: float, w: float,
             case: str, target: tuple[float, float] | None, busy: bool) -> None:
        """Record one simulation step: the true pose, the measured speed ``v`` (m/s) and turn
        rate ``w`` (rad/s), the name of the behavior case installed (``""`` or a name such as
        ``"fixed"`` when none), the point the robot steers for (None when idle) and whether
        it has a message goal."""
        tx, ty = (np.nan, np.nan) if target is None else target
        self._steps.append((t, x, y, theta, v, w, tx, ty, self._case(case), busy))

    def retrieval(self, t: float, case: str, kind: str, triggers: tuple[str, ...],
                  similarity: float, adapted: bool) -> None:
        """Record a consultation of the case memory: the case it installed, the case's
        ``kind`` (one of :data:`RETRIEVAL_KINDS`; ``""`` and any case name when it installed
        none), the triggers that fired, the similarity in [0, 1] (NaN when unknown) and
        whether the case was adapted."""
        if kind not in RETRIEVAL_KINDS:
            raise ValueError(f"retrieval kind {kind!r}: expected one of "
                             f"{', '.join(map(repr, RETRIEVAL_KINDS))}")
        self._case(case)
        self.retrievals.append(Retrieval(float(t), case, kind, tuple(triggers),
                                         float(similarity), bool(adapted)))

    def event(self, t: float, kind: str, x: float, y: float, text: str = "") -> None:
        """Record an event of ``kind`` (one of :data:`EVENT_KINDS`) at ``(x, y)``; the goal
        events' ``text`` is the message's place."""
        if kind not in EVENT_KINDS:
            raise ValueError(f"event kind {kind!r}: expected one of {', '.join(EVENT_KINDS)}")
        self.events.append(Event(float(t), kind, float(x), float(y), text))

    def track(self) -> Track:
        """The steps so far as arrays."""
        rows = np.array([row[:8] for row in self._steps], dtype=float).reshape(-1, 8)
        return Track(t=rows[:, 0], x=rows[:, 1], y=rows[:, 2], theta=rows[:, 3],
                     v=rows[:, 4], w=rows[:, 5], target=rows[:, 6:8],
                     case=np.array([row[8] for row in self._steps], dtype=np.int32),
                     busy=np.array([row[9] for row in self._steps], dtype=bool))

    def count(self, kind: str) -> int:
        """How many events of ``kind`` the day had."""
        return sum(event.kind == kind for event in self.events)

    # --- the file ------------------------------------------------------------------------

    def save(self, path: Path) -> None:
        """Write the log to ``path`` as one compressed ``.npz``, replacing the file whole or
        not at all."""
        track = self.track()
        retrievals, events = self.retrievals, self.events
        arrays: dict[str, np.ndarray] = {
            "format": np.array(FORMAT), "version": np.array(VERSION),
            "day": np.array(self.day), "cases": _strings(self.cases),
            "steps": np.column_stack([track.t, track.x, track.y, track.theta, track.v,
                                      track.w, track.target]).reshape(-1, len(_STEP_COLUMNS)),
            "step_case": track.case, "step_busy": track.busy,
            "retrieval_t": np.array([r.t for r in retrievals], dtype=float),
            "retrieval_case": np.array([self._index[r.case] for r in retrievals],
                                       dtype=np.int32),
            "retrieval_kind": _strings([r.kind for r in retrievals]),
            # a retrieval fires one or more triggers: their names flattened, with the count
            # of each retrieval's, rather than joined into a string a name could contain
            "retrieval_triggers": _strings([name for r in retrievals for name in r.triggers]),
            "retrieval_trigger_count": np.array([len(r.triggers) for r in retrievals],
                                                dtype=np.int32),
            "retrieval_similarity": np.array([r.similarity for r in retrievals], dtype=float),
            "retrieval_adapted": np.array([r.adapted for r in retrievals], dtype=bool),
            "event_t": np.array([e.t for e in events], dtype=float),
            "event_kind": _strings([e.kind for e in events]),
            "event_xy": np.array([(e.x, e.y) for e in events], dtype=float).reshape(-1, 2),
            "event_text": _strings([e.text for e in events]),
        }
        if self.clocks is not None:
            arrays["mover_clocks"] = np.asarray(self.clocks, dtype=float)
        try:
            with files.replacing(path, "wb") as handle:
                np.savez_compressed(handle, **arrays)
        except OSError as exc:
            raise CbrError(f"{path}: cannot write the day log ({exc.strerror or exc})") from exc

    @classmethod
    def load(cls, path: Path) -> DayLog:
        """Read a log :meth:`save` wrote; a CbrError naming ``path`` when it is missing or is
        not a day log."""
        expected = ("expected a day log (day_N.npz) that the delivery workload writes with "
                    "workload.log: true")
        try:
            with files.open_regular(path) as handle:
                loaded = np.load(handle, allow_pickle=False)
                if not isinstance(loaded, np.lib.npyio.NpzFile):  # a lone .npy array
                    raise CbrError(f"{path}: not a day log (one array, not an archive); "
                                   f"{expected}")
                with loaded:
                    arrays = {name: loaded[name] for name in loaded.files}
        except FileNotFoundError:
            raise CbrError(f"{path}: no such file; {expected}") from None
        except IsADirectoryError:
            raise CbrError(f"{path}: is a folder; {expected}") from None
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
            # np.load reads a file that is neither .npz nor .npy as a pickle, refused here
            raise CbrError(f"{path}: not a day log ({exc}); {expected}") from None
        if str(arrays.get("format", "")) != FORMAT:
            raise CbrError(f"{path}: not a day log (it has no '{FORMAT}' tag); {expected}")
        try:
            version = int(arrays["version"])
            if version > VERSION:
                raise CbrError(f"{path}: a day log of layout {version}, newer than this cbr "
                               f"reads ({VERSION}); update cbr to read it")
            return cls._of(arrays)
        except (KeyError, ValueError, TypeError, IndexError) as exc:
            raise CbrError(f"{path}: a damaged day log ({type(exc).__name__}: {exc}); "
                           f"{expected}") from None

    @classmethod
    def _of(cls, arrays: dict[str, np.ndarray]) -> DayLog:
        cases = [str(name) for name in arrays["cases"]]
        steps = arrays["steps"]
        if steps.ndim != 2 or steps.shape[1] != len(_STEP_COLUMNS):
            raise ValueError(f"steps of shape {steps.shape}, expected (n, {len(_STEP_COLUMNS)})")
        rows = steps.tolist()
        step_case = arrays["step_case"].tolist()
        step_busy = arrays["step_busy"].tolist()
        if not len(rows) == len(step_case) == len(step_busy):
            raise ValueError("the step columns differ in length")
        counts = arrays["retrieval_trigger_count"].tolist()
        names = [str(n) for n in arrays["retrieval_triggers"]]
        ends = np.cumsum(counts).tolist()
        if ends and ends[-1] != len(names):
            raise ValueError("the retrievals' trigger counts do not add up to their triggers")
        retrievals = [
            Retrieval(t, cases[case], str(kind), tuple(names[end - count:end]), similarity,
                      adapted)
            for t, case, kind, count, end, similarity, adapted in zip(
                arrays["retrieval_t"].tolist(), arrays["retrieval_case"].tolist(),
                arrays["retrieval_kind"], counts, ends,
                arrays["retrieval_similarity"].tolist(), arrays["retrieval_adapted"].tolist(),
                strict=True)]
        events = [Event(t, str(kind), x, y, str(text)) for t, kind, (x, y), text in zip(
            arrays["event_t"].tolist(), arrays["event_kind"], arrays["event_xy"].tolist(),
            arrays["event_text"], strict=True)]
        if step_case and not 0 <= min(step_case) <= max(step_case) < len(cases):
            raise IndexError("a step names a case past the list of cases")
        clocks = arrays.get("mover_clocks")
        if clocks is not None and (clocks.ndim != 2 or len(clocks) != len(rows)):
            raise ValueError(f"mover clocks of shape {clocks.shape}, expected one row a step")
        return cls(day=int(arrays["day"]), cases=cases, retrievals=retrievals, events=events,
                   steps=[(*row, case, busy) for row, case, busy
                          in zip(rows, step_case, step_busy, strict=True)], clocks=clocks)


def _strings(values: list[str]) -> np.ndarray:
    """``values`` as a NumPy unicode array, which loads without pickles (an empty list too)."""
    return np.array(values, dtype=str) if values else np.zeros(0, dtype="<U1")
