"""Loaders for grid files besides Moving AI maps: ROS map_server maps, PGM, PNG, NumPy, text.

Every loader returns a :class:`~cbr_grid.grid.Grid` whose row y = 0 is the image's (or file's)
top row, as in Moving AI maps, so a picture of the map reads the same way as the grid. Every
error names the file and says what was expected; where a line number means something the error
reads ``<file>, line N: expected ...``. Errors quote numbers and the format's own words (a ROS
``mode``) but never other text of the file: a configuration that names the
wrong file, a secret one say, must not get it printed.

ROS map_server (``.yaml``)
    A YAML mapping with ``image`` (relative to the YAML file), ``resolution`` (> 0), ``origin``
    ([x, y, yaw]), ``negate`` (0/1 or false/true), ``occupied_thresh`` and ``free_thresh``
    (0 <= free <= occupied <= 1) and optionally ``mode`` (``trinary``, the default, ``scale``
    or ``raw``); ``map_type`` (written by Nav2's test maps) is accepted and ignored.
    ``resolution`` and ``origin`` become the grid's ``frame``
    (:class:`~cbr_grid.frame.MapFrame`); y = 0 is the image's top row. The pixels become
    occupancy values exactly as Nav2's map_server computes them, modes and alpha included, and
    the values become risk as Nav2's costmap static layer reads them
    (:mod:`cbr_grid.occupancy`). Unknown cells are marked in the grid's ``unknown`` mask;
    ``allow_unknown`` (True by default, as Nav2's planners) lets a planner cross them at the
    highest cost short of an obstacle, False makes them obstacles.
Images (``.pgm`` and others inside a ROS map, ``.png``)
    Read with Pillow (:func:`read_image`): binary ``P5`` and plain ``P2`` greymaps of 8 or 16
    bits, PNG, and whatever else Pillow reads, up to :data:`MAX_IMAGE_PIXELS` pixels whatever
    Pillow's own limit. Palettes and transparent colours become RGBA, other colour spaces RGB.
PNG (``.png``)
    A colour image is reduced to luminance 0.299 R + 0.587 G + 0.114 B (alpha ignored). Cells
    darker than ``threshold`` (luminance in [0, 1]) are obstacles, the rest free.
NumPy (``.npy``)
    A 2-D array of real risk values in [0, 1], ``[y, x]``; pickled and complex arrays are
    refused.
Text (``.grid``)
    One row per line, y = 0 first: ``.`` free (risk 0), ``#`` obstacle (risk 1), a digit d
    risk d / 10 (``0`` to ``9``: 0.0 to 0.9). Every row has the same length; LF or CRLF line
    ends; blank lines after the last row are ignored, nothing else is.
"""

from __future__ import annotations

import contextlib
import io
import math
import re
import threading
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import attrs
import numpy as np
import yaml

from cbr_grid import EXTENSIONS
from cbr_grid.frame import MapFrame
from cbr_grid.grid import Grid
from cbr_grid.movingai import load_map
from cbr_grid.occupancy import MODES, occupancy_risk, occupancy_values
from cbrcore.documents import compose_yaml, construct_yaml, read_bytes
from cbrcore.errors import CbrError


def _read(path: Path) -> bytes:
    try:
        return read_bytes(path)
    except OSError as exc:
        raise CbrError(f"{path}: cannot read: {exc.strerror or exc}") from exc


def _grid(path: Path, risk: np.ndarray, corner_cutting: bool, frame: MapFrame | None = None,
          unknown: np.ndarray | None = None) -> Grid:
    """A grid of ``risk``, with Grid's own complaint about the values prefixed by the file."""
    try:
        return Grid(risk, corner_cutting=corner_cutting, frame=frame, unknown=unknown)
    except CbrError as exc:
        raise CbrError(f"{path}: {exc}") from exc


# --- images --------------------------------------------------------------------------------------

