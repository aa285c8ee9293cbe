"""attrs validators of the 2D world's numbers: finite, and on the right side of zero."""

from __future__ import annotations

import math

import attrs


def positive(instance: object, attribute: attrs.Attribute, value: float) -> None:
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{attribute.name} must be a finite number > 0, not {value!r}")


def non_negative(instance: object, attribute: attrs.Attribute, value: float) -> None:
    if not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"{attribute.name} must be a finite number >= 0, not {value!r}")


def fraction(instance: object, attribute: attrs.Attribute, value: float) -> None:
    if not (0.0 <= value < 1.0):
        raise ValueError(f"{attribute.name} must lie in [0, 1), not {value!r}")
