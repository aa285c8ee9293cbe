"""The primitive behaviors of 004 Table 1, each a fuzzy control rule: what a behavior proposes
(:class:`Proposal`), what a behavior is (:class:`Behavior`), and the twelve of the table.

A behavior looks at the observation and proposes a turn rate and a speed together with a
*degree of fit* in [0, 1], how well its context holds now (its activation: 0 means it has
nothing to say, say avoidCollision with nothing ahead). It may leave the turn or the speed
unspecified (``None``): ``moveForward`` has no opinion on turning. :mod:`.behaviors` merges the
proposals of a set by priority x fit.

The classes take metres, m/s and radians (plain data is converted by :mod:`.arguments`); a
direction or position left None is the symbolic ``curr-head`` (the heading when the behavior
starts, latched at its first step) or ``curr-goal`` (the pilot's current target, read at every
step). A behavior that latches something forgets it on :meth:`Behavior.reset`. The sonar work
runs in :mod:`.kernels`, loaded when a behavior that reads the sonar is built.

The heading behaviors (goStraight, goToPos) turn :data:`TURN_GAIN` per radian of heading
error; the line-following ones (followWall, enterDoorway) steer for a point a lookahead ahead
on the line they follow, turning :data:`STEER_GAIN` per radian. Along a straight line, with
``e`` the distance off the line, ``L`` the lookahead, ``K`` the gain and ``v`` the speed, this
is a damped oscillator ``e'' + K e' + (K v / L) e = 0`` (the heading error is the derivative
term: ``e' = -v sin(error)``), damping ratio ``sqrt(K L / (4 v))``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

import attrs
import numpy as np

from cbr_world2d.pilots.arguments import SPEEDS, TOP_TURN_RATE, TURN_RATES
from cbr_world2d.pilots.base import Point, bearing_error, wrap_angle

if TYPE_CHECKING:
    from cbr_world2d.sensors import Observation

TURN_GAIN = TOP_TURN_RATE / math.pi
"""1/s: turn rate per radian of heading error of the heading behaviors (goToPos, goStraight),
so that a heading straight behind asks for the top turn rate. Gentler than a pilot of its own
would turn, on purpose: merged with equal weight, avoidCollision turning at rate R out-turns
goToPos until the goal lies R / TURN_GAIN off the heading, beyond 90 degrees for R from
``mod-fast`` up, where goToPos asks for no speed; so the pair stops before a wall instead of
creeping into it at an angle."""
APPROACH = 0.5
"""m: goToPos slows in proportion to the distance left within this much of its position."""
COLLISION_ARC = math.radians(60.0)
"""avoidCollision and slowAvoid watch the beams within this angle of the heading (on a Pioneer
the front beams at 10, 30 and 50 degrees either side): what the robot would run into."""
OBSTACLE_ARC = math.radians(90.0)
"""avoidObstacle watches the front half of the ring, side beams included."""
COLLISION_FADE = 1.5
"""avoidCollision fits fully within its distance and fades out linearly to this many times it."""

COLLISION_CREEP = SPEEDS["slow"]
"""m/s: the speed avoidCollision asks for at the edge of its reach, falling to 0 at half its
distance."""
REAR_ARC = math.radians(110.0)
"""backOff reads the beams more than this off the heading as behind the robot (on a Pioneer the
rear ring's discs at 130 to 180 degrees)."""
REAR_ROOM = 0.4
"""m: backOff backs up only while every rear reading is longer than this."""
BACK_CLEAR = 2.0
"""backOff stops once the nearest reading ahead is this many times its distance."""
BACK_TIME = 3.0
"""s: backOff backs up at most this long at once."""
BACK_REST = 4.0
"""s: after backing up, backOff rests this long before it may back up again."""

SIDE_ARC = math.radians(20.0)
"""followWall and enterDoorway read what is beside the robot from the beams within this angle
of straight left or right: on a Pioneer the discs at +-90 degrees, whose 30 degree cones take in
the foot of the perpendicular to a wall within 15 degrees of parallel. The next discs, at 50
and 130 degrees, are 40 degrees off and read what lies ahead or behind, say a corner."""
WALL_REACH = 1.5
"""m: followWall latches on and follows a wall whose side reading is within this: half a hallway
3.5 m wide less the robot's radius (a Pioneer's 0.25 m), so that in any hallway up to that
width a wall is in reach; beyond, the robot is in open space and has no wall to follow."""
HOLD_MIN = 0.3
"""m: followWall holds at least this reading: where Figure 4(b)'s avoidCollision (20 cm,
fading out at 1.5 x 20 cm) stops fitting, so that following a wall never sets it off."""
HOLD_MAX = 1.0
"""m: followWall holds at most this reading: half a metre (a Pioneer's width) inside
:data:`WALL_REACH`, so that swinging out while it corrects does not lose the wall."""
STEER_GAIN = 1.0
"""1/s: turn rate per radian of heading error of the line-following behaviors, stiffer than
:data:`TURN_GAIN` since they turn back onto a line rather than merely toward a point."""
WALL_LOOKAHEAD = 1.0
"""m: followWall steers for the point this far ahead at the held distance. With
:data:`STEER_GAIN` the damping ratio ``sqrt(K L / 4v)`` is 0.79 at ``fast`` (0.4 m/s) and more
at every slower named speed: it settles without overshooting to speak of, within a few metres."""
DOOR_LOOKAHEAD = 0.5
"""m: enterDoorway steers for the point on the door's axis this far ahead of the robot's
projection on it: shorter than :data:`WALL_LOOKAHEAD`, since the robot must be on the axis
before the jambs; the damping ratio is 0.79 at ``moderate`` (0.2 m/s), the fastest it drives."""
DOOR_REACH = 2.0
"""m: enterDoorway fits within this of the door's centre (and no farther past it than
:data:`DOOR_PAST`): room for about four lookaheads of travel, in which the steering closes an
offset of a metre from the axis before the door."""
DOOR_PAST = 0.5
"""m: enterDoorway fits until the robot's centre is this far past the door's line, twice a
Pioneer's radius, so that its body is through with room to spare; within this of the line either
way the jambs are beside it, and it centres between them when both side readings are within
:data:`JAMB_REACH`."""
JAMB_REACH = 0.6
"""m: side readings within this count as a doorway's jambs: a Pioneer centred in a doorway up to
1.7 m wide (0.6 + 0.25 m each side) reads both; ordinary doors are 0.8 to 1.2 m wide."""
DOOR_SPEED = SPEEDS["moderate"]
"""m/s: enterDoorway's speed at :data:`DOOR_REACH` from the door: ``moderate``, the fastest at
which :data:`DOOR_LOOKAHEAD`'s steering is damped enough (ratio 0.79)."""
DOOR_CREEP = SPEEDS["slow"]
"""m/s: enterDoorway's speed at the door's centre, where the clearance is least (0.35 m either
side of a Pioneer in a 1.2 m doorway); between the two it slows in proportion to the distance.
At ``slow`` it reads the jambs a hundred times while crossing the metre where it centres
between them, at the default step of 0.1 s."""
TURN_TO_RATE = TURN_RATES["moderate"]
"""rad/s: turnTo turns at most this fast (50 deg/s, half the Pioneer's limit): with
:data:`TURN_TO_GAIN` the rate asked for then falls no faster than the robot can brake."""
TURN_TO_GAIN = 2.0
"""1/s: turnTo's turn rate per radian of heading error below :data:`TURN_TO_RATE`. Following it,
the rate asked for falls at 2/s times the rate, at most 2 x 50 = 100 deg/s^2, the Pioneer's turn
acceleration limit, so the robot brakes as asked and does not overshoot."""
FACING = math.radians(2.0)
"""turnTo is done within this of its heading: at the sonar's 5 m range, 17 cm to one side, less
than a Pioneer's radius."""
SCAN_RATE = TURN_RATES["slow"]
"""rad/s: localize turns on the spot at this rate (25 deg/s): at the default step of 0.1 s the
ring turns 2.5 degrees between readings, a twelfth of a sonar cone, so every direction is
sounded densely; a turn takes 14.4 s."""
SCAN_ANGLE = 2.0 * math.pi
"""localize has observed enough once it has turned this much: every beam has swept the whole
circle."""


@attrs.frozen
class Proposal:
    """What one behavior asks for: a turn rate (rad/s) and a speed (m/s), either None when it
    has no opinion, with its degree of fit in [0, 1]. ``limit``: the speed is a most the robot
    may drive, to the degree of the fit (a behavior that slows for an obstacle), not merely a
    wish to blend with the others."""

    turn: float | None
    speed: float | None
    fit: float
    limit: bool = False


NOTHING = Proposal(None, None, 0.0)
"""The proposal of a behavior whose context does not hold."""


class Behavior(Protocol):
    """A behavior: proposes a turn rate and a speed with a degree of fit each step."""

    def propose(self, obs: Observation, target: Point) -> Proposal:
        """This step's proposal; ``target`` is the pilot's current target."""
        ...

    def reset(self) -> None:
        """Forget what was latched at the start (a new trial or a newly installed set)."""
        ...


def _clip(value: float, low: float, high: float) -> float:
    return min(max(value, low), high)


SectorKernel = Callable[[np.ndarray, np.ndarray, float, float], tuple[float, float]]
""":func:`cbr_world2d.pilots.kernels.sector`: ``(nearest, side)`` of the sonar beams within an
arc of the heading."""
SidesKernel = Callable[[np.ndarray, np.ndarray, float], tuple[float, float]]
""":func:`cbr_world2d.pilots.kernels.sides`: the ``(left, right)`` readings beside the robot."""


# numba loads when a behavior that reads the sonar is built, not with the registration at every
# start of cbr; the behavior keeps the kernel so that a step looks up no module
def _sector_kernel() -> SectorKernel:
    from cbr_world2d.pilots.kernels import sector

    return sector


def _sides_kernel() -> SidesKernel:
    from cbr_world2d.pilots.kernels import sides

    return sides


def _floats(values: np.ndarray) -> np.ndarray:
    return np.asarray(values, dtype=np.float64)


@attrs.define
class Stop:
    """``(stop)``: stop forward movement (speed 0, turn unspecified)."""

    def propose(self, obs: Observation, target: Point) -> Proposal:
        return Proposal(None, 0.0, 1.0)

    def reset(self) -> None:
        pass


@attrs.define
class MoveForward:
    """``(moveForward velocity)``: move forward at ``velocity`` m/s (turn unspecified)."""

    velocity: float

    def propose(self, obs: Observation, target: Point) -> Proposal:
        return Proposal(None, self.velocity, 1.0)

    def reset(self) -> None:
        pass


@attrs.define
class GoStraight:
    """``(goStraight velocity direction)``: keep the heading ``direction`` (radians, or None
    for the heading when the behavior starts) at ``velocity`` m/s, slower when off course
    (speed times cos of the heading error) and turning :data:`TURN_GAIN` per radian of error."""

    velocity: float
    direction: float | None = None
    _latched: float | None = attrs.field(default=None, init=False)

    def propose(self, obs: Observation, target: Point) -> Proposal:
        if self._latched is None:
            self._latched = obs.pose.theta if self.direction is None else self.direction
        error = wrap_angle(self._latched - obs.pose.theta)
        return Proposal(TURN_GAIN * error, self.velocity * max(math.cos(error), 0.0), 1.0)

    def reset(self) -> None:
        self._latched = None


@attrs.define
class GoToPos:
    """``(goToPos position speed accuracy)``: head for ``position`` (None: the pilot's target)
    at ``speed`` m/s. It turns :data:`TURN_GAIN` per radian of heading error, drives at speed
    times cos of the error (not at all when the point is behind), slows
    in proportion within 0.5 m of the point, and holds still (turn and speed 0) once within
    ``accuracy`` metres of it."""

    position: Point | None
    speed: float
    accuracy: float

    def propose(self, obs: Observation, target: Point) -> Proposal:
        pose = obs.pose
        goal = target if self.position is None else self.position
        distance, error = bearing_error(pose.x, pose.y, pose.theta, goal)
        if distance <= self.accuracy:
            return Proposal(0.0, 0.0, 1.0)
        speed = self.speed * max(math.cos(error), 0.0) * min(1.0, distance / APPROACH)
        return Proposal(TURN_GAIN * error, speed, 1.0)

    def reset(self) -> None:
        pass


@attrs.define
class AvoidObstacle:
    """``(avoidObstacle distance speed)``: with something within ``distance`` metres in the
    front half, slow to ``speed`` and turn away at ``turn_rate`` (the side with the closer
    readings, see :func:`cbr_world2d.pilots.kernels.sector`, chosen when the obstacle comes
    within ``distance`` and held until it is clear: a reading flickering about the robot's axis
    does not swing it left and right). Its fit grows from 0 at ``distance`` to 1 at contact:
    ``1 - nearest / distance``. ``turn_rate`` is none of Table 1's arguments: plain data leaves
    it at ``moderate``."""

    distance: float
    speed: float
    turn_rate: float = TURN_RATES["moderate"]
    _sector: SectorKernel = attrs.field(init=False, factory=_sector_kernel, eq=False,
                                        repr=False)
    _side: float = attrs.field(default=0.0, init=False)

    def propose(self, obs: Observation, target: Point) -> Proposal:
        nearest, side = self._sector(_floats(obs.sonar), _floats(obs.sonar_angles),
                                     OBSTACLE_ARC, self.distance)
        fit = _clip(1.0 - nearest / self.distance, 0.0, 1.0)
        if fit == 0.0:
            self._side = 0.0
            return NOTHING
        if self._side == 0.0:
            self._side = side
        return Proposal(self._side * self.turn_rate, self.speed, fit, limit=True)

    def reset(self) -> None:
        self._side = 0.0


@attrs.define
class AvoidCollision:
    """``(avoidCollision distance turnRate)``: with something within ``distance`` metres ahead
    (beams within 60 degrees of the heading), slow down and turn away at ``turn_rate`` rad/s,
    the side chosen when the obstacle comes into reach and held until it is clear. Its fit is 1
    within ``distance`` and fades linearly to 0 at 1.5 times ``distance``. The speed it asks
    for falls from :data:`COLLISION_CREEP` at 1.5 times ``distance`` to 0 at half of it: the
    robot keeps steering round what it can pass rather than freezing before it (Table 1 says
    "turn", not "stop"), and stops for what is right in front of it."""

    distance: float
    turn_rate: float
    _sector: SectorKernel = attrs.field(init=False, factory=_sector_kernel, eq=False,
                                        repr=False)
    _side: float = attrs.field(default=0.0, init=False)

    def propose(self, obs: Observation, target: Point) -> Proposal:
        reach = COLLISION_FADE * self.distance
        nearest, side = self._sector(_floats(obs.sonar), _floats(obs.sonar_angles),
                                     COLLISION_ARC, reach)
        fit = _clip((reach - nearest) / (reach - self.distance), 0.0, 1.0)
        if fit == 0.0:
            self._side = 0.0
            return NOTHING
        if self._side == 0.0:
            self._side = side
        stop = 0.5 * self.distance
        speed = COLLISION_CREEP * _clip((nearest - stop) / (reach - stop), 0.0, 1.0)
        return Proposal(self._side * self.turn_rate, speed, fit, limit=True)

    def reset(self) -> None:
        self._side = 0.0


@attrs.define
class BackOff:
    """``(backOff distance speed)``: the escape the other behaviors lack. With something within
    ``distance`` metres ahead (the beams of :data:`COLLISION_ARC`) and room behind (every rear
    beam reads more than :data:`REAR_ROOM`), back up at ``speed`` turning the nose toward the
    freer side, fit 1, until the nearest reading ahead is :data:`BACK_CLEAR` times ``distance``
    or :data:`BACK_TIME` seconds have passed; then it rests :data:`BACK_REST` seconds, so that
    the other behaviors drive on before it may back up again."""

    distance: float
    speed: float
    _sector: SectorKernel = attrs.field(init=False, factory=_sector_kernel, eq=False,
                                        repr=False)
    _sides: SidesKernel = attrs.field(init=False, factory=_sides_kernel, eq=False, repr=False)
    _since: float | None = attrs.field(default=None, init=False)
    """When the backing up started; None while not backing up."""
    _turn: float = attrs.field(default=0.0, init=False)
    _rest_until: float = attrs.field(default=-math.inf, init=False)

    def propose(self, obs: Observation, target: Point) -> Proposal:
        ranges, angles = _floats(obs.sonar), _floats(obs.sonar_angles)
        nearest, _ = self._sector(ranges, angles, COLLISION_ARC, self.distance)
        if self._since is None:
            if obs.t < self._rest_until or nearest >= self.distance:
                return NOTHING
            behind = _rear(ranges, angles)
            if behind <= REAR_ROOM:
                return NOTHING
            left, right = self._sides(ranges, angles, SIDE_ARC)
            # the heading turns with the turn rate whichever way the robot drives: turning
            # counter-clockwise while backing up points the nose left, toward the freer side
            self._since, self._turn = obs.t, (1.0 if left >= right else -1.0)
        if (nearest >= BACK_CLEAR * self.distance or obs.t - self._since >= BACK_TIME
                or _rear(ranges, angles) <= REAR_ROOM):
            self._since, self._rest_until = None, obs.t + BACK_REST
            return NOTHING
        return Proposal(self._turn * TURN_RATES["slow"], -self.speed, 1.0)

    def reset(self) -> None:
        self._since, self._turn, self._rest_until = None, 0.0, -math.inf


def _rear(ranges: np.ndarray, angles: np.ndarray) -> float:
    """The shortest reading of the beams pointing backward (more than 110 degrees off the
    heading)."""
    back = np.abs((angles + math.pi) % (2.0 * math.pi) - math.pi) > REAR_ARC
    return float(ranges[back].min()) if back.any() else math.inf


@attrs.define
class SlowAvoid:
    """``(slowAvoid distance speed)``: slow but continue toward an obstacle. With something
    within ``distance`` metres ahead (the beams of :data:`COLLISION_ARC`, what the robot would
    run into), propose ``speed`` and no turn; the fit grows from 0 at ``distance`` to 1 at
    contact, ``1 - nearest / distance``, so merged with a faster ``moveForward`` the robot slows
    the more the nearer the obstacle, and lets a pedestrian step aside (004 Figure 4(b))."""

    distance: float
    speed: float
    _sector: SectorKernel = attrs.field(init=False, factory=_sector_kernel, eq=False,
                                        repr=False)

    def propose(self, obs: Observation, target: Point) -> Proposal:
        nearest, _ = self._sector(_floats(obs.sonar), _floats(obs.sonar_angles),
                                  COLLISION_ARC, self.distance)
        fit = _clip(1.0 - nearest / self.distance, 0.0, 1.0)
        return NOTHING if fit == 0.0 else Proposal(None, self.speed, fit, limit=True)

    def reset(self) -> None:
        pass


@attrs.define
class FollowWall:
    """``(followWall direction)``: travel along a detected wall, heading ``direction``
    (radians, or None for the heading when the behavior starts).

    At its first step with a wall in reach (a side reading, :data:`SIDE_ARC`, within
    :data:`WALL_REACH`) it latches the nearer side and the reading there, clipped to
    [:data:`HOLD_MIN`, :data:`HOLD_MAX`], as the distance to hold. Then it steers for the point
    :data:`WALL_LOOKAHEAD` ahead at that distance: the heading ``direction`` turned toward the
    wall by ``atan((reading - hold) / WALL_LOOKAHEAD)``, :data:`STEER_GAIN` per radian of
    error (proportional on the distance; the heading error is the derivative term). It proposes
    a turn only, fit 1; with no wall in reach on the latched side (the wall ended, or a doorway)
    its fit is 0 and it latches afresh on the next wall in reach. Along a wall at an angle
    ``a`` to ``direction`` it holds the distance ``WALL_LOOKAHEAD * tan(a)`` off the one it
    latched (``curr-head`` started parallel to the wall gives ``a = 0``)."""

    direction: float | None = None
    _sides: SidesKernel = attrs.field(init=False, factory=_sides_kernel, eq=False, repr=False)
    _heading: float | None = attrs.field(default=None, init=False)
    _side: int = attrs.field(default=0, init=False)
    """+1 following a wall on the left, -1 on the right, 0 none latched."""
    _hold: float = attrs.field(default=0.0, init=False)

    def propose(self, obs: Observation, target: Point) -> Proposal:
        pose = obs.pose
        if self._heading is None:
            self._heading = pose.theta if self.direction is None else self.direction
        left, right = self._sides(_floats(obs.sonar), _floats(obs.sonar_angles), SIDE_ARC)
        if self._side == 0:
            nearer = min(left, right)
            if nearer > WALL_REACH:
                return NOTHING
            self._side = 1 if left <= right else -1
            self._hold = _clip(nearer, HOLD_MIN, HOLD_MAX)
        reading = left if self._side > 0 else right
        if reading > WALL_REACH:
            self._side = 0
            return NOTHING
        wanted = self._heading + self._side * math.atan((reading - self._hold) / WALL_LOOKAHEAD)
        return Proposal(STEER_GAIN * wrap_angle(wanted - pose.theta), None, 1.0)

    @property
    def holding(self) -> tuple[int, float] | None:
        """``(side, distance)`` latched (side +1 left, -1 right), or None."""
        return None if self._side == 0 else (self._side, self._hold)

    def reset(self) -> None:
        self._heading = None
        self._side = 0
        self._hold = 0.0


@attrs.define
class EnterDoorway:
    """``(enterDoorway door direction)``: go through the doorway centred at ``door`` (None: the
    pilot's target) heading ``direction`` (radians, or None for the heading when the behavior
    starts).

    The door's axis is the line through ``door`` along ``direction``. Within
    :data:`DOOR_REACH` of the door and no farther than :data:`DOOR_PAST` past its line, fit 1:
    it steers for the carrot on the axis :data:`DOOR_LOOKAHEAD` ahead of the robot's
    projection on it (:data:`STEER_GAIN` per radian of error), where the jambs are beside the
    robot (within :data:`DOOR_PAST` of the line, both side readings within
    :data:`JAMB_REACH`) for the point midway between them instead, and drives at
    :data:`DOOR_SPEED` slowing in proportion to :data:`DOOR_CREEP` at the door, times cos of
    the heading error (not at all facing away). Elsewhere its fit is 0."""

    door: Point | None
    direction: float | None = None
    _sides: SidesKernel = attrs.field(init=False, factory=_sides_kernel, eq=False, repr=False)
    _heading: float | None = attrs.field(default=None, init=False)

    def propose(self, obs: Observation, target: Point) -> Proposal:
        pose = obs.pose
        if self._heading is None:
            self._heading = pose.theta if self.direction is None else self.direction
        cx, cy = target if self.door is None else self.door
        ux, uy = math.cos(self._heading), math.sin(self._heading)
        dx, dy = pose.x - cx, pose.y - cy
        along = dx * ux + dy * uy
        distance = math.hypot(dx, dy)
        if distance > DOOR_REACH or along > DOOR_PAST:
            return NOTHING
        # how far left of the axis the robot is (its normal (-uy, ux) points left)
        across = dy * ux - dx * uy
        if abs(along) <= DOOR_PAST:
            left, right = self._sides(_floats(obs.sonar), _floats(obs.sonar_angles), SIDE_ARC)
            if left <= JAMB_REACH and right <= JAMB_REACH:
                across = 0.5 * (right - left)
        carrot = (pose.x + DOOR_LOOKAHEAD * ux + across * uy,
                  pose.y + DOOR_LOOKAHEAD * uy - across * ux)
        _, error = bearing_error(pose.x, pose.y, pose.theta, carrot)
        speed = DOOR_CREEP + (DOOR_SPEED - DOOR_CREEP) * distance / DOOR_REACH
        return Proposal(STEER_GAIN * error, speed * max(math.cos(error), 0.0), 1.0)

    def reset(self) -> None:
        self._heading = None


def _turning(error: float) -> float:
    return _clip(TURN_TO_GAIN * error, -TURN_TO_RATE, TURN_TO_RATE)


@attrs.define
class TurnToPos:
    """``(turnTo pos)``: turn on the spot to face ``pos`` (None: the pilot's target): speed 0
    and a turn of :data:`TURN_TO_GAIN` per radian of bearing error, at most
    :data:`TURN_TO_RATE`, fit 1, until the robot faces it within :data:`FACING`; from then on
    (until reset) fit 0. A point at the robot's own position has no bearing: nothing to do."""

    pos: Point | None
    _done: bool = attrs.field(default=False, init=False)

    def propose(self, obs: Observation, target: Point) -> Proposal:
        if self._done:
            return NOTHING
        pose = obs.pose
        distance, error = bearing_error(pose.x, pose.y, pose.theta,
                                        target if self.pos is None else self.pos)
        if distance == 0.0 or abs(error) <= FACING:
            self._done = True
            return NOTHING
        return Proposal(_turning(error), 0.0, 1.0)

    def reset(self) -> None:
        self._done = False


@attrs.define
class TurnToAngle:
    """``(turnTo direction angle)``: turn on the spot by ``angle`` radians (positive to the
    left) from ``direction`` (radians, or None for the heading when the behavior starts),
    latched at the first step: the robot turns the shorter way to ``direction`` and on by
    ``angle`` in its sense, so ``(turnTo curr-head 180)`` turns left and ``-180`` right. Speed 0
    and turning as :class:`TurnToPos` does, fit 1, until the rest of the turn is within
    :data:`FACING`; from then on (until reset) fit 0. The turn is counted from the odometry's
    headings step by step, so it may exceed half a turn."""

    direction: float | None
    angle: float
    _left: float | None = attrs.field(default=None, init=False)
    """The turn still to make, radians counter-clockwise; None before the first step."""
    _last: float = attrs.field(default=0.0, init=False)
    _done: bool = attrs.field(default=False, init=False)

    def propose(self, obs: Observation, target: Point) -> Proposal:
        if self._done:
            return NOTHING
        theta = obs.pose.theta
        if self._left is None:
            base = 0.0 if self.direction is None else wrap_angle(self.direction - theta)
            self._left = base + self.angle
        else:
            self._left -= wrap_angle(theta - self._last)
        self._last = theta
        if abs(self._left) <= FACING:
            self._done = True
            return NOTHING
        return Proposal(_turning(self._left), 0.0, 1.0)

    def reset(self) -> None:
        self._left = None
        self._last = 0.0
        self._done = False


@attrs.define
class Localize:
    """``(localize)``: make sensor observations for the localization algorithm: stand still
    (speed 0, a limit: the others do not drive the robot off while it looks) and turn on the
    spot at :data:`SCAN_RATE`, fit 1, until it has turned
    :data:`SCAN_ANGLE` (counted from the odometry's headings); from then on (until reset) fit
    0. :attr:`cbr_world2d.pilots.BehaviorPilot.localizing` is True while it fits, when the map
    subsystem takes its observations."""

    _turned: float = attrs.field(default=0.0, init=False)
    _last: float | None = attrs.field(default=None, init=False)

    def propose(self, obs: Observation, target: Point) -> Proposal:
        theta = obs.pose.theta
        if self._last is not None:
            self._turned += abs(wrap_angle(theta - self._last))
        self._last = theta
        if self._turned >= SCAN_ANGLE:
            return NOTHING
        return Proposal(SCAN_RATE, 0.0, 1.0, limit=True)

    def reset(self) -> None:
        self._turned = 0.0
        self._last = None
