"""What a 2D trial records (see :mod:`cbr_recording`): the world, the robot, what it sensed
and where it was heading, at simulation time.

A trial (or a delivery day) is an episode of the recording. At its start go the world's walls,
landmarks, point obstacles and places (latched), then, as the robot drives:

- each step the ``rate`` lets through: the frames as REP 105 has them (``/tf``: ``odom`` ->
  ``base_link`` the odometry's estimate, ``map`` -> ``odom`` the correction that puts it on
  the true pose), the odometry's estimate and speeds (``/odom``, in ``odom``), the sonar ring
  (``/sonar``), the people present (``/world/people``) and the camera's sightings
  (``/camera/sightings``: the peak of each fuzzy place, in ``base_link``);
- whenever they change: the doors open (green) or shut (red) (``/world/doors``), the target
  and any diverting target (``/target``), and a planned route (``/plan``, a delivery day's);
- when they happen: the navigator's events and collisions as labels (``/events``).

The sonar ring is a ``LaserScan`` of one ray a degree round the robot: each ray inside a beam's
cone reads that beam's range from the robot's centre (the rim reading plus the mount radius;
the nearest where two cones overlap); a ray no beam covers, or whose beam heard no echo, reads
+inf (no return).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from cbr_recording import cdr
from cbr_recording.markers import Clear, Marker
from cbr_world2d.sensors import SonarRing

if TYPE_CHECKING:
    from cbr_recording.recorder import Recorder
    from cbr_world2d.robot import Pose, RobotState
    from cbr_world2d.simulation import Simulation
    from cbr_world2d.world import Door, World

WALL = (0.6, 0.6, 0.6, 1.0)
OPEN = (0.2, 0.8, 0.3, 1.0)
SHUT = (0.9, 0.2, 0.2, 1.0)
LANDMARK = (0.2, 0.5, 1.0, 1.0)
PERSON = (1.0, 0.6, 0.1, 0.9)
TARGET = (0.1, 0.8, 0.2, 0.9)
DIVERTING = (1.0, 0.5, 0.0, 0.9)
SIGHTINGS = Marker("sightings", 0, "sphere_list", scale=(0.3, 0.3, 0.3),
                   color=(0.2, 0.5, 1.0, 0.6), frame="base_link")
"""The camera's sightings: a sphere at the peak of each fuzzy place, in the robot's frame."""
EVENT_SECONDS = 10.0
"""How long an event's label stays shown."""

RAYS = 360


def world_markers(world: World) -> list[Marker]:
    """The static world: walls and polygon edges, landmarks with their ids, point obstacles
    and the places' names."""
    segments = world.static_segments
    items = [Marker("walls", 0, "line_list", segments.reshape(-1, 2), scale=(0.05, 0, 0),
                    color=WALL)]
    for k, mark in enumerate(world.landmarks):
        items.append(Marker("landmarks", k, "cylinder", pose=(mark.x, mark.y, 0.0),
                            scale=(2 * mark.radius, 2 * mark.radius, 0.5), color=LANDMARK))
        items.append(Marker("landmark ids", k, "text", pose=(mark.x, mark.y, 0.0),
                            scale=(0, 0, 0.3), text=mark.id))
    for k, (x, y, radius) in enumerate(world.points):
        items.append(Marker("points", k, "cylinder", pose=(x, y, 0.0),
                            scale=(2 * radius, 2 * radius, 0.3), color=WALL))
    for k, (name, (x, y)) in enumerate(world.places.items()):
        items.append(Marker("places", k, "text", pose=(x, y, 0.0), scale=(0, 0, 0.25),
                            text=name, color=(0.8, 0.8, 0.8, 1.0)))
    return items


def _correction(truth: RobotState, estimate: Pose) -> tuple[float, ...]:
    """The ``map`` -> ``odom`` transform that puts the odometry's ``estimate`` (the pose in
    ``odom``) on the ``truth`` (the pose in ``map``), as a localiser would: truth composed
    with the inverse of the estimate, in the plane."""
    turn = truth.theta - estimate.theta
    c, s = math.cos(turn), math.sin(turn)
    x = truth.x - (c * estimate.x - s * estimate.y)
    y = truth.y - (s * estimate.x + c * estimate.y)
    return cdr.pose_numbers(x, y, turn)


def _next_change(door: Door, t: float) -> float:
    """When ``door`` next opens or shuts after ``t`` (it is open while ``(t + phase) mod
    period < open_for``)."""
    into = (t + door.phase) % door.period
    return t + (door.open_for - into if into < door.open_for else door.period - into)


def _beam_table(sonar: SonarRing) -> np.ndarray:
    """For each of :data:`RAYS` rays from -pi, the beams whose cones cover it, as a (RAYS,
    k) table of beam indices, k the most beams covering one ray; the index ``len(beams)``
    (a reading of +inf) fills the rest."""
    rays = -math.pi + np.arange(RAYS) * (2 * math.pi / RAYS)
    off = np.angle(np.exp(1j * (rays[:, None] - np.array(sonar.angles)[None, :])))
    covers = np.abs(off) <= 0.5 * sonar.beam_width + 1e-9
    table = np.full((RAYS, max(int(covers.sum(axis=1).max()), 1)), len(sonar.angles))
    for ray, beams in enumerate(covers):
        found = np.flatnonzero(beams)
        table[ray, :len(found)] = found
    return table


