"""Probabilistic selection among the candidate paths (Kruusmaa & Svensson).

"Each path is selected as a solution with some probability ... the lower the cost, the higher
the probability": the papers give no formula, so three rules are offered, each a function of the
candidates' costs F_1..F_k with a temperature T > 0:

``boltzmann`` (default)
    p_i ∝ exp(-(F_i - F_min) / T): the softmax of the negated costs. With the default ratio cost
    (1 for an ideal path) T is in units of the ideal cost: T = 0.1 makes a path 0.1 costlier
    e ≈ 2.7 times less likely.
``inverse``
    p_i ∝ F_i^(-1/T): at T = 1 a path is chosen in inverse proportion to its cost.
``greedy``
    the cheapest path, eq. (5) as written (ties share the probability).

Exploration is separate: with probability ``explore`` no case is chosen and the fallback solver
plans a new path, which keeps the robot learning when the world changes.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

Rule = Literal["boltzmann", "inverse", "greedy"]


def probabilities(costs: np.ndarray, rule: Rule, temperature: float) -> np.ndarray:
    """The probability of choosing each candidate of cost ``costs`` (finite, positive for
    ``inverse``) under ``rule``; they sum to 1."""
    costs = np.asarray(costs, dtype=float)
    if rule == "greedy":
        weights = (costs == costs.min()).astype(float)
    elif rule == "boltzmann":
        weights = np.exp(-(costs - costs.min()) / temperature)
    elif rule == "inverse":
        # relative to the cheapest, so that a low temperature cannot overflow
        weights = (costs.min() / costs) ** (1.0 / temperature)
    else:
        raise ValueError(f"unknown selection rule {rule!r}; expected boltzmann, inverse or greedy")
    return weights / weights.sum()
