"""``cbr rupart``: add case files to a case base and show case files.

``cbr rupart add FILE... --store STORE`` (or ``--config CONFIG``) reads and validates every
file first (``.sexp`` or ``.yaml``, :mod:`cbr_behaviors.casefiles`), then stores all their cases
in one transaction: a bad file stores nothing and exits with code 2, its message naming the
file, the line and the item. ``cbr rupart show FILE`` prints a case file's cases in either
form. The store is named as for ``cbr casebase``; the case modules load when a command runs.
"""

from __future__ import annotations

import enum
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from cbrcore.errors import CbrError, ConfigError

if TYPE_CHECKING:
    from cbr_behaviors.cases import AnyCase
    from cbrcore.config import Config

app = typer.Typer(name="rupart", no_args_is_help=True,
                  help="RUPART's case files (004): add them to a case base, show them.")


class CaseFormat(enum.StrEnum):
    sexp = "sexp"
    yaml = "yaml"


FilesArgument = Annotated[list[Path], typer.Argument(
    metavar="FILE", show_default=False,
    help="Case files: .sexp (004's s-expressions) or .yaml.")]
StoreOption = Annotated[str | None, typer.Option(
    "--store", metavar="STORE", show_default=False,
    help="The store, written as in a configuration's casebase slot: a registered name, or a "
    "YAML mapping whose 'use' names it and whose other keys are its options, such as "
    "'{use: sqlite, path: cb.sqlite}'.")]
ConfigOption = Annotated[Path | None, typer.Option(
    "--config", "-c", metavar="CONFIG", show_default=False,
    help="A configuration file whose casebase slot names the store.")]


def _read_all(paths: list[Path]) -> list[AnyCase]:
    """The cases of every file, all files read before any is used; one error listing the
    problems of every bad file."""
    from cbr_behaviors.casefiles import read_cases
    from cbr_behaviors.cases import CaseFormatError

    cases: list[AnyCase] = []
    errors: list[str] = []
    for path in paths:
        try:
            cases += read_cases(path)
        except CaseFormatError as exc:
            errors.append(str(exc))
    if errors:
        raise CbrError("\n".join(errors))
    return cases


def _store_only(store: str | None, config: Path | None) -> tuple[Config, Path | None]:
    """A configuration holding only the case base ``--store`` or ``--config`` names, and the
    output folder to open it with: with ``--config`` the one ``cbr run`` gives the
    configuration (``runs/<name>``), where its relative case base paths lie."""
    from cbrcore.config import Config, load_config, parse_config, parse_yaml
    from cbrcore.plugins import current

    registry = current().registry
    if config is not None:
        loaded = load_config(config, registry)
        selected = Config(seed=loaded.seed, casebase=loaded.casebase, source=loaded.source)
        label, out_dir = str(config), (Path("runs") / config.stem).resolve()
    else:
        assert store is not None
        raw, _ = parse_yaml(store, "--store")
        try:
            selected = Config(casebase=parse_config({"casebase": raw}, registry).casebase)
        except ConfigError as exc:
            raise ConfigError("--store", exc.problems) from None
        label, out_dir = "--store", None
    if selected.casebase is None:
        raise CbrError(f"{label}: names no case base (its casebase slot is empty)")
    return selected, out_dir


@app.command()
def add(files: FilesArgument, store: StoreOption = None, config: ConfigOption = None) -> None:
    """Add the cases of case files to a case base, all in one transaction."""
    from cbr_behaviors.cases import KINDS
    from cbrcore.engine import Engine

    if (store is None) == (config is None):
        raise typer.BadParameter("name the case base with one of them",
                                 param_hint="--store or --config")
    # every file is read before the case base is opened: a bad one leaves it untouched
    cases = [case.to_case() for case in _read_all(files)]
    selected, out_dir = _store_only(store, config)
    with Engine(selected, out_dir=out_dir) as engine:
        casebase = engine.casebase
        assert casebase is not None
        with casebase.transaction():
            for case in cases:
                casebase.add(case)
        label, revision = str(casebase), casebase.revision
    kinds = Counter(case.kind for case in cases)
    counts = ", ".join(f"{kinds[k]} {k}" for k in KINDS if kinds[k])
    typer.echo(f"added {len(cases)} cases ({counts or 'none'}) to {label} (revision "
               f"{revision})")


@app.command()
def show(file: Annotated[Path, typer.Argument(metavar="FILE", show_default=False,
                                              help="A case file: .sexp or .yaml.")],
         fmt: Annotated[CaseFormat, typer.Option(
             "--format", help="Print the cases as s-expressions or as YAML.")
         ] = CaseFormat.sexp) -> None:
    """Print the cases of a case file (or of an exported case base) as s-expressions or YAML."""
    from cbr_behaviors.casefiles import read_cases, to_sexp, to_yaml

    cases = read_cases(file)
    typer.echo(to_sexp(cases) if fmt is CaseFormat.sexp else to_yaml(cases), nl=False)


def add_commands(app_: typer.Typer) -> None:
    """Add the ``rupart`` command group to the ``cbr`` application."""
    app_.add_typer(app)
