"""Pictures of a delivery day (:class:`~cbr_behaviors.daylog.DayLog`): where the robot drove
and under which case, when it retrieved and why, how fast it went, and a GIF of the day.

Every picture colours a case the same way (:func:`case_colours`), so the floor plan, the
timeline and the animation can be read side by side. A day installs dozens of cases (adapted
ones get names of their own), more than colours can tell apart: the :data:`SHOWN_CASES`
installed longest get a colour and a legend entry each, the others share one grey.

The world is drawn with the pieces of :mod:`cbr_world2d.plot`; matplotlib is imported inside
the functions, each figure with its own Agg canvas, as there.
"""

from __future__ import annotations

import itertools
import math
import sys
import zlib
from collections import Counter
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cbr_behaviors.daylog import GOAL_EVENTS, DayLog, Track
from cbr_world2d.plot import (
    WorldMotion,
    draw_static,
    gif_frame,
    gif_palette,
    save_figure,
    world_figure,
    write_gif,
)
from cbr_world2d.robot import PIONEER_2DX
from cbr_world2d.world import World

if TYPE_CHECKING:
    from matplotlib.axes import Axes

NO_CASE = "0.3"
"""The colour of the steps under no named case (the name ``""``)."""
OTHER_CASES = "0.72"
"""The colour the cases past the :data:`SHOWN_CASES` longest installed share."""
SHOWN_CASES = 14
"""How many cases, those installed longest, get a colour of their own."""
DOORS = "0.45"
"""The doors in the day's picture, where they are open at some times and shut at others."""
MARKERS: dict[str, dict[str, Any]] = {
    "message": {"marker": "s", "color": "tab:purple", "markerfacecolor": "none"},
    "delivered": {"marker": "o", "color": "tab:green"},
    "missed": {"marker": "X", "color": "tab:red"},
    "unfinished": {"marker": "s", "color": "tab:orange"},
    "impasse": {"marker": "D", "color": "magenta"},
    "collision": {"marker": "x", "color": "red", "markeredgewidth": 2},
    "stall": {"marker": "o", "color": "black", "markerfacecolor": "none"},
}
"""How each event kind is marked, in every picture."""
INCIDENTS = ("impasse", "collision", "stall")
"""The events that happen to the robot (the others are about messages)."""
_PALETTE_SIZE = 20


def case_colours(ranked: Sequence[str], shown: int = SHOWN_CASES) -> dict[str, Any]:
    """A colour for each case name of ``ranked``, most important first: the first ``shown``
    names a colour each of matplotlib's ``tab20`` (its greys left out), the others
    :data:`OTHER_CASES`; the name ``""`` (no case) is :data:`NO_CASE`.

    A name's colour is picked by a CRC-32 of the name (Python's ``hash`` of a string changes
    with every process), so a case keeps its colour from picture to picture and from day to
    day; when two of the names shown pick the same colour, the later one in sorted order
    takes the next free one.
    """
    from matplotlib import colormaps

    palette = [c for i, c in enumerate(colormaps["tab20"].colors) if i not in (14, 15)]
    named = [name for name in dict.fromkeys(ranked) if name]
    colours: dict[str, Any] = dict.fromkeys(named[shown:], OTHER_CASES)
    taken: set[int] = set()
    for name in sorted(named[:shown]):
        slot = zlib.crc32(name.encode()) % len(palette)
        free = next((k % len(palette) for k in range(slot, slot + len(palette))
                     if k % len(palette) not in taken), slot)
        taken.add(free)
        colours[name] = palette[free]
    if "" in ranked:
        colours[""] = NO_CASE
    return colours


def case_label(name: str) -> str:
    """How a case is named in a legend or a title."""
    return name or "(no case)"


