"""Planning for nonholonomic robots (section 5 of the case graph paper).

The move condition P(i, j, k) is a component of kind ``kinematics``
(:mod:`cbr_kinematics.models`); the edge-based Dijkstra and A* that respect it search grids
(:mod:`cbr_kinematics.grid_search`) and graphs of directed edges, the case graph's among them
(:mod:`cbr_kinematics.graph_search`). The grid solvers and the case graph planner take a
model by name in their ``kinematics`` option.
"""

from __future__ import annotations

from cbr_kinematics.models import Forward, ForwardBackward, Holonomic, Kinematics
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.hookspecs import hookimpl
from cbrcore.registry import Registry

HOLONOMIC = "holonomic"
"""The name of the model without constraints, every option's default."""


def kinematics_of(name: str, ctx: Context, where: str) -> Kinematics | None:
    """The kinematic model registered as ``name``, checked, or None for one that allows every
    turn: the ordinary searches plan for it. ``where`` names the option in errors.

    The default, ``holonomic``, is known without a registry lookup, so planners built by hand
    with an empty registry plan as before.
    """
    if name == HOLONOMIC:
        return None
    model = ctx.registry.create("kinematics", name, None, ctx)
    if not isinstance(model, Kinematics):
        raise CbrError(f"{where}: kinematics {name!r} is a {type(model).__name__}, not a "
                       "cbr_kinematics.models.Kinematics")
    try:
        _ = model.table  # built and checked once, here
    except ValueError as exc:
        raise CbrError(f"{where}: kinematics {name!r}: {exc}") from None
    return None if model.unconstrained else model


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("kinematics", HOLONOMIC, Holonomic)
    registry.add("kinematics", "forward", Forward)
    registry.add("kinematics", "forward_backward", ForwardBackward)
