"""Peak memory of planning on a large grid: bytes per cell of a Grid, of a search, of the engine.

Each measurement runs in a fresh Python process, so that its peak resident set size
(``ru_maxrss``) is its own. A process builds an N x N map of random obstacles (15% of the
cells, made a band of rows at a time so that no N x N float temporary is needed) as a
:class:`cbr_grid.grid.Grid`, then:

- ``grid``: nothing more, the map alone;
- ``astar`` / ``dijkstra``: one long query, from the free cell nearest one corner to the free
  cell nearest the opposite one, through ``cbr_solvers.search``;
- ``engine``: the hybrid planner of ``configs/hybrid_grid.yaml`` (case graph retrieval, reuse
  and retention, path quality revision against the landmark bound, A* as the solver) on an
  in-memory case base, built with ``Engine.from_dict`` on the map, a few long trips each solved
  and learned;
- ``engine_octile``: the same with the reviser's default octile bound, which keeps no
  per-cell landmark tables.

Each reports its peak RSS, its RSS at the end, the RSS after the imports (the interpreter,
numpy, numba and the kernels loaded), the bytes the Grid's arrays, the search's working arrays
and move masks, and the case graph's per-cell and per-vertex arrays hold, and its time; the
engine also its peak and present RSS once built (warm: the landmark tables built), before its
first trip. Bytes per cell divide by N². The target: an 8000 x 8000 map plans (A* and the
engine) within 2 GB of peak RSS.

    python benchmarks/memory.py [--side 8000] [--trips 3] [--out benchmarks/results]
                                [--kinds grid astar dijkstra engine engine_octile]

Writes ``memory.json`` and ``memory.md``.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import json
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from docfigures.provenance import units, write_results

KINDS = ("grid", "astar", "dijkstra", "engine", "engine_octile")
DENSITY = 0.15
SEED = 0
LIMIT = 2 * 10**9
"""The target's peak RSS in bytes: 2 GB."""
BAND = 256
"""Rows of random numbers drawn at a time while building the map."""
ENGINE = {
    "seed": SEED,
    "casebase": "memory",
    "retrieve": {"use": "casegraph", "delta": 8},
    "reuse": {"use": "casegraph", "connector": "dijkstra"},
    "revise": {"use": "path_quality", "ideal": "landmarks", "max_ratio": 1.5},
    "solver": "astar",
    "retain": ["casegraph"],
}
"""The hybrid configuration's planning and learning components (configs/hybrid_grid.yaml)."""
OCTILE = {**ENGINE, "revise": {"use": "path_quality", "max_ratio": 1.5}}
"""The same with the reviser's default ideal length, the octile distance (no landmark tables)."""


def _peak_rss() -> int:
    """This process's peak resident set size in bytes (Linux reports kilobytes)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def _rss() -> int:
    """This process's resident set size now, in bytes (Linux's /proc/self/statm, in pages)."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * resource.getpagesize()


def obstacles(side: int, seed: int) -> np.ndarray:
    """A side x side boolean map, True on an obstacle, drawn a band of rows at a time."""
    rng = np.random.default_rng(seed)
    blocked = np.empty((side, side), dtype=bool)
    for top in range(0, side, BAND):
        rows = min(BAND, side - top)
        blocked[top:top + rows] = rng.random((rows, side), dtype=np.float32) < DENSITY
    return blocked


def _nearest_free(passable: np.ndarray, x: int, y: int) -> tuple[int, int]:
    """The free cell nearest (x, y) along the diagonal through it, searched outward."""
    h, w = passable.shape
    for r in range(max(h, w)):
        ys, xs = np.nonzero(passable[max(y - r, 0):y + r + 1, max(x - r, 0):x + r + 1])
        if len(xs):
            return int(xs[0] + max(x - r, 0)), int(ys[0] + max(y - r, 0))
    raise SystemExit("the map has no free cell")


def _trip(passable: np.ndarray, number: int) -> tuple[tuple[int, int], tuple[int, int]]:
    """The ``number``-th long trip: between cells near opposite corners, turning each time."""
    h, w = passable.shape
    corners = [(1, 1), (w - 2, h - 2), (w - 2, 1), (1, h - 2)]
    a, b = corners[number % 4], corners[(number % 4) ^ 1]
    return _nearest_free(passable, *a), _nearest_free(passable, *b)


