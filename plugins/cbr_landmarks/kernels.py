"""The compiled branch and bound of 002 section 3.2 and the fuzzy overlaps it reads.

:func:`match_case` finds, for one stored graph, the best reference pair and matching (see
:mod:`cbr_landmarks.similarity` for the definitions); :func:`match_rows` runs it over many stored
graphs in one call. They take the flat arrays of :func:`cbr_landmarks.similarity.flattened`.
This module is imported where graphs are first matched, not when the plugin loads.
"""

from __future__ import annotations

import numpy as np

from cbr_kernels import njit
from cbr_world2d.fuzzy import TWO_PI

EPSILON = 1e-12
"""Slack of every pruning comparison: a bound summed in another order than the score it bounds
may differ from it in the last bits, and must not prune the optimum for that."""




@njit(inline="always")
def coded_normaliser(na: int, nb: int, normalise: int) -> int:
    """:func:`cbr_landmarks.similarity.normaliser` with ``normalise`` an index into
    :data:`~cbr_landmarks.similarity.NORMALISE`."""
    if normalise == 1:
        return nb - 1
    if normalise == 2:
        return na - 1
    return max(na, nb) - 1


@njit(inline="always")
def height(a1: float, a2: float, a3: float, b1: float, b2: float, b3: float) -> float:
    """:func:`cbr_world2d.fuzzy.overlap` of two triangles given by their corners, the same
    arithmetic written with selects instead of branches so that loops over many pairs run on
    SIMD lanes."""
    swap = a2 > b2
    l2 = b2 if swap else a2
    l3 = b3 if swap else a3
    r1 = a1 if swap else b1
    r2 = a2 if swap else b2
    reach = l3 - r1
    # the peaks differ and reach > 0 make the denominator positive; otherwise it is not used
    denominator = (l3 - l2) + (r2 - r1)
    h = min(1.0, reach / (denominator if denominator > 0.0 else 1.0))
    h = h if reach > 0.0 else 0.0
    return 1.0 if a2 == b2 else h


@njit(inline="always")
def pair_similarity(d1: float, d2: float, d3: float, a1: float, a2: float, a3: float,
                    e1: float, e2: float, e3: float, b1: float, b2: float, b3: float) -> float:
    """``sim`` of two pairs given by their distance triangles ``d, e`` and angle triangles
    ``a, b``: the angle ``b`` is turned to the nearest of ``a``'s peak, as
    :func:`cbr_world2d.fuzzy.angle_overlap` does (numba's ``round`` halves to even, as
    Python's)."""
    shift = TWO_PI * round((a2 - b2) / TWO_PI)
    return 0.5 * (height(d1, d2, d3, e1, e2, e3)
                  + height(a1, a2, a3, b1 + shift, b2 + shift, b3 + shift))


@njit(inline="always")
def _similarity(da: np.ndarray, aa: np.ndarray, p: int, db: np.ndarray, ab: np.ndarray,
                q: int) -> float:
    """:func:`pair_similarity` of row ``p`` of ``da, aa`` and row ``q`` of ``db, ab``."""
    return pair_similarity(da[p, 0], da[p, 1], da[p, 2], aa[p, 0], aa[p, 1], aa[p, 2],
                           db[q, 0], db[q, 1], db[q, 2], ab[q, 0], ab[q, 1], ab[q, 2])


@njit(inline="always")
def _allowed_pair(i: int, j: int, adj_a: np.ndarray, adj_b: np.ndarray, base_b: int,
                  matched_a: np.ndarray, matched_b: np.ndarray, count: int,
                  constraint: int) -> bool:
    """Whether matching ``i`` to ``j`` keeps the obstacle constraint with the ``count``
    matched pairs ``matched_a[k] -> matched_b[k]``."""
    if constraint == 2:
        return True
    row_a = adj_a[i]
    row_b = adj_b[base_b + j]
    for k in range(count):
        in_a = (row_a >> matched_a[k]) & 1
        in_b = (row_b >> matched_b[k]) & 1
        if in_a > in_b or (constraint == 1 and in_b > in_a):
            return False
    return True


