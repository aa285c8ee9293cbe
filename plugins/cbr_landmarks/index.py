"""Retrieval over every stored situation: flat arrays, a prefilter and one kernel call.

:class:`SituationIndex` holds the stored landmark graphs as flat arrays (their landmark counts,
the offsets of each graph's pairs and landmarks, the fuzzy distances and angles of every ordered
pair, the obstacles as bitmasks) so that :meth:`SituationIndex.search` runs 002's branch and
bound (:func:`cbr_landmarks.similarity.match_case`) over all the candidate graphs in one numba
call, with no Python per case.

The prefilter is exact. A case that reaches a threshold ``t > 1/2`` has a reference pair
``(ra, rb)`` and landmarks ``i, j`` whose similarity ``sim(i, j | ra, rb)`` is at least ``t``:
the score is a sum of at most ``N`` terms over ``N``, so its largest term is at least the score.
A term is the mean of two overlaps of at most 1 each, so both overlaps are at least ``2t - 1 >
0``, and two triangles overlap that much exactly when their cuts at that level (the intervals
where each is at least ``2t - 1``) intersect. So the index keeps, for every ordered pair
``(rb, j)`` of every stored graph, the box of its distance and angle cuts, sorted by the angle
cut's lower end, at a few fixed levels (:data:`LEVELS`); a search takes the highest level not
over ``2t - 1``, looks up for each ordered pair of the situation the stored boxes its box meets
(its angle turned by -2 pi, 0 and 2 pi, as :func:`cbr_world2d.fuzzy.angle_overlap` turns
angles) and runs the branch and bound on their graphs only. Level 0 is the triangles'
supports, 002's bare claim that some pair of supports must meet.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import attrs
import numba
import numpy as np

from cbr_landmarks.graph import MAX_LANDMARKS, LandmarkGraph
from cbr_landmarks.similarity import (
    CONSTRAINT,
    NORMALISE,
    Matching,
    SimilarityOptions,
    flattened,
    match_case,
    normaliser,
    pair_similarity,
)
from cbr_world2d.fuzzy import TWO_PI

LEAF = 8
"""Most stored pairs in a leaf of a tree."""
SLACK = 1e-9
"""How much the prefilter widens every comparison, so that rounding never drops a pair the
similarity itself would count."""
_STACK = 64


@attrs.frozen
class Found:
    """A stored graph that reached the threshold, and its best matching."""

    row: int
    """The graph's position in the list the index was built from."""
    matching: Matching


# --------------------------------------------------------------------------------------------
# the trees of stored pairs


@numba.njit(cache=True)
def _build_tree(tri: np.ndarray, perm: np.ndarray, start: int, end: int, node_range: np.ndarray,
                node_child: np.ndarray, node_box: np.ndarray, first_node: int,
                scale: np.ndarray) -> int:
    """A k-d tree over the pairs ``perm[start:end]`` (rows of ``tri``: distance low, peak,
    high, angle low, peak, high), split at the median peak of the wider dimension (measured
    in ``scale``, the typical support widths, so that splits cut where boxes are many); its
    nodes are written from ``first_node`` on. Returns the next free node."""
    stack = np.empty((_STACK, 2), dtype=np.int64)
    top = 0
    free = first_node + 1
    stack[0, 0] = first_node
    stack[0, 1] = -1
    node_range[first_node, 0] = start
    node_range[first_node, 1] = end
    top = 1
    while top > 0:
        top -= 1
        node = stack[top, 0]
        s, e = node_range[node, 0], node_range[node, 1]
        box = node_box[node]
        box[0] = box[1] = box[4] = box[5] = np.inf
        box[2] = box[3] = box[6] = box[7] = -np.inf
        for k in range(s, e):
            t = tri[perm[k]]
            box[0] = min(box[0], t[0])
            box[1] = min(box[1], t[1])
            box[2] = max(box[2], t[1])
            box[3] = max(box[3], t[2])
            box[4] = min(box[4], t[3])
            box[5] = min(box[5], t[4])
            box[6] = max(box[6], t[4])
            box[7] = max(box[7], t[5])
        if e - s <= LEAF:
            node_child[node] = -1
            continue
        axis = 1 if (box[2] - box[1]) / scale[0] >= (box[6] - box[5]) / scale[1] else 4
        keys = np.empty(e - s)
        for k in range(s, e):
            keys[k - s] = tri[perm[k], axis]
        perm[s:e] = perm[s:e][np.argsort(keys, kind="mergesort")]
        mid = (s + e) // 2
        left = free
        free += 2
        node_child[node] = left
        node_range[left, 0], node_range[left, 1] = s, mid
        node_range[left + 1, 0], node_range[left + 1, 1] = mid, e
        stack[top, 0] = left
        stack[top + 1, 0] = left + 1
        top += 2
    return free


