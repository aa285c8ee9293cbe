"""Geometry kernels of the 2D world: ray casting, swept-disc collision, clearance, visibility.

Every kernel is compiled with numba and takes plain float64 arrays, because the simulator calls
them every step: segments are ``(n, 4)`` rows ``x0, y0, x1, y1`` and discs ``(m, 3)`` rows
``x, y, radius`` (see :meth:`cbr_world2d.world.World.segments_at`). Angles are radians,
counter-clockwise from the x axis.

Collision is continuous, not sampled: :func:`sweep` treats each segment as a capsule of the
moving disc's radius around it and each disc as a disc of the summed radii, and returns the
first fraction of the move at which the disc's centre would enter one of them. The entry is
computed against the radius grown by :data:`GAP`, so a disc stopped there keeps a gap of about
``GAP`` metres and never ends overlapping, whatever the rounding.
"""

from __future__ import annotations

import math

import numpy as np

from cbr_kernels import njit

GAP = 1e-6
"""Metres kept between a disc stopped by :func:`sweep` and what stopped it."""

_INF = np.inf


@njit(inline="always")
def _segment_distance2(px: float, py: float, ax: float, ay: float, bx: float,
                       by: float) -> tuple[float, float, float]:
    """Squared distance from ``p`` to segment ``ab`` and the closest point of the segment."""
    ex = bx - ax
    ey = by - ay
    length2 = ex * ex + ey * ey
    s = 0.0
    if length2 > 0.0:
        s = ((px - ax) * ex + (py - ay) * ey) / length2
        s = min(max(s, 0.0), 1.0)
    qx = ax + s * ex
    qy = ay + s * ey
    return (px - qx) * (px - qx) + (py - qy) * (py - qy), qx, qy


@njit(inline="always")
def _ray_segment(ox: float, oy: float, dx: float, dy: float, ax: float, ay: float, bx: float,
                 by: float) -> float:
    """Distance along the unit ray ``o + t d`` to segment ``ab`` (inf when missed)."""
    ex = bx - ax
    ey = by - ay
    wx = ax - ox
    wy = ay - oy
    denom = dx * ey - dy * ex
    if denom != 0.0:
        t = (wx * ey - wy * ex) / denom
        s = (wx * dy - wy * dx) / denom
        if t >= 0.0 and 0.0 <= s <= 1.0:
            return t
        return _INF
    # Parallel: only a collinear segment can be hit, at its nearer end (or at once if the
    # origin lies on it).
    if wx * dy - wy * dx != 0.0:
        return _INF
    ta = wx * dx + wy * dy
    tb = (bx - ox) * dx + (by - oy) * dy
    if max(ta, tb) < 0.0:
        return _INF
    return max(min(ta, tb), 0.0)


@njit
def _near(x: float, y: float, reach: float, segments: np.ndarray,
          discs: np.ndarray) -> tuple[np.ndarray, int, np.ndarray, int]:
    """Indices of the segments and discs within ``reach`` of ``(x, y)``: the only ones a ray
    of that length can hit, so each ray tests a handful instead of the whole world."""
    n = segments.shape[0]
    m = discs.shape[0]
    near_s = np.empty(n, np.int64)
    near_d = np.empty(m, np.int64)
    ns = 0
    nd = 0
    reach2 = reach * reach
    for i in range(n):
        d2, _, _ = _segment_distance2(x, y, segments[i, 0], segments[i, 1], segments[i, 2],
                                      segments[i, 3])
        if d2 <= reach2:
            near_s[ns] = i
            ns += 1
    for i in range(m):
        dx = x - discs[i, 0]
        dy = y - discs[i, 1]
        bound = reach + discs[i, 2]
        if dx * dx + dy * dy <= bound * bound:
            near_d[nd] = i
            nd += 1
    return near_s, ns, near_d, nd


