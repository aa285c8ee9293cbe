"""A plugin registering a world: a rectangular room, `world: {use: room, width: 8}`."""

import attrs

from cbrcore import hookimpl
from cbrcore.context import Context
from cbrcore.options import option
from cbrcore.registry import Registry


@attrs.frozen
class RoomOptions:
    width: float = option(10.0, "Width in metres.", validator=attrs.validators.gt(0))
    depth: float = option(6.0, "Depth in metres.", validator=attrs.validators.gt(0))


@attrs.frozen
class Room:
    width: float
    depth: float


def make_room(options: RoomOptions, ctx: Context) -> Room:
    return Room(options.width, options.depth)


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("world", "room", make_room, options=RoomOptions)
