"""The ``cbr`` command line.

User errors (bad configuration, unknown component, broken plugin, unusable case base, bad usage)
print one clear message and exit with code 2; ``--traceback`` shows where they came from.
"""

from __future__ import annotations

import sys
import traceback
from collections.abc import Sequence

import typer
from rich.console import Console

from cbrcore.cli import casebase, commands
from cbrcore.errors import CbrError
from cbrcore.plugins import current


def _options(
    traceback_: bool = typer.Option(False, "--traceback", help="Show tracebacks of errors."),
) -> None:
    """Case-based reasoning for mobile robot navigation."""
    # main() reads --traceback from the raw arguments, so errors raised while parsing or while
    # plugins add their commands honour it too.


def build_app() -> typer.Typer:
    """The ``cbr`` application: plugin commands first, so a built-in name always wins."""
    app = typer.Typer(name="cbr", no_args_is_help=True, pretty_exceptions_enable=False,
                      rich_markup_mode=None, callback=_options)
    current().pm.hook.cbr_cli(app=app)
    commands.install(app)
    app.add_typer(casebase.app)
    return app


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``cbr`` with ``argv`` (default: the process's arguments); return the exit code."""
    args = list(sys.argv[1:] if argv is None else argv)
    show_traceback = "--traceback" in args
    err = Console(stderr=True, highlight=False, soft_wrap=True)
    try:
        command = typer.main.get_command(build_app())
        result = command.main(args, prog_name="cbr", standalone_mode=False)
    except typer.Exit as exc:
        return exc.exit_code
    except typer.TyperException as exc:  # usage errors, raised by typer's copy of click
        exc.show()
        return exc.exit_code
    except typer.Abort:
        err.print("Aborted.")
        return 1
    except CbrError as exc:
        if show_traceback:
            err.print(traceback.format_exc(), markup=False)
        err.print(f"error: {exc}", markup=False)
        return 2
    return result if isinstance(result, int) else 0


def console_main() -> None:
    """The ``cbr`` console script."""
    sys.exit(main())
