"""attrs validators of the 2D world's numbers: finite, and on the right side of zero; and the
way problems show those numbers."""

from __future__ import annotations

import math
from collections.abc import Sequence

import attrs

from cbrcore.documents import found


def number_text(value: float) -> str:
    """A number as an error shows it: integers without a decimal point, 15 digits at most."""
    try:
        return format(float(value), ".15g")
    except OverflowError:  # an integer past the largest float
        return found(value, setting=True)


def point_text(point: Sequence[float]) -> str:
    """A point (or bounds) as an error shows it: ``[x, y]``."""
    return f"[{', '.join(number_text(v) for v in point)}]"


def positive(instance: object, attribute: attrs.Attribute, value: float) -> None:
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{attribute.name} must be a finite number > 0, not {value!r}")


def non_negative(instance: object, attribute: attrs.Attribute, value: float) -> None:
    if not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"{attribute.name} must be a finite number >= 0, not {value!r}")


def fraction(instance: object, attribute: attrs.Attribute, value: float) -> None:
    if not (0.0 <= value < 1.0):
        raise ValueError(f"{attribute.name} must lie in [0, 1), not {value!r}")


MIN_DT = 1e-4
"""The shortest simulation step, in seconds: a robot moves micrometres a step below it, and a
trial of minutes takes millions of steps."""

MAX_DT = 1.0
"""The longest simulation step, in seconds: the robot drives up to its top speed blind between
two readings of its sensors, and the sonar's and the pilots' reactions assume far less."""

MAX_STEPS = 10_000_000
"""The most steps a trial may take (its timeout over its step): about 11 days of simulated
time in steps of 0.1 s, and hours of computing."""


def step(instance: object, attribute: attrs.Attribute, value: float) -> None:
    if not (MIN_DT <= value <= MAX_DT):
        raise ValueError(f"'{attribute.name}' must lie in [{MIN_DT:g}, {MAX_DT:g}] seconds, "
                         f"not {value!r}")


def too_many_steps(timeout: float, dt: float) -> str | None:
    """Why a trial of ``timeout`` seconds in steps of ``dt`` is too long to simulate, or None.
    """
    if timeout / dt <= MAX_STEPS:
        return None
    return (f"a timeout of {timeout:g} s in steps of {dt:g} s is more than the {MAX_STEPS} "
            "steps a trial may take (the limit, cbr_world2d.checks.MAX_STEPS)")

MAX_TRIALS = 100_000
"""The most trials one command or workload runs (a workload's listed and random trials times
its repeats): at a few seconds each, days of computing."""

MAX_FRAMES = 10_000
"""The most frames of an animation (``cbr sim run --gif``, ``cbr rupart day``): matplotlib
draws each, a fraction of a second apiece, and the GIF holds them all."""
