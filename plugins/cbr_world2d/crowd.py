"""Where the movers of a world are while a robot drives among them.

A mover walks its loop on a clock of its own. A mover that ``yields`` (a person, as people do)
stops while the robot stands in its way: its next step would bring its rim within
:data:`YIELD_GAP` of the robot's, and the robot lies across its line of walking (less than
:data:`PASSING` between their rims across it; a robot beside the line is passed). It walks on
when the way is clear, or after :data:`PATIENCE` seconds of waiting, when it pushes past as the
scripted loop would. The clock of a mover that does not yield is the world's time, so worlds
without yielding movers run exactly as :meth:`World.discs_at` says.
"""

from __future__ import annotations

import math

import numpy as np

from cbr_world2d.world import Point, World

YIELD_GAP = 0.3
"""Metres between a yielding mover's rim and the robot's under which it steps no nearer."""
PASSING = 0.1
"""Metres between the rims, across a yielding mover's line of walking, it passes the robot at."""
PATIENCE = 5.0
"""Seconds a yielding mover waits for the robot before it walks on regardless."""


class Crowd:
    """The movers of ``world`` on their own clocks, from time ``t`` where their loops put them
    (:attr:`before`: ``dt`` earlier), advanced a step at a time by :meth:`advance`;
    :attr:`clocks` is each mover's clock now (its time along its loop)."""

    def __init__(self, world: World, t: float = 0.0, dt: float = 0.0) -> None:
        self.world = world
        self.t = float(t)
        self.waited = np.zeros(len(world.movers))
        self._blocked = np.zeros(len(world.movers))
        self.yields = any(m.yields for m in world.movers)
        self.now: list[Point] = [m.position(self.t) for m in world.movers]
        """Where each mover is now."""
        self.before: list[Point] = [m.position(max(0.0, self.t - dt)) for m in world.movers]
        """Where each mover was a step ago."""

    @property
    def clocks(self) -> np.ndarray:
        return self.t - self.waited

    def discs(self) -> np.ndarray:
        """The discs that block now: the world's static discs and the movers present."""
        return self.world.discs_at(self.t, self.now)

    def advance(self, t: float, robot: Point, radius: float) -> None:
        """Move every mover to time ``t``, the robot at ``robot`` with ``radius`` in the way
        of those that yield."""
        dt = t - self.t
        self.before = self.now
        now: list[Point] = []
        for i, mover in enumerate(self.world.movers):
            here, ahead = self.before[i], mover.position(t - self.waited[i])
            if mover.yields and mover.present(t):
                if not self._in_way(here, ahead, robot, radius + mover.radius):
                    self._blocked[i] = 0.0
                elif self._blocked[i] < PATIENCE:
                    self.waited[i] += dt
                    self._blocked[i] += dt
                    now.append(here)
                    continue
            now.append(ahead)
        self.t = t
        self.now = now

    @staticmethod
    def _in_way(here: Point, ahead: Point, robot: Point, rims: float) -> bool:
        """Whether stepping from ``here`` to ``ahead`` walks into the robot at ``robot``:
        ``rims`` is the sum of the two radii."""
        step = math.dist(here, ahead)
        if step == 0.0 or math.dist(ahead, robot) >= rims + YIELD_GAP:
            return False
        ux, uy = (ahead[0] - here[0]) / step, (ahead[1] - here[1]) / step
        rx, ry = robot[0] - here[0], robot[1] - here[1]
        return rx * ux + ry * uy > 0.0 and abs(rx * uy - ry * ux) < rims + PASSING
