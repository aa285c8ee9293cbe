"""``cbr casebase``: look into, check, export and import case bases of any registered store.

The commands import the stores, the configuration machinery and the engine when they run, so
that every other command, ``cbr --help`` included, does not.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import attrs
import typer

from cbrcore.errors import CaseBaseError, CbrError, ConfigError
from cbrcore.plugins import current

if TYPE_CHECKING:
    from cbrcore.casebase import CaseStore
    from cbrcore.casebase.formats import DocumentFormat
    from cbrcore.casebase.store import StoreFile
    from cbrcore.config import Config

app = typer.Typer(
    name="casebase",
    help="Inspect, check, export and import case bases: a SQLite file, or any registered store.",
    no_args_is_help=True,
)


_SELECTORS = "FILE, --store or --config"

CaseBaseFile = Annotated[Path | None, typer.Argument(
    metavar="FILE", help="A SQLite case base file; short for --store '{use: sqlite, path: FILE}'.",
    show_default=False)]
StoreOption = Annotated[str | None, typer.Option(
    "--store", metavar="STORE",
    help="The store, written as in a configuration's casebase slot: a registered name, or a "
         "YAML mapping whose 'use' names it and whose other keys are its options, such as "
         "'{use: sqlite, path: cb.sqlite}'. Relative paths resolve against the working folder.",
    show_default=False)]
ConfigOption = Annotated[Path | None, typer.Option(
    "--config", "-c", metavar="CONFIG",
    help="A configuration file whose casebase slot names the store; relative paths resolve "
         "against its folder.", show_default=False)]
FormatOption = Annotated[str | None, typer.Option(
    "--format", metavar="FORMAT",
    help="yaml, json or a format a plugin offers, such as nav2-route (cbr casebase formats "
         "lists them); default: from the file's extension (export to standard output writes "
         "yaml).", show_default=False)]
WorldOption = Annotated[str | None, typer.Option(
    "--world", metavar="WORLD",
    help="The world the cases belong to, for a format that needs it (nav2-route: a map with a "
         "metric frame), written as in a configuration's world slot, such as "
         "'{use: map_file, path: depot.yaml}'; default: the world of --config. Relative paths "
         "resolve against the working folder.", show_default=False)]


def _casebase_slot(file: Path | None, store: str | None, config: Path | None, *,
                   reading: bool) -> Config:
    """A configuration holding only the case base that ``FILE``, --store or --config names.

    For a command that only reads (``reading``), a store that can open its case base read-only
    (SQLite, PostgreSQL) does: that never creates a file or a schema, works in a folder the user
    may not write, and for a database role that may only read.
    """
    from cbrcore.casebase.store import capabilities
    from cbrcore.config import Config, load_config, parse_config, parse_yaml

    given = [name for name, value in (("FILE", file), ("--store", store), ("--config", config))
             if value is not None]
    if len(given) != 1:
        found = f", not {' and '.join(given)}" if given else ""
        raise typer.BadParameter(f"name the case base with one of them{found}",
                                 param_hint=_SELECTORS)
    registry = current().registry
    if config is not None:
        loaded = load_config(config, registry)
        casebase = loaded.casebase
        file = None if casebase is None else capabilities(casebase.options).file
        if file is not None and not (casebase.options.path
                                     and casebase.options.path.is_absolute()):
            # the file a run of the configuration keeps in its default output folder, as
            # cbr run does: a relative path names a file inside that folder
            inside = casebase.options.path or Path(file.default_name)
            path = (Path("runs") / config.stem / inside).resolve()
            casebase = attrs.evolve(casebase, options=attrs.evolve(casebase.options, path=path))
        label, selected = str(loaded.source), Config(seed=loaded.seed, casebase=casebase,
                                                     source=loaded.source)
    else:
        if store is not None:
            label, (raw, _) = "--store", parse_yaml(store, "--store")
        else:
            # the file as named on the command line, wherever it is
            label, raw = str(file), {"use": "sqlite", "path": str(file.resolve())}
        try:
            selected = Config(casebase=parse_config({"casebase": raw}, registry).casebase)
        except ConfigError as exc:
            raise ConfigError(label, exc.problems) from None
    if selected.casebase is None:
        raise CbrError(f"{label}: names no case base (its casebase slot is empty)")
    if reading and capabilities(selected.casebase.options).read_only:
        selected = _with_store_options(selected, read_only=True)
    return selected


def _with_store_options(selected: Config, **changes: Any) -> Config:
    assert selected.casebase is not None
    options = attrs.evolve(selected.casebase.options, **changes)
    return attrs.evolve(selected, casebase=attrs.evolve(selected.casebase, options=options))


def _world_for(fmt: DocumentFormat, world: str | None, config: Path | None) -> Any:
    """The world ``--world`` or the configuration names, built as a run builds it, when ``fmt``
    needs one; None when it does not."""
    from cbrcore.config import Config, load_config, parse_config, parse_yaml
    from cbrcore.engine import Engine

    if not fmt.world:
        if world is not None:
            raise typer.BadParameter(f"the {fmt.name} format needs no world", param_hint="--world")
        return None
    registry = current().registry
    if world is not None:
        raw, _ = parse_yaml(world, "--world")
        try:
            selected = Config(world=parse_config({"world": raw}, registry).world)
        except ConfigError as exc:
            raise ConfigError("--world", exc.problems) from None
    elif config is not None:
        loaded = load_config(config, registry)
        selected = Config(seed=loaded.seed, world=loaded.world, source=loaded.source)
    else:
        selected = Config()
    if selected.world is None:
        where = "" if config is None else f" ({config} has none)"
        raise typer.BadParameter(f"the {fmt.name} format needs the world the cases belong to "
                                 f"({fmt.world}); name it with --world or with a --config whose "
                                 f"world slot names it{where}", param_hint="--world")
    with Engine(selected) as engine:
        return engine.world


@contextlib.contextmanager
def _opened(selected: Config) -> Iterator[tuple[str, CaseStore]]:
    """The case base ``selected`` configures and its store's registered name, closed after the
    block.

    It is opened by an engine configured with it alone, so the store is built exactly as a run
    builds it.
    """
    from cbrcore.engine import Engine

    with Engine(selected) as engine:
        assert selected.casebase is not None and engine.casebase is not None
        yield selected.casebase.name, engine.casebase


def _shown(value: Any) -> str:
    return value if isinstance(value, str) else json.dumps(value)


@app.command()
def info(
    file: CaseBaseFile = None,
    store: StoreOption = None,
    config: ConfigOption = None,
    as_json: Annotated[bool, typer.Option("--json", help=(
        "Print the facts as JSON: store (its registered name), revision, cases, kinds, worlds, "
        "then the store's own (for a SQLite file path, schema, size_bytes, wal_bytes and "
        "journal_mode)."))] = False,
) -> None:
    """Show a case base's store, revision, case counts by kind, the worlds its cases belong to,
    and what its store tells of it (for a SQLite file: path, schema version, sizes and journal
    mode)."""
    from cbrcore.casebase import describe
    from cbrcore.casebase.worlds import recorded_worlds

    with _opened(_casebase_slot(file, store, config, reading=True)) as (name, casebase):
        worlds, _ = recorded_worlds(casebase)
        facts: dict[str, Any] = {"store": name, "revision": casebase.revision,
                                 "cases": casebase.count(), "kinds": casebase.kind_counts(),
                                 "worlds": [world.to_data() for world in worlds],
                                 **describe(casebase)}
    if as_json:
        typer.echo(json.dumps(facts, indent=2))
        return
    kinds = facts.pop("kinds")
    facts.pop("worlds")
    lines = []
    for key, value in facts.items():
        lines.append(f"{key.replace('_', ' '):<13} {_shown(value)}")
        if key == "cases":
            lines += [f"  {kind:<11} {n}" for kind, n in kinds.items()]
            lines += [f"{'world':<13} {world.description} ({world.sha256})" for world in worlds]
            if not worlds:
                lines.append(f"{'world':<13} none recorded")
    typer.echo("\n".join(lines))


@app.command()
def check(
    file: CaseBaseFile = None,
    store: StoreOption = None,
    config: ConfigOption = None,
    as_json: Annotated[bool, typer.Option(
        "--json", help='Print the verdict as JSON: {"casebase", "ok", "problems"}.')] = False,
) -> None:
    """Check a case base thoroughly: its store's own check, then the invariants of every loaded
    plugin's cases (a case graph's segments meet only at vertices, ...).

    Prints "ok" and exits 0 when it is sound; lists the problems and exits 1 when it is not (or
    its store finds it unusable: corrupt, not a case base, or of another schema version); exits 2
    when it does not exist. With --json the exit codes are the same.
    """
    from cbrcore.casebase import UnusableCaseBase
    from cbrcore.casebase.worlds import world_problems

    label: str | None = None
    try:
        with _opened(_casebase_slot(file, store, config, reading=True)) as (_, casebase):
            problems = casebase.check()
            if not problems:  # the families read the cases the store vouched for
                problems = [f"worlds: {p}" for p in world_problems(casebase)]
                problems += family_problems(casebase)
            label = str(casebase)
    except UnusableCaseBase as exc:
        # the store refused to open it, so there is no case base to name but the message's
        problems = [str(exc)]
    if as_json:
        typer.echo(json.dumps({"casebase": label, "ok": not problems, "problems": problems},
                              indent=2))
    elif label is None:
        typer.echo(problems[0])
    elif problems:
        noun = "problem" if len(problems) == 1 else "problems"
        typer.echo("\n".join([f"{label}: {len(problems)} {noun}:",
                              *(f"  - {p}" for p in problems)]))
    else:
        typer.echo("ok")
    if problems:
        raise typer.Exit(code=1)


def family_problems(casebase: CaseStore) -> list[str]:
    """The broken invariants every loaded plugin finds among its cases (``cbr_check_casebase``),
    each named with the plugin; a check that fails is a problem too."""
    plugins = current()
    problems = []
    for impl in reversed(plugins.pm.hook.cbr_check_casebase.get_hookimpls()):
        try:
            # an implementation declares just the arguments it uses, as pluggy calls it
            arguments = {"casebase": casebase}
            found = impl.function(**{name: arguments[name] for name in impl.argnames}) or []
        except CbrError as exc:
            found = [f"the check failed: {exc}"]
        problems += [f"{impl.plugin_name}: {problem}" for problem in found]
    return problems


@app.command("export")
def export(
    file: CaseBaseFile = None,
    store: StoreOption = None,
    config: ConfigOption = None,
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", metavar="FILE", help="File to write; default: standard output.",
        show_default=False,
    )] = None,
    fmt: FormatOption = None,
    world: WorldOption = None,
) -> None:
    """Write a case base as YAML or JSON text (YAML on standard output unless told), or in a
    format a plugin offers (a case graph as a Nav2 route graph: --format nav2-route)."""
    from cbrcore.casebase import document_of
    from cbrcore.casebase.formats import format_for, write_casebase

    selected = _casebase_slot(file, store, config, reading=True)
    chosen = format_for(output, fmt) if output is not None else format_for("", fmt or "yaml")
    on_world = _world_for(chosen, world, config)
    with _opened(selected) as (_, casebase):
        document = document_of(casebase)
    if output is None:
        typer.echo(chosen.dump(document, on_world), nl=False)
        return
    _refuse_the_case_base_itself(selected, output)
    write_casebase(document, output, chosen.name, world=on_world)
    typer.echo(f"exported {len(document.cases)} cases (revision {document.revision}) "
               f"to {output}")


@app.command("import")
def import_(
    file: Annotated[Path | None, typer.Argument(
        metavar="FILE", help="The SQLite case base file, created when missing (give the store "
        "with --store or --config instead, and DOCUMENT alone).", show_default=False)] = None,
    document: Annotated[Path | None, typer.Argument(
        metavar="DOCUMENT", help="The exported file (required): YAML, JSON, or a format a plugin "
        "offers (a Nav2 route graph, .geojson).", show_default=False)] = None,
    store: StoreOption = None,
    config: ConfigOption = None,
    append: Annotated[bool, typer.Option(
        "--append", help="Add the cases, with new ids, to a case base that already has some.",
    )] = False,
    fmt: FormatOption = None,
    world: WorldOption = None,
) -> None:
    """Load an exported document into a case base, all in one transaction.

    A case base that already holds cases is refused unless --append is given. A Nav2 route
    graph (--format nav2-route, or a .geojson file) seeds a case graph on the map of --world or
    --config.
    """
    from cbrcore.casebase import load_document
    from cbrcore.casebase.formats import format_for, read_casebase
    from cbrcore.casebase.worlds import store_policy

    if document is None:  # one argument is the document
        file, document = None, file
    if document is None:
        raise typer.BadParameter("name the exported file to import", param_hint="DOCUMENT")
    chosen = format_for(document, fmt)
    if append and not chosen.append:
        raise typer.BadParameter(f"a {chosen.name} document is a whole case base; it is "
                                 "imported into an empty one, not appended", param_hint="--append")
    # read and validate first, so that a bad document does not leave an empty case base behind
    loaded = read_casebase(document, chosen.name, world=_world_for(chosen, world, config))
    selected = _casebase_slot(file, store, config, reading=False)
    assert selected.casebase is not None
    worlds = store_policy(selected.casebase.options)
    new_file = _new_case_base_file(selected)
    if new_file is None:
        with _opened(selected) as (_, casebase):
            added = load_document(casebase, loaded, append=append, worlds=worlds)
            revision = casebase.revision
            label = str(casebase)
    else:
        # a new case base is made beside its place and moved there once it is complete: a
        # failed import leaves no file, and no other process sees the case base half imported
        target, file = new_file
        partial = target.with_name(f".{target.name}.{secrets.token_hex(8)}.partial")
        try:
            with _opened(_with_store_options(selected, path=partial, create=True)) as (
                    _, casebase):
                added = load_document(casebase, loaded, append=append, worlds=worlds)
                revision = casebase.revision
            _move_into_place(partial, target)
        except CaseBaseError as exc:
            # the user knows the case base by the name it is to have
            raise type(exc)(str(exc).replace(str(partial), str(target))) from exc
        finally:
            for leftover in file.files(partial):
                with contextlib.suppress(FileNotFoundError):
                    leftover.unlink()
        label = str(target)
    typer.echo(f"imported {added} cases into {label} (revision {revision})")


def _new_case_base_file(selected: Config) -> tuple[Path, StoreFile] | None:
    """The case base file that an import would create, and how its store keeps it; None for a
    store that keeps no file, or a file that exists."""
    from cbrcore.casebase.store import capabilities

    casebase = selected.casebase
    file = None if casebase is None else capabilities(casebase.options).file
    if (file is None or casebase is None or casebase.options.path is None
            or not casebase.options.create):  # the store refuses to create it, and says so
        return None
    # the file a link names is the case base; the link stays
    path = Path(os.path.realpath(casebase.options.path))
    try:
        found = path.stat()
    except OSError:
        return path, file
    if not stat.S_ISREG(found.st_mode):
        raise CaseBaseError(f"{path} is not a regular file, so it cannot hold a case base")
    # an empty file is what a process killed while creating a case base leaves behind
    return None if found.st_size else (path, file)


def _refuse_the_case_base_itself(selected: Config, output: Path) -> None:
    """Refuse an export over the case base file it reads (or a link to it), which the document
    would replace: the case base would be lost."""
    from cbrcore.casebase.store import capabilities

    casebase = selected.casebase
    if (casebase is None or capabilities(casebase.options).file is None
            or casebase.options.path is None):
        return
    with contextlib.suppress(OSError):  # an output that does not exist yet is another file
        if os.path.samefile(output, casebase.options.path):
            raise CaseBaseError(f"cannot write {output}: it is the case base being exported; "
                                f"expected another file (.yaml, .yml or .json)")


@app.command("formats")
def formats() -> None:
    """List the formats a case base is exported to and imported from: cbrcore's own and those
    the loaded plugins offer, with their file extensions and what each needs."""
    from cbrcore.casebase.formats import document_formats

    for name, offered in document_formats().items():
        fmt = offered.format
        needs = f"; needs {fmt.world}" if fmt.world else ""
        typer.echo(f"{name:<11} {' '.join(fmt.suffixes):<12} {offered.plugin:<15} "
                   f"{fmt.summary}{needs}")


def _move_into_place(partial: Path, target: Path) -> None:
    """Give the complete case base ``partial`` the name ``target``, unless a case base appeared
    there meanwhile."""
    try:
        try:
            os.link(partial, target)  # fails rather than replace a file created meanwhile
            return
        except FileExistsError:
            if target.stat().st_size:
                raise CaseBaseError(f"{target} was created by another process during the "
                                    f"import; the import was not applied") from None
        except OSError:
            pass  # a file system without hard links
        with contextlib.suppress(FileNotFoundError):
            # the empty file left in its place keeps its permissions
            os.chmod(partial, stat.S_IMODE(target.stat().st_mode))
        os.replace(partial, target)
    except OSError as exc:
        raise CaseBaseError(f"cannot create case base {target}: {exc.strerror or exc}") from exc
