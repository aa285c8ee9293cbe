"""What the case graph's learn steps keep true of its segment cases, checked on a case base.

Every segment is a straight run of cells in one of the 8 grid directions between two distinct
cells on the map; two segments share a cell only where both end (a vertex), and no two join the
same pair of vertices. The graph the family loads from the store then has exactly the segments'
ends as vertices and the segments as edges. The check needs no world: it reads the cases and the
map size the case base records (:func:`cbr_grid.risk.recorded_map`), and builds the graph's
structure without the compiled cost code.
"""

from __future__ import annotations

import numpy as np

from cbr_casegraph.cases import SEGMENT
from cbr_casegraph.geometry import is_straight, segment_cells
from cbr_casegraph.graph import CaseGraph
from cbr_grid.grid import Grid
from cbr_grid.risk import recorded_map
from cbrcore.casebase.store import CaseStore
from cbrcore.errors import CbrError
from cbrcore.model import Case

Cell = tuple[int, int]


def _ends(case: Case, size: tuple[int, int] | None) -> tuple[tuple[Cell, Cell] | None, str]:
    """The end cells of a segment case, or None and what is wrong with it."""
    where = f"segment case {case.id}"
    problem = case.problem
    try:
        raw = [problem["a"], problem["b"]]
        if not all(len(cell) == 2 and all(isinstance(v, int) and not isinstance(v, bool)
                                          for v in cell) for cell in raw):
            raise TypeError
    except (KeyError, TypeError):
        return None, (f"{where}: problem {problem!r}; expected {{'a': [x, y], 'b': [x, y]}} "
                      "of integer cells")
    a, b = (int(raw[0][0]), int(raw[0][1])), (int(raw[1][0]), int(raw[1][1]))
    for cell in (a, b):
        if min(cell) < 0 or (size is not None and not (cell[0] < size[0] and cell[1] < size[1])):
            shape = f"the recorded {size[0]}x{size[1]} map" if size else "the map"
            return None, f"{where}: end {cell} is outside {shape}"
    if not is_straight(a, b):
        return None, (f"{where}: from {a} to {b} is not a straight run of cells in one of the 8 "
                      "grid directions")
    return (a, b), ""


def graph_problems(casebase: CaseStore) -> list[str]:
    """The broken invariants of the case graph stored in ``casebase``; empty when it is sound."""
    size, problems = recorded_map(casebase)
    segments: dict[int, tuple[Cell, Cell]] = {}
    for case in casebase.cases(SEGMENT):
        ends, problem = _ends(case, size)
        if ends is None:
            problems.append(problem)
        else:
            segments[int(case.id or 0)] = ends
    problems += _overlaps(segments)
    if problems:
        return problems
    return _index_problems(casebase, segments, size)


def _overlaps(segments: dict[int, tuple[Cell, Cell]]) -> list[str]:
    """Segments sharing a cell that is not an end of both, and segments joining the same ends."""
    problems = []
    # each cell: the segments through it, and whether it is an end of each
    on: dict[Cell, list[tuple[int, bool]]] = {}
    joined: dict[frozenset[Cell], int] = {}
    reported: set[tuple[int, int]] = set()
    for case_id, (a, b) in segments.items():
        pair = frozenset((a, b))
        if pair in joined:
            problems.append(f"segment cases {joined[pair]} and {case_id} both join {a} and {b}")
        joined.setdefault(pair, case_id)
        cells = segment_cells(a, b).tolist()
        for i, (x, y) in enumerate(cells):
            end = i in (0, len(cells) - 1)
            for other, other_end in on.get((x, y), ()):
                if not (end and other_end) and (other, case_id) not in reported:
                    reported.add((other, case_id))
                    problems.append(f"segment cases {other} and {case_id} overlap at cell "
                                    f"({x}, {y}): segments may meet only at a vertex, where "
                                    "both end")
            on.setdefault((x, y), []).append((case_id, end))
    return problems


def _index_problems(casebase: CaseStore, segments: dict[int, tuple[Cell, Cell]],
                    size: tuple[int, int] | None) -> list[str]:
    """Whether the graph the family loads from the store has the segments' ends as vertices and
    the segments as edges."""
    if not segments:
        return []
    if size is None:  # a map just large enough for every segment
        ends = np.array([cell for pair in segments.values() for cell in pair])
        size = (int(ends[:, 0].max()) + 1, int(ends[:, 1].max()) + 1)
    try:
        graph = CaseGraph.load(Grid(np.zeros((size[1], size[0]))), casebase, priced=False)
    except CbrError as exc:
        return [f"the case graph cannot be loaded from the case base: {exc}"]
    problems = []
    vertices = {(int(x), int(y)) for x, y in graph.vertices().tolist()}
    expected = {cell for pair in segments.values() for cell in pair}
    if vertices != expected:
        problems.append(f"the loaded graph's vertices differ from the segments' ends: "
                        f"{len(vertices - expected)} extra, {len(expected - vertices)} missing")
    ids = graph.edge_ids()
    a, b = graph.ends(ids)
    edges = {int(i): frozenset({(int(p[0]), int(p[1])), (int(q[0]), int(q[1]))})
             for i, p, q in zip(ids.tolist(), a.tolist(), b.tolist(), strict=True)}
    stored = {case_id: frozenset(pair) for case_id, pair in segments.items()}
    if edges != stored:
        differ = sorted(set(edges).symmetric_difference(stored)
                        | {i for i in set(edges) & set(stored) if edges[i] != stored[i]})
        problems.append(f"the loaded graph's edges differ from the segment cases "
                        f"{', '.join(map(str, differ[:10]))}")
    return problems
