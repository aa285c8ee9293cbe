"""The ``trace`` observer: one JSON line per phase call, with its duration and result."""

from __future__ import annotations

import json
import time
from collections.abc import Generator
from pathlib import Path
from typing import IO, Any

import attrs

from cbrcore.context import Context
from cbrcore.errors import ConfigError
from cbrcore.files import open_regular
from cbrcore.hookspecs import hookimpl
from cbrcore.model import Retrieval, Revision, Solution
from cbrcore.options import OutputPath, in_run_folder, option


@attrs.frozen
class TraceOptions:
    file: OutputPath | None = option(
        None, "Where to write the trace (JSON lines): an absolute path, or a file inside the "
        "run's output folder; default: trace.jsonl there.")


def _summary(result: Any) -> dict[str, Any]:
    if isinstance(result, Retrieval):
        best = result.matches[0] if result.matches else None
        return {"matches": len(result.matches),
                "best": None if best is None else {"case": best.case.id,
                                                   "similarity": best.similarity}}
    if isinstance(result, Solution):
        return {"cost": result.cost, "cases": list(result.cases)}
    if isinstance(result, Revision):
        return {"accepted": result.accepted, "reason": result.reason}
    return {}


def _appendable(path: Path) -> bool:
    """Whether ``path`` is missing, empty or a trace: a regular file whose first byte opens a
    JSON object (a named pipe or a device is not, and is never waited on)."""
    try:
        with open_regular(path) as handle:
            first = handle.read(1)
    except FileNotFoundError:
        return True
    except OSError:
        return False
    return first in (b"", b"{")


class Trace:
    """Trace every phase: query index, phase, wall time in ms, outcome and a result summary.

    A wrapper around each phase hook, so it measures the configured component and sees its
    result or its exception. Lines are flushed as written: a killed run keeps its trace.
    """

    def __init__(self, options: TraceOptions, ctx: Context) -> None:
        if options.file is not None:
            path = in_run_folder(options.file, ctx.out_dir, ctx.config_dir)
        elif ctx.out_dir is None:
            raise ConfigError("observers", [
                "observers: trace needs a 'file' when the engine has no output folder"])
        else:
            path = ctx.out_dir / "trace.jsonl"
        if not _appendable(path):
            raise ConfigError("observers", [
                f"observers: trace file: {path} exists and is not a trace (its first line is "
                "not a JSON object); a trace appends to an earlier trace only, so that it "
                "cannot damage another file (a case base, say): name another file"])
        path.parent.mkdir(parents=True, exist_ok=True)
        self._handle: IO[str] = path.open("a", encoding="utf-8")

    def _watch(self, phase: str, ctx: Context) -> Generator[None, Any, Any]:
        started = time.perf_counter()
        record: dict[str, Any] = {"step": ctx.step, "phase": phase}
        try:
            result = yield
        except BaseException as exc:
            record.update(error=f"{type(exc).__name__}: {exc}")
            raise
        else:
            record.update(_summary(result))
            return result
        finally:
            record["ms"] = round((time.perf_counter() - started) * 1000, 4)
            self._handle.write(json.dumps(record) + "\n")
            self._handle.flush()

    @hookimpl(wrapper=True)
    def cbr_retrieve(self, ctx: Context) -> Generator[None, Any, Any]:
        return (yield from self._watch("retrieve", ctx))

    @hookimpl(wrapper=True)
    def cbr_reuse(self, ctx: Context) -> Generator[None, Any, Any]:
        return (yield from self._watch("reuse", ctx))

    @hookimpl(wrapper=True)
    def cbr_revise(self, ctx: Context) -> Generator[None, Any, Any]:
        return (yield from self._watch("revise", ctx))

    @hookimpl(wrapper=True)
    def cbr_solve(self, ctx: Context) -> Generator[None, Any, Any]:
        return (yield from self._watch("solve", ctx))

    @hookimpl(wrapper=True)
    def cbr_retain(self, ctx: Context) -> Generator[None, Any, Any]:
        return (yield from self._watch("retain", ctx))

    @hookimpl(wrapper=True)
    def cbr_forget(self, ctx: Context) -> Generator[None, Any, Any]:
        return (yield from self._watch("forget", ctx))