# Pillow's own words for a damaged file, by what they mean; other messages may quote the file
_PILLOW_PROBLEMS = (
    ("truncated", "its pixel data ends before the size its header gives"),
    ("not enough image data", "its pixel data ends before the size its header gives"),
    ("too large for this mode", "a pixel value exceeds the image's maximum value"),
)


_NOT_RGB = ("CMYK", "YCbCr", "LAB", "HSV")
"""Pillow's colour modes whose channels are converted to RGB before they are read: a map reader
averages red, green, blue and alpha."""


MAX_GRID_CELLS = 2**28
"""The most cells a map read from an image or a ``.npy`` file may have: 16384 x 16384, 820 m a
side in 5 cm cells. Its risk values alone take 2 GiB, and planning on it several times that; a
file whose header declares more is refused before its cells are read. (The other formats are
bounded by the size of a document, :mod:`cbrcore.documents`.)"""

MAX_IMAGE_PIXELS = MAX_GRID_CELLS
"""The most pixels a map image may have, checked from the image's header before it is decoded.
Pillow's own limit (``PIL.Image.MAX_IMAGE_PIXELS``, about 89 million) guards against images
from strangers; a map is a trusted local file, and the map of a large site may well have more."""

_PILLOW_LIMIT = threading.Lock()
"""Held while Pillow's process-wide limit is this module's, for one read."""


@contextlib.contextmanager
def _map_image_limit() -> Iterator[None]:
    """Pillow's pixel limit set to :data:`MAX_IMAGE_PIXELS` for one read, every image past it
    refused (Pillow only warns up to twice its limit), restored after."""
    from PIL import Image

    with _PILLOW_LIMIT, warnings.catch_warnings():
        warnings.simplefilter("error", Image.DecompressionBombWarning)
        saved = Image.MAX_IMAGE_PIXELS
        Image.MAX_IMAGE_PIXELS = MAX_IMAGE_PIXELS
        try:
            yield
        finally:
            Image.MAX_IMAGE_PIXELS = saved


def read_image(path: str | Path) -> np.ndarray:
    """The image's levels as floats in [0, 1] (0 black), ``[y, x]`` for a greyscale image or
    ``[y, x, channel]`` for colour (alpha last), row 0 at the top.

    Any image Pillow reads: PGM (binary ``P5`` and plain ``P2``, 8 or 16 bits), PNG (8 or 16
    bits, palette images expanded), BMP, TIFF... Pillow scales a PGM's values to its full range,
    so a pixel v of maximum value m reads as v / m, rounded to 1/255 (1/65535 for 16 bits).
    Images of up to :data:`MAX_IMAGE_PIXELS` pixels are read, whatever Pillow's own limit.
    """
    from PIL import Image, UnidentifiedImageError

    path = Path(path)
    if not path.exists():
        raise CbrError(f"{path}: cannot read: no such file")
    data = _read(path)
    try:
        with _map_image_limit(), Image.open(io.BytesIO(data)) as image:
            image.load()
            if image.mode in ("P", "PA") or "transparency" in image.info:
                # a palette's colours, and a transparent colour or grey as alpha
                image = image.convert("RGBA")
            elif image.mode in _NOT_RGB:
                # channels that are no colour channels or alpha, such as a JPEG's YCbCr
                image = image.convert("RGB")
            mode = image.mode
            pixels = np.asarray(image)
    except UnidentifiedImageError as exc:
        raise CbrError(f"{path}: cannot read the image; expected a PGM (P2 or P5), PNG or "
                       "another image format Pillow reads") from exc
    except (Image.DecompressionBombError, Image.DecompressionBombWarning) as exc:
        # Pillow's message gives the image's pixel count, a number: safe to quote
        count = re.search(r"\((\d+) pixels\)", str(exc))
        has = f"{count[1]} pixels, more" if count else "more pixels"
        raise CbrError(f"{path}: cannot read the image: it has {has} than the "
                       f"{MAX_IMAGE_PIXELS} a map image may have "
                       "(cbr_grid.formats.MAX_IMAGE_PIXELS)") from exc
    except Exception as exc:  # Pillow raises many unrelated types for a damaged file
        text = str(exc)
        # only Pillow's own words are said: other messages may quote the file's bytes
        said = next((meaning for words, meaning in _PILLOW_PROBLEMS if words in text),
                    "the file is damaged")
        raise CbrError(f"{path}: cannot read the image: {said}") from exc
    if pixels.ndim not in (2, 3) or pixels.size == 0:
        raise CbrError(f"{path}: expected a greyscale or colour image, got an array of shape "
                       f"{pixels.shape}")
    if pixels.dtype == bool:
        return pixels.astype(np.float64)
    if mode.startswith("I"):
        # 16-bit greyscale, which Pillow holds in 32-bit integers
        if pixels.min() < 0 or pixels.max() > 65535:
            raise CbrError(f"{path}: expected pixel values from 0 to 65535")
        return pixels / 65535.0
    if mode == "F":
        raise CbrError(f"{path}: expected an image of integer pixels, got floating point ones")
    return pixels / 255.0


