"""Loaders for the Moving AI grid benchmark formats: ``.map`` grids and ``.scen`` scenarios.

A map file is ``type octile``, ``height H``, ``width W``, ``map`` and H rows of W characters,
row y holding cells (0, y) .. (W-1, y). ``.``, ``G`` and ``S`` are passable ground (risk 0);
``@``, ``O``, ``T`` and ``W`` are blocked (risk 1). A scenario file is ``version 1`` (or
``1.0``) and one line per problem: bucket, map, W, H, start x, y, goal x, y, optimal length,
separated by tabs or spaces. Line ends may be LF or CRLF. Every error names the file and line
and says what was expected there; it quotes numbers it read but never other text of the file,
which may not be a map at all (a configuration naming the wrong file must not print it).
"""

from __future__ import annotations

import re
from decimal import Decimal, InvalidOperation
from pathlib import Path

import attrs
import numpy as np

from cbr_grid.grid import Grid
from cbr_grid.query import Cell
from cbrcore.documents import read_bytes
from cbrcore.errors import CbrError

PASSABLE = ".GS"
BLOCKED = "@OTW"

_RISK = np.full(256, np.nan)
_RISK[np.frombuffer(PASSABLE.encode(), dtype=np.uint8)] = 0.0
_RISK[np.frombuffer(BLOCKED.encode(), dtype=np.uint8)] = 1.0


def _lines(path: Path) -> list[bytes]:
    try:
        data = read_bytes(path)
    except OSError as exc:
        raise CbrError(f"{path}: cannot read: {exc.strerror or exc}") from exc
    # bytes.splitlines splits on LF, CRLF and CR only, unlike str.splitlines
    return data.splitlines()


def _text(line: bytes) -> str:
    return line.decode("ascii", errors="backslashreplace")


def _header(path: Path, lines: list[bytes], number: int, key: str, expected: str) -> str:
    """The value of header line ``number`` (1-based), which must be ``key value``; ``expected``
    says what the line should hold."""
    if number > len(lines):
        raise CbrError(f"{path}, line {number}: expected {expected}, the file ends")
    words = _text(lines[number - 1]).split()
    if len(words) != 2 or words[0] != key:
        raise CbrError(f"{path}, line {number}: expected {expected}")
    return words[1]


def _size(path: Path, lines: list[bytes], number: int, key: str) -> int:
    expected = f"'{key}' followed by a positive integer"
    value = _header(path, lines, number, key, expected)
    # a number of more digits than a size can have is refused before Python converts it
    if not value.isdigit() or len(value) > _DIGITS or int(value) < 1:
        got = f", got {value!r}" if value.isdigit() and len(value) <= _DIGITS else ""
        raise CbrError(f"{path}, line {number}: expected {expected}{got}")
    return int(value)


def load_map(path: str | Path, *, corner_cutting: bool = False) -> Grid:
    """The grid of a Moving AI ``.map`` file."""
    path = Path(path)
    lines = _lines(path)
    header = "the Moving AI header 'type octile'"
    if _header(path, lines, 1, "type", header) != "octile":
        raise CbrError(f"{path}, line 1: expected {header}")
    height = _size(path, lines, 2, "height")
    width = _size(path, lines, 3, "width")
    if len(lines) < 4:
        raise CbrError(f"{path}, line 4: expected 'map', got the end of the file")
    if _text(lines[3]).strip() != "map":
        raise CbrError(f"{path}, line 4: expected 'map'")
    rows = lines[4:4 + height]
    if len(rows) < height:
        raise CbrError(f"{path}, line {5 + len(rows)}: expected {height} map rows (height "
                       f"{height}), the file ends after {len(rows)}")
    lengths = np.fromiter((len(r) for r in rows), dtype=np.int64, count=height)
    wrong = np.flatnonzero(lengths != width)
    if len(wrong):
        y = int(wrong[0])
        raise CbrError(f"{path}, line {5 + y}: expected a row of {width} characters (width "
                       f"{width}), got {lengths[y]}")
    extra = [i for i, line in enumerate(lines[4 + height:], 5 + height) if line.strip()]
    if extra:
        raise CbrError(f"{path}, line {extra[0]}: expected the end of the map after {height} rows "
                       f"(height {height}), got more text")
    codes = np.frombuffer(b"".join(rows), dtype=np.uint8).reshape(height, width)
    risk = _RISK[codes]
    unknown = np.isnan(risk)
    if unknown.any():
        y, x = (int(i) for i in np.argwhere(unknown)[0])
        raise CbrError(f"{path}, line {5 + y}: unknown map character at column {x + 1}; "
                       f"expected one of {' '.join(PASSABLE)} (passable) or "
                       f"{' '.join(BLOCKED)} (blocked)")
    return Grid(risk, corner_cutting=corner_cutting)


