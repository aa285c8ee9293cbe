"""The grid world family: grids with per-cell risk, distances, path costs, Moving AI and ROS
maps, inflation by a robot's radius, the simulated robot of the ``trips`` workload and the map
learning of the ``risk_map`` retainer."""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl
from cbrcore.lazy import lazy_exports

if TYPE_CHECKING:
    from cbr_grid.formats import load_grid
    from cbr_grid.frame import MapFrame
    from cbr_grid.grid import Grid
    from cbr_grid.inflation import Inflation, inflate
    from cbr_grid.movingai import load_map
    from cbr_grid.query import Cell, GridQuery
    from cbrcore.casebase.store import CaseStore
    from cbrcore.context import Context
    from cbrcore.fingerprint import WorldFingerprint
    from cbrcore.registry import Registry

__all__ = ["Cell", "Grid", "GridQuery", "Inflation", "MapFrame", "inflate", "load_grid",
           "load_map"]

_EXPORTS = {"Cell": "cbr_grid.query", "Grid": "cbr_grid.grid", "GridQuery": "cbr_grid.query",
            "Inflation": "cbr_grid.inflation", "MapFrame": "cbr_grid.frame",
            "inflate": "cbr_grid.inflation", "load_grid": "cbr_grid.formats",
            "load_map": "cbr_grid.movingai",
            **dict.fromkeys(["MovingAIOptions", "movingai_world", "MapFileOptions",
                             "FrameOptions", "map_file_world", "GeneratedOptions",
                             "generated_world"], "cbr_grid.worlds")}
"""Where each name this package exports is defined: imported when first asked for, so that
loading the plugin (every start of ``cbr``) does not import NumPy and the map formats."""


__getattr__ = lazy_exports("cbr_grid", _EXPORTS, globals())


EXTENSIONS = (".map", ".yaml", ".yml", ".png", ".npy", ".grid")
"""The file extensions :func:`cbr_grid.formats.load_grid` knows."""

_WORLDS = "cbr_grid.worlds"


@hookimpl
def cbr_register(registry: Registry) -> None:
    # named, not imported: the grid and NumPy load when a configuration uses a component
    registry.add("world", "movingai", f"{_WORLDS}:movingai_world",
                 options=f"{_WORLDS}:MovingAIOptions")
    registry.add("world", "map_file", f"{_WORLDS}:map_file_world",
                 options=f"{_WORLDS}:MapFileOptions")
    registry.add("world", "generated", f"{_WORLDS}:generated_world",
                 options=f"{_WORLDS}:GeneratedOptions")
    registry.add("workload", "trips", "cbr_grid.trips:Trips", options="cbr_grid.trips:TripsOptions")
    registry.add("retainer", "risk_map", "cbr_grid.risk:RiskMap",
                 options="cbr_grid.risk:RiskOptions")


@hookimpl
def cbr_check_casebase(casebase: CaseStore) -> list[str]:
    """The invariants of the risks the ``risk_map`` retainer learned
    (:func:`cbr_grid.risk.risk_problems`)."""
    from cbr_grid.risk import risk_problems

    return risk_problems(casebase)


@hookimpl
def cbr_world_fingerprint(world: object) -> WorldFingerprint | None:
    """A :class:`Grid`'s fingerprint is its map's (:func:`cbr_grid.grid.grid_fingerprint`)."""
    from cbr_grid.grid import Grid, grid_fingerprint

    return grid_fingerprint(world) if isinstance(world, Grid) else None


@hookimpl
def cbr_world_object(obj: object, ctx: Context) -> Grid | None:
    """A :class:`Grid` given as ``Engine(world=...)`` is the world as it is; a NumPy array is
    read by :meth:`Grid.from_array` (booleans: True an obstacle; floats: risk in [0, 1]; int8:
    a ROS occupancy grid's -1 and 0 to 100; other integer dtypes are refused, as a map of 0
    and 1 would read as 0 % and 1 % occupied)."""
    import numpy as np

    from cbr_grid.grid import Grid

    if isinstance(obj, Grid):
        return obj
    if isinstance(obj, np.ndarray):
        return Grid.from_array(obj)
    return None
