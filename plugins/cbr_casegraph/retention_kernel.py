"""The compiled part of retention: eq. (12) and the writes of one retained path, with no Python
per segment.

:func:`retain` takes the path's candidate segments (cut by :mod:`cbr_casegraph.retention`) and
changes the index's arrays in place exactly as :mod:`cbr_casegraph.writes` would one segment at a
time: a segment similar by eq. (12) to one stored before the path is skipped, the others are
connected (the edges at their ends split there), priced and indexed. New edges take the ids from
the index's next id on, which tells them from the edges stored before the path; the kernel logs
every insert and drop in order, so that the caller can write them to a case base and give the new
edges the ids it chooses.

The index's arrays must have room for what the path can add: two vertices and five edge ids per
segment (the segment and the two parts of each edge split at its ends), and every cell of the
segments a tile (:mod:`cbr_casegraph.tiles`).
"""

from __future__ import annotations

import numpy as np

from cbr_casegraph.search import run_cost, run_risk
from cbr_casegraph.tile_kernels import cell_value, set_cell
from cbr_casegraph.tiles import OWNER, SIZE, VERTEX
from cbr_kernels import njit

CHEBYSHEV = 0
MANHATTAN = 1
EUCLIDEAN = 2
OCTILE = 3
MEASURES = {"chebyshev": CHEBYSHEV, "manhattan": MANHATTAN, "euclidean": EUCLIDEAN,
            "octile": OCTILE}
"""The code of each distance of :mod:`cbr_grid.distances` in the kernels."""

CONNECTED = 0
SPLIT_PART = 1
DROPPED = 2
"""The kinds of the log's entries: an edge a segment made, one part of a split edge (after
the entry dropping that edge), an edge dropped because it was split."""

SLOTS = 0
NEXT_ID = 1
FREE = 2
CONNECTIONS = 3
"""The positions in the counters array: vertex slots in use, the next edge id, free vertex
slots left, and the edges connected so far."""


@njit(inline="always")
def _within(measure: int, px: int, py: int, qx: int, qy: int, delta: int) -> bool:
    """Whether cells p and q are within ``delta`` under ``measure``, decided as the float
    distances of :mod:`cbr_grid.distances` decide it."""
    dx, dy = abs(px - qx), abs(py - qy)
    if measure == CHEBYSHEV:
        return max(dx, dy) <= delta
    if measure == MANHATTAN:
        return dx + dy <= delta
    if measure == EUCLIDEAN:
        # exact on integers: the square root of an integer is never within an ulp of an
        # integer it differs from
        return dx * dx + dy * dy <= delta * delta
    return (np.sqrt(2.0) - 1.0) * min(dx, dy) + max(dx, dy) <= delta


@njit(inline="always")
def _slot(dx: int, dy: int) -> int:
    """The column of the leaving-edge table for the direction of (dx, dy)."""
    code = (np.sign(dy) + 1) * 3 + np.sign(dx) + 1
    return code - 1 if code > 4 else code


@njit
def similar(directory: np.ndarray, tiles: np.ndarray, vx: np.ndarray, vy: np.ndarray,
            leaving: np.ndarray, ea: np.ndarray, eb: np.ndarray, ax: int, ay: int, bx: int,
            by: int, delta: int, measure: int, before: int, replaced: np.ndarray, count: int
            ) -> bool:
    """Eq. (12): whether an edge with an id below ``before``, or one of the first ``count``
    ends (ax, ay, bx, by) of ``replaced``, has its ends within ``delta`` of a and b (either
    way round) under ``measure``.

    Every distance is at least the Chebyshev distance, so one end of such an edge is a vertex
    in the square N(a, delta): the vertices there and their edges are every candidate.
    """
    # cells past the map but in its last tiles are in no tile's layers: -1, as if clipped
    h, w = directory.shape[0] * SIZE, directory.shape[1] * SIZE
    for y in range(max(ay - delta, 0), min(ay + delta, h - 1) + 1):
        for x in range(max(ax - delta, 0), min(ax + delta, w - 1) + 1):
            v = cell_value(directory, tiles, VERTEX, x, y)
            if v < 0 or not _within(measure, x, y, ax, ay, delta):
                continue
            for s in range(8):
                e = leaving[v, s]
                if e < 0 or e >= before:
                    continue
                o = eb[e] if ea[e] == v else ea[e]
                if _within(measure, vx[o], vy[o], bx, by, delta):
                    return True
    for k in range(count):
        px, py, qx, qy = replaced[k, 0], replaced[k, 1], replaced[k, 2], replaced[k, 3]
        if ((_within(measure, px, py, ax, ay, delta) and _within(measure, qx, qy, bx, by, delta))
                or (_within(measure, qx, qy, ax, ay, delta)
                    and _within(measure, px, py, bx, by, delta))):
            return True
    return False


