"""The continuous 2D world: worlds of walls, landmarks, doors and people; a disc robot with a
sonar ring, a camera, a bumper and odometry; pilots; trials; and the ``trials`` workload that
consults the engine from inside a running simulation.

Registers the ``world2d_file`` and ``world2d_generated`` worlds, the ``pilot`` kind (the
top-level ``pilot:`` slot, which the ``trials`` workload needs) with the ``potential_field`` and
``behaviors`` pilots, the ``trials`` workload, the ``rescuer`` solver, the ``divert_target``
metric, and the ``cbr sim`` commands. See docs/world2d.md.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import attrs
import typer

from cbr_world2d.cli import add_commands
from cbr_world2d.metric import DivertTarget
from cbr_world2d.pilots import (
    PILOT,
    BehaviorPilotOptions,
    PotentialFieldOptions,
    behavior_pilot,
    potential_field_pilot,
)
from cbr_world2d.pilots.rescuer import RescuerOptions
from cbr_world2d.solver import RescuerSolver
from cbr_world2d.workload import Trials, TrialsOptions
from cbr_world2d.world import World
from cbr_world2d.worldfile import load_world
from cbrcore.context import Context
from cbrcore.fingerprint import WorldFingerprint, fingerprint
from cbrcore.hookspecs import hookimpl
from cbrcore.options import option
from cbrcore.registry import Registry


@attrs.frozen
class WorldFileOptions:
    path: Path = option(doc="The world file (YAML; relative to the configuration file).")


def world_file(options: WorldFileOptions, ctx: Context) -> World:
    """A 2D world read from a world file (docs/world2d.md lists its keys)."""
    return load_world(options.path)


def _office_only(instance: GeneratedWorldOptions, attribute: attrs.Attribute,
                 value: object) -> None:
    if value is not None and value is not False and instance.kind not in OFFICES:
        raise ValueError(f"'{attribute.name}' is an option of the office floors "
                         f"({', '.join(OFFICES)}), not of kind {instance.kind!r}")


_COUNT = attrs.validators.optional(attrs.validators.and_(attrs.validators.instance_of(int),
                                                         attrs.validators.ge(0)))
OFFICES = ("office", "office_floor")
"""The generated kinds that are office floors."""


@attrs.frozen
class GeneratedWorldOptions:
    kind: Literal["semi_structured", "scenario", "office", "office_floor"] = option(
        doc="The layout: landmarks joined by linear obstacles into walls, corners, U-shapes and "
        "dead ends (002 Figure 1); one V, U, wall, dead-end corridor, wall with a gap or room "
        "round the start in the way from start to target, like 002's scenarios (Figure 7); an "
        "office floor of a hallway with four rooms a side, doors on schedules and people "
        "(004's building, the reproduction's floor); or an "
        "office floor whose layout (rooms, one or two hallways, widths) is drawn from the "
        "seed as well.")
    seed: int | None = option(None, "The layout's seed; none uses the run's seed.")
    people: int | None = option(
        None, "Office floors: how many people walk the hallways (none: the generator's "
        "choice).", validator=[_COUNT, _office_only])
    objects: int | None = option(
        None, "Office floors: how many transient objects (carts, boxes) stand in the hallways "
        "for a while (none: the generator's choice).", validator=[_COUNT, _office_only])
    doors_open: bool = option(False, "Office floors: every door open all day.",
                              validator=_office_only)


def generated_world(options: GeneratedWorldOptions, ctx: Context) -> World:
    """A 2D world generated from a seed: the same seed always gives the same world."""
    # the layouts are placed with numba kernels, loaded when a world is generated rather than
    # with the registration at every start of cbr
    from cbr_world2d.generate import office, office_floor, scenario, semi_structured

    seed = ctx.seed if options.seed is None else options.seed
    if options.kind in OFFICES:
        counts = {k: v for k, v in (("people", options.people), ("objects", options.objects))
                  if v is not None}
        make = office if options.kind == "office" else office_floor
        return make(seed, doors_open=options.doors_open, **counts)
    return {"semi_structured": semi_structured, "scenario": scenario}[options.kind](seed)


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add_kind("pilot", "the 2D robot's local controller: turns observations and a "
                               "target into speed and turn rate commands",
                      slot="pilot", key=PILOT)
    registry.add("pilot", "potential_field", potential_field_pilot,
                 options=PotentialFieldOptions)
    registry.add("pilot", "behaviors", behavior_pilot, options=BehaviorPilotOptions)
    registry.add("world", "world2d_file", world_file, options=WorldFileOptions)
    registry.add("world", "world2d_generated", generated_world, options=GeneratedWorldOptions)
    registry.add("workload", "trials", Trials, options=TrialsOptions)
    registry.add("solver", "rescuer", RescuerSolver, options=RescuerOptions)
    registry.add("metric", "divert_target", DivertTarget)


@hookimpl
def cbr_world_fingerprint(world: object) -> WorldFingerprint | None:
    """A 2D world's fingerprint: its bounds, walls, polygons, point obstacles, landmarks, doors
    with their schedules, people and places (not its name), described by its name and size."""
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
    add_commands(app)