# --------------------------------------------------------------------------------------------
# the prefilter


@numba.njit(cache=True)
def _vote(qd: np.ndarray, qa: np.ndarray, na: int, level: float, threshold: float,
          normalise: int, classes: np.ndarray, class_root: np.ndarray, node_range: np.ndarray,
          node_child: np.ndarray, node_box: np.ndarray, tri: np.ndarray, key: np.ndarray,
          key_row: np.ndarray, key_start: np.ndarray, counts: np.ndarray, stamp: np.ndarray,
          last: np.ndarray, current: np.ndarray, excess: np.ndarray,
          epoch: int) -> tuple[np.ndarray, np.ndarray, int, int]:
    """The reference pairs ``(ra, row, rb)`` whose bound reaches ``threshold`` (rows ``row,
    ra, rb`` of the first array), the number of stored pairs met and the next epoch.

    ``sigma = (1 + level) / 2 < threshold``. For each pair ``(ra, i)`` of the situation, the
    trees of the stored graphs of landmark counts ``classes`` yield the stored pairs ``(rb,
    j)`` whose cuts at ``level`` meet its own (so every pair of similarity ``sigma`` or more,
    and some below); every other pair scores below ``sigma``. So for the reference pair
    ``(ra, rb)`` each ``i`` adds at most ``max(sigma, best met similarity)``, at most ``q =
    min(na, nb) - 1`` landmarks are matched, and the pair can reach ``threshold`` only if
    ``sigma * q`` plus the sum of the ``i``'s excesses over ``sigma`` reaches ``threshold *
    N``. A stored landmark ``rb`` no pair met cannot: ``sigma * q < threshold * N``.
    ``stamp``, ``last``, ``current``, ``excess`` are scratch over the stored landmarks, reset
    lazily by ``epoch``.
    """
    sigma = 0.5 * (1.0 + level)
    keep = 1.0 - level
    out = np.empty((64, 3), dtype=np.int64)
    found = 0
    met = 0
    touched = np.empty(stamp.shape[0], dtype=np.int64)
    stack = np.empty(_STACK, dtype=np.int64)
    for ra in range(na):
        epoch += 1
        ntouched = 0
        for i in range(na):
            if i == ra:
                continue
            p = ra * na + i
            d1, d2, d3 = qd[p, 0], qd[p, 1], qd[p, 2]
            a1, a2, a3 = qa[p, 0], qa[p, 1], qa[p, 2]
            dlo = d1 + level * (d2 - d1) - SLACK
            dhi = d3 - level * (d3 - d2) + SLACK
            for turn in (-TWO_PI, 0.0, TWO_PI):
                # the stored angles turned by ``turn`` against the situation's
                alo = a1 + level * (a2 - a1) - SLACK - turn
                ahi = a3 - level * (a3 - a2) + SLACK - turn
                for c in classes:
                    stack[0] = class_root[c]
                    top = 1
                    while top > 0:
                        top -= 1
                        node = stack[top]
                        box = node_box[node]
                        if (keep * box[0] + level * box[1] > dhi
                                or keep * box[3] + level * box[2] < dlo
                                or keep * box[4] + level * box[5] > ahi
                                or keep * box[7] + level * box[6] < alo):
                            continue
                        child = node_child[node]
                        if child >= 0:
                            stack[top] = child
                            stack[top + 1] = child + 1
                            top += 2
                            continue
                        for e in range(node_range[node, 0], node_range[node, 1]):
                            t = tri[e]
                            if (t[0] + level * (t[1] - t[0]) > dhi
                                    or t[2] - level * (t[2] - t[1]) < dlo
                                    or t[3] + level * (t[4] - t[3]) > ahi
                                    or t[5] - level * (t[5] - t[4]) < alo):
                                continue
                            met += 1
                            s = pair_similarity(d1, d2, d3, a1, a2, a3, t[0], t[1], t[2], t[3],
                                                t[4], t[5])
                            k = key[e]
                            if stamp[k] != epoch:
                                stamp[k] = epoch
                                last[k] = i
                                current[k] = s
                                excess[k] = 0.0
                                touched[ntouched] = k
                                ntouched += 1
                            elif last[k] != i:
                                excess[k] += max(current[k] - sigma, 0.0)
                                last[k] = i
                                current[k] = s
                            elif s > current[k]:
                                current[k] = s
        for u in range(ntouched):
            k = touched[u]
            row = key_row[k]
            nb = counts[row]
            if normalise == 1:
                n = nb - 1
            elif normalise == 2:
                n = na - 1
            else:
                n = max(na, nb) - 1
            bound = sigma * (min(na, nb) - 1) + excess[k] + max(current[k] - sigma, 0.0)
            if bound < threshold * n - SLACK:
                continue
            if found == out.shape[0]:
                grown = np.empty((2 * found, 3), dtype=np.int64)
                grown[:found] = out
                out = grown
            out[found, 0] = row
            out[found, 1] = ra
            out[found, 2] = k - key_start[row]
            found += 1
    return out[:found], met, epoch