def _graph_bytes() -> dict[str, Any]:
    """The case graphs alive in this process: their per-cell and per-vertex arrays."""
    from cbr_casegraph.graph import CaseGraph

    graphs = [o for o in gc.get_objects() if isinstance(o, CaseGraph)]
    if not graphs:
        return {}
    graph = graphs[0]
    per_cell = {"cell_tiles": graph.index.cells.nbytes}
    arrays = {name: value for name, value in vars(graph.index).items()
              if isinstance(value, np.ndarray)}
    return {"graphs": len(graphs), "vertices": int(graph.vertex_count),
            "per_cell_bytes": per_cell,
            "vertex_and_edge_arrays_bytes": {k: int(v.nbytes) for k, v in arrays.items()},
            "vertex_and_edge_item_bytes": {k: int(v.itemsize) for k, v in arrays.items()}}


def _landmarks() -> dict[str, int]:
    """The bytes and the count of the landmark distance tables alive in this process (the
    reviser's bound)."""
    from cbr_pathquality.ideal import Landmarks

    found = [o for o in gc.get_objects() if isinstance(o, Landmarks)]
    return {"landmark_bytes": sum(int(o.tables.nbytes) for o in found),
            "landmarks": sum(len(o.tables) for o in found)}


def held_bytes(array: np.ndarray) -> int:
    """The bytes ``array``'s elements take: a value broadcast along an axis (stride 0) is held
    once along it, as a Grid's factor shared by every passable cell is."""
    return array.itemsize * int(np.prod([n for n, step in zip(array.shape, array.strides,
                                                                 strict=True) if step]))


def child(kind: str, side: int, trips: int) -> dict[str, Any]:
    """One measurement in this process: what it holds and its peak RSS."""
    from cbr_grid.grid import Grid
    from cbr_solvers import search

    # Load the kernels on a tiny grid first, so the baseline includes them.
    tiny = Grid(np.zeros((4, 4)))
    search.astar(tiny.factor, tiny.passable, False, (0, 0), [(3, 3)])
    if kind.startswith("engine"):
        importlib.import_module("cbrcore.engine")  # imported before the baseline
    baseline = _peak_rss()
    began = time.perf_counter()
    grid = Grid.from_array(obstacles(side, SEED))
    built = time.perf_counter() - began
    result: dict[str, Any] = {
        "kind": kind, "side": side, "cells": side * side, "baseline_rss": baseline,
        "build_s": built,
        "grid_bytes": {name: held_bytes(getattr(grid, name))
                       for name in ("risk", "passable", "factor")},
    }
    began = time.perf_counter()
    if kind in ("astar", "dijkstra"):
        start, goal = _trip(grid.passable, 0)
        found = getattr(search, kind)(grid.factor, grid.passable, grid.corner_cutting, start,
                                      [goal])
        result.update(start=start, goal=goal, cost=None if found is None else found.cost,
                      expanded=None if found is None else found.expanded)
    elif kind.startswith("engine"):
        from cbr_grid.query import GridQuery
        from cbrcore.engine import Engine
        from cbrcore.model import Outcome

        sources = []
        with Engine.from_dict(ENGINE if kind == "engine" else OCTILE, world=grid) as engine:
            # the engine is warm: the landmark tables, if any, are built
            result["built_peak_rss"], result["built_rss"] = _peak_rss(), _rss()
            for number in range(trips):
                problem = GridQuery(*_trip(grid.passable, number))
                proposal = engine.solve(problem)
                sources.append(proposal.source)
                engine.learn(problem, proposal, Outcome(success=True))
            result["sources"] = sources
            result["case_graph"] = _graph_bytes()
            result.update(_landmarks())
    result["run_s"] = time.perf_counter() - began
    workspace = search._WORKSPACE
    result["search_bytes"] = {
        "stamp": int(workspace.stamp.nbytes), "dist": int(workspace.dist.nbytes),
        "parent": int(workspace.parent.nbytes),
        "move_masks": sum(int(entry[1].nbytes) for entry in search._MASKS.values())}
    result["peak_rss"], result["final_rss"] = _peak_rss(), _rss()
    result["units"] = units()  # the source this measurement ran, for the results' provenance
    return result