@njit(error_model="numpy")
def _cast(x: float, y: float, angles: np.ndarray, max_range: float, segments: np.ndarray,
          discs: np.ndarray, out: np.ndarray) -> None:
    # Obstacles outer, rays inner, and the inner loops free of branches and of Python's
    # zero-division checks (error_model="numpy"), so that LLVM runs them on SIMD lanes: about
    # twice as fast as testing ray by ray. A ray parallel to a segment divides by zero there;
    # the resulting inf or nan fails every test, and such pairs are redone exactly afterwards.
    near_s, ns, near_d, nd = _near(x, y, max_range, segments, discs)
    nr = angles.shape[0]
    dxs = np.empty(nr)
    dys = np.empty(nr)
    for k in range(nr):
        dxs[k] = math.cos(angles[k])
        dys[k] = math.sin(angles[k])
        out[k] = max_range
    parallel = 0
    for j in range(ns):
        i = near_s[j]
        wx = segments[i, 0] - x
        wy = segments[i, 1] - y
        ex = segments[i, 2] - segments[i, 0]
        ey = segments[i, 3] - segments[i, 1]
        tnum = wx * ey - wy * ex
        for k in range(nr):
            denom = dxs[k] * ey - dys[k] * ex
            parallel += denom == 0.0
            inverse = 1.0 / denom
            t = tnum * inverse
            s = (wx * dys[k] - wy * dxs[k]) * inverse
            best = out[k]
            out[k] = t if (t >= 0.0) & (s >= 0.0) & (s <= 1.0) & (t < best) else best
    if parallel > 0:
        for j in range(ns):
            i = near_s[j]
            ex = segments[i, 2] - segments[i, 0]
            ey = segments[i, 3] - segments[i, 1]
            for k in range(nr):
                if dxs[k] * ey - dys[k] * ex == 0.0:
                    t = _ray_segment(x, y, dxs[k], dys[k], segments[i, 0], segments[i, 1],
                                     segments[i, 2], segments[i, 3])
                    out[k] = min(out[k], t)
    for j in range(nd):
        i = near_d[j]
        fx = x - discs[i, 0]
        fy = y - discs[i, 1]
        c = fx * fx + fy * fy - discs[i, 2] * discs[i, 2]
        if c <= 0.0:
            # Inside this disc: every ray reads 0.
            for k in range(nr):
                out[k] = 0.0
            continue
        for k in range(nr):
            b = fx * dxs[k] + fy * dys[k]
            disc = b * b - c
            t = -b - math.sqrt(max(disc, 0.0))
            best = out[k]
            out[k] = t if (b < 0.0) & (disc >= 0.0) & (t < best) else best


@njit
def cast_rays(x: float, y: float, angles: np.ndarray, max_range: float, segments: np.ndarray,
              discs: np.ndarray) -> np.ndarray:
    """Distance from ``(x, y)`` to the first segment or disc along each ray of absolute angle
    ``angles[k]``, or ``max_range`` when nothing lies within it. A ray starting inside a disc
    reads 0; a ray along a collinear segment hits its nearer end."""
    out = np.empty(angles.shape[0])
    _cast(x, y, angles, max_range, segments, discs, out)
    return out


@njit
def ring_ranges_into(x: float, y: float, theta: float, directions: np.ndarray,
                     offsets: np.ndarray, max_range: float, radius: float, segments: np.ndarray,
                     discs: np.ndarray, out: np.ndarray) -> None:
    """:func:`ring_ranges` written into ``out`` ``(B,)``: returning a fresh array from a
    compiled function costs about a microsecond of boxing, which a caller on the hot path
    saves by passing its own."""
    nb = directions.shape[0]
    nk = offsets.shape[0]
    angles = np.empty(nb * nk)
    for b in range(nb):
        for k in range(nk):
            angles[b * nk + k] = theta + directions[b] + offsets[k]
    hits = np.empty(nb * nk)
    _cast(x, y, angles, max_range + radius, segments, discs, hits)
    for b in range(nb):
        best = hits[b * nk]
        for k in range(1, nk):
            best = min(best, hits[b * nk + k])
        out[b] = best
    half = 0.0
    for k in range(nk):
        half = max(half, abs(offsets[k]))
    if half > 0.0:
        _cone_nearest(x, y, theta, directions, half, max_range + radius, segments, discs, out)
    for b in range(nb):
        out[b] = min(max(out[b] - radius, 0.0), max_range)


