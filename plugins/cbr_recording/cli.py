"""The ``cbr record`` commands."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from cbrcore.cli.commands import output_console


def info(
    file: Annotated[Path, typer.Argument(metavar="FILE", show_default=False,
                                         help="The MCAP recording to describe.")],
    as_json: Annotated[bool, typer.Option("--json",
                                          help="Print the contents as one JSON object.")]
    = False,
) -> None:
    """List a recording's topics, their message types, counts and the time span."""
    from rich.table import Table

    from cbr_recording.info import contents

    found = contents(file)
    if as_json:
        typer.echo(json.dumps(found.as_dict(), indent=2))
        return

    def shown(t: float | None) -> str:
        return "-" if t is None else f"{t:.3f}"

    span = ("empty" if found.start is None
            else f"{shown(found.start)} s to {shown(found.end)} s "
                 f"({found.end - found.start:.3f} s)")
    title = f"{file}: {sum(t.count for t in found.topics)} messages, {span}"
    if not found.closed:
        title += " (not closed: the run was stopped; these are its complete chunks)"
    table = Table("topic", "type", "messages", "first s", "last s", title=title)
    for topic in found.topics:
        table.add_row(topic.name, topic.type, str(topic.count), shown(topic.first),
                      shown(topic.last))
    output_console().print(table)


def add_commands(app: typer.Typer) -> None:
    """Add the ``cbr record`` group to ``app``."""
    record = typer.Typer(name="record", help="Read recordings (MCAP with ROS 2 types).",
                         no_args_is_help=True)
    record.command("info")(info)
    app.add_typer(record)
