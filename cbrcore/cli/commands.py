"""The built-in ``cbr`` commands: run, validate, plugins, reference.

Tables fit the terminal they are shown in; written to a pipe or a file they keep every cell
whole, however wide (``--json`` gives the same facts for programs).

Each command imports what it runs with when it runs: ``cbr --help`` and every other command
would otherwise import the engine, the configuration machinery and rich's tables.
"""

from __future__ import annotations

import enum
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from cbrcore.cli import completion
from cbrcore.plugins import current

if TYPE_CHECKING:
    from rich.console import Console
    from rich.table import Table

UNBOUNDED = 100_000
"""The width of output that is not a terminal: wide enough that no table is wrapped or cut."""

_SET_HELP = ("Override a configuration value (VALUE is read as YAML); repeatable. A problem in "
             "the value is reported against this option.")


class Reference(enum.StrEnum):
    """The references ``cbr reference`` prints."""

    config = "config"
    hooks = "hooks"
    cli = "cli"


def output_console() -> Console:
    """The console a command prints its tables on: the terminal's width, or unbounded."""
    from rich.console import Console

    # cells and lines hold users' and plugins' text (kinds, names, errors): rich would read
    # ``[x]`` as markup and ``:x:`` as an emoji, so neither is interpreted
    console = Console(highlight=False, soft_wrap=True, markup=False, emoji=False)
    if not console.is_terminal:  # a pipe or a file: the reader, not a window, sets the width
        console.width = UNBOUNDED
    return console


def _set_option() -> Any:
    return typer.Option([], "--set", "-s", metavar="KEY.PATH=VALUE", help=_SET_HELP,
                        autocompletion=completion.settings)


def _json_option(what: str) -> Any:
    return typer.Option(False, "--json", help=f"Print {what} as one JSON object.")


def run(
    config: Path = typer.Argument(..., metavar="CONFIG", help="The YAML configuration to run."),
    out: Path | None = typer.Option(
        None, "--out", "-o", metavar="DIR",
        help="Output folder (default: runs/<config name>). A folder holding an earlier run "
             "of the same configuration is continued: its case base keeps its cases and "
             "results.csv grows; one holding another configuration's results is refused."),
    fresh: bool = typer.Option(
        False, "--fresh",
        help="Start afresh: remove the output folder's results.csv, summary.json, "
             "manifest.json and its SQLite case base (saying so first) before running."),
    set_: list[str] = _set_option(),
    record: Path | None = typer.Option(
        None, "--record", metavar="FILE",
        help="Record the run as MCAP with ROS 2 message types, for Foxglove and ros2 bag play "
             "(the 'record' observer of the recording plugin)."),
    force: bool = typer.Option(False, "--force",
                               help="With --record: replace the recording file if it exists."),
    as_json: bool = _json_option("the run's summary (that of summary.json)"),
) -> None:
    """Run the configured workload: results.csv, summary.json and manifest.json go to --out."""
    from cbrcore.cli.compiling import announce_cold_cache, announcing_compiles

    cold = announce_cold_cache()  # before the components' imports, which take seconds

    from rich.table import Table

    from cbrcore.cli.progress import progress as _progress
    from cbrcore.config import load_config
    from cbrcore.engine import Engine
    from cbrcore.run import run_workload
    from cbrcore.run_folder import check_continuable, earlier_results, fresh_files, remove

    if force and record is None:
        raise typer.BadParameter("--force goes with --record", param_hint="--force")
    out_dir = out if out is not None else Path("runs") / config.stem
    # an absolute file, so that the recording is checked with the configuration, before
    # anything of the run is touched
    observers = ([] if record is None else
                 [{"use": "record", "file": str(record.resolve()), "force": force}])
    checked = load_config(config, current().registry, set_, observers)
    # settled before the engine opens the folder's case base: a refused run changes nothing
    if fresh:
        doomed = fresh_files(out_dir, checked)
        if doomed:
            typer.echo(f"cbr run: --fresh: removing {', '.join(p.name for p in doomed)} "
                       f"from {out_dir}", err=True)
            remove(doomed)
    else:
        check_continuable(out_dir, checked)
        earlier_results(out_dir)
    with announcing_compiles(announced=cold), \
            Engine(checked, out_dir=out_dir.resolve()) as engine:
        cases = len(engine.casebase) if engine.casebase is not None else 0
        if cases or (out_dir / "results.csv").is_file():
            typer.echo(f"cbr run: continuing from {cases} cases in {out_dir}", err=True)
        with _progress("cbr run", "queries") as progress:
            summary = run_workload(engine, out_dir, overrides=set_, progress=progress)
    if as_json:
        typer.echo(json.dumps(summary, indent=2, default=str))
        return
    table = Table(title=f"{config.name}: {summary['queries']} queries", show_header=False)
    rows: list[tuple[str, Any]] = [
        ("answered by the case base", summary["from_casebase"]),
        ("answered by the fallback solver", summary["from_solver"]),
        ("unsolved", summary["unsolved"]),
        ("CBR share", f"{summary['cbr_share']:.1%}"),
        ("success rate", f"{summary['success_rate']:.1%}"),
    ]
    if summary["mean_outcome_cost"] is not None:
        rows.append(("mean outcome cost", f"{summary['mean_outcome_cost']:.4g}"))
    if summary["learn_skipped"]:
        # another process held the case base's write lock longer than the store waits
        rows += [("learn steps skipped (locked)", summary["learn_skipped"]),
                 ("  still not learned", summary["learn_pending"])]
    rows += [(f"median {phase} ms", f"{ms:.3f}") for phase, ms in summary["median_ms"].items()]
    rows += [(name, f"{value:.4g}") for name, value in summary["metric_means"].items()]
    if summary["earlier_queries"]:
        rows.append(("continued", f"from {summary['cases_at_start']} cases; queries from "
                                  f"{summary['first_query']}, after {summary['earlier_queries']} "
                                  "in results.csv"))
    rows += [("wall time s", f"{summary['seconds']:.2f}"), ("output", str(out_dir))]
    for key, value in rows:
        table.add_row(key, str(value))
    console = output_console()
    console.print(table)
    console.print(_evolution_table(summary["evolution"]))