@njit
def _cone_nearest(x: float, y: float, theta: float, directions: np.ndarray, half: float,
                  limit: float, segments: np.ndarray, discs: np.ndarray,
                  out: np.ndarray) -> None:
    """Lower each beam's distance in ``out`` to the exact nearest obstacle inside its cone.

    The edge rays already found whatever crosses a cone's sides; what lies wholly between the
    rays (a wall's end pointing at the robot, a small disc) is nearest at a segment's end, at
    the foot of the perpendicular from the centre, or, for a disc, along the line to its centre,
    whenever that point lies inside the cone. Without this, a thin obstacle between two rays
    stays unseen however close it comes. Only candidates nearer than ``limit`` can matter.
    """
    n = segments.shape[0]
    m = discs.shape[0]
    # the candidates within reach, relative to the centre: gathered once, then tested against
    # every beam by a dot product
    px = np.empty(3 * n + m)
    py = np.empty(3 * n + m)
    norm = np.empty(3 * n + m)
    reach = np.empty(3 * n + m)
    count = 0
    for i in range(n):
        x0 = segments[i, 0] - x
        y0 = segments[i, 1] - y
        dx = segments[i, 2] - segments[i, 0]
        dy = segments[i, 3] - segments[i, 1]
        length2 = dx * dx + dy * dy
        t = 0.0 if length2 == 0.0 else min(max(-(x0 * dx + y0 * dy) / length2, 0.0), 1.0)
        fx = x0 + t * dx
        fy = y0 + t * dy
        if fx * fx + fy * fy >= limit * limit:
            continue  # the foot is the segment's nearest point: all of it is out of reach
        for qx, qy in ((x0, y0), (x0 + dx, y0 + dy), (fx, fy)):
            d = math.sqrt(qx * qx + qy * qy)
            if d < limit:
                px[count] = qx
                py[count] = qy
                norm[count] = d
                reach[count] = d
                count += 1
    for j in range(m):
        qx = discs[j, 0] - x
        qy = discs[j, 1] - y
        d = math.sqrt(qx * qx + qy * qy)
        if d - discs[j, 2] < limit:
            px[count] = qx
            py[count] = qy
            norm[count] = d
            reach[count] = d - discs[j, 2]
            count += 1
    cos_half = math.cos(half)
    for k in range(count):
        norm[k] *= cos_half
    for b in range(directions.shape[0]):
        ux = math.cos(theta + directions[b])
        uy = math.sin(theta + directions[b])
        best = out[b]
        for k in range(count):
            if reach[k] < best and px[k] * ux + py[k] * uy >= norm[k]:
                best = reach[k]
        out[b] = best


@njit
def ring_ranges(x: float, y: float, theta: float, directions: np.ndarray, offsets: np.ndarray,
                max_range: float, radius: float, segments: np.ndarray,
                discs: np.ndarray) -> np.ndarray:
    """Ranges of a ring of cone-shaped beams mounted on the rim of a disc of ``radius``.

    Beam ``b`` points at ``theta + directions[b]`` and is sampled by rays at the relative
    ``offsets`` across its cone; it reads the nearest of them, measured from the rim (0 when
    touching) and capped at ``max_range``. With more than one ray the outer ones are the cone's
    edges, and the beam reads the nearest obstacle anywhere inside the cone, also one lying
    wholly between the rays. Distances are taken from the centre less the radius: for a
    beam's axis that is exactly the reading from its mount point on the rim (nothing lies
    inside the robot's disc); elsewhere in the cone it differs from it by at most
    ``radius * (1 - cos(half width))``, under a centimetre for the default ring.
    """
    out = np.empty(directions.shape[0])
    ring_ranges_into(x, y, theta, directions, offsets, max_range, radius, segments, discs, out)
    return out


@njit(inline="always")
def _circle_entry(px: float, py: float, dx: float, dy: float, cx: float, cy: float,
                  r: float) -> float:
    """First t >= 0 at which ``p + t d`` (``p`` outside the circle) reaches the circle."""
    fx = px - cx
    fy = py - cy
    b = fx * dx + fy * dy
    if b >= 0.0:
        return _INF
    a = dx * dx + dy * dy
    c = fx * fx + fy * fy - r * r
    disc = b * b - a * c
    if disc < 0.0:
        return _INF
    return (-b - math.sqrt(disc)) / a


