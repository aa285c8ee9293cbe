"""Pictures of the 2D world and of trials: the world at a time, a trial's trajectory coloured by
time, and a GIF of a trial with its doors and people moving.

matplotlib is imported inside the functions, with the Agg canvas attached to each figure, so
that importing the package stays cheap and no window or global pyplot state is ever involved.
The pieces the trial pictures are made of are public for other pictures of the world (RUPART's
day, :mod:`cbr_behaviors.dayplot`): a figure sized to the world (:func:`world_figure`), what
does not change (:func:`draw_static`), the doors and people at a time (:func:`draw_moving`, or
:class:`WorldMotion` for an animation) and the GIF writer (:func:`gif_frame`,
:func:`gif_palette`, :func:`write_gif`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from cbr_world2d.simulation import TrialResult
from cbr_world2d.world import World
from cbrcore import files
from cbrcore.errors import CbrError

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

_WALL = "black"
_LINEAR = "saddlebrown"
_POLYGON = "0.55"
_POINT = "0.35"
_LANDMARK = "tab:blue"
_DOOR_SHUT = "tab:red"
_DOOR_OPEN = "tab:green"
_MOVER = "tab:orange"
_PLACE = "tab:purple"
_ROBOT = "tab:cyan"
_TARGET = "gold"

_MIN_INCHES, _MAX_INCHES = 4.0, 9.0


def world_figure(world: World, extra_width: float = 0.0) -> Figure:
    """A figure with an Agg canvas, sized to the world's aspect; ``extra_width`` inches more
    for a colorbar or a legend beside the world."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    xmin, ymin, xmax, ymax = world.bounds
    width, height = xmax - xmin, ymax - ymin
    longest = max(width, height)
    inches = min(max(longest * 0.4, _MIN_INCHES), _MAX_INCHES)
    figure = Figure(figsize=(inches * width / longest + 1.0 + extra_width,
                             inches * height / longest + 0.8))
    FigureCanvasAgg(figure)
    return figure


def save_figure(figure: Figure, path: Path, **kwargs: Any) -> None:
    """``figure.savefig(path, **kwargs)``; a file that cannot be written is a CbrError naming
    it."""
    try:
        figure.savefig(path, **kwargs)
    except (OSError, ValueError) as exc:
        raise CbrError(f"{path}: cannot write the picture: {exc}") from exc


def door_rows(world: World, t: float) -> tuple[np.ndarray, np.ndarray]:
    """The door segments ``(n, 2, 2)`` shut and open at time ``t``."""
    rows = world.door_segments.reshape(-1, 2, 2)
    shut = np.array([not door.is_open(t) for door in world.doors], dtype=bool)
    return rows[shut], rows[~shut]


