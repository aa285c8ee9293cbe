"""Eq. (12) of the case graph through its spatial index, against a brute-force scan.

``CaseGraph.similar`` and the comparison the compiled ``add_path`` makes at ``similarity_delta``
> 0 look only at the vertices in the square N(a, δr) around a new segment's first end and at
their edges. The properties here check that this decides exactly as a scan over every stored
segment's ends, under each distance, after any sequence of retained paths, forgotten segments,
merges and another writer's commits followed through the store: a candidate segment of a path
becomes an edge exactly when no segment stored before the path is similar to it.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from cbr_casegraph import retention
from cbr_casegraph.geometry import segment_cells
from cbr_casegraph.graph import CaseGraph
from cbr_casegraph.state import graph_of
from cbr_grid.distances import DISTANCES
from cbr_grid.grid import Grid
from cbr_grid.query import without_loops
from cbrcore.casebase.memory import MemoryStore
from cbrcore.context import Context
from cbrcore.registry import Registry

Cell = tuple[int, int]
SIDE = 12

cell = st.tuples(st.integers(0, SIDE - 1), st.integers(0, SIDE - 1))
step = st.one_of(
    st.tuples(st.just("path"), st.lists(cell, min_size=2, max_size=4), st.integers(0, 2),
              st.sampled_from(sorted(DISTANCES))),
    st.tuples(st.just("remove"), st.lists(cell, min_size=1, max_size=1), st.just(0),
              st.just("chebyshev")),
    st.tuples(st.just("merge"), st.lists(cell, min_size=1, max_size=1), st.just(0),
              st.just("chebyshev")))
Step = tuple[str, list[Cell], int, str]


def bent(corners: list[Cell]) -> np.ndarray:
    """An 8-connected path through the corners: each leg a diagonal, then a straight run."""
    cells = [np.asarray(corners[0])]
    for (x0, y0), (x1, y1) in itertools.pairwise(corners):
        d = min(abs(x1 - x0), abs(y1 - y0))
        mid = (x0 + d * int(np.sign(x1 - x0)), y0 + d * int(np.sign(y1 - y0)))
        for a, b in (((x0, y0), mid), (mid, (x1, y1))):
            if a != b:
                cells.extend(segment_cells(a, b)[1:])
    return np.array(cells, dtype=np.int64)


def stored_ends(graph: CaseGraph) -> tuple[np.ndarray, np.ndarray]:
    return graph.ends(graph.edge_ids())


def brute(ends: tuple[np.ndarray, np.ndarray], a: Cell, b: Cell, delta: int, name: str) -> bool:
    """Eq. (12) by a scan over all the given segments' ends."""
    ka, kb = ends
    d = DISTANCES[name]
    return bool((((d(ka, a) <= delta) & (d(kb, b) <= delta))
                 | ((d(kb, a) <= delta) & (d(ka, b) <= delta))).any())


@contextmanager
def compared_with_brute_force(graph: CaseGraph, path: np.ndarray, delta: int, name: str,
                              calls: list[bool]) -> Iterator[None]:
    """Within the block, ``path`` is retained: every candidate segment of it must end up an edge
    exactly when a scan of the segments ``graph`` held when the block began (the cases stored
    before the path) finds none similar to it by eq. (12). A segment that is also the one-step
    edge of a crossing is an edge either way. Each scan's answer is appended to ``calls``."""
    before = tuple(e.copy() for e in stored_ends(graph))
    segments, crossings = retention.candidates(graph.index, without_loops(path))
    joins = {frozenset({(px, py), (qx, qy)}) for px, py, qx, qy in crossings.tolist()}
    yield
    a, b = stored_ends(graph)
    edges = {frozenset({tuple(p), tuple(q)}) for p, q in zip(a.tolist(), b.tolist(), strict=True)}
    for ax, ay, bx, by in segments.tolist():
        found = delta > 0 and brute(before, (ax, ay), (bx, by), delta, name)
        pair = frozenset({(ax, ay), (bx, by)})
        if pair not in joins:
            assert (pair not in edges) == found, (ax, ay, bx, by)
        calls.append(found)


def apply(graph: CaseGraph, op: str, cells: list[Cell], delta: int, name: str,
          calls: list[bool]) -> None:
    ids = graph.edge_ids().tolist()
    if op == "path" or not ids:
        path = bent(cells if len(cells) > 1 else [*cells, (0, 0)])
        if len(path) > 1:
            with compared_with_brute_force(graph, path, delta, name, calls):
                graph.add_path(path, similarity_delta=delta, distance=name)
    elif op == "remove":
        graph.remove([ids[(cells[0][0] * SIDE + cells[0][1]) % len(ids)]])
    else:
        graph.merge_redundant()


