"""Loaders for grid files besides Moving AI maps: ROS map_server maps, PGM, PNG, NumPy, text.

Every loader returns a :class:`~cbr_grid.grid.Grid` whose row y = 0 is the image's (or file's)
top row, as in Moving AI maps, so a picture of the map reads the same way as the grid. Every
error names the file and says what was expected; where a line number means something the error
reads ``<file>, line N: expected ...``. Errors quote numbers and the format's own words (a PGM
magic number, a ROS ``mode``) but never other text of the file: a configuration that names the
wrong file, a secret one say, must not get it printed.

ROS map_server (``.yaml``)
    A YAML mapping with ``image`` (relative to the YAML file), ``resolution`` (> 0), ``origin``
    ([x, y, yaw]), ``negate`` (0/1 or false/true), ``occupied_thresh`` and ``free_thresh``
    (0 <= free <= occupied <= 1) and optionally ``mode`` (``trinary``, the default, or
    ``scale``; ``raw`` is refused). ROS puts ``origin`` at the image's bottom-left corner; the
    grid keeps cells only, so ``resolution`` and ``origin`` are checked and then dropped, and
    y = 0 is the image's top row. A pixel value v of an image with maximum value m reads as the
    occupancy p = (m - v) / m, or v / m with ``negate`` (for 8-bit images, (255 - v) / 255 and
    v / 255). A cell is occupied (risk 1) when p > occupied_thresh, free (risk 0) when
    p < free_thresh, and unknown otherwise; unknown cells get ``unknown_risk`` (1 by default:
    treated as obstacles). In ``scale`` mode the unknown band instead gets risk p. Colour
    images are averaged over their channels (alpha ignored), as map_server does.
PGM (``.pgm``, inside a ROS map)
    Binary ``P5`` and plain ``P2`` greymaps with a maximum value of at most 255; ``#`` comments
    are allowed in the header (and anywhere in ``P2``).
PNG (``.png``)
    Read with matplotlib; a colour image is reduced to luminance 0.299 R + 0.587 G + 0.114 B
    (alpha ignored). Cells darker than ``threshold`` (luminance in [0, 1]) are obstacles, the
    rest free.
NumPy (``.npy``)
    A 2-D array of real risk values in [0, 1], ``[y, x]``; pickled and complex arrays are
    refused.
Text (``.grid``)
    One row per line, y = 0 first: ``.`` free (risk 0), ``#`` obstacle (risk 1), a digit d
    risk d / 10 (``0`` to ``9``: 0.0 to 0.9). Every row has the same length; LF or CRLF line
    ends; blank lines after the last row are ignored, nothing else is.
"""

from __future__ import annotations

import io
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from cbr_grid.grid import Grid
from cbr_grid.movingai import load_map
from cbrcore.documents import compose_yaml, construct_yaml, read_bytes
from cbrcore.errors import CbrError

_DIGITS = 18
"""The most digits a PGM size or pixel value may have: any such number fits in 64 bits."""

def _read(path: Path) -> bytes:
    try:
        return read_bytes(path)
    except OSError as exc:
        raise CbrError(f"{path}: cannot read: {exc.strerror or exc}") from exc


def _grid(path: Path, risk: np.ndarray, corner_cutting: bool) -> Grid:
    """A grid of ``risk``, with Grid's own complaint about the values prefixed by the file."""
    try:
        return Grid(risk, corner_cutting=corner_cutting)
    except CbrError as exc:
        raise CbrError(f"{path}: {exc}") from exc


# --- PGM -----------------------------------------------------------------------------------------

_PGM_TOKEN = re.compile(rb"#[^\n]*|[^\s#]+")
_MAGIC = re.compile(rb"P[0-9]")


def _line_of(data: bytes, offset: int) -> int:
    return data.count(b"\n", 0, offset) + 1


def _pgm_tokens(data: bytes, count: int) -> tuple[list[tuple[bytes, int]], int]:
    """The first ``count`` non-comment tokens with their offsets, and where the last one ends."""
    tokens: list[tuple[bytes, int]] = []
    end = 0
    for match in _PGM_TOKEN.finditer(data):
        if match.group().startswith(b"#"):
            continue
        tokens.append((match.group(), match.start()))
        end = match.end()
        if len(tokens) == count:
            break
    return tokens, end


