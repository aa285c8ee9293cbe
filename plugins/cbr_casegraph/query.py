"""The compiled CBR query of the case graph planner: steps 3-6 and the path, with no Python per
step.

One query is a constant number of kernel calls: :func:`cases_near` per terminal (E_s and E_g of
eq. 11), then :func:`adapt_swept` (the Dijkstra connector: both local sweeps, the temporary
edges, the virtual splits, the search over the extended graph and the cell path) or, for a
connector that searches once per case, :func:`extend` with the temporary edges it found.

The stored graph enters as its CSR adjacency plus three tables by edge id (the vertices at the
edge's ends a and b, and its cost): :class:`EdgeTables`, built once per adjacency. The overlay of
the query (virtual vertices, temporary edges, the parts of split edges) lives in the kernel's
own small arrays and is numbered exactly as the planner's Python overlay numbers it, so that
equally cheap paths are broken the same way: virtual vertices in the order they are first met
(start, its link targets, goal, its link targets), split edges in the order of their first
virtual vertex, each split from its end a to its end b.
"""

from __future__ import annotations

import numpy as np

from cbr_casegraph.search import descend, graph_search, path_cost, run_costs
from cbr_casegraph.tile_kernels import cell_value
from cbr_casegraph.tiles import OWNER, SIZE, VERTEX
from cbr_kernels import njit
from cbr_solvers.aistar import COST_STEPS, wavefront

OK = 0
NO_START_LINK = 1
NO_GOAL_LINK = 2
NOT_CONNECTED = 3
"""Status codes of an adaptation: a path, or why there is none."""

START_LINK = -1
GOAL_LINK = -2
"""The kind of a temporary edge that is a local path (others are parts of a stored edge)."""


@njit
def cases_near(directory: np.ndarray, tiles: np.ndarray, indptr: np.ndarray, edge: np.ndarray,
               e_a: np.ndarray, e_b: np.ndarray, e_cost: np.ndarray, xy: np.ndarray,
               cx: int, cy: int, delta: int, selective: bool) -> tuple[np.ndarray, bool]:
    """The edges of finite cost meeting N((cx, cy), delta), ascending, and whether the cell lies
    on the graph (inside an edge, or a vertex with edges).

    Full adaptation takes every edge with a cell in the square; selective adaptation only those
    with an end within 3·delta of the cell (eqs. 9-11).
    """
    # cells past the map but in its last tiles are in no tile's layers: -1, as if clipped
    h, w = directory.shape[0] * SIZE, directory.shape[1] * SIZE
    x0, y0 = max(cx - delta, 0), max(cy - delta, 0)
    x1, y1 = min(cx + delta, w - 1), min(cy + delta, h - 1)
    found = np.empty(64, dtype=np.int64)
    count = np.int64(0)  # not the literal 0: numba would compile _sorted_unique for it too
    for y in range(y0, y1 + 1):
        for x in range(x0, x1 + 1):
            inside = cell_value(directory, tiles, OWNER, x, y)
            vertex = cell_value(directory, tiles, VERTEX, x, y)
            lo, hi = 0, 0
            if vertex >= 0:
                lo, hi = indptr[vertex], indptr[vertex + 1]
            need = count + (1 if inside >= 0 else 0) + hi - lo
            if need > found.shape[0]:
                found = np.concatenate((found, np.empty(max(need, found.shape[0]),
                                                        dtype=np.int64)))
            if inside >= 0:
                found[count] = inside
                count += 1
            for k in range(lo, hi):
                found[count] = edge[k]
                count += 1
    edges = _sorted_unique(found, count)
    keep = np.zeros(edges.shape[0], dtype=np.bool_)
    reach = 3 * delta
    for i in range(edges.shape[0]):
        e = edges[i]
        if not e_cost[e] < np.inf:
            continue
        if selective:
            a, b = e_a[e], e_b[e]
            near_a = max(abs(xy[a, 0] - cx), abs(xy[a, 1] - cy)) <= reach
            near_b = max(abs(xy[b, 0] - cx), abs(xy[b, 1] - cy)) <= reach
            if not (near_a or near_b):
                continue
        keep[i] = True
    vertex = cell_value(directory, tiles, VERTEX, cx, cy)
    on_graph = (cell_value(directory, tiles, OWNER, cx, cy) >= 0
                or (vertex >= 0 and indptr[vertex + 1] > indptr[vertex]))
    return edges[keep], on_graph


