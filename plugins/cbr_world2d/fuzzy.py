"""Triangular fuzzy numbers and their similarity (002 section 3, Figure 3).

A measured distance or angle is a :class:`Triangle` ``(low, peak, high)``: membership 1 at the
peak, falling linearly to 0 at ``low`` and ``high``. Two measures are as similar as the height
of the intersection of their triangles, ``max_x min(a(x), b(x))`` (:func:`overlap`), computed
in closed form: with ``a.peak <= b.peak`` the maximum sits where ``a``'s falling edge crosses
``b``'s rising edge, at height ``(a.high - b.low) / ((a.high - a.peak) + (b.peak - b.low))``
clipped to ``[0, 1]`` (1 when the peaks coincide).

Angles wrap at +-pi, so two angle triangles are compared after shifting the second by the
multiple of 2 pi that brings its peak nearest to the first's (:func:`angle_overlap`): a bearing
of 179 degrees and one of -179 degrees are 2 degrees apart, not 358. A triangle's support is
never wrapped, so a bearing triangle near +-pi may reach past it; :func:`angle_contains` reads
containment the same way.
"""

from __future__ import annotations

import math

import attrs
import numpy as np

TWO_PI = 2.0 * math.pi


def wrap_angle(angle: float) -> float:
    """``angle`` wrapped into (-pi, pi]."""
    return angle - TWO_PI * math.ceil((angle - math.pi) / TWO_PI)


def _ordered(instance: Triangle, attribute: attrs.Attribute, value: float) -> None:
    if not all(math.isfinite(v) for v in (instance.low, instance.peak, instance.high)):
        raise ValueError(f"a triangle's corners must be finite, not {instance!r}")
    if not instance.low <= instance.peak <= instance.high:
        raise ValueError(f"a triangle needs low <= peak <= high, not {instance!r}")


@attrs.frozen
class Triangle:
    """A triangular fuzzy number: membership 0 at ``low``, 1 at ``peak``, 0 at ``high``."""

    low: float = attrs.field(converter=float)
    peak: float = attrs.field(converter=float)
    high: float = attrs.field(converter=float, validator=_ordered)

    @classmethod
    def around(cls, peak: float, below: float, above: float | None = None) -> Triangle:
        """The triangle peaking at ``peak`` whose support reaches ``below`` under it and
        ``above`` (default: ``below``) over it."""
        return cls(peak - below, peak, peak + (below if above is None else above))

    @property
    def support(self) -> tuple[float, float]:
        return self.low, self.high

    @property
    def spread(self) -> float:
        """Width of the support."""
        return self.high - self.low

    def contains(self, x: float) -> bool:
        """Whether ``x`` lies in the support ``[low, high]``."""
        return self.low <= x <= self.high

    def membership(self, x: float) -> float:
        """The degree in [0, 1] to which ``x`` is this number."""
        if x < self.low or x > self.high:
            return 0.0
        if x < self.peak:
            return (x - self.low) / (self.peak - self.low)
        if x > self.peak:
            return (self.high - x) / (self.high - self.peak)
        return 1.0

    def shifted(self, by: float) -> Triangle:
        return Triangle(self.low + by, self.peak + by, self.high + by)

    def as_tuple(self) -> tuple[float, float, float]:
        return self.low, self.peak, self.high


def unchecked(low: float, peak: float, high: float) -> Triangle:
    """A :class:`Triangle` built without conversion or validation, for hot loops whose corners
    are floats already known to be ordered and finite (about half the cost)."""
    triangle = object.__new__(Triangle)
    object.__setattr__(triangle, "low", low)
    object.__setattr__(triangle, "peak", peak)
    object.__setattr__(triangle, "high", high)
    return triangle


def _height(a1: float, a2: float, a3: float, b1: float, b2: float, b3: float) -> float:
    if a2 > b2:
        a1, a2, a3, b1, b2, b3 = b1, b2, b3, a1, a2, a3
    if a2 == b2:
        return 1.0
    if a3 <= b1:
        return 0.0
    # a2 < b2 and a3 > b1 make the denominator positive: (a3 - b1) + (b2 - a2) > 0.
    return min(1.0, (a3 - b1) / ((a3 - a2) + (b2 - b1)))


def overlap(a: Triangle, b: Triangle) -> float:
    """Similarity of two fuzzy numbers: the height of their intersection (002 Figure 3)."""
    return _height(a.low, a.peak, a.high, b.low, b.peak, b.high)


def nearest_turn(reference: float, angle: float) -> float:
    """The multiple of 2 pi that, added to ``angle``, brings it nearest to ``reference``."""
    return TWO_PI * round((reference - angle) / TWO_PI)


def angle_overlap(a: Triangle, b: Triangle) -> float:
    """:func:`overlap` of two angle triangles after shifting ``b`` by the multiple of 2 pi that
    brings its peak nearest to ``a``'s."""
    return overlap(a, b.shifted(nearest_turn(a.peak, b.peak)))


def angle_contains(triangle: Triangle, angle: float) -> bool:
    """Whether ``angle`` (or one of its turns by 2 pi) lies in the triangle's support."""
    return triangle.contains(angle + nearest_turn(triangle.peak, angle))


def overlap_arrays(a: np.ndarray, b: np.ndarray, angular: bool = False) -> np.ndarray:
    """:func:`overlap` row by row for ``(n, 3)`` arrays of ``low, peak, high`` (broadcasting
    like numpy); ``angular`` compares them as :func:`angle_overlap` does."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if angular:
        shift = TWO_PI * np.round((a[..., 1] - b[..., 1]) / TWO_PI)
        b = b + shift[..., None]
    a, b = np.broadcast_arrays(a, b)
    swap = a[..., 1] > b[..., 1]
    left = np.where(swap[..., None], b, a)
    right = np.where(swap[..., None], a, b)
    a2, a3 = left[..., 1], left[..., 2]
    b1, b2 = right[..., 0], right[..., 1]
    reach = a3 - b1
    denominator = (a3 - a2) + (b2 - b1)
    with np.errstate(divide="ignore", invalid="ignore"):
        height = np.where(reach > 0.0, reach / np.where(denominator > 0.0, denominator, 1.0),
                          0.0)
    height = np.clip(height, 0.0, 1.0)
    return np.where(a2 == b2, 1.0, height)
