"""The continuous 2D world: worlds of walls, landmarks, doors and people; a disc robot with a
sonar ring, a camera, a bumper and odometry; pilots; trials; and the ``trials`` workload that
consults the engine from inside a running simulation.

Registers the ``world2d_file`` and ``world2d_generated`` worlds, the ``pilot`` kind (the
top-level ``pilot:`` slot, which the ``trials`` workload needs) with the ``potential_field`` and
``behaviors`` pilots, the ``trials`` workload, the ``rescuer`` solver, the ``divert_target``
metric, and the ``cbr sim`` commands. See docs/world2d.md.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl
from cbrcore.stash import StashKey

if TYPE_CHECKING:
    import typer

    from cbr_world2d.pilots.base import Pilot
    from cbrcore.fingerprint import WorldFingerprint
    from cbrcore.registry import Registry

PILOT: StashKey[Pilot] = StashKey()
"""The run's configured pilot, as the trials workload reads it."""

_WORLDS = "cbr_world2d.world_components"
_PILOTS = "cbr_world2d.pilots"


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add_kind("pilot", "the 2D robot's local controller: turns observations and a "
                               "target into speed and turn rate commands",
                      slot="pilot", key=PILOT)
    # named, not imported: the simulator loads when a configuration uses a component
    registry.add("pilot", "potential_field", f"{_PILOTS}:potential_field_pilot",
                 options=f"{_PILOTS}:PotentialFieldOptions")
    registry.add("pilot", "behaviors", f"{_PILOTS}:behavior_pilot",
                 options=f"{_PILOTS}:BehaviorPilotOptions")
    registry.add("world", "world2d_file", f"{_WORLDS}:world_file",
                 options=f"{_WORLDS}:WorldFileOptions")
    registry.add("world", "world2d_generated", f"{_WORLDS}:generated_world",
                 options=f"{_WORLDS}:GeneratedWorldOptions")
    registry.add("workload", "trials", "cbr_world2d.workload:Trials",
                 options="cbr_world2d.workload:TrialsOptions")
    registry.add("solver", "rescuer", "cbr_world2d.solver:RescuerSolver",
                 options="cbr_world2d.pilots.rescuer:RescuerOptions")
    registry.add("metric", "divert_target", "cbr_world2d.metric:DivertTarget")


@hookimpl
def cbr_world_fingerprint(world: object) -> WorldFingerprint | None:
    """A 2D world's fingerprint: its bounds, walls, polygons, point obstacles, landmarks, doors
    with their schedules, people and places (not its name), described by its name and size."""
    import attrs

    from cbr_world2d.world import World
    from cbrcore.fingerprint import fingerprint

    if not isinstance(world, World):
        return None
    content = {field.name: getattr(world, field.name) for field in attrs.fields(World)
               if field.init and field.name != "name"}
    xmin, ymin, xmax, ymax = world.bounds
    size = f"{xmax - xmin:g} x {ymax - ymin:g} m"
    return fingerprint("cbr_world2d.World", content,
                       f"{world.name} ({size})" if world.name else f"2D world of {size}")


@hookimpl
def cbr_cli(app: typer.Typer) -> None:
    """``cbr sim show``, ``cbr sim run`` and ``cbr sim batch``."""
    from cbr_world2d.cli import add_commands

    add_commands(app)
