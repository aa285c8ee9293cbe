"""``cbr casebase``: look into, check, export and import case base files."""

from __future__ import annotations

import enum
import json
from pathlib import Path
from typing import Annotated, Any

import typer

from cbrcore.casebase import (
    SQLiteStore,
    UnusableCaseBase,
    document_of,
    dump_document,
    load_document,
    read_document,
    write_document,
)

app = typer.Typer(
    name="casebase",
    help="Inspect, check, export and import case base files.",
    no_args_is_help=True,
)


class TextFormat(enum.StrEnum):
    yaml = "yaml"
    json = "json"


CaseBasePath = Annotated[Path, typer.Argument(help="The case base file (SQLite).",
                                              show_default=False)]
FormatOption = Annotated[
    TextFormat | None,
    typer.Option("--format", help="yaml or json; default: from the file's extension (export "
                 "to standard output writes yaml).", show_default=False),
]


def _facts(path: Path, store: SQLiteStore) -> dict[str, Any]:
    wal = path.with_name(path.name + "-wal")
    return {
        "path": str(path),
        "schema": store.schema_version,
        "revision": store.revision,
        "cases": store.count(),
        "kinds": store.kind_counts(),
        "size_bytes": path.stat().st_size,
        "wal_bytes": wal.stat().st_size if wal.exists() else 0,
        "journal_mode": store.journal_mode,
    }


@app.command()
def info(
    path: CaseBasePath,
    as_json: Annotated[bool, typer.Option("--json", help="Print the facts as JSON.")] = False,
) -> None:
    """Show a case base's schema version, revision, case counts by kind and file details."""
    with SQLiteStore(path, create=False) as store:
        facts = _facts(path, store)
    if as_json:
        typer.echo(json.dumps(facts, indent=2))
        return
    lines = [
        f"case base     {facts['path']}",
        f"schema        {facts['schema']}",
        f"revision      {facts['revision']}",
        f"cases         {facts['cases']}",
        *(f"  {kind:<11} {n}" for kind, n in facts["kinds"].items()),
        f"size          {facts['size_bytes']} bytes (+ {facts['wal_bytes']} bytes write-ahead log)",
        f"journal mode  {facts['journal_mode']}",
    ]
    typer.echo("\n".join(lines))


@app.command()
def check(path: CaseBasePath) -> None:
    """Check a case base file thoroughly.

    Prints "ok" and exits 0 when it is sound; lists the problems and exits 1 when it is not (or
    is corrupt, not a case base, or of another schema version); exits 2 when it does not exist.
    """
    try:
        store = SQLiteStore(path, create=False)
    except UnusableCaseBase as exc:
        typer.echo(str(exc))
        raise typer.Exit(code=1) from exc
    with store:
        problems = store.check()
    if problems:
        noun = "problem" if len(problems) == 1 else "problems"
        typer.echo("\n".join([f"{path}: {len(problems)} {noun}:", *(f"  - {p}" for p in problems)]))
        raise typer.Exit(code=1)
    typer.echo("ok")


@app.command("export")
def export(
    path: CaseBasePath,
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="File to write; default: standard output.", show_default=False,
    )] = None,
    fmt: FormatOption = None,
) -> None:
    """Write a case base as YAML or JSON text (YAML on standard output unless told)."""
    with SQLiteStore(path, create=False) as store:
        document = document_of(store)
    chosen = fmt.value if fmt is not None else None
    if output is None:
        typer.echo(dump_document(document, chosen or "yaml"), nl=False)
        return
    write_document(document, output, chosen)
    typer.echo(f"exported {len(document.cases)} cases (revision {document.revision}) "
               f"to {output}")


@app.command("import")
def import_(
    path: CaseBasePath,
    file: Annotated[Path, typer.Argument(help="The exported YAML or JSON file.",
                                         show_default=False)],
    append: Annotated[bool, typer.Option(
        "--append", help="Add the cases, with new ids, to a case base that already has some.",
    )] = False,
    fmt: FormatOption = None,
) -> None:
    """Load an exported file into a case base (created when missing), all in one transaction.

    A case base that already holds cases is refused unless --append is given.
    """
    # read and validate first, so that a bad file does not leave an empty case base behind
    document = read_document(file, fmt.value if fmt is not None else None)
    with SQLiteStore(path) as store:
        added = load_document(store, document, append=append)
        revision = store.revision
    typer.echo(f"imported {added} cases into {path} (revision {revision})")
