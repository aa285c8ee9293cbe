"""A plugin that lets a program hand the engine a room as a (width, depth) tuple:
`Engine(config, world=(8.0, 5.0))`."""

import attrs

from cbrcore import hookimpl
from cbrcore.errors import CbrError


@attrs.frozen
class Room:
    width: float
    depth: float


@hookimpl
def cbr_world_object(obj: object) -> Room | None:
    if not (isinstance(obj, tuple) and len(obj) == 2):
        return None  # not ours: another plugin may know it
    if min(obj) <= 0:
        raise CbrError(f"a room needs a positive width and depth, not {obj}")
    return Room(*map(float, obj))
