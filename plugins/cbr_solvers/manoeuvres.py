"""What it costs to leave a vertex in each direction, given how the robot arrived: the move
condition P(i, j, k) of section 5 with its manoeuvres, compiled for both edge-based searches.

A manoeuvre is recorded as a code: 0 for none, 1 + l for one intermediate edge in direction l,
9 + 8·l + p for two (l, then p). :data:`CODES` bounds them, so a parent state and the
manoeuvre made before its successor pack into one integer.
"""

from __future__ import annotations

import numpy as np

from cbr_grid.directions import STEPS
from cbr_kernels import njit

CODES = 73
"""The number of manoeuvre codes: none, 8 single and 64 double ones."""


@njit
def leave_costs(arrival: int, out_cost: np.ndarray, turns: np.ndarray, manoeuvres: int,
                extra: np.ndarray, code: np.ndarray) -> None:
    """Fill ``extra[b]`` with the least cost added to leave the vertex in direction b after
    arriving in direction ``arrival`` (0 without a manoeuvre, inf when impossible) and
    ``code[b]`` with the manoeuvre that achieves it.

    ``out_cost[l]`` is the cost of driving out and back along the first part of an edge leaving
    the vertex in direction l (inf when there is none). ``arrival`` -1 means the heading is
    free: every direction is allowed as it is.
    """
    if arrival < 0:
        extra[:] = 0.0
        code[:] = 0
        return
    for b in range(8):
        extra[b] = 0.0 if turns[arrival, b] else np.inf
        code[b] = 0
    if manoeuvres < 1:
        return
    # one[x]: the least cost to be moving in direction x after one out-and-back, via one_l[x]
    one = np.full(8, np.inf)
    one_l = np.zeros(8, dtype=np.int64)
    for out in range(8):
        if turns[arrival, out] and out_cost[out] < np.inf:
            x = (out + 4) % 8
            if out_cost[out] < one[x]:
                one[x] = out_cost[out]
                one_l[x] = out
    for x in range(8):
        if one[x] < np.inf:
            for b in range(8):
                if turns[x, b] and one[x] < extra[b]:
                    extra[b] = one[x]
                    code[b] = 1 + one_l[x]
    if manoeuvres < 2:
        return
    for x in range(8):
        if one[x] == np.inf:
            continue
        for p in range(8):
            if not (turns[x, p] and out_cost[p] < np.inf):
                continue
            y = (p + 4) % 8
            total = one[x] + out_cost[p]
            for b in range(8):
                if turns[y, b] and total < extra[b]:
                    extra[b] = total
                    code[b] = 9 + 8 * one_l[x] + p


@njit
def decode(code: int) -> tuple[int, int]:
    """The directions (l, p) of the intermediate edges of manoeuvre ``code``; -1 for none."""
    if code == 0:
        return -1, -1
    if code < 9:
        return code - 1, -1
    return (code - 9) // 8, (code - 9) % 8


@njit
def manoeuvre_cells(x: int, y: int, code: int, out: np.ndarray, at: int) -> int:
    """Write the cells driven by manoeuvre ``code`` at cell (x, y) into ``out`` from row
    ``at`` (out to the neighbour and back, once or twice); the next free row."""
    first, second = decode(code)
    for d in (first, second):
        if d >= 0:
            out[at, 0], out[at, 1] = x + STEPS[d, 0], y + STEPS[d, 1]
            out[at + 1, 0], out[at + 1, 1] = x, y
            at += 2
    return at