def measure(kind: str, side: int, trips: int) -> dict[str, Any]:
    """``child`` in a fresh interpreter."""
    done = subprocess.run([sys.executable, __file__, "--child", kind, "--side", str(side),
                           "--trips", str(trips)], capture_output=True, text=True, check=False)
    if done.returncode != 0:
        return {"kind": kind, "side": side, "error": done.stderr.strip().splitlines()[-1:]}
    return json.loads(done.stdout.strip().splitlines()[-1])


def _mb(value: float | None) -> str:
    return "-" if value is None else f"{value / 1e6:.0f}"


def table(rows: list[dict[str, Any]]) -> str:
    lines = ["| measurement | map | peak RSS MB | peak once built MB | after imports MB | "
             "peak - imports, B/cell | "
             "grid B/cell | search B/cell | case graph B/cell | landmarks B/cell | "
             "case graph vertices | B/vertex | time s | within 2 GB |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        if "error" in row:
            lines.append(f"| {row['kind']} | {row['side']}² | failed: {' '.join(row['error'])} "
                         "| | | | | | | | | | | |")
            continue
        cells = row["cells"]
        search = sum(row.get("search_bytes", {}).values())
        case_graph = row.get("case_graph", {})
        graph = sum(case_graph.get("per_cell_bytes", {}).values())
        vertices = case_graph.get("vertices")
        per_vertex = (sum(case_graph["vertex_and_edge_arrays_bytes"].values()) / vertices
                      if vertices else None)
        count = f" ({row['landmarks']})" if row.get("landmarks") else ""
        lines.append(
            f"| {row['kind']} | {row['side']}² | {_mb(row['peak_rss'])} | "
            f"{_mb(row.get('built_peak_rss'))} | {_mb(row['baseline_rss'])} | "
            f"{(row['peak_rss'] - row['baseline_rss']) / cells:.1f} | "
            f"{sum(row['grid_bytes'].values()) / cells:.1f} | "
            f"{search / cells:.1f} | {graph / cells:.1f} | "
            f"{row.get('landmark_bytes', 0) / cells:.1f}{count} | {vertices or '-'} | "
            f"{'-' if per_vertex is None else f'{per_vertex:.0f}'} | "
            f"{row['build_s'] + row['run_s']:.1f} | "
            f"{'yes' if row['peak_rss'] <= LIMIT else 'no'} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--side", type=int, default=8000, help="side of the square map")
    parser.add_argument("--trips", type=int, default=3, help="engine trips")
    parser.add_argument("--kinds", nargs="*", default=list(KINDS), choices=KINDS)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results"))
    parser.add_argument("--child", choices=KINDS, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(child(args.child, args.side, args.trips)))
        return
    rows = []
    ran: set[str] = set()
    for kind in args.kinds:
        rows.append(measure(kind, args.side, args.trips))
        ran.update(rows[-1].pop("units", ()))
        print(json.dumps({k: v for k, v in rows[-1].items() if k != "case_graph"}), flush=True)
    result = {"side": args.side, "trips": args.trips, "density": DENSITY, "seed": SEED,
              "limit_bytes": LIMIT, "measurements": rows}
    args.out.mkdir(parents=True, exist_ok=True)
    write_results(args.out / "memory.json", result, unit_names=ran)
    text = "\n\n".join([
        table(rows),
        f"A {args.side}x{args.side} map with {DENSITY:.0%} random obstacles, one fresh process "
        f"per row. Peak RSS is the process's `ru_maxrss`; once built is the same "
        "when the engine is built and warm (its landmark tables made), before its first trip; "
        "after imports is the same before the map is built (Python, numpy, numba and the loaded "
        "kernels). Grid, search and case graph bytes are those of their arrays: the Grid's "
        "risk, factor (held once when every passable cell shares it) and passable arrays; "
        "the search's working arrays (stamp, cost, parent move) and remembered move masks; "
        "the case graph's cell-indexed arrays; the path quality reviser's landmark distance "
        "tables (how many in brackets). B/vertex is the case graph's vertex and edge arrays "
        "(with their spare capacity) per vertex; the case base's records come on top."])
    (args.out / "memory.md").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
