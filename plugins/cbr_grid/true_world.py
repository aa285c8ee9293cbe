"""The true world a simulated robot drives on: its map plus the obstacles the map does not show.

The robot's map is the configured grid. The true world adds *unknown obstacles* on cells free in
that map: ``static`` cells that are always blocked, ``dynamic`` cells each blocked during a trip
with one probability, and listed *sites* (a door of one or more cells, a crowded crossing), all
the cells of one site blocked together during a trip with the site's own probability. Which of
them are blocked on a trip is drawn once per trip (:meth:`TrueWorld.draw`), from the generator
the true world is given, so a seed repeats the same worlds.
"""

from __future__ import annotations

from collections.abc import Sequence

import attrs
import numpy as np

from cbr_grid.grid import Grid
from cbr_grid.query import path_array
from cbrcore.errors import CbrError


@attrs.frozen
class Blocked:
    """The unknown obstacles present on one trip: the dynamic cells blocked ((k, 2) cells) and
    the indexes of the listed sites blocked."""

    dynamic: np.ndarray
    sites: tuple[int, ...]


class TrueWorld:
    """The robot's map with its unknown obstacles and sites; see the module docstring.

    ``places`` are cells trips start and end on: no unknown obstacle or site may cover one.
    """

    def __init__(self, grid: Grid, *, appear: float, places: np.ndarray | None = None,
                 what: str = "the true world") -> None:
        self.grid = grid
        self.what = what
        """Who owns the true world, as errors name it."""
        self.appear = appear
        self.places = places
        self.static = np.zeros((0, 2), dtype=np.int64)
        """The (k, 2) cells always blocked."""
        self.dynamic = np.zeros((0, 2), dtype=np.int64)
        """The (k, 2) cells where an obstacle may appear during a trip."""
        self.sites: list[np.ndarray] = []
        """The (k, 2) cells of each listed site, blocked together during a trip."""
        self.site_appear = np.zeros(0, dtype=np.float64)
        """The probability of each listed site to be blocked during one trip."""
        self.unknown = np.zeros(grid.passable.shape, dtype=bool)
        """Cells holding an unknown obstacle or belonging to a site."""
        self._static_passable = grid.passable

    def site_cells(self, sites: Sequence[Sequence[tuple[int, int]]]) -> list[np.ndarray]:
        """The (k, 2) cells of each site; a CbrError naming the site and the cell unless each is
        free in the map."""
        groups = [path_array(cells) for cells in sites]
        for i, cells in enumerate(groups):
            for x, y in cells.tolist():
                self.grid.check_cell((x, y), f"{self.what}: sites[{i}] cell")
        return groups

    def place(self, static: object, dynamic: object,
              sites: Sequence[tuple[Sequence[tuple[int, int]], float]] = ()) -> None:
        """Put the unknown obstacles on the given (x, y) cells, replacing all of them:
        ``static`` always blocked, ``dynamic`` each blocked per trip with probability
        ``appear`` and each of ``sites`` (cells, probability) blocked per trip, all its cells
        together. Every cell must be free in the map, distinct from all the others and no
        place; a refused placement leaves the world as it was."""
        static_cells, dynamic_cells = path_array(static), path_array(dynamic)
        for x, y in np.concatenate((static_cells, dynamic_cells)).tolist():
            self.grid.check_cell((x, y), f"{self.what}: an unknown obstacle")
        site_cells = self.site_cells([cells for cells, _ in sites])
        cells = np.concatenate((static_cells, dynamic_cells, *site_cells))
        unique, counts = np.unique(cells, axis=0, return_counts=True)
        if (counts > 1).any():
            twice = tuple(unique[np.argmax(counts > 1)].tolist())
            raise CbrError(f"{self.what}: cell {twice} holds two unknown obstacles or sites; "
                           f"expected distinct cells")
        unknown = np.zeros(self.grid.passable.shape, dtype=bool)
        unknown[cells[:, 1], cells[:, 0]] = True
        if self.places is not None:
            taken = unknown[self.places[:, 1], self.places[:, 0]]
            if taken.any():
                i = int(np.argmax(taken))
                raise CbrError(f"{self.what}: places[{i}] {tuple(self.places[i].tolist())} is "
                               f"on an unknown obstacle or a site; expected a cell the robot "
                               f"can always stand on")
        self.unknown = unknown
        self.static, self.dynamic, self.sites = static_cells, dynamic_cells, site_cells
        self.site_appear = np.array([appear for _, appear in sites], dtype=np.float64)
        passable = self.grid.passable.copy()
        passable[static_cells[:, 1], static_cells[:, 0]] = False
        passable.setflags(write=False)
        self._static_passable = passable

    def draw(self, rng: np.random.Generator) -> Blocked:
        """Which dynamic cells and sites are blocked on one trip."""
        dynamic = self.dynamic[rng.random(len(self.dynamic)) < self.appear]
        # drawn after the dynamic cells, and not at all without listed sites, so that a seed
        # gives the same trips as before sites were configured
        sites = (tuple(np.flatnonzero(rng.random(len(self.site_appear))
                                      < self.site_appear).tolist()) if self.sites else ())
        return Blocked(dynamic, sites)

    def passable(self, blocked: Blocked | None = None) -> np.ndarray:
        """The true world's passable mask (read-only) with ``blocked`` blocked too."""
        cells = (np.concatenate([path_array(blocked.dynamic),
                                 *(self.sites[i] for i in blocked.sites)])
                 if blocked is not None else np.zeros((0, 2), dtype=np.int64))
        if not len(cells):
            return self._static_passable
        passable = self._static_passable.copy()
        passable[cells[:, 1], cells[:, 0]] = False
        passable.setflags(write=False)
        return passable
