"""The ``record`` observer: the run recorded as MCAP with ROS 2 message types.

It opens the recording when the engine is built and leaves the
:class:`~cbr_recording.recorder.Recorder` in the stash for the families, which record their
world, robot and decisions on it; around each planning phase it notes the phase's wall time and
answer, which the consultation's decision message lists. ``cbr run --record FILE`` adds it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Generator
from pathlib import Path
from typing import Any

import attrs

from cbr_recording.files import check_path
from cbr_recording.keys import RECORDER
from cbrcore.context import Context
from cbrcore.errors import CbrError
from cbrcore.hookspecs import hookimpl
from cbrcore.options import OutputPath, in_run_folder, option


def _rate(_: object, attribute: attrs.Attribute, value: float) -> None:
    if not (isinstance(value, float) and math.isfinite(value) and value > 0):
        raise ValueError(f"'{attribute.name}' must be a finite number > 0, got {value!r}")


@attrs.frozen
class RecordOptions:
    """Checked when the configuration is read for an absolute ``file`` (``cbr run --record``
    gives one), when the engine is built for a file in the run's folder: either way before the
    run writes anything."""

    file: OutputPath = option(
        Path("recording.mcap"), "The MCAP file to write: an absolute path, or a file inside "
        "the run's output folder.")
    force: bool = option(False, "Replace the file if it exists (else the run is refused).")
    rate: float = option(
        5.0, "The most messages a second of simulation time on the fast topics (the robot's "
        "pose and transform, odometry, sonar, people).", validator=_rate)

    def __attrs_post_init__(self) -> None:
        if self.file.is_absolute():
            try:
                check_path(self.file, force=self.force, what="file")
            except CbrError as exc:
                raise ValueError(str(exc)) from None


class Record:
    """Record the run into ``file`` (see :class:`RecordOptions`)."""

    def __init__(self, options: RecordOptions, ctx: Context) -> None:
        from cbr_recording.recorder import Recorder

        path = in_run_folder(options.file, ctx.out_dir, ctx.config_dir)
        self.recorder = Recorder(path, force=options.force, rate=options.rate)
        ctx.stash[RECORDER] = self.recorder

    def _watch(self, phase: str, ctx: Context) -> Generator[None, Any, Any]:
        started = time.perf_counter()
        result, error = None, ""
        try:
            result = yield
        except BaseException as exc:
            error = f"{type(exc).__name__}: {exc}"
            raise
        else:
            return result
        finally:
            self.recorder.note(ctx.step, phase, time.perf_counter() - started, result, error)

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

    def close(self) -> None:
        self.recorder.close()