class TrialRecording:
    """Records one simulation on ``recorder`` as it steps (see the module)."""

    def __init__(self, recorder: Recorder, sim: Simulation) -> None:
        self.recorder = recorder
        recorder.episode()
        recorder.at(sim.t)
        recorder.markers("/world/walls", world_markers(sim.world), latched=True)
        sonar = sim.sensors.sonar
        self._sonar = sonar
        self._covers = None if sonar is None else _beam_table(sonar)
        # the sonar's readings from the robot's centre, and +inf for the rays no beam covers
        self._readings = np.full(0 if sonar is None else len(sonar.angles) + 1, np.inf)
        markers = "visualization_msgs/msg/MarkerArray"
        self._fast_topics: dict[str, Any] = {
            "tf": recorder.channel("/tf", "tf2_msgs/msg/TFMessage"),
            "tf bytes": cdr.transforms_template([("map", "odom"), ("odom", "base_link")]),
            "odom": recorder.channel("/odom", "nav_msgs/msg/Odometry"),
            "odom bytes": cdr.odometry_template("odom", "base_link"),
            "sightings": recorder.channel("/camera/sightings", markers),
            "sightings bytes": cdr.PointsMarker(SIGHTINGS)}
        if sonar is not None:
            self._fast_topics["sonar"] = recorder.channel("/sonar", "sensor_msgs/msg/LaserScan")
            self._fast_topics["sonar bytes"] = cdr.laser_scan_template(
                "base_link", -math.pi, 2 * math.pi / RAYS, RAYS, 0.0,
                sonar.max_range + sonar.mount_radius, recorder.period)
        self._doors: tuple[bool, ...] | None = None
        self._doors_change = -math.inf
        self._events = 0
        self._target: tuple[object, ...] | None = None
        self._sighted = False
        width = 2 * max((mover.radius for mover in sim.world.movers), default=0.0)
        # one marker for them all, each as wide as the widest person
        self._people = (Marker("people", 0, "sphere_list", scale=(width, width, 0.5),
                               color=PERSON) if sim.world.movers else None)
        if self._people is not None:
            self._fast_topics["people"] = recorder.channel("/world/people", markers)
            self._fast_topics["people bytes"] = cdr.PointsMarker(self._people)
        self.step(sim)

    def route(self, points: list[tuple[float, float]]) -> None:
        """The route the robot follows now (``/plan``), from where it is."""
        self.recorder.path("/plan", np.asarray(points, dtype=np.float64))

    def step(self, sim: Simulation) -> None:
        recorder = self.recorder
        recorder.at(sim.t)
        world = sim.world
        if world.doors and sim.t >= self._doors_change:
            # a door changes only on its schedule: looked at again when the next one does
            doors = tuple(door.is_open(sim.t) for door in world.doors)
            self._doors_change = min(_next_change(door, sim.t) for door in world.doors)
            if doors != self._doors:
                self._doors = doors
                colors = np.repeat([OPEN if is_open else SHUT for is_open in doors], 2, axis=0)
                recorder.markers("/world/doors", [Marker(
                    "doors", 0, "line_list", world.door_segments.reshape(-1, 2),
                    scale=(0.08, 0, 0), colors=colors)])
        navigator = sim.navigator
        target = (sim.target, navigator.current_target if navigator.diverting else None)
        if target != self._target:
            self._target = target
            items: list[Marker | Clear] = [Clear(), Marker(
                "target", 0, "sphere", pose=(*sim.target, 0.0), scale=(0.3, 0.3, 0.3),
                color=TARGET)]
            if target[1] is not None:
                items.append(Marker("diverting", 0, "sphere", pose=(*target[1], 0.0),
                                    scale=(0.3, 0.3, 0.3), color=DIVERTING))
            recorder.markers("/target", items)
        if sim.events:
            # ids run on, so that a label stays its lifetime rather than until the next event
            first = self._events
            self._events += len(sim.events)
            recorder.markers("/events", [
                Marker("events", first + k, "text", pose=(event.x, event.y, 0.0),
                       scale=(0, 0, 0.25), text=event.name, color=SHUT,
                       lifetime=EVENT_SECONDS)
                for k, event in enumerate(sim.events)])
        if recorder.due("/robot"):
            self._fast(sim)

    def _fast(self, sim: Simulation) -> None:
        # written through channels and templates laid out once: this runs at every
        # recorded step, where the recorder's general methods would cost more than the step
        recorder = self.recorder
        stamp = recorder.stamp
        state, obs = sim.state, sim.observation
        fast = self._fast_topics
        pose = cdr.pose_numbers(obs.pose.x, obs.pose.y, obs.pose.theta)
        fast["tf"].write(fast["tf bytes"].fill(stamp, _correction(state, obs.pose), pose))
        fast["odom"].write(fast["odom bytes"].fill(stamp, pose, (obs.v, 0, 0, 0, 0, obs.w)))
        if self._covers is not None and len(obs.sonar):
            sonar, readings = self._sonar, self._readings
            readings[:-1] = obs.sonar
            # a beam that heard no echo reads its maximum range: no return, +inf in ROS
            readings[:-1][readings[:-1] >= sonar.max_range] = np.inf
            readings[:-1] += sonar.mount_radius
            fast["sonar"].write(fast["sonar bytes"].fill(
                stamp, readings[self._covers].min(axis=1)))
        if self._people is not None:
            people = [(x, y, 0.0) for mover, (x, y) in zip(sim.world.movers, sim.crowd.now,
                                                           strict=True) if mover.present(sim.t)]
            fast["people"].write(fast["people bytes"].fill(stamp, np.array(people).reshape(
                -1, 3)))
        if obs.sightings or self._sighted:
            peaks = [(s.distance.peak * math.cos(s.bearing.peak),
                      s.distance.peak * math.sin(s.bearing.peak), 0.0) for s in obs.sightings]
            fast["sightings"].write(fast["sightings bytes"].fill(stamp, np.array(peaks).reshape(
                -1, 3)))
            self._sighted = bool(obs.sightings)
