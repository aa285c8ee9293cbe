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
    index); one that was not (a killed run) was read through to count."""

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
    """Read ``path``'s summary (or, lacking one, every message); a CbrError unless it is an
    MCAP file."""
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
            summary = reader.get_summary()
            if summary is not None and summary.statistics is not None:
                return _from_summary(path, header.profile, summary)
            return _by_reading(path, header.profile, reader)
        except (McapError, ValueError, EOFError, AssertionError) as exc:
            raise CbrError(f"{path}: not a readable MCAP file ({exc})") from None


def _seconds(ns: int) -> float:
    return ns / 1e9


def _from_summary(path: Path, profile: str, summary: Any) -> Contents:
    stats = summary.statistics
    counts = stats.channel_message_counts
    # the summary's statistics give each channel's count, the message index its time span
    spans: dict[int, list[int]] = {}
    for index in summary.chunk_indexes:
        for channel in index.message_index_offsets:
            span = spans.setdefault(channel, [index.message_start_time,
                                              index.message_end_time])
            span[0] = min(span[0], index.message_start_time)
            span[1] = max(span[1], index.message_end_time)
    topics = []
    for channel_id, channel in sorted(summary.channels.items()):
        schema = summary.schemas.get(channel.schema_id)
        span = spans.get(channel_id)
        topics.append(Topic(channel.topic, schema.name if schema else "",
                            counts.get(channel_id, 0),
                            None if span is None else _seconds(span[0]),
                            None if span is None else _seconds(span[1])))
    empty = stats.message_count == 0
    return Contents(path, profile, tuple(topics),
                    None if empty else _seconds(stats.message_start_time),
                    None if empty else _seconds(stats.message_end_time), True)


def _by_reading(path: Path, profile: str, reader: Any) -> Contents:
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
                    False)
