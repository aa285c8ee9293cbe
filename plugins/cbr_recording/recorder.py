"""The recorder: one MCAP file of ROS 2 messages, written as a run goes.

Families record through the :class:`Recorder` a run's ``record`` observer puts in the stash
(:data:`~cbr_recording.keys.RECORDER`), with plain values (metres, radians, NumPy arrays,
:class:`~cbr_recording.markers.Marker`); the recorder encodes the standard ROS 2 messages as
CDR (:mod:`cbr_recording.cdr`) and writes them with their ``ros2msg`` schemas, as ``ros2 bag
record`` does, so that Foxglove opens the file as it is and ``ros2 bag play`` replays it. A hot
loop writes through a :class:`Channel` with a :class:`~cbr_recording.cdr.Template` laid out
once (the 2D world's fast topics).

Time is simulation time. A run is a series of *episodes* (a grid trip, a 2D trial, a delivery
day), each with a clock from 0 that only moves forward; :meth:`Recorder.episode` starts the
next one a second after the latest time so far, so the episodes follow one another on one time
line. Fast topics (the robot's transform, the sonar) are kept to ``rate`` a second of simulation
time (:meth:`Recorder.due`).

A killed run leaves a file whose complete chunks read back (:func:`~cbr_recording.info.contents`
and the MCAP readers); only a recording that was closed has its summary.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import IO, Any

import numpy as np
from mcap.writer import CompressionType, Writer

from cbr_recording import cdr
from cbr_recording.files import check_path
from cbr_recording.markers import Clear, Marker
from cbr_recording.messages import DECISION, typestore
from cbrcore.errors import CbrError
from cbrcore.model import Proposal, Retrieval, Revision, Solution

PLANNING = ("retrieve", "reuse", "revise", "solve")
"""The phases of a consultation, whose time is the time to answer it."""

PROFILE = "ros2"
LIBRARY = "cbrcore"

# What rosbag2 writes for a latched topic (transient local, reliable, keep last 1): a player
# offers it so, and a subscriber joining late (RViz's map display) still gets the map.
_LATCHED_QOS = """\
- history: 1
  depth: 1
  reliability: 1
  durability: 1
  deadline:
    sec: 2147483647
    nsec: 4294967295
  lifespan:
    sec: 2147483647
    nsec: 4294967295
  liveliness: 1
  liveliness_lease_duration:
    sec: 2147483647
    nsec: 4294967295
  avoid_ros_namespace_conventions: false
"""


def describe(result: Any) -> str:
    """A phase's answer in words."""
    if isinstance(result, Retrieval):
        if not result.matches:
            return "no case" + (f" ({result.reason})" if result.reason else "")
        best = result.matches[0]
        return f"{len(result.matches)} cases, best {best.case.id} ({best.similarity:.3f})"
    if isinstance(result, Solution):
        cost = "a solution" if result.cost is None else f"cost {result.cost:.6g}"
        count = len(result.cases)
        if count > 3:  # a path of many case graph segments: how many, not which
            return f"{cost} from {count} cases"
        cases = ", ".join(str(case) for case in result.cases)
        return cost + (f" from {cases}" if cases else "")
    if isinstance(result, Revision):
        return "accepted" if result.accepted else f"rejected: {result.reason}"
    return "nothing"


def _phases(proposal: Proposal, reused: Solution | None) -> str:
    """Each planning phase the engine ran for ``proposal``, its time and its answer."""
    answers = {"retrieve": proposal.retrieval, "reuse": reused, "revise": proposal.revision,
               "solve": None if proposal.from_casebase else proposal.solution}
    timings = proposal.timings
    return "; ".join(f"{phase} {1000 * timings[phase]:.3f} ms: {describe(answers[phase])}"
                     for phase in PLANNING if phase in timings)


class Channel:
    """One topic of a recording (:meth:`Recorder.channel`), written at the recorder's current
    time with its own sequence numbers."""

    __slots__ = ("_add", "_recorder", "_sequence", "id")

    def __init__(self, recorder: Recorder, channel_id: int, add: Any) -> None:
        self._recorder = recorder
        self._add = add
        self.id = channel_id
        self._sequence = 0

    def write(self, data: bytes) -> None:
        """Write one message's CDR bytes."""
        stamp = self._recorder._stamp
        self._add(self.id, stamp, data, stamp, self._sequence)
        self._sequence += 1


