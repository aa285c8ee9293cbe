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
_CLEARED = Marker("", 0, "arrow")
_NO_COLORS = np.zeros((0, 4))
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


_STAMP = struct.Struct("<iI")
_SEVEN = struct.Struct("<7d")


class Template:
    """Messages of one layout that differ only in their stamp and in fixed-size blocks of
    numbers: the bytes are laid out once and each message packs its numbers into a copy,
    which costs a microsecond where encoding field by field costs several."""

    __slots__ = ("_blocks", "_sample", "_stamps")

    def __init__(self, sample: bytes, stamps: Sequence[int],
                 blocks: Sequence[tuple[int, struct.Struct | np.dtype]]) -> None:
        self._sample = sample
        self._stamps = tuple(stamps)
        self._blocks = tuple(blocks)

    def fill(self, ns: int, *values: Sequence[float] | np.ndarray) -> bytes:
        """The message stamped ``ns`` with each block's numbers, in the blocks' order: a
        tuple for a ``struct`` block, an array for a NumPy one."""
        out = bytearray(self._sample)
        sec, nanosec = divmod(ns, 1_000_000_000)
        for at in self._stamps:
            _STAMP.pack_into(out, at, sec, nanosec)
        for (at, packer), numbers in zip(self._blocks, values, strict=True):
            if isinstance(packer, np.dtype):
                data = np.asarray(numbers, dtype=packer).tobytes()
                out[at:at + len(data)] = data
            else:
                packer.pack_into(out, at, *numbers)
        return bytes(out)


def pose_numbers(x: float, y: float, yaw: float) -> tuple[float, ...]:
    """A Pose's seven numbers (a Transform's too): x, y, 0 and the turn by ``yaw`` about z."""
    return (x, y, 0.0, 0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw))


def transforms_template(frames: Sequence[tuple[str, str]]) -> Template:
    """:func:`transforms` of the links ``frames`` (parent, child) as a :class:`Template` of
    one block a link, its seven :func:`pose_numbers`, every link stamped alike."""
    out = Encoder()
    out.u32(len(frames))
    stamps, blocks = [], []
    for parent, child in frames:
        out.align(4)
        stamps.append(len(_ENCAPSULATION) + len(out.body))
        out.header(0, parent)
        out.string(child)
        out.align(8)
        blocks.append((len(_ENCAPSULATION) + len(out.body), _SEVEN))
        out.pose(0.0, 0.0, 0.0)
    return Template(out.bytes(), stamps, blocks)


def odometry_template(frame: str, child: str) -> Template:
    """``odometry`` as a :class:`Template` of two blocks: the seven :func:`pose_numbers`
    and the twist's (v, 0, 0, 0, 0, w)."""
    sample = odometry(0, frame, child, 0.0, 0.0, 0.0, 0.0, 0.0)
    twist = len(sample) - 8 * (36 + 6)
    return Template(sample, [4], [(twist - 8 * (36 + 7), _SEVEN),
                                (twist, struct.Struct("<6d"))])


def laser_scan_template(frame: str, angle_min: float, increment: float, rays: int,
                        range_min: float, range_max: float, scan_time: float) -> Template:
    """``laser_scan`` of ``rays`` ranges as a :class:`Template` of one block, the ranges."""
    sample = laser_scan(0, frame, angle_min, increment, np.zeros(rays), range_min, range_max,
                        scan_time)
    return Template(sample, [4], [(len(sample) - 4 - 4 * rays, np.dtype("<f4"))])


def pose_stamped(ns: int, frame: str, x: float, y: float, yaw: float) -> bytes:
    """``geometry_msgs/msg/PoseStamped``."""
    out = Encoder()
    out.header(ns, frame)
    out.pose(x, y, yaw)
    return out.bytes()