def load_pgm(path: str | Path) -> tuple[np.ndarray, int]:
    """The pixels ``[y, x]`` (row 0 = the image's top) and maximum value of a P2 or P5 greymap."""
    path = Path(path)
    data = _read(path)
    tokens, end = _pgm_tokens(data, 4)
    names = ("the magic number P2 or P5", "a positive width", "a positive height",
             "a maximum value from 1 to 255")
    if tokens and tokens[0][0] not in (b"P2", b"P5"):
        # another Netpbm magic number is named; anything else may not be an image at all
        magic = tokens[0][0]
        got = f", got {magic.decode()!r}" if _MAGIC.fullmatch(magic) else ""
        raise CbrError(f"{path}, line {_line_of(data, tokens[0][1])}: expected {names[0]}{got}")
    if len(tokens) < 4:
        raise CbrError(f"{path}, line {_line_of(data, len(data))}: expected "
                       f"{names[len(tokens)]}, the file ends")
    magic = tokens[0][0]
    numbers = []
    for name, (token, offset) in zip(names[1:], tokens[1:], strict=True):
        if not token.isdigit() or len(token) > _DIGITS or int(token) < 1:
            got = (f", got {token.decode()!r}" if token.isdigit() and len(token) <= _DIGITS
                   else "")  # digits: a number
            raise CbrError(f"{path}, line {_line_of(data, offset)}: expected {name}{got}")
        numbers.append(int(token))
    width, height, maxval = numbers
    if maxval > 255:
        raise CbrError(f"{path}, line {_line_of(data, tokens[3][1])}: expected {names[3]} "
                       f"(8-bit pixels), got {maxval}")
    if magic == b"P5":
        # exactly one whitespace byte separates the maximum value from the pixel bytes
        pixels = np.frombuffer(data, dtype=np.uint8, offset=min(end + 1, len(data)))
        if pixels.size != width * height:
            raise CbrError(f"{path}: expected {width * height} pixel bytes ({width}x{height}) "
                           f"after the header, got {pixels.size}")
        values = pixels.astype(np.int64)
        offsets = None
    else:
        body = [(m.group(), m.start()) for m in _PGM_TOKEN.finditer(data, end)
                if not m.group().startswith(b"#")]
        bad = next(((t, o) for t, o in body if not t.isdigit() or len(t) > _DIGITS), None)
        if bad is not None:
            raise CbrError(f"{path}, line {_line_of(data, bad[1])}: expected a pixel value")
        if len(body) != width * height:
            raise CbrError(f"{path}: expected {width * height} pixel values ({width}x{height}) "
                           f"after the header, got {len(body)}")
        values = np.array([t for t, _ in body], dtype=np.int64)
        offsets = [o for _, o in body]
    over = np.flatnonzero(values > maxval)
    if len(over):
        i = int(over[0])
        place = (f"line {_line_of(data, offsets[i])}" if offsets is not None
                 else f"byte {end + 1 + i}")
        raise CbrError(f"{path}, {place}: expected pixel values up to the maximum {maxval}, "
                       f"got {values[i]} at ({i % width}, {i // width})")
    return values.reshape(height, width), maxval


# --- images --------------------------------------------------------------------------------------

def _image(path: Path) -> np.ndarray:
    """The image as floats in [0, 1], ``[y, x]`` or ``[y, x, channel]``, row 0 at the top."""
    import matplotlib.image

    if not path.is_file():
        raise CbrError(f"{path}: cannot read: no such file")
    data = _read(path)
    try:
        # the format by the file's extension, as matplotlib deduces it from a file name
        image = np.asarray(matplotlib.image.imread(io.BytesIO(data),
                                                   format=path.suffix[1:].lower() or "png"))
    except Exception as exc:  # the image libraries raise many unrelated types for a bad file
        # their messages may quote the file's first bytes, so only the expectation is said
        raise CbrError(f"{path}: cannot read the image; expected a PNG file") from exc
    if np.issubdtype(image.dtype, np.integer):
        image = image / np.iinfo(image.dtype).max
    if image.ndim not in (2, 3) or image.size == 0:
        raise CbrError(f"{path}: expected a greyscale or colour image, got an array of shape "
                       f"{image.shape}")
    return image.astype(np.float64)