@njit(inline="always")
def _leaving(nx: float, ny: float, dx: float, dy: float, t0x: float, t0y: float, t1x: float,
             t1y: float) -> bool:
    """Whether a move along ``d`` that starts heading ``t0`` and ends heading ``t1`` never
    goes against the outward normal ``n``."""
    return nx * dx + ny * dy >= 0.0 and nx * t0x + ny * t0y >= 0.0 and nx * t1x + ny * t1y >= 0.0


@njit(inline="always")
def _capsule_entry(px: float, py: float, dx: float, dy: float, t0x: float, t0y: float,
                   t1x: float, t1y: float, ax: float, ay: float, bx: float, by: float, r: float,
                   reach2: float) -> float:
    """First t at which ``p + t d`` comes within ``r`` of segment ``ab``.

    Starting within ``r``, the move is blocked at once (0) unless it leaves: see
    :func:`_sweep`.
    """
    d2, qx, qy = _segment_distance2(px, py, ax, ay, bx, by)
    if d2 <= r * r:
        if _leaving(px - qx, py - qy, dx, dy, t0x, t0y, t1x, t1y):
            return _INF
        return 0.0
    if d2 > reach2:
        return _INF
    best = _INF
    ex = bx - ax
    ey = by - ay
    length = math.sqrt(ex * ex + ey * ey)
    if length > 0.0:
        ux = ex / length
        uy = ey / length
        lx = (px - ax) * ux + (py - ay) * uy
        ly = (py - ay) * ux - (px - ax) * uy
        ddx = dx * ux + dy * uy
        ddy = dy * ux - dx * uy
        # Side entries; ``ly`` is compared with 0, not with r, and the time clamped at 0, so
        # that rounding which puts a start just outside by ``d2`` but just inside by ``ly``
        # still reads as an entry at once.
        t = _INF
        if ly >= 0.0 and ddy < 0.0:
            t = max((ly - r) / -ddy, 0.0)
        elif ly < 0.0 and ddy > 0.0:
            t = max((-r - ly) / ddy, 0.0)
        if t < _INF:
            along = lx + t * ddx
            if 0.0 <= along <= length:
                best = t
    best = min(best, _circle_entry(px, py, dx, dy, ax, ay, r))
    return min(best, _circle_entry(px, py, dx, dy, bx, by, r))


@njit
def _sweep(x0: float, y0: float, x1: float, y1: float, radius: float, t0x: float, t0y: float,
           t1x: float, t1y: float, segments: np.ndarray, discs: np.ndarray) -> float:
    """:func:`sweep` for a move whose path starts heading ``t0`` and ends heading ``t1``.

    A path that starts in contact (within ``radius + GAP`` of an obstacle) may go on only if
    neither its chord nor its end headings go against the obstacle's outward normal ``n``:
    the headings of an arc turning less than 180 degrees then all satisfy ``n . u >= 0``, so
    every point ``p`` of it has ``n . (p - p0) >= 0`` and, the distance to a convex obstacle
    being convex with gradient ``n`` at ``p0``, is no nearer than ``p0``.
    """
    dx = x1 - x0
    dy = y1 - y0
    move = math.sqrt(dx * dx + dy * dy)
    if move == 0.0:
        return 1.0
    r = radius + GAP
    reach = r + move
    reach2 = reach * reach
    best = 1.0
    for i in range(segments.shape[0]):
        t = _capsule_entry(x0, y0, dx, dy, t0x, t0y, t1x, t1y, segments[i, 0], segments[i, 1],
                           segments[i, 2], segments[i, 3], r, reach2)
        if t < best:
            best = t
            if best <= 0.0:
                return 0.0
    for i in range(discs.shape[0]):
        cx = discs[i, 0]
        cy = discs[i, 1]
        rr = r + discs[i, 2]
        fx = x0 - cx
        fy = y0 - cy
        if fx * fx + fy * fy <= rr * rr:
            if _leaving(fx, fy, dx, dy, t0x, t0y, t1x, t1y):
                continue
            return 0.0
        t = _circle_entry(x0, y0, dx, dy, cx, cy, rr)
        if t < best:
            best = t
    return max(best, 0.0)


