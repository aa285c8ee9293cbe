"""``cbr rupart``: add case files to a case base, show case files, draw a delivery day.

``cbr rupart add FILE... --store STORE`` (or ``--config CONFIG``) reads and validates every
file first (``.sexp`` or ``.yaml``, :mod:`cbr_behaviors.casefiles`), then stores all their cases
in one transaction: a bad file stores nothing and exits with code 2, its message naming the
file, the line and the item. ``cbr rupart show FILE`` prints a case file's cases in either
form. The store is named as for ``cbr casebase``; the case modules load when a command runs.

``cbr rupart day RUN_DIR`` draws a day of a ``delivery`` run made with ``workload.log: true``
(:mod:`cbr_behaviors.dayplot`): it rebuilds the run's world from the configuration its
``manifest.json`` records, through the registry as the engine builds it (:func:`run_world`),
and reads the day's log ``day_N.npz``.
"""

from __future__ import annotations

import enum
import json
import math
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from cbrcore.errors import CbrError, ConfigError

if TYPE_CHECKING:
    from cbr_behaviors.casetypes import AnyCase
    from cbr_world2d.world import World
    from cbrcore.config import Config

app = typer.Typer(name="rupart", no_args_is_help=True,
                  help="RUPART's case files (004): add them to a case base, show them; draw "
                  "a day of a delivery run.")


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
    from cbr_behaviors.casetypes import CaseFormatError

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
    from cbr_behaviors.casetypes import KINDS
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
         ] = CaseFormat.sexp,
         as_json: Annotated[bool, typer.Option(
             "--json", help="Print the cases as one JSON object, {\"cases\": [...]}, each as "
             "its entry of a YAML case file (instead of --format).")] = False) -> None:
    """Print the cases of a case file (or of an exported case base) as s-expressions or YAML."""
    from cbr_behaviors.casefiles import read_cases, to_entries, to_sexp, to_yaml

    cases = read_cases(file)
    if as_json:
        typer.echo(json.dumps({"cases": to_entries(cases)}))
        return
    typer.echo(to_sexp(cases) if fmt is CaseFormat.sexp else to_yaml(cases), nl=False)


DELIVERY = "delivery"
"""The workload whose runs record days."""


def _manifest(run_dir: Path) -> dict[str, Any]:
    """The configuration ``cbr run`` recorded in ``run_dir``, checked to be a delivery run's."""
    if not run_dir.is_dir():
        raise CbrError(f"{run_dir}: no such run folder; expected the output folder of "
                       f"'cbr run' with the {DELIVERY} workload")
    from cbrcore.documents import DocumentError, found, load_json, read_text

    path = run_dir / "manifest.json"
    try:
        manifest = load_json(read_text(path), str(path))
    except FileNotFoundError:
        raise CbrError(f"{path}: no such file; expected the manifest 'cbr run' writes into a "
                       f"run folder") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, DocumentError) as exc:
        raise CbrError(f"{path}: not a run's manifest ({exc}); expected the JSON file 'cbr "
                       f"run' writes") from None
    config = manifest.get("config") if isinstance(manifest, dict) else None
    if not isinstance(config, dict) or not isinstance(config.get("world"), dict):
        raise CbrError(f"{path}: records no configuration with a world; expected the "
                       f"manifest of a 'cbr run' of the {DELIVERY} workload")
    workload = config.get("workload")
    used = workload.get("use") if isinstance(workload, dict) else None
    if used != DELIVERY:
        raise CbrError(f"{path}: a run of the workload {found(used, setting=True)}, not "
                       f"{DELIVERY!r}; only "
                       f"{DELIVERY} runs record days")
    return config


