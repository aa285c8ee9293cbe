"""The conventions every ``cbr`` command follows, a plugin's included.

``-h`` works wherever ``--help`` does (:data:`CONTEXT_SETTINGS`, inherited by every command
below the application). Help names each value by a readable metavar: an argument by its name in
capitals (``CONFIG``, ``[NAME]`` when optional, ``FILE...`` when repeated), an option by the
metavar it declares or else its choices (``--size [ci|full]``) or its name in capitals
(``--trials TRIALS``), never by a typed placeholder (``<int range>``, ``<list[str]>``) or a
braced argument (``{config}``). Declare a metavar that says what the value is where the name
does not (``--set KEY.PATH=VALUE``, ``--start X,Y|PLACE``), and list a fixed set of values as an
``enum.Enum`` (or :func:`choices` in the metavar of a value typer cannot see as a choice). A
value outside an enum's choices is refused in plain words, ``--size: 'huge' is not one of ci,
full``, a usage error (exit code 2).

An option whose value is written ``KEY=VALUE`` (``--set retrieve=nearest``) completes in bash
too, which splits that word at its ``=`` (:func:`cbrcore.cli.completion.split_option_value`):
its completer is given the whole ``KEY=VALUE`` word and returns whole words, as in zsh and fish.

:func:`follow_conventions` gives a typer application's commands, its groups' included, the
:class:`CbrCommand` class that renders help this way; ``cbr`` applies it to the whole
application after plugins have added their commands, so plugin authors need do nothing.
"""

from __future__ import annotations

import enum
from collections.abc import Iterable
from typing import Any

import typer
from typer.core import TyperCommand
from typer.models import CommandInfo

from cbrcore.cli.completion import split_option_value

CONTEXT_SETTINGS: dict[str, Any] = {"help_option_names": ["-h", "--help"]}
"""The settings of the ``cbr`` application's context, which every command's context inherits."""


def choices(values: Iterable[object]) -> str:
    """The metavar listing a fixed set of values: ``[ci|full]``."""
    return "[" + "|".join(_choice_text(v) for v in values) + "]"


def _choices_of(param: Any) -> tuple[object, ...] | None:
    """The fixed values a parameter takes, if it takes a fixed set."""
    # typer describes a parameter's type by a type descriptor from 0.29, by click's parameter
    # type before: both hold the choices of an enum (or click.Choice) as ``choices``
    described = getattr(param, "type_descriptor", None) or getattr(param, "type", None)
    found = getattr(described, "choices", None)
    return tuple(found) if found else None


def _choice_text(value: object) -> str:
    return str(value.value if isinstance(value, enum.Enum) else value)


def metavar_of(param: Any) -> str | None:
    """The metavar help shows for ``param``: None for a flag, which takes no value."""
    if param.metavar is not None:
        return str(param.metavar)
    if param.param_type_name == "argument":
        return str(param.name).upper()
    if getattr(param, "is_flag", False) or getattr(param, "count", False):
        return None
    found = _choices_of(param)
    return choices(found) if found else str(param.name).upper()


class _PlainBadParameter(typer.BadParameter):
    """A bad value whose message names the parameter itself, shown as it is."""

    def format_message(self) -> str:
        return self.message


def _choice_error(command: Any, ctx: typer.Context, args: list[str],
                  param: Any) -> _PlainBadParameter | None:
    """The plain error for a value of ``param`` outside its choices (``--robot: 'nosuch' is not
    one of pioneer2dx, ros2005``), or None when ``param`` takes no fixed set of values."""
    found = _choices_of(param) if param is not None else None
    if not found:
        return None
    given = command.make_parser(ctx).parse_args(args=args)[0].get(param.name)
    allowed = [_choice_text(choice) for choice in found]
    values = given if isinstance(given, list | tuple) else [given]
    bad = next((value for value in values if value not in allowed), None)
    if bad is None:
        return None
    name = max(param.opts, key=len) if param.param_type_name == "option" else param.metavar
    return _PlainBadParameter(f"{name}: {bad!r} is not one of {', '.join(allowed)}", ctx=ctx,
                             param=param)


class CbrCommand(TyperCommand):
    """A typer command whose usage line and help name values by readable metavars."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        for param in self.params:
            # set once, so that usage errors ("Missing argument 'CONFIG'") agree with help
            param.metavar = metavar_of(param)

    def collect_usage_pieces(self, ctx: typer.Context) -> list[str]:
        pieces = [self.options_metavar] if self.options_metavar else []
        for param in self.get_params(ctx):
            if param.param_type_name != "argument":
                continue
            name = str(param.metavar)
            if param.nargs != 1:
                name += "..."
            pieces.append(name if param.required else f"[{name}]")
        return pieces

    def parse_args(self, ctx: typer.Context, args: list[str]) -> list[str]:
        """Parse as typer does, but say a value outside a parameter's choices in plain words
        (typer's message reads ``Value error, ...``)."""
        given = list(args)  # the parser consumes the list it is handed
        try:
            return list(super().parse_args(ctx, args))
        except typer.BadParameter as exc:
            plain = _choice_error(self, ctx, given, exc.param)
            if plain is None:
                raise
            raise plain from exc

    def format_options(self, ctx: typer.Context, formatter: Any) -> None:
        arguments: list[tuple[str, str]] = []
        options: list[tuple[str, str]] = []
        for param in self.get_params(ctx):
            record = param.get_help_record(ctx)
            if record is None:  # hidden
                continue
            if param.param_type_name == "argument":
                # the record's own name carries typer's type placeholder; the metavar is enough
                arguments.append((str(param.metavar), record[1]))
            else:
                options.append(record)
        for title, rows in (("Arguments", arguments), ("Options", options)):
            if rows:
                with formatter.section(title):
                    formatter.write_dl(rows)

    def shell_complete(self, ctx: typer.Context, incomplete: str) -> list[Any]:
        """Completions of the word the parameters left: the value of a ``KEY=VALUE`` option
        word that bash split at its ``=``, else the command's own (its options' names)."""
        split = split_option_value(ctx.find_root().info_name or "")
        if split is None:
            return list(super().shell_complete(ctx, incomplete))
        option, word = split
        key = word[: word.index("=") + 1]
        for param in self.get_params(ctx):
            if option in (*param.opts, *param.secondary_opts):
                items = [item for item in param.shell_complete(ctx, word)
                         if str(item.value).startswith(key)]
                for item in items:  # bash replaces what follows the '=' alone
                    item.value = str(item.value)[len(key):]
                return items
        return []


def follow_conventions(app: typer.Typer) -> None:
    """Build the commands of ``app`` and of its groups, at any depth, as :class:`CbrCommand`,
    except a command that chose a class of its own (a subclass of typer's)."""
    commands: list[CommandInfo] = list(app.registered_commands)
    for group in app.registered_groups:
        if group.typer_instance is not None:
            follow_conventions(group.typer_instance)
    for info in commands:
        if info.cls is None or info.cls is TyperCommand:  # typer's default
            info.cls = CbrCommand
