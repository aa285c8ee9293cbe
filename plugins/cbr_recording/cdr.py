"""CDR encodings written with NumPy for the messages whose size grows with the run: a
``nav_msgs/msg/Path`` of thousands of poses costs milliseconds through the type store's
per-field serialiser and microseconds here. The bytes are those the type store writes
(checked by the tests); every other message goes through the type store.

ROS 2's CDR: a 4-byte little-endian encapsulation header, then each field aligned to its own
size (at most 8) counted from after that header; a string is its length with the closing NUL,
then its bytes and the NUL; a sequence is its length, then its items.
"""

from __future__ import annotations

import math
import struct

import numpy as np

_ENCAPSULATION = b"\x00\x01\x00\x00"
_POSE_BYTES = 7 * 8


def _header(sec: int, nanosec: int, frame: str) -> bytes:
    name = frame.encode() + b"\x00"
    return struct.pack("<iII", sec, nanosec, len(name)) + name


def _poses(points: np.ndarray, yaws: np.ndarray) -> np.ndarray:
    """(n, 56) bytes: position x, y, 0 and the quaternion of a turn by ``yaws`` about z."""
    half = 0.5 * yaws
    values = np.column_stack((points[:, 0], points[:, 1], np.zeros(len(points)),
                              np.zeros(len(points)), np.zeros(len(points)), np.sin(half),
                              np.cos(half))).astype("<f8")
    return values.view(np.uint8).reshape(len(points), _POSE_BYTES)


def headings(points: np.ndarray) -> np.ndarray:
    """Each point's heading along a path: towards the next point, the last as the one
    before."""
    step = np.diff(np.asarray(points, dtype=np.float64).reshape(-1, 2), axis=0)
    if not len(step):
        return np.zeros(len(points))
    yaws = np.arctan2(step[:, 1], step[:, 0])
    return np.append(yaws, yaws[-1])


def path(sec: int, nanosec: int, frame: str, points: np.ndarray, yaws: np.ndarray) -> bytes:
    """A ``nav_msgs/msg/Path`` whose poses (each stamped as the path) are at ``points`` (n, 2)
    facing ``yaws`` (n,)."""
    header = _header(sec, nanosec, frame)
    body = bytearray(header)
    body += b"\x00" * (-len(body) % 4)
    body += struct.pack("<I", len(points))
    if not len(points):
        return _ENCAPSULATION + bytes(body)
    poses = _poses(np.asarray(points, dtype=np.float64), np.asarray(yaws, dtype=np.float64))
    # the first pose starts 4-aligned, so its padding before the floats is its own; every
    # later one starts 8-aligned (the one before ends with a float64), so theirs is shared
    first_pad = -(len(body) + len(header)) % 8
    body += header + b"\x00" * first_pad + poses[0].tobytes()
    pad = -len(header) % 8
    rest = np.zeros((len(points) - 1, len(header) + pad + _POSE_BYTES), dtype=np.uint8)
    rest[:, :len(header)] = np.frombuffer(header, dtype=np.uint8)
    rest[:, len(header) + pad:] = poses[1:]
    return _ENCAPSULATION + bytes(body) + rest.tobytes()


def _pose(x: float, y: float, yaw: float) -> bytes:
    return struct.pack("<7d", x, y, 0.0, 0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw))


def pose_stamped(sec: int, nanosec: int, frame: str, x: float, y: float, yaw: float) -> bytes:
    """A ``geometry_msgs/msg/PoseStamped`` at (x, y) facing ``yaw``."""
    body = _header(sec, nanosec, frame)
    return _ENCAPSULATION + body + b"\x00" * (-len(body) % 8) + _pose(x, y, yaw)


def transform(sec: int, nanosec: int, parent: str, child: str, x: float, y: float,
              yaw: float) -> bytes:
    """A ``tf2_msgs/msg/TFMessage`` holding the one transform ``parent`` -> ``child``."""
    name = child.encode() + b"\x00"
    body = struct.pack("<I", 1) + _header(sec, nanosec, parent)
    body += b"\x00" * (-len(body) % 4) + struct.pack("<I", len(name)) + name
    # a Transform's translation and rotation are the seven numbers of a Pose
    return _ENCAPSULATION + body + b"\x00" * (-len(body) % 8) + _pose(x, y, yaw)


_PRIMITIVES = {"int32": struct.Struct("<i"), "uint32": struct.Struct("<I"),
               "float64": struct.Struct("<d")}


def flat(fields: list[tuple[str, object]]) -> bytes:
    """A message of primitive fields and strings only, each given as (type, value) in the
    definition's order: ``int32``, ``uint32``, ``float64`` or ``string``."""
    body = bytearray()
    for kind, value in fields:
        if kind == "string":
            text = str(value).encode() + b"\x00"
            body += b"\x00" * (-len(body) % 4)
            body += struct.pack("<I", len(text)) + text
        else:
            packer = _PRIMITIVES[kind]
            body += b"\x00" * (-len(body) % packer.size)
            body += packer.pack(value)
    return _ENCAPSULATION + bytes(body)