class _Cases:
    """The cases of a day as the pictures show them: ranked by how long each was installed,
    a colour each (:func:`case_colours`), and legend entries for those shown."""

    def __init__(self, log: DayLog, track: Track) -> None:
        from matplotlib.colors import to_rgba_array

        steps = np.bincount(track.case, minlength=len(log.cases))
        share = steps / max(len(track), 1)
        # sorted is stable: cases installed equally long keep the order they were first seen
        ranked = sorted(range(len(log.cases)), key=lambda i: -steps[i])
        installed = [i for i in ranked if steps[i]]
        colours = case_colours([log.cases[i] for i in installed], SHOWN_CASES)
        self.rgba = to_rgba_array([colours.get(name, OTHER_CASES) for name in log.cases]
                                  ).reshape(-1, 4)
        """The RGBA colour of each case of ``log.cases``, ``(k, 4)``, to index by a step's."""
        self.entries = [(self.rgba[i], f"{case_label(log.cases[i])} ({share[i]:.0%})")
                        for i in installed[:SHOWN_CASES]]
        """Legend entries: a colour and a label with the share of the day, longest first."""
        others = installed[SHOWN_CASES:]
        if others:
            self.entries.append((OTHER_CASES, f"{len(others)} other cases "
                                              f"({sum(share[i] for i in others):.0%})"))


def _place(world: World, text: str, x: float, y: float) -> tuple[float, float]:
    """Where a message's event is marked: its place, or where it was recorded."""
    spot = world.places.get(text)
    return (float(spot[0]), float(spot[1])) if spot is not None else (x, y)


def _title(log: DayLog) -> str:
    counts = ", ".join(f"{log.count(kind)} {kind}" for kind in GOAL_EVENTS[1:])
    incidents = ", ".join(f"{log.count(kind)} {kind}{'s' * (log.count(kind) != 1)}"
                          for kind in INCIDENTS)
    return (f"day {log.day}: {log.count('message')} messages, {counts}\n{incidents}, "
            f"{len(log.retrievals)} retrievals")


def _marker(kind: str, **extra: Any) -> dict[str, Any]:
    return {"linestyle": "none", "markersize": 8, **MARKERS[kind], **extra}


def _incident(kind: str) -> dict[str, Any]:
    """An incident's mark on the floor: a day may have a hundred impasses, so small and
    translucent, the path showing through."""
    return _marker(kind, markersize=5, alpha=0.6)


