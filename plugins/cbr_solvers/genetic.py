"""A genetic algorithm path planner on an 8-connected grid (Šeda & Dvořák, section 3).

**Coding.** A chromosome is a string of L directions, one of the 8 moves to a neighbour cell per
gene, with L = 2·max(m, n) for an m x n search area (eq. (4); the window's size when a window is
given). It is decoded by walking from the start one gene at a time. Walking stops at the first
goal reached: the remaining genes are not taken into consideration.

**Infeasible moves.** The paper counts as infeasible the moves off the grid, the moves into an
obstacle and a move that reverses the one before it (3-7, 4-8, 5-1, ...). It says that *when
generating* the directions such moves must be avoided, and does not say what crossover and
mutation do about them. Our reading: the random initial chromosomes are generated as random
walks that draw each gene among the feasible directions at the cell reached (a gene where none is
feasible, or after the goal, is any direction), and in decoding any infeasible gene is skipped:
the robot stays where it is and the next gene moves from there. Our movement rules add to the
paper's infeasible moves those leaving the window and the diagonal steps that cut a blocked
corner (the rule of :func:`cbr_grid.search_base.move`); "the move before" is the last move
executed, not a skipped gene.

**Fitness** is lexicographic: first the distance from the last cell reached to the nearest goal,
then the cost of the path up to there under the grid's step cost contract (see
:mod:`cbr_solvers.search`). The paper's implementation used the Euclidean distance, our default;
``distance="octile"`` uses the length of the shortest free 8-connected path instead.

**Evolution**, with the paper's settings: a population of 50, binary tournament selection of each
parent, uniform crossover, mutation of one gene selected at random (with probability
``mutation`` per child, to a different random direction) and incremental replacement: each
generation makes one child, which replaces the worst chromosome unless it is worse than it. A
generation is thus one child, and the run ends after ``generations`` of them (the paper's 50000).
The paper has no other termination criterion; we also stop when the best chromosome reaches a
goal at the lower bound of any path's cost (the octile distance times the smallest factor in the
window), since no chromosome can then be better.

**Result.** The decoded path of the best chromosome, with the loops it walks cut out (the
stretch between two visits of one cell is dropped, which never raises the cost and keeps every
step a legal one); the paper does not do this, and only the returned path is changed, not the
evolution. ``cost`` is the cost of that loop-free path and ``expanded`` counts the genes decoded
over all evaluations (moves tried, skipped ones included). The result is None when the best
chromosome ends away from every goal. The initial population may be seeded with given paths,
each encoded into a chromosome (the chromosome grows to hold the longest of them); the paper
suggests injecting retrieved cases this way.

Random numbers come from numba's generator, seeded inside the compiled kernel, so one seed always
gives the same result.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np

from cbr_grid.costs import SQRT2
from cbr_grid.query import without_loops
from cbr_grid.search_base import (
    DX,
    DY,
    MOVE_DIRECTIONS,
    MOVE_OF_DIRECTION,
    checked_arguments,
    move,
)
from cbr_kernels import njit
from cbr_solvers.search import SearchResult, _heuristic

DEFAULT_GENERATIONS = 50_000
DEFAULT_POPULATION = 50
DEFAULT_MUTATION = 1.0
DISTANCES = ("euclidean", "octile")

# The opposite of each move, the one a gene may not follow.
_REVERSE = MOVE_OF_DIRECTION[(MOVE_DIRECTIONS + 4) % 8]


@njit
def _goal_distance(x: int, y: int, goals: np.ndarray, euclidean: bool) -> float:
    """The distance from (x, y) to the nearest goal; 0 exactly on a goal."""
    if not euclidean:
        return _heuristic(x, y, goals, 1.0)
    best = np.inf
    for k in range(goals.shape[0]):
        dx = abs(goals[k, 0] - x)
        dy = abs(goals[k, 1] - y)
        best = min(best, math.sqrt(dx * dx + dy * dy))
    return best


@njit
def _decode(genes: np.ndarray, factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
            sx: int, sy: int, goals: np.ndarray, x0: int, y0: int, x1: int, y1: int,
            euclidean: bool, cells: np.ndarray) -> tuple[int, float, float, int]:
    """Walk ``genes`` from (sx, sy), skipping infeasible moves, until a goal or the last gene.

    Writes the cells visited into ``cells`` (room for len(genes) + 1 rows) and returns (cells
    written, distance of the last to the nearest goal, cost of the walk, genes decoded).
    """
    cx, cy = sx, sy
    cells[0, 0], cells[0, 1] = cx, cy
    n = 1
    cost = 0.0
    last = -1
    distance = _goal_distance(cx, cy, goals, euclidean)
    decoded = 0
    for i in range(genes.shape[0]):
        if distance == 0.0:
            break
        d = genes[i]
        decoded += 1
        if last >= 0 and d == _REVERSE[last]:
            continue
        if not move(passable, corner_cutting, cx, cy, d, x0, y0, x1, y1):
            continue
        nx, ny = cx + DX[d], cy + DY[d]
        length = SQRT2 if d >= 4 else 1.0
        cost += length * (factor[cy, cx] + factor[ny, nx]) * 0.5
        cx, cy = nx, ny
        last = d
        cells[n, 0], cells[n, 1] = cx, cy
        n += 1
        distance = _goal_distance(cx, cy, goals, euclidean)
    return n, distance, cost, decoded


@njit
def _walk(genes: np.ndarray, passable: np.ndarray, corner_cutting: bool, sx: int, sy: int,
          goals: np.ndarray, x0: int, y0: int, x1: int, y1: int) -> None:
    """Fill ``genes`` with a random walk from (sx, sy) that draws only feasible moves."""
    feasible = np.empty(8, dtype=np.int64)
    cx, cy = sx, sy
    last = -1
    for i in range(genes.shape[0]):
        # after the goal the genes are never decoded; where no move is feasible, any gene is
        count = 0
        if _goal_distance(cx, cy, goals, True) > 0.0:
            for d in range(8):
                if (last < 0 or d != _REVERSE[last]) and move(passable, corner_cutting, cx, cy,
                                                              d, x0, y0, x1, y1):
                    feasible[count] = d
                    count += 1
        if count == 0:
            genes[i] = np.random.randint(0, 8)
            continue
        d = feasible[np.random.randint(0, count)]
        genes[i] = d
        cx, cy = cx + DX[d], cy + DY[d]
        last = d


@njit(inline="always")
def _better(d1: float, c1: float, d2: float, c2: float) -> bool:
    """Whether fitness (d1, c1) beats (d2, c2): nearer the goal, or as near and cheaper."""
    return d1 < d2 or (d1 == d2 and c1 < c2)


@njit
def _tournament(distance: np.ndarray, cost: np.ndarray) -> int:
    """The fitter of two chromosomes drawn at random (binary tournament)."""
    a = np.random.randint(0, distance.shape[0])
    b = np.random.randint(0, distance.shape[0])
    return b if _better(distance[b], cost[b], distance[a], cost[a]) else a


@njit
def _evolve(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool, sx: int, sy: int,
            goals: np.ndarray, x0: int, y0: int, x1: int, y1: int, euclidean: bool,
            seeds: np.ndarray, size: int, generations: int, mutation: float, bound: float,
            seed: int) -> tuple[np.ndarray, int]:
    """Run the steady-state GA; returns (best chromosome, genes decoded).

    ``seeds`` holds the encoded seed paths, one row of L genes each, -1 where a gene is to be
    drawn at random; its width is the chromosome length L. ``bound`` is a lower bound of any
    path's cost: a best chromosome at a goal with that cost ends the run.
    """
    np.random.seed(seed)
    length = seeds.shape[1]
    population = np.empty((size, length), dtype=np.int64)
    distance = np.empty(size)
    cost = np.empty(size)
    cells = np.empty((length + 1, 2), dtype=np.int64)
    expanded = 0
    for p in range(size):
        if p < seeds.shape[0]:
            for i in range(length):
                g = seeds[p, i]
                population[p, i] = g if g >= 0 else np.random.randint(0, 8)
        else:
            _walk(population[p], passable, corner_cutting, sx, sy, goals, x0, y0, x1, y1)
        _, distance[p], cost[p], decoded = _decode(population[p], factor, passable,
                                                   corner_cutting, sx, sy, goals, x0, y0, x1,
                                                   y1, euclidean, cells)
        expanded += decoded
    best = 0
    for p in range(1, size):
        if _better(distance[p], cost[p], distance[best], cost[best]):
            best = p

    child = np.empty(length, dtype=np.int64)
    for _ in range(generations):
        if distance[best] == 0.0 and cost[best] <= bound:
            break
        a = _tournament(distance, cost)
        b = _tournament(distance, cost)
        for i in range(length):
            child[i] = population[a, i] if np.random.random() < 0.5 else population[b, i]
        if np.random.random() < mutation:
            i = np.random.randint(0, length)
            child[i] = (child[i] + np.random.randint(1, 8)) % 8
        _, d, c, decoded = _decode(child, factor, passable, corner_cutting, sx, sy, goals, x0,
                                   y0, x1, y1, euclidean, cells)
        expanded += decoded
        worst = 0
        for p in range(1, size):
            if _better(distance[worst], cost[worst], distance[p], cost[p]):
                worst = p
        if _better(distance[worst], cost[worst], d, c):
            continue  # the child is the worst of all: it is the one eliminated
        # replacing even an equal worst lets the population drift across plateaus
        population[worst] = child
        distance[worst], cost[worst] = d, c
        if _better(d, c, distance[best], cost[best]):
            best = worst
    return population[best].copy(), expanded


def _direction(dx: int, dy: int) -> int:
    """The gene of the move (dx, dy), or -1 when it is no move to an 8-neighbour."""
    for d in range(8):
        if DX[d] == dx and DY[d] == dy:
            return d
    return -1


def _encode(paths: Iterable[object], start: tuple[int, int], length: int,
            count: int) -> np.ndarray:
    """The first ``count`` seed paths as rows of genes, -1 past a path's end, at least
    ``length`` wide."""
    rows: list[list[int]] = []
    for number, path in enumerate(paths):
        if number == count:
            break
        cells = np.asarray(path, dtype=np.int64).reshape(-1, 2)
        if len(cells) == 0 or tuple(cells[0]) != start:
            raise ValueError(f"seed path {number} does not begin at the start {start}")
        genes = [_direction(int(dx), int(dy)) for dx, dy in np.diff(cells, axis=0)]
        if -1 in genes:
            raise ValueError(f"seed path {number} has a step to a cell that is no 8-neighbour")
        rows.append(genes)
    width = max([length, *map(len, rows)])
    seeds = np.full((len(rows), width), -1, dtype=np.int64)
    for row, genes in zip(seeds, rows, strict=True):
        row[:len(genes)] = genes
    return seeds


def _cost(factor: np.ndarray, path: np.ndarray) -> float:
    """The cost of ``path`` under the step cost contract."""
    a, b = path[:-1], path[1:]
    lengths = np.where((a != b).all(axis=1), SQRT2, 1.0)
    return float(np.sum(lengths * (factor[a[:, 1], a[:, 0]] + factor[b[:, 1], b[:, 0]]) * 0.5))


def genetic(factor: np.ndarray, passable: np.ndarray, corner_cutting: bool,
            start: Sequence[int], goals: object, window: Sequence[int] | None = None, *,
            generations: int = DEFAULT_GENERATIONS, population: int = DEFAULT_POPULATION,
            mutation: float = DEFAULT_MUTATION, seed: int = 0,
            seed_paths: Iterable[object] = (), distance: str = "euclidean"
            ) -> SearchResult | None:
    """A path from ``start`` to the nearest of ``goals`` by the genetic algorithm.

    Arguments as for :func:`cbr_solvers.search.dijkstra`; ``window`` also sets the chromosome
    length L = 2·max(width, height) of the clipped window. ``generations`` children are made at
    most, by a population of ``population`` chromosomes; ``mutation`` is the probability that a
    child has one random gene changed; ``seed`` (an integer >= 0) fixes every random draw.
    ``seed_paths`` (sequences of (x, y) cells from the start in 8-neighbour steps, not
    necessarily feasible) replace the first random chromosomes. ``distance`` ("euclidean" or
    "octile") measures how far a chromosome ends from the goals.

    Returns None when the best chromosome does not end on a goal (also when the start is
    blocked or outside the window, or no goal is passable inside it); the path is otherwise
    loop-free and obeys the movement rules. ``expanded`` is the number of genes decoded. Raises
    ValueError for bad arguments, cells outside the grid and a factor that is not finite and
    positive on a passable cell of the window.
    """
    if not (isinstance(generations, int) and generations >= 0):
        raise ValueError(f"generations must be an integer >= 0, got {generations!r}")
    if not (isinstance(population, int) and population >= 2):
        raise ValueError(f"population must be an integer >= 2, got {population!r}")
    if not 0.0 <= mutation <= 1.0:
        raise ValueError(f"mutation must be a probability in [0, 1], got {mutation!r}")
    if not (isinstance(seed, int | np.integer) and seed >= 0):
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    if distance not in DISTANCES:
        raise ValueError(f"distance must be one of {', '.join(DISTANCES)}, got {distance!r}")
    factor, passable, (sx, sy), targets, (x0, y0, x1, y1) = checked_arguments(
        factor, passable, start, goals, window)
    seeds = _encode(seed_paths, (sx, sy), 2 * max(x1 - x0 + 1, y1 - y0 + 1), population)
    if not (x0 <= sx <= x1 and y0 <= sy <= y1) or not passable[sy, sx]:
        return None
    open_ = passable[y0:y1 + 1, x0:x1 + 1]
    factors = factor[y0:y1 + 1, x0:x1 + 1][open_]
    if not ((factors > 0.0) & (factors < np.inf)).all():
        raise ValueError("factor must be finite and positive on passable cells")
    inside = ((targets >= (x0, y0)) & (targets <= (x1, y1))).all(axis=1)
    targets = targets[inside]
    targets = np.ascontiguousarray(targets[passable[targets[:, 1], targets[:, 0]]])
    if len(targets) == 0:
        return None
    nearest = _goal_distance(sx, sy, targets, False)
    # a hair above the bound, so that rounding in a path's summed cost cannot hide an optimum
    bound = nearest * float(factors.min()) * (1.0 + 1e-9)
    state = int(np.random.SeedSequence(int(seed)).generate_state(1)[0])
    genes, expanded = _evolve(factor, passable, bool(corner_cutting), sx, sy, targets, x0, y0,
                              x1, y1, distance == "euclidean", seeds, population, generations,
                              float(mutation), bound, state)
    cells = np.empty((len(genes) + 1, 2), dtype=np.int64)
    n, left, _, _ = _decode(genes, factor, passable, bool(corner_cutting), sx, sy, targets, x0,
                            y0, x1, y1, distance == "euclidean", cells)
    if left != 0.0:
        return None
    path = without_loops(cells[:n])
    return SearchResult(path, _cost(factor, path), int(expanded))