def probes(rng: np.random.Generator, graph: CaseGraph, count: int) -> list[tuple[Cell, Cell]]:
    """Segment end pairs to ask about: random cells and cells next to stored ends."""
    found = []
    a, b = stored_ends(graph)
    for _ in range(count):
        if len(a) and rng.random() < 0.7:
            k = int(rng.integers(len(a)))
            p = np.clip(a[k] + rng.integers(-2, 3, 2), 0, SIDE - 1)
            q = np.clip(b[k] + rng.integers(-2, 3, 2), 0, SIDE - 1)
        else:
            p, q = rng.integers(0, SIDE, 2), rng.integers(0, SIDE, 2)
        found.append(((int(p[0]), int(p[1])), (int(q[0]), int(q[1]))))
    return found


@given(st.lists(step, min_size=1, max_size=10), st.integers(0, 2**16))
# the second path's segment (2,2)-(3,2) is similar to the stored (3,1)-(2,2), and its diagonal
# step (3,2)-(2,1) crosses that edge, which joins the same two cells by a one-step edge
@example([("path", [(3, 1), (0, 2)], 0, "chebyshev"),
          ("path", [(0, 0), (3, 2), (1, 0)], 1, "chebyshev")], 0)
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_the_indexed_eq_12_decides_as_a_scan_of_every_stored_segment(steps: list[Step],
                                                                       seed: int) -> None:
    rng = np.random.default_rng(seed)
    graph = CaseGraph(Grid(np.zeros((SIDE, SIDE))))
    calls: list[bool] = []
    for op, cells, delta, name in steps:
        apply(graph, op, cells, delta, name, calls)
        ends = stored_ends(graph)
        for a, b in probes(rng, graph, 12):
            for delta_ in (1, 2, 3):
                for name_ in DISTANCES:
                    assert graph.similar(a, b, delta_, name_) == brute(ends, a, b, delta_, name_)


@given(st.lists(step, min_size=1, max_size=8), st.integers(0, 2**16))
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_a_graph_following_another_writer_answers_eq_12_as_a_scan(steps: list[Step],
                                                                   seed: int) -> None:
    """The index is the graph's own vertex grid, which catching up with another writer's
    splits, merges and removals keeps in step."""
    rng = np.random.default_rng(seed)
    grid = Grid(np.zeros((SIDE, SIDE)))
    store = MemoryStore()
    ctx = Context(registry=Registry(), seed=0, world=grid, casebase=store)
    followed = graph_of(ctx)
    writer = CaseGraph(grid, store)
    calls: list[bool] = []
    for op, cells, delta, name in steps:
        with store.transaction():
            apply(writer, op, cells, delta, name, calls)
        ctx.mirror.sync()
        assert graph_of(ctx) is followed
        ends = stored_ends(followed)
        for a, b in probes(rng, followed, 8):
            for name_ in DISTANCES:
                assert followed.similar(a, b, 2, name_) == brute(ends, a, b, 2, name_)


def test_a_split_stored_segment_is_compared_as_it_was_before_the_path() -> None:
    # stored: a-b, (0, 1)-(8, 1). The new path starts inside it at s = (4, 1), which splits it
    # at s, goes down and round, and comes back along row 0 from c = (9, 0) to d = (0, 0): within
    # one cell of a and b, so similar at δr 1 to the segment stored before the path, though to
    # neither of its parts (c is 5 cells from s, d 4).
    #   d - - - - - - - - c
    #   a - - - s - - - b |
    #   . . . . | . . . . |
    #   . . . . + - - - - +
    graph = CaseGraph(Grid(np.zeros((4, 10))))
    graph.add_path(np.array([[x, 1] for x in range(9)]))
    path = bent([(4, 1), (4, 3), (9, 3), (9, 0), (0, 0)])
    calls: list[bool] = []
    with compared_with_brute_force(graph, path, 1, "chebyshev", calls):
        graph.add_path(path, similarity_delta=1)
    assert calls.count(True) == 1
    a, b = stored_ends(graph)
    ends = {frozenset({tuple(p), tuple(q)}) for p, q in zip(a.tolist(), b.tolist(), strict=True)}
    assert frozenset({(9, 0), (0, 0)}) not in ends
    assert {frozenset({(0, 1), (4, 1)}), frozenset({(4, 1), (8, 1)})} <= ends
