"""A world plugin telling its rooms apart, so that a case base learned in an 8 m room refuses
a 9 m one: `world: {use: room, width: 8}`."""

import attrs

from cbrcore import hookimpl
from cbrcore.fingerprint import WorldFingerprint, fingerprint
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


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("world", "room", lambda options, ctx: Room(options.width, options.depth),
                 options=RoomOptions)


@hookimpl
def cbr_world_fingerprint(world: object) -> WorldFingerprint | None:
    if not isinstance(world, Room):
        return None  # another plugin's world
    # hash what the cases depend on, the room's size, not how it was made
    return fingerprint("room", world, f"room {world.width:g}x{world.depth:g} m")