def transforms(ns: int, links: Sequence[tuple[str, str, float, float, float]]) -> bytes:
    """``tf2_msgs/msg/TFMessage`` of the transforms ``links``, each (parent, child, x, y,
    yaw): the pose of the child in the parent."""
    out = Encoder()
    out.u32(len(links))
    for parent, child, x, y, yaw in links:
        out.header(ns, parent)
        out.string(child)
        out.pose(x, y, yaw)  # a Transform's translation and rotation: a Pose's seven numbers
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


def _constant(write: Any) -> bytes:
    """The bytes ``write`` adds to a body that is 4-aligned (any 4-aligned start gives the
    same: the fields it writes are 4 bytes wide at most)."""
    out = Encoder()
    write(out)
    return bytes(out.body)


def _texture_tail(out: Encoder) -> None:
    out.string("")  # texture_resource
    out.header(0, "")  # texture: an empty CompressedImage
    out.string("")
    out.u32(0)
    out.u32(0)  # uv_coordinates


def _mesh_tail(out: Encoder) -> None:
    out.string("")  # mesh_resource
    out.string("")  # mesh_file: no file
    out.u32(0)
    out.boolean(False)


_TEXTURE_TAIL = _constant(_texture_tail)
_MESH_TAIL = _constant(_mesh_tail)
_MARKER_NUMBERS = struct.Struct("<10d4fiI?")


def _marker_head(out: Encoder, ns: int, item: Marker, kind: int, action: int) -> None:
    """A marker's fields before its points."""
    out.header(ns, item.frame)
    out.string(item.ns)
    out.align(4)
    out.body += struct.pack("<iii", item.id, kind, action)
    x, y, yaw = item.pose
    seconds = float(item.lifetime)
    out.align(8)
    # pose, scale, colour, lifetime and frame_locked: aligned as they fall after the pose
    out.body += _MARKER_NUMBERS.pack(
        x, y, 0.0, 0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw), *item.scale,
        *item.color, int(seconds), round((seconds - int(seconds)) * 1e9), False)


def _marker_tail(out: Encoder, item: Marker) -> None:
    """A marker's fields after its points, from a 4-aligned start."""
    colors = _NO_COLORS if item.colors is None else item.colors
    out.array(np.asarray(colors, dtype="<f4"), 4)
    out.body += _TEXTURE_TAIL
    out.string(item.text)
    out.align(4)
    out.body += _MESH_TAIL


def _marker(out: Encoder, ns: int, item: Marker | Clear) -> None:
    if isinstance(item, Clear):
        kind, action, item = 0, _DELETEALL, _CLEARED
    else:
        kind, action = KINDS[item.kind], _ADD
    _marker_head(out, ns, item, kind, action)
    out.array(np.asarray(item.points, dtype="<f8"), 8)
    _marker_tail(out, item)


class PointsMarker:
    """A ``MarkerArray`` of the one marker ``item`` whose points change from message to
    message (the people present): its other fields laid out once."""

    __slots__ = ("_head", "_pad", "_tail")

    def __init__(self, item: Marker) -> None:
        head = Encoder()
        head.u32(1)
        _marker_head(head, 0, item, KINDS[item.kind], _ADD)
        head.align(4)
        self._head = _ENCAPSULATION + bytes(head.body)
        # the points start 8-aligned after their count; the colours after them are
        # 4-aligned whatever the count, so the tail is the same bytes every time
        self._pad = b"\x00" * (-(len(head.body) + 4) % 8)
        tail = Encoder()
        _marker_tail(tail, item)
        self._tail = bytes(tail.body)

    def fill(self, ns: int, points: np.ndarray) -> bytes:
        """The array stamped ``ns`` with ``points`` (n, 3) as the marker's points."""
        out = bytearray(self._head)
        _STAMP.pack_into(out, 8, *divmod(ns, 1_000_000_000))
        out += _U32.pack(len(points))
        if len(points):
            out += self._pad
            out += np.ascontiguousarray(points, dtype="<f8").tobytes()
        out += self._tail
        return bytes(out)


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
