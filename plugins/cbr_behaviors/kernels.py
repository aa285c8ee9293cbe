"""The compiled pass of :class:`cbr_behaviors.index.IndexTable`: every case's overall distance
to a query (and on request its per-feature ones), and the nearest few, in one call.

The formulas are those of :mod:`cbr_behaviors.index`, whose
:func:`~cbr_behaviors.index.feature_distances` and :func:`~cbr_behaviors.index.overall` are the
plain Python reference; the overall distance is summed in :data:`FEATURES` order as there, so
that both give the same numbers but for the last bits of a square root. The table's arrays are
feature-major (one row per feature component, one column per case) and every feature is one
loop over the cases with no branch in it, so that the loops run on SIMD lanes. This module is
imported when a table is first searched, not when the plugin loads.
"""

from __future__ import annotations

import math

import numpy as np

from cbr_behaviors.index import (
    FEATURES,
    FRACTIONS,
    POINTS,
    SETS,
    SONAR_BEAMS,
    SONAR_MAX,
    TERMS,
    VARIABLE_CODE,
)
from cbr_kernels import njit
from cbr_kernels.bits import popcount

SONAR_KIND, MOTORS_KIND, SET_KIND, POINT_KIND, TERM_KIND, FRACTION_KIND = range(6)
"""The kinds of feature, each with its own distance."""
KIND = tuple(SET_KIND if f in SETS else POINT_KIND if f in POINTS else TERM_KIND if f in TERMS
             else FRACTION_KIND if f in FRACTIONS else SONAR_KIND if f == "sonar"
             else MOTORS_KIND for f in FEATURES)
"""The kind of each feature, by its position in :data:`FEATURES`."""
SLOT = tuple(next(group.index(f) for group in (SETS, POINTS, TERMS, FRACTIONS, (f,))
                  if f in group) for f in FEATURES)
"""Each feature's position among its kind's (:data:`SETS`, :data:`POINTS`, :data:`TERMS`,
:data:`FRACTIONS`), which picks its rows of the table's arrays of that kind."""


@njit(inline="always")
def _case(rows: np.ndarray | None, i: int) -> int:
    """The case at position ``i`` of the pass: ``i`` itself when ``rows`` is None. The test is
    settled when the kernel is compiled for each type of ``rows``, so that a pass over every
    case reads the arrays in order, on SIMD lanes."""
    if rows is None:
        return i
    return rows[i]


@njit(inline="always")
def _add(f: int, i: int, d: float, both: bool, weight: float, d_sum: np.ndarray,
         w_sum: np.ndarray, per_feature: np.ndarray | None) -> None:
    """Adds feature ``f``'s distance ``d`` at position ``i`` to the weighted sums if the case
    and the query ``both`` specify it (adding 0 otherwise leaves the sums as skipping it
    would), and records it in ``per_feature`` when there is one."""
    d_sum[i] += weight * d if both else 0.0
    w_sum[i] += weight if both else 0.0
    if per_feature is not None:
        per_feature[f, i] = d if both else np.nan