def plot_day(world: World, log: DayLog, path: Path) -> None:
    """Draw the day over its floor into the picture file ``path``: the trajectory coloured
    by the installed case (the legend names each with its share of the day), the places of
    the messages marked delivered, missed or unfinished (a count beside a mark for more than
    one), and where the robot met an impasse, a collision or a stall."""
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    track = log.track()
    figure = world_figure(world, extra_width=2.2)
    ax = figure.add_subplot()
    draw_static(ax, world, labels=True)
    handles: list[Any] = []
    if world.doors:
        ax.add_collection(LineCollection(list(world.door_segments.reshape(-1, 2, 2)),
                                         colors=DOORS, linewidths=2.0, linestyles="dotted",
                                         zorder=3))
        handles.append(Line2D([], [], color=DOORS, linewidth=2.0, linestyle="dotted",
                              label="doors (on schedules)"))
    cases = _Cases(log, track)
    if len(track) > 1:
        points = np.column_stack([track.x, track.y])
        ax.add_collection(LineCollection(np.stack([points[:-1], points[1:]], axis=1),
                                         colors=cases.rgba[track.case[:-1]], linewidths=2.0,
                                         zorder=4))
    handles += [Line2D([], [], color=colour, linewidth=3.0, label=label)
                for colour, label in cases.entries]
    if len(track):
        ax.plot(track.x[0], track.y[0], "^", color="tab:cyan", markeredgecolor="black",
                markersize=9, zorder=6)
        handles.append(Line2D([], [], linestyle="none", marker="^", color="tab:cyan",
                              markeredgecolor="black", markersize=9, label="start"))
    # a place may have several messages a day: one mark per outcome, beside each other
    reach = max(world.bounds[2] - world.bounds[0], world.bounds[3] - world.bounds[1])
    shift = {"delivered": (-0.015 * reach, 0.0), "missed": (0.015 * reach, 0.0),
             "unfinished": (0.0, -0.015 * reach)}
    outcomes = Counter((kind, _place(world, e.text, e.x, e.y))
                       for e in log.events if (kind := e.kind) in shift)
    for kind in shift:
        spots = [(spot, n) for (k, spot), n in outcomes.items() if k == kind]
        if not spots:
            continue
        dx, dy = shift[kind]
        xs = [x + dx for (x, _), _ in spots]
        ys = [y + dy for (_, y), _ in spots]
        ax.plot(xs, ys, **_marker(kind, markeredgecolor="black"), zorder=7)
        for x, y, (_, n) in zip(xs, ys, spots, strict=True):
            if n > 1:
                ax.annotate(f"{n}", (x, y), xytext=(4, 4), textcoords="offset points",
                            fontsize=7, fontweight="bold")
        handles.append(Line2D([], [], **_marker(kind, markeredgecolor="black"),
                              label=f"message {kind}"))
    for kind in INCIDENTS:
        where = np.array([(e.x, e.y) for e in log.events if e.kind == kind],
                         dtype=float).reshape(-1, 2)
        if where.shape[0]:
            ax.plot(where[:, 0], where[:, 1], **_incident(kind), zorder=8)
            handles.append(Line2D([], [], **_marker(kind), label=f"{kind} ({where.shape[0]})"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7,
              framealpha=0.9, borderaxespad=0.0)
    ax.set_title(f"{world.name + ', ' if world.name else ''}{_title(log)}", fontsize=9)
    figure.tight_layout()
    save_figure(figure, path, dpi=120)


def _runs(values: np.ndarray) -> list[tuple[int, int]]:
    """The runs of equal values as ``(first, past)`` index pairs."""
    if values.shape[0] == 0:
        return []
    starts = np.flatnonzero(np.diff(values)) + 1
    edges = [0, *starts.tolist(), int(values.shape[0])]
    return list(itertools.pairwise(edges))


def _case_band(ax: Axes, log: DayLog, track: Track, end: float) -> None:
    """The installed case over time: a bar per stretch, coloured by case."""
    from matplotlib.patches import Patch

    cases = _Cases(log, track)
    colours = cases.rgba
    spans: dict[int, list[tuple[float, float]]] = {}
    for first, past in _runs(track.case):
        stop = float(track.t[past]) if past < len(track) else end
        start = float(track.t[first])
        spans.setdefault(int(track.case[first]), []).append((start, stop - start))
    for index, bars in spans.items():
        ax.broken_barh(bars, (0.0, 1.0), facecolors=colours[index])
    ax.set_yticks([])
    ax.set_ylim(0.0, 1.0)
    ax.set_ylabel("case", rotation=0, ha="right", va="center", fontsize=8)
    handles = [Patch(facecolor=colour, label=label) for colour, label in cases.entries]
    if handles:
        # beside the rows below as well: the other rows explain themselves in their labels
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7,
                  title="installed case (share of the day)", title_fontsize=7,
                  borderaxespad=0.0)


def _retrieval_ticks(ax: Axes, log: DayLog) -> None:
    """A tick per retrieval on the row of each trigger that fired it, coloured by the
    trigger; a retrieval whose case was adapted has a hollow diamond on its tick."""
    from matplotlib import colormaps

    names = sorted({name for r in log.retrievals for name in r.triggers})
    palette = colormaps["tab10"].colors
    for row, name in enumerate(names):
        fired = [r for r in log.retrievals if name in r.triggers]
        colour = palette[row % len(palette)]
        ax.plot([r.t for r in fired], [row] * len(fired), linestyle="none", marker="|",
                markersize=10, markeredgewidth=1.5, color=colour)
        adapted = [r.t for r in fired if r.adapted]
        if adapted:
            ax.plot(adapted, [row] * len(adapted), linestyle="none", marker="d",
                    markersize=6, markerfacecolor="none", color=colour)
    ax.set_yticks(range(len(names)), names, fontsize=7)
    ax.set_ylim(-0.7, max(len(names), 1) - 0.3)
    ax.set_ylabel("retrievals\nby trigger\n(\u25c7 adapted)", rotation=0, ha="right",
                  va="center", fontsize=8)
    if not names:
        ax.text(0.5, 0.5, "no retrievals", transform=ax.transAxes, ha="center", va="center",
                fontsize=8, color="0.4")
    untriggered = [r.t for r in log.retrievals if not r.triggers]
    if untriggered:
        ax.plot(untriggered, [-0.5] * len(untriggered), "|", color="0.3")


