"""002 Figure 7, rebuilt from the runs of ``landmark-scenarios``: every trial's path, the points
A, B and C of the paper's account, the consultations, the retrievals and the diverting targets.

002 names three points: A, where the robot starts (and, with CBR, retrieves a case); B, where
the robot without CBR meets the obstacles (scenario 1: it begins to avoid the wall; scenario 2:
the side-to-side loop in the V); C, the diverting target the CBR agent sends the robot to. They
are found in the runs:

- **B** is where the first trial without CBR first heads more than :data:`TURNED` degrees away
  from its target (after the first :data:`SETTLE` seconds, while the pilot turns toward it);
- **C** is the point of the first trial with CBR nearest the first diverting target a
  retrieved case gave it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from cbr_landmarks.experiments.common import Driven
    from cbr_world2d.world import World

TURNED = 45.0
"""Degrees between the robot's heading and the bearing of its target that make point B."""

SETTLE = 5.0
"""Seconds at the start of a trial not looked at for point B."""


def point_b(path: np.ndarray, target: Sequence[float]) -> tuple[float, float] | None:
    """Where a path (rows ``t, x, y, theta``) first heads more than :data:`TURNED` degrees away
    from ``target`` after :data:`SETTLE` seconds; None if it never does."""
    bearing = np.arctan2(target[1] - path[:, 2], target[0] - path[:, 1])
    off = np.abs((path[:, 3] - bearing + math.pi) % (2 * math.pi) - math.pi)
    late = np.flatnonzero((path[:, 0] >= SETTLE) & (off > math.radians(TURNED)))
    return None if not len(late) else (float(path[late[0], 1]), float(path[late[0], 2]))


def point_c(path: np.ndarray, decisions: Sequence[Mapping[str, Any]], trial: int
            ) -> tuple[float, float] | None:
    """The point of ``path`` nearest the first diverting target a retrieved case gave trial
    ``trial``; None if no case gave one."""
    for d in decisions:
        if d["trial"] == trial and d["source"] == "casebase" and math.isfinite(d["divert_x"]):
            gap = np.hypot(path[:, 1] - d["divert_x"], path[:, 2] - d["divert_y"])
            k = int(np.argmin(gap))
            return float(path[k, 1]), float(path[k, 2])
    return None


def _paths(run: Driven) -> list[np.ndarray]:
    return [run.paths[name] for name in sorted(run.paths, key=lambda n: int(n.split("_")[1]))]


def draw_scenario(ax: Axes, world: World, alone: Driven, agent: Driven, title: str) -> None:
    """One scenario: the world, every trial's path (the first bold), A, B, C, the consultations,
    retrievals and diverting targets of the robot with CBR."""
    from cbr_world2d.plot import draw_world

    draw_world(ax, world)
    start, target = world.places["start"], world.places["target"]
    for run, style, label in ((alone, "--", "without CBR"), (agent, "-", "with CBR")):
        paths = _paths(run)
        for k, path in enumerate(paths):
            first = k == 0
            ax.plot(path[:, 1], path[:, 2], style, color="black" if first else "0.45",
                    linewidth=1.4 if first else 0.6, alpha=1.0 if first else 0.35,
                    label=f"{label} (first trial; grey: all {len(paths)})" if first else None,
                    zorder=3 if first else 2)
    decisions = agent.decisions
    asked = [d for d in decisions if d["source"] != "casebase"]
    retrieved = [d for d in decisions if d["source"] == "casebase"]
    targets = [d for d in decisions if math.isfinite(d["divert_x"])]
    if asked:
        ax.plot([d["x"] for d in asked], [d["y"] for d in asked], ".", color="tab:gray",
                markersize=5, label="consulted, no case", zorder=4)
    if retrieved:
        ax.plot([d["x"] for d in retrieved], [d["y"] for d in retrieved], "^",
                color="tab:green", markersize=7, label="a case retrieved", zorder=4)
    if targets:
        ax.plot([d["divert_x"] for d in targets], [d["divert_y"] for d in targets], "x",
                color="tab:red", markersize=8, mew=2, label="diverting target", zorder=4)
    ax.plot(*target, marker="*", markersize=16, color="tab:red", linestyle="none", zorder=5)
    points: dict[str, tuple[float, float] | None] = {"A": (start[0], start[1])}
    first_alone, first_agent = _paths(alone)[:1], _paths(agent)[:1]
    points["B"] = point_b(first_alone[0], target) if first_alone else None
    points["C"] = point_c(first_agent[0], decisions, 0) if first_agent else None
    for name, at in points.items():
        if at is not None:
            ax.plot(*at, "o", color="black", markersize=5, zorder=6)
            ax.annotate(name, at, textcoords="offset points", xytext=(-13, -13),
                        fontweight="bold", zorder=6)
    ax.set_title(title)


def figure7(worlds: Mapping[str, World], driven: Mapping[str, Mapping[str, Driven]]
            ) -> Figure:
    """The figure: one panel per scenario, the robots ``no-cbr`` and ``cbr-handmade``."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(13, 6.5))
    legend: dict[str, Any] = {}
    for k, (scenario, world) in enumerate(worlds.items()):
        ax = figure.add_subplot(1, len(worlds), k + 1)
        draw_scenario(ax, world, driven[scenario]["no-cbr"], driven[scenario]["cbr-handmade"],
                      f"scenario {scenario[-1]}")
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            legend.setdefault(label, handle)
    # one legend for both panels, below them, clear of the paths
    figure.legend(list(legend.values()), list(legend), loc="lower center", ncol=3, fontsize=8)
    figure.subplots_adjust(bottom=0.2)
    figure.suptitle("002 Figure 7, rebuilt: dashed without CBR, solid with it")
    return figure
