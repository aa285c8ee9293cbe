"""Retrieval over every stored situation: flat arrays, an exact prefilter, one kernel call.

:class:`SituationIndex` holds the stored landmark graphs as flat arrays (landmark counts, the
offsets of each graph's pairs and landmarks, the fuzzy distances and angles of every ordered
pair, the obstacles as bitmasks), so that :meth:`SituationIndex.search` runs 002's branch and
bound (:func:`cbr_landmarks.kernels.match_rows`) over all the candidate graphs in one numba
call, with no Python per case.

For a threshold ``t`` over 1/2 a prefilter picks the candidates, and is exact: it leaves out
only reference pairs ``(ra, rb)`` that cannot reach ``t``, so the search finds what the branch
and bound over every graph finds. First, a matching scores at most ``min(n_A, n_B) - 1`` over
``N``, which rules out the landmark counts too far from the situation's (in ``paper`` matching
every count but the situation's). Then a cut level
``c`` under ``2t - 1`` is taken (:func:`prefilter_level`) and ``sigma = (1 + c) / 2 < t``. Two
triangles overlap by ``c`` or more exactly when their cuts at ``c`` (where each is at least
``c``) meet, so a pair ``(i, j)`` whose similarity is over ``sigma``, both overlaps then being
over ``c``, has its distance cuts and its angle cuts meeting (the angles turned by the whole
turn :func:`cbr_world2d.fuzzy.angle_overlap` uses, one of -2 pi, 0, 2 pi). For each ordered
pair ``(ra, i)`` of the situation the stored pairs ``(rb, j)`` whose cuts meet its own are
compared (the stored pairs sit in bins by distance peak and angle width, sorted by angle peak,
so a bin yields them by two binary searches; one set of bins per landmark count, and one of
all counts together for a search that looks at most of them). With ``best_i`` the best
similarity over ``sigma`` of ``i`` to a compared pair of ``rb`` (``sigma`` when none), a
matching with reference ``(ra, rb)`` scores at most ``sigma q + sum_i (best_i - sigma)`` over
``N`` (at most ``q = min(n_A, n_B) - 1`` landmarks are matched, each scoring at most its
``best_i``): only the reference pairs where that reaches ``t`` go to the branch and bound,
which is left nothing else to try on their graphs. A reference pair none of whose pairs is
over ``sigma`` scores at most ``sigma q / N < t``. At ``c = 0`` this is 002's argument that some
pair of a case reaching ``t > 1/2`` has both its distance and angle supports meeting those of
a pair of the situation (its best term is at least its mean ``t``, and a term with an overlap
of 0 is at most 1/2). The largest bound over a graph's reference pairs bounds its similarity:
a search for the best few matches the graphs highest bound first and stops at the first whose
bound is under the best few found.

At a threshold of 1/2 or less, or without the prefilter, every graph goes to the branch and
bound (with the prefilter, those whose landmark count can reach the threshold).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import attrs
import numpy as np

from cbr_kernels import njit
from cbr_landmarks.graph import MAX_LANDMARKS, LandmarkGraph
from cbr_landmarks.kernels import coded_normaliser, height, match_rows
from cbr_landmarks.similarity import (
    CONSTRAINT,
    MATCHING,
    NORMALISE,
    Matching,
    SimilarityOptions,
    check_threshold,
    flattened,
    normaliser,
)
from cbr_world2d.fuzzy import TWO_PI

BIN = 0.1
"""Metres of distance peak per bin of stored pairs."""
WIDTHS = np.array([0.3, 0.6])
"""Angle half-widths (radians) that split a bin further."""
SLACK = 1e-9
"""How much the prefilter widens every comparison, so that rounding never drops a pair the
similarity itself would count."""


@attrs.frozen
class Found:
    """A stored graph that reached the threshold, and its best matching."""

    row: int
    """The graph's position in the list the index was built from."""
    matching: Matching


# --------------------------------------------------------------------------------------------
# the prefilter


@njit(inline="always")
def _first_over(values: np.ndarray, start: int, end: int, bound: float, inclusive: bool) -> int:
    """The first index in ``[start, end)`` of the ascending ``values`` over ``bound`` (at or
    over it when ``inclusive``), ``end`` if none."""
    while start < end:
        middle = (start + end) >> 1
        if values[middle] < bound or (not inclusive and values[middle] == bound):
            start = middle + 1
        else:
            end = middle
    return start


