"""How the pages write figures in prose: ranges, lists, rounded ratios, spreads, verdicts."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from .results import FiguresError


def grouped(value: float, digits: int = 0) -> str:
    """``value`` with thousands separated by commas, as the pages write large counts."""
    return f"{value:,.{digits}f}"


def span(values: Sequence[float], digits: int, unit: str = "") -> str:
    """``lo-hi`` of ``values`` at ``digits``, or the one value when both round alike."""
    lo, hi = f"{min(values):.{digits}f}", f"{max(values):.{digits}f}"
    return f"{lo}{unit}" if lo == hi else f"{lo}-{hi}{unit}"


def listed(parts: Sequence[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    if not parts:
        raise FiguresError("nothing to list")
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + f" and {parts[-1]}"


def about(value: float) -> str:
    """``value`` to two significant digits, as prose rounds a large ratio."""
    if value <= 0:
        raise FiguresError(f"expected a positive figure, got {value}")
    digits = 1 - math.floor(math.log10(value))
    return grouped(round(value, digits), max(0, digits))


def all_of(fraction: str) -> str:
    """A count out of a total written ``k/n`` in the results: ``all n``, or ``k of n``."""
    count, total = fraction.split("/")
    return f"all {total}" if count == total else f"{count} of {total}"


def goal(target: dict[str, Any]) -> str:
    """The figure of a target such as ``<= 1.0``."""
    return f"{float(target['goal'].split()[-1]):g}"


def verdict(met: bool) -> str:
    return "met" if met else "not met"


def pm(stats: dict[str, float | None], scale: float = 1.0, digits: int = 1,
       sign: bool = False) -> str:
    """``mean ± std`` of a spread over seeds, or ``-`` when no seed had the figure."""
    if stats["mean"] is None or stats["std"] is None:
        return "-"
    mean = f"{stats['mean'] * scale:{'+' if sign else ''}.{digits}f}"
    return f"{mean} ± {stats['std'] * scale:.{digits}f}"