def load_png(path: str | Path, *, threshold: float = 0.5, corner_cutting: bool = False) -> Grid:
    """The grid of an image: pixels darker than ``threshold`` are obstacles, the rest free."""
    path = Path(path)
    if not 0 <= threshold <= 1:
        raise CbrError(f"{path}: the threshold must be within [0, 1], got {threshold!r}")
    image = read_image(path)
    if image.ndim == 3:
        if image.shape[2] >= 3:
            image = image[:, :, :3] @ np.array([0.299, 0.587, 0.114])
        else:
            image = image[:, :, 0]  # greyscale with alpha
    return _grid(path, (image < threshold).astype(np.float64), corner_cutting)


# --- ROS map_server ------------------------------------------------------------------------------

def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _kind(value: Any) -> str:
    """``value`` as an error may show it: a number or boolean as written, text and containers
    by their kind only, as they may come from a file that is no map description."""
    if isinstance(value, bool | int | float):
        return repr(value)
    if value is None:
        return "null"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    return "a mapping" if isinstance(value, dict) else type(value).__name__


def _yaml_mapping(path: Path) -> tuple[dict[str, Any], dict[str, int]]:
    """The YAML file's top-level mapping and the line of each key."""
    text = _read(path).decode("utf-8", errors="replace")
    try:
        node = compose_yaml(text, str(path))
        data = construct_yaml(node, str(path))
    except yaml.YAMLError as exc:
        # PyYAML's problem texts quote the offending characters; the place is enough
        mark = getattr(exc, "problem_mark", None)
        where = f", line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        raise CbrError(f"{path}{where}: expected a YAML map description, got invalid "
                       "YAML") from exc
    if not isinstance(node, yaml.MappingNode) or not isinstance(data, dict):
        raise CbrError(f"{path}, line 1: expected a YAML mapping with image, resolution, "
                       f"origin, negate, occupied_thresh and free_thresh, got {_kind(data)}")
    lines = {key.value: key.start_mark.line + 1 for key, _ in node.value
             if isinstance(key, yaml.ScalarNode)}
    return data, lines


def _field(path: Path, data: dict[str, Any], lines: dict[str, int], key: str, expected: str,
           ok: Any) -> Any:
    if key not in data:
        raise CbrError(f"{path}: expected a '{key}' entry ({expected}), it is missing")
    value = data[key]
    if not ok(value):
        raise CbrError(f"{path}, line {lines.get(key, 1)}: expected '{key}' to be {expected}, "
                       f"got {_kind(value)}")
    return value


KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")
"""The keys of a ROS map description this loader reads."""
IGNORED_KEYS = ("map_type",)
"""Keys real map descriptions carry that say nothing the loader needs: Nav2's test maps write
``map_type: occupancy``."""