def _evolution_table(stretches: list[dict[str, Any]]) -> Table:
    """The run's evolution: one row per stretch of queries."""
    from rich.table import Table

    table = Table(title="as the run went on")
    metrics = [key for key in (stretches[0] if stretches else {})
               if key not in ("first", "last", "cbr_share", "median_plan_ms")]
    for column in ("queries", "CBR share", "median plan ms", *metrics):
        table.add_column(column, justify="right")
    for entry in stretches:
        table.add_row(f"{entry['first']}-{entry['last']}", f"{entry['cbr_share']:.1%}",
                      f"{entry['median_plan_ms']:.3f}",
                      *("" if entry[key] is None else f"{entry[key]:.4g}" for key in metrics))
    return table


def validate(
    config: Path = typer.Argument(..., metavar="CONFIG",
                                  help="The YAML configuration to check."),
    set_: list[str] = _set_option(),
    as_json: bool = _json_option(
        '{"config": CONFIG, "resolved": {...}}, every slot\'s component with all its options, '
        "defaults filled in, as a run's manifest.json records them,"),
) -> None:
    """Check a configuration without running it; list the components it selects."""
    from cbrcore.config import load_config

    checked = load_config(config, current().registry, set_)
    if as_json:
        typer.echo(json.dumps({"config": str(config), "resolved": checked.resolved()},
                              indent=2, default=str))
        return
    console = output_console()
    console.print(f"{config}: ok")
    for slot, value in checked.resolved().items():
        if slot == "seed":
            console.print(f"  seed: {value}")
        else:
            items = value if isinstance(value, list) else [value]
            console.print(f"  {slot}: {', '.join(item['use'] for item in items)}")


def plugins(
    as_json: bool = _json_option(
        "the plugins (keys plugins, each with name, module, distribution, version, hooks, "
        "components and kinds; failed, each with name, distribution, version, stage and error; "
        "and skipped)"),
) -> None:
    """List the loaded plugins, their distributions, hooks, components and the component kinds
    they declare, and any failures."""
    from rich.table import Table
    from rich.text import Text

    loaded = current()
    if as_json:
        data = {
            "plugins": [{"name": p.name, "module": p.module, "distribution": p.distribution,
                         "version": p.version, "hooks": list(p.hooks),
                         "components": list(p.components), "kinds": list(p.kinds)}
                        for p in loaded.loaded],
            "failed": [{"name": f.name, "distribution": f.distribution, "version": f.version,
                        "stage": f.stage, "error": f.error} for f in loaded.failed],
            "skipped": loaded.skipped,
        }
        typer.echo(json.dumps(data, indent=2))
        return
    table = Table("plugin", "distribution", "hooks", "components", "kinds")
    kinds = loaded.registry.kinds
    for p in loaded.loaded:
        source = f"{p.distribution} {p.version}" if p.distribution else "(registered in code)"
        declared = [f"{kind.name} (slot {kind.slot.name})" if kind.slot else kind.name
                    for kind in (kinds[name] for name in p.kinds)]
        table.add_row(p.name, source, "\n".join(p.hooks), "\n".join(p.components),
                      "\n".join(declared))
    console = output_console()
    console.print(table)
    for failure in loaded.failed:
        console.print(Text.assemble(("failed", "red"), f": {failure.describe()}"))
    if loaded.skipped:
        console.print(f"skipped by CBR_PLUGINS / CBR_DISABLE_PLUGINS: {', '.join(loaded.skipped)}")


def reference(
    ctx: typer.Context,
    what: Reference = typer.Argument(
        ..., metavar="WHAT", show_default=False,
        help="config: every component and its options; hooks: the hook specifications; "
             "cli: every command with its arguments and options."),
) -> None:
    """Print the configuration, hook or command-line reference as markdown."""
    from cbrcore.cli.reference import cli_reference
    from cbrcore.reference import config_reference, hook_reference

    if what is Reference.config:
        typer.echo(config_reference(current().registry), nl=False)
    elif what is Reference.hooks:
        typer.echo(hook_reference(), nl=False)
    else:  # the command tree this very command belongs to, plugins' commands included
        typer.echo(cli_reference(ctx.find_root().command, current()), nl=False)


def install(app: typer.Typer) -> None:
    """Add the built-in commands to ``app``."""
    for command in (run, validate, plugins, reference):
        app.command()(command)