@numba.njit(cache=True)
def _match_rows(da: np.ndarray, aa: np.ndarray, adj_a: np.ndarray, na: int, rows: np.ndarray,
                references: np.ndarray, counts: np.ndarray, pair_starts: np.ndarray,
                key_start: np.ndarray, db: np.ndarray, ab: np.ndarray, adj_b: np.ndarray,
                normalise: int, constraint: int, threshold: float, similarity: np.ndarray,
                reference: np.ndarray, mapping: np.ndarray, nodes: np.ndarray) -> None:
    """:func:`~cbr_landmarks.similarity.match_case` for each stored graph ``rows[k]``, trying
    the reference pairs ``references[k]``; results in row ``k`` of the outputs."""
    width = max(na, counts.max())
    sims = np.empty((na * width, na, width))
    fwork = np.empty(na * width + 3 * na)
    iwork = np.empty((8 + na, width), dtype=np.int64)
    for k in range(rows.shape[0]):
        r = rows[k]
        s, ra, rb, expanded = match_case(da, aa, adj_a, na, db, ab, adj_b, pair_starts[r],
                                         key_start[r], counts[r], normalise, constraint,
                                         threshold, references[k], sims, fwork, iwork,
                                         mapping[k])
        similarity[k] = s
        reference[k, 0] = ra
        reference[k, 1] = rb
        nodes[k] = expanded


# --------------------------------------------------------------------------------------------
# the index


def _classes(na: int, threshold: float, normalise: str) -> list[int]:
    """The landmark counts of the stored graphs that can reach ``threshold`` against a
    situation of ``na`` landmarks: a matching scores at most ``min(na, nb) - 1`` over ``N``."""
    return [nb for nb in range(2, MAX_LANDMARKS + 1)
            if min(na, nb) - 1 >= threshold * normaliser(na, nb, normalise) - SLACK]


def _check_threshold(threshold: float) -> float:
    threshold = float(threshold)
    if not (math.isfinite(threshold) and threshold >= 0.0):
        raise ValueError(f"a similarity threshold is a number >= 0, got {threshold!r}")
    return threshold


