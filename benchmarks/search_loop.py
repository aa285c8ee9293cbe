"""One heap-search loop for every graph, specialised by numba, against the project's own kernels.

The project writes its best-first searches one per graph (:mod:`cbr_solvers.search` on grids,
:mod:`cbr_solvers.graph_search` on a robot's directed edges, :mod:`cbr_casegraph.search` on the
case graph plus its overlay, the experience reuser's two searches, the kinematic lattice). They
share the heap (:mod:`cbr_grid.search_base`) but not the loop. This benchmark writes the loop
once, ``one_loop``, taking the edge relaxation as a numba function argument: numba compiles a
copy of the loop for each function passed, with the relaxation inlined, so this is the cheapest
way to write the loop once. It runs on the same queries as

- the case graph's kernel (:func:`cbr_casegraph.search.graph_search`), on the CSR graph of a
  random map's legal steps, with the same relaxation (base edges, then overlay edges);
- the grid A* and Dijkstra (:func:`cbr_solvers.search.astar`, ``dijkstra``), on the same map.

    python benchmarks/search_loop.py [--side 300] [--queries 40] [--repeats 3] [--seed 0]
                                     [--out benchmarks/results]

Every cost is checked against the kernel it is compared with. Writes ``search_loop.json`` and
``.md``: per comparison the median over the queries of the one loop's time over the kernel's.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from docfigures.provenance import script_command, write_results

from cbr_casegraph.search import graph_search
from cbr_grid.costs import SQRT2
from cbr_grid.search_base import DX, DY, move_masks, pop, push_grown
from cbr_kernels import njit
from cbr_solvers.search import astar, dijkstra

RESULTS = Path(__file__).resolve().parent / "results"


@njit
def one_loop(relax, graph, n: int, source: int, goal: int
             ) -> tuple[bool, float, int]:
    """Best-first search from ``source`` to ``goal`` over ``n`` vertices; ``relax(graph, v,
    goal, dist, came, code, closed, keys, items, size)`` pushes v's improved neighbours and
    returns the heap. Returns (found, cost, settled)."""
    dist = np.full(n, np.inf)
    came = np.full(n, -1, dtype=np.int64)
    code = np.zeros(n, dtype=np.int64)
    closed = np.zeros(n, dtype=np.bool_)
    keys = np.empty(64, dtype=np.float64)
    items = np.empty(64, dtype=np.int64)
    dist[source] = 0.0
    size = np.int64(0)
    keys, items = push_grown(keys, items, size, 0.0, source)
    size += 1
    settled = 0
    while size > 0:
        v = pop(keys, items, size)
        size -= 1
        if closed[v]:
            continue
        closed[v] = True
        settled += 1
        if v == goal:
            break
        keys, items, size = relax(graph, v, goal, dist, came, code, closed, keys, items, size)
    return closed[goal], dist[goal], settled


@njit(inline="always")
def relax_overlaid(graph, v, goal, dist, came, code, closed, keys, items, size):
    """The case graph kernel's relaxation: base CSR edges, then overlay edges."""
    indptr, target, weight, edge, o_ptr, o_target, o_weight, xy, informed, scale = graph
    gx, gy = xy[goal, 0], xy[goal, 1]
    here = dist[v]
    for part in range(2):
        if part == 0:
            if v >= indptr.shape[0] - 1:
                continue
            lo, hi = indptr[v], indptr[v + 1]
        else:
            lo, hi = o_ptr[v], o_ptr[v + 1]
        for k in range(lo, hi):
            if part == 0:
                u, w, c = target[k], weight[k], edge[k]
            else:
                u, w, c = o_target[k], o_weight[k], -(k + 1)
            if closed[u] or not w < np.inf:
                continue
            g = here + w
            if g >= dist[u]:
                continue
            dist[u] = g
            came[u] = v
            code[u] = c
            key = g
            if informed:
                dx, dy = abs(xy[u, 0] - gx), abs(xy[u, 1] - gy)
                key = g + (max(dx, dy) + (SQRT2 - 1.0) * min(dx, dy)) * scale
            keys, items = push_grown(keys, items, size, key, u)
            size += 1
    return keys, items, size


def csr(passable: np.ndarray) -> tuple[np.ndarray, ...]:
    """The map's legal moves, as the grid kernels' move masks give them, in the case graph
    kernel's arrays (no overlay edges)."""
    h, w = passable.shape
    masks = move_masks(passable, False).reshape(-1)
    tails, heads, lengths = [], [], []
    for d in range(8):
        cells = np.flatnonzero(masks & (1 << d))
        tails.append(cells)
        heads.append(cells + DY[d] * w + DX[d])
        lengths.append(np.full(len(cells), SQRT2 if d >= 4 else 1.0))
    tails, heads = np.concatenate(tails), np.concatenate(heads)
    order = np.argsort(tails, kind="stable")
    indptr = np.zeros(h * w + 1, dtype=np.int64)
    np.add.at(indptr, tails + 1, 1)
    xs, ys = np.meshgrid(np.arange(w), np.arange(h))
    xy = np.stack((xs.ravel(), ys.ravel()), axis=1).astype(np.int64)
    return (np.cumsum(indptr), heads[order].astype(np.int64), np.concatenate(lengths)[order],
            np.arange(len(order), dtype=np.int64), np.zeros(h * w + 1, dtype=np.int64),
            np.zeros(0, dtype=np.int64), np.zeros(0), xy)