@njit(inline="always")
def _top_sum(values: np.ndarray, count: int, q: int) -> float:
    """The sum of the ``q`` largest of ``values[:count]`` (which it reorders)."""
    total = 0.0
    if q >= count:
        for k in range(count):
            total += values[k]
        return total
    for k in range(q):
        top = k
        for e in range(k + 1, count):
            if values[e] > values[top]:
                top = e
        values[k], values[top] = values[top], values[k]
        total += values[k]
    return total


@njit(inline="always")
def _rest(depth: int, m: int, order: np.ndarray, cands: np.ndarray, ncand: np.ndarray,
          s: np.ndarray, used: int, need: int, buffer: np.ndarray) -> float:
    """What the landmarks from ``depth`` on could still add when ``need`` more are matched:
    the ``need`` largest of each one's best similarity to a landmark of ``B`` not ``used``
    (its candidates are sorted best first, so the first unused one gives it). Admissible: it
    drops the injectivity among them and the constraint."""
    count = 0
    for d in range(depth, m):
        i = order[d]
        for k in range(ncand[d]):
            j = cands[d, k]
            if (used >> j) & 1 == 0:
                buffer[count] = s[i, j]
                count += 1
                break
    return _top_sum(buffer, count, need)


@njit
def match_case(da: np.ndarray, aa: np.ndarray, adj_a: np.ndarray, na: int, db: np.ndarray,
               ab: np.ndarray, adj_b: np.ndarray, pair_b: int, base_b: int, nb: int,
               matching: int, normalise: int, constraint: int, threshold: float,
               references: np.ndarray, sims: np.ndarray, fwork: np.ndarray, iwork: np.ndarray,
               mapping: np.ndarray) -> tuple[float, int, int, int]:
    """002's branch and bound between the situation ``A`` and one case ``B``.

    ``A`` is ``da, aa`` (its triangles flattened to ``(na * na, 3)``, pair ``(u, v)`` in row
    ``u * na + v``) and ``adj_a`` (bit ``v`` of ``adj_a[u]`` set when an obstacle joins them);
    ``B``'s triangles start at row ``pair_b`` of ``db, ab`` and its adjacency at ``base_b`` of
    ``adj_b``. ``matching``, ``normalise`` and ``constraint`` index
    :data:`cbr_landmarks.similarity.MATCHING`, :data:`~cbr_landmarks.similarity.NORMALISE` and
    :data:`~cbr_landmarks.similarity.CONSTRAINT`.
    Only the reference pairs ``(ra, rb)`` with ``references[ra, rb]`` set are tried (the
    retrieval index rules the others out). ``sims`` ``(na * nb, na, nb)``, ``fwork``
    ``(na * nb + 4 na + nb,)`` and ``iwork`` ``(9 + na, max(na, nb))`` (int) are scratch, at least
    that large.

    Every matching tried matches ``min(na, nb) - 1`` landmarks besides the references: all of
    the smaller graph's, so that only the larger one's extra landmarks stay out (``paper``:
    the counts must be equal, and the matching is a bijection). The obstacle constraint holds
    for every matched pair.

    Returns ``(similarity, ra, rb, nodes)`` and writes the matching into ``mapping[:na]``;
    the similarity is -1 (and ``mapping`` untouched) when no matching reaches ``threshold``.
    """
    if matching == 1 and na != nb:
        return -1.0, -1, -1, 0
    n = coded_normaliser(na, nb, normalise)
    target = threshold * n
    # how many landmarks of A a matching leaves out: those beyond B's count (spare[d]: how
    # many may still be left out at depth d)
    skips = na - min(na, nb)
    # every matched landmark scores at most 1 and at most min(na, nb) - 1 are matched
    if min(na, nb) - 1 < target - EPSILON:
        return -1.0, -1, -1, 0
    m = na - 1
    pairs = na * nb
    bounds = fwork[:pairs]
    partial = fwork[pairs:pairs + na]
    frees = fwork[pairs + na:pairs + 2 * na]
    keys = fwork[pairs + 2 * na:pairs + 3 * na]
    tops = fwork[pairs + 3 * na:pairs + 4 * na]
    columns = fwork[pairs + 4 * na:pairs + 4 * na + nb]
    order = iwork[0]
    ncand = iwork[1]
    chosen = iwork[2]
    pointer = iwork[3]
    matched_a = iwork[4]
    matched_b = iwork[5]
    count = iwork[6]
    best_map = iwork[7]
    spare = iwork[8]
    cands = iwork[9:]
    nodes = 0
    best = -1.0
    best_ra = -1
    best_rb = -1
    # 002's heuristic h for every reference pair, the sum of each landmark's best similarity,
    # made tighter where only q of them are matched: the q largest, and no more than the q
    # largest of B's landmarks' best. A pair is given up part way once one per landmark still
    # to add cannot reach the threshold.
    q = min(na, nb) - 1
    for ra in range(na):
        for rb in range(nb):
            p = ra * nb + rb
            bounds[p] = -1.0
            if not references[ra, rb]:
                continue
            s = sims[p]
            h = 0.0
            left = m
            columns[:nb] = 0.0
            for i in range(na):
                if i == ra:
                    continue
                top = 0.0
                for j in range(nb):
                    value = 0.0
                    if j != rb:
                        value = _similarity(da, aa, ra * na + i, db, ab, pair_b + rb * nb + j)
                    s[i, j] = value
                    top = max(top, value)
                    columns[j] = max(columns[j], value)
                tops[m - left] = top
                h += top
                left -= 1
                if h + left < target - EPSILON:
                    break
            else:
                bounds[p] = min(_top_sum(tops, m, q), _top_sum(columns, nb, q))
    # the pairs best bound first, so that a good matching is found early and prunes the rest
    visit = np.argsort(-bounds, kind="mergesort")
    for t in range(pairs):
        p = visit[t]
        h = bounds[p]
        if h < 0.0 or h <= best + EPSILON or h < target - EPSILON:
            break
        ra = p // nb
        rb = p - ra * nb
        s = sims[p]
        # A's other landmarks best first, and each one's candidates best first
        d = 0
        for i in range(na):
            if i == ra:
                continue
            top = 0.0
            for j in range(nb):
                top = max(top, s[i, j])
            e = d
            while e > 0 and keys[e - 1] < top:
                keys[e] = keys[e - 1]
                order[e] = order[e - 1]
                e -= 1
            keys[e] = top
            order[e] = i
            d += 1
        for d in range(m):
            i = order[d]
            k = 0
            for j in range(nb):
                value = s[i, j]
                if j != rb:
                    e = k
                    while e > 0 and s[i, cands[d, e - 1]] < value:
                        cands[d, e] = cands[d, e - 1]
                        e -= 1
                    cands[d, e] = j
                    k += 1
            ncand[d] = k
        nodes += 1
        matched_a[0] = ra
        matched_b[0] = rb
        count[0] = 1
        used = 1 << rb
        d = 0
        pointer[0] = 0
        partial[0] = 0.0
        spare[0] = skips
        frees[0] = _rest(1, m, order, cands, ncand, s, used, q, tops)
        while d >= 0:
            k = pointer[d]
            if k > ncand[d] or (k == ncand[d] and spare[d] == 0):
                d -= 1
                if d >= 0 and chosen[d] >= 0:
                    used &= ~(1 << chosen[d])
                continue
            pointer[d] = k + 1
            i = order[d]
            if k < ncand[d]:
                j = cands[d, k]
                if (used >> j) & 1:
                    continue
                gain = s[i, j]
                # candidates come best first: when this one cannot win, neither can a later
                # one nor leaving i unmatched
                reach = partial[d] + gain + frees[d]
                if reach <= best + EPSILON or reach < target - EPSILON:
                    pointer[d] = ncand[d] + 1
                    continue
                if not _allowed_pair(i, j, adj_a, adj_b, base_b, matched_a, matched_b,
                                     count[d], constraint):
                    continue
                rest = _rest(d + 1, m, order, cands, ncand, s, used | (1 << j),
                             q - count[d], tops)
            else:
                # i left out, as one of A's landmarks beyond B's count
                j = -1
                gain = 0.0
                rest = frees[d]
            score = partial[d] + gain
            bound = score + rest
            if bound <= best + EPSILON or bound < target - EPSILON:
                continue
            nodes += 1
            chosen[d] = j
            if d == m - 1:
                if score >= target:
                    best, best_ra, best_rb = score, ra, rb
                    best_map[:na] = -1
                    best_map[ra] = rb
                    for e in range(d + 1):
                        best_map[order[e]] = chosen[e]
                continue
            c = count[d]
            spare[d + 1] = spare[d]
            if j >= 0:
                used |= 1 << j
                matched_a[c] = i
                matched_b[c] = j
                c += 1
            else:
                spare[d + 1] -= 1
            count[d + 1] = c
            partial[d + 1] = score
            d += 1
            pointer[d] = 0
            frees[d] = _rest(d + 1, m, order, cands, ncand, s, used, q - (count[d] - 1), tops)
    if best < 0.0 or best / n < threshold:
        return -1.0, -1, -1, nodes
    mapping[:na] = best_map[:na]
    return best / n, best_ra, best_rb, nodes


