"""The grid world family: grids with per-cell risk, distances, path costs, Moving AI maps."""

from __future__ import annotations

from pathlib import Path

import attrs

from cbr_grid.grid import Grid
from cbr_grid.movingai import load_map
from cbrcore.context import Context
from cbrcore.hookspecs import hookimpl
from cbrcore.options import option
from cbrcore.registry import Registry


@attrs.frozen
class MovingAIOptions:
    map: Path = option(doc="The Moving AI .map file (relative to the configuration file).")
    corner_cutting: bool = option(
        False, "Let a diagonal step pass one blocked orthogonal cell (the benchmarks' optimal "
        "lengths assume false).")


def movingai_world(options: MovingAIOptions, ctx: Context) -> Grid:
    """A grid read from a Moving AI .map file: passable . G S, blocked @ O T W.

    Passable cells have risk 0 and blocked cells risk 1; moves are 8-connected with steps of
    length 1 and sqrt(2), and by default a diagonal step never cuts a blocked corner.
    """
    return load_map(options.map, corner_cutting=options.corner_cutting)


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("world", "movingai", movingai_world, options=MovingAIOptions)
