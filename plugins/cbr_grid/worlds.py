"""The grid worlds a configuration's ``world`` slot builds: a Moving AI map, a map file of any
supported format, or a generated layout, each optionally inflated by the robot's radius."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Literal

import attrs

from cbr_grid.formats import load_grid
from cbr_grid.frame import MapFrame
from cbr_grid.generate import generate
from cbr_grid.grid import Grid
from cbr_grid.inflation import Inflation, inflate
from cbr_grid.movingai import load_map
from cbrcore.context import Context
from cbrcore.options import option

_INFLATION_DOC = ("Inflate the obstacles by the robot's radius, as Nav2's inflation layer does: "
                  "robot_radius, inflation_radius, cost_scaling_factor (metres on a map with a "
                  "frame, else cells); null inflates nothing.")


def _inflated(grid: Grid, inflation: Inflation | None) -> Grid:
    return grid if inflation is None else inflate(grid, inflation)


@attrs.frozen
class MovingAIOptions:
    map: Path = option(doc="The Moving AI .map file (relative to the configuration file).")
    corner_cutting: bool = option(
        False, "Let a diagonal step pass one blocked orthogonal cell (the benchmarks' optimal "
        "lengths assume false).")
    inflation: Inflation | None = option(None, _INFLATION_DOC)


def movingai_world(options: MovingAIOptions, ctx: Context) -> Grid:
    """A grid read from a Moving AI .map file: passable . G S, blocked @ O T W.

    Passable cells have risk 0 and blocked cells risk 1; moves are 8-connected with steps of
    length 1 and sqrt(2), and by default a diagonal step never cuts a blocked corner.
    """
    grid = load_map(options.map, corner_cutting=options.corner_cutting)
    return _inflated(_named(grid, options.map.name), options.inflation)


def _named(grid: Grid, source: str) -> Grid:
    return attrs.evolve(grid, name=f"{source} ({grid.width}x{grid.height})")


_UNIT = attrs.validators.and_(attrs.validators.ge(0.0), attrs.validators.le(1.0))
_ROS_SUFFIXES = (".yaml", ".yml")


def _positive_metres(_: object, attribute: attrs.Attribute, value: float) -> None:
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"'{attribute.name}' must be a finite number of metres > 0, "
                         f"got {value!r}")


def _finite_pose(_: object, attribute: attrs.Attribute, value: tuple[float, ...]) -> None:
    if not all(math.isfinite(v) for v in value):
        raise ValueError(f"'{attribute.name}' must be three finite numbers [x, y, yaw], "
                         f"got {list(value)!r}")


def _no_frame_for_ros(instance: MapFileOptions, attribute: attrs.Attribute,
                      value: FrameOptions | None) -> None:
    if value is not None and instance.path.suffix.lower() in _ROS_SUFFIXES:
        raise ValueError(f"'{attribute.name}' must be null for a ROS map ({instance.path.name}), "
                         "which carries its own frame (resolution and origin)")


@attrs.frozen
class FrameOptions:
    """Where a map of cells only lies in a metric map frame, written as a ROS map writes it."""

    resolution: float = option(doc="The side of a cell in metres.", validator=_positive_metres)
    origin: tuple[float, float, float] = option(
        (0.0, 0.0, 0.0), "[x, y, yaw]: the pose in the map frame of the map's lower-left "
        "corner (metres, radians), as in a ROS map_server YAML; finite numbers.",
        validator=_finite_pose)

    def frame(self) -> MapFrame:
        x, y, yaw = self.origin
        return MapFrame(self.resolution, x, y, yaw)


@attrs.frozen
class MapFileOptions:
    path: Path = option(doc="The map file (relative to the configuration file): .map (Moving AI), "
                        ".yaml (ROS map_server), .png, .npy (risk array) or .grid (text).")
    corner_cutting: bool = option(
        False, "Let a diagonal step pass one blocked orthogonal cell.")
    allow_unknown: bool = option(
        True, "ROS maps: let the planner cross cells the map leaves unknown, at the highest "
        "cost short of an obstacle (Nav2's planners' option and default); false makes them "
        "obstacles.")
    threshold: float = option(
        0.5, "PNG images: pixels darker than this luminance (0 black, 1 white) are obstacles.",
        validator=_UNIT)
    frame: FrameOptions | None = option(
        None, "Maps of cells only (.map, .png, .npy, .grid): place the map in a metric map "
        "frame, {resolution, origin}, so that inflation radii, trips' places and pictures are "
        "in metres; a ROS map carries its own and takes none.", validator=_no_frame_for_ros)
    inflation: Inflation | None = option(None, _INFLATION_DOC)


def map_file_world(options: MapFileOptions, ctx: Context) -> Grid:
    """A grid read from a .map, .yaml (ROS map_server), .png, .npy or .grid file.

    The extension chooses the loader; the file's top row becomes y = 0 (see cbr_grid.formats).
    A ROS map keeps its metric frame, and ``frame`` gives another map one, so its inflation
    radii are in metres.
    """
    grid = load_grid(options.path, corner_cutting=options.corner_cutting,
                     allow_unknown=options.allow_unknown, threshold=options.threshold,
                     frame=None if options.frame is None else options.frame.frame())
    return _inflated(_named(grid, options.path.name), options.inflation)


@attrs.frozen
class GeneratedOptions:
    kind: Literal["random", "office", "maze"] = option(
        doc="The layout: random obstacles, an office of rooms and corridors, or a perfect maze.")
    width: int = option(64, "Columns (at least 3).", validator=attrs.validators.ge(3))
    height: int = option(64, "Rows (at least 3).", validator=attrs.validators.ge(3))
    density: float = option(0.2, "random: the fraction of cells that are obstacles.",
                            validator=_UNIT)
    terrain: float = option(
        0.0, "The amount of smooth terrain risk added to free cells, in [0, 1); 0 adds none.",
        validator=attrs.validators.and_(attrs.validators.ge(0.0), attrs.validators.lt(1.0)))
    corner_cutting: bool = option(
        False, "Let a diagonal step pass one blocked orthogonal cell.")
    inflation: Inflation | None = option(None, _INFLATION_DOC)


def generated_world(options: GeneratedOptions, ctx: Context) -> Grid:
    """A grid generated from the run's seed: random obstacles, an office or a perfect maze.

    The layout and the optional terrain risk draw from independent streams of ``ctx.seed``, so
    the same seed always gives the same grid (see cbr_grid.generate).
    """
    grid = generate(options.kind, options.width, options.height, ctx.seed,
                    density=options.density, terrain=options.terrain,
                    corner_cutting=options.corner_cutting)
    density = f", density {options.density:g}" if options.kind == "random" else ""
    name = f"{options.kind} {options.width}x{options.height}{density}, seed {ctx.seed}"
    return _inflated(attrs.evolve(grid, name=name), options.inflation)