@njit
def _sorted_unique(values: np.ndarray, count: int) -> np.ndarray:
    """The distinct values of ``values[:count]``, ascending, sorted in place by insertion: the
    edges around a cell are few, and numba's own sort would take seconds to compile."""
    for i in range(1, count):
        value = values[i]
        j = i - 1
        while j >= 0 and values[j] > value:
            values[j + 1] = values[j]
            j -= 1
        values[j + 1] = value
    distinct = 0
    for i in range(count):
        if distinct == 0 or values[i] != values[distinct - 1]:
            values[distinct] = values[i]
            distinct += 1
    return values[:distinct].copy()


@njit(inline="always")
def _span(a: int, d: int, length: int, c: int, delta: int) -> tuple[int, int]:
    """The positions i in [0, length] with |a + i·d - c| <= delta (empty when lo > hi)."""
    if d == 0:
        return (0, length) if abs(a - c) <= delta else (1, 0)
    if d > 0:
        return max(c - delta - a, 0), min(c + delta - a, length)
    return max(a - c - delta, 0), min(a - c + delta, length)


@njit
def local_links(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
                e_a: np.ndarray, e_b: np.ndarray, xy: np.ndarray, cases: np.ndarray,
                cx: int, cy: int, delta: int, radius: int
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Step 4 with the Dijkstra connector: one sweep from (cx, cy) over N(., radius), stopped
    once every cell of the cases within N(., delta) is settled, and the link targets: of each
    case its cheapest cells there (ties all kept, since which one the best path should use
    depends on where it goes next).

    Returns (box (x0, y0, x1, y1), the sweep's costs over the box, row-major, the targets as
    (k, 2) cells in row-major order without repeats, their costs).
    """
    h, w = passable.shape
    x0, y0 = max(cx - radius, 0), max(cy - radius, 0)
    x1, y1 = min(cx + radius, w - 1), min(cy + radius, h - 1)
    ww = x1 - x0 + 1
    n = ww * (y1 - y0 + 1)
    count = cases.shape[0]
    spans = np.empty((count, 2), dtype=np.int64)
    want = np.zeros(n, dtype=np.bool_)
    for k in range(count):
        a, b = e_a[cases[k]], e_b[cases[k]]
        ax, ay = xy[a, 0], xy[a, 1]
        dx, dy = np.sign(xy[b, 0] - ax), np.sign(xy[b, 1] - ay)
        length = max(abs(xy[b, 0] - ax), abs(xy[b, 1] - ay))
        lx, hx = _span(ax, dx, length, cx, delta)
        ly, hy = _span(ay, dy, length, cy, delta)
        lo, hi = max(lx, ly), min(hx, hy)
        spans[k, 0], spans[k, 1] = lo, hi
        for i in range(lo, hi + 1):
            cell = (ay + i * dy - y0) * ww + (ax + i * dx - x0)
            want[cell] = True
    source = np.array([[cx, cy]], dtype=np.int64)
    # an int64, not the constant numba would type as the literal 1: the literal compiles a
    # wavefront of its own, where int64 shares the one the planners compile from Python
    dist = wavefront(factor, passable, corner_cutting, source, x0, y0, x1, y1,
                     np.int64(COST_STEPS), np.flatnonzero(want))
    chosen = np.zeros(n, dtype=np.bool_)
    for k in range(count):
        a, b = e_a[cases[k]], e_b[cases[k]]
        ax, ay = xy[a, 0], xy[a, 1]
        dx, dy = np.sign(xy[b, 0] - ax), np.sign(xy[b, 1] - ay)
        best = np.inf
        for i in range(spans[k, 0], spans[k, 1] + 1):
            best = min(best, dist[(ay + i * dy - y0) * ww + (ax + i * dx - x0)])
        if not best < np.inf:
            continue
        for i in range(spans[k, 0], spans[k, 1] + 1):
            cell = (ay + i * dy - y0) * ww + (ax + i * dx - x0)
            if dist[cell] == best:
                chosen[cell] = True
    targets = np.flatnonzero(chosen)
    cells = np.empty((targets.shape[0], 2), dtype=np.int64)
    costs = np.empty(targets.shape[0])
    for i in range(targets.shape[0]):
        cells[i, 0] = x0 + targets[i] % ww
        cells[i, 1] = y0 + targets[i] // ww
        costs[i] = dist[targets[i]]
    box = np.array([x0, y0, x1, y1], dtype=np.int64)
    return box, dist, cells, costs


@njit
def adapt_swept(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
                directory: np.ndarray, tiles: np.ndarray, indptr: np.ndarray,
                target: np.ndarray, weight: np.ndarray, edge: np.ndarray, xy: np.ndarray,
                e_a: np.ndarray, e_b: np.ndarray, start_cases: np.ndarray,
                goal_cases: np.ndarray, start_on_graph: bool, goal_on_graph: bool,
                sx: int, sy: int, gx: int, gy: int, delta: int, radius: int, informed: bool,
                scale: float, potential: np.ndarray
                ) -> tuple[int, np.ndarray, float, np.ndarray, int, int]:
    """Steps 4-6 and the path with the Dijkstra connector, as :func:`extend` returns them."""
    s_box, s_dist, s_cells, s_costs = local_links(factor, passable, corner_cutting, e_a, e_b,
                                                  xy, start_cases, sx, sy, delta, radius)
    none = np.zeros(0, dtype=np.int64)
    if _links_beside(s_cells, sx, sy) == 0 and not start_on_graph:
        return NO_START_LINK, np.zeros((0, 2), dtype=np.int64), np.inf, none, 0, 0
    g_box, g_dist, g_cells, g_costs = local_links(factor, passable, corner_cutting, e_a, e_b,
                                                  xy, goal_cases, gx, gy, delta, radius)
    offsets = np.zeros(1, dtype=np.int64)
    paths = np.zeros((0, 2), dtype=np.int64)
    return extend(factor, passable, corner_cutting, directory, tiles, indptr, target, weight,
                  edge, xy, e_a, e_b, start_on_graph, goal_on_graph, sx, sy, gx, gy,
                  s_cells, s_costs, s_box, s_dist, offsets, paths,
                  g_cells, g_costs, g_box, g_dist, offsets, paths, informed, scale, potential)


@njit
def _links_beside(cells: np.ndarray, x: int, y: int) -> int:
    """How many of the link targets are not the terminal's own cell."""
    count = 0
    for i in range(cells.shape[0]):
        if cells[i, 0] != x or cells[i, 1] != y:
            count += 1
    return count


@njit
def _vertex(directory: np.ndarray, tiles: np.ndarray, base: int, vx: np.ndarray,
            vy: np.ndarray, split_edge: np.ndarray, split_at: np.ndarray,
            counts: np.ndarray, x: int, y: int) -> int:
    """The vertex of (x, y) in G': a stored one, or a virtual one made on first use (and
    recorded as a split point when it lies inside a stored edge). ``counts`` holds the number
    of virtual vertices and of split points."""
    stored = cell_value(directory, tiles, VERTEX, x, y)
    if stored >= 0:
        return stored
    for i in range(counts[0]):
        if vx[i] == x and vy[i] == y:
            return base + i
    i = counts[0]
    vx[i], vy[i] = x, y
    counts[0] += 1
    inside = cell_value(directory, tiles, OWNER, x, y)
    if inside >= 0:
        split_edge[counts[1]] = inside
        split_at[counts[1]] = i
        counts[1] += 1
    return base + i


@njit
def extend(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
           directory: np.ndarray, tiles: np.ndarray, indptr: np.ndarray, target: np.ndarray,
           weight: np.ndarray, edge: np.ndarray, xy: np.ndarray, e_a: np.ndarray,
           e_b: np.ndarray, start_on_graph: bool, goal_on_graph: bool,
           sx: int, sy: int, gx: int, gy: int,
           s_cells: np.ndarray, s_costs: np.ndarray, s_box: np.ndarray, s_dist: np.ndarray,
           s_offsets: np.ndarray, s_paths: np.ndarray,
           g_cells: np.ndarray, g_costs: np.ndarray, g_box: np.ndarray, g_dist: np.ndarray,
           g_offsets: np.ndarray, g_paths: np.ndarray, informed: bool, scale: float,
           potential: np.ndarray) -> tuple[int, np.ndarray, float, np.ndarray, int, int]:
    """Steps 4-6 and the path, from the temporary edges of start and goal.

    Each terminal's links are its target cells and their costs; the cells of link k are either
    given (``*_paths[*_offsets[k]:*_offsets[k + 1]]``, from the terminal) or, when no paths are
    given, traced back through the terminal's sweep (``*_dist`` over ``*_box``) when the best
    path uses it. A link to the terminal's own cell is left out.

    Returns (status, the cell path with loops cut out, its cost on the map, for each hop of the
    path found in G' the stored edge it runs along or is a part of (-1 for a local path), the
    number of temporary edges, the vertices the graph search settled).

    ``potential`` is the landmark table of the stored vertices
    (:class:`cbr_casegraph.potentials.Potentials`), with no rows when the search is not to
    use it. A virtual vertex inside a stored edge gets the entries the table would hold for it,
    the least over the edge's two ends of the end's entry plus the parts' costs between; the
    goal's interval of each landmark spans its targets' entries widened by their links' costs
    (the goal's own entry too, when it lies on the graph), so that the bound stays consistent
    across the goal's links.
    """
    none = np.zeros(0, dtype=np.int64)
    base = indptr.shape[0] - 1
    links = s_cells.shape[0] + g_cells.shape[0]
    capacity = links + 2
    vx = np.empty(capacity, dtype=np.int64)
    vy = np.empty(capacity, dtype=np.int64)
    split_edge = np.empty(capacity, dtype=np.int64)
    split_at = np.empty(capacity, dtype=np.int64)
    counts = np.zeros(2, dtype=np.int64)
    # temporary edges: ends, cost, and what they are (START_LINK / GOAL_LINK and the link's
    # index, or the stored edge a part of which they are)
    eu = np.empty(2 * capacity + links, dtype=np.int64)
    ev = np.empty_like(eu)
    ew = np.empty(eu.shape[0])
    kind = np.empty_like(eu)
    link_of = np.empty_like(eu)
    temporary = 0
    ends = np.empty(2, dtype=np.int64)
    for side in range(2):
        if side == 0:
            x, y, cells, costs, on_graph = sx, sy, s_cells, s_costs, start_on_graph
        else:
            x, y, cells, costs, on_graph = gx, gy, g_cells, g_costs, goal_on_graph
        here = _vertex(directory, tiles, base, vx, vy, split_edge, split_at, counts,
                       x, y)
        ends[side] = here
        made = 0
        for k in range(cells.shape[0]):
            if cells[k, 0] == x and cells[k, 1] == y:
                continue
            there = _vertex(directory, tiles, base, vx, vy, split_edge, split_at,
                            counts, cells[k, 0], cells[k, 1])
            eu[temporary], ev[temporary], ew[temporary] = here, there, costs[k]
            kind[temporary] = START_LINK if side == 0 else GOAL_LINK
            link_of[temporary] = k
            temporary += 1
            made += 1
        if made == 0 and not on_graph:
            return (NO_START_LINK if side == 0 else NO_GOAL_LINK,
                    np.zeros((0, 2), dtype=np.int64), np.inf, none, temporary, 0)
    # the parts of every stored edge with virtual vertices inside it, from its end a to b
    done = np.zeros(counts[1], dtype=np.bool_)
    part_from = np.empty((counts[1] * 2 + 2, 2), dtype=np.int64)
    part_to = np.empty_like(part_from)
    first_part = temporary
    # per split edge, its first part and the virtual vertices inside it, in order from a
    group_part = np.empty(counts[1] + 1, dtype=np.int64)
    group_edge = np.empty(counts[1], dtype=np.int64)
    group_points = np.empty(counts[1], dtype=np.int64)
    groups = 0
    for s in range(counts[1]):
        if done[s]:
            continue
        split = split_edge[s]
        a, b = e_a[split], e_b[split]
        ax, ay = xy[a, 0], xy[a, 1]
        points = np.empty(counts[1], dtype=np.int64)
        along = np.empty(counts[1], dtype=np.int64)
        m = 0
        for t in range(s, counts[1]):
            if split_edge[t] == split:
                done[t] = True
                points[m] = base + split_at[t]
                along[m] = max(abs(vx[split_at[t]] - ax), abs(vy[split_at[t]] - ay))
                m += 1
        # the points in order along the edge, sorted by insertion: an edge holds few
        for i in range(1, m):
            point, at = points[i], along[i]
            j = i - 1
            while j >= 0 and along[j] > at:
                points[j + 1], along[j + 1] = points[j], along[j]
                j -= 1
            points[j + 1], along[j + 1] = point, at
        group_part[groups] = temporary
        group_edge[groups] = split
        for j in range(m):
            group_points[temporary - first_part - groups + j] = points[j]
        groups += 1
        previous = a
        for j in range(m + 1):
            following = b if j == m else points[j]
            eu[temporary], ev[temporary] = previous, following
            kind[temporary], link_of[temporary] = split, -1
            p = temporary - first_part
            part_from[p, 0], part_from[p, 1] = _cell(xy, vx, vy, base, previous)
            part_to[p, 0], part_to[p, 1] = _cell(xy, vx, vy, base, following)
            temporary += 1
            previous = following
    parts = temporary - first_part
    if parts > 0:
        priced = run_costs(factor, passable, corner_cutting, part_from[:parts], part_to[:parts])
        # element by element: an array assigned to a slice compiles numba's formatted shape
        # error, seconds of a first run's compile
        for p in range(parts):
            ew[first_part + p] = priced[p]
    group_part[groups] = temporary
    landmarks = potential.shape[1] if informed and potential.shape[0] > 0 else 0
    virtual = np.full((counts[0], landmarks), np.inf)
    for i in range(groups):
        first, m = group_part[i], group_part[i + 1] - group_part[i] - 1
        inside = group_points[first - first_part - i:first - first_part - i + m]
        a, b = e_a[group_edge[i]], e_b[group_edge[i]]
        for k in range(landmarks):
            forward = potential[a, k]
            for j in range(m):
                forward += ew[first + j]
                virtual[inside[j] - base, k] = forward
            backward = potential[b, k]
            for j in range(m, 0, -1):
                backward += ew[first + j]
                virtual[inside[j - 1] - base, k] = min(virtual[inside[j - 1] - base, k],
                                                       backward)
    low = np.full(landmarks, np.inf)
    high = np.full(landmarks, -np.inf)
    for k in range(landmarks):
        goal = ends[1]
        if goal < base or goal_on_graph:
            at_goal = potential[goal, k] if goal < base else virtual[goal - base, k]
            if at_goal < np.inf:
                low[k], high[k] = at_goal, at_goal
        for t in range(temporary):
            if kind[t] != GOAL_LINK:
                continue
            there = ev[t]
            d = potential[there, k] if there < base else virtual[there - base, k]
            if d < np.inf:
                low[k] = min(low[k], d + ew[t])
                high[k] = max(high[k], d - ew[t])
    n = base + counts[0]
    # the overlay in CSR form, each temporary edge in both directions, stably by tail vertex
    o_ptr = np.zeros(n + 1, dtype=np.int64)
    for k in range(temporary):
        o_ptr[eu[k] + 1] += 1
        o_ptr[ev[k] + 1] += 1
    for v in range(n):
        o_ptr[v + 1] += o_ptr[v]
    fill = o_ptr[:-1].copy()
    o_target = np.empty(2 * temporary, dtype=np.int64)
    o_weight = np.empty(2 * temporary)
    o_edge = np.empty(2 * temporary, dtype=np.int64)
    for half in range(2):
        for k in range(temporary):
            tail, head = (eu[k], ev[k]) if half == 0 else (ev[k], eu[k])
            slot = fill[tail]
            fill[tail] += 1
            o_target[slot], o_weight[slot], o_edge[slot] = head, ew[k], k
    all_xy = np.empty((n, 2), dtype=np.int64)
    for v in range(base):
        all_xy[v, 0], all_xy[v, 1] = xy[v, 0], xy[v, 1]
    for i in range(counts[0]):
        all_xy[base + i, 0], all_xy[base + i, 1] = vx[i], vy[i]
    found, _, vertices, codes, settled = graph_search(
        indptr, target, weight, edge, o_ptr, o_target, o_weight, all_xy, ends[0], ends[1],
        informed, scale, potential, virtual, low, high)
    if not found:
        return (NOT_CONNECTED, np.zeros((0, 2), dtype=np.int64), np.inf, none, temporary,
                settled)
    path, hops = _expand(factor, passable, corner_cutting, all_xy, vertices, codes, o_edge, eu,
                         kind, link_of, s_box, s_dist, s_offsets, s_paths, s_cells,
                         g_box, g_dist, g_offsets, g_paths, g_cells)
    path = cut_loops(path)
    return OK, path, path_cost(factor, path), hops, temporary, settled


@njit(inline="always")
def _cell(xy: np.ndarray, vx: np.ndarray, vy: np.ndarray, base: int, v: int
          ) -> tuple[int, int]:
    if v < base:
        return xy[v, 0], xy[v, 1]
    return vx[v - base], vy[v - base]


@njit
def _link_cells(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
                box: np.ndarray, dist: np.ndarray, offsets: np.ndarray, paths: np.ndarray,
                cells: np.ndarray, k: int) -> np.ndarray:
    """The cells of link k from its terminal: given, or traced back through the sweep."""
    if offsets.shape[0] > 1:
        return paths[offsets[k]:offsets[k + 1]].copy()
    return descend(dist, factor, passable, corner_cutting, box[0], box[1], box[2], box[3],
                   cells[k, 0], cells[k, 1])


@njit
def _expand(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, xy: np.ndarray,
            vertices: np.ndarray, codes: np.ndarray, o_edge: np.ndarray, eu: np.ndarray,
            kind: np.ndarray, link_of: np.ndarray,
            s_box: np.ndarray, s_dist: np.ndarray, s_offsets: np.ndarray, s_paths: np.ndarray,
            s_cells: np.ndarray, g_box: np.ndarray, g_dist: np.ndarray, g_offsets: np.ndarray,
            g_paths: np.ndarray, g_cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The cell path along the found vertices, and for each hop the stored edge it runs along
    or is a part of (-1 for a local path). Each hop's first cell is dropped but the first's."""
    hops = codes.shape[0]
    pieces = [np.empty((0, 2), dtype=np.int64) for _ in range(hops)]
    stored = np.empty(hops, dtype=np.int64)
    total = 1
    for i in range(hops):
        code = codes[i]
        stored[i] = code
        if code < 0:
            k = o_edge[-code - 1]
            stored[i] = kind[k] if kind[k] >= 0 else -1
            if kind[k] < 0:
                if kind[k] == START_LINK:
                    piece = _link_cells(factor, passable, corner_cutting, s_box, s_dist,
                                        s_offsets, s_paths, s_cells, link_of[k])
                else:
                    piece = _link_cells(factor, passable, corner_cutting, g_box, g_dist,
                                        g_offsets, g_paths, g_cells, link_of[k])
                # a link's cells run from its terminal; the goal's are driven towards it
                pieces[i] = piece if vertices[i] == eu[k] else piece[::-1].copy()
        if pieces[i].shape[0] > 0:
            total += pieces[i].shape[0] - 1
        else:
            total += max(abs(xy[vertices[i + 1], 0] - xy[vertices[i], 0]),
                         abs(xy[vertices[i + 1], 1] - xy[vertices[i], 1]))
    path = np.empty((total, 2), dtype=np.int64)
    path[0, 0], path[0, 1] = xy[vertices[0], 0], xy[vertices[0], 1]
    at = 1
    for i in range(hops):
        piece = pieces[i]
        if piece.shape[0] > 0:
            for j in range(1, piece.shape[0]):
                path[at, 0], path[at, 1] = piece[j, 0], piece[j, 1]
                at += 1
            continue
        # a stored edge or a part of one: a straight run between its two vertices
        ux, uy = xy[vertices[i], 0], xy[vertices[i], 1]
        wx, wy = xy[vertices[i + 1], 0], xy[vertices[i + 1], 1]
        dx, dy = np.sign(wx - ux), np.sign(wy - uy)
        for j in range(1, max(abs(wx - ux), abs(wy - uy)) + 1):
            path[at, 0], path[at, 1] = ux + j * dx, uy + j * dy
            at += 1
    return path, stored


@njit
def cut_loops(path: np.ndarray) -> np.ndarray:
    """The path with every loop cut out, as :func:`cbr_grid.query.without_loops` cuts them:
    from each kept cell the path goes on from the last visit of that cell."""
    n = path.shape[0]
    width = 0
    for i in range(n):
        width = max(width, path[i, 0] + 1)
    # the last visit of each cell, from a hash table of the cells with linear probing, at most
    # half full (linear time; a sort would compile numba's, seconds of a first run)
    bits = 1
    while (1 << bits) < 2 * n:
        bits += 1
    mask = (1 << bits) - 1
    table_cell = np.full(mask + 1, -1, dtype=np.int64)
    table_last = np.empty(mask + 1, dtype=np.int64)
    slot_of = np.empty(n, dtype=np.int64)
    for i in range(n):
        cell = path[i, 1] * width + path[i, 0]
        # Fibonacci hashing of the cell's low 31 bits: rows of a map whose width is a power of
        # two would otherwise fall on one slot
        slot = (((cell & 0x7FFFFFFF) * 2654435769) & 0xFFFFFFFF) >> (32 - min(bits, 32))
        slot &= mask
        while table_cell[slot] != -1 and table_cell[slot] != cell:
            slot = (slot + 1) & mask
        table_cell[slot] = cell
        table_last[slot] = i
        slot_of[i] = slot
    count = 0
    i = 0
    while i < n:
        count += 1
        i = table_last[slot_of[i]] + 1
    if count == n:
        return path
    out = np.empty((count, 2), dtype=np.int64)
    count = 0
    i = 0
    while i < n:
        out[count, 0], out[count, 1] = path[i, 0], path[i, 1]
        count += 1
        i = table_last[slot_of[i]] + 1
    return out