class Recorder:
    """Writes ROS 2 messages to the MCAP file ``path``; close it (or use it as a context
    manager) to write the file's summary.

    ``force`` replaces an existing file (else a CbrError); ``rate`` is the most messages a
    second of simulation time that :meth:`due` lets through per topic; ``first_query`` is the
    ``query`` column of ``results.csv`` the run's first consultation has (a run continuing a
    folder numbers its queries after the earlier runs'). The file is created with the first
    message: a run that fails before recording anything leaves none.
    """

    def __init__(self, path: Path, *, force: bool = False, rate: float = 2.0,
                 first_query: int = 0) -> None:
        if not (rate > 0 and np.isfinite(rate)):
            raise CbrError(f"recording rate must be a finite number > 0, got {rate!r}")
        check_path(path, force=force)
        self.file = path
        self._force = force
        self._first_query = first_query
        self._file: IO[bytes] | None = None
        self._writer: Writer | None = None
        self._store = typestore()
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, tuple[Channel, str]] = {}
        self._period = 1.0 / rate
        self._last: dict[str, float] = {}
        self._offset = 0.0
        self._stamp = 0
        self._end = -1
        self._templates: dict[object, Any] = {}
        self._reused: tuple[int, Solution | None] = (-1, None)
        self._closed = False

    # -- time -----------------------------------------------------------------------------

    @property
    def period(self) -> float:
        """The least seconds of simulation time between two messages of a fast topic."""
        return self._period

    @property
    def stamp(self) -> int:
        """The time of the next message, the episode's start plus its clock, in integer
        nanoseconds as messages are stamped."""
        return self._stamp

    def episode(self) -> None:
        """Start the next episode, its clock at 0, a second after the latest time so far."""
        if self._end >= 0:
            self._offset = self._end / 1e9 + 1.0
        self.at(0.0)

    def at(self, t: float) -> None:
        """Set the episode's clock to ``t`` seconds."""
        self._stamp = round((self._offset + float(t)) * 1e9)
        # the latest time set, so that the next episode follows whatever was written
        self._end = max(self._end, self._stamp)

    def due(self, topic: str, period: float | None = None) -> bool:
        """Whether ``topic`` may take a message now at the recording's rate (or at most one
        every ``period`` seconds of simulation time); a True answer counts as the topic's
        message."""
        now = self._stamp / 1e9
        last = self._last.get(topic)
        least = self._period if period is None else period
        if last is not None and now - last < least - 1e-9:
            return False
        self._last[topic] = now
        return True

    # -- writing --------------------------------------------------------------------------

    def channel(self, topic: str, msgtype: str, latched: bool = False) -> Channel:
        """The channel of ``topic``, which carries messages of ``msgtype``; a CbrError when
        the topic carries another type. ``latched`` topics are offered as ``ros2 bag
        record`` offers a latched one, so that a late subscriber gets the last message."""
        known = self._channels.get(topic)
        if known is not None:
            channel, kind = known
            if kind != msgtype:
                raise CbrError(f"recording {self.file}: topic {topic} carries {kind}, not "
                               f"{msgtype}")
            return channel
        writer = self._writer if self._writer is not None else self._open()
        schema = self._schemas.get(msgtype)
        if schema is None:
            text, _ = self._store.generate_msgdef(msgtype, ros_version=2)
            schema = self._schemas[msgtype] = writer.register_schema(
                msgtype, "ros2msg", text.encode())
        metadata = {"offered_qos_profiles": _LATCHED_QOS} if latched else {}
        channel = Channel(self, writer.register_channel(topic, "cdr", schema, metadata),
                          writer.add_message)
        self._channels[topic] = (channel, msgtype)
        return channel

    def _open(self) -> Writer:
        path = self.file
        path.parent.mkdir(parents=True, exist_ok=True)
        try:
            self._file = path.open("wb" if self._force else "xb")
        except OSError as exc:
            raise CbrError(f"recording {path}: cannot be written ({exc.strerror or exc})"
                           ) from exc
        self._writer = Writer(self._file, compression=CompressionType.LZ4)
        self._writer.start(profile=PROFILE, library=LIBRARY)
        return self._writer

    def _write(self, topic: str, msgtype: str, data: bytes, latched: bool = False) -> None:
        self.channel(topic, msgtype, latched).write(data)

    def _template(self, key: object, make: Any) -> Any:
        template = self._templates.get(key)
        if template is None:
            template = self._templates[key] = make(*key[1:])
        return template

    # -- the vocabulary families use ------------------------------------------------------

    def grid(self, topic: str, data: np.ndarray, resolution: float,
             origin: tuple[float, float, float] = (0.0, 0.0, 0.0), *, frame: str = "map",
             latched: bool = False) -> None:
        """``nav_msgs/msg/OccupancyGrid``: ``data`` int8 rows from the lower left (-1 unknown,
        0..100 occupied), ``resolution`` metres a cell, ``origin`` the pose (x, y, yaw) of its
        lower-left corner."""
        self._write(topic, "nav_msgs/msg/OccupancyGrid",
                    cdr.occupancy_grid(self._stamp, frame, data, resolution, origin), latched)

    def path(self, topic: str, points: np.ndarray, yaws: np.ndarray | None = None, *,
             frame: str = "map") -> None:
        """``nav_msgs/msg/Path`` through ``points`` (n, 2) metres, facing ``yaws`` (default:
        each pose the next, :func:`~cbr_recording.cdr.headings`)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if yaws is None:
            yaws = cdr.headings(points)
        self._write(topic, "nav_msgs/msg/Path", cdr.path(self._stamp, frame, points, yaws))

    def pose(self, topic: str, x: float, y: float, yaw: float, *, frame: str = "map") -> None:
        """``geometry_msgs/msg/PoseStamped``."""
        self._write(topic, "geometry_msgs/msg/PoseStamped",
                    cdr.pose_stamped(self._stamp, frame, float(x), float(y), float(yaw)))

    def transform(self, x: float, y: float, yaw: float, *, parent: str = "map",
                  child: str = "base_link") -> None:
        """The pose of ``child`` in ``parent`` on ``/tf`` (``tf2_msgs/msg/TFMessage``)."""
        template = self._template((cdr.transforms_template, ((parent, child),)),
                                  cdr.transforms_template)
        self._write("/tf", "tf2_msgs/msg/TFMessage",
                    template.fill(self._stamp, cdr.pose_numbers(x, y, yaw)))

    def odometry(self, topic: str, x: float, y: float, yaw: float, v: float, w: float, *,
                 frame: str = "map", child: str = "base_link") -> None:
        """``nav_msgs/msg/Odometry``: an estimated pose and the speed and turn rate."""
        template = self._template((cdr.odometry_template, frame, child),
                                  cdr.odometry_template)
        self._write(topic, "nav_msgs/msg/Odometry", template.fill(
            self._stamp, cdr.pose_numbers(x, y, yaw), (v, 0.0, 0.0, 0.0, 0.0, w)))

    def scan(self, topic: str, angle_min: float, increment: float, ranges: np.ndarray,
             range_min: float, range_max: float, scan_time: float, *,
             frame: str = "base_link") -> None:
        """``sensor_msgs/msg/LaserScan``: ``ranges`` at ``angle_min + k * increment``."""
        template = self._template(
            (cdr.laser_scan_template, frame, angle_min, increment, len(ranges), range_min,
             range_max, scan_time), cdr.laser_scan_template)
        self._write(topic, "sensor_msgs/msg/LaserScan", template.fill(self._stamp, ranges))

    def markers(self, topic: str, items: Sequence[Marker | Clear], *,
                latched: bool = False) -> None:
        """``visualization_msgs/msg/MarkerArray``."""
        self._write(topic, "visualization_msgs/msg/MarkerArray",
                    cdr.marker_array(self._stamp, items), latched)

    def moving(self, topic: str, item: Marker, points: np.ndarray) -> None:
        """A ``MarkerArray`` of the one marker ``item`` at ``points`` (n, 2) or (n, 3): a
        marker drawn again and again with new points only (the people present), laid out
        once (:class:`~cbr_recording.cdr.PointsMarker`)."""
        template = self._template((cdr.PointsMarker, item), cdr.PointsMarker)
        xyz = np.zeros((len(points), 3))
        if len(points):
            given = np.asarray(points, dtype=np.float64)
            xyz[:, :given.shape[1]] = given
        self._write(topic, "visualization_msgs/msg/MarkerArray",
                    template.fill(self._stamp, xyz))

    def note(self, query: int, reused: Solution | None) -> None:
        """What reuse answered consultation ``query`` (the ``record`` observer notes it): a
        proposal keeps it only when revision accepted it."""
        self._reused = (query, reused)

    def decision(self, query: int, proposal: Proposal, *, action: str = "",
                 detail: Mapping[str, Any] | None = None) -> None:
        """Consultation ``query`` of the run (counted from 0) and its ``proposal`` on
        ``/cbr/decision`` (cbrcore's ``Decision`` type, numbered as ``results.csv``), with what
        the family made of it: ``action`` in words and ``detail`` as JSON."""
        matches = proposal.retrieval.matches if proposal.retrieval is not None else ()
        best = matches[0] if matches else None
        noted, reused = self._reused
        if noted != query:
            reused = proposal.solution if proposal.from_casebase else None
        self._write("/cbr/decision", DECISION, cdr.decision(
            self._stamp, query=self._first_query + query, source=proposal.source,
            case_id="" if best is None else str(best.case.id),
            similarity=math.nan if best is None else best.similarity,
            retrieved=len(matches), fallback_reason=proposal.fallback_reason or "",
            action=action,
            plan_ms=1000.0 * sum(proposal.timings.get(p, 0.0) for p in PLANNING),
            phases=_phases(proposal, reused), detail=detail or {}))

    def close(self) -> None:
        """Write the file's summary and close it; idempotent."""
        if self._closed:
            return
        self._closed = True
        if self._writer is None or self._file is None:
            return
        try:
            self._writer.finish()
        finally:
            self._file.close()

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