def _speed(ax: Axes, track: Track) -> None:
    """Speed over time, the stretches without a message goal shaded."""
    ax.plot(track.t, track.v, color="tab:blue", linewidth=0.8)
    for first, past in _runs(track.busy.astype(np.int8)):
        if not track.busy[first]:
            ax.axvspan(float(track.t[first]), float(track.t[past - 1]), color="0.88",
                       zorder=0)
    ax.set_ylabel("speed (m/s)\n(grey: idle,\nno message)", rotation=0, ha="right",
                  va="center", fontsize=8)
    ax.axhline(0.0, color="0.5", linewidth=0.5)


def _events(ax: Axes, log: DayLog) -> None:
    """A row per kind of event, a mark at each one's time."""
    kinds = [*GOAL_EVENTS, *(k for k in INCIDENTS if log.count(k))]
    for row, kind in enumerate(kinds):
        times = [e.t for e in log.events if e.kind == kind]
        if times:
            ax.plot(times, [row] * len(times), **_marker(kind, markersize=6))
    ax.set_yticks(range(len(kinds)), kinds, fontsize=7)
    ax.set_ylim(-0.7, len(kinds) - 0.3)
    ax.invert_yaxis()
    ax.set_ylabel("events", rotation=0, ha="right", va="center", fontsize=8)


