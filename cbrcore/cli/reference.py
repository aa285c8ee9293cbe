"""The command-line reference, generated from the ``cbr`` command tree.

``docs/reference/cli.md`` is :func:`cli_reference` over the application with the built-in
plugins (``cbr reference cli``); a test keeps it current. Every command, a plugin's included,
gets its usage line, its help and a row per argument and option with its metavar, help, range
and default. Nothing depends on the terminal: usage lines are assembled, not formatted to a width.
"""

from __future__ import annotations

import enum
import inspect
from typing import Any

from cbrcore.plugins import Plugins

_TOP = """\
# Command line reference

`cbr` alone prints the help and exits 0, and so does a group alone (`cbr sim`, `cbr casebase`):
asked what there is to do, it says. `python -m cbrcore` runs the same command line. Every
command takes `-h` and `--help`.

Help shows each value by a metavar that says what it is (`CONFIG`, `DIR`, `KEY.PATH=VALUE`) and
a choice by its values (`[ci|full]`); an optional argument is in brackets (`[NAME]`). Plugin
commands follow the same conventions: `cbr` applies them to every command it lists.

**Output.** Tables fit the terminal they are printed in; when standard output is a pipe or a
file they are never wrapped or cut at a width. For programs, a command with `--json` in its
table below prints JSON instead of tables and lines, with the same exit code.

**Exit codes.** 0 on success. 2 for a user error: a bad configuration, an unknown component, a
plugin that fails in a phase, an unusable case base file, a bad option or argument (a value
outside an option's choices reads `--robot: 'nosuch' is not one of pioneer2dx, ros2005`); the
message is printed to standard error, without a traceback unless `--traceback` is given.
`cbr casebase check` exits 1 when it finds problems, `cbr plan` when no path exists. Anything
else that exits non-zero with a traceback is a bug.

Plugins add their own commands through the `cbr_cli` hook; they are listed by `cbr --help` and
below with the plugin that adds them (this page lists those of the built-in plugins; `cbr
reference cli` prints it for the plugins installed). A plugin command never replaces a built-in
one of the same name: it is left out, and every command prints one line on stderr, `warning:
plugin 'x' from cbr-x 1.0 failed to add command 'run': the name is taken by cbrcore's own
command` (or `by plugin 'solvers' from cbrcore`). A plugin whose `cbr_cli` raises, even
`SystemExit`, adds none of its commands and gets the same kind of line (`failed to add its
commands: RuntimeError: ...`); the other commands work. With `CBR_STRICT_PLUGINS=1` the line is
an error and every command exits with code 2.

The topic pages say more about each command: [Running and experiments](../running.md),
[Case bases](../casebase.md#cbr-casebase-commands), [Grid worlds and
solvers](../grid.md#command-line), [The 2D world](../world2d-trials.md#cbr-sim).
"""

_ENVIRONMENT = (
    ("CBR_PLUGINS", "comma-separated plugin names: only these load"),
    ("CBR_DISABLE_PLUGINS", "comma-separated plugin names that never load"),
    ("CBR_STRICT_PLUGINS", "`1` (any value but empty or `0`) makes any plugin failure an error "
                           "instead of a warning"),
    ("CBR_MAX_DOCUMENT_BYTES", "the largest configuration, `--set` value or case base document "
                               "read, in bytes; default 100000000"),
    ("CBR_MAX_DOCUMENT_DEPTH", "the most levels of nested collections in such a document; "
                               "default 100, at most 200"),
    ("CBR_MAX_DOCUMENT_NODES", "the most values (scalars, mapping keys, collections) in such a "
                               "document, YAML aliases expanded; default 10000000"),
    ("CBR_MAX_DOCUMENT_ALIAS_NODES", "the most values that YAML aliases may repeat in such a "
                                     "document; default 100000"),
)

_BOTTOM = """\
A document beyond a limit is refused before it is built, with exit code 2 (see
[Writing a configuration](../configuration.md#size-and-depth-limits)). Every file named as input
must be a regular file: a named pipe, a device or a folder is refused without being read. The
limits of every input are listed in [Limits](limits.md).
"""


def _cell(text: str) -> str:
    """``text`` on one line, fit for a markdown table cell."""
    return " ".join(text.split()).replace("|", "\\|")


