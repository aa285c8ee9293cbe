"""The built-in ``cbr`` commands: run, validate, plugins, experiment, reference."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from cbrcore.config import load_config
from cbrcore.engine import Engine
from cbrcore.experiment import Size, run_experiment
from cbrcore.plugins import current
from cbrcore.reference import config_reference, hook_reference
from cbrcore.run import run_workload

_SET_HELP = "Override a configuration value: KEY.PATH=VALUE (VALUE is read as YAML). Repeatable."


def _out() -> Console:
    return Console(highlight=False, soft_wrap=True)


@contextmanager
def _progress(label: str) -> Iterator[Callable[[int, int], None]]:
    console = Console(stderr=True)
    bar = Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                   console=console, transient=True, disable=not console.is_terminal)
    task = bar.add_task(label, total=None)
    with bar:
        yield lambda done, total: bar.update(task, completed=done, total=total)


def run(
    config: Path = typer.Argument(..., help="The YAML configuration to run."),
    out: Path | None = typer.Option(
        None, "--out", "-o",
        help="Output folder (default: runs/<config name>; a run into a folder that holds a "
             "case base continues from it)."),
    set_: list[str] = typer.Option([], "--set", "-s", help=_SET_HELP),
) -> None:
    """Run the configured workload: results.csv, summary.json and manifest.json go to --out."""
    out_dir = out if out is not None else Path("runs") / config.stem
    with Engine.from_yaml(config, overrides=set_, out_dir=out_dir.resolve()) as engine, \
            _progress("queries") as progress:
        summary = run_workload(engine, out_dir, overrides=set_, progress=progress)
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
    rows += [(f"median {phase} ms", f"{ms:.3f}") for phase, ms in summary["median_ms"].items()]
    rows += [(name, f"{value:.4g}") for name, value in summary["metric_means"].items()]
    rows += [("wall time s", f"{summary['seconds']:.2f}"), ("output", str(out_dir))]
    for key, value in rows:
        table.add_row(key, str(value))
    _out().print(table)
    _out().print(_evolution_table(summary["evolution"]))


def _evolution_table(stretches: list[dict[str, Any]]) -> Table:
    """The run's evolution: one row per stretch of queries."""
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
    config: Path = typer.Argument(..., help="The YAML configuration to check."),
    set_: list[str] = typer.Option([], "--set", "-s", help=_SET_HELP),
) -> None:
    """Check a configuration without running it; list the components it selects."""
    checked = load_config(config, current().registry, set_)
    console = _out()
    console.print(f"{config}: ok")
    for slot, value in checked.resolved().items():
        if slot == "seed":
            console.print(f"  seed: {value}")
        else:
            items = value if isinstance(value, list) else [value]
            console.print(f"  {slot}: {', '.join(item['use'] for item in items)}")


def plugins(
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object."),
) -> None:
    """List the loaded plugins, their distributions, hooks, components and the component kinds
    they declare, and any failures."""
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
    console = _out()
    console.print(table)
    for failure in loaded.failed:
        console.print(f"[red]failed[/red]: {failure.describe()}", markup=True)
    if loaded.skipped:
        console.print(f"skipped by CBR_PLUGINS / CBR_DISABLE_PLUGINS: {', '.join(loaded.skipped)}")


def experiment(
    name: str | None = typer.Argument(None, help="The experiment to run."),
    list_: bool = typer.Option(False, "--list", help="List the registered experiments."),
    size: str = typer.Option("full", "--size", help="ci (minutes) or full (the paper's scale)."),
    out: Path | None = typer.Option(None, "--out", "-o",
                                    help="Output folder (default: experiments/<name>-<size>)."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of every random choice."),
) -> None:
    """Run an experiment registered by a plugin: results.json, results.md and PNG figures."""
    registry = current().registry
    if list_:
        table = Table("experiment", "plugin", "what it reproduces")
        for component in registry:
            if component.kind == "experiment":
                table.add_row(component.name, component.plugin, component.summary)
        _out().print(table)
        return
    if name is None:
        raise typer.BadParameter("name an experiment, or use --list", param_hint="NAME")
    if size not in ("ci", "full"):
        raise typer.BadParameter(f"expected ci or full, got {size!r}", param_hint="--size")
    out_dir = out if out is not None else Path("experiments") / f"{name}-{size}"
    sized: Size = "ci" if size == "ci" else "full"
    with _progress(name) as progress:
        written = run_experiment(name, current(), size=sized, out_dir=out_dir, seed=seed,
                                 progress=progress)
    console = _out()
    console.print((out_dir / "results.md").read_text(encoding="utf-8"), markup=False)
    for path in written:
        console.print(f"wrote {path}")


def reference(
    what: str = typer.Argument(..., help="config or hooks"),
) -> None:
    """Print the configuration or hook reference as markdown."""
    if what == "config":
        typer.echo(config_reference(current().registry), nl=False)
    elif what == "hooks":
        typer.echo(hook_reference(), nl=False)
    else:
        raise typer.BadParameter(f"expected config or hooks, got {what!r}", param_hint="WHAT")


def install(app: typer.Typer) -> None:
    """Add the built-in commands to ``app``."""
    for command in (run, validate, plugins, experiment, reference):
        app.command()(command)

