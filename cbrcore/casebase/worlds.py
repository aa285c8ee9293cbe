"""The worlds a case base's cases belong to, recorded in its meta.

Cases that name a world's cells (a case graph's segments, whole paths, learned risks) are
meaningless, and harmful, in another world. A run whose components use such cases records the
fingerprint of its world (:mod:`cbrcore.fingerprint`) under the meta key :data:`WORLDS_KEY` in
its first learn step, and a run or an import that would bring another world's cases together
with them is refused (:class:`OtherWorld`) unless the case base's store is configured with
``worlds: any``. The record is a list: one world, or several when cases were let carry over,
which ``cbr casebase check`` reports.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import attrs

from cbrcore.casebase.store import CaseStore
from cbrcore.errors import CaseBaseError
from cbrcore.fingerprint import WorldFingerprint

WORLDS_KEY = "cbrcore.worlds"
"""The meta key of the worlds a case base's cases belong to: a list of
``{"sha256": ..., "description": ...}``."""

Worlds = Literal["one", "any"]
"""Whether a case base takes the cases of one world only (``one``) or of any (``any``)."""

ONE: Worlds = "one"
ANY: Worlds = "any"


WORLDS_DOC = ("one: the case base holds the cases of the world it recorded first, and a run or "
              "an import of another world's cases is refused (exit 2); any: cases of several "
              "worlds carry over into it (cbr casebase check reports them). Runs whose "
              "components are all world-independent record no world.")
"""The documentation of the ``worlds`` option of every store of cbrcore."""

WORLDS_VALIDATOR = attrs.validators.in_((ONE, ANY))


def store_policy(options: object) -> Worlds:
    """The ``worlds`` setting of a store's options; ``one`` for a store that has no such option
    (a plugin's store offers it as ``worlds: Worlds = option(ONE, WORLDS_DOC,
    validator=WORLDS_VALIDATOR)``)."""
    value = getattr(options, "worlds", ONE)
    return ANY if value == ANY else ONE


class OtherWorld(CaseBaseError):
    """A case base whose cases belong to another world than those about to join them."""


def recorded_worlds(casebase: CaseStore) -> tuple[list[WorldFingerprint], list[str]]:
    """The worlds ``casebase`` records (none when it records none) and what is wrong with the
    record."""
    return parse_worlds(casebase.get_meta(WORLDS_KEY), f"meta {WORLDS_KEY!r}")


def parse_worlds(value: object, where: str) -> tuple[list[WorldFingerprint], list[str]]:
    """The worlds a record ``value`` (read at ``where``) lists, and what is wrong with it."""
    if value is None:
        return [], []
    expected = "expected a list of {sha256: 64 hexadecimal digits, description: text}"
    if not isinstance(value, list):
        return [], [f"{where} is a {type(value).__name__}; {expected}"]
    worlds: list[WorldFingerprint] = []
    problems = []
    for index, entry in enumerate(value):
        world = WorldFingerprint.from_data(entry)
        if world is None:
            problems.append(f"{where}[{index}]: {expected}")
        elif world in worlds:
            problems.append(f"{where}[{index}]: world {world.short} is listed twice")
        else:
            worlds.append(world)
    return worlds, problems


def listing(worlds: Sequence[WorldFingerprint]) -> str:
    """``worlds`` for a message: ``office 100x100, seed 1 (world 3fa2c1d9e0b4) and ...``."""
    shown = [str(world) for world in worlds]
    return shown[0] if len(shown) == 1 else ", ".join(shown[:-1]) + " and " + shown[-1]


def admit(recorded: Sequence[WorldFingerprint], joining: Sequence[WorldFingerprint],
          policy: Worlds, casebase: object, what: str) -> list[WorldFingerprint]:
    """The worlds a case base recording ``recorded`` records once the cases of the worlds
    ``joining`` join it; ``what`` says who brings them, in the error (``this run's world is``).

    With ``policy`` ``one`` that may be one world at most: otherwise :class:`OtherWorld` names
    the case base, both sides' worlds (descriptions and short hashes) and how to proceed.
    """
    merged = list(recorded) + [world for world in joining if world not in recorded]
    if policy == ANY or len(merged) <= 1:
        return merged
    noun = "world" if len(recorded) == 1 else f"{len(recorded)} worlds"
    raise OtherWorld(
        f"case base {casebase} holds the cases of another world: it records the {noun} "
        f"{listing(recorded)}; {what} {listing(joining)}. Its cases name "
        "another world's cells: use the world it records (the same map, or the same generator "
        "and seed; vary only the trips, with the workload's own seed), or another case base; "
        "to let the cases carry over all the same, configure the case base with worlds: any "
        "(--set casebase.worlds=any)")


def record_world(casebase: CaseStore, world: WorldFingerprint, policy: Worlds) -> None:
    """Record ``world`` among the worlds of ``casebase``, or raise :class:`OtherWorld` when the
    case base holds another world's cases and ``policy`` is ``one``.

    One transaction: the record read is the one written against, so of two processes of
    different worlds starting on one new case base, the second to learn is refused. A case base
    that records ``world`` already is not written to.
    """
    with casebase.transaction():
        join_worlds(casebase, [world], policy, "this run's world is")


def join_worlds(casebase: CaseStore, joining: Sequence[WorldFingerprint], policy: Worlds,
                what: str) -> None:
    """Record the worlds ``joining`` of cases that ``what`` adds to ``casebase`` (see
    :func:`admit`), inside the caller's transaction."""
    if not joining:
        return
    recorded, problems = recorded_worlds(casebase)
    if problems:
        raise CaseBaseError(f"case base {casebase}: {problems[0]}; cbr casebase check lists "
                            "what is wrong")
    merged = admit(recorded, joining, policy, casebase, what)
    if merged != recorded:
        casebase.set_meta(WORLDS_KEY, [entry.to_data() for entry in merged])


def world_problems(casebase: CaseStore) -> list[str]:
    """What ``cbr casebase check`` reports of the worlds ``casebase`` records: a malformed
    record, and cases of more than one world."""
    worlds, problems = recorded_worlds(casebase)
    if len(worlds) > 1:
        problems.append(f"meta {WORLDS_KEY!r}: the cases belong to {len(worlds)} worlds, "
                        f"{listing(worlds)}; a case base holds one world's cases (these carried "
                        "over with worlds: any)")
    return problems
