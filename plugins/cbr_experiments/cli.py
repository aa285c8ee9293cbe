"""``cbr experiment``: list the registered experiments, or run one and write its files.

The experiment, NumPy and the task runners are imported inside the command, so that loading the
plugin at every start of ``cbr`` stays cheap.
"""

from __future__ import annotations

import enum
import json
from pathlib import Path

import typer

from cbrcore.cli.commands import output_console
from cbrcore.plugins import current


class Size(enum.StrEnum):
    """How large an experiment is run."""

    ci = "ci"
    full = "full"


def experiment_names(incomplete: str) -> list[tuple[str, str]]:
    """The registered experiments whose name starts with ``incomplete``, with their summaries:
    the shell completion of ``NAME``."""
    return [(c.name, c.summary) for c in current().registry
            if c.kind == "experiment" and c.name.startswith(incomplete)]


def experiment(
    name: str | None = typer.Argument(
        None, metavar="NAME", help="The experiment to run (see --list).",
        autocompletion=experiment_names, show_default=False),
    list_: bool = typer.Option(False, "--list", help="List the registered experiments."),
    size: Size = typer.Option(
        Size.ci, "--size",
        help="ci: small enough for a test run (minutes at most); full: the papers' scale."),
    out: Path | None = typer.Option(None, "--out", "-o", metavar="DIR",
                                    help="Output folder (default: experiments/<name>-<size>)."),
    seed: int = typer.Option(0, "--seed", min=0, metavar="SEED",
                             help="Seed of every random choice."),
    as_json: bool = typer.Option(False, "--json",
                                 help="With --list: print the experiments as one JSON object."),
    scheduler: str | None = typer.Option(
        None, "--scheduler", metavar="SCHEDULER",
        help="Run the experiment's independent tasks on Dask distributed: 'local' starts a "
             "cluster on this machine, an address (tcp://host:8786) uses a running scheduler. "
             "The results are the same as without it."),
    workers: int | None = typer.Option(
        None, "--workers", metavar="N",
        help="With --scheduler local: worker processes (default: one per core)."),
    record: Path | None = typer.Option(None, "--record", metavar="FILE", hidden=True),
) -> None:
    """Run an experiment registered by a plugin: results.json, results.md and PNG figures."""
    from rich.table import Table

    from cbr_experiments.experiment import Size as ExperimentSize
    from cbr_experiments.experiment import run_experiment
    from cbr_experiments.tasks import open_tasks
    from cbrcore.cli.compiling import announce_cold_cache, announcing_compiles
    from cbrcore.cli.progress import progress as _progress

    if record is not None:
        raise typer.BadParameter(
            "an experiment runs many runs, spread over processes, and records none; record "
            "one of its runs with 'cbr run CONFIG --record FILE.mcap'", param_hint="--record")
    registry = current().registry
    if list_:
        found = [c for c in registry if c.kind == "experiment"]
        if as_json:
            typer.echo(json.dumps({"experiments": [
                {"name": c.name, "plugin": c.plugin, "summary": c.summary} for c in found]},
                indent=2))
            return
        table = Table("experiment", "plugin", "what it reproduces")
        for component in found:
            table.add_row(component.name, component.plugin, component.summary)
        output_console().print(table)
        return
    if as_json:
        raise typer.BadParameter("--json goes with --list", param_hint="--json")
    if name is None:
        raise typer.BadParameter("name an experiment, or use --list", param_hint="NAME")
    out_dir = out if out is not None else Path("experiments") / f"{name}-{size.value}"
    sized: ExperimentSize = "ci" if size is Size.ci else "full"
    cold = announce_cold_cache()  # before the experiment's imports, which take seconds
    with announcing_compiles(announced=cold), open_tasks(scheduler, workers=workers) as tasks, \
            _progress(f"cbr experiment {name}", "steps") as progress:
        written = run_experiment(name, current(), size=sized, out_dir=out_dir, seed=seed,
                                 progress=progress, tasks=tasks)
    console = output_console()
    console.print((out_dir / "results.md").read_text(encoding="utf-8"))
    for path in written:
        console.print(f"wrote {path}")


def add_commands(app: typer.Typer) -> None:
    """Add ``cbr experiment`` to ``app``; its help lists the experiments registered now."""
    names = [c.name for c in current().registry if c.kind == "experiment"]
    # \b keeps click from rewrapping the list, which would break names at their hyphens
    listed = ("\b\nExperiments:\n" + "\n".join(f"  {name}" for name in names) if names
              else "No experiment is registered.")
    app.command(epilog=listed)(experiment)
