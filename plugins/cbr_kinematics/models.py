"""Kinematic models: the move condition P(i, j, k) of the nonholonomic planner.

A robot that has reached vertex j along edge (i, j), moving in direction a = δ(i, j), may leave
along edge (j, k), direction b = δ(j, k), when its model allows the turn from a to b
(:meth:`Kinematics.turns`), or through a manoeuvre of at most :attr:`Kinematics.manoeuvres`
intermediate edges at j: it drives out along an edge (j, l) it may turn onto, comes back along
it in reverse (moving in direction δ(l, j)) and carries on from there, so the condition of
section 5 for one intermediate edge is turns[a, δ(j, l)] and turns[δ(l, j), b], and for two
it chains once more through an edge (j, p). A manoeuvre adds the cost of driving out and back
along the part of each intermediate edge used (its first step).

The built-in models are the paper's: ``holonomic`` (every turn), ``forward`` (forward and
forward-diagonal moves only: a turn of at most 45 degrees, alpha in {0, 1, 7}) and
``forward_backward`` (the same turns, plus backward and backward-diagonal manoeuvres through
one or two intermediate edges). Another model is a component of kind ``kinematics``: a class
deriving from :class:`Kinematics` registered by a plugin.
"""

from __future__ import annotations

import abc
import functools

import numpy as np

MAX_MANOEUVRES = 2
"""The most intermediate edges one manoeuvre may use (the paper's two)."""


def turn_table(max_turn: int) -> np.ndarray:
    """The (8, 8) table of turns of at most ``max_turn`` 45-degree steps either way."""
    a = np.arange(8)
    alpha = np.abs(a[:, None] - a[None, :])
    return np.minimum(alpha, 8 - alpha) <= max_turn


class Kinematics(abc.ABC):
    """A kinematic model of a robot moving on a grid or a graph of directed edges.

    Subclasses give the turns the robot may make at a vertex and how many intermediate edges a
    manoeuvre may use; :attr:`table` checks both once, for the compiled searches.
    """

    manoeuvres: int = 0
    """How many intermediate edges a manoeuvre at a vertex may use: 0, 1 or 2."""

    def __init__(self, options: object = None, ctx: object = None) -> None:
        """Built by the registry with the model's options and the run context."""
        self.options = options

    @abc.abstractmethod
    def turns(self) -> np.ndarray:
        """An (8, 8) bool table: ``turns[a, b]`` when a robot arriving at a vertex moving in
        direction a may leave it moving in direction b without a manoeuvre."""

    @functools.cached_property
    def table(self) -> np.ndarray:
        """:meth:`turns`, checked: a C-contiguous read-only (8, 8) bool array."""
        table = np.asarray(self.turns())
        if table.shape != (8, 8) or table.dtype != np.bool_:
            raise ValueError(f"{type(self).__name__}.turns() must be an (8, 8) bool array, got "
                             f"{table.dtype} {table.shape}")
        if isinstance(self.manoeuvres, bool) or self.manoeuvres not in range(MAX_MANOEUVRES + 1):
            raise ValueError(f"{type(self).__name__}.manoeuvres must be 0, 1 or 2, got "
                             f"{self.manoeuvres!r}")
        table = np.ascontiguousarray(table)
        table.setflags(write=False)
        return table

    @property
    def unconstrained(self) -> bool:
        """Whether every turn is allowed: the ordinary vertex searches plan for this model."""
        return bool(self.table.all())


class Holonomic(Kinematics):
    """Every turn is allowed: the robot may leave a vertex in any direction."""

    def turns(self) -> np.ndarray:
        return np.ones((8, 8), dtype=bool)


class Forward(Kinematics):
    """Forward and forward-diagonal moves only: a turn of at most 45 degrees per vertex."""

    def turns(self) -> np.ndarray:
        return turn_table(1)


class ForwardBackward(Forward):
    """Forward moves turning at most 45 degrees, and backward manoeuvres through one or two
    intermediate edges for sharper turns."""

    manoeuvres = 2
