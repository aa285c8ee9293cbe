"""Learning the index weights w_f from outcomes: the introspective step 004 leaves open.

The survey (000, section 3.3) says RUPART's introspective learning "focuses on changes to the
indexing criteria based on retrieval failures: ... altering the weights used for similarity
assessment". Our rule, after each installed case's spell: the features that called the case
similar (a per-feature distance below the spell's mean) share the credit or the blame. With
``d_f`` the per-feature distances the retrieval reported and ``m`` their mean over the features
both sides specified::

    w_f <- w_f * exp(+rate * (m - d_f))     after a good spell
    w_f <- w_f * exp(-rate * (m - d_f))     after a bad one

so a feature that matched well is trusted more when the case worked and less when it misled;
features the case left unspecified are untouched. The weights are then clipped to
``[LOW, HIGH]`` and rescaled to mean 1, so the learned weights stay comparable with the fixed
default (all 1). They live in the case base's metadata under :data:`KEY`, written inside the
learn step's transaction: every process sharing the case base reads what the last committed
step wrote and updates it, so concurrent learners compose their updates instead of losing
them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from cbr_behaviors.index import FEATURES
from cbrcore.casebase.store import CaseStore

KEY = "rupart.weights"
"""The case base metadata key of the learned weights: a mapping feature -> weight."""
LOW = 0.05
"""The least a learned weight may become: a feature is never switched off for good."""
HIGH = 20.0
"""The most a learned weight may become (before rescaling to mean 1)."""


def stored_weights(store: CaseStore) -> np.ndarray | None:
    """The learned weights in ``store`` as a vector in :data:`FEATURES` order, or None when
    none were learned (or what is stored is not a mapping of finite non-negative numbers)."""
    data = store.get_meta(KEY)
    if not isinstance(data, Mapping):
        return None
    values = [data.get(f, 1.0) for f in FEATURES]
    if not all(isinstance(v, int | float) and math.isfinite(v) and v >= 0 for v in values):
        return None
    return np.asarray(values, dtype=np.float64)


def updated(weights: np.ndarray, distances: Mapping[str, float], good: bool,
            rate: float) -> np.ndarray:
    """``weights`` after one spell whose case matched with per-feature ``distances``."""
    known = [(FEATURES.index(f), d) for f, d in distances.items()
             if f in FEATURES and math.isfinite(d)]
    new = np.array(weights, dtype=np.float64)
    if len(known) < 2:
        return new
    mean = sum(d for _, d in known) / len(known)
    sign = 1.0 if good else -1.0
    for k, d in known:
        new[k] *= math.exp(sign * rate * (mean - d))
    new = np.clip(new, LOW, HIGH)
    return new / new.mean()


def store_weights(store: CaseStore, weights: np.ndarray) -> None:
    """Write ``weights`` into ``store``'s metadata (call inside its transaction)."""
    store.set_meta(KEY, {f: round(float(w), 6) for f, w in zip(FEATURES, weights, strict=True)})
