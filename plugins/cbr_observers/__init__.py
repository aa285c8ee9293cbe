"""Built-in observers: components that wrap the phase hooks to watch the cycle."""

from __future__ import annotations

from cbr_observers.trace import Trace, TraceOptions
from cbrcore.hookspecs import hookimpl
from cbrcore.registry import Registry


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("observer", "trace", Trace, options=TraceOptions)
