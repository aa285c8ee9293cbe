"""The messages of a recording, encoded as CDR with NumPy and ``struct``.

A recording writes many small messages (a pose per step of a day) and some large ones (a path
of thousands of poses, a case graph of thousands of cells); the type store's per-field
serialiser costs tens of microseconds for the first and milliseconds for the second, more than
the simulation step the message records. These encoders write the same bytes (the tests
compare them with the type store's for every message type) in a few microseconds, the arrays in
one copy each. The type store still gives the schemas.

ROS 2's CDR: a 4-byte little-endian encapsulation header, then each field aligned to its own
size (at most 8) counted from after that header; a string is its length with the closing NUL,
then its bytes and the NUL; a sequence is its length, then its items.
"""

from __future__ import annotations

import json
import math
import struct
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from cbr_recording.markers import KINDS, Clear, Marker

_ENCAPSULATION = b"\x00\x01\x00\x00"
_ADD, _DELETEALL = 0, 3
_I32, _U32 = struct.Struct("<i"), struct.Struct("<I")
_F32, _F64 = struct.Struct("<f"), struct.Struct("<d")


class Encoder:
    """A message's bytes, field by field, aligned as CDR requires."""

    __slots__ = ("body",)

    def __init__(self) -> None:
        self.body = bytearray()

    def align(self, size: int) -> None:
        self.body += b"\x00" * (-len(self.body) % size)

    def i32(self, value: int) -> None:
        self.align(4)
        self.body += _I32.pack(value)

    def u32(self, value: int) -> None:
        self.align(4)
        self.body += _U32.pack(value)

    def f32(self, value: float) -> None:
        self.align(4)
        self.body += _F32.pack(value)

    def f64s(self, *values: float) -> None:
        self.align(8)
        self.body += struct.pack(f"<{len(values)}d", *values)

    def boolean(self, value: bool) -> None:
        self.body.append(1 if value else 0)

    def string(self, text: str) -> None:
        data = text.encode() + b"\x00"
        self.u32(len(data))
        self.body += data

    def array(self, values: np.ndarray, alignment: int) -> None:
        """A sequence of fixed-size items: its length, then ``values``'s rows as bytes."""
        self.u32(len(values))
        if len(values):
            self.align(alignment)
            self.body += np.ascontiguousarray(values).tobytes()

    def stamp(self, ns: int) -> None:
        sec, nanosec = divmod(ns, 1_000_000_000)
        self.i32(sec)
        self.u32(nanosec)

    def header(self, ns: int, frame: str) -> None:
        self.stamp(ns)
        self.string(frame)

    def pose(self, x: float, y: float, yaw: float, z: float = 0.0) -> None:
        self.f64s(x, y, z, 0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw))

    def bytes(self) -> bytes:
        return _ENCAPSULATION + bytes(self.body)


def _poses(points: np.ndarray, yaws: np.ndarray) -> np.ndarray:
    """(n, 56) bytes: position x, y, 0 and the quaternion of a turn by ``yaws`` about z."""
    half = 0.5 * yaws
    zeros = np.zeros(len(points))
    values = np.column_stack((points[:, 0], points[:, 1], zeros, zeros, zeros, np.sin(half),
                              np.cos(half))).astype("<f8")
    return values.view(np.uint8).reshape(len(points), 56)


def headings(points: np.ndarray) -> np.ndarray:
    """Each point's heading along a path: towards the next point, the last as the one
    before."""
    step = np.diff(np.asarray(points, dtype=np.float64).reshape(-1, 2), axis=0)
    if not len(step):
        return np.zeros(len(points))
    yaws = np.arctan2(step[:, 1], step[:, 0])
    return np.append(yaws, yaws[-1])


def path(ns: int, frame: str, points: np.ndarray, yaws: np.ndarray) -> bytes:
    """``nav_msgs/msg/Path``: poses (each stamped as the path) at ``points`` (n, 2) facing
    ``yaws`` (n,)."""
    head = Encoder()
    head.header(ns, frame)
    item = bytes(head.body)  # every pose's header is the path's
    out = Encoder()
    out.body += item
    out.u32(len(points))
    if not len(points):
        return out.bytes()
    poses = _poses(np.asarray(points, dtype=np.float64), np.asarray(yaws, dtype=np.float64))
    # the first pose starts 4-aligned, so its padding before the floats is its own; every
    # later one starts 8-aligned (the one before ends with a float64), so theirs is shared
    out.body += item
    out.align(8)
    out.body += poses[0].tobytes()
    pad = -len(item) % 8
    rest = np.zeros((len(points) - 1, len(item) + pad + 56), dtype=np.uint8)
    rest[:, :len(item)] = np.frombuffer(item, dtype=np.uint8)
    rest[:, len(item) + pad:] = poses[1:]
    out.body += rest.tobytes()
    return out.bytes()


