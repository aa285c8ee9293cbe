"""A planned path written to a file: CSV, or GeoJSON for GIS tools and web maps.

The format follows the file's extension (:data:`PATH_FORMATS`). The points are cells (x, y) or,
on a map with a metric frame, map-frame metres; a GeoJSON file says which in its ``properties``
(``units`` ``cells`` or ``m``), a CSV file in its header (``x,y`` or ``x_m,y_m``). GeoJSON
coordinates are meant to be longitude and latitude; a path in a robot's map frame is a local,
planar one, which GIS tools draw as it is when told the layer has no geographic reference.
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from cbrcore.errors import CbrError
from cbrcore.files import write_text

PATH_FORMATS = {".csv": "csv", ".geojson": "geojson", ".json": "geojson"}
"""The format of a path file by its extension (lower case)."""


def path_format(out: Path) -> str:
    """The format of the path file ``out`` by its extension, or a CbrError naming the
    extensions there are."""
    found = PATH_FORMATS.get(out.suffix.lower())
    if found is None:
        raise CbrError(f"{out}: a path file is CSV or GeoJSON; expected the extension "
                       f"{', '.join(PATH_FORMATS)}, got {out.suffix or 'none'!r}")
    return found


def _csv(points: np.ndarray, metres: bool) -> str:
    text = io.StringIO()
    text.write("x_m,y_m\n" if metres else "x,y\n")
    for x, y in points.tolist():
        # repr keeps every digit, so that the file reads back to the very same numbers
        text.write(f"{x!r},{y!r}\n")
    return text.getvalue()


def _geojson(points: np.ndarray, metres: bool, properties: dict[str, Any]) -> str:
    coordinates = points.tolist()
    if len(coordinates) == 1:
        # a LineString has two positions or more: a path that stays put is one twice over
        coordinates *= 2
    feature = {"type": "Feature",
               "geometry": {"type": "LineString", "coordinates": coordinates},
               "properties": {"units": "m" if metres else "cells", **properties}}
    return json.dumps(feature) + "\n"


def write_path(out: Path, points: ArrayLike, *, metres: bool,
               properties: dict[str, Any] | None = None) -> None:
    """Write the path ``points`` ((n, 2): cells, or map-frame metres when ``metres``) to
    ``out`` in the format of its extension, whole or not at all; GeoJSON gets ``properties``
    (JSON values) besides its ``units``. A file that cannot be written is a CbrError."""
    chosen = path_format(out)
    array = np.asarray(points, dtype=np.float64 if metres else np.int64)
    text = (_csv(array, metres) if chosen == "csv"
            else _geojson(array, metres, properties or {}))
    try:
        write_text(out, text)
    except OSError as exc:
        raise CbrError(f"{out}: cannot write the path: {exc.strerror or exc}") from exc
