"""The spatial index of whole-path cases against the brute-force Hausdorff kernel.

``PathBase.hausdorff`` compares a new path only with the stored paths its index of squares and
the kept bounding boxes find near it. The property: after any sequence of paths added,
forgotten, and added, replaced or forgotten by another writer and followed through the store,
it finds exactly the stored paths that the kernel run over every stored path finds within the
limit, by the directed and by the symmetric distance (also when only the symmetric one is asked
for), with the same distances, under each cell distance.
"""

from __future__ import annotations

import attrs
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cbr_pathcases.base import BUCKET, PATH, PathBase, base_of, path_case
from cbr_pathcases.hausdorff import hausdorff

from .test_pathcases import DISTANCES, Cell, assert_same_base, context, free, next_query, run

SIDE = 3 * BUCKET  # several squares of the index on each axis
META = {"cost": 1.0, "length": 1.0, "risk": 0.0, "ideal": 1.0, "traversals": 1}

corner = st.tuples(st.integers(0, SIDE - 1), st.integers(0, SIDE - 1))
corners = st.lists(corner, min_size=1, max_size=3)
step = st.tuples(st.sampled_from(["add", "add", "remove", "other add", "other remove",
                                  "other replace"]), corners, st.integers(0, 99))


def near_path(rng: np.random.Generator, base: PathBase) -> np.ndarray:
    """A new path: often a stored one with its corners moved by a few cells, else random."""
    if len(base) and rng.random() < 0.7:
        stored = base.paths[int(rng.integers(len(base)))]
        picks = stored[np.unique(rng.integers(0, len(stored), 3))]
        moved = np.clip(picks + rng.integers(-2, 3, picks.shape), 0, SIDE - 1)
        return run(*(tuple(c) for c in moved.tolist()))
    return run(*(tuple(c) for c in rng.integers(0, SIDE, (2, 2)).tolist()))


def brute(base: PathBase, path: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray]:
    """D(path, P) and D(P, path) for every stored path, exactly."""
    offsets = np.concatenate(([0], np.cumsum([len(p) for p in base.paths]))).astype(np.int64)
    cells = np.concatenate(base.paths) if base.paths else np.zeros((0, 2), dtype=np.int64)
    return hausdorff(path, cells, offsets, distance=name)


@given(st.lists(step, min_size=1, max_size=12), st.integers(0, 2**16))
@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_the_index_finds_what_the_kernel_over_every_stored_path_finds(
        steps: list[tuple[str, list[Cell], int]], seed: int) -> None:
    rng = np.random.default_rng(seed)
    ctx = context(free(SIDE, SIDE))
    store = ctx.casebase
    for op, cells, k in steps:
        path = run(*cells) if len(cells) > 1 else run(cells[0], (0, 0))
        ids = base_of(ctx).ids.tolist()
        with ctx.mirror.transaction():
            if op == "add" or (not ids and op in ("remove", "other remove", "other replace")):
                base_of(ctx).add(path, META)
            elif op == "remove":
                base_of(ctx).remove([ids[k % len(ids)]])
            elif op == "other add":
                store.add(path_case(path, META))
            elif op == "other remove":
                store.remove([ids[k % len(ids)]])
            else:
                case = store.get(ids[k % len(ids)])
                store.replace(attrs.evolve(case, problem=path_case(path, META).problem,
                                           solution=path.tolist()))
        next_query(ctx)
    base = base_of(ctx)
    assert ctx.mirror.reloads == 0 and len(base) == len(store.cases(PATH))
    assert_same_base(base, PathBase.load(store))
    for _ in range(4):
        path = near_path(rng, base)
        for name in DISTANCES:
            forward, backward = brute(base, path, name)
            symmetric = np.maximum(forward, backward)
            for limit in (0.0, 1.0, 1.5, 2.0, 5.0):
                rows, ours, theirs = base.hausdorff(path, distance=name, limit=limit)
                within = forward <= limit
                assert set(rows[ours <= limit].tolist()) == set(np.flatnonzero(within).tolist())
                assert np.allclose(ours[ours <= limit], forward[rows[ours <= limit]])
                both = np.maximum(ours, theirs) <= limit
                assert set(rows[both].tolist()) == set(np.flatnonzero(symmetric <= limit)
                                                       .tolist())
                assert np.allclose(theirs[both], backward[rows[both]])
                # wanting only the symmetric distance changes nothing within the limit
                again, ours, theirs = base.hausdorff(path, distance=name, limit=limit,
                                                     symmetric=True)
                assert np.array_equal(again, rows)
                both = np.maximum(ours, theirs) <= limit
                assert set(rows[both].tolist()) == set(np.flatnonzero(symmetric <= limit)
                                                       .tolist())
                assert np.allclose(ours[both], forward[rows[both]])
                assert np.allclose(theirs[both], backward[rows[both]])


