"""World fingerprints: what a case base records of the world its cases belong to.

A world plugin answers ``cbr_world_fingerprint`` for its worlds with :func:`fingerprint`, giving
the world's content (a grid's cells and frame, a 2D world's walls and landmarks) as plain values
and NumPy arrays. The content is encoded canonically (every value tagged with its type, mapping
keys sorted, floats written exactly, arrays as little-endian bytes with their dtype and shape) and
hashed with SHA-256, so a fingerprint depends on the content alone: the same in every process and
on every machine, and different as soon as one cell, wall or frame differs.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Mapping
from typing import Any

import attrs
import numpy as np

from cbrcore.model import JSON

SHORT = 12
"""The hexadecimal digits of a fingerprint that messages and listings show."""

_DIGEST = re.compile(r"[0-9a-f]{64}")


@attrs.frozen
class WorldFingerprint:
    """A world as a case base records it: the SHA-256 of its content and a short description
    for people (``office 100x100, seed 7``), which takes no part in comparisons."""

    sha256: str
    description: str = attrs.field(eq=False)

    @property
    def short(self) -> str:
        """The first :data:`SHORT` digits of the hash, as messages show it."""
        return self.sha256[:SHORT]

    def __str__(self) -> str:
        return f"{self.description} (world {self.short})"

    def to_data(self) -> dict[str, JSON]:
        return {"sha256": self.sha256, "description": self.description}

    @classmethod
    def from_data(cls, value: Any) -> WorldFingerprint | None:
        """The fingerprint written as :meth:`to_data` writes it; None for anything else."""
        if (isinstance(value, Mapping) and set(value) == {"sha256", "description"}
                and isinstance(value["sha256"], str) and _DIGEST.fullmatch(value["sha256"])
                and isinstance(value["description"], str)):
            return cls(value["sha256"], value["description"])
        return None


def fingerprint(kind: str, content: Any, description: str) -> WorldFingerprint:
    """The fingerprint of a world of ``kind`` (the plugin's name for its sort of world, so that
    two sorts never share a hash) whose content is ``content``: None, booleans, integers, floats,
    strings, bytes, NumPy arrays and scalars, and lists, tuples, mappings with string keys and
    attrs instances (their fields by name) of these."""
    digest = hashlib.sha256()
    _encode(digest, kind)
    _encode(digest, content)
    return WorldFingerprint(digest.hexdigest(), description)


def _sized(tag: bytes, data: bytes) -> bytes:
    return tag + str(len(data)).encode() + b":" + data


def _encode(digest: Any, value: Any) -> None:
    """Feed ``value`` to ``digest`` so that no two different values give the same bytes."""
    if isinstance(value, np.generic):
        value = value.item()
    if value is None:
        digest.update(b"N")
    elif isinstance(value, bool):
        digest.update(b"T" if value else b"F")
    elif isinstance(value, int):
        digest.update(_sized(b"i", str(value).encode()))
    elif isinstance(value, float):
        # the exact binary value: repr would do too, but hex says so on its face
        digest.update(_sized(b"f", value.hex().encode()))
    elif isinstance(value, str):
        digest.update(_sized(b"s", value.encode("utf-8", "surrogatepass")))
    elif isinstance(value, bytes):
        digest.update(_sized(b"b", value))
    elif isinstance(value, np.ndarray):
        array = np.ascontiguousarray(value, dtype=value.dtype.newbyteorder("<"))
        digest.update(_sized(b"a", f"{array.dtype.str}{array.shape}".encode()))
        # the bytes of _sized(b"", array.tobytes()), read in place: a map's copy would double
        # its memory while the engine is built
        digest.update(str(array.nbytes).encode() + b":")
        digest.update(memoryview(array.reshape(-1)).cast("B"))
    elif isinstance(value, Mapping):
        if not all(isinstance(key, str) for key in value):
            raise TypeError("a fingerprint's mappings have string keys")
        digest.update(b"m" + str(len(value)).encode() + b":")
        for key in sorted(value):
            _encode(digest, key)
            _encode(digest, value[key])
    elif isinstance(value, list | tuple):
        digest.update(b"l" + str(len(value)).encode() + b":")
        for item in value:
            _encode(digest, item)
    elif attrs.has(type(value)):
        _encode(digest, {field.name: getattr(value, field.name)
                         for field in attrs.fields(type(value)) if field.init})
    else:
        raise TypeError(f"a fingerprint cannot encode a {type(value).__name__}")