def plot_timeline(log: DayLog, path: Path) -> None:
    """Draw the day over one time axis into the picture file ``path``, top to bottom: the
    installed case (coloured as in :func:`plot_day`), the retrievals as ticks on the row of
    each trigger that fired them (hollow for an adapted case), the speed with the idle
    stretches shaded, and the events: messages arriving, delivered, missed and unfinished,
    and the impasses, collisions and stalls."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    track = log.track()
    triggers = len({name for r in log.retrievals for name in r.triggers})
    kinds = len(GOAL_EVENTS) + sum(bool(log.count(k)) for k in INCIDENTS)
    ratios = [0.5, 0.3 + 0.22 * max(triggers, 1), 1.6, 0.3 + 0.2 * kinds]
    figure = Figure(figsize=(12.0, 1.0 + sum(ratios)))
    FigureCanvasAgg(figure)
    case_ax, retrieval_ax, speed_ax, event_ax = figure.subplots(
        4, 1, sharex=True, gridspec_kw={"height_ratios": ratios})
    times = [*track.t.tolist(), *(r.t for r in log.retrievals), *(e.t for e in log.events)]
    start, end = (min(times), max(times)) if times else (0.0, 1.0)
    end = max(end + (float(np.median(np.diff(track.t))) if len(track) > 1 else 0.0),
              start + 1e-3)
    _case_band(case_ax, log, track, end)
    _retrieval_ticks(retrieval_ax, log)
    _speed(speed_ax, track)
    _events(event_ax, log)
    # a little room at both ends, so that a mark at the day's first or last moment shows whole
    event_ax.set_xlim(start - 0.01 * (end - start), end + 0.01 * (end - start))
    event_ax.set_xlabel("time (s)")
    case_ax.set_title(_title(log).replace("\n", "; "), fontsize=9)
    # margins in inches rather than tight_layout, which would open gaps between the rows for
    # the case legend hanging beside them; the figure widens by the legend's width
    legend = case_ax.get_legend()
    margin = 0.25 + (0.0 if legend is None else
                     legend.get_window_extent(figure.canvas.get_renderer()).width / figure.dpi)
    width, height = 10.5 + margin, figure.get_size_inches()[1]
    figure.set_size_inches(width, height)
    figure.subplots_adjust(left=1.3 / width, right=1.0 - margin / width,
                           top=1.0 - 0.45 / height, bottom=0.55 / height, hspace=0.12)
    save_figure(figure, path, dpi=110)


def frame_count(track: Track, fps: int, speedup: float) -> int:
    """How many frames :func:`frame_times` gives, counted without making them."""
    if fps < 1 or not (math.isfinite(speedup) and speedup > 0):
        raise ValueError(f"fps must be at least 1 and speedup a number > 0, not {fps} and "
                         f"{speedup}")
    if len(track) == 0:
        raise ValueError("the day log has no steps to animate")
    frames = (float(track.t[-1]) - float(track.t[0])) / (speedup / fps) + 1e-9
    return math.floor(frames) + 1 if math.isfinite(frames) else sys.maxsize


def frame_times(track: Track, fps: int, speedup: float) -> np.ndarray:
    """The simulated times of an animation's frames: ``speedup / fps`` seconds apart from the
    first step to the last (the last frame at most that much before the last step)."""
    count = frame_count(track, fps, speedup)
    return float(track.t[0]) + speedup / fps * np.arange(count)


def _clock(t: float) -> str:
    minutes, seconds = divmod(t, 60.0)
    return f"{int(minutes):02d}:{seconds:04.1f}"


def animate_day(world: World, log: DayLog, path: Path, fps: int = 10,
                speedup: float = 20.0, *, dpi: int = 80,
                radius: float = PIONEER_2DX.radius) -> int:
    """Write a GIF of the day to ``path``: the robot (a disc of ``radius`` in its case's
    colour, its heading and a dotted line to the point it steers for) driving its trail,
    people walking and doors opening and shutting as at that time, the places with open
    messages, and each delivery, missed deadline and incident marked as it happens; the
    title holds the clock and the installed case.

    ``speedup`` seconds of the day pass in a second of GIF, at ``fps`` frames a second: a
    frame every ``speedup / fps`` simulated seconds (:func:`frame_times`), each showing the
    last step at or before its time; a 30-minute day at the defaults is a 90-second GIF of
    900 frames. Returns the number of frames. The frames are blitted as in
    :func:`cbr_world2d.plot.animate_trial`, and all in one palette
    (:func:`cbr_world2d.plot.gif_palette`), which keeps a day's GIF to a few megabytes.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle

    track = log.track()
    times = frame_times(track, fps, speedup)
    rows = np.clip(np.searchsorted(track.t, times, side="right") - 1, 0, len(track) - 1)
    cases = _Cases(log, track)
    colours = cases.rgba

    figure = world_figure(world, extra_width=2.6)
    figure.set_dpi(dpi)
    ax = figure.add_subplot()
    draw_static(ax, world, labels=True)
    handles = [Line2D([], [], color=colour, linewidth=3.0, label=label)
               for colour, label in cases.entries]
    handles += [Line2D([], [], **_marker(kind), label=label) for kind, label in (
        ("message", "open message"), ("delivered", "delivered"), ("missed", "missed"),
        *((k, k) for k in INCIDENTS if log.count(k)))]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7,
              borderaxespad=0.0)
    trails = _Trails(ax, track, colours)
    motion = WorldMotion(ax, world)
    marks = {kind: ax.plot([], [], **(_marker(kind, markeredgecolor="black")
                                      if kind in GOAL_EVENTS else _incident(kind)),
                           zorder=7)[0]
             for kind in ("message", "delivered", "missed", *INCIDENTS)}
    steer, = ax.plot([], [], linestyle="dotted", color="goldenrod", linewidth=1.2, zorder=6)
    body = Circle((track.x[0], track.y[0]), radius, edgecolor="black", zorder=8)
    ax.add_patch(body)
    heading, = ax.plot([], [], color="black", linewidth=1.5, zorder=9)
    # a title of the longest form, so that the layout leaves room for every frame's
    title = ax.set_title(f"day {log.day}  00:00.0  case: {max(log.cases, key=len, default='')}"
                         "  (idle)", fontsize=9)
    figure.tight_layout()
    moving = [*trails.lines, *motion.artists, steer, *marks.values(), body, heading, title]
    for artist in moving:
        artist.set_animated(True)
    canvas = figure.canvas
    canvas.draw()
    background = canvas.copy_from_bbox(figure.bbox)
    # the trail is drawn at 0.7 opacity over the white floor
    faded = [0.3 + 0.7 * colour[:3] for colour in colours]
    palette = gif_palette(figure, [*colours[:, :3], *faded, "goldenrod", "black",
                                   *(style["color"] for style in MARKERS.values())])
    events = sorted(log.events, key=lambda e: e.t)

    def frames() -> Iterator[Any]:
        for now, i in zip(times.tolist(), rows.tolist(), strict=True):
            x, y, theta = float(track.x[i]), float(track.y[i]), float(track.theta[i])
            trails.until(i)
            body.center = (x, y)
            body.set_facecolor(colours[track.case[i]])
            heading.set_data([x, x + radius * math.cos(theta)],
                             [y, y + radius * math.sin(theta)])
            tx, ty = track.target[i]
            steer.set_data(([x, tx], [y, ty]) if math.isfinite(tx) else ([], []))
            motion.at(now, None if log.clocks is None else log.clocks[i])
            _mark_events(marks, world, [e for e in events if e.t <= now])
            name = case_label(log.cases[track.case[i]])
            title.set_text(f"day {log.day}  {_clock(now)}  case: {name}"
                           f"{'' if track.busy[i] else '  (idle)'}")
            canvas.restore_region(background)
            for artist in moving:
                ax.draw_artist(artist)
            yield gif_frame(figure, palette)

    # drawn while the GIF is written: a day's 900 frames are not held twice
    write_gif(frames(), path, fps)
    return len(times)


