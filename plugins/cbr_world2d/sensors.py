"""The robot's senses: sonar ring, camera, bump sensor and odometry, and what they observe.

Every random draw comes from the ``numpy.random.Generator`` handed to the call, in a fixed
order (odometry, sonar, camera), so one seed repeats every reading. The sensors see the world
as the arrays the simulator passes (segments ``(n, 4)``, discs ``(m, 3)``, landmarks
``(k, 3)``); the numeric work runs in the kernels of :mod:`cbr_world2d.geometry`.

- :class:`SonarRing`: the Pioneer 2 DX's 16 sonars (8 front, 8 rear), each a cone sampled by a
  few rays, ranges measured from the robot's rim (0 means touching).
- :class:`Camera`: each visible landmark's distance and bearing as triangular fuzzy numbers
  whose spread grows with distance (002 section 3); the support always holds the true value.
- :class:`Bumper`: whether the last step collided, and the bearing of the contact.
- :class:`Odometry`: dead reckoning with optional noise and a location confidence in (0, 1].
- :class:`Sensors` bundles them; :meth:`Sensors.observe` returns an :class:`Observation`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import attrs
import numpy as np

from cbr_kernels import njit
from cbr_world2d.checks import fraction, non_negative, positive
from cbr_world2d.fuzzy import Triangle, unchecked, wrap_angle
from cbr_world2d.geometry import landmarks_seen, nearest_point, ring_ranges_into
from cbr_world2d.robot import PIONEER_2DX, Pose, RobotState
from cbr_world2d.world import World

PIONEER_SONAR_DEGREES: tuple[float, ...] = (
    90.0, 50.0, 30.0, 10.0, -10.0, -30.0, -50.0, -90.0,
    -90.0, -130.0, -150.0, -170.0, 170.0, 150.0, 130.0, 90.0,
)
"""Headings of the Pioneer 2 DX's sonar discs relative to the robot's heading, in ARIA's sonar
order: ``SonarUnit 0..7`` the front ring at 90, 50, 30, 10, -10, -30, -50, -90 degrees and
``SonarUnit 8..15`` the rear ring at -90, -130, -150, -170, 170, 150, 130, 90 degrees (ARIA
``params/p2dx.p``, section "Sonar parameters")."""


@njit
def _add_noise(ranges: np.ndarray, normal: np.ndarray, sigma: float, top: float) -> None:
    for i in range(ranges.shape[0]):
        ranges[i] = min(max(ranges[i] + sigma * normal[i], 0.0), top)


@njit
def _measure(seen: np.ndarray, uniform: np.ndarray, d_base: float, d_per_metre: float,
             b_base: float, b_per_metre: float, noise: float, out: np.ndarray) -> None:
    """Rows ``d_low, d_peak, d_high, b_low, b_peak, b_high`` of the camera's fuzzy measures
    of the landmarks ``seen`` (rows ``index, distance, bearing``) into ``out``; ``uniform``
    ``(n, 2)`` in [0, 1) becomes triangular errors on [-1, 1] (inverse CDF)."""
    for i in range(out.shape[0]):
        distance = seen[i, 1]
        d_half = d_base + d_per_metre * distance
        b_half = b_base + b_per_metre * distance
        errors = np.empty(2)
        for k in range(2):
            u = uniform[i, k]
            if u < 0.5:
                errors[k] = math.sqrt(2.0 * u) - 1.0
            else:
                errors[k] = 1.0 - math.sqrt(2.0 * (1.0 - u))
        d_peak = max(distance + noise * errors[0] * d_half, 0.0)
        b_peak = seen[i, 2] + noise * errors[1] * b_half
        out[i, 0] = max(d_peak - d_half, 0.0)
        out[i, 1] = d_peak
        out[i, 2] = d_peak + d_half
        out[i, 3] = b_peak - b_half
        out[i, 4] = b_peak
        out[i, 5] = b_peak + b_half


def _radians(degrees: tuple[float, ...]) -> tuple[float, ...]:
    return tuple(math.radians(d) for d in degrees)


@attrs.frozen
class SonarRing:
    """A ring of sonar beams mounted on the robot's rim.

    ``angles`` are the beams' headings relative to the robot's (radians; default the Pioneer 2
    DX's 16, :data:`PIONEER_SONAR_DEGREES`). Each beam is a cone ``beam_width`` wide whose
    edges and axis are cast as ``rays_per_beam`` rays spread evenly across it; with two rays or
    more it reads the nearest obstacle anywhere inside the cone, also one lying between the
    rays (:func:`cbr_world2d.geometry.ring_ranges`), with one ray the axis alone. A reading is
    the distance from the rim (``mount_radius`` from the centre), capped at ``max_range``,
    plus Gaussian noise of standard deviation ``noise`` metres, kept in ``[0, max_range]``.

    Defaults: ``max_range`` 5 m and ``beam_width`` 30 degrees, the Pioneer sonar of
    MobileRobots' simulator (MobileSim / AMRISim ``PioneerRobotModels.world.inc``,
    ``pioneerSonar``: ``sview [0.1 5.0 30]``, min and max range in metres, field of view in
    degrees; its 10 cm blind zone is not modelled, so 0 still means touching);
    ``rays_per_beam`` 3; ``mount_radius`` the
    :data:`~cbr_world2d.robot.PIONEER_2DX` radius; ``noise`` 1 cm.
    """

    angles: tuple[float, ...] = attrs.field(
        default=_radians(PIONEER_SONAR_DEGREES), converter=lambda a: tuple(float(x) for x in a))
    max_range: float = attrs.field(default=5.0, converter=float, validator=positive)
    beam_width: float = attrs.field(default=math.radians(30.0), converter=float,
                                    validator=non_negative)
    rays_per_beam: int = attrs.field(default=3, converter=int)
    noise: float = attrs.field(default=0.01, converter=float, validator=non_negative)
    mount_radius: float = attrs.field(default=PIONEER_2DX.radius, converter=float,
                                      validator=non_negative)
    _directions: np.ndarray = attrs.field(init=False, repr=False, eq=False)
    _offsets: np.ndarray = attrs.field(init=False, repr=False, eq=False)

    def __attrs_post_init__(self) -> None:
        if not self.angles:
            raise ValueError("a sonar ring needs at least one beam")
        if self.rays_per_beam < 1:
            raise ValueError(f"rays_per_beam must be >= 1, not {self.rays_per_beam}")
        directions = np.array(self.angles, dtype=float)
        if self.rays_per_beam == 1:
            offsets = np.zeros(1)
        else:
            half = 0.5 * self.beam_width
            offsets = np.linspace(-half, half, self.rays_per_beam)
        directions.flags.writeable = False
        offsets.flags.writeable = False
        object.__setattr__(self, "_directions", directions)
        object.__setattr__(self, "_offsets", offsets)

    @property
    def directions(self) -> np.ndarray:
        """The beams' headings relative to the robot's, ``(R,)`` radians (read-only)."""
        return self._directions

    def fitted(self, radius: float) -> SonarRing:
        """This ring mounted on a robot of ``radius``."""
        return attrs.evolve(self, mount_radius=radius)

    def read(self, pose: Pose | RobotState, segments: np.ndarray, discs: np.ndarray,
             rng: np.random.Generator) -> np.ndarray:
        """The ranges ``(R,)`` of every beam seen from ``pose``."""
        ranges = np.empty(self._directions.shape[0])
        ring_ranges_into(float(pose.x), float(pose.y), float(pose.theta), self._directions,
                         self._offsets, self.max_range, self.mount_radius, segments, discs,
                         ranges)
        if self.noise > 0.0:
            _add_noise(ranges, rng.standard_normal(ranges.shape[0]), self.noise, self.max_range)
        return ranges


@attrs.frozen
class Sighting:
    """A landmark the camera saw: its fuzzy ``distance`` (metres) and fuzzy ``bearing``
    (radians, relative to the robot's heading; see :mod:`cbr_world2d.fuzzy` on angles)."""

    id: str
    distance: Triangle
    bearing: Triangle


def sighted_points(sightings: Sequence[Sighting]) -> tuple[np.ndarray, np.ndarray]:
    """The sighted landmarks' places in the robot's frame at the peaks ``(n, 2)`` and how far
    off each may be ``(n,)``, in metres: the wider side of the distance triangle plus the arc
    the wider side of the bearing triangle spans at that distance (which bounds the chord to
    the true place)."""
    d = np.array([s.distance.as_tuple() for s in sightings], dtype=float).reshape(-1, 3)
    b = np.array([s.bearing.as_tuple() for s in sightings], dtype=float).reshape(-1, 3)
    points = d[:, 1:2] * np.column_stack((np.cos(b[:, 1]), np.sin(b[:, 1])))
    off_bearing = np.minimum(np.maximum(b[:, 1] - b[:, 0], b[:, 2] - b[:, 1]), math.pi)
    uncertainty = np.maximum(d[:, 1] - d[:, 0], d[:, 2] - d[:, 1]) + d[:, 1] * off_bearing
    return points, uncertainty


@attrs.frozen
class Camera:
    """A forward camera that recognises landmarks (002 section 2, the Vision agent).

    A landmark is seen when its centre lies within ``max_range`` and within ``fov / 2`` of the
    heading, and no segment crosses the line of sight to it. Each measure is a symmetric
    triangle whose half-width grows with the true distance ``d``: ``distance_spread +
    distance_spread_per_metre * d`` for the distance, ``bearing_spread +
    bearing_spread_per_metre * d`` for the bearing (002 section 3: measuring is imprecise, the
    more so the farther). The peak is the true value plus an error drawn from the triangular
    distribution on ``[-noise, noise]`` times the half-width, ``noise < 1``, so the support
    always contains the true value. A distance triangle is cut at 0 (its peak too).

    Defaults (002 gives no figures): a 60 degree field of view and 6 m range; distances
    within 5 cm + 5 % and bearings within 2 degrees + 0.5 degree per metre; ``noise`` 0.5.

    **Panning** (002's Vision agent turns the camera to look for landmarks): with ``pan`` over
    0 the field of view is centred not on the heading but ``aim(t)`` radians off it, sweeping
    from 0 to ``pan``, back to ``-pan`` and to 0 at ``pan_rate`` radians per second, so that a
    sweep covers ``fov + 2 pan`` round the heading and takes ``4 pan / pan_rate`` seconds.
    Bearings are still relative to the heading.
    """

    fov: float = attrs.field(default=math.radians(60.0), converter=float, validator=positive)
    max_range: float = attrs.field(default=6.0, converter=float, validator=positive)
    distance_spread: float = attrs.field(default=0.05, converter=float,
                                         validator=non_negative)
    distance_spread_per_metre: float = attrs.field(default=0.05, converter=float,
                                                   validator=non_negative)
    bearing_spread: float = attrs.field(default=math.radians(2.0), converter=float,
                                        validator=non_negative)
    bearing_spread_per_metre: float = attrs.field(default=math.radians(0.5), converter=float,
                                                  validator=non_negative)
    noise: float = attrs.field(default=0.5, converter=float, validator=fraction)
    pan: float = attrs.field(default=0.0, converter=float,
                             validator=attrs.validators.and_(non_negative,
                                                             attrs.validators.le(math.pi)))
    pan_rate: float = attrs.field(default=math.radians(60.0), converter=float,
                                  validator=positive)

    def aim(self, t: float) -> float:
        """Where the camera points at time ``t``, radians off the heading (see Panning)."""
        if self.pan <= 0.0:
            return 0.0
        u = (t * self.pan_rate) % (4.0 * self.pan)
        if u <= self.pan:
            return u
        if u <= 3.0 * self.pan:
            return 2.0 * self.pan - u
        return u - 4.0 * self.pan

    def view(self, pose: Pose | RobotState, landmarks: np.ndarray,
             segments: np.ndarray, aim: float = 0.0) -> np.ndarray:
        """The landmarks seen with the camera ``aim`` radians off the heading, true values:
        rows ``index, distance, bearing`` ``(s, 3)``, the bearing relative to the heading."""
        seen = np.empty((landmarks.shape[0], 3))
        n = landmarks_seen(float(pose.x), float(pose.y), float(pose.theta) + aim, landmarks,
                           self.fov, self.max_range, segments, seen)
        seen = seen[:n]
        if aim != 0.0:
            seen[:, 2] = np.arctan2(np.sin(seen[:, 2] + aim), np.cos(seen[:, 2] + aim))
        return seen

    def see(self, pose: Pose | RobotState, landmarks: np.ndarray, ids: tuple[str, ...] | list[str],
            segments: np.ndarray, rng: np.random.Generator, t: float = 0.0
            ) -> tuple[Sighting, ...]:
        """The sightings at time ``t`` (which sets where a panning camera points), in the
        order of ``landmarks`` (rows ``x, y, radius``; ``ids`` names them)."""
        seen = self.view(pose, landmarks, segments, self.aim(t))
        n = seen.shape[0]
        if n == 0:
            return ()
        uniform = rng.random((n, 2)) if self.noise > 0.0 else np.full((n, 2), 0.5)
        rows = np.empty((n, 6))
        _measure(seen, uniform, self.distance_spread, self.distance_spread_per_metre,
                 self.bearing_spread, self.bearing_spread_per_metre, self.noise, rows)
        return tuple(
            Sighting(ids[int(i)], unchecked(row[0], row[1], row[2]),
                     unchecked(row[3], row[4], row[5]))
            for i, row in zip(seen[:, 0].tolist(), rows.tolist(), strict=True))


@attrs.frozen
class Bumper:
    """A bump ring: reports whether the last step collided and, if so, the bearing of the
    contact (the nearest obstacle surface point) relative to the heading."""

    def read(self, pose: Pose | RobotState, bumped: bool, segments: np.ndarray,
             discs: np.ndarray) -> tuple[bool, float]:
        if not bumped:
            return False, math.nan
        _, qx, qy = nearest_point(float(pose.x), float(pose.y), segments, discs)
        if math.isnan(qx):
            return True, math.nan
        return True, wrap_angle(math.atan2(qy - pose.y, qx - pose.x) - pose.theta)


@attrs.define(on_setattr=attrs.setters.NO_OP)
class Odometry:
    """Dead reckoning from the wheels, with optional noise and a location confidence.

    Each update measures the true move since the last one (the displacement ``ds`` in the
    robot's frame and the turn ``dtheta``) scaled by ``1 + noise_v * N(0, 1)`` and
    ``1 + noise_w * N(0, 1)`` and applies it to the estimated :attr:`pose`. The error's
    variance is propagated as an extended Kalman filter does along the path: the along-track
    variance grows by ``(noise_v ds)^2``; the heading variance ``H`` by ``(noise_w dtheta)^2``;
    the cross-track error ``c`` carries the heading error along, so that with ``C`` its
    covariance with the heading, ``var(c) += 2 ds C + ds^2 H`` and ``C += ds H`` (a heading error
    made early pushes the estimate sideways for the rest of the way, which variances added step
    by step as if independent would miss). :attr:`confidence` is
    ``1 / (1 + variance / confidence_scale^2)``: 1 without noise or right after
    :meth:`reset`, halved when the error's standard deviation reaches ``confidence_scale``
    metres.

    Noise is off by default so that the estimate is the truth; MobileRobots' simulator uses
    0.0075 (``odom_error``, metres per metre and radians per radian) as a Pioneer's typical
    error, a reasonable ``noise_v`` / ``noise_w`` for experiments that want drift.
    """

    noise_v: float = attrs.field(default=0.0, converter=float, validator=non_negative)
    noise_w: float = attrs.field(default=0.0, converter=float, validator=non_negative)
    confidence_scale: float = attrs.field(default=0.5, converter=float, validator=positive)
    _x: float = attrs.field(default=0.0, init=False)
    _y: float = attrs.field(default=0.0, init=False)
    _theta: float = attrs.field(default=0.0, init=False)
    _variance: float = attrs.field(default=0.0, init=False)
    _heading_variance: float = attrs.field(default=0.0, init=False)
    _cross: float = attrs.field(default=0.0, init=False)
    """The covariance of the cross-track error with the heading error."""
    _speed: float = attrs.field(default=0.0, init=False)
    _turn_rate: float = attrs.field(default=0.0, init=False)

    def reset(self, pose: Pose | RobotState) -> None:
        """Start dead reckoning from ``pose``, known exactly."""
        self._x, self._y, self._theta = float(pose.x), float(pose.y), float(pose.theta)
        self._variance = self._heading_variance = self._cross = 0.0
        self._speed = self._turn_rate = 0.0

    @property
    def pose(self) -> Pose:
        """The estimated pose."""
        return Pose(self._x, self._y, self._theta)

    @property
    def confidence(self) -> float:
        return 1.0 / (1.0 + self._variance / (self.confidence_scale * self.confidence_scale))

    @property
    def speed(self) -> float:
        """The speed measured over the last update (m/s)."""
        return self._speed

    @property
    def turn_rate(self) -> float:
        """The turn rate measured over the last update (rad/s)."""
        return self._turn_rate

    def update(self, before: Pose | RobotState, after: Pose | RobotState, dt: float,
               rng: np.random.Generator) -> Pose:
        """Measure the move ``before -> after`` that took ``dt`` seconds; the new estimate.

        The wheels measure the displacement in the robot's own frame and the turn; the
        estimate applies them, scaled by the noise, from its own pose, so without noise it
        stays the truth exactly (blocked steps included). The measured speed is the arc
        length over ``dt``: the speed of the step's unicycle arc.
        """
        dx = after.x - before.x
        dy = after.y - before.y
        cos_b = math.cos(before.theta)
        sin_b = math.sin(before.theta)
        forward = cos_b * dx + sin_b * dy
        left = cos_b * dy - sin_b * dx
        dtheta = wrap_angle(after.theta - before.theta)
        if self.noise_v > 0.0 or self.noise_w > 0.0:
            e_v, e_w = rng.standard_normal(2)
            scale = 1.0 + self.noise_v * e_v
            dtheta_m = dtheta * (1.0 + self.noise_w * e_w)
            ds = math.hypot(forward, left)
            self._heading_variance += (self.noise_w * dtheta) ** 2
            self._variance += ((self.noise_v * ds) ** 2 + 2.0 * ds * self._cross
                               + ds * ds * self._heading_variance)
            self._cross += ds * self._heading_variance
        else:
            scale = 1.0
            dtheta_m = dtheta
        forward *= scale
        left *= scale
        cos_e = math.cos(self._theta)
        sin_e = math.sin(self._theta)
        self._x += cos_e * forward - sin_e * left
        self._y += sin_e * forward + cos_e * left
        self._theta = wrap_angle(self._theta + dtheta_m)
        if dt > 0.0:
            chord = math.copysign(math.hypot(forward, left), forward)
            half = 0.5 * abs(dtheta_m)
            arc = chord * half / math.sin(half) if half > 1e-9 else chord
            self._speed = arc / dt
            self._turn_rate = dtheta_m / dt
        return Pose(self._x, self._y, self._theta)


@attrs.frozen(eq=False)
class Observation:
    """What the robot knows after a step.

    ``pose`` is the odometry estimate and ``true_pose`` the truth (for logging and plots, not
    for pilots); ``sonar`` the ranges ``(R,)`` at ``sonar_angles`` relative to the heading;
    ``bumped`` whether the last step collided and ``bump_bearing`` where (nan if not);
    ``sightings`` the landmarks seen; ``confidence`` the odometry's location confidence;
    ``v``, ``w`` the speed and turn rate the odometry measured over the last step.
    """

    t: float
    pose: Pose
    true_pose: Pose
    sonar: np.ndarray
    sonar_angles: np.ndarray
    bumped: bool
    sightings: tuple[Sighting, ...]
    confidence: float
    v: float
    w: float
    bump_bearing: float = math.nan


@attrs.define(on_setattr=attrs.setters.NO_OP)
class Sensors:
    """The robot's sensor suite; ``sonar`` or ``camera`` None leaves that sense out.

    It keeps the odometry's estimate between calls: :meth:`observe` starts it from the true
    pose on the first call after construction or :meth:`reset`, then updates it with each move.
    """

    sonar: SonarRing | None = attrs.field(factory=SonarRing)
    camera: Camera | None = attrs.field(factory=Camera)
    odometry: Odometry = attrs.field(factory=Odometry)
    bumper: Bumper = attrs.field(factory=Bumper)
    _previous: RobotState | None = attrs.field(default=None, init=False)
    _previous_t: float = attrs.field(default=0.0, init=False)
    _ids_of: object = attrs.field(default=None, init=False, repr=False)
    _ids: tuple[str, ...] = attrs.field(default=(), init=False, repr=False)

    def fitted(self, radius: float) -> Sensors:
        """A fresh suite like this one with the sonar mounted on a robot of ``radius``."""
        sonar = None if self.sonar is None else self.sonar.fitted(radius)
        return Sensors(sonar=sonar, camera=self.camera,
                       odometry=Odometry(self.odometry.noise_v, self.odometry.noise_w,
                                         self.odometry.confidence_scale),
                       bumper=self.bumper)

    def reset(self) -> None:
        """Forget the previous state: the next :meth:`observe` restarts dead reckoning."""
        self._previous = None

    def observe(self, state: RobotState, world: World, t: float, bumped: bool,
                rng: np.random.Generator, segments: np.ndarray | None = None,
                discs: np.ndarray | None = None) -> Observation:
        """Sense ``world`` at time ``t`` from ``state``.

        ``segments`` and ``discs`` default to ``world.segments_at(t)`` and
        ``world.discs_at(t)``; a simulator that already has them passes them in.
        """
        if segments is None:
            segments = world.segments_at(t)
        if discs is None:
            discs = world.discs_at(t)
        if self._previous is None:
            self.odometry.reset(state)
        else:
            self.odometry.update(self._previous, state, t - self._previous_t, rng)
        self._previous = state
        self._previous_t = t
        if self.sonar is not None:
            sonar = self.sonar.read(state, segments, discs, rng)
            angles = self.sonar.directions
        else:
            sonar = angles = np.zeros(0)
        sightings: tuple[Sighting, ...] = ()
        if self.camera is not None:
            if self._ids_of is not world:
                self._ids_of = world
                self._ids = tuple(mark.id for mark in world.landmarks)
            sightings = self.camera.see(state, world.landmark_array, self._ids, segments, rng,
                                        t)
        bump, bearing = self.bumper.read(state, bumped, segments, discs)
        odometry = self.odometry
        return Observation(t=t, pose=odometry.pose,
                           true_pose=Pose(state.x, state.y, state.theta), sonar=sonar,
                           sonar_angles=angles, bumped=bump, sightings=sightings,
                           confidence=odometry.confidence, v=odometry.speed,
                           w=odometry.turn_rate, bump_bearing=bearing)
