"""Built-in observers: components that wrap the phase hooks to watch the cycle."""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl

if TYPE_CHECKING:
    from cbrcore.registry import Registry


@hookimpl
def cbr_register(registry: Registry) -> None:
    # named, not imported: the observer loads when a configuration uses it
    registry.add("observer", "trace", "cbr_observers.trace:Trace",
                 options="cbr_observers.trace:TraceOptions")