class _Trails:
    """The animation's trail: a line per case through the stretches the case was installed,
    each cut at the step shown. One line of a few thousand points per case draws in a
    fraction of the time a collection of a segment per step takes to rebuild every frame."""

    def __init__(self, ax: Axes, track: Track, colours: np.ndarray) -> None:
        pieces: dict[int, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}
        for first, past in _runs(track.case):
            # a stretch's last segment reaches the next stretch's first point; NaN breaks the
            # line before the case's next stretch
            end = min(past + 1, len(track))
            pieces.setdefault(int(track.case[first]), []).append((
                np.append(track.x[first:end], np.nan), np.append(track.y[first:end], np.nan),
                np.append(np.arange(first, end), end)))
        self.parts = [(np.concatenate([p[0] for p in parts]),
                       np.concatenate([p[1] for p in parts]),
                       np.concatenate([p[2] for p in parts])) for parts in pieces.values()]
        self.lines = [ax.plot([], [], color=colours[case], linewidth=1.5, alpha=0.7,
                              zorder=4)[0] for case in pieces]

    def until(self, step: int) -> None:
        """Show the trail up to step ``step``."""
        for line, (xs, ys, steps) in zip(self.lines, self.parts, strict=True):
            shown = int(np.searchsorted(steps, step, side="right"))
            line.set_data(xs[:shown], ys[:shown])


def _mark_events(marks: dict[str, Any], world: World, happened: list[Any]) -> None:
    """Set the animation's marks to the events so far: the places of the messages still open,
    and every delivery, missed deadline and incident."""
    open_places: Counter[tuple[float, float]] = Counter()
    spots: dict[str, list[tuple[float, float]]] = {kind: [] for kind in marks}
    for event in happened:
        if event.kind in GOAL_EVENTS:
            spot = _place(world, event.text, event.x, event.y)
            if event.kind == "message":
                open_places[spot] += 1
            else:
                open_places[spot] -= 1
                if event.kind in spots:
                    spots[event.kind].append(spot)
        elif event.kind in spots:
            spots[event.kind].append((event.x, event.y))
    spots["message"] = [spot for spot, n in open_places.items() if n > 0]
    for kind, mark in marks.items():
        xy = np.array(spots[kind], dtype=float).reshape(-1, 2)
        mark.set_data(xy[:, 0], xy[:, 1])
