"""Experiments and their sweeps: the ``cbr experiment`` command, which runs the components of
kind ``experiment`` that the families register (:mod:`cbr_experiments.experiment`), and the
runners that spread an experiment's independent tasks over a pool of processes or a Dask
cluster (:mod:`cbr_experiments.tasks`).

The engine runs no experiment: a family's experiments import what they need from here, and the
command joins ``cbr`` through ``cbr_cli``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.hookspecs import hookimpl

if TYPE_CHECKING:
    import typer


@hookimpl
def cbr_cli(app: typer.Typer) -> None:
    """``cbr experiment``."""
    from cbr_experiments.cli import add_commands

    add_commands(app)