def load_ros(path: str | Path, *, allow_unknown: bool = True,
             corner_cutting: bool = False) -> Grid:
    """The grid of a ROS map_server map: a YAML description and its image (PGM, PNG, ...).

    See the module docstring for the rules; y = 0 is the image's top row, the grid's ``frame``
    holds ``resolution`` and ``origin`` and its ``unknown`` mask the cells map_server leaves
    unknown.
    """
    path = Path(path)
    data, lines = _yaml_mapping(path)
    extra = sorted(str(k) for k in data if k not in KEYS and k not in IGNORED_KEYS)
    if extra:
        raise CbrError(f"{path}, line {lines.get(extra[0], 1)}: expected only the keys "
                       f"{', '.join(sorted(KEYS + IGNORED_KEYS))}, got another key")
    image = _field(path, data, lines, "image", "an image file name",
                   lambda v: isinstance(v, str) and v != "")
    resolution = _field(path, data, lines, "resolution", "a positive number",
                        lambda v: _number(v) and v > 0)
    origin = _field(path, data, lines, "origin", "a list of three numbers [x, y, yaw]",
                    lambda v: isinstance(v, list) and len(v) == 3 and all(map(_number, v)))
    negate = _field(path, data, lines, "negate", "0 or 1",
                    lambda v: isinstance(v, bool) or v in (0, 1))
    occupied = _field(path, data, lines, "occupied_thresh", "a number within [0, 1]",
                      lambda v: _number(v) and 0 <= v <= 1)
    free = _field(path, data, lines, "free_thresh",
                  f"a number within [0, occupied_thresh = {occupied}]",
                  lambda v: _number(v) and 0 <= v <= occupied)
    mode = data.get("mode", "trinary")
    if mode not in MODES:
        # other values may be anything
        raise CbrError(f"{path}, line {lines.get('mode', 1)}: expected 'mode' to be "
                       f"{', '.join(MODES)}, got {_kind(mode)}")

    levels = read_image(path.parent / image)
    try:
        values = occupancy_values(levels, mode=mode, negate=bool(negate),
                                  occupied_thresh=occupied, free_thresh=free)
    except CbrError as exc:
        raise CbrError(f"{path}: {exc}") from exc
    risk, unknown = occupancy_risk(values, allow_unknown=allow_unknown)
    return _grid(path, risk, corner_cutting, MapFrame(resolution, *origin),
                 unknown if unknown.any() else None)


# --- NumPy and text ------------------------------------------------------------------------------

def load_npy(path: str | Path, *, corner_cutting: bool = False) -> Grid:
    """The grid of a ``.npy`` file holding a 2-D risk array ``[y, x]``."""
    path = Path(path)
    data = _read(path)
    _check_npy_header(path, data)
    try:
        risk = np.load(io.BytesIO(data), allow_pickle=False)
    except (OSError, ValueError, EOFError) as exc:
        # NumPy's message quotes the file's first bytes when they are not the .npy magic
        raise CbrError(f"{path}: expected a NumPy array file (.npy)") from exc
    if not isinstance(risk, np.ndarray) or not (
            np.issubdtype(risk.dtype, np.number) or risk.dtype == bool):
        # a structured dtype's field names are the file's text, so the dtype is not shown
        raise CbrError(f"{path}: expected a numeric array")
    if np.iscomplexobj(risk):
        # converting to risk values would drop the imaginary parts silently
        raise CbrError(f"{path}: expected real risk values, got a complex array")
    return _grid(path, risk, corner_cutting)


