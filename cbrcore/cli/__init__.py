"""The ``cbr`` command line.

``cbr`` alone prints help and exits 0; ``cbr --version`` (``-V``) prints the versions of cbrcore
and of every loaded plugin. User errors (bad configuration, unknown component, broken plugin,
unusable case base, bad usage) print one clear message and exit with code 2; ``--traceback``
shows where they came from. A plugin that failed to load while the others did is one
``warning:`` line on stderr.
"""

from __future__ import annotations

import platform
import sys
import traceback
import warnings
from collections.abc import Callable, Sequence
from importlib import metadata
from typing import TYPE_CHECKING, TextIO

import typer
from typer.models import CommandInfo

from cbrcore.cli import casebase, commands
from cbrcore.cli.conventions import CONTEXT_SETTINGS, follow_conventions
from cbrcore.cli.plugin_commands import cbr_commands
from cbrcore.errors import CbrError, PluginWarning
from cbrcore.plugins import Plugins, current

if TYPE_CHECKING:
    from rich.console import Console


def _show_version(value: bool) -> None:
    if not value:
        return
    typer.echo(versions(current()), nl=False)
    raise typer.Exit()


def versions(plugins: Plugins) -> str:
    """What ``cbr --version`` prints: cbrcore's version and each loaded plugin's source."""
    try:
        own = metadata.version("cbrcore")
    except metadata.PackageNotFoundError:  # a source tree that is not installed
        own = "(not installed)"
    lines = [f"cbrcore {own} (Python {platform.python_version()})"]
    width = max((len(p.name) for p in plugins.loaded), default=0)
    for p in plugins.loaded:
        source = f"{p.distribution} {p.version}" if p.distribution else "(registered in code)"
        lines.append(f"  {p.name:<{width}}  {source}")
    if not plugins.loaded:
        lines.append("  no plugins loaded")
    lines += [f"  {failure.describe()}" for failure in plugins.failed]
    return "\n".join(lines) + "\n"


def _options(
    traceback_: bool = typer.Option(False, "--traceback", help="Show tracebacks of errors."),
    version: bool = typer.Option(
        False, "--version", "-V", is_eager=True, callback=_show_version,
        help="Show the versions of cbrcore and of the loaded plugins, and exit."),
) -> None:
    """Case-based reasoning for mobile robot navigation."""
    # main() reads --traceback from the raw arguments, so errors raised while parsing or while
    # plugins add their commands honour it too; --version is handled by its callback


def build_app() -> typer.Typer:
    """The ``cbr`` application: cbrcore's commands and those the plugins add, each plugin's
    isolated and a name taken by whoever claims it first, cbrcore's own commands before
    its built-in plugins', and those before any other's (:mod:`cbrcore.cli.plugin_commands`).
    Every command follows :mod:`cbrcore.cli.conventions`."""
    app = typer.Typer(name="cbr", no_args_is_help=True, pretty_exceptions_enable=False,
                      rich_markup_mode=None, callback=_options,
                      context_settings=CONTEXT_SETTINGS)
    plugins = current()
    core = typer.Typer()
    commands.install(core)
    core.add_typer(casebase.app)
    for unit in cbr_commands(plugins, core):
        if isinstance(unit, CommandInfo):
            app.registered_commands.append(unit)
        else:
            app.registered_groups.append(unit)
    follow_conventions(app)
    return app


class _Stderr:
    """The console of the messages on stderr, made when the first is printed: most commands
    print none, and rich's console takes a noticeable part of ``cbr --help``'s start."""

    def __init__(self) -> None:
        self._console: Console | None = None

    def print(self, text: str) -> None:
        if self._console is None:
            from rich.console import Console

            # messages quote users' files and plugins' text: printed as written, no markup or
            # emoji
            self._console = Console(stderr=True, highlight=False, soft_wrap=True, markup=False,
                                    emoji=False)
        self._console.print(text)


ShowWarning = Callable[[Warning | str, type[Warning], str, int, TextIO | None, str | None], None]


def _plugin_warnings_as_lines(err: _Stderr, show: ShowWarning) -> ShowWarning:
    """A ``warnings.showwarning`` printing a :class:`PluginWarning` as one ``warning:`` line.

    The source line a warning names is cbrcore's, not the user's, so it would only distract;
    other categories go on to ``show``. Filters still apply, since they run before display.
    """

    def display(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                file: TextIO | None = None, line: str | None = None) -> None:
        if issubclass(category, PluginWarning):
            err.print(f"warning: {message}")
        else:
            show(message, category, filename, lineno, file, line)

    return display


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``cbr`` with ``argv`` (default: the process's arguments); return the exit code."""
    err = _Stderr()
    # catch_warnings restores the display on return, for callers running ``main`` in-process
    with warnings.catch_warnings():
        warnings.showwarning = _plugin_warnings_as_lines(err, warnings.showwarning)
        return _run(list(sys.argv[1:] if argv is None else argv), err)


def _run(args: list[str], err: _Stderr) -> int:
    show_traceback = "--traceback" in args
    if not args:  # ``cbr`` alone asks what there is to do: help, and success
        args = ["--help"]
    try:
        command = typer.main.get_command(build_app())
        result = command.main(args, prog_name="cbr", standalone_mode=False)
    except typer.Exit as exc:
        return exc.exit_code
    except typer.TyperException as exc:  # usage errors, raised by typer's copy of click
        # a group given no command (``cbr sim``) is asked what there is, as ``cbr`` alone: its
        # help, and success; click names that case by its class, in whichever copy raised it
        helped = getattr(exc, "ctx", None)
        if type(exc).__name__ == "NoArgsIsHelpError" and helped is not None:
            typer.echo(helped.get_help())
            return 0
        exc.show()
        return exc.exit_code
    except typer.Abort:
        err.print("Aborted.")
        return 1
    except (CbrError, PluginWarning) as exc:  # a plugin warning is raised under -W error
        if show_traceback:
            err.print(traceback.format_exc())
        err.print(f"error: {exc}")
        return 2
    except MemoryError:
        # an input within the documented limits can still outgrow a small machine's memory
        if show_traceback:
            err.print(traceback.format_exc())
        err.print("error: out of memory: the input needs more memory than this machine has "
                  "(the sizes cbr accepts: docs/reference/limits.md)")
        return 2
    return result if isinstance(result, int) else 0


def console_main() -> None:
    """The ``cbr`` console script."""
    sys.exit(main())
