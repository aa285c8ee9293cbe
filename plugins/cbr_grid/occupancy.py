"""Occupancy values as ROS and Nav2 know them, from a map image and into a grid's risk.

Two steps, each by the convention of the Nav2 component that takes it:

**Image to occupancy** (:func:`occupancy_values`), as Nav2's map_server reads a map image
(``loadMapFromFile``). A pixel's *shade* is the mean of its channels, levels in [0, 1]; its
occupancy ``occ`` is ``1 - shade``, or ``shade`` with ``negate``. The value, an int8 of a ROS
``OccupancyGrid`` (-1 unknown, 0 to 100), depends on the map's ``mode``:

- ``trinary``: 100 when ``occ > occupied_thresh``, 0 when ``occ < free_thresh``, -1 otherwise.
  The shade of an image with alpha averages the alpha (opacity, 1 opaque) with the colour
  channels, as map_server keeps doing for compatibility: a transparent white pixel's shade is
  0.75.
- ``scale``: -1 for a pixel that is not fully opaque; otherwise 100 and 0 as in trinary, and in
  between ``rint((occ - free_thresh) / (occupied_thresh - free_thresh) * 100)`` (rounded half
  to even). The shade averages the colour channels only.
- ``raw``: the shade of the colour channels times 255, rounded (halves up), is the value when
  it is 0 to 100 and -1 (unknown) above; ``negate``, the thresholds and alpha play no part.

A greyscale pixel's shade is its level (map_server sees it as three equal channels, so a grey
pixel with alpha averages as three greys and the alpha).

**Occupancy to risk** (:func:`occupancy_risk`), as Nav2's costmap static layer reads an
``OccupancyGrid`` with ``lethal_cost_threshold`` 100 and ``trinary_costmap`` false: 100 is an
obstacle (risk 1, cost ``LETHAL`` 254), 0 free, and a value v between the cost
``int(v / 100 * 254)``, which becomes the risk cost / 254 as the inflation layer's costs do
(:mod:`cbr_grid.inflation`). Nav2's default ``trinary_costmap: true`` would make every value
below 100 free and so drop what a ``scale`` map says; a map whose in-between values should be
unknown is a ``trinary`` map. Unknown cells (-1) are marked, and their risk is the planner's
``allow_unknown`` choice (:func:`unknown_risk`).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from cbrcore.errors import CbrError

Mode = Literal["trinary", "scale", "raw"]
MODES: tuple[Mode, ...] = ("trinary", "scale", "raw")
"""map_server's modes, its default first."""

UNKNOWN = -1
"""The occupancy value of an unknown cell."""
OCCUPIED = 100
"""The occupancy value of an occupied cell, and Nav2's default ``lethal_cost_threshold``."""
LETHAL = 254
"""Nav2's cost of an obstacle cell (``LETHAL_OBSTACLE``): the cost a risk of 1 stands for."""
MAX_NON_OBSTACLE = 252
"""Nav2's highest cost of a cell a robot may cross (``MAX_NON_OBSTACLE``)."""
ALLOWED_UNKNOWN_RISK = MAX_NON_OBSTACLE / LETHAL
"""The risk of unknown cells a planner may cross (``allow_unknown``): the costliest cell that is
no obstacle, as NavFn gives unknown cells its highest cost short of an obstacle."""


def unknown_risk(allow_unknown: bool) -> float:
    """The risk of unknown cells: :data:`ALLOWED_UNKNOWN_RISK` when the planner may cross them,
    1 (obstacles) when it may not."""
    return ALLOWED_UNKNOWN_RISK if allow_unknown else 1.0


def _shade(levels: np.ndarray, with_alpha: bool) -> np.ndarray:
    """The mean level of each pixel's channels ``[y, x]``, alpha included when ``with_alpha``."""
    if levels.ndim == 2:
        return levels
    channels = levels.shape[2]
    colour = levels[:, :, :3] if channels >= 3 else levels[:, :, :1]
    # map_server sees a grey pixel as three equal channels, which weigh three times
    weights = np.ones(3) if channels >= 3 else np.array([3.0])
    if with_alpha and channels in (2, 4):
        colour = np.concatenate((colour, levels[:, :, -1:]), axis=2)
        weights = np.append(weights, 1.0)
    return colour @ (weights / weights.sum())


def _opaque(levels: np.ndarray) -> np.ndarray | bool:
    """Per pixel ``[y, x]``, whether it is fully opaque; True for an image without alpha."""
    if levels.ndim == 3 and levels.shape[2] in (2, 4):
        return levels[:, :, -1] >= 1.0
    return True


def occupancy_values(levels: np.ndarray, *, mode: Mode, negate: bool, occupied_thresh: float,
                     free_thresh: float) -> np.ndarray:
    """map_server's occupancy values (int8, ``[y, x]``, row 0 the image's top row) of an
    image's ``levels`` in [0, 1] (``[y, x]`` or ``[y, x, channel]`` with alpha last), by the
    rules of the module docstring."""
    if mode not in MODES:
        raise CbrError(f"expected a map mode of {', '.join(MODES)}, got {mode!r}")
    if mode == "raw":
        # std::round, halves away from zero (NumPy's round takes them to even)
        value = np.floor(_shade(levels, with_alpha=False) * 255 + 0.5)
        return np.where(value <= OCCUPIED, value, UNKNOWN).astype(np.int8)
    shade = _shade(levels, with_alpha=mode == "trinary")
    occ = shade if negate else 1.0 - shade
    occupied, free = occ > occupied_thresh, occ < free_thresh
    values = np.full(occ.shape, UNKNOWN, dtype=np.int8)
    if mode == "scale":
        opaque = _opaque(levels)
        occupied &= opaque
        free &= opaque
        band = ~occupied & ~free & opaque
        if band.any() and occupied_thresh == free_thresh:
            # map_server would divide by zero
            raise CbrError(f"scale mode needs free_thresh below occupied_thresh, got both "
                           f"{free_thresh}")
        values[band] = np.rint((occ[band] - free_thresh) / (occupied_thresh - free_thresh)
                               * OCCUPIED)
    values[occupied] = OCCUPIED
    values[free] = 0
    return values


def occupancy_risk(values: np.ndarray, *, allow_unknown: bool) -> tuple[np.ndarray, np.ndarray]:
    """The risk ``[y, x]`` and the unknown cells' mask of occupancy ``values`` (-1 to 100), read
    as the module docstring says; values are not checked here."""
    unknown = values == UNKNOWN
    cost = np.floor(values.astype(np.float64) / OCCUPIED * LETHAL)
    risk = np.where(values >= OCCUPIED, 1.0, cost / LETHAL)
    risk[unknown] = unknown_risk(allow_unknown)
    return risk, unknown