def _check_npy_header(path: Path, data: bytes) -> None:
    """Refuse a ``.npy`` file whose header declares more cells than :data:`MAX_GRID_CELLS` or
    more data than the file holds, before NumPy allocates the array the header declares.

    A file that is not a ``.npy`` file of version 1 or 2 passes, for :func:`numpy.load` to
    refuse; version 3 only differs in allowing non-ASCII field names, which a risk array has not.
    """
    from numpy.lib import format as npy

    stream = io.BytesIO(data)
    try:
        version = npy.read_magic(stream)
        if version == (1, 0):
            shape, _, dtype = npy.read_array_header_1_0(stream)
        elif version == (2, 0):
            shape, _, dtype = npy.read_array_header_2_0(stream)
        else:
            return
    except (OSError, ValueError, EOFError):
        return
    cells = math.prod(shape)
    if cells > MAX_GRID_CELLS:
        raise CbrError(f"{path}: its header declares an array of {cells} cells, more than the "
                       f"{MAX_GRID_CELLS} a map may have (cbr_grid.formats.MAX_GRID_CELLS)")
    if not dtype.hasobject and cells * dtype.itemsize > len(data) - stream.tell():
        raise CbrError(f"{path}: its data ends before the size its header declares "
                       f"({cells} cells of {dtype.itemsize} bytes)")


_TEXT_RISK = np.full(256, np.nan)
_TEXT_RISK[ord(".")] = 0.0
_TEXT_RISK[ord("#")] = 1.0
_TEXT_RISK[np.frombuffer(b"0123456789", dtype=np.uint8)] = np.arange(10) / 10


def load_text(path: str | Path, *, corner_cutting: bool = False) -> Grid:
    """The grid of a ``.grid`` text file (see the module docstring)."""
    path = Path(path)
    rows = _read(path).splitlines()
    while rows and not rows[-1].strip():
        rows.pop()
    if not rows:
        raise CbrError(f"{path}, line 1: expected a row of cells (. # 0-9), got an empty file")
    width = len(rows[0])
    lengths = np.array([len(r) for r in rows])
    wrong = np.flatnonzero(lengths != width)
    if len(wrong):
        y = int(wrong[0])
        raise CbrError(f"{path}, line {y + 1}: expected a row of {width} cells like line 1, "
                       f"got {lengths[y]}")
    codes = np.frombuffer(b"".join(rows), dtype=np.uint8).reshape(len(rows), width)
    risk = _TEXT_RISK[codes]
    unknown = np.isnan(risk)
    if unknown.any():
        y, x = (int(i) for i in np.argwhere(unknown)[0])
        raise CbrError(f"{path}, line {y + 1}: expected '.', '#' or a digit at column {x + 1}")
    return _grid(path, risk, corner_cutting)


# --- by extension --------------------------------------------------------------------------------



def load_grid(path: str | Path, *, corner_cutting: bool = False, allow_unknown: bool = True,
              threshold: float = 0.5, frame: MapFrame | None = None) -> Grid:
    """The grid of a map file, read by the loader its extension names (see :data:`EXTENSIONS`).

    ``allow_unknown`` applies to ROS maps and ``threshold`` to PNG images. ``frame`` places a
    map of cells only (every format but ROS maps, which carry their own) in a map frame.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".yaml", ".yml"):
        if frame is not None:
            raise CbrError(f"{path}: a ROS map has its own frame (resolution and origin); "
                           "expected no frame to be given")
        return load_ros(path, allow_unknown=allow_unknown, corner_cutting=corner_cutting)
    if suffix == ".map":
        grid = load_map(path, corner_cutting=corner_cutting)
    elif suffix == ".png":
        grid = load_png(path, threshold=threshold, corner_cutting=corner_cutting)
    elif suffix == ".npy":
        grid = load_npy(path, corner_cutting=corner_cutting)
    elif suffix == ".grid":
        grid = load_text(path, corner_cutting=corner_cutting)
    else:
        raise CbrError(f"{path}: expected a map file ending in {', '.join(EXTENSIONS)}, "
                       f"got {suffix or 'no extension'!r}")
    return grid if frame is None else attrs.evolve(grid, frame=frame)
