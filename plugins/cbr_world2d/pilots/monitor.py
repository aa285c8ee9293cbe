"""The progress monitor: whether the robot is moving on, blocked, or oscillating.

The monitor keeps the trajectory of the last ``window`` seconds (the pose the robot believes it
has, and its distance to the current target) and judges it once the history covers a whole
window. Over that window, with ``D`` the net displacement, ``L`` the path length driven and
``P`` the progress (how much the distance to the target shrank):

* **moving** when ``P >= min_progress`` (getting closer is never being stuck), and while the
  history is shorter than the window (too early to judge);
* **oscillating** when, without progress, ``L >= min_path`` and ``L >= oscillation_ratio * D``:
  the robot drives but comes back where it was, the side-to-side loop of 002's scenario 2;
* **blocked** when, without progress, ``D < min_displacement``: it hardly moves;
* **moving** otherwise (it goes somewhere, say around an obstacle, though not yet closer).

The defaults suit both robots of the package: the slow robot of 002 drives 0.5 m in a 10 s
window at its 5 cm/s, so 0.3 m of displacement tells moving from blocked for it, and a Pioneer
at cruising speed covers several metres. The monitor updates in constant time per step (the
path length is a running sum), whatever the time step.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Literal

import attrs

from cbr_world2d.pilots.base import Point
from cbrcore.options import option

Status = Literal["moving", "blocked", "oscillating"]

STUCK: tuple[Status, ...] = ("blocked", "oscillating")
"""The statuses that say the robot got stuck, and the names of the events reporting them."""

_POSITIVE = attrs.validators.gt(0.0)


@attrs.frozen
class MonitorOptions:
    """The thresholds of the progress monitor (metres and seconds)."""

    window: float = option(10.0, "Seconds of trajectory judged at once.", validator=_POSITIVE)
    min_progress: float = option(
        0.2, "Getting this much closer to the target within the window is progress.",
        validator=_POSITIVE)
    min_displacement: float = option(
        0.3, "Without progress, a net displacement under this within the window is blocked.",
        validator=_POSITIVE)
    min_path: float = option(
        0.3, "Without progress, driving at least this far within the window ...",
        validator=_POSITIVE)
    oscillation_ratio: float = option(
        3.0, "... and at least this many times the net displacement is oscillating.",
        validator=attrs.validators.gt(1.0))


class ProgressMonitor:
    """Judges the recent trajectory; feed it every step with :meth:`update`."""

    def __init__(self, options: MonitorOptions | None = None) -> None:
        self.options = options if options is not None else MonitorOptions()
        # (t, x, y, path length driven so far, distance to the target)
        self._history: deque[tuple[float, float, float, float, float]] = deque()
        self.status: Status = "moving"

    def reset(self) -> None:
        """Forget the trajectory (a new trial, or a new target to judge progress toward)."""
        self._history.clear()
        self.status = "moving"

    def update(self, t: float, x: float, y: float, target: Point) -> Status:
        """Add the pose at time ``t`` and return the status of the window ending there."""
        history = self._history
        distance = math.hypot(target[0] - x, target[1] - y)
        path = 0.0
        if history:
            _, x0, y0, path, _ = history[-1]
            path += math.hypot(x - x0, y - y0)
        history.append((t, x, y, path, distance))
        window = self.options.window
        # keep the newest sample at or before t - window as the window's start
        while len(history) > 1 and t - history[1][0] >= window:
            history.popleft()
        self.status = self._judge(history[0], history[-1])
        return self.status

    def _judge(self, first: tuple[float, float, float, float, float],
               last: tuple[float, float, float, float, float]) -> Status:
        o = self.options
        t0, x0, y0, path0, distance0 = first
        t1, x1, y1, path1, distance1 = last
        if t1 - t0 < o.window or distance0 - distance1 >= o.min_progress:
            return "moving"
        driven = path1 - path0
        displacement = math.hypot(x1 - x0, y1 - y0)
        if driven >= o.min_path and driven >= o.oscillation_ratio * displacement:
            return "oscillating"
        if displacement < o.min_displacement:
            return "blocked"
        return "moving"
