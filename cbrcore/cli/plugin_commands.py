"""The commands plugins add to ``cbr``, each plugin's isolated from the others'.

Each plugin's ``cbr_cli`` adds its commands to an application of its own, which is then built
(so that a declaration typer cannot turn into a command fails there, named) and whose commands
join ``cbr`` one by one. A command name goes to whoever claims it first: cbrcore's own commands,
then those of cbrcore's built-in plugins, then the others'. A plugin whose ``cbr_cli`` raises
(``SystemExit`` included; only ``KeyboardInterrupt`` goes through) adds no command at all, and a
command whose name is taken is left out while the plugin's other commands join. Either is one
:class:`~cbrcore.errors.PluginWarning` naming the plugin, its distribution and what went wrong,
and every other command works; with ``CBR_STRICT_PLUGINS=1`` it is a
:class:`~cbrcore.errors.PluginError` instead.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterator

import typer
from typer.models import CommandInfo, TyperInfo

from cbrcore.errors import PluginError, PluginWarning
from cbrcore.plugins import PluginFailure, Plugins, describe_exception

Unit = CommandInfo | TyperInfo
"""What joins ``cbr`` as a whole: a command, or a group with its commands."""

Contribution = tuple[str, list[Unit]]
"""Who adds commands (a plugin's name, or ``cbrcore``) and the commands that join ``cbr``."""


def _names(unit: Unit) -> list[str]:
    """The names ``unit`` takes in ``cbr``: a group added without a name takes its commands'."""
    if isinstance(unit, CommandInfo):
        callback = unit.callback
        return [unit.name or typer.main.get_command_name(getattr(callback, "__name__", ""))]
    name = typer.main.solve_typer_info_defaults(unit).name
    if name:
        return [name]
    if unit.typer_instance is None:
        return []
    return list(typer.main.get_group(unit.typer_instance).commands)


def _units(app: typer.Typer) -> list[Unit]:
    return [*app.registered_commands, *app.registered_groups]


def _staged(add: Callable[[typer.Typer], None]) -> typer.Typer:
    """The application ``add`` puts its commands on, built once to prove typer can build it."""
    staging = typer.Typer()
    add(staging)
    typer.main.get_group(staging)
    return staging


class _Collector:
    """Gathers the contributions, refusing a plugin's failures as the plugins' strictness says."""

    def __init__(self, plugins: Plugins) -> None:
        self.plugins = plugins
        self.taken: dict[str, str] = {}

    def fail(self, name: str, stage: str, error: str) -> None:
        info = next((p for p in self.plugins.loaded if p.name == name), None)
        source = (info.distribution, info.version) if info is not None else (None, None)
        message = PluginFailure(name, *source, stage, error).describe()
        if self.plugins.strict:
            raise PluginError(message)
        warnings.warn(message, PluginWarning, stacklevel=2)

    def owner(self, claimant: str) -> str:
        if claimant == "cbrcore":
            return "cbrcore's own command"
        info = next((p for p in self.plugins.loaded if p.name == claimant), None)
        source = f" from {info.distribution}" if info is not None and info.distribution else ""
        return f"plugin {claimant!r}{source}"

    def claim(self, claimant: str, units: list[Unit]) -> list[Unit]:
        """The units whose names are all free, each now taken by ``claimant``."""
        kept = []
        for unit in units:
            names = _names(unit)
            clash = next((n for n in names if n in self.taken), None)
            if clash is not None:
                self.fail(claimant, f"add command {clash!r}",
                          f"the name is taken by {self.owner(self.taken[clash])}")
                continue
            self.taken.update(dict.fromkeys(names, claimant))
            kept.append(unit)
        return kept

    def plugin(self, name: str) -> Contribution | None:
        """The commands plugin ``name`` adds, or None when its ``cbr_cli`` fails."""
        pm = self.plugins.pm
        others = [obj for other, obj in pm.list_name_plugin() if other != name]
        try:
            staging = _staged(lambda app: pm.subset_hook_caller(
                "cbr_cli", remove_plugins=others)(app=app))
        except KeyboardInterrupt:
            raise
        except BaseException as exc:  # a broken plugin must not take the command line down
            self.fail(name, "add its commands", describe_exception(exc))
            return None
        return name, self.claim(name, _units(staging))


def cbr_commands(plugins: Plugins, core: typer.Typer) -> Iterator[Unit]:
    """The commands of ``cbr``: those on ``core`` and those the plugins add, in the order they
    are listed (the plugins' before cbrcore's, the others' first), each name claimed once."""
    collector = _Collector(plugins)
    contributions: list[Contribution] = [("cbrcore", collector.claim("cbrcore", _units(core)))]
    # in the order pluggy would call them: the last registered first
    callers = [impl.plugin_name for impl in reversed(plugins.pm.hook.cbr_cli.get_hookimpls())]
    builtin = [name for name in callers if name in plugins.builtins]
    third_party = [name for name in callers if name not in plugins.builtins]
    for name in (*builtin, *third_party):
        if (found := collector.plugin(name)) is not None:
            contributions.append(found)
    # help lists the plugins' commands first: the third parties', the built-ins', then cbrcore's
    order = {name: rank for rank, name in enumerate([*third_party, *builtin, "cbrcore"])}
    for _, units in sorted(contributions, key=lambda c: order[c[0]]):
        yield from units