def _prose(text: str | None) -> list[str]:
    """A help text as markdown paragraphs; a click ``\\b`` block (kept unwrapped) as a code
    block."""
    lines: list[str] = []
    for paragraph in inspect.cleandoc(text or "").split("\n\n"):
        if paragraph.startswith("\b\n"):
            lines += ["```text", paragraph[2:], "```", ""]
        elif paragraph.strip():
            lines += [paragraph, ""]
    return lines


def _value(value: object) -> str:
    return str(value.value if isinstance(value, enum.Enum) else value)


def _default(param: Any) -> str:
    """The default a parameter's row shows: ``required``, the value, or nothing."""
    if param.required:
        return "required"
    default = param.default
    if not param.show_default or default is None or callable(default):
        return ""
    if param.param_type_name == "option" and param.is_flag:
        # a flag pair (--gif/--no-gif) shows the side it defaults to; a lone flag is off
        return f"`{param.opts[0]}`" if default and param.secondary_opts else ""
    if isinstance(default, list | tuple):
        return ", ".join(f"`{_value(v)}`" for v in default)
    return f"`{_value(default)}`"


def _range(param: Any) -> str:
    low, high = getattr(param, "min", None), getattr(param, "max", None)
    if low is not None and high is not None:
        return f" From {low} to {high}."
    if low is not None:
        return f" At least {low}."
    if high is not None:
        return f" At most {high}."
    return ""


def _names(param: Any) -> str:
    """The argument's metavar, or the option's names, the last followed by its metavar."""
    metavar = param.metavar or ""
    if param.param_type_name == "argument":
        return f"`{metavar}{'...' if param.nargs != 1 else ''}`".replace("|", "\\|")
    names = [*param.opts, *param.secondary_opts]
    shown = [f"`{name}`" for name in names[:-1]]
    value = f" {metavar}" if metavar and not param.is_flag else ""
    shown.append(f"`{names[-1]}{value}`")
    return ", ".join(shown).replace("|", "\\|")


def _rows(command: Any) -> list[str]:
    params = [p for p in command.params if not getattr(p, "hidden", False)]
    if not params:
        return []
    lines = ["| argument or option | meaning | default |", "|---|---|---|"]
    for param in params:
        meaning = _cell((getattr(param, "help", None) or "") + _range(param))
        lines.append(f"| {_names(param)} | {meaning} | {_default(param)} |")
    return [*lines, ""]


def _usage(command: Any, path: str) -> list[str]:
    ctx = command.context_class(command, info_name=path)
    pieces = command.collect_usage_pieces(ctx)
    return ["```text", " ".join([path, *pieces]), "```", ""]


def _added_by(command: Any, plugins: Plugins) -> list[str]:
    module = getattr(getattr(command, "callback", None), "__module__", None) or ""
    for plugin in plugins.loaded:
        if module == plugin.module or module.startswith(f"{plugin.module}."):
            return [f"Added by the `{plugin.name}` plugin.", ""]
    return []


def _section(command: Any, path: str, depth: int, plugins: Plugins) -> list[str]:
    lines = [f"{'#' * depth} `{path}`", "", *_usage(command, path),
             *_added_by(command, plugins), *_prose(command.help), *_rows(command),
             *_prose(command.epilog)]
    for name, sub in getattr(command, "commands", {}).items():
        if not getattr(sub, "hidden", False):
            lines += _section(sub, f"{path} {name}", depth + 1, plugins)
    return lines


def cli_reference(root: Any, plugins: Plugins) -> str:
    """The command-line reference of ``root``, the ``cbr`` click group, whose plugin commands
    are attributed to the one of ``plugins`` whose module defines them."""
    name = root.name or "cbr"
    lines = [_TOP, "## Global options", "", *_usage(root, name), *_rows(root)]
    for command_name, command in root.commands.items():
        if not getattr(command, "hidden", False):
            lines += _section(command, f"{name} {command_name}", 2, plugins)
    lines += ["## Environment variables", "", "| variable | effect |", "|---|---|",
              *(f"| `{name}` | {effect} |" for name, effect in _ENVIRONMENT), "", _BOTTOM]
    return "\n".join(lines).rstrip("\n") + "\n"