@attrs.frozen
class Scenario:
    """One Moving AI problem: plan from ``start`` to ``goal`` on the named map.

    ``optimal`` is the published shortest 8-connected length without corner cutting;
    ``precision`` is half a unit in the last digit printed for it. ``line`` is the line of the
    ``.scen`` file it was read from (0 for one made otherwise), for errors about the problem;
    it takes no part in comparisons, so the same problem read from two files compares equal.
    """

    bucket: int
    map_name: str
    width: int
    height: int
    start: Cell
    goal: Cell
    optimal: float
    precision: float
    line: int = attrs.field(default=0, eq=False)

    def agrees(self, length: float) -> bool:
        """Whether ``length`` could have been printed as ``optimal``.

        Some files round and others truncate (the MAPF and city files print 31.28427124 for
        31.2842712474...), so a length agrees when it is within one unit in the last printed
        digit, twice ``precision``. A relative margin of 1e-9 more absorbs the error some files
        accumulated summing inexact step lengths (Berlin_1_256 prints 315.30360718 for a
        length of at least 315.3036072312).
        """
        margin = 2 * self.precision + 1e-9 * max(1.0, self.optimal)
        return abs(length - self.optimal) <= margin


_INTEGER = re.compile(r"-?[0-9]+")
_LONGEST = Decimal("1e300")
_FIELDS = "bucket map width height start_x start_y goal_x goal_y optimal"

_DIGITS = 18
"""The most digits a size or coordinate may have: any such number fits in 64 bits."""


def _integer(path: Path, number: int, name: str, value: str) -> int:
    if not _INTEGER.fullmatch(value) or len(value.lstrip("+-")) > _DIGITS:
        raise CbrError(f"{path}, line {number}: expected an integer {name} of at most "
                       f"{_DIGITS} digits")
    return int(value)


def _scenario(path: Path, number: int, line: str) -> Scenario:
    fields = line.split()
    if len(fields) != 9:
        raise CbrError(f"{path}, line {number}: expected 9 fields ({_FIELDS}), "
                       f"got {len(fields)}")
    bucket = _integer(path, number, "bucket", fields[0])
    width, height, sx, sy, gx, gy = (
        _integer(path, number, name, value) for name, value in
        zip(_FIELDS.split()[2:8], fields[2:8], strict=True))
    if width < 1 or height < 1:
        raise CbrError(f"{path}, line {number}: expected a positive map size, "
                       f"got {width}x{height}")
    for what, x, y in (("start", sx, sy), ("goal", gx, gy)):
        if not (0 <= x < width and 0 <= y < height):
            raise CbrError(f"{path}, line {number}: {what} ({x}, {y}) is outside the "
                           f"{width}x{height} map")
    try:
        written = Decimal(fields[8])
    except InvalidOperation:
        written = None
    if written is None:
        # not a number: the field is quoted only when it reads as one
        raise CbrError(f"{path}, line {number}: expected a non-negative optimal length")
    if not written.is_finite() or written < 0:
        raise CbrError(f"{path}, line {number}: expected a non-negative optimal length, "
                       f"got {fields[8]!r}")
    # a finite Decimal's exponent is the power of ten of its last written digit
    exponent = int(written.as_tuple().exponent)
    if written >= _LONGEST or exponent >= 300:
        # a float holds at most 1.8e308 and 10.0 ** exponent overflows past 308; no grid has a
        # path anywhere near that long (0e400 is refused too: its precision would overflow)
        raise CbrError(f"{path}, line {number}: expected an optimal length below 1e300, "
                       f"got {fields[8]!r}")
    return Scenario(bucket, fields[1], width, height, (sx, sy), (gx, gy), float(written),
                    0.5 * 10.0 ** exponent, number)


def load_scen(path: str | Path, grid: Grid | None = None) -> list[Scenario]:
    """The scenarios of a Moving AI ``.scen`` file, checked against ``grid``'s size if given."""
    path = Path(path)
    lines = [_text(line) for line in _lines(path)]
    if not lines or lines[0].split() not in (["version", "1"], ["version", "1.0"]):
        got = ", got an empty file" if not lines else ""
        raise CbrError(f"{path}, line 1: expected 'version 1' or 'version 1.0'{got}")
    scenarios = []
    for number, line in enumerate(lines[1:], 2):
        if not line.strip():
            continue
        scenario = _scenario(path, number, line)
        if grid is not None and (scenario.width, scenario.height) != (grid.width, grid.height):
            raise CbrError(f"{path}, line {number}: the scenario is for a {scenario.width}x"
                           f"{scenario.height} map, the given map is {grid.width}x{grid.height}")
        scenarios.append(scenario)
    return scenarios
