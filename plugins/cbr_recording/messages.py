"""ROS 2 messages built from plain values, with the types of the ROS 2 Humble type store.

Every type is a standard ROS 2 message type except :data:`DECISION`, cbrcore's own, whose
definition travels in the recording as every schema does (Foxglove and the MCAP tools read it
from there).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from cbr_recording.markers import KINDS, Clear, Marker

DECISION = "cbrcore_msgs/msg/Decision"
"""The type of a consultation of the engine."""

DECISION_DEFINITION = """\
# One consultation of the CBR engine, stamped with the simulation time it was made at.
builtin_interfaces/Time stamp
# the consultation's number in the run: the query column of results.csv
uint32 query
# where the answer came from: casebase, solver:<name> or none
string source
# the best retrieved case (empty when none was retrieved)
string case_id
# its similarity in [0, 1] (NaN when nothing was retrieved)
float64 similarity
# how many cases the retrieval returned
uint32 retrieved
# why the fallback solver answered (empty when the case base did)
string fallback_reason
# what the family made of the answer, in words: the behaviors installed, the action taken
string action
# the wall time the engine took to answer (retrieve to the fallback solver), in milliseconds
float64 plan_ms
# each phase the engine ran, in order: its wall time and what it answered
string phases
# the family's detail as one JSON object
string detail
"""

_ADD, _DELETEALL = 0, 3


def typestore() -> Any:
    """The ROS 2 Humble type store with cbrcore's :data:`DECISION` added."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(DECISION_DEFINITION, DECISION))
    return store


class Messages:
    """Builds the messages of one type store; times are integer nanoseconds."""

    def __init__(self, store: Any) -> None:
        self.types = types = store.types
        self._time = types["builtin_interfaces/msg/Time"]
        self._duration = types["builtin_interfaces/msg/Duration"]
        self._header = types["std_msgs/msg/Header"]
        self._point = types["geometry_msgs/msg/Point"]
        self._quaternion = types["geometry_msgs/msg/Quaternion"]
        self._vector = types["geometry_msgs/msg/Vector3"]
        self._pose = types["geometry_msgs/msg/Pose"]
        self._pose_stamped = types["geometry_msgs/msg/PoseStamped"]
        self._color = types["std_msgs/msg/ColorRGBA"]
        self._marker = types["visualization_msgs/msg/Marker"]
        self._image = types["sensor_msgs/msg/CompressedImage"]
        self._mesh = types["visualization_msgs/msg/MeshFile"]
        self._no_image = None

    def stamp(self, ns: int) -> Any:
        return self._time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def header(self, ns: int, frame: str) -> Any:
        return self._header(stamp=self.stamp(ns), frame_id=frame)

    def quaternion(self, yaw: float) -> Any:
        return self._quaternion(x=0.0, y=0.0, z=math.sin(0.5 * yaw), w=math.cos(0.5 * yaw))

    def pose(self, x: float, y: float, yaw: float) -> Any:
        return self._pose(position=self._point(x=float(x), y=float(y), z=0.0),
                          orientation=self.quaternion(float(yaw)))

    def occupancy_grid(self, ns: int, frame: str, data: np.ndarray, resolution: float,
                       origin: tuple[float, float, float]) -> Any:
        """A ``nav_msgs/msg/OccupancyGrid`` of ``data`` (rows from the lower left, int8: -1
        unknown, 0..100 occupied)."""
        height, width = data.shape
        info = self.types["nav_msgs/msg/MapMetaData"](
            map_load_time=self.stamp(ns), resolution=float(resolution), width=width,
            height=height, origin=self.pose(*origin))
        return self.types["nav_msgs/msg/OccupancyGrid"](
            header=self.header(ns, frame), info=info,
            data=np.ascontiguousarray(data, dtype=np.int8).ravel())

    def odometry(self, ns: int, frame: str, child: str, x: float, y: float, yaw: float,
                 v: float, w: float) -> Any:
        t = self.types
        covariance = np.zeros(36)
        twist = t["geometry_msgs/msg/Twist"](linear=self._vector(x=float(v), y=0.0, z=0.0),
                                             angular=self._vector(x=0.0, y=0.0, z=float(w)))
        return t["nav_msgs/msg/Odometry"](
            header=self.header(ns, frame), child_frame_id=child,
            pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=self.pose(x, y, yaw),
                                                           covariance=covariance),
            twist=t["geometry_msgs/msg/TwistWithCovariance"](twist=twist,
                                                             covariance=covariance))

    def laser_scan(self, ns: int, frame: str, angle_min: float, increment: float,
                   ranges: np.ndarray, range_min: float, range_max: float,
                   scan_time: float) -> Any:
        ranges = np.asarray(ranges, dtype=np.float32)
        return self.types["sensor_msgs/msg/LaserScan"](
            header=self.header(ns, frame), angle_min=float(angle_min),
            angle_max=float(angle_min + increment * (len(ranges) - 1)),
            angle_increment=float(increment), time_increment=0.0, scan_time=float(scan_time),
            range_min=float(range_min), range_max=float(range_max), ranges=ranges,
            intensities=np.zeros(0, dtype=np.float32))

    def _rgba(self, color: Sequence[float]) -> Any:
        r, g, b, a = (float(c) for c in color)
        return self._color(r=r, g=g, b=b, a=a)

    def marker(self, ns: int, item: Marker | Clear) -> Any:
        if self._no_image is None:
            self._no_image = self._image(header=self.header(0, ""), format="",
                                         data=np.zeros(0, dtype=np.uint8))
        if isinstance(item, Clear):
            kind, action, item = 0, _DELETEALL, Marker("", 0, "arrow")
        else:
            kind, action = KINDS[item.kind], _ADD
        seconds = float(item.lifetime)
        lifetime = self._duration(sec=int(seconds),
                                  nanosec=round((seconds - int(seconds)) * 1e9))
        points = [self._point(x=x, y=y, z=z) for x, y, z in item.points.tolist()]
        colors = ([] if item.colors is None
                  else [self._rgba(c) for c in np.asarray(item.colors, dtype=float).tolist()])
        sx, sy, sz = item.scale
        return self._marker(
            header=self.header(ns, item.frame), ns=item.ns, id=int(item.id), type=kind,
            action=action, pose=self.pose(*item.pose),
            scale=self._vector(x=float(sx), y=float(sy), z=float(sz)),
            color=self._rgba(item.color), lifetime=lifetime, frame_locked=False,
            points=points, colors=colors, texture_resource="", texture=self._no_image,
            uv_coordinates=[], text=item.text, mesh_resource="",
            mesh_file=self._mesh(filename="", data=np.zeros(0, dtype=np.uint8)),
            mesh_use_embedded_materials=False)

    def marker_array(self, ns: int, items: Sequence[Marker | Clear]) -> Any:
        return self.types["visualization_msgs/msg/MarkerArray"](
            markers=[self.marker(ns, item) for item in items])