def mover_centres(world: World, t: float,
                  clocks: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The movers' centres ``(m, 2)`` at time ``t`` and whether each is present ``(m,)``;
    ``clocks`` are the movers' own clocks then when some yielded to a robot (None: ``t``)."""
    if clocks is None:
        clocks = np.full(len(world.movers), t)
    centres = np.array([mover.position(float(clock)) for mover, clock
                        in zip(world.movers, clocks, strict=True)], dtype=float).reshape(-1, 2)
    present = np.array([mover.present(t) for mover in world.movers], dtype=bool)
    return centres, present


def draw_world(ax: Axes, world: World, t: float = 0.0, *, labels: bool = True) -> None:
    """Draw ``world`` as it is at time ``t`` into ``ax``.

    Walls black, linear obstacles between landmarks brown, polygons and point obstacles grey,
    landmarks blue with their ids, doors red when shut and dashed green when open, movers
    (present at ``t``) orange, named places purple. ``labels`` writes landmark ids and place
    names.
    """
    draw_static(ax, world, labels=labels)
    draw_moving(ax, world, t)


def draw_moving(ax: Axes, world: World, t: float) -> None:
    """Draw the doors and movers of ``world`` as they are at time ``t`` into ``ax``."""
    from matplotlib.collections import LineCollection, PatchCollection
    from matplotlib.patches import Circle

    if world.doors:
        shut, opened = door_rows(world, t)
        ax.add_collection(LineCollection(list(shut), colors=_DOOR_SHUT, linewidths=3.0,
                                         label="doors (shut)"))
        ax.add_collection(LineCollection(list(opened), colors=_DOOR_OPEN, linewidths=1.5,
                                         linestyles="dashed", label="doors (open)"))
    if world.movers:
        centres, present = mover_centres(world, t)
        radii = [mover.radius for mover in world.movers]
        ax.add_collection(PatchCollection(
            [Circle(c, r) for c, r, p in zip(centres, radii, present, strict=True) if p],
            facecolor=_MOVER, edgecolor="none", alpha=0.8))


def draw_static(ax: Axes, world: World, *, labels: bool = True) -> None:
    """Draw everything of ``world`` that does not change with time into ``ax`` (all of
    :func:`draw_world` but the doors and movers) and set the axes' frame to the world."""
    from matplotlib.collections import LineCollection, PatchCollection
    from matplotlib.patches import Circle, Polygon, Rectangle

    xmin, ymin, xmax, ymax = world.bounds
    ax.add_patch(Rectangle((xmin, ymin), xmax - xmin, ymax - ymin, fill=False,
                           edgecolor=_WALL, linewidth=2.0))
    plain = [(w.a, w.b) for w in world.walls if w.between is None]
    linear = [(w.a, w.b) for w in world.walls if w.between is not None]
    if plain:
        ax.add_collection(LineCollection(plain, colors=_WALL, linewidths=1.5, label="walls"))
    if linear:
        ax.add_collection(LineCollection(linear, colors=_LINEAR, linewidths=2.5,
                                         label="linear obstacles"))
    if world.polygons:
        ax.add_collection(PatchCollection([Polygon(p, closed=True) for p in world.polygons],
                                          facecolor=_POLYGON, edgecolor=_WALL, linewidth=0.8))
    if world.points:
        ax.add_collection(PatchCollection([Circle((x, y), r) for x, y, r in world.points],
                                          facecolor=_POINT, edgecolor="none"))
    if world.landmarks:
        ax.add_collection(PatchCollection(
            [Circle((m.x, m.y), m.radius) for m in world.landmarks],
            facecolor=_LANDMARK, edgecolor="navy", linewidth=0.8, alpha=0.85))
        if labels:
            for mark in world.landmarks:
                ax.annotate(mark.id, (mark.x, mark.y), xytext=(0, 6),
                            textcoords="offset points", ha="center", va="bottom", fontsize=7,
                            color="navy")
    if world.places:
        names = sorted(world.places)
        spots = np.array([world.places[n] for n in names], dtype=float)
        ax.scatter(spots[:, 0], spots[:, 1], marker="+", color=_PLACE, s=30, zorder=3)
        if labels:
            for name, (x, y) in zip(names, spots, strict=True):
                ax.annotate(name, (x, y), xytext=(3, -9), textcoords="offset points",
                            fontsize=6, color=_PLACE)
    width, height = xmax - xmin, ymax - ymin
    margin = 0.02 * max(width, height)
    ax.set_xlim(xmin - margin, xmax + margin)
    ax.set_ylim(ymin - margin, ymax + margin)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def plot_world(world: World, path: Path, t: float = 0.0) -> None:
    """Draw ``world`` at time ``t`` into the picture file ``path`` (the format by its
    extension)."""
    figure = world_figure(world)
    ax = figure.add_subplot()
    draw_world(ax, world, t)
    ax.set_title(world.name or "world", fontsize=10)
    figure.tight_layout()
    save_figure(figure, path, dpi=120)


def _title(result: TrialResult) -> str:
    verdict = "reached" if result.success else result.reason
    return (f"{verdict} in {result.time:.1f} s, {result.distance:.2f} m, "
            f"{result.collisions} collision{'s' * (result.collisions != 1)}")


def draw_trial(ax: Axes, world: World, result: TrialResult) -> Any:
    """Draw ``world`` (at the trial's start) and the trial over it into ``ax``; returns the
    trajectory's collection, whose colours map the time (for a colorbar)."""
    from matplotlib.collections import LineCollection

    draw_world(ax, world, 0.0)
    path = result.trajectory
    points = path[:, 1:3]
    lines = LineCollection(np.stack([points[:-1], points[1:]], axis=1), cmap="viridis",
                           linewidths=2.0, zorder=4)
    lines.set_array(path[1:, 0])
    if path.shape[0] > 1:
        lines.set_clim(0.0, max(float(path[-1, 0]), 1e-9))
    ax.add_collection(lines)
    start, target = result.trial.start, result.trial.target
    ax.plot(start.x, start.y, "o", color="tab:green", markersize=8, zorder=5, label="start")
    reach = 0.6 * max(world.bounds[2] - world.bounds[0], world.bounds[3] - world.bounds[1])
    ax.annotate("", xy=(start.x + 0.04 * reach * math.cos(start.theta),
                        start.y + 0.04 * reach * math.sin(start.theta)),
                xytext=(start.x, start.y), arrowprops={"arrowstyle": "->", "color": "tab:green"},
                zorder=5)
    ax.plot(*target, "*", color=_TARGET, markeredgecolor="black", markersize=16, zorder=6,
            label="target")
    diverting = np.array(result.diverting, dtype=float).reshape(-1, 2)
    if diverting.shape[0]:
        ax.plot(diverting[:, 0], diverting[:, 1], "D", color="tab:pink",
                markeredgecolor="black", markersize=7, zorder=6, label="diverting targets")
    hits = np.array([(e.x, e.y) for e in result.events if e.name == "collision"],
                    dtype=float).reshape(-1, 2)
    if hits.shape[0]:
        ax.plot(hits[:, 0], hits[:, 1], "x", color="red", markersize=8, markeredgewidth=2,
                zorder=7, label="collisions")
    stuck = np.array([(e.x, e.y) for e in result.stuck], dtype=float).reshape(-1, 2)
    if stuck.shape[0]:
        ax.plot(stuck[:, 0], stuck[:, 1], "o", markerfacecolor="none", color="tab:red",
                markersize=10, zorder=6, label="blocked / oscillating")
    ax.legend(loc="upper left", fontsize=7, framealpha=0.8)
    return lines


def plot_trial(world: World, result: TrialResult, path: Path) -> None:
    """Draw ``world`` and the trial ``result`` into the picture file ``path``: the trajectory
    coloured by time with a colorbar, the start, the final target as a star, the diverting
    targets, collisions and where the robot got stuck; the title says how it went."""
    figure = world_figure(world, extra_width=1.2)
    ax = figure.add_subplot()
    lines = draw_trial(ax, world, result)
    figure.colorbar(lines, ax=ax, label="time (s)", fraction=0.046, pad=0.04)
    ax.set_title(f"{world.name + ': ' if world.name else ''}{_title(result)}", fontsize=10)
    figure.tight_layout()
    save_figure(figure, path, dpi=120)


def animate_trial(world: World, result: TrialResult, path: Path, fps: int = 10,
                  max_frames: int = 150, dpi: int = 80) -> int:
    """Write a GIF of the trial ``result`` to ``path``: the robot's disc and heading driving
    its trajectory, the trail behind it, doors opening and shutting and people walking.

    At most ``max_frames`` frames, evenly spaced in time over the trial, played at ``fps``
    frames a second; returns the number of frames drawn (Pillow stores two identical frames
    in a row as one, which only happens when the robot, the world and the clock shown to a
    tenth of a second all stand still between them).

    The frames are what :class:`matplotlib.animation.PillowWriter` would write, but blitted:
    the world, axes and labels are drawn once and each frame redraws only the moving artists
    over that background, some twenty times faster than redrawing the whole figure per frame.
    """
    from matplotlib.patches import Circle

    if fps < 1 or max_frames < 1:
        raise ValueError(f"fps and max_frames must be at least 1, not {fps} and {max_frames}")
    trajectory, clocks = result.trajectory, result.mover_clocks
    count = min(max_frames, trajectory.shape[0])
    rows = np.unique(np.linspace(0, trajectory.shape[0] - 1, count).round().astype(int))
    radius = result.spec.radius

    figure = world_figure(world)
    figure.set_dpi(dpi)
    ax = figure.add_subplot()
    # doors and movers are drawn with the robot, per frame
    draw_static(ax, world, labels=True)
    ax.plot(*result.trial.target, "*", color=_TARGET, markeredgecolor="black", markersize=16,
            zorder=6)
    for point in result.diverting:
        ax.plot(*point, "D", color="tab:pink", markeredgecolor="black", markersize=7, zorder=6)
    trail, = ax.plot([], [], color="tab:blue", linewidth=1.5, zorder=4)
    motion = WorldMotion(ax, world)
    body = Circle((trajectory[0, 1], trajectory[0, 2]), radius, facecolor=_ROBOT,
                  edgecolor="black", zorder=7)
    ax.add_patch(body)
    heading, = ax.plot([], [], color="black", linewidth=1.5, zorder=8)
    title = ax.set_title("t = 0.0 s", fontsize=10)
    figure.tight_layout()
    moving = [trail, *motion.artists, body, heading, title]
    for artist in moving:
        artist.set_animated(True)
    canvas = figure.canvas
    canvas.draw()
    background = canvas.copy_from_bbox(figure.bbox)

    frames = []
    for i in rows:
        t, x, y, theta = trajectory[i, :4]
        trail.set_data(trajectory[:i + 1, 1], trajectory[:i + 1, 2])
        body.center = (x, y)
        heading.set_data([x, x + radius * math.cos(theta)], [y, y + radius * math.sin(theta)])
        motion.at(float(t), None if clocks is None else clocks[i])
        title.set_text(f"t = {t:.1f} s")
        canvas.restore_region(background)
        for artist in moving:
            ax.draw_artist(artist)
        frames.append(gif_frame(figure))
    write_gif(frames, path, fps)
    return len(frames)


class WorldMotion:
    """The doors and people of a world as animated artists of ``ax``, set to a time with
    :meth:`at`: an animation draws the rest of the world once (:func:`draw_static`) and
    redraws :attr:`artists` per frame, doors red when shut and dashed green when open, people
    orange while present, as :func:`draw_moving` draws them."""

    def __init__(self, ax: Axes, world: World) -> None:
        from matplotlib.collections import LineCollection
        from matplotlib.patches import Circle

        self.world = world
        self.shut = LineCollection([], colors=_DOOR_SHUT, linewidths=3.0, zorder=3)
        self.opened = LineCollection([], colors=_DOOR_OPEN, linewidths=1.5,
                                     linestyles="dashed", zorder=3)
        ax.add_collection(self.shut)
        ax.add_collection(self.opened)
        self.people = [Circle((0.0, 0.0), mover.radius, facecolor=_MOVER, edgecolor="none",
                              alpha=0.8, zorder=6) for mover in world.movers]
        for person in self.people:
            ax.add_patch(person)
        self.artists: list[Any] = [self.shut, self.opened, *self.people]
        """The artists to mark animated and redraw per frame, in their drawing order."""

    def at(self, t: float, clocks: np.ndarray | None = None) -> None:
        """Move the doors and people to time ``t``, the people to their own ``clocks`` when
        some yielded to a robot (:func:`mover_centres`)."""
        world = self.world
        if world.doors:
            now_shut, now_open = door_rows(world, t)
            self.shut.set_segments(list(now_shut))
            self.opened.set_segments(list(now_open))
        if self.people:
            centres, present = mover_centres(world, t, clocks)
            for person, centre, here in zip(self.people, centres, present, strict=True):
                person.center = (centre[0], centre[1])
                person.set_visible(bool(here))


def gif_frame(figure: Figure, palette: Any = None) -> Any:
    """What ``figure``'s Agg canvas holds now as a palette image (a PIL ``Image``) for
    :func:`write_gif`: in its own 256 colours, or mapped to the colours of ``palette`` (from
    :func:`gif_palette`), without dithering."""
    from PIL import Image

    frame = Image.fromarray(np.asarray(figure.canvas.buffer_rgba())).convert("RGB")
    if palette is not None:
        return frame.quantize(palette=palette, dither=Image.Dither.NONE)
    # a GIF holds palette images; the fast octree palette is five times quicker than
    # Pillow's default median cut, which would take most of the time otherwise
    return frame.quantize(256, method=Image.Quantize.FASTOCTREE)


def gif_palette(figure: Figure, colours: Sequence[Any] = ()) -> Any:
    """One palette for every frame of an animation: the 256 colours that best render what
    ``figure``'s canvas holds now, the world's colours (doors shut and open, people, the
    robot) and ``colours`` (any matplotlib colours), which may appear only later.

    Frames in their own palettes (:func:`gif_frame` without one) differ in nearly every
    pixel's index even where nothing moved, so the GIF stores each frame whole; frames in one
    palette differ only where something moved, and a long animation's file is several times
    smaller.
    """
    from matplotlib.colors import to_rgb
    from PIL import Image

    frame = np.asarray(figure.canvas.buffer_rgba())[:, :, :3]
    # people are drawn at 0.8 opacity, mostly over the white floor
    person = 0.2 + 0.8 * np.array(to_rgb(_MOVER))
    swatches = [to_rgb(c) for c in (_DOOR_SHUT, _DOOR_OPEN, person, _ROBOT, _TARGET, *colours)]
    # each colour a block of the strip beneath the frame, large enough to get a palette entry
    block = 12
    strip = np.full((block, max(frame.shape[1], block * len(swatches)), 3), 255, dtype=np.uint8)
    for i, colour in enumerate(swatches):
        strip[:, i * block:(i + 1) * block] = np.round(np.array(colour) * 255)
    width = strip.shape[1]
    padded = np.full((frame.shape[0], width, 3), 255, dtype=np.uint8)
    padded[:, :frame.shape[1]] = frame
    return Image.fromarray(np.concatenate([padded, strip])).quantize(256)


def write_gif(frames: Iterable[Any], path: Path, fps: int) -> None:
    """Write the :func:`gif_frame` images ``frames`` (at least one) to ``path`` as a looping
    GIF of ``fps`` frames a second, replacing the file whole or not at all; a file that
    cannot be written is a CbrError naming it. ``frames`` may be a generator, drawn as it is
    written, so that only the GIF writer holds the frames."""
    frames = iter(frames)
    first = next(frames)
    try:
        with files.replacing(path, "wb") as handle:
            first.save(handle, format="GIF", save_all=True, append_images=frames,
                       duration=round(1000 / fps), loop=0)
    except OSError as exc:
        raise CbrError(f"{path}: cannot write the animation: {exc}") from exc
