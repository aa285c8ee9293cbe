"""Recordings: a run, a trial or a delivery day written as MCAP with ROS 2 message types.

The ``record`` observer (:mod:`cbr_recording.observer`) opens a recording for a run;
``cbr run --record FILE`` adds it. The families record on the run's
:class:`~cbr_recording.recorder.Recorder`, found under :data:`~cbr_recording.keys.RECORDER`;
``cbr record info`` lists what a recording holds. The ROS and MCAP libraries are imported
only when something is recorded or read.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl

if TYPE_CHECKING:
    import typer

    from cbrcore.registry import Registry


@hookimpl
def cbr_register(registry: Registry) -> None:
    registry.add("observer", "record", "cbr_recording.observer:Record",
                 options="cbr_recording.observer:RecordOptions")


@hookimpl
def cbr_cli(app: typer.Typer) -> None:
    """``cbr record``."""
    from cbr_recording.cli import add_commands

    add_commands(app)
