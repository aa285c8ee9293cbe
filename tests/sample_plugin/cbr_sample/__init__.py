"""cbr-sample-plugin: a third-party cbrcore plugin found through the ``cbr`` entry point group."""

from __future__ import annotations

from cbr_sample.corridor import (
    ClosestTrip,
    ClosestTripOptions,
    PhaseCounter,
    Remember,
    Splice,
    Trips,
    TripsOptions,
    Walk,
)
from cbrcore import hookimpl
from cbrcore.registry import Registry


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("workload", "corridor_trips", Trips, options=TripsOptions)
    registry.add("retriever", "closest_trip", ClosestTrip, options=ClosestTripOptions)
    registry.add("reuser", "splice", Splice)
    registry.add("solver", "walk", Walk)
    registry.add("retainer", "remember", Remember)
    registry.add("observer", "phase_counter", PhaseCounter)