def pose_stamped(ns: int, frame: str, x: float, y: float, yaw: float) -> bytes:
    """``geometry_msgs/msg/PoseStamped``."""
    out = Encoder()
    out.header(ns, frame)
    out.pose(x, y, yaw)
    return out.bytes()


def transform(ns: int, parent: str, child: str, x: float, y: float, yaw: float) -> bytes:
    """``tf2_msgs/msg/TFMessage`` holding the one transform ``parent`` -> ``child``."""
    out = Encoder()
    out.u32(1)
    out.header(ns, parent)
    out.string(child)
    out.pose(x, y, yaw)  # a Transform's translation and rotation: the seven numbers of a Pose
    return out.bytes()


def odometry(ns: int, frame: str, child: str, x: float, y: float, yaw: float, v: float,
             w: float) -> bytes:
    """``nav_msgs/msg/Odometry``: the pose and the speeds, covariances unknown (zero)."""
    out = Encoder()
    out.header(ns, frame)
    out.string(child)
    out.pose(x, y, yaw)
    covariance = (0.0,) * 36
    out.f64s(*covariance)
    out.f64s(v, 0.0, 0.0, 0.0, 0.0, w)
    out.f64s(*covariance)
    return out.bytes()


def laser_scan(ns: int, frame: str, angle_min: float, increment: float, ranges: np.ndarray,
               range_min: float, range_max: float, scan_time: float) -> bytes:
    """``sensor_msgs/msg/LaserScan`` without intensities."""
    out = Encoder()
    out.header(ns, frame)
    for value in (angle_min, angle_min + increment * (len(ranges) - 1), increment, 0.0,
                  scan_time, range_min, range_max):
        out.f32(value)
    out.array(np.asarray(ranges, dtype="<f4"), 4)
    out.u32(0)
    return out.bytes()


def occupancy_grid(ns: int, frame: str, data: np.ndarray, resolution: float,
                   origin: tuple[float, float, float]) -> bytes:
    """``nav_msgs/msg/OccupancyGrid`` of ``data`` (rows from the lower left, int8: -1
    unknown, 0..100 occupied), loaded at ``ns``."""
    height, width = data.shape
    out = Encoder()
    out.header(ns, frame)
    out.stamp(ns)
    out.f32(resolution)
    out.u32(width)
    out.u32(height)
    out.pose(*origin)
    out.array(np.asarray(data, dtype=np.int8).ravel(), 1)
    return out.bytes()


def _marker(out: Encoder, ns: int, item: Marker | Clear) -> None:
    if isinstance(item, Clear):
        kind, action, item = 0, _DELETEALL, Marker("", 0, "arrow")
    else:
        kind, action = KINDS[item.kind], _ADD
    out.header(ns, item.frame)
    out.string(item.ns)
    out.i32(item.id)
    out.i32(kind)
    out.i32(action)
    out.pose(*item.pose)
    out.f64s(*item.scale)
    for value in item.color:
        out.f32(value)
    seconds = float(item.lifetime)
    out.i32(int(seconds))
    out.u32(round((seconds - int(seconds)) * 1e9))
    out.boolean(False)
    out.array(np.asarray(item.points, dtype="<f8"), 8)
    colors = np.zeros((0, 4)) if item.colors is None else item.colors
    out.array(np.asarray(colors, dtype="<f4"), 4)
    out.string("")  # texture_resource
    out.header(0, "")  # texture: an empty CompressedImage
    out.string("")
    out.u32(0)
    out.u32(0)  # uv_coordinates
    out.string(item.text)
    out.string("")  # mesh_resource
    out.string("")  # mesh_file: no file
    out.u32(0)
    out.boolean(False)


def marker_array(ns: int, items: Sequence[Marker | Clear]) -> bytes:
    """``visualization_msgs/msg/MarkerArray``."""
    out = Encoder()
    out.u32(len(items))
    for item in items:
        _marker(out, ns, item)
    return out.bytes()


def decision(ns: int, *, query: int, source: str, case_id: str, similarity: float,
             retrieved: int, fallback_reason: str, action: str, plan_ms: float, phases: str,
             detail: Mapping[str, Any]) -> bytes:
    """cbrcore's ``cbrcore_msgs/msg/Decision`` (:data:`~cbr_recording.messages.DECISION`)."""
    out = Encoder()
    out.stamp(ns)
    out.u32(query)
    out.string(source)
    out.string(case_id)
    out.f64s(similarity)
    out.u32(retrieved)
    out.string(fallback_reason)
    out.string(action)
    out.f64s(plan_ms)
    out.string(phases)
    out.string(json.dumps(dict(detail), default=str, sort_keys=True))
    return out.bytes()
