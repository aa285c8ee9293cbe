"""A plugin adding `cbr room-distance 0,0 3,4`, which prints the straight-line distance."""

import math

import typer

from cbrcore import hookimpl


@hookimpl
def cbr_cli(app: typer.Typer) -> None:
    @app.command("room-distance")
    def room_distance(start: str, goal: str) -> None:
        """Print the distance between two points X,Y in metres."""
        (x0, y0), (x1, y1) = ([float(v) for v in p.split(",")] for p in (start, goal))
        typer.echo(f"{math.hypot(x1 - x0, y1 - y0):g}")