@njit(error_model="numpy")
def _vote(qd: np.ndarray, qa: np.ndarray, na: int, level: float, threshold: float,
          normalise: int, groups: np.ndarray, group_bins: np.ndarray,
          group_reach: np.ndarray, bin_distance: np.ndarray, bin_start: np.ndarray,
          bin_box: np.ndarray, tri: np.ndarray, key: np.ndarray, key_lo: int, key_hi: int,
          key_row: np.ndarray, key_rb: np.ndarray, counts: np.ndarray, width: int,
          best: np.ndarray,
          excess: np.ndarray, hit: np.ndarray, touched: np.ndarray, buffer: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The stored graphs with a reference pair whose bound reaches ``threshold``, those
    reference pairs and the bound of the graph (:func:`_by_row`; for a graph of ``width``
    landmarks at most), and how many stored pairs were compared.

    The bound of the module's docstring over the stored pairs of the bin groups ``classes``
    of a :class:`PairBins` (its other arguments) whose first landmark is numbered ``key_lo``
    to ``key_hi`` (those of the landmark counts searched), at cut ``level``, ``sigma = (1 +
    level) / 2 < threshold``. A pair is compared
    at each turn of the angles (-2 pi, 0, 2 pi) where the cuts meet, and its similarity
    computed at that turn; the largest over the turns is at least the similarity at the
    nearest turn, which the kernel computes, so the bound holds.

    Scratch, one entry per stored landmark: ``best`` (the best similarity over sigma of the
    current ``i``) and ``excess`` (the summed excesses over sigma of the current reference's
    landmarks so far), both 0 on entry and on return, ``hit`` (the landmarks the current
    ``i`` met) and ``touched`` (those the current reference met); ``buffer`` holds a bin's
    similarities (the most pairs in a bin).
    """
    sigma = 0.5 * (1.0 + level)
    keep = 1.0 - level
    d_lo, d_pk, d_hi, a_lo, a_pk, a_hi = tri[0], tri[1], tri[2], tri[3], tri[4], tri[5]
    out = np.empty((64, 3), dtype=np.int64)
    bounds = np.empty(64)
    found = 0
    compared = 0
    for ra in range(na):
        ntouched = 0
        for i in range(na):
            if i == ra:
                continue
            p = ra * na + i
            d1, d2, d3 = qd[p, 0], qd[p, 1], qd[p, 2]
            dlo = d1 + level * (d2 - d1) - SLACK
            dhi = d3 - level * (d3 - d2) + SLACK
            nhit = 0
            for c in groups:
                # the bins whose distance peaks lie near enough for a cut to meet [dlo, dhi]
                b0, b1 = group_bins[c], group_bins[c + 1]
                lowest = np.floor((dlo - keep * group_reach[c, 1]) / BIN)
                highest = np.floor((dhi + keep * group_reach[c, 0]) / BIN)
                first_bin = _first_over(bin_distance, b0, b1, lowest, True)
                last_bin = _first_over(bin_distance, first_bin, b1, highest, False)
                for b in range(first_bin, last_bin):
                    box = bin_box[b]
                    if keep * box[0] + level * box[1] > dhi or keep * box[3] + level * box[2] < dlo:
                        continue
                    start = bin_start[b]
                    end = bin_start[b + 1]
                    for turn in (-TWO_PI, 0.0, TWO_PI):
                        # the situation's angle turned against the stored ones
                        b1, b2, b3 = qa[p, 0] - turn, qa[p, 1] - turn, qa[p, 2] - turn
                        alo = b1 + level * (b2 - b1) - SLACK
                        ahi = b3 - level * (b3 - b2) + SLACK
                        # a stored cut can meet [alo, ahi] only if its peak lies within the
                        # bin's widest half-widths of it
                        low = alo - keep * box[5]
                        high = ahi + keep * box[4]
                        if high < a_pk[start] or low > a_pk[end - 1]:
                            continue
                        first = _first_over(a_pk, start, end, low, True)
                        last = _first_over(a_pk, first, end, high, False)
                        # branch-free, so that it runs on SIMD lanes
                        for e in range(first, last):
                            x1, x2, x3 = d_lo[e], d_pk[e], d_hi[e]
                            y1, y2, y3 = a_lo[e], a_pk[e], a_hi[e]
                            k = key[e]
                            meets = ((x1 + level * (x2 - x1) <= dhi)
                                     & (x3 - level * (x3 - x2) >= dlo)
                                     & (y1 + level * (y2 - y1) <= ahi)
                                     & (y3 - level * (y3 - y2) >= alo)
                                     & (k >= key_lo) & (k < key_hi))
                            compared += meets
                            s = 0.5 * (height(d1, d2, d3, x1, x2, x3)
                                       + height(b1, b2, b3, y1, y2, y3))
                            buffer[e - first] = s if meets else 0.0
                        for e in range(first, last):
                            value = buffer[e - first]
                            if value > sigma:
                                k = key[e]
                                if best[k] == 0.0:
                                    hit[nhit] = k
                                    nhit += 1
                                best[k] = max(best[k], value)
            # add i's excesses
            for u in range(nhit):
                k = hit[u]
                before = excess[k]
                excess[k] = before + (best[k] - sigma)
                best[k] = 0.0
                if before == 0.0:
                    touched[ntouched] = k
                    ntouched += 1
        for u in range(ntouched):
            k = touched[u]
            nb = counts[key_row[k]]
            bound = sigma * (min(na, nb) - 1) + excess[k]
            excess[k] = 0.0
            n = coded_normaliser(na, nb, normalise)
            if bound < threshold * n - SLACK:
                continue
            if found == out.shape[0]:
                grown = np.empty((2 * found, 3), dtype=np.int64)
                grown[:found] = out
                out = grown
                wider = np.empty(2 * found)
                wider[:found] = bounds
                bounds = wider
            out[found, 0] = key_row[k]
            out[found, 1] = ra
            out[found, 2] = key_rb[k]
            bounds[found] = bound / n
            found += 1
    rows, references, row_bound = _by_row(out[:found], bounds[:found], na, width)
    return rows, references, row_bound, compared


@njit
def _by_row(keys: np.ndarray, bounds: np.ndarray, na: int, width: int
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The reference pairs ``keys`` ``(row, ra, rb)`` by stored graph: the rows ascending,
    for each the reference pairs to try (``(rows, na, width)`` booleans), and the largest
    of their ``bounds`` (a graph's similarity is that of its best reference pair)."""
    order = np.argsort(keys[:, 0], kind="mergesort")
    count = 0
    for e in range(order.shape[0]):
        count += e == 0 or keys[order[e], 0] != keys[order[e - 1], 0]
    rows = np.empty(count, dtype=np.int64)
    references = np.zeros((count, na, width), dtype=np.bool_)
    row_bound = np.zeros(count)
    k = -1
    for e in range(order.shape[0]):
        u = order[e]
        if e == 0 or keys[u, 0] != keys[order[e - 1], 0]:
            k += 1
            rows[k] = keys[u, 0]
        references[k, keys[u, 1], keys[u, 2]] = True
        row_bound[k] = max(row_bound[k], bounds[u])
    return rows, references, row_bound


# --------------------------------------------------------------------------------------------
# the index


def _classes(na: int, threshold: float, options: SimilarityOptions) -> list[int]:
    """The landmark counts of the stored graphs that can reach ``threshold`` against a
    situation of ``na`` landmarks: ``na`` alone in ``paper`` matching; else those where
    ``min(na, nb) - 1`` matched landmarks over ``N`` can."""
    if options.matching == "paper":
        return [na]
    return list(_reaching(na, threshold, options.normalise))


@functools.lru_cache(maxsize=1024)
def _reaching(na: int, threshold: float, normalise: str) -> tuple[int, ...]:
    # cached: a search asks once per query, and the thresholds repeat
    return tuple(nb for nb in range(2, MAX_LANDMARKS + 1)
                 if min(na, nb) - 1 >= threshold * normaliser(na, nb, normalise) - SLACK)


def prefilter_level(threshold: float) -> float:
    """The cut level the prefilter compares stored pairs at for ``threshold`` (over 1/2).

    The lower the level, the more pairs are compared (their cuts are wider) but the tighter
    the bound on a reference pair (a pair not compared adds at most ``(1 + level) / 2``), so
    the fewer reference pairs the branch and bound is left with; the level must stay under
    ``2 threshold - 1`` for the bound to rule any out. ``1 - threshold`` under it: at 0.8,
    level 0.4 compares about half the pairs level 0 does and leaves about three times the
    reference pairs, and searched faster on the benchmark's situations
    (benchmarks/landmarks_retrieval.py); near 1 the situations over the threshold are few and
    alike, the cuts narrow, and the bound need not rule out much (0.85 at 0.95, the stricter
    threshold of a search for the best few).
    """
    return max(0.0, 3.0 * threshold - 2.0 - SLACK)


RAISED = (0.9, 0.75)
"""How far from the threshold toward 1 the stricter thresholds of a search for the best few
lie (0.98 and 0.95 at 0.8): the third best situation of a query of the benchmark
(benchmarks/landmarks_retrieval.py) is most often between 0.97 and 0.99."""


def raised(threshold: float) -> list[float]:
    """The stricter thresholds a search for the best few looks at first, strictest first
    (:data:`RAISED`; none over 1/2 or at 1). The higher the threshold, the narrower the
    prefilter's cuts and the fewer graphs the branch and bound is left with; a view of many
    landmarks finds hundreds of stored situations over 0.8, and often a few over 0.95."""
    if not 0.5 < threshold < 1.0:
        return []
    return [threshold + share * (1.0 - threshold) for share in RAISED]


@attrs.frozen(eq=False)
class PairBins:
    """Every stored ordered pair of distinct landmarks in bins, for the prefilter.

    The pairs are grouped (``group_bins[g]`` to ``group_bins[g + 1]`` are the bins of group
    ``g``: their graph's landmark count, or 0 for all of them), then binned by distance peak
    in bins of :data:`BIN` metres split by the angle's half-width at :data:`WIDTHS` (pairs
    ``bin_start[b]`` to ``bin_start[b + 1]``), and sorted by angle peak in a bin. A pair is a
    column of ``tri`` (rows: its distance low, peak, high, its angle low, peak, high) and an
    entry of ``key`` (its first landmark, numbered as :class:`SituationIndex` numbers them).
    ``bin_box[b]`` bounds the bin's triangles: least distance low and peak, largest distance
    peak and high, largest angle half-widths below and above the peak; ``bin_distance[b]`` is
    its distance bin (``floor(peak / BIN)``, ascending within a group) and ``group_reach[g]``
    the largest distance half-widths below and above the peak of group ``g``'s pairs, so that
    a search finds a group's bins near a distance by binary search.
    """

    tri: np.ndarray
    key: np.ndarray
    group_bins: np.ndarray
    group_reach: np.ndarray
    bin_distance: np.ndarray
    bin_start: np.ndarray
    bin_box: np.ndarray

    @classmethod
    def build(cls, tri: np.ndarray, key: np.ndarray, group: np.ndarray) -> PairBins:
        """The bins of the pairs ``tri`` ``(pairs, 6)`` of first landmarks ``key`` in the
        groups ``group`` (0 to :data:`~cbr_landmarks.graph.MAX_LANDMARKS`)."""
        # bins of distance peak, each split by the angle's half-width so that the few wide
        # angles (landmarks close together) do not widen every window of their bin
        half = np.maximum(tri[:, 4] - tri[:, 3], tri[:, 5] - tri[:, 4])
        # (a half-width falls in one of len(WIDTHS) + 1 classes)
        distance_bin = (np.floor(tri[:, 1] / BIN).astype(np.int64) * (len(WIDTHS) + 1)
                        + np.searchsorted(WIDTHS, half))
        order = np.lexsort((tri[:, 4], distance_bin, group))
        tri = np.ascontiguousarray(tri[order])
        group, distance_bin = group[order], distance_bin[order]
        new_bin = np.ones(len(tri), dtype=bool)
        new_bin[1:] = (group[1:] != group[:-1]) | (distance_bin[1:] != distance_bin[:-1])
        bin_start = np.append(np.flatnonzero(new_bin), len(tri)).astype(np.int64)
        starts = bin_start[:-1]
        if len(tri):
            bin_box = np.column_stack((
                np.minimum.reduceat(tri[:, 0], starts), np.minimum.reduceat(tri[:, 1], starts),
                np.maximum.reduceat(tri[:, 1], starts), np.maximum.reduceat(tri[:, 2], starts),
                np.maximum.reduceat(tri[:, 4] - tri[:, 3], starts),
                np.maximum.reduceat(tri[:, 5] - tri[:, 4], starts)))
        else:
            bin_box = np.empty((0, 6))
        group_bins = np.searchsorted(group[starts], np.arange(MAX_LANDMARKS + 2)
                                     ).astype(np.int64)
        bin_distance = (distance_bin[starts] // (len(WIDTHS) + 1)).astype(np.float64)
        group_reach = np.zeros((MAX_LANDMARKS + 2, 2))
        np.maximum.at(group_reach[:, 0], group, tri[:, 1] - tri[:, 0])
        np.maximum.at(group_reach[:, 1], group, tri[:, 2] - tri[:, 1])
        return cls(np.ascontiguousarray(tri.T), key[order], group_bins, group_reach,
                   bin_distance, bin_start, bin_box)

    def arrays(self) -> tuple[np.ndarray, ...]:
        """The arrays in the order :func:`_vote` takes them, from ``group_bins`` to
        ``tri``."""
        return (self.group_bins, self.group_reach, self.bin_distance, self.bin_start,
                self.bin_box, self.tri)

    @property
    def widest(self) -> int:
        """The most pairs in one bin."""
        return int(np.diff(self.bin_start).max(initial=0))


TOGETHER = 0.5
"""The least share of the stored pairs that the landmark counts a search looks at must hold
for the prefilter to go through the bins of all counts together
(:attr:`SituationIndex.together`) rather than count by count."""


@attrs.frozen(eq=False)
class SituationIndex:
    """The stored landmark graphs as flat arrays, searched in one kernel call.

    Graph ``r`` has ``counts[r]`` landmarks; its pair ``(u, v)`` is row ``pair_starts[r] + u
    * n + v`` of ``delta`` and ``alpha``, and its landmark ``u`` row ``key_start[r] + u`` of
    ``adjacency`` (obstacle bitmasks).

    For the prefilter the stored landmarks are numbered again by landmark count (those of
    count ``n`` are ``count_keys[n]`` to ``count_keys[n + 1]``, so that the prefilter's
    scratch for the counts a search looks at lies together; ``key_row``, ``key_rb`` name
    their graph and index; ``count_pairs[n]`` is how many ordered pairs of distinct landmarks
    the graphs of count ``n`` hold), and every such pair is in two
    :class:`PairBins`: ``by_count``, grouped by its graph's landmark count, and
    ``together``, all in one group. A search that looks at few of the counts goes through
    their groups of ``by_count``; one that looks at counts holding at least :data:`TOGETHER`
    of the pairs goes through ``together`` (fewer bins to find, the pairs of the other counts
    passed over as it compares), where a view of many landmarks compared with every count
    spends less.

    ``scratch`` is the prefilter's working memory (:func:`_vote`), made once: its per-landmark
    sums are kept at 0 between searches, so that a search touches only the stored landmarks
    it meets (the index is not for concurrent searches from threads that release the GIL;
    the kernels do not).
    """

    counts: np.ndarray
    pair_starts: np.ndarray
    key_start: np.ndarray
    delta: np.ndarray
    alpha: np.ndarray
    adjacency: np.ndarray
    key_row: np.ndarray
    key_rb: np.ndarray
    count_keys: tuple[int, ...]
    count_pairs: tuple[int, ...]
    by_count: PairBins
    together: PairBins
    scratch: tuple[np.ndarray, ...]

    @classmethod
    def build(cls, graphs: Sequence[LandmarkGraph]) -> SituationIndex:
        """The index of ``graphs``; a search names them by their position in the sequence."""
        counts = np.array([g.n for g in graphs], dtype=np.int64)
        pair_starts = np.concatenate(([0], np.cumsum(counts ** 2)[:-1])).astype(np.int64)
        key_start = np.concatenate(([0], np.cumsum(counts)[:-1])).astype(np.int64)
        flat = [flattened(g) for g in graphs]
        delta = np.concatenate([f[0] for f in flat] + [np.empty((0, 3))])
        alpha = np.concatenate([f[1] for f in flat] + [np.empty((0, 3))])
        adjacency = np.concatenate([f[2] for f in flat] + [np.empty(0, dtype=np.int64)])
        landmark_row = np.repeat(np.arange(len(graphs), dtype=np.int64), counts)
        landmark_rb = np.arange(len(landmark_row), dtype=np.int64) - key_start[landmark_row]
        by_count = np.argsort(counts[landmark_row], kind="stable")
        number = np.empty(len(by_count), dtype=np.int64)
        number[by_count] = np.arange(len(by_count))
        landmark_counts = counts[landmark_row][by_count]
        count_keys = tuple(np.searchsorted(landmark_counts, np.arange(MAX_LANDMARKS + 2)
                                           ).tolist())
        # every ordered pair of distinct landmarks
        off = np.concatenate([~np.eye(n, dtype=bool).ravel() for n in counts.tolist()]
                             + [np.empty(0, dtype=bool)])
        pair_row = np.repeat(np.arange(len(graphs), dtype=np.int64), counts ** 2)[off]
        first = np.concatenate([np.repeat(np.arange(n), n) for n in counts.tolist()]
                               + [np.empty(0, dtype=np.int64)]).astype(np.int64)[off]
        tri = np.concatenate((delta[off], alpha[off]), axis=1)
        pair_count = counts[pair_row]
        key = number[key_start[pair_row] + first]
        count_pairs = tuple(np.bincount(pair_count, minlength=MAX_LANDMARKS + 1).tolist())
        bins = PairBins.build(tri, key, pair_count)
        together = PairBins.build(tri, key, np.zeros_like(pair_count))
        landmarks = len(landmark_row)
        scratch = (np.zeros(landmarks), np.zeros(landmarks), np.empty(landmarks, np.int64),
                   np.empty(landmarks, np.int64),
                   np.empty(max(bins.widest, together.widest)))
        # read-only as a graph's own triangles are, so that the kernel compiled for one case
        # serves the index too
        delta.flags.writeable = False
        alpha.flags.writeable = False
        return cls(counts, pair_starts, key_start, delta, alpha, adjacency,
                   landmark_row[by_count], landmark_rb[by_count], count_keys, count_pairs,
                   bins, together, scratch)

    def __len__(self) -> int:
        return int(self.counts.shape[0])

    def candidates(self, query: LandmarkGraph, threshold: float,
                   options: SimilarityOptions = SimilarityOptions()
                   ) -> tuple[np.ndarray, np.ndarray, int]:
        """What :meth:`search` runs the branch and bound on: the stored graphs (rows), for
        each the reference pairs to try (``(rows, n_A, largest count)`` booleans), and how many
        stored pairs the prefilter compared (0 when it is not used)."""
        threshold = check_threshold(threshold)
        rows, references, _, compared = self._candidates(
            flattened(query), query.n, threshold, options,
            _classes(query.n, threshold, options))
        return rows, references, compared

    def _candidates(self, flat: tuple[np.ndarray, ...], na: int, threshold: float,
                    options: SimilarityOptions, classes: list[int]
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """:meth:`candidates` for the query of ``na`` landmarks :func:`flattened` to
        ``flat``, among the stored graphs of the landmark counts ``classes`` (all of them
        without the prefilter), and a bound on each one's similarity (1 where the prefilter
        gives none)."""
        width = int(self.counts.max(initial=2))
        if not options.prefilter or threshold <= 0.5:
            rows = (np.flatnonzero(np.isin(self.counts, classes)) if options.prefilter
                    else np.arange(len(self))).astype(np.int64)
            return rows, np.ones((len(rows), na, width), bool), np.ones(len(rows)), 0
        if not classes:
            return np.empty(0, np.int64), np.empty((0, na, width), bool), np.empty(0), 0
        qd, qa, _ = flat
        lowest, highest = min(classes), max(classes)
        if sum(self.count_pairs[lowest:highest + 1]) >= TOGETHER * sum(self.count_pairs):
            bins, groups = self.together, np.zeros(1, dtype=np.int64)
        else:
            bins, groups = self.by_count, np.array(classes, dtype=np.int64)
        return _vote(qd, qa, na, prefilter_level(threshold), threshold,
                     NORMALISE.index(options.normalise), groups, *bins.arrays(), bins.key,
                     self.count_keys[lowest], self.count_keys[highest + 1], self.key_row,
                     self.key_rb, self.counts, width, *self.scratch)

    def search(self, query: LandmarkGraph, threshold: float,
               options: SimilarityOptions = SimilarityOptions(),
               limit: int | None = None) -> list[Found]:
        """Every stored graph whose similarity to ``query`` reaches ``threshold``, best first
        (ties by row), at most ``limit``: the prefilter's candidates go through the branch and
        bound in one kernel call.

        With a ``limit`` and the prefilter, the stored graphs of the smallest landmark count
        the search looks at are searched first, then the others at the similarity of the
        ``limit``-th best found so far, when there are that many (every graph of the best
        ``limit`` reaches it). While fewer have been found, each search looks first at the
        stricter thresholds :func:`raised` gives, strictest first: when ``limit`` graphs
        reach one, they are the best ``limit`` of the graphs searched (every other scores
        under it)."""
        if limit is not None and limit < 0:
            raise ValueError(f"limit must be None or >= 0, got {limit!r}")
        threshold = check_threshold(threshold)
        classes = _classes(query.n, threshold, options)
        if limit == 0:
            return []
        flat = flattened(query)
        if not (limit and options.prefilter and threshold > 0.5):
            return self._search(flat, query.n, threshold, options, limit, classes)
        found: list[Found] = []
        floor = threshold
        for group in (classes[:1], classes[1:]):
            if not group:
                continue
            for level in (raised(threshold) if len(found) < limit else []) + [floor]:
                merged = sorted(found + self._search(flat, query.n, level, options, limit,
                                                     group), key=_rank)[:limit]
                if len(merged) == limit and merged[-1].matching.similarity >= level:
                    break
            found = merged
            if len(found) == limit:
                floor = found[-1].matching.similarity
        return found

    def _search(self, flat: tuple[np.ndarray, ...], na: int, threshold: float,
                options: SimilarityOptions, limit: int | None, classes: list[int]
                ) -> list[Found]:
        rows, references, bounds, _ = self._candidates(flat, na, threshold, options, classes)
        qd, qa, adj = flat
        k = rows.shape[0]
        similarity = np.empty(k)
        reference = np.empty((k, 2), dtype=np.int64)
        mapping = np.full((k, na), -1, dtype=np.int64)
        nodes = np.empty(k, dtype=np.int64)
        if k:
            match_rows(qd, qa, adj, na, rows, references, bounds, limit or 0, self.counts,
                       self.pair_starts, self.key_start, self.delta, self.alpha, self.adjacency,
                       MATCHING.index(options.matching), NORMALISE.index(options.normalise),
                       CONSTRAINT.index(options.constraint), float(threshold), similarity,
                       reference, mapping, nodes)
        keep = _ranked(similarity, rows, -1 if limit is None else limit)
        # whole columns to Python at once: a query may find hundreds of cases
        return [Found(row, Matching(value, (ra, rb), tuple(matched), expanded))
                for row, value, (ra, rb), matched, expanded in zip(
                    rows[keep].tolist(), similarity[keep].tolist(), reference[keep].tolist(),
                    mapping[keep].tolist(), nodes[keep].tolist(), strict=True)]


@njit
def _ranked(similarity: np.ndarray, rows: np.ndarray, limit: int) -> np.ndarray:
    """The positions of the graphs found (``similarity`` at least 0), best first, ties by
    row, at most ``limit`` of them (all when it is negative)."""
    keep = np.flatnonzero(similarity >= 0.0)
    # rows ascending within equal similarities: sort by row, then stably by similarity
    keep = keep[np.argsort(rows[keep], kind="mergesort")]
    keep = keep[np.argsort(-similarity[keep], kind="mergesort")]
    return keep if limit < 0 else keep[:limit]


def _rank(found: Found) -> tuple[float, int]:
    """The order of a search's results: best first, ties by row."""
    return -found.matching.similarity, found.row
