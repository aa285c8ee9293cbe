"""Kinematic models of nonholonomic robots (section 5 of the case graph paper).

The move condition P(i, j, k) is a component of kind ``kinematics``
(:mod:`cbr_kinematics.models`). A configuration declares its robot's model once, in the
top-level ``kinematics`` slot (``holonomic`` when it says nothing); the engine puts the model
in the run's stash under :data:`KINEMATICS`, and every planner of the run (the grid solvers,
the case graph planner, the simulated robot's replanner) reads it there and plans with the
edge-based Dijkstra and A* that respect it, which search grids
(:mod:`cbr_solvers.kinematic_search`) and graphs of directed edges, the case graph's among them
(:mod:`cbr_solvers.graph_search`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.errors import CbrError
from cbrcore.hookspecs import hookimpl
from cbrcore.options import configured
from cbrcore.stash import StashKey

if TYPE_CHECKING:
    from cbr_kinematics.models import Kinematics
    from cbrcore.context import Context
    from cbrcore.registry import Registry

HOLONOMIC = "holonomic"
"""The name of the model without constraints, the slot's default."""

KINEMATICS = StashKey["Kinematics"]()
"""The run's kinematic model, built from the configuration's ``kinematics`` slot."""


def kinematics_of(name: str, ctx: Context, where: str) -> Kinematics | None:
    """The kinematic model registered as ``name``, checked, or None for one that allows every
    turn: the ordinary searches plan for it. ``where`` names the option in errors."""
    return checked(ctx.registry.create("kinematics", name, None, ctx), name, where)


def robot_kinematics(ctx: Context, where: str) -> Kinematics | None:
    """The run's kinematic model (the configuration's ``kinematics`` slot), checked, or None
    for one that allows every turn, and for a context built without a configuration."""
    model = ctx.stash.get(KINEMATICS, None)
    return None if model is None else checked(model, type(model).__name__, where)


def require_any_move(planner: str, instead: str) -> None:
    """Refuse, while a component's options are read, a configuration whose robot has kinematic
    constraints: ``planner`` plans only for robots that may make any move, and ``instead`` says
    what plans for that robot. A ValueError, which the options' reader reports with the
    option's place in the file."""
    robot = configured("kinematics")
    if robot not in (None, HOLONOMIC):
        raise ValueError(f"{planner} plans for robots that may make any move, not for "
                         f"kinematics {robot!r} (the configuration's robot); {instead}")


def checked(model: object, name: str, where: str) -> Kinematics | None:
    """``model`` if it is a constrained kinematic model whose turn table is sound, None if it
    allows every turn; a CbrError naming ``where`` and ``name`` otherwise."""
    from cbr_kinematics.models import Kinematics

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
    registry.add_kind("kinematics", "a robot's move condition: which move may follow which at a "
                                    "vertex; the run's model, declared once, plans every path",
                      slot="kinematics", default=HOLONOMIC, key=KINEMATICS)
    # named, not imported: the models and NumPy load when a run plans with them
    registry.add("kinematics", HOLONOMIC, "cbr_kinematics.models:Holonomic")
    registry.add("kinematics", "forward", "cbr_kinematics.models:Forward")
    registry.add("kinematics", "forward_backward", "cbr_kinematics.models:ForwardBackward")
