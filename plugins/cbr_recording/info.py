"""What a recording holds: its topics, their types, counts and time spans."""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import attrs

from cbrcore.errors import CbrError


def _broken() -> tuple[type[Exception], ...]:
    """What reading a damaged or cut-short record raises."""
    from mcap.exceptions import McapError

    return (McapError, EOFError, ValueError, struct.error, RuntimeError)


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
    """What ``path`` holds, read record by record from the start, so that the file of a
    killed run (no summary, maybe a record cut short at its end) reads as far as it goes; a
    CbrError unless it starts as an MCAP file."""
    from mcap.records import Channel, Footer, Header, Message, Schema
    from mcap.stream_reader import StreamReader

    try:
        handle = path.open("rb")
    except FileNotFoundError:
        raise CbrError(f"{path}: no such file") from None
    except OSError as exc:
        raise CbrError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    with handle:
        records = StreamReader(handle).records
        try:
            header = next(records)
        except (*_broken(), StopIteration) as exc:
            why = str(exc) or ("the file is empty" if isinstance(exc, StopIteration)
                               else type(exc).__name__)
            raise CbrError(f"{path}: not a readable MCAP file ({why})") from None
        if not isinstance(header, Header):
            raise CbrError(f"{path}: not a readable MCAP file (no header record)")
        schemas: dict[int, str] = {}
        channels: dict[int, tuple[str, int]] = {}
        found: dict[int, list[int]] = {}
        closed = False
        try:
            for record in records:
                if isinstance(record, Message):
                    entry = found.setdefault(record.channel_id, [0, record.log_time,
                                                                 record.log_time])
                    entry[0] += 1
                    entry[1] = min(entry[1], record.log_time)
                    entry[2] = max(entry[2], record.log_time)
                elif isinstance(record, Schema):
                    schemas[record.id] = record.name
                elif isinstance(record, Channel):
                    channels[record.id] = (record.topic, record.schema_id)
                elif isinstance(record, Footer):
                    closed = True
        except _broken():
            pass  # a record cut short by a killed run: what came before it stands
    topics = []
    for channel_id, (topic, schema_id) in channels.items():
        count, first, last = found.get(channel_id, (0, None, None))
        topics.append(Topic(topic, schemas.get(schema_id, ""), count,
                            None if first is None else first / 1e9,
                            None if last is None else last / 1e9))
    firsts = [t.first for t in topics if t.first is not None]
    lasts = [t.last for t in topics if t.last is not None]
    return Contents(path, header.profile, tuple(topics), min(firsts, default=None),
                    max(lasts, default=None), closed)
