"""The 2D worlds a configuration's ``world`` slot builds: one read from a world file, or one
generated from a seed."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import attrs

from cbr_world2d.world import World
from cbr_world2d.worldfile import load_world
from cbrcore.context import Context
from cbrcore.options import option


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
