"""Seeded grid generators: random obstacles, offices, mazes, and a smooth terrain risk layer.

Each generator draws from ``numpy.random.default_rng(seed)``, so one seed always gives the same
grid. Obstacles have risk 1 and free cells risk 0 until :func:`terrain_risk` adds a hazard.
"""

from __future__ import annotations

import attrs
import numpy as np

from cbr_grid.grid import Grid
from cbrcore.errors import CbrError

Seed = int | np.random.SeedSequence
"""What the generators accept as a seed (a run derives independent ones with ``spawn``)."""


def _check_size(width: int, height: int, least: int = 1) -> None:
    if width < least or height < least:
        raise CbrError(f"a generated grid must be at least {least}x{least} cells, "
                       f"got {width}x{height}")


def random_obstacles(width: int, height: int, density: float, seed: Seed, *,
                     corner_cutting: bool = False) -> Grid:
    """A grid with round(density · width · height) obstacles at uniformly random cells."""
    _check_size(width, height)
    if not 0 <= density <= 1:
        raise CbrError(f"the obstacle density must be within [0, 1], got {density!r}")
    rng = np.random.default_rng(seed)
    cells = width * height
    risk = np.zeros(cells)
    risk[rng.choice(cells, size=round(density * cells), replace=False)] = 1.0
    return Grid(risk.reshape(height, width), corner_cutting=corner_cutting)


