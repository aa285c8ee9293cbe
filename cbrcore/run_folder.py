"""A run's output folder as a later run finds it: what it holds, whether a run may continue it,
and what starting afresh removes.

A run into a folder that already holds results continues them: its case base keeps its cases,
``results.csv`` grows by the new run's rows, their query numbers following on. The folder's
``manifest.json`` records a fingerprint of the configuration that wrote it (:func:`config_sha256`);
a run of another configuration is refused (its rows would not belong with the others) unless it
starts afresh, which removes the folder's results and its case base file first
(:func:`fresh_files`).
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import attrs

from cbrcore import files
from cbrcore.config import Config
from cbrcore.errors import CbrError
from cbrcore.options import in_run_folder

RESULTS = "results.csv"
SUMMARY = "summary.json"
MANIFEST = "manifest.json"



def config_sha256(config: Config) -> str:
    """The SHA-256 of the configuration as resolved (every default filled in, secrets as they
    are shown), as a run's manifest records it under ``config_sha256``. Observers are left
    out: they watch a run (a trace, a recording) without changing what it does, so a run
    recorded once and not the next continues the same results."""
    return _digest(config.resolved())


def _digest(resolved: Any) -> str:
    if isinstance(resolved, Mapping):
        resolved = {key: value for key, value in resolved.items() if key != "observers"}
    # through JSON as the manifest stores it, so a configuration and the manifest written of it
    # give the same digest (tuples become lists, paths strings)
    plain = json.loads(json.dumps(resolved, default=str))
    text = json.dumps(plain, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


@attrs.frozen
class Earlier:
    """The results an earlier run left in the folder: ``rows`` of ``results.csv`` under
    ``columns`` (empty for no file), and the query number the next run starts from."""

    rows: int = 0
    next_query: int = 0
    columns: tuple[str, ...] = ()


def earlier_results(out_dir: Path) -> Earlier:
    """What ``out_dir/results.csv`` holds; nothing for a folder without one.

    A CbrError names the file when it cannot be read as a run's results (no ``query`` column,
    a query number that is not a whole number), without quoting it.
    """
    path = out_dir / RESULTS
    if not path.exists():
        return Earlier()
    expected = "expected a run's results, or start afresh with --fresh"
    try:
        # a named pipe or a folder in its place is refused, not waited on
        with files.open_regular(path) as raw, \
                io.TextIOWrapper(raw, encoding="utf-8", newline="") as handle:
            reader = csv.DictReader(handle)
            columns = tuple(reader.fieldnames or ())
            if columns and "query" not in columns:
                raise CbrError(f"{path}: its header has no 'query' column; {expected}")
            rows, last = 0, -1
            for row in reader:
                rows += 1
                last = max(last, _query_number(row.get("query") or "", path, reader.line_num,
                                               expected))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise CbrError(f"{path}: cannot be read as a run's results ({_reason(exc)}); "
                       f"{expected}") from exc
    return Earlier(rows=rows, next_query=last + 1, columns=columns)


def _query_number(text: str, path: Path, line: int, expected: str) -> int:
    try:
        # ASCII digits only: int() would also take '٣' or ' 3 '
        if text.isascii() and text.isdigit():
            return int(text)
    except ValueError:  # more digits than Python converts
        pass
    raise CbrError(f"{path}, line {line}: the query number is not a whole number; {expected}")


def check_continuable(out_dir: Path, config: Config) -> None:
    """Refuse, with a CbrError, to continue ``out_dir`` when its manifest was written by another
    configuration, or is no run's manifest; a folder without a manifest may be continued."""
    path = out_dir / MANIFEST
    if not path.exists():
        return
    advice = ("run into another folder (--out), or start afresh with --fresh, which removes "
              "the folder's results and case base")
    try:
        with files.open_regular(path) as raw:
            data = json.loads(raw.read().decode("utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise CbrError(f"{path}: cannot be read as a run's manifest ({_reason(exc)}); "
                       f"{advice}") from exc
    if not isinstance(data, dict) or not isinstance(data.get("config"), dict):
        raise CbrError(f"{path}: records no run's configuration (the folder holds something "
                       f"else, an experiment's output say); {advice}")
    stored = data.get("config_sha256")
    # a manifest written before the fingerprint was recorded is compared by its configuration
    recorded = stored if isinstance(stored, str) else _digest(data["config"])
    if recorded != config_sha256(config):
        written = data.get("config_file")
        source = written if isinstance(written, str) and written else "another configuration"
        raise CbrError(f"{out_dir}: holds the results of a different configuration ({source}, "
                       f"configuration {recorded[:12]}, this one is "
                       f"{config_sha256(config)[:12]}); {advice}")


def _reason(exc: Exception) -> str:
    """Why a file could not be read, without quoting it: the system's words for an OSError
    (``Is a directory``, ``is a named pipe``), else the kind of error."""
    if isinstance(exc, OSError):
        return str(exc.strerror or type(exc).__name__)
    return "not JSON" if isinstance(exc, json.JSONDecodeError) else type(exc).__name__


def fresh_files(out_dir: Path, config: Config) -> list[Path]:
    """The files starting afresh in ``out_dir`` removes, those that exist: the run's results,
    summary and manifest, and the configuration's case base file with its companion files (of
    a store that keeps one, such as SQLite: :class:`~cbrcore.casebase.store.StoreFile`) when it
    is kept inside the folder and not opened read-only. A case base elsewhere (another folder,
    a database server) is not the folder's and is left alone."""
    from cbrcore.casebase.store import capabilities

    found = [out_dir / name for name in (RESULTS, SUMMARY, MANIFEST)]
    casebase = config.casebase
    file = None if casebase is None else capabilities(casebase.options).file
    if file is not None and not casebase.options.read_only:
        database = in_run_folder(casebase.options.path or Path(file.default_name), out_dir,
                                 config.base_dir)
        if database.resolve().is_relative_to(out_dir.resolve()):
            found += file.files(database)
    return [path for path in found if path.is_file()]


def remove(paths: list[Path]) -> None:
    """Remove ``paths``; a CbrError names the first that cannot be removed."""
    for path in paths:
        try:
            path.unlink(missing_ok=True)
        except OSError as exc:
            raise CbrError(f"{path}: cannot be removed ({exc.strerror or exc})") from exc