@njit
def sweep(x0: float, y0: float, x1: float, y1: float, radius: float, segments: np.ndarray,
          discs: np.ndarray) -> float:
    """The largest fraction ``u`` in [0, 1] of the straight move ``p0 -> p1`` that a disc of
    ``radius`` can make without touching a segment or a disc (1.0 when the move is free).

    Conservative: contact is computed for ``radius + GAP``, so the disc at ``p0 + u (p1 - p0)``
    keeps a gap to everything. A disc already in contact (within ``radius + GAP``) can move
    away or along, never closer: such a move returns 0.
    """
    dx = x1 - x0
    dy = y1 - y0
    return _sweep(x0, y0, x1, y1, radius, dx, dy, dx, dy, segments, discs)


@njit
def advance(x: float, y: float, theta: float, v: float, w: float, dt: float, radius: float,
            segments: np.ndarray, discs: np.ndarray) -> tuple[float, float, float, bool]:
    """Drive a disc of ``radius`` along the exact unicycle arc of speed ``v`` and turn rate
    ``w`` for ``dt`` seconds; returns ``(x, y, theta, blocked)``.

    The arc is cut into pieces of at most 45 degrees and each piece's chord is swept with the
    radius grown by the piece's sagitta, the farthest the arc strays from its chord, so the
    whole arc is covered; a piece that starts in contact goes on only if it leaves (see
    :func:`_sweep`). A blocked move stops where the chord touches; the heading still
    turns by the full ``w dt`` since a disc turning on the spot cannot hit anything.
    """
    phi = w * dt
    pieces = max(1, math.ceil(abs(phi) / (math.pi / 4.0)))
    h = dt / pieces
    step_phi = w * h
    step_s = v * h
    half = 0.5 * step_phi
    if abs(half) > 1e-9:
        chord = step_s * math.sin(half) / half
        sagitta = abs(step_s) * (1.0 - math.cos(half)) / abs(step_phi)
    else:
        chord = step_s
        sagitta = abs(step_s * step_phi) * 0.125
    cx = x
    cy = y
    heading = theta
    blocked = False
    # The path's own headings: the robot's when driving forward, the opposite in reverse.
    sense = 1.0 if step_s > 0.0 else -1.0
    if step_s != 0.0:
        for _ in range(pieces):
            mid = heading + half
            nx = cx + chord * math.cos(mid)
            ny = cy + chord * math.sin(mid)
            u = _sweep(cx, cy, nx, ny, radius + sagitta, sense * math.cos(heading),
                       sense * math.sin(heading), sense * math.cos(heading + step_phi),
                       sense * math.sin(heading + step_phi), segments, discs)
            if u < 1.0:
                cx += u * (nx - cx)
                cy += u * (ny - cy)
                blocked = True
                break
            cx = nx
            cy = ny
            heading += step_phi
    return cx, cy, wrap(theta + phi), blocked


@njit
def wrap(angle: float) -> float:
    """``angle`` wrapped into (-pi, pi]."""
    return angle - 2.0 * math.pi * math.ceil((angle - math.pi) / (2.0 * math.pi))


@njit
def nearest_point(x: float, y: float, segments: np.ndarray,
                  discs: np.ndarray) -> tuple[float, float, float]:
    """``(distance, qx, qy)``: the obstacle surface point nearest to ``(x, y)`` and the signed
    distance to it (negative inside a disc); ``(inf, nan, nan)`` in an empty world."""
    best = _INF
    bx = np.nan
    by = np.nan
    for i in range(segments.shape[0]):
        d2, qx, qy = _segment_distance2(x, y, segments[i, 0], segments[i, 1], segments[i, 2],
                                        segments[i, 3])
        d = math.sqrt(d2)
        if d < best:
            best = d
            bx = qx
            by = qy
    for i in range(discs.shape[0]):
        fx = x - discs[i, 0]
        fy = y - discs[i, 1]
        centre = math.sqrt(fx * fx + fy * fy)
        d = centre - discs[i, 2]
        if d < best:
            best = d
            if centre > 0.0:
                bx = discs[i, 0] + fx / centre * discs[i, 2]
                by = discs[i, 1] + fy / centre * discs[i, 2]
            else:
                bx = discs[i, 0] + discs[i, 2]
                by = discs[i, 1]
    return best, bx, by