def test_a_path_along_another_is_found_across_the_squares_of_the_index() -> None:
    # a stored path along row 20 from x = 0 to 47 passes through three squares; a new path
    # one row below from x = 14 to 18 starts and ends in squares the stored one also crosses,
    # and a new path 3 rows away is beyond the limit 2 though in the same squares
    ctx = context(free(SIDE, SIDE))
    base = base_of(ctx)
    stored = base.add(run((0, 20), (SIDE - 1, 20)), META)
    rows, forward, _ = base.hausdorff(run((14, 21), (18, 21)), distance="euclidean", limit=2.0)
    assert base.ids[rows].tolist() == [stored] and forward.tolist() == [1.0]
    rows, forward, _ = base.hausdorff(run((14, 23), (18, 23)), distance="euclidean", limit=2.0)
    assert not (forward <= 2.0).any()


def test_the_store_of_cells_grows_and_compacts_keeping_every_path() -> None:
    # 300 paths of 48 cells outgrow the first buffer of cells; forgetting 250 of them leaves
    # most of it garbage, which is compacted away
    ctx = context(free(SIDE, SIDE))
    base = base_of(ctx)
    paths = [run((0, k % SIDE), (SIDE - 1, (k * 7) % SIDE)) for k in range(300)]
    ids = [base.add(path, META) for path in paths]
    base.remove(ids[::6] + ids[1::6] + ids[2::6] + ids[3::6] + ids[4::6])
    kept = ids[5::6]
    assert base.ids.tolist() == kept
    for row, case_id in enumerate(kept):
        assert np.array_equal(base.paths[row], paths[ids.index(case_id)])
    assert_same_base(base, PathBase.load(ctx.casebase))
    rows, forward, _ = base.hausdorff(paths[5], distance="chebyshev", limit=0.0)
    assert base.ids[rows[forward == 0]].tolist() == [
        case_id for case_id in kept if np.array_equal(paths[ids.index(case_id)], paths[5])]


@pytest.mark.parametrize("drops", [[0], [4], [11], [1, 2], [0, 5, 6, 11], list(range(0, 12, 2))])
def test_forgetting_a_few_rows_moves_the_others_up_as_loading_anew_orders_them(
        drops: list[int]) -> None:
    ctx = context(free(SIDE, SIDE))
    base = base_of(ctx)
    ids = [base.add(run((0, k), (SIDE - 1, SIDE - 1 - k)), {**META, "cost": 1.0 + k})
           for k in range(12)]
    base.touch(ids[3:5])
    base.remove([ids[k] for k in drops])
    assert base.ids.tolist() == [i for k, i in enumerate(ids) if k not in drops]
    assert_same_base(base, PathBase.load(ctx.casebase))


def euclidean_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.hypot(*(a[:, None, :] - b[None, :, :]).transpose(2, 0, 1))


def test_paths_driven_against_the_new_one_get_their_exact_distances() -> None:
    # stored paths between the new path's ends, most of them driven the other way: the
    # kernel's scans must find each cell's nearest cell whichever way the stored path runs
    ctx = context(free(SIDE, SIDE))
    base = base_of(ctx)
    new = run((1, 1), (12, 20), (22, 22))
    stored = [new[::-1], run((22, 21), (13, 20), (1, 2)), run((22, 22), (10, 20), (1, 1)),
              run((1, 1), (13, 19), (22, 22)), run((21, 22), (12, 21), (2, 1))]
    for path in stored:
        base.add(path, META)
    rows, forward, backward = base.hausdorff(new, distance="euclidean", limit=np.inf)
    assert rows.tolist() == list(range(len(stored)))
    for path, ours, theirs in zip(stored, forward, backward, strict=True):
        matrix = euclidean_matrix(new, path)
        assert ours == pytest.approx(matrix.min(axis=1).max())
        assert theirs == pytest.approx(matrix.min(axis=0).max())
    assert forward[0] == backward[0] == 0.0
