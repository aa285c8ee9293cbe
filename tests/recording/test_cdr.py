"""The NumPy CDR encoders write exactly the bytes of the ROS type store's own serialiser."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cbr_recording import cdr
from cbr_recording.markers import Clear, Marker
from cbr_recording.messages import DECISION, typestore

STORE = typestore()
T = STORE.types
NS = 12 * 1_000_000_000 + 345


def reference(message: object) -> bytes:
    return bytes(STORE.serialize_cdr(message, message.__msgtype__))


def stamp(ns: int) -> object:
    return T["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def header(ns: int, frame: str) -> object:
    return T["std_msgs/msg/Header"](stamp=stamp(ns), frame_id=frame)


def vector(x: float, y: float, z: float) -> object:
    return T["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)


def pose(x: float, y: float, yaw: float, z: float = 0.0) -> object:
    return T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=x, y=y, z=z),
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2),
                                                      w=math.cos(yaw / 2)))


frames = st.text(alphabet="abcdefghijklmnop_/", max_size=12)
numbers = st.floats(-1e4, 1e4)


@settings(max_examples=60, deadline=None)
@given(frame=frames, points=st.lists(st.tuples(numbers, numbers), max_size=7))
def test_path(frame: str, points: list[tuple[float, float]]) -> None:
    xy = np.array(points, dtype=float).reshape(-1, 2)
    yaws = cdr.headings(xy)
    h = header(NS, frame)
    poses = [T["geometry_msgs/msg/PoseStamped"](header=h, pose=pose(x, y, a))
             for (x, y), a in zip(xy.tolist(), yaws.tolist(), strict=True)]
    expected = reference(T["nav_msgs/msg/Path"](header=h, poses=poses))
    assert cdr.path(NS, frame, xy, yaws) == expected


@settings(max_examples=40, deadline=None)
@given(parent=frames, child=frames, x=numbers, y=numbers, yaw=st.floats(-7, 7))
def test_pose_and_transforms(parent: str, child: str, x: float, y: float, yaw: float) -> None:
    stamped = T["geometry_msgs/msg/PoseStamped"](header=header(NS, parent), pose=pose(x, y, yaw))
    assert cdr.pose_stamped(NS, parent, x, y, yaw) == reference(stamped)
    links = [(parent, child, x, y, yaw), (child, "base_link", y, -x, -yaw)]
    for count in (1, 2):
        tf = T["tf2_msgs/msg/TFMessage"](transforms=[
            T["geometry_msgs/msg/TransformStamped"](
                header=header(NS, a), child_frame_id=b,
                transform=T["geometry_msgs/msg/Transform"](
                    translation=vector(px, py, 0.0), rotation=pose(px, py, turn).orientation))
            for a, b, px, py, turn in links[:count]])
        assert cdr.transforms(NS, links[:count]) == reference(tf)
        template = cdr.transforms_template([(a, b) for a, b, *_ in links[:count]])
        assert template.fill(NS, *(cdr.pose_numbers(px, py, turn)
                                   for *_, px, py, turn in links[:count])) == reference(tf)


def test_odometry() -> None:
    zeros = np.zeros(36)
    twist = T["geometry_msgs/msg/Twist"](linear=vector(0.4, 0.0, 0.0),
                                         angular=vector(0.0, 0.0, -0.2))
    expected = T["nav_msgs/msg/Odometry"](
        header=header(NS, "map"), child_frame_id="base_link",
        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose(1.0, 2.0, 0.5),
                                                       covariance=zeros),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=zeros))
    assert cdr.odometry(NS, "map", "base_link", 1.0, 2.0, 0.5, 0.4, -0.2) == reference(expected)


@pytest.mark.parametrize("rays", [0, 1, 5, 360])
def test_laser_scan(rays: int) -> None:
    ranges = np.linspace(0.1, 5.0, rays).astype(np.float32)
    ranges[::3] = np.inf
    increment = math.radians(1.0)
    expected = T["sensor_msgs/msg/LaserScan"](
        header=header(NS, "base_link"), angle_min=-math.pi,
        angle_max=-math.pi + increment * (rays - 1), angle_increment=increment,
        time_increment=0.0, scan_time=0.1, range_min=0.0, range_max=5.0, ranges=ranges,
        intensities=np.zeros(0, dtype=np.float32))
    got = cdr.laser_scan(NS, "base_link", -math.pi, increment, ranges, 0.0, 5.0, 0.1)
    assert got == reference(expected)


@pytest.mark.parametrize("shape", [(1, 1), (3, 5), (7, 2)])
def test_occupancy_grid(shape: tuple[int, int]) -> None:
    data = np.random.default_rng(1).integers(-1, 101, size=shape).astype(np.int8)
    info = T["nav_msgs/msg/MapMetaData"](map_load_time=stamp(NS), resolution=0.05,
                                         width=shape[1], height=shape[0],
                                         origin=pose(-1.5, 2.0, 0.3))
    expected = T["nav_msgs/msg/OccupancyGrid"](header=header(NS, "map"), info=info,
                                               data=data.ravel())
    assert cdr.occupancy_grid(NS, "map", data, 0.05, (-1.5, 2.0, 0.3)) == reference(expected)


def _reference_marker(item: Marker | Clear) -> object:
    rgba = T["std_msgs/msg/ColorRGBA"]
    if isinstance(item, Clear):
        kind, action, item = 0, 3, Marker("", 0, "arrow")
    else:
        kind, action = {"cube_list": 6, "text": 9, "sphere": 2}[item.kind], 0
    colors = [] if item.colors is None else [rgba(r=r, g=g, b=b, a=a)
                                             for r, g, b, a in item.colors.tolist()]
    seconds = item.lifetime
    return T["visualization_msgs/msg/Marker"](
        header=header(NS, item.frame), ns=item.ns, id=item.id, type=kind, action=action,
        pose=pose(*item.pose), scale=vector(*item.scale),
        color=rgba(r=item.color[0], g=item.color[1], b=item.color[2], a=item.color[3]),
        lifetime=T["builtin_interfaces/msg/Duration"](
            sec=int(seconds), nanosec=round((seconds - int(seconds)) * 1e9)),
        frame_locked=False,
        points=[T["geometry_msgs/msg/Point"](x=x, y=y, z=z) for x, y, z in item.points.tolist()],
        colors=colors, texture_resource="",
        texture=T["sensor_msgs/msg/CompressedImage"](header=header(0, ""), format="",
                                                    data=np.zeros(0, dtype=np.uint8)),
        uv_coordinates=[], text=item.text, mesh_resource="",
        mesh_file=T["visualization_msgs/msg/MeshFile"](filename="",
                                                      data=np.zeros(0, dtype=np.uint8)),
        mesh_use_embedded_materials=False)


def test_marker_array() -> None:
    items = [
        Clear(),
        Marker("cells", 4, "cube_list", [[1.0, 2.0], [3.0, 4.5]], scale=(1.0, 1.0, 0.1),
               color=(0.5, 0.25, 0.0, 1.0), colors=np.array([[1, 0, 0, 1], [0, 1, 0, 0.5]]),
               frame="map"),
        Marker("label", 0, "text", pose=(1.0, -1.0, 0.3), text="door a", lifetime=2.5,
               frame="base_link"),
        Marker("one", 1, "sphere", pose=(0.5, 0.5, 0.0), scale=(0.2, 0.2, 0.2)),
    ]
    expected = T["visualization_msgs/msg/MarkerArray"](
        markers=[_reference_marker(item) for item in items])
    assert cdr.marker_array(NS, items) == reference(expected)


def test_decision() -> None:
    detail = {"b": [1, 2], "a": "x"}
    expected = T[DECISION](stamp=stamp(NS), query=7, source="casebase", case_id="case 3",
                           similarity=0.8, retrieved=4, fallback_reason="", action="went",
                           plan_ms=1.5, phases="retrieve 1 ms: 4 cases",
                           detail=json.dumps(detail, sort_keys=True))
    got = cdr.decision(NS, query=7, source="casebase", case_id="case 3", similarity=0.8,
                       retrieved=4, fallback_reason="", action="went", plan_ms=1.5,
                       phases="retrieve 1 ms: 4 cases", detail=detail)
    assert got == reference(expected)


def test_templates_fill_the_encoders_bytes() -> None:
    odometry = cdr.odometry_template("odom", "base_link")
    assert odometry.fill(NS, cdr.pose_numbers(1.0, 2.0, 0.5), (0.4, 0, 0, 0, 0, -0.2)) == (
        cdr.odometry(NS, "odom", "base_link", 1.0, 2.0, 0.5, 0.4, -0.2))
    ranges = np.linspace(0.2, 5.0, 360)
    scan = cdr.laser_scan_template("base_link", -math.pi, 0.01, 360, 0.0, 5.0, 0.1)
    assert scan.fill(NS, ranges) == cdr.laser_scan(NS, "base_link", -math.pi, 0.01, ranges,
                                                   0.0, 5.0, 0.1)


@pytest.mark.parametrize("count", [0, 1, 4])
@pytest.mark.parametrize("frame", ["map", "ab", "base_link"])
def test_points_marker_fills_the_encoders_bytes(count: int, frame: str) -> None:
    points = np.random.default_rng(count).random((count, 3))
    item = Marker("people", 0, "sphere_list", scale=(0.5, 0.5, 0.5), color=(1, 0.5, 0, 1),
                  frame=frame)
    expected = cdr.marker_array(NS, [Marker("people", 0, "sphere_list", points,
                                            scale=(0.5, 0.5, 0.5), color=(1, 0.5, 0, 1),
                                            frame=frame)])
    assert cdr.PointsMarker(item).fill(NS, points) == expected
