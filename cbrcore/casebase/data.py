"""The rules for what a case base may store.

Every store applies them to what it is given: case contents and plugin meta values must be plain
JSON data (dicts with string keys, lists, strings, numbers, booleans, None). NaN and infinity are
refused rather than stored: they are not JSON, and a value that silently turned into ``null`` or
broke the export would be worse than an error at the point where it was produced. Tuples are
refused too, because they would come back as lists. Case kinds and meta keys must be valid Unicode
text, revision stamps cannot be ahead of the case base, and one meta key is reserved for the
revision itself.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from typing import Any

from cbrcore.model import JSON, Case

REVISION_KEY = "cbrcore.revision"
"""The meta key a store keeps its revision under; plugins cannot use it."""

MAX_INTEGER = 2**63 - 1
"""The largest id, use count, revision or revision stamp a case base holds (SQLite's largest
integer)."""


def is_json(value: Any) -> bool:
    """Whether ``value`` is plain JSON data (the fast test; :func:`json_problems` says why not)."""
    if value is None or isinstance(value, str | int):
        return True
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, list):
        return all(is_json(item) for item in value)
    if isinstance(value, dict):
        return all(isinstance(k, str) and is_json(v) for k, v in value.items())
    return False


def _step(path: str, key: Any) -> str:
    return f"{path}.{key}" if isinstance(key, str) and key.isidentifier() else f"{path}[{key!r}]"


def json_problems(value: Any, path: str) -> Iterator[str]:
    """Why ``value`` is not plain JSON data: one ``"path: reason"`` per offending item."""
    if value is None or isinstance(value, str | int):
        return
    if isinstance(value, float):
        if not math.isfinite(value):
            yield f"{path}: {value!r} is not JSON data (NaN and infinity cannot be stored)"
    elif isinstance(value, list):
        for index, item in enumerate(value):
            yield from json_problems(item, f"{path}[{index}]")
    elif isinstance(value, dict):
        for key, item in value.items():
            if isinstance(key, str):
                yield from json_problems(item, _step(path, key))
            else:
                yield f"{path}: key {key!r} is not a string (JSON object keys are strings)"
    elif isinstance(value, tuple):
        yield f"{path}: a tuple is not JSON data; use a list"
    else:
        yield f"{path}: {type(value).__name__} {_short(value)} is not JSON data"


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _is_unicode(text: str) -> bool:
    # kinds and meta keys are stored as SQLite text, which must be valid UTF-8
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def _is_count(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def case_problems(case: Case, revision: int | None) -> list[str]:
    """What keeps ``case`` from being stored in a case base at ``revision``, one line each.

    ``revision`` bounds the case's revision stamps: a case cannot be created or used after the
    revision that stores it. None leaves the stamps unbounded.
    """
    problems: list[str] = []
    if not isinstance(case.kind, str) or not case.kind:
        problems.append(f"kind: expected a non-empty string, got {_short(case.kind)}")
    elif not _is_unicode(case.kind):
        problems.append(f"kind: {case.kind!r} is not valid Unicode text")
    for field in ("problem", "solution"):
        value = getattr(case, field)
        if not is_json(value):
            problems.extend(json_problems(value, field))
    if not isinstance(case.meta, Mapping):
        problems.append(f"meta: expected a mapping, got {_short(case.meta)}")
    elif not is_json(dict(case.meta)):
        problems.extend(json_problems(dict(case.meta), "meta"))
    if not _is_count(case.uses):
        problems.append(f"uses: expected a non-negative integer, got {_short(case.uses)}")
    elif case.uses > MAX_INTEGER:
        problems.append(f"uses: {_short(case.uses)} is beyond the largest integer a case base "
                        "holds (2^63 - 1)")
    for field in ("created", "last_used"):
        stamp = getattr(case, field)
        if stamp is None:
            continue
        if not _is_count(stamp):
            problems.append(f"{field}: expected a revision number, got {_short(stamp)}")
        elif stamp > MAX_INTEGER:
            problems.append(f"{field}: {_short(stamp)} is beyond the largest integer a case "
                            "base holds (2^63 - 1)")
        elif revision is not None and stamp > revision:
            problems.append(f"{field}: revision {stamp} is after the case base's "
                            f"revision {revision}")
    return problems


def check_since(since: int, revision: int) -> None:
    """Raise ValueError when ``changes(since)`` asks about a revision the case base, at
    ``revision``, has not reached (or a negative one)."""
    if not 0 <= since <= revision:
        raise ValueError(f"changes since revision {since}: expected a revision from 0 to "
                         f"{revision}")


def change_problems(case_id: int, created: int | None, last_used: int | None, changed: Any,
                    revision: int | None) -> list[str]:
    """What is wrong with the revision a store records as the last write of a case: it must lie
    from the case's creation or last use to the case base's ``revision``. Stamps that are
    themselves after the revision are left to :func:`case_problems`."""
    written = max(created or 0, last_used or 0)
    if revision is not None and written > revision:
        return []
    if not isinstance(changed, int) or changed < written or (
            revision is not None and changed > revision):
        # a write that did not record its revision would hide from processes catching up
        return [f"case {case_id}: changed at revision {changed!r}; expected a revision from "
                f"{written} (its creation or last use) to the case base's, {revision}"]
    return []


def removal_problems(removed: list[tuple[int, Any]], revision: int | None) -> list[str]:
    """What is wrong with a store's record of removed cases, (id, revision removed at) pairs:
    each removal is at a revision from 1 to the case base's."""
    return [f"removed case {case_id}: removed at revision {removed_at!r}; expected a revision "
            f"from 1 to the case base's, {revision}"
            for case_id, removed_at in removed
            if not isinstance(removed_at, int) or removed_at < 1
            or (revision is not None and removed_at > revision)]


def check_case(case: Case, revision: int) -> None:
    """Raise ValueError naming the case kind and the field when ``case`` cannot be stored."""
    problems = case_problems(case, revision)
    if problems:
        raise ValueError(f"case kind {case.kind!r}: " + "; ".join(problems[:3]))


def check_meta(key: str, value: JSON) -> None:
    """Raise when ``key`` is not a usable meta key or ``value`` is not plain JSON data."""
    check_meta_key(key)
    if not is_json(value):
        raise ValueError(f"meta key {key!r}: " + "; ".join(list(json_problems(value, "value"))[:3]))


def check_meta_key(key: str) -> None:
    """Raise when ``key`` is not a string of valid Unicode or is reserved for the revision."""
    if not isinstance(key, str):
        raise TypeError(f"meta keys are strings, got {key!r}")
    if not _is_unicode(key):
        raise ValueError(f"meta key {key!r} is not valid Unicode text")
    if key == REVISION_KEY:
        raise ValueError(f"meta key {key!r} is reserved for the case base's revision")