@njit
def candidates(directory: np.ndarray, tiles: np.ndarray, leaving: np.ndarray, ea: np.ndarray,
               eb: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The new segments of the loop-free path ``cells`` before eq. (12) is asked about them,
    and its crossings of stored diagonal steps.

    A step is new unless it runs along a stored edge. Each maximal stretch of new steps is
    cut at its turns, at the cells the graph already holds and where a new diagonal step
    crosses a stored one between cells (an X in a 2x2 block). Returns the segments (rows ax,
    ay, bx, by, in path order) and the crossings (rows: the crossing step's first cell, the
    stored cell beside it that a one-step edge joins it to).
    """
    n = cells.shape[0]
    vertex = np.empty(n, dtype=np.int64)
    inside = np.empty(n, dtype=np.int64)
    for i in range(n):
        vertex[i] = cell_value(directory, tiles, VERTEX, cells[i, 0], cells[i, 1])
        inside[i] = cell_value(directory, tiles, OWNER, cells[i, 0], cells[i, 1])
    new = np.ones(max(n - 1, 0), dtype=np.bool_)
    cut = np.zeros(n, dtype=np.bool_)
    crossings = np.empty((max(n - 1, 0), 4), dtype=np.int64)
    found = 0
    for i in range(n - 1):
        dx, dy = cells[i + 1, 0] - cells[i, 0], cells[i + 1, 1] - cells[i, 1]
        if inside[i] >= 0 and inside[i + 1] >= 0:
            new[i] = inside[i] != inside[i + 1]
        elif vertex[i] >= 0 and inside[i + 1] >= 0:
            # along that edge when the vertex is one of its ends
            new[i] = ea[inside[i + 1]] != vertex[i] and eb[inside[i + 1]] != vertex[i]
        elif inside[i] >= 0 and vertex[i + 1] >= 0:
            new[i] = ea[inside[i]] != vertex[i + 1] and eb[inside[i]] != vertex[i + 1]
        elif vertex[i] >= 0 and vertex[i + 1] >= 0:
            # two vertices side by side: along the one-step edge between them, if any
            new[i] = leaving[vertex[i], _slot(dx, dy)] < 0
        if new[i] and dx != 0 and dy != 0:
            # the two cells beside a diagonal step p -> q: r = (q.x, p.y), t = (p.x, q.y)
            rx, ry = cells[i + 1, 0], cells[i, 1]
            tx, ty = cells[i, 0], cells[i + 1, 1]
            if _share_an_edge(directory, tiles, leaving, rx, ry, tx, ty):
                crossings[found, 0], crossings[found, 1] = cells[i, 0], cells[i, 1]
                crossings[found, 2], crossings[found, 3] = rx, ry
                found += 1
                cut[i] = True
    if n == 0:
        return np.empty((0, 4), dtype=np.int64), crossings[:0]
    cut[0] = cut[n - 1] = True
    for i in range(n):
        if vertex[i] >= 0 or inside[i] >= 0:
            cut[i] = True
    for i in range(1, n - 1):
        if (new[i - 1] != new[i] or cells[i, 0] - cells[i - 1, 0] != cells[i + 1, 0] - cells[i, 0]
                or cells[i, 1] - cells[i - 1, 1] != cells[i + 1, 1] - cells[i, 1]):
            cut[i] = True
    segments = np.empty((n, 4), dtype=np.int64)
    count = 0
    last = 0
    for j in range(1, n):
        if not cut[j]:
            continue
        # a stretch of new steps begins and ends at a cut, so the pair of cuts around a new
        # step is a segment of it and the pair around a stored step is not
        if new[last]:
            segments[count, 0], segments[count, 1] = cells[last, 0], cells[last, 1]
            segments[count, 2], segments[count, 3] = cells[j, 0], cells[j, 1]
            count += 1
        last = j
    return segments[:count], crossings[:found]


@njit(inline="always")
def _share_an_edge(directory: np.ndarray, tiles: np.ndarray, leaving: np.ndarray, rx: int,
                   ry: int, tx: int, ty: int) -> bool:
    """Whether an edge contains both cells r and t: the one a cell is inside of, or those
    meeting at it."""
    r_in = cell_value(directory, tiles, OWNER, rx, ry)
    t_in = cell_value(directory, tiles, OWNER, tx, ty)
    r_at = cell_value(directory, tiles, VERTEX, rx, ry)
    t_at = cell_value(directory, tiles, VERTEX, tx, ty)
    if (r_in < 0 and r_at < 0) or (t_in < 0 and t_at < 0):
        return False
    if r_in >= 0 and t_in >= 0:
        return r_in == t_in
    if r_in >= 0 or t_in >= 0:
        edge = r_in if r_in >= 0 else t_in
        at = t_at if r_in >= 0 else r_at
        return bool((leaving[at] == edge).any())
    for s in range(8):
        for u in range(8):
            if leaving[r_at, s] >= 0 and leaving[r_at, s] == leaving[t_at, u]:
                return True
    return False


@njit
def retain(directory: np.ndarray, tiles: np.ndarray, vx: np.ndarray, vy: np.ndarray,
           leaving: np.ndarray, ea: np.ndarray, eb: np.ndarray, cost: np.ndarray,
           risk: np.ndarray, uses: np.ndarray, created: np.ndarray, alive: np.ndarray,
           free: np.ndarray, counters: np.ndarray, factor: np.ndarray, passable: np.ndarray,
           corner_cutting: bool, risk_map: np.ndarray, segments: np.ndarray,
           crossings: np.ndarray, delta: int, measure: int, log: np.ndarray,
           changed: np.ndarray, added: np.ndarray) -> tuple[int, int, int]:
    """Retain the candidate ``segments`` (rows ax, ay, bx, by, in path order), then the one-step
    ``crossings`` (rows: a cell of the path, the stored cell beside it) whose path cell is a
    vertex by then.

    A segment is skipped when, at ``delta`` > 0, an edge stored before the path is similar to
    it by eq. (12) under ``measure`` (edges the path split away are compared as they were).
    Fills ``log`` (rows: kind, edge id), ``changed`` (vertices whose edges changed) and
    ``added`` (the edges the segments and crossings made) and returns how many of each. The
    k-th edge added gets the creation stamp -k, and the parts of a split edge its stamp.
    """
    before = counters[NEXT_ID]
    replaced = np.empty((2 * (segments.shape[0] + crossings.shape[0]) + 1, 4), dtype=np.int64)
    n = np.zeros(4, dtype=np.int64)  # log entries, changed vertices, added edges, replaced
    for k in range(segments.shape[0] + crossings.shape[0]):
        if k < segments.shape[0]:
            ax, ay, bx, by = segments[k, 0], segments[k, 1], segments[k, 2], segments[k, 3]
            if delta > 0 and similar(directory, tiles, vx, vy, leaving, ea, eb, ax, ay, bx, by,
                                     delta, measure, before, replaced, n[3]):
                continue
        else:
            row = k - segments.shape[0]
            ax, ay = crossings[row, 0], crossings[row, 1]
            bx, by = crossings[row, 2], crossings[row, 3]
            if cell_value(directory, tiles, VERTEX, ax, ay) < 0:  # its segment was skipped
                continue
        va = _vertex(directory, tiles, vx, vy, leaving, ea, eb, cost, risk, uses, created,
                     alive, free, counters, factor, passable, corner_cutting, risk_map, ax, ay,
                     before, log, changed, replaced, n)
        vb = _vertex(directory, tiles, vx, vy, leaving, ea, eb, cost, risk, uses, created,
                     alive, free, counters, factor, passable, corner_cutting, risk_map, bx, by,
                     before, log, changed, replaced, n)
        joined = leaving[va, _slot(bx - ax, by - ay)]
        if joined >= 0 and (eb[joined] if ea[joined] == va else ea[joined]) == vb:
            continue
        # the stamp is the connection's number, negated: the caller knows the stamps
        counters[CONNECTIONS] += 1
        edge = _insert(directory, tiles, vx, vy, leaving, ea, eb, cost, risk, uses, created,
                       alive, counters, factor, passable, corner_cutting, risk_map, va, vb, 0,
                       -counters[CONNECTIONS], log, CONNECTED, changed, n)
        added[n[2]] = edge
        n[2] += 1
    return n[0], n[1], n[2]


@njit
def _vertex(directory: np.ndarray, tiles: np.ndarray, vx: np.ndarray, vy: np.ndarray,
            leaving: np.ndarray, ea: np.ndarray, eb: np.ndarray, cost: np.ndarray,
            risk: np.ndarray, uses: np.ndarray, created: np.ndarray, alive: np.ndarray,
            free: np.ndarray, counters: np.ndarray, factor: np.ndarray, passable: np.ndarray,
            corner_cutting: bool, risk_map: np.ndarray, x: int, y: int, before: int,
            log: np.ndarray, changed: np.ndarray, replaced: np.ndarray, n: np.ndarray) -> int:
    """The vertex on (x, y), made if needed (from the last free slot, else a new one), the
    edge whose interior held the cell split there."""
    v = cell_value(directory, tiles, VERTEX, x, y)
    if v >= 0:
        return v
    through = cell_value(directory, tiles, OWNER, x, y)
    if counters[FREE] > 0:
        counters[FREE] -= 1
        v = free[counters[FREE]]
    else:
        v = counters[SLOTS]
        counters[SLOTS] += 1
    vx[v], vy[v] = x, y
    set_cell(directory, tiles, VERTEX, x, y, v)
    if through < 0:
        return v
    # the split edge's ends stay vertices: its parts come back now
    va, vb = ea[through], eb[through]
    _drop(directory, tiles, vx, vy, leaving, ea, eb, alive, through, log, changed, n)
    if through < before:
        r = n[3]
        replaced[r, 0], replaced[r, 1] = vx[va], vy[va]
        replaced[r, 2], replaced[r, 3] = vx[vb], vy[vb]
        n[3] += 1
    _insert(directory, tiles, vx, vy, leaving, ea, eb, cost, risk, uses, created, alive,
            counters, factor, passable, corner_cutting, risk_map, va, v, uses[through],
            created[through], log, SPLIT_PART, changed, n)
    _insert(directory, tiles, vx, vy, leaving, ea, eb, cost, risk, uses, created, alive,
            counters, factor, passable, corner_cutting, risk_map, v, vb, uses[through],
            created[through], log, SPLIT_PART, changed, n)
    return v


@njit
def _insert(directory: np.ndarray, tiles: np.ndarray, vx: np.ndarray, vy: np.ndarray,
            leaving: np.ndarray, ea: np.ndarray, eb: np.ndarray, cost: np.ndarray,
            risk: np.ndarray, uses: np.ndarray, created: np.ndarray, alive: np.ndarray,
            counters: np.ndarray, factor: np.ndarray, passable: np.ndarray,
            corner_cutting: bool, risk_map: np.ndarray, va: int, vb: int, edge_uses: int,
            stamp: int, log: np.ndarray, kind: int, changed: np.ndarray, n: np.ndarray) -> int:
    """Put a new edge, priced on the map, between vertices va and vb; its id."""
    edge = counters[NEXT_ID]
    counters[NEXT_ID] += 1
    ax, ay, bx, by = vx[va], vy[va], vx[vb], vy[vb]
    ea[edge], eb[edge] = va, vb
    cost[edge] = run_cost(factor, passable, corner_cutting, ax, ay, bx, by)
    risk[edge] = run_risk(risk_map, ax, ay, bx, by)
    uses[edge], created[edge], alive[edge] = edge_uses, stamp, True
    dx, dy = bx - ax, by - ay
    leaving[va, _slot(dx, dy)] = edge
    leaving[vb, _slot(-dx, -dy)] = edge
    _interior(directory, tiles, ax, ay, bx, by, edge)
    log[n[0], 0], log[n[0], 1] = kind, edge
    changed[n[1]], changed[n[1] + 1] = va, vb
    n[0] += 1
    n[1] += 2
    return edge


@njit
def _drop(directory: np.ndarray, tiles: np.ndarray, vx: np.ndarray, vy: np.ndarray,
          leaving: np.ndarray, ea: np.ndarray, eb: np.ndarray, alive: np.ndarray, edge: int,
          log: np.ndarray, changed: np.ndarray, n: np.ndarray) -> None:
    """Take ``edge`` out, keeping its ends as vertices."""
    va, vb = ea[edge], eb[edge]
    ax, ay, bx, by = vx[va], vy[va], vx[vb], vy[vb]
    _interior(directory, tiles, ax, ay, bx, by, -1)
    alive[edge] = False
    leaving[va, _slot(bx - ax, by - ay)] = -1
    leaving[vb, _slot(ax - bx, ay - by)] = -1
    log[n[0], 0], log[n[0], 1] = DROPPED, edge
    changed[n[1]], changed[n[1] + 1] = va, vb
    n[0] += 1
    n[1] += 2


@njit(inline="always")
def _interior(directory: np.ndarray, tiles: np.ndarray, ax: int, ay: int, bx: int, by: int,
              value: int) -> None:
    """Set the cells strictly between a and b on their straight segment to ``value``."""
    dx, dy = np.sign(bx - ax), np.sign(by - ay)
    for i in range(1, max(abs(bx - ax), abs(by - ay))):
        set_cell(directory, tiles, OWNER, ax + i * dx, ay + i * dy, value)
