"""What a grid run records (see :mod:`cbr_recording`): the map, the learned risk map, and each
trip's plan, the robot driving it and the obstacles it met.

A trip is an episode of the recording. Its clock runs as the robot drives: one second per
straight step, √2 per diagonal one (the cost model's step lengths; a cell's risk does not slow
it) and ``collision_time`` seconds at each stop before an obstacle, so a trip lasts its
``travel_time``. The consultation and the plan are at 0 s. Cells are drawn at their centres in
the map frame: a ROS map's own, else one metre per cell with the grid's lower-left corner at
the origin.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from cbr_grid.frame import MapFrame
from cbr_grid.grid import Grid
from cbr_grid.query import GridQuery

if TYPE_CHECKING:
    from cbr_grid.drive import DriveReport
    from cbr_recording.markers import Marker
    from cbr_recording.recorder import Recorder
    from cbrcore.model import Proposal

UNIT_FRAME = MapFrame(1.0)
"""The frame of a grid that has none: one metre per cell, the lower-left corner at 0."""

RED = (0.9, 0.1, 0.1, 1.0)


def frame_of(grid: Grid) -> MapFrame:
    return grid.frame if grid.frame is not None else UNIT_FRAME


def in_metres(grid: Grid, cells: np.ndarray) -> np.ndarray:
    """The (n, 2) map-frame points of the centres of ``cells`` (x, y) of ``grid``."""
    xy = np.asarray(cells, dtype=np.float64).reshape(-1, 2)
    return frame_of(grid).centres(xy, grid.height)


def occupancy(grid: Grid) -> np.ndarray:
    """``grid`` as ROS occupancy values, rows from the lower left: a cell's risk times 100
    (100 an obstacle), -1 where the map does not know the cell."""
    values = np.rint(grid.risk * 100.0).astype(np.int8)
    if grid.unknown is not None:
        values[grid.unknown] = -1
    return np.flipud(values)


def publish_grid(recorder: Recorder, topic: str, grid: Grid, *, latched: bool = False) -> None:
    frame = frame_of(grid)
    recorder.grid(topic, occupancy(grid), frame.resolution, frame.origin, latched=latched)


def cells_marker(grid: Grid, ns: str, cells: np.ndarray, color: tuple[float, ...], *,
                 colors: np.ndarray | None = None, height: float = 0.1,
                 marker_id: int = 0) -> Marker:
    """A cube on each of ``cells``, a cell wide."""
    from cbr_recording.markers import Marker

    side = frame_of(grid).resolution
    points = in_metres(grid, cells)
    return Marker(ns, marker_id, "cube_list", np.column_stack(
        (points, np.full(len(points), 0.5 * height))), scale=(side, side, height),
        color=color, colors=colors, pose=(0.0, 0.0, 0.0))


def risk_colors(risk: np.ndarray) -> np.ndarray:
    """Green at risk 0 to red at risk 1, opaque."""
    risk = np.clip(np.asarray(risk, dtype=np.float64), 0.0, 1.0)
    return np.column_stack((risk, 1.0 - risk, np.zeros_like(risk), np.ones_like(risk)))


class TripRecording:
    """Records the trips of one ``trips`` workload: its map once, the learned map whenever it
    changed, and each trip."""

    def __init__(self, configured: Grid) -> None:
        self.configured = configured
        self._shown: Grid | None = None
        self._met_shown = False

    def begin(self, recorder: Recorder, grid: Grid) -> None:
        """Start a trip's episode on the current map ``grid``."""
        recorder.episode()
        if self._shown is None:
            publish_grid(recorder, "/map", self.configured, latched=True)
        if grid is not self._shown:
            publish_grid(recorder, "/risk_map", grid, latched=True)
            self._shown = grid

    def trip(self, recorder: Recorder, grid: Grid, query: int, problem: GridQuery,
             proposal: Proposal, report: DriveReport | None, collision_time: float) -> None:
        """The consultation, its plan, the drive and the obstacles met, at the trip's times."""
        from cbr_recording.cdr import headings
        from cbr_recording.markers import Clear

        recorder.at(0.0)
        solution = proposal.solution
        action = "no path" if solution is None else (
            f"path of {len(solution.value)} cells, cost {solution.cost:.6g}")
        recorder.decision(query, proposal, action=action, detail={
            "start": list(problem.start), "goal": list(problem.goal)})
        driven = None if report is None else report.driven
        if solution is not None:
            if driven is not None and not report.stops and len(driven) == len(solution.value):
                # a drive that never stopped followed its plan cell by cell: the plan's
                # metres and headings are the drive's, without converting the plan's list
                plan = driven
            else:
                plan = np.asarray(solution.value)
            points = in_metres(grid, plan)
            yaws = headings(points)
            recorder.path("/plan", points, yaws)
        if report is None:
            return
        if driven is not plan:
            points = in_metres(grid, driven)
            yaws = headings(points)
        times, stopped = _drive_times(driven, report.stops, collision_time)
        for i in _moments(driven, stopped).tolist():
            recorder.at(float(times[i]))
            x, y = points[i].tolist()
            recorder.pose("/robot/pose", x, y, float(yaws[i]))
            recorder.transform(x, y, float(yaws[i]))
        recorder.path("/driven", points, yaws)
        # drawn when the robot met something, and cleared on the next trip
        if report.met or self._met_shown:
            items: list[Marker | Clear] = [Clear()]
            if report.met:
                items.append(cells_marker(grid, "met", np.array(report.met), RED, height=0.5))
            recorder.markers("/obstacles", items)
            self._met_shown = bool(report.met)


def _moments(driven: np.ndarray, stopped: np.ndarray) -> np.ndarray:
    """The indices of ``driven`` where the robot's pose is recorded: the start, each stop
    and the end. Between two of them it follows its plan of the moment (``/driven`` draws
    it), so poses there would add messages but no news."""
    return np.unique(np.concatenate(([0, len(driven) - 1], stopped)).astype(np.int64))


def _drive_times(driven: np.ndarray, stops: tuple[tuple[int, int], ...],
                 collision_time: float) -> tuple[np.ndarray, np.ndarray]:
    """The time the robot is on each cell of ``driven`` (a second per straight step, √2 per
    diagonal one, and ``collision_time`` more after each stop) and the indices of the stops
    (each stop, in order, at the next visit of its cell)."""
    steps = np.abs(np.diff(driven, axis=0)).sum(axis=1)
    lengths = np.where(steps == 2, math.sqrt(2.0), 1.0)
    times = np.concatenate(([0.0], np.cumsum(lengths)))
    at = 0
    stopped = []
    for stop in stops:
        hits = np.flatnonzero((driven[at:] == stop).all(axis=1))
        if not len(hits):
            break
        at += int(hits[0])
        stopped.append(at)
        times[at + 1:] += collision_time
    return times, np.array(stopped, dtype=np.int64)
