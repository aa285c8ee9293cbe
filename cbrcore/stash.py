"""Typed keys for state that components of one run share (in the manner of pytest's stash).

A plugin family that keeps state for the whole run (the map the last proposal was planned on,
the robot's kinematic model) declares a key once, at module level, with the type of its value::

    PLANNED_WORLD = StashKey[Grid]()

and reads and writes ``ctx.stash[PLANNED_WORLD]``. A key is an object, not a string, so two
plugins can never collide on a name, a type checker knows what ``ctx.stash[key]`` holds, and
only code that can import the key can reach the value.
"""

from __future__ import annotations

from typing import Any, Generic, TypeVar, cast

T = TypeVar("T")
D = TypeVar("D")


class StashKey(Generic[T]):
    """A key of a :class:`Stash` whose value is a ``T``; compared by identity."""

    __slots__ = ()


class Stash:
    """Run-wide state of the components, under typed :class:`StashKey` keys."""

    __slots__ = ("_values",)

    def __init__(self) -> None:
        self._values: dict[StashKey[Any], object] = {}

    def __setitem__(self, key: StashKey[T], value: T) -> None:
        self._values[key] = value

    def __getitem__(self, key: StashKey[T]) -> T:
        return cast(T, self._values[key])

    def get(self, key: StashKey[T], default: D) -> T | D:
        """The value under ``key``, or ``default`` when nothing is stored there."""
        try:
            return self[key]
        except KeyError:
            return default

    def setdefault(self, key: StashKey[T], default: T) -> T:
        """The value under ``key``, storing ``default`` there first when nothing is."""
        try:
            return self[key]
        except KeyError:
            self[key] = default
            return default

    def __delitem__(self, key: StashKey[T]) -> None:
        del self._values[key]

    def __contains__(self, key: StashKey[T]) -> bool:
        return key in self._values

    def __len__(self) -> int:
        return len(self._values)