def prefilter_level(threshold: float) -> float:
    """The cut level the prefilter looks stored pairs up at for ``threshold`` (> 1/2): pairs
    of similarity ``(1 + level) / 2`` or more are found. Level 0 (the supports) finds the most
    pairs and bounds the reference pairs tightest; the search measured fastest there."""
    return 0.0 * (2.0 * threshold - 1.0)


@attrs.frozen(eq=False)
class SituationIndex:
    """The stored landmark graphs as flat arrays, searched in one kernel call.

    Graph ``r`` has ``counts[r]`` landmarks; its pair ``(u, v)`` is row ``pair_starts[r] + u
    * n + v`` of ``delta`` and ``alpha``, its landmark ``u`` is ``key_start[r] + u`` of
    ``adjacency`` (obstacle bitmasks) and of ``key_row``. Every ordered pair of distinct
    landmarks is also an entry of ``tri`` (its two triangles) and ``key`` (its first
    landmark), grouped by the graph's landmark count, each group a k-d tree (``class_root``,
    ``node_range``, ``node_child``, ``node_box``) for the prefilter.
    """

    counts: np.ndarray
    pair_starts: np.ndarray
    key_start: np.ndarray
    delta: np.ndarray
    alpha: np.ndarray
    adjacency: np.ndarray
    key_row: np.ndarray
    tri: np.ndarray
    key: np.ndarray
    class_root: np.ndarray
    node_range: np.ndarray
    node_child: np.ndarray
    node_box: np.ndarray
    _scratch: tuple[np.ndarray, ...] = attrs.field(repr=False)
    _epoch: list[int] = attrs.field(repr=False)

    @classmethod
    def build(cls, graphs: Sequence[LandmarkGraph]) -> SituationIndex:
        """The index of ``graphs``; a search names them by their position in it."""
        counts = np.array([g.n for g in graphs], dtype=np.int64)
        pair_starts = np.concatenate(([0], np.cumsum(counts ** 2)[:-1])).astype(np.int64)
        key_start = np.concatenate(([0], np.cumsum(counts)[:-1])).astype(np.int64)
        flat = [flattened(g) for g in graphs]
        delta = np.concatenate([f[0] for f in flat] + [np.empty((0, 3))])
        alpha = np.concatenate([f[1] for f in flat] + [np.empty((0, 3))])
        adjacency = np.concatenate([f[2] for f in flat] + [np.empty(0, dtype=np.int64)])
        key_row = np.repeat(np.arange(len(graphs), dtype=np.int64), counts)
        # every ordered pair of distinct landmarks, grouped by its graph's landmark count
        off = np.concatenate([~np.eye(n, dtype=bool).ravel() for n in counts.tolist()]
                             + [np.empty(0, dtype=bool)])
        pair_row = np.repeat(np.arange(len(graphs), dtype=np.int64), counts ** 2)[off]
        first = np.concatenate([np.repeat(np.arange(n), n) for n in counts.tolist()]
                               + [np.empty(0, dtype=np.int64)]).astype(np.int64)[off]
        tri = np.concatenate((delta[off], alpha[off]), axis=1)
        key = key_start[pair_row] + first
        perm = np.argsort(counts[pair_row], kind="stable").astype(np.int64)
        sizes = np.bincount(counts[pair_row], minlength=MAX_LANDMARKS + 1)
        widths = np.array([np.median(tri[:, 2] - tri[:, 0]), np.median(tri[:, 5] - tri[:, 3])]
                          ) if len(tri) else np.ones(2)
        scale = np.maximum(widths, 1e-6)
        nodes = 4 * (len(tri) // 4 + MAX_LANDMARKS + 1)
        node_range = np.zeros((nodes, 2), dtype=np.int64)
        node_child = np.full(nodes, -1, dtype=np.int64)
        node_box = np.zeros((nodes, 8))
        class_root = np.full(MAX_LANDMARKS + 1, -1, dtype=np.int64)
        start = 0
        free = 0
        for n in range(MAX_LANDMARKS + 1):
            if sizes[n]:
                class_root[n] = free
                free = _build_tree(tri, perm, start, start + int(sizes[n]), node_range,
                                   node_child, node_box, free, scale)
                start += int(sizes[n])
        total = int(counts.sum())
        scratch = (np.full(total, -1, dtype=np.int64), np.empty(total, dtype=np.int64),
                   np.empty(total), np.empty(total))
        return cls(counts, pair_starts, key_start, delta, alpha, adjacency, key_row,
                   np.ascontiguousarray(tri[perm]), key[perm], class_root, node_range[:free],
                   node_child[:free], node_box[:free], scratch, [0])

    def __len__(self) -> int:
        return int(self.counts.shape[0])

    def candidates(self, query: LandmarkGraph, threshold: float,
                   options: SimilarityOptions = SimilarityOptions()
                   ) -> tuple[np.ndarray, np.ndarray, int]:
        """The stored graphs :meth:`search` runs the branch and bound on, the reference pairs
        it tries for each (``(rows, na, largest count)`` booleans) and how many stored pairs
        the prefilter looked at (0 without it)."""
        threshold = _check_threshold(threshold)
        na = query.n
        classes = [c for c in _classes(na, threshold, options.normalise)
                   if self.class_root[c] >= 0]
        if not options.prefilter:
            rows = np.arange(len(self), dtype=np.int64)
            return rows, np.ones((len(rows), na, int(self.counts.max(initial=2))), bool), 0
        if threshold <= 0.5:
            rows = np.flatnonzero(np.isin(self.counts, classes)).astype(np.int64)
            return rows, np.ones((len(rows), na, int(self.counts.max(initial=2))), bool), 0
        qd, qa, _ = flattened(query)
        stamp, last, current, excess = self._scratch
        keys, met, self._epoch[0] = _vote(
            qd, qa, na, prefilter_level(threshold), threshold,
            NORMALISE.index(options.normalise), np.array(classes, dtype=np.int64),
            self.class_root, self.node_range, self.node_child, self.node_box, self.tri,
            self.key, self.key_row, self.key_start, self.counts, stamp, last, current, excess,
            self._epoch[0])
        rows, where = np.unique(keys[:, 0], return_inverse=True)
        references = np.zeros((len(rows), na, int(self.counts[rows].max(initial=2))), bool)
        references[where, keys[:, 1], keys[:, 2]] = True
        return rows, references, met

    def search(self, query: LandmarkGraph, threshold: float,
               options: SimilarityOptions = SimilarityOptions(),
               limit: int | None = None) -> list[Found]:
        """Every stored graph whose similarity to ``query`` reaches ``threshold``, best first
        (ties by row), at most ``limit``: the branch and bound runs on the prefilter's
        candidates in one kernel call."""
        if limit is not None and limit < 0:
            raise ValueError(f"limit must be None or >= 0, got {limit!r}")
        rows, references, _ = self.candidates(query, threshold, options)
        qd, qa, adj = flattened(query)
        k = rows.shape[0]
        similarity = np.empty(k)
        reference = np.empty((k, 2), dtype=np.int64)
        mapping = np.full((k, query.n), -1, dtype=np.int64)
        nodes = np.empty(k, dtype=np.int64)
        if k:
            _match_rows(qd, qa, adj, query.n, rows, references, self.counts, self.pair_starts,
                        self.key_start, self.delta, self.alpha, self.adjacency,
                        NORMALISE.index(options.normalise), CONSTRAINT.index(options.constraint),
                        float(threshold), similarity, reference, mapping, nodes)
        keep = np.flatnonzero(similarity >= 0.0)
        keep = keep[np.lexsort((rows[keep], -similarity[keep]))][:limit]
        return [Found(int(rows[k]), Matching(float(similarity[k]), (int(reference[k, 0]),
                                                                    int(reference[k, 1])),
                                             tuple(mapping[k].tolist()), int(nodes[k])))
                for k in keep.tolist()]
