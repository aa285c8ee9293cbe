"""What a recording holds: its topics, their types, counts and time spans."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import attrs

from cbrcore.errors import CbrError


@attrs.frozen
class Topic:
    """One topic of a recording: its message type, how many messages, first and last time
    (seconds)."""

    name: str
    type: str
    count: int
    first: float | None
    last: float | None


@attrs.frozen
class Contents:
    """A recording's topics, its time span (seconds) and whether it was closed (has its
    summary): one that was not (a killed run) holds the messages of its complete chunks."""

    path: Path
    profile: str
    topics: tuple[Topic, ...]
    start: float | None
    end: float | None
    closed: bool

    def as_dict(self) -> dict[str, Any]:
        return {"file": str(self.path), "profile": self.profile, "closed": self.closed,
                "start": self.start, "end": self.end,
                "topics": [attrs.asdict(topic) for topic in self.topics]}


def contents(path: Path) -> Contents:
    """What ``path`` holds; a CbrError unless it is an MCAP file."""
    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    try:
        handle = path.open("rb")
    except FileNotFoundError:
        raise CbrError(f"{path}: no such file") from None
    except OSError as exc:
        raise CbrError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    with handle:
        try:
            reader = make_reader(handle)
            header = reader.get_header()
            closed = reader.get_summary() is not None
            return _by_reading(path, header.profile, reader, closed)
        except (McapError, ValueError, EOFError, AssertionError) as exc:
            raise CbrError(f"{path}: not a readable MCAP file ({exc})") from None


def _seconds(ns: int) -> float:
    return ns / 1e9


def _by_reading(path: Path, profile: str, reader: Any, closed: bool) -> Contents:
    """Every topic's count and time span, from reading every message (undecoded): the
    summary's statistics count messages per channel but do not give a channel's span."""
    found: dict[str, list[Any]] = {}
    for schema, channel, message in reader.iter_messages(log_time_order=False):
        entry = found.setdefault(channel.topic, [schema.name if schema else "", 0, None, None])
        entry[1] += 1
        t = message.log_time
        entry[2] = t if entry[2] is None else min(entry[2], t)
        entry[3] = t if entry[3] is None else max(entry[3], t)
    topics = tuple(Topic(name, kind, count, _seconds(first), _seconds(last))
                   for name, (kind, count, first, last) in found.items())
    firsts = [topic.first for topic in topics if topic.first is not None]
    lasts = [topic.last for topic in topics if topic.last is not None]
    return Contents(path, profile, topics, min(firsts, default=None), max(lasts, default=None),
                    closed)