@njit
def match_rows(da: np.ndarray, aa: np.ndarray, adj_a: np.ndarray, na: int, rows: np.ndarray,
               references: np.ndarray, bounds: np.ndarray, limit: int, counts: np.ndarray,
               pair_starts: np.ndarray, key_start: np.ndarray, db: np.ndarray, ab: np.ndarray,
               adj_b: np.ndarray, matching: int, normalise: int, constraint: int,
               threshold: float, similarity: np.ndarray, reference: np.ndarray,
               mapping: np.ndarray, nodes: np.ndarray) -> None:
    """:func:`match_case` between ``A`` and each graph ``rows[k]`` of a list of graphs
    flattened together (graph ``r`` has ``counts[r]`` landmarks, its pairs start at row
    ``pair_starts[r]`` of ``db, ab``, its landmarks at ``key_start[r]`` of ``adj_b``), trying the
    reference pairs ``references[k]``; the results go to row ``k`` of the outputs.

    With a ``limit`` over 0 only the best ``limit`` graphs are wanted: ``bounds[k]`` bounds
    the similarity of graph ``rows[k]``, the graphs are matched highest bound first, and once
    ``limit`` of them reach a similarity, that is the threshold of every later one (it must
    reach the ``limit``-th best to be among the best); the graphs whose bound is under it
    are not matched at all (similarity -1, nodes 0). Those left out score under the
    ``limit``-th best found, so the best ``limit`` of the outputs are those of every graph."""
    width = max(na, counts.max())
    sims = np.empty((na * width, na, width))
    fwork = np.empty(na * width + 4 * na + width)
    iwork = np.empty((9 + na, width), dtype=np.int64)
    count = rows.shape[0]
    visit = np.argsort(-bounds, kind="mergesort") if limit > 0 else np.arange(count)
    # the best limit similarities so far, best first
    best = np.full(max(limit, 1), -1.0)
    floor = threshold
    for t in range(count):
        k = visit[t]
        if limit > 0 and bounds[k] < floor - EPSILON:
            for u in range(t, count):
                similarity[visit[u]] = -1.0
                nodes[visit[u]] = 0
            break
        r = rows[k]
        s, ra, rb, expanded = match_case(da, aa, adj_a, na, db, ab, adj_b, pair_starts[r],
                                         key_start[r], counts[r], matching, normalise,
                                         constraint, floor, references[k], sims, fwork,
                                         iwork, mapping[k])
        similarity[k] = s
        reference[k, 0] = ra
        reference[k, 1] = rb
        nodes[k] = expanded
        if limit > 0 and s > best[limit - 1]:
            e = limit - 1
            while e > 0 and best[e - 1] < s:
                best[e] = best[e - 1]
                e -= 1
            best[e] = s
            floor = max(threshold, best[limit - 1])