@njit
def clearance(x: float, y: float, segments: np.ndarray, discs: np.ndarray) -> float:
    """Distance from ``(x, y)`` to the nearest obstacle surface (negative inside a disc, inf in
    an empty world)."""
    best = _INF
    for i in range(segments.shape[0]):
        d2, _, _ = _segment_distance2(x, y, segments[i, 0], segments[i, 1], segments[i, 2],
                                      segments[i, 3])
        best = min(best, math.sqrt(d2))
    for i in range(discs.shape[0]):
        fx = x - discs[i, 0]
        fy = y - discs[i, 1]
        best = min(best, math.sqrt(fx * fx + fy * fy) - discs[i, 2])
    return best


@njit(inline="always")
def _blocks(x0: float, y0: float, dx: float, dy: float, ax: float, ay: float, bx: float,
            by: float) -> bool:
    """Whether segment ``ab`` meets the closed segment ``p0 -> p0 + d``."""
    ex = bx - ax
    ey = by - ay
    wx = ax - x0
    wy = ay - y0
    denom = dx * ey - dy * ex
    if denom != 0.0:
        t = (wx * ey - wy * ex) / denom
        s = (wx * dy - wy * dx) / denom
        return 0.0 <= t <= 1.0 and 0.0 <= s <= 1.0
    if wx * dy - wy * dx != 0.0:
        return False
    length2 = dx * dx + dy * dy
    if length2 == 0.0:
        return False
    ta = (wx * dx + wy * dy) / length2
    tb = ((bx - x0) * dx + (by - y0) * dy) / length2
    return max(ta, tb) >= 0.0 and min(ta, tb) <= 1.0


@njit
def visible(x0: float, y0: float, x1: float, y1: float, segments: np.ndarray) -> bool:
    """Line of sight: no segment meets the straight line from ``p0`` to ``p1`` (touching
    counts as blocking)."""
    dx = x1 - x0
    dy = y1 - y0
    for i in range(segments.shape[0]):
        if _blocks(x0, y0, dx, dy, segments[i, 0], segments[i, 1], segments[i, 2],
                   segments[i, 3]):
            return False
    return True


@njit
def landmarks_seen(x: float, y: float, theta: float, landmarks: np.ndarray, fov: float,
                   max_range: float, segments: np.ndarray, out: np.ndarray) -> int:
    """The landmarks a camera at ``(x, y)`` facing ``theta`` sees, written compactly into the
    first rows of ``out`` ``(k, 3)`` as ``index, distance, bearing``; returns how many.

    A landmark of ``landmarks`` ``(k, 3)`` is seen when its centre lies within ``max_range``,
    within ``fov / 2`` of the heading, and no segment crosses the line of sight to it.
    Distances are to the centre, bearings relative to ``theta`` in (-pi, pi].
    """
    half = 0.5 * fov
    n = 0
    for i in range(landmarks.shape[0]):
        dx = landmarks[i, 0] - x
        dy = landmarks[i, 1] - y
        distance = math.sqrt(dx * dx + dy * dy)
        if distance > max_range:
            continue
        bearing = wrap(math.atan2(dy, dx) - theta)
        if abs(bearing) > half:
            continue
        clear = True
        for j in range(segments.shape[0]):
            if _blocks(x, y, dx, dy, segments[j, 0], segments[j, 1], segments[j, 2],
                       segments[j, 3]):
                clear = False
                break
        if clear:
            out[n, 0] = i
            out[n, 1] = distance
            out[n, 2] = bearing
            n += 1
    return n


@njit
def landmark_view(x: float, y: float, theta: float, landmarks: np.ndarray, fov: float,
                  max_range: float, segments: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What a camera at ``(x, y)`` facing ``theta`` sees of landmarks ``(k, 3)``.

    Returns ``(seen, distance, bearing)``, each ``(k,)``: whether each landmark is seen (see
    :func:`landmarks_seen`), and the distance and bearing of every landmark's centre.
    """
    k = landmarks.shape[0]
    seen = np.zeros(k, np.bool_)
    distance = np.empty(k)
    bearing = np.empty(k)
    for i in range(k):
        dx = landmarks[i, 0] - x
        dy = landmarks[i, 1] - y
        distance[i] = math.sqrt(dx * dx + dy * dy)
        bearing[i] = wrap(math.atan2(dy, dx) - theta)
    rows = np.empty((k, 3))
    n = landmarks_seen(x, y, theta, landmarks, fov, max_range, segments, rows)
    for j in range(n):
        seen[int(rows[j, 0])] = True
    return seen, distance, bearing