def run_world(run_dir: Path) -> World:
    """The world of the delivery run in ``run_dir``, rebuilt from the resolved configuration
    its ``manifest.json`` records: the world slot and the seed checked against the registry
    and built by an engine, as the run built them (a generated world depends on the seed);
    a CbrError naming the file when the folder holds no delivery run."""
    from cbr_world2d.world import World
    from cbrcore.config import Config, config_from_data
    from cbrcore.engine import Engine
    from cbrcore.plugins import current

    config = _manifest(run_dir)
    path = run_dir / "manifest.json"
    registry = current().registry
    try:
        checked = config_from_data({"seed": config.get("seed", 0), "world": config["world"]},
                                   registry)
    except ConfigError as exc:
        raise ConfigError(f"{path}: the recorded configuration", exc.problems) from None
    # only the world: the run's case base, pilot and workload stay untouched
    with Engine(Config(seed=checked.seed, world=checked.world)) as engine:
        world = engine.world
    if not isinstance(world, World):
        raise CbrError(f"{path}: the run's world is a {type(world).__name__}, not a 2D world "
                       f"(cbr_world2d) that the {DELIVERY} workload runs on")
    return world


def _day_file(run_dir: Path, day: int) -> Path:
    path = run_dir / f"day_{day}.npz"
    if path.is_file():
        return path
    recorded = sorted(run_dir.glob("day_*.npz"), key=lambda p: (len(p.name), p.name))
    have = (f"the days recorded there: {', '.join(p.name for p in recorded)}" if recorded
            else "it records none: run with --set workload.log=true")
    raise CbrError(f"{path}: no such day log; expected the day_N.npz the {DELIVERY} workload "
                   f"writes with workload.log: true ({have})")


@app.command()
def day(
    run_dir: Annotated[Path, typer.Argument(
        metavar="RUN_DIR", show_default=False,
        help="The output folder of 'cbr run' with the delivery workload and workload.log: "
        "true.")],
    day_: Annotated[int, typer.Option("--day", min=0, metavar="N",
                                      help="The day to draw (0 is the first).")] = 0,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", metavar="DIR", show_default=False,
        help="Where the pictures go (default: RUN_DIR).")] = None,
    gif: Annotated[bool, typer.Option("--gif/--no-gif",
                                      help="Also animate the day into day_N.gif.")] = True,
    fps: Annotated[int, typer.Option("--fps", min=1, metavar="N",
                                     help="Frames a second of the GIF.")] = 10,
    speedup: Annotated[float, typer.Option(
        "--speedup", metavar="FACTOR",
        help="Seconds of the day a second of the GIF shows.")] = 20.0,
) -> None:
    """Draw a delivery day: the floor with the path coloured by case, a timeline, a GIF."""
    from cbr_behaviors.daylog import DayLog
    from cbr_behaviors.dayplot import animate_day, frame_count, plot_day, plot_timeline
    from cbr_world2d.checks import MAX_FRAMES
    from cbrcore.engine import output_folder

    if not (math.isfinite(speedup) and speedup > 0.0):
        raise typer.BadParameter(f"expected a finite number > 0, got {speedup!r}",
                                 param_hint="'--speedup'")
    _manifest(run_dir)  # a folder of another run fails before its day files are looked at
    path = _day_file(run_dir, day_)
    log = DayLog.load(path)
    if len(log.track()) == 0:
        raise CbrError(f"{path}: the day log holds no steps; expected a day the delivery "
                       "workload ran")
    frames = frame_count(log.track(), fps, speedup)
    if gif and frames > MAX_FRAMES:
        raise CbrError(f"--speedup {speedup:g}: the day's GIF would have {frames} frames at "
                       f"{fps} a second, more than the {MAX_FRAMES} an animation may have (the "
                       "limit); give a larger --speedup")
    world = run_world(run_dir)
    out_dir = run_dir if out is None else out
    output_folder(out_dir)
    picture, timeline = out_dir / f"day_{day_}.png", out_dir / f"day_{day_}_timeline.png"
    plot_day(world, log, picture)
    typer.echo(f"wrote {picture}")
    plot_timeline(log, timeline)
    typer.echo(f"wrote {timeline}")
    if gif:
        animation = out_dir / f"day_{day_}.gif"
        frames = animate_day(world, log, animation, fps=fps, speedup=speedup)
        typer.echo(f"wrote {animation} ({frames} frames, {frames / fps:.0f} s)")


def add_commands(app_: typer.Typer) -> None:
    """Add the ``rupart`` command group to the ``cbr`` application."""
    app_.add_typer(app)