def office(width: int, height: int, seed: Seed, *, room: int = 6, door: int = 2,
           corridor: int = 2, corner_cutting: bool = False) -> Grid:
    """An office floor: bands of rooms between horizontal corridors, joined on the left.

    From the top the floor alternates a corridor ``corridor`` rows high with a band of rooms
    ``room`` rows high inside one-cell walls; a corridor ``corridor`` columns wide runs down the
    left edge and joins the horizontal ones. Room widths vary randomly around ``room``, and each
    room has one door ``door`` cells wide at a random place in its wall to the corridor above or
    (where there is one) below, so every free cell is reachable from every other. Rows left
    over at the bottom, too few for another band, are corridor.
    """
    _check_size(width, height)
    if room < 1 or door < 1 or corridor < 1:
        raise CbrError(f"room, door and corridor must be at least 1, got room={room}, "
                       f"door={door}, corridor={corridor}")
    rng = np.random.default_rng(seed)
    risk = np.zeros((height, width))
    top = corridor
    while top + room + 2 <= height:
        bottom = top + room + 1  # the band's wall rows are top and bottom
        risk[top, corridor:] = risk[bottom, corridor:] = 1.0
        below = bottom + 1 < height
        left = corridor  # the wall column left of the next room
        while left + 1 < width:
            span = int(rng.integers(max(1, room - room // 3), room + room // 3 + 1))
            right = min(left + span + 1, width)  # the wall column right of the room
            if width - right < 3:
                # a sliver too narrow for a room joins this one
                right = width
            risk[top:bottom + 1, left] = 1.0
            if right < width:
                risk[top:bottom + 1, right] = 1.0
            inside = right - left - 1
            wide = min(door, inside)
            start = left + 1 + int(rng.integers(0, inside - wide + 1))
            row = bottom if below and rng.random() < 0.5 else top
            risk[row, start:start + wide] = 0.0
            left = right
        top = bottom + 1 + corridor
    return Grid(risk, corner_cutting=corner_cutting)


def maze(width: int, height: int, seed: Seed, *, corner_cutting: bool = False) -> Grid:
    """A perfect maze: exactly one corridor path between any two free cells.

    Maze cells sit at odd (x, y); walls fill the rest, including the border and, for an even
    width or height, the last column or row. Passages are carved by the sidewinder algorithm,
    vectorised over the whole grid: the top row of cells is one east-west corridor; in every
    other row, runs of cells joined eastwards each open one passage north from a random cell of
    the run. Each row adds as many passages as it has cells (one fewer for the top row), and
    each joins a new cell to the cells above, so the passages form a spanning tree.
    """
    _check_size(width, height, least=3)
    rng = np.random.default_rng(seed)
    cols, rows = (width - 1) // 2, (height - 1) // 2
    # close[j, i]: the run through cell (i, j) ends there; it always ends at the east edge, and
    # the top row is a single run
    close = rng.random((rows, cols)) < 0.5
    close[:, -1] = True
    close[0, :-1] = False
    # number the runs in reading order; a run starts after each closing cell
    run = np.concatenate(([0], np.cumsum(close.ravel())[:-1]))
    # one random member of every run: sort by (run, random key) and keep each run's first
    order = np.lexsort((rng.random(run.size), run))
    first = np.ones(run.size, dtype=bool)
    first[1:] = run[order][1:] != run[order][:-1]
    north = np.zeros(run.size, dtype=bool)
    north[order[first]] = True
    north = north.reshape(rows, cols)
    north[0] = False

    risk = np.ones((height, width))
    risk[1:2 * rows:2, 1:2 * cols:2] = 0.0
    # an east passage sits between cells (i, j) and (i + 1, j) at (2i + 2, 2j + 1)
    east = ~close[:, :-1]
    risk[1:2 * rows:2, 2:2 * cols - 1:2][east] = 0.0
    # a north passage from cell (i, j) sits at (2i + 1, 2j)
    risk[2:2 * rows - 1:2, 1:2 * cols:2][north[1:]] = 0.0
    return Grid(risk, corner_cutting=corner_cutting)


def terrain_risk(grid: Grid, seed: Seed, scale: float = 4.0, amount: float = 0.5) -> Grid:
    """``grid`` with a smooth random hazard added to its free cells; obstacles stay 1.

    The hazard is white noise blurred by a Gaussian of standard deviation ``scale`` cells
    (wrapping around the grid's edges, so no edge is smoother than the middle) and stretched
    to [0, 1]. A free cell of risk r becomes r + (1 - r) · amount · hazard, which stays below 1
    for ``amount`` in [0, 1).
    """
    if scale <= 0:
        raise CbrError(f"the terrain scale must be positive, got {scale!r}")
    if not 0 <= amount < 1:
        raise CbrError(f"the terrain amount must be within [0, 1), got {amount!r}")
    rng = np.random.default_rng(seed)
    noise = rng.standard_normal((grid.height, grid.width))
    # scipy loads on first use: the command line imports every plugin to list its components
    from scipy import ndimage

    smooth = ndimage.gaussian_filter(noise, scale, mode="wrap")
    spread = smooth.max() - smooth.min()
    hazard = (smooth - smooth.min()) / spread if spread > 0 else np.zeros_like(smooth)
    risk = np.where(grid.passable, grid.risk + (1 - grid.risk) * amount * hazard, 1.0)
    return attrs.evolve(grid, risk=risk)


KINDS = ("random", "office", "maze")
"""The layouts :func:`generate` draws."""


def generate(kind: str, width: int, height: int, seed: int, *, density: float = 0.2,
             terrain: float = 0.0, corner_cutting: bool = False) -> Grid:
    """A grid of layout ``kind`` (``density`` applies to ``random``), with ``terrain`` risk.

    The layout and the terrain draw from independent streams spawned from ``seed``, so adding
    terrain leaves the obstacles where they were.
    """
    layout, texture = np.random.SeedSequence(seed).spawn(2)
    if kind == "random":
        grid = random_obstacles(width, height, density, layout, corner_cutting=corner_cutting)
    elif kind == "office":
        grid = office(width, height, layout, corner_cutting=corner_cutting)
    elif kind == "maze":
        grid = maze(width, height, layout, corner_cutting=corner_cutting)
    else:
        raise CbrError(f"expected a grid kind among {', '.join(KINDS)}, got {kind!r}")
    return terrain_risk(grid, texture, amount=terrain) if terrain > 0 else grid
