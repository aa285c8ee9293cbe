"""A landmark graph: the situation part ``<L, O, delta, alpha>`` of a case of 002 (section 3).

``L`` are landmark ids, ``O`` the linear obstacles as pairs of landmarks, ``delta[i, j]`` the
fuzzy distance from landmark ``i`` to landmark ``j`` and ``alpha[i, j]`` the fuzzy angle of the
line from ``i`` to ``j`` against the robot's x axis, both triangles ``(low, peak, high)`` of
:mod:`cbr_world2d.fuzzy`. The labellings are total: every ordered pair has its triangles (the
diagonal holds zeros and is never read). Angle peaks are kept in ``(-pi, pi]``; a support may
reach past them, as the camera's bearings do.

Graphs are plain data in the case base (:meth:`LandmarkGraph.to_data`) and are checked when they
are read back (:meth:`LandmarkGraph.from_data`): a graph with fewer than two landmarks, an obstacle
naming a landmark it does not have, a triangle out of order or a measure that is not a finite
number is refused with the field that is wrong.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import attrs
import numpy as np

from cbr_world2d.fuzzy import TWO_PI
from cbrcore.errors import CbrError
from cbrcore.names import name_problem

MAX_LANDMARKS = 16
"""The most landmarks one graph holds (the matching's search grows with their number)."""

MAX_MEASURE = 1e6
"""The largest magnitude of a case's measures (distances in metres, angles) and of its action's
offsets: beyond it an angle wraps to noise and a target lies nowhere in any world."""


class GraphError(CbrError):
    """A landmark graph that cannot be used; the message names where and the field."""


def _wrapped(alpha: np.ndarray) -> np.ndarray:
    """``alpha`` with each triangle shifted by whole turns so that its peak lies in (-pi, pi]."""
    peak = math.pi - np.remainder(math.pi - alpha[..., 1], TWO_PI)
    shifted = alpha - (alpha[..., 1] - peak)[..., None]
    # the peak itself exactly, so that no rounding puts it a hair past pi
    shifted[..., 1] = peak
    return shifted


def _check_triangles(values: np.ndarray, n: int, field: str, where: str) -> None:
    if values.shape != (n, n, 3):
        raise GraphError(f"{where}: {field}: expected {n} x {n} triangles [low, peak, high] "
                         f"(one per ordered pair of the {n} landmarks), got shape "
                         f"{list(values.shape)}")
    bad = ~(np.isfinite(values) & (np.abs(values) <= MAX_MEASURE)).all(axis=2)
    if bad.any():
        i, j = np.argwhere(bad)[0].tolist()
        raise GraphError(f"{where}: {field}[{i}][{j}]: every measure must be a finite number "
                         f"within ±{MAX_MEASURE:g} (the limit), not {values[i, j].tolist()}")
    disorder = (values[..., 0] > values[..., 1]) | (values[..., 1] > values[..., 2])
    if disorder.any():
        i, j = np.argwhere(disorder)[0].tolist()
        raise GraphError(f"{where}: {field}[{i}][{j}]: a triangle needs low <= peak <= high, "
                         f"not {values[i, j].tolist()}")


def _check_ids(ids: Sequence[object], where: str) -> None:
    """Refuse a landmark id with a control character, before anything prints the ids."""
    for k, landmark in enumerate(ids):
        problem = name_problem(landmark) if isinstance(landmark, str) else None
        if problem is not None:
            raise GraphError(f"{where}: landmarks[{k}]: expected a landmark id, but {problem}")


@attrs.frozen(eq=False)
class LandmarkGraph:
    """Landmarks, linear obstacles between them, and the fuzzy distances and angles of every
    ordered pair. Build one with :meth:`from_points` or :meth:`from_data`; the constructor
    checks what it is given and raises :class:`GraphError` (``where`` names the graph)."""

    ids: tuple[str, ...] = attrs.field(converter=tuple)
    obstacles: frozenset[tuple[int, int]] = attrs.field(converter=frozenset)
    """Pairs ``(i, j)``, ``i < j``, of landmark indices joined by a linear obstacle."""
    delta: np.ndarray = attrs.field(repr=False)
    alpha: np.ndarray = attrs.field(repr=False)
    where: str = attrs.field(default="landmark graph", repr=False)

    def __attrs_post_init__(self) -> None:
        n, where = len(self.ids), self.where
        if n < 2:
            raise GraphError(f"{where}: landmarks: a case needs at least two landmarks (002: "
                             f"|L| >= 2), got {n}")
        if n > MAX_LANDMARKS:
            raise GraphError(f"{where}: landmarks: at most {MAX_LANDMARKS} landmarks, got {n}")
        _check_ids(self.ids, where)
        if len(set(self.ids)) != n:
            raise GraphError(f"{where}: landmarks: ids must be distinct, got {list(self.ids)}")
        for i, j in self.obstacles:
            if not (0 <= i < j < n):
                raise GraphError(f"{where}: obstacles: ({i}, {j}) is not a pair of distinct "
                                 f"landmarks of the {n}")
        delta = np.array(self.delta, dtype=float)
        alpha = np.array(self.alpha, dtype=float)
        _check_triangles(delta, n, "delta", where)
        _check_triangles(alpha, n, "alpha", where)
        if (delta[..., 0] < 0.0).any():
            i, j = np.argwhere(delta[..., 0] < 0.0)[0].tolist()
            raise GraphError(f"{where}: delta[{i}][{j}]: a distance cannot be negative, not "
                             f"{delta[i, j].tolist()}")
        object.__setattr__(self, "delta", delta)
        object.__setattr__(self, "alpha", _wrapped(alpha))
        self.delta.flags.writeable = False
        self.alpha.flags.writeable = False

    @property
    def n(self) -> int:
        return len(self.ids)

    def index(self, landmark: str) -> int:
        """The index of the landmark ``landmark``."""
        return self.ids.index(landmark)

    def subgraph(self, keep: Sequence[int]) -> LandmarkGraph:
        """The graph of the landmarks ``keep`` (indices, in that order) and the obstacles
        between them."""
        keep = list(keep)
        where = {old: new for new, old in enumerate(keep)}
        pairs = {(min(where[i], where[j]), max(where[i], where[j])) for i, j in self.obstacles
                 if i in where and j in where}
        grid = np.ix_(keep, keep)
        return LandmarkGraph([self.ids[k] for k in keep], pairs, self.delta[grid],
                             self.alpha[grid], self.where)

    def adjacency(self) -> np.ndarray:
        """Bit ``j`` of row ``i`` set when an obstacle joins landmarks ``i`` and ``j``
        (``(n,)`` uint64)."""
        bits = np.zeros(self.n, dtype=np.uint64)
        for i, j in self.obstacles:
            bits[i] |= np.uint64(1 << j)
            bits[j] |= np.uint64(1 << i)
        return bits

    @classmethod
    def from_points(cls, ids: Sequence[str], points: np.ndarray, uncertainty: np.ndarray,
                    obstacles: Iterable[tuple[str, str]] = (), where: str = "landmark graph"
                    ) -> LandmarkGraph:
        """The graph of landmarks at ``points`` ``(n, 2)`` in the robot's frame (x ahead), each
        known within ``uncertainty`` ``(n,)`` metres of its true place.

        ``delta[i, j]`` peaks at the distance of the points and spreads by the sum ``r`` of
        their uncertainties; ``alpha[i, j]`` peaks at the direction from ``i`` to ``j`` and
        spreads by the widest angle under which disc ``j`` (radius ``r``) is seen from ``i``,
        ``asin(r / d)`` (pi when the discs overlap): every pair of true places lies inside both
        triangles' supports.
        """
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        uncertainty = np.asarray(uncertainty, dtype=float).reshape(-1)
        if not (np.isfinite(points).all() and np.isfinite(uncertainty).all()):
            raise GraphError(f"{where}: landmarks: positions and uncertainties must be finite "
                             "numbers")
        gap = points[None, :, :] - points[:, None, :]
        d = np.hypot(gap[..., 0], gap[..., 1])
        r = uncertainty[:, None] + uncertainty[None, :]
        delta = np.stack((np.maximum(d - r, 0.0), d, d + r), axis=-1)
        peak = np.arctan2(gap[..., 1], gap[..., 0])
        # r / d overflows for landmarks a denormal apart; the clip and the where discard it
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            half = np.where(r < d, np.arcsin(np.clip(r / np.where(d > 0, d, 1.0), 0.0, 1.0)),
                            math.pi)
        alpha = np.stack((peak - half, peak, peak + half), axis=-1)
        diagonal = np.eye(len(points), dtype=bool)
        delta[diagonal] = 0.0
        alpha[diagonal] = 0.0
        ids = tuple(ids)
        index = {landmark: k for k, landmark in enumerate(ids)}
        pairs = set()
        for a, b in obstacles:
            if a not in index or b not in index:
                missing = a if a not in index else b
                raise GraphError(f"{where}: obstacles: {missing!r} is not one of the landmarks "
                                 f"{list(ids)}")
            pairs.add((min(index[a], index[b]), max(index[a], index[b])))
        return cls(ids, pairs, delta, alpha, where)

    def to_data(self) -> dict[str, Any]:
        """Plain data: ``landmarks``, ``obstacles`` (pairs of ids), ``delta`` and ``alpha``
        (n x n lists of ``[low, peak, high]``)."""
        return {
            "landmarks": list(self.ids),
            "obstacles": [[self.ids[i], self.ids[j]] for i, j in sorted(self.obstacles)],
            "delta": np.round(self.delta, 6).tolist(),
            "alpha": np.round(self.alpha, 6).tolist(),
        }

    @classmethod
    def from_data(cls, data: Any, where: str) -> LandmarkGraph:
        """The graph stored as :meth:`to_data` wrote it; :class:`GraphError` saying which field
        is wrong otherwise."""
        if not isinstance(data, Mapping):
            raise GraphError(f"{where}: expected a mapping with landmarks, obstacles, delta and "
                             f"alpha, got {type(data).__name__}")
        missing = [k for k in ("landmarks", "delta", "alpha") if k not in data]
        if missing:
            raise GraphError(f"{where}: missing {', '.join(missing)}")
        ids = data["landmarks"]
        if not (isinstance(ids, list) and all(isinstance(i, str) for i in ids)):
            raise GraphError(f"{where}: landmarks: expected a list of landmark ids, got {ids!r}")
        _check_ids(ids, where)
        index = {landmark: k for k, landmark in enumerate(ids)}
        pairs = set()
        for k, pair in enumerate(data.get("obstacles") or []):
            if not (isinstance(pair, list) and len(pair) == 2):
                raise GraphError(f"{where}: obstacles[{k}]: expected a pair of landmark ids, "
                                 f"got {pair!r}")
            for landmark in pair:
                if landmark not in index:
                    raise GraphError(f"{where}: obstacles[{k}]: {landmark!r} is not one of the "
                                     f"landmarks {ids}")
            a, b = index[pair[0]], index[pair[1]]
            if a == b:
                raise GraphError(f"{where}: obstacles[{k}]: an obstacle joins two different "
                                 f"landmarks, got {pair!r}")
            pairs.add((min(a, b), max(a, b)))
        arrays = {}
        for field in ("delta", "alpha"):
            try:
                arrays[field] = np.array(data[field], dtype=float)
            except (TypeError, ValueError, OverflowError):  # overflow: an integer past floats
                raise GraphError(f"{where}: {field}: expected {len(ids)} x {len(ids)} triangles "
                                 "[low, peak, high] of numbers") from None
        return cls(ids, pairs, arrays["delta"], arrays["alpha"], where)