def queries_on(passable: np.ndarray, count: int, seed: int) -> list[tuple[int, int]]:
    """``count`` pairs of distinct free cells (as flat indices) that a path joins."""
    rng = np.random.default_rng(seed)
    free = np.flatnonzero(passable)
    factor = np.ones(passable.shape)
    w = passable.shape[1]
    found: list[tuple[int, int]] = []
    while len(found) < count:
        s, g = (int(cell) for cell in rng.choice(free, size=2, replace=False))
        if astar(factor, passable, False, (s % w, s // w), [(g % w, g // w)]) is not None:
            found.append((s, g))
    return found


def timed(call: Callable[[], Any], repeats: int) -> tuple[float, Any]:
    """The median time of ``repeats`` calls in milliseconds, and the last result."""
    runs = []
    for _ in range(repeats):
        started = time.perf_counter()
        found = call()
        runs.append(time.perf_counter() - started)
    return statistics.median(runs) * 1e3, found


def case_graph_cost(arrays: tuple[np.ndarray, ...], informed: bool, s: int, g: int) -> float:
    # no landmark table: the octile bound alone, as the generic loop has it
    return graph_search(*arrays, s, g, informed, 1.0, np.zeros((0, 0)), np.zeros((0, 0)),
                        np.zeros(0), np.zeros(0))[1]


def grid_cost(solver: Callable[..., Any], passable: np.ndarray, s: int, g: int) -> float:
    side = passable.shape[1]
    return solver(np.ones(passable.shape), passable, False, divmod(s, side)[::-1],
                  [divmod(g, side)[::-1]]).cost


def run(side: int, count: int, repeats: int, seed: int) -> dict[str, Any]:
    passable = np.random.default_rng(seed).random((side, side)) >= 0.2
    arrays = csr(passable)
    n = side * side
    queries = queries_on(passable, count, seed + 1)
    rows = []
    for informed, solver in ((False, dijkstra), (True, astar)):
        graph = (*arrays, informed, 1.0)
        anchors = {"case graph kernel": partial(case_graph_cost, arrays, informed),
                   "grid kernel": partial(grid_cost, solver, passable)}
        one_loop(relax_overlaid, graph, n, 0, 1)
        for name, anchor in anchors.items():
            ratios, ours, theirs = [], [], []
            for number, (s, g) in enumerate(queries):
                anchor(s, g)
                pair = [partial(anchor, s, g), partial(one_loop, relax_overlaid, graph, n, s, g)]
                # alternate which runs first so drift on a noisy machine hits both alike
                if number % 2:
                    (loop_ms, (_, found, _)), (kernel_ms, cost) = (
                        timed(pair[1], repeats), timed(pair[0], repeats))
                else:
                    (kernel_ms, cost), (loop_ms, (_, found, _)) = (
                        timed(pair[0], repeats), timed(pair[1], repeats))
                if not abs(found - cost) <= 1e-9 * max(1.0, cost):
                    raise AssertionError(f"costs differ from {s} to {g}: {found} against {cost}")
                ratios.append(loop_ms / kernel_ms)
                ours.append(loop_ms)
                theirs.append(kernel_ms)
            rows.append({"search": "A*" if informed else "Dijkstra", "against": name,
                         "queries": len(queries), "kernel_ms": statistics.median(theirs),
                         "one_loop_ms": statistics.median(ours),
                         "one_loop_over_kernel": statistics.median(ratios)})
    return {"side": side, "obstacles": 0.2, "seed": seed, "repeats": repeats, "rows": rows}


def markdown(result: dict[str, Any]) -> str:
    lines = [f"Random {result['side']}x{result['side']} map, 20% obstacles, seed "
             f"{result['seed']}; medians over the queries.", "",
             "| search | against | queries | kernel ms | one loop ms | one loop / kernel |",
             "| --- | --- | --- | --- | --- | --- |"]
    for row in result["rows"]:
        lines.append(f"| {row['search']} | {row['against']} | {row['queries']} "
                     f"| {row['kernel_ms']:.2f} | {row['one_loop_ms']:.2f} "
                     f"| {row['one_loop_over_kernel']:.2f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--side", type=int, default=300)
    parser.add_argument("--queries", type=int, default=40)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    if args.side < 2 or args.queries < 1 or args.repeats < 1:
        parser.error("--side must be 2 or more, --queries and --repeats 1 or more")
    result = run(args.side, args.queries, args.repeats, args.seed)
    write_results(args.out / "search_loop.json", result, command=script_command(__file__, argv))
    (args.out / "search_loop.md").write_text(markdown(result) + "\n", encoding="utf-8")
    print(markdown(result))
    return result


if __name__ == "__main__":
    main()