@njit(error_model="numpy")
def score(n: int, rows: np.ndarray | None, specified: np.ndarray, sonar: np.ndarray,
          motors: np.ndarray, points: np.ndarray, fractions: np.ndarray, bits: np.ndarray,
          sizes: np.ndarray, terms: np.ndarray, lengths: np.ndarray, q_specified: np.ndarray,
          q_sonar: np.ndarray, q_motors: np.ndarray, q_points: np.ndarray,
          q_fractions: np.ndarray, q_bits: np.ndarray, q_sizes: np.ndarray,
          q_terms: np.ndarray, q_lengths: np.ndarray, weights: np.ndarray,
          location_scale: float, top_speed: float, top_turn_rate: float, k: int,
          total: np.ndarray, per_feature: np.ndarray | None, best: np.ndarray) -> int:
    """The overall distance to the query of the ``n`` cases ``rows`` (all the cases in order
    when None) into ``total``, their per-feature ones into ``per_feature`` ``(F, n)`` when
    given (NaN where either side leaves the feature out), and the positions in ``total`` of
    the ``k`` smallest (ties by case) into ``best``, smallest first; returns how many that is
    (``min(k, n)``).

    The table (``N`` cases): ``specified`` ``(F, N)``; ``sonar`` ``(16, N)``; ``motors``
    ``(2, N)``; ``points`` ``(2, 2, N)`` (:data:`POINTS`, x and y); ``fractions`` ``(16, N)``
    (:data:`FRACTIONS`); the sets (:data:`SETS`) as bitsets ``bits`` ``(3, W, N)`` over the
    table's names, with their sizes ``sizes`` ``(3, N)``; the terms (:data:`TERMS`) as atom
    codes ``terms`` ``(2, L, N)`` with their lengths ``lengths`` ``(2, N)``. The query's
    arrays are the same without the case axis, its sets' sizes counting the names no case has
    (they only widen the union) and its terms as long as they are (atoms no case has coded
    :data:`~cbr_behaviors.index.UNKNOWN_CODE`).
    """
    d_sum = np.zeros(n)
    w_sum = np.zeros(n)
    scratch = np.empty(n)
    counts = np.empty(n, dtype=np.int64)
    for f in range(len(FEATURES)):
        if not q_specified[f]:
            if per_feature is not None:
                per_feature[f, :] = np.nan
            continue
        kind = KIND[f]
        slot = SLOT[f]
        weight = weights[f]
        mask = specified[f]
        if kind == SONAR_KIND:
            scratch[:] = 0.0
            for b in range(SONAR_BEAMS):
                qb = q_sonar[b]
                column = sonar[b]
                for i in range(n):
                    diff = qb - column[_case(rows, i)]
                    scratch[i] += diff * diff
            for i in range(n):
                d = math.sqrt(scratch[i] / SONAR_BEAMS) / SONAR_MAX
                _add(f, i, d, mask[_case(rows, i)], weight, d_sum, w_sum, per_feature)
        elif kind == MOTORS_KIND:
            v, w = q_motors[0], q_motors[1]
            for i in range(n):
                r = _case(rows, i)
                dv = (v - motors[0, r]) / top_speed
                dw = (w - motors[1, r]) / top_turn_rate
                d = min(1.0, math.sqrt((dv * dv + dw * dw) / 2.0))
                _add(f, i, d, mask[r], weight, d_sum, w_sum, per_feature)
        elif kind == SET_KIND:
            counts[:] = 0
            for word in range(bits.shape[1]):
                qw = q_bits[slot, word]
                column = bits[slot, word]
                for i in range(n):
                    counts[i] += popcount(qw & column[_case(rows, i)])
            qn = q_sizes[slot]
            size = sizes[slot]
            for i in range(n):
                r = _case(rows, i)
                common = counts[i]
                union = qn + size[r] - common
                d = 1.0 - common / union if union > 0 else 0.0
                _add(f, i, d, mask[r], weight, d_sum, w_sum, per_feature)
        elif kind == POINT_KIND:
            x, y = q_points[slot, 0], q_points[slot, 1]
            for i in range(n):
                r = _case(rows, i)
                dx = x - points[slot, 0, r]
                dy = y - points[slot, 1, r]
                d = min(1.0, math.sqrt(dx * dx + dy * dy) / location_scale)
                _add(f, i, d, mask[r], weight, d_sum, w_sum, per_feature)
        elif kind == TERM_KIND:
            qn = q_lengths[slot]
            size = lengths[slot]
            for i in range(n):
                counts[i] = abs(qn - size[_case(rows, i)])
            for p in range(min(qn, terms.shape[1])):
                x = q_terms[slot, p]
                column = terms[slot, p]
                for i in range(n):
                    r = _case(rows, i)
                    y = column[r]
                    counts[i] += ((p < size[r]) & (x != y) & (x != VARIABLE_CODE)
                                  & (y != VARIABLE_CODE))
            for i in range(n):
                r = _case(rows, i)
                longest = max(qn, size[r])
                d = counts[i] / longest if longest > 0 else 0.0
                _add(f, i, d, mask[r], weight, d_sum, w_sum, per_feature)
        else:
            a = q_fractions[slot]
            column = fractions[slot]
            for i in range(n):
                r = _case(rows, i)
                _add(f, i, abs(a - column[r]), mask[r], weight, d_sum, w_sum, per_feature)
    for i in range(n):
        total[i] = d_sum[i] / w_sum[i] if w_sum[i] > 0.0 else 1.0
    found = 0
    bound = np.inf
    for i in range(n if k > 0 else 0):
        t = total[i]
        if t > bound:
            continue
        # the best k so far, kept sorted by (total, case) by insertion; ``rows`` need not be
        # sorted, so a total equal to the k-th's may still win by its case
        r = _case(rows, i)
        if found == k and t == bound and r > _case(rows, best[k - 1]):
            continue
        e = found if found < k else k - 1
        while e > 0:
            before = best[e - 1]
            if total[before] < t or (total[before] == t and _case(rows, before) < r):
                break
            best[e] = before
            e -= 1
        best[e] = i
        found = min(found + 1, k)
        if found == k:
            bound = total[best[k - 1]]
    return found
