"""Pilots: what turns observations and a target into motion commands.

:mod:`.base` holds the :class:`Pilot` protocol, :mod:`.potential_field` the potential-field
pilot of 002; the behavior-merging controller of 004 is :mod:`.behaviors` (the behaviors known
by name, behavior sets, the merge and the pilot) over :mod:`.primitives` (the twelve primitive
behaviors of 004 Table 1) and :mod:`.arguments` (their arguments as plain data, the named
levels); :mod:`.monitor` holds the progress monitor and :mod:`.rescuer` the Rescuer that
:class:`cbr_world2d.navigator.Navigator` combines with a pilot; :mod:`.kernels` holds the numba
kernels of the potential field and the behaviors, imported when a pilot is built, not here.
The two factories below build the registered pilots (``potential_field`` and ``behaviors``)
from their options.
"""

from __future__ import annotations

from cbr_world2d import PILOT
from cbr_world2d.pilots.arguments import (
    PRIORITIES,
    SPEEDS,
    TOP_SPEED,
    TOP_TURN_RATE,
    TURN_RATES,
    register_argument,
)
from cbr_world2d.pilots.base import Command, Pilot, Point, bearing_error, wrap_angle
from cbr_world2d.pilots.behaviors import (
    BEHAVIORS,
    ActiveBehavior,
    BehaviorPilot,
    BehaviorPilotOptions,
    BehaviorType,
    lookup_behavior,
    merge,
    parse_behavior_set,
    register_behavior,
)
from cbr_world2d.pilots.monitor import MonitorOptions, ProgressMonitor, Status
from cbr_world2d.pilots.potential_field import PotentialField, PotentialFieldOptions
from cbr_world2d.pilots.primitives import Behavior, Proposal
from cbr_world2d.pilots.rescuer import Rescuer, RescuerOptions, Restored
from cbrcore.context import Context

__all__ = [
    "BEHAVIORS", "PILOT", "PRIORITIES", "SPEEDS", "TOP_SPEED", "TOP_TURN_RATE", "TURN_RATES",
    "ActiveBehavior", "Behavior", "BehaviorPilot", "BehaviorPilotOptions", "BehaviorType",
    "Command", "MonitorOptions", "Pilot", "Point", "PotentialField", "PotentialFieldOptions",
    "ProgressMonitor", "Proposal", "Rescuer", "RescuerOptions", "Restored", "Status",
    "bearing_error", "behavior_pilot", "lookup_behavior", "merge", "parse_behavior_set",
    "potential_field_pilot", "register_argument", "register_behavior", "wrap_angle",
]


def potential_field_pilot(options: PotentialFieldOptions, ctx: Context) -> PotentialField:
    """The ``potential_field`` pilot: attraction to the target, repulsion from the sonar's
    echoes (002 section 2); classic, so it gets trapped in U-shapes."""
    return PotentialField(options)


def behavior_pilot(options: BehaviorPilotOptions, ctx: Context) -> BehaviorPilot:
    """The ``behaviors`` pilot: active behaviors' proposals merged by priority x fit (004)."""
    return BehaviorPilot.from_data(options.behaviors, options.length_unit)