def load_png(path: str | Path, *, threshold: float = 0.5, corner_cutting: bool = False) -> Grid:
    """The grid of an image: pixels darker than ``threshold`` are obstacles, the rest free."""
    path = Path(path)
    if not 0 <= threshold <= 1:
        raise CbrError(f"{path}: the threshold must be within [0, 1], got {threshold!r}")
    image = _image(path)
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


def load_ros(path: str | Path, *, unknown_risk: float = 1.0,
             corner_cutting: bool = False) -> Grid:
    """The grid of a ROS map_server map: a YAML description and its image (PGM or PNG).

    See the module docstring for the rules; y = 0 is the image's top row.
    """
    path = Path(path)
    if not 0 <= unknown_risk <= 1:
        raise CbrError(f"{path}: the risk of unknown cells must be within [0, 1], "
                       f"got {unknown_risk!r}")
    data, lines = _yaml_mapping(path)
    known = {"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"}
    extra = sorted(str(k) for k in data if k not in known)
    if extra:
        raise CbrError(f"{path}, line {lines.get(extra[0], 1)}: expected only the keys "
                       f"{', '.join(sorted(known))}, got another key")
    image = _field(path, data, lines, "image", "an image file name",
                   lambda v: isinstance(v, str) and v != "")
    _field(path, data, lines, "resolution", "a positive number", lambda v: _number(v) and v > 0)
    _field(path, data, lines, "origin", "a list of three numbers [x, y, yaw]",
           lambda v: isinstance(v, list) and len(v) == 3 and all(map(_number, v)))
    negate = _field(path, data, lines, "negate", "0 or 1",
                    lambda v: isinstance(v, bool) or v in (0, 1))
    occupied = _field(path, data, lines, "occupied_thresh", "a number within [0, 1]",
                      lambda v: _number(v) and 0 <= v <= 1)
    free = _field(path, data, lines, "free_thresh",
                  f"a number within [0, occupied_thresh = {occupied}]",
                  lambda v: _number(v) and 0 <= v <= occupied)
    mode = data.get("mode", "trinary")
    if mode not in ("trinary", "scale"):
        # raw, map_server's third mode, is named; other values may be anything
        got = "'raw'" if mode == "raw" else _kind(mode)
        raise CbrError(f"{path}, line {lines.get('mode', 1)}: expected 'mode' to be trinary or "
                       f"scale, got {got}")

    image_path = path.parent / image
    if image_path.suffix.lower() == ".pgm":
        values, maxval = load_pgm(image_path)
        level = values / maxval
    else:
        level = _image(image_path)
        if level.ndim == 3:
            # map_server averages the colour channels and ignores alpha
            level = level[:, :, :3].mean(axis=2) if level.shape[2] >= 3 else level[:, :, 0]
    occupancy = level if negate else 1.0 - level
    risk = np.where(occupancy > occupied, 1.0,
                    np.where(occupancy < free, 0.0,
                             occupancy if mode == "scale" else unknown_risk))
    return _grid(path, risk, corner_cutting)


# --- NumPy and text ------------------------------------------------------------------------------

def load_npy(path: str | Path, *, corner_cutting: bool = False) -> Grid:
    """The grid of a ``.npy`` file holding a 2-D risk array ``[y, x]``."""
    path = Path(path)
    data = _read(path)
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

EXTENSIONS = (".map", ".yaml", ".yml", ".png", ".npy", ".grid")
"""The file extensions :func:`load_grid` knows."""


def load_grid(path: str | Path, *, corner_cutting: bool = False, unknown_risk: float = 1.0,
              threshold: float = 0.5) -> Grid:
    """The grid of a map file, read by the loader its extension names (see :data:`EXTENSIONS`).

    ``unknown_risk`` applies to ROS maps and ``threshold`` to PNG images.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".map":
        return load_map(path, corner_cutting=corner_cutting)
    if suffix in (".yaml", ".yml"):
        return load_ros(path, unknown_risk=unknown_risk, corner_cutting=corner_cutting)
    if suffix == ".png":
        return load_png(path, threshold=threshold, corner_cutting=corner_cutting)
    if suffix == ".npy":
        return load_npy(path, corner_cutting=corner_cutting)
    if suffix == ".grid":
        return load_text(path, corner_cutting=corner_cutting)
    raise CbrError(f"{path}: expected a map file ending in {', '.join(EXTENSIONS)}, "
                   f"got {suffix or 'no extension'!r}")
