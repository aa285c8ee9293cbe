"""The ``record`` observer: the run recorded as MCAP with ROS 2 message types.

It opens the recording when the engine is built and leaves the
:class:`~cbr_recording.recorder.Recorder` in the stash for the families, which record their
world, robot and decisions on it. A decision lists each planning phase's time and answer from
the proposal; around reuse the observer notes what reuse answered, which the proposal drops
when revision rejects it. ``cbr run --record FILE`` adds it.
"""

from __future__ import annotations

import math
from collections.abc import Generator
from pathlib import Path
from typing import Any

import attrs

from cbr_recording.files import check_path
from cbr_recording.keys import RECORDER
from cbrcore.context import Context
from cbrcore.errors import CbrError, ConfigError
from cbrcore.hookspecs import hookimpl
from cbrcore.options import OutputPath, in_run_folder, option


def _rate(_: object, attribute: attrs.Attribute, value: float) -> None:
    if not (isinstance(value, float) and math.isfinite(value) and value > 0):
        raise ValueError(f"'{attribute.name}' must be a finite number > 0, got {value!r}")


@attrs.frozen
class RecordOptions:
    """An absolute ``file`` (``cbr run --record`` gives one) is checked when the configuration
    is read, before the run touches anything."""

    file: OutputPath | None = option(
        None, "The MCAP file to write: an absolute path, or a file inside the run's output "
        "folder; default: recording.mcap there. A file inside the folder that exists (an "
        "earlier run's, continued) is kept, the recording going to <name>-2.mcap, -3 ...")
    force: bool = option(False, "Replace the file if it exists (else an absolute path is "
                         "refused, and one inside the run's folder numbered).")
    rate: float = option(
        2.0, "The most messages a second of simulation time on the 2D world's fast topics "
        "(the robot's transform, odometry, sonar, people, sightings); each hertz costs a "
        "delivery day about 2.6% of its time (benchmarks/recording_cost.py).",
        validator=_rate)

    def __attrs_post_init__(self) -> None:
        if self.file is not None and self.file.is_absolute():
            try:
                check_path(self.file, force=self.force, what="file")
            except CbrError as exc:
                raise ValueError(str(exc)) from None


DEFAULT_FILE = Path("recording.mcap")


def _free(path: Path) -> Path:
    """``path``, or when a file is there the first free ``<stem>-2<suffix>``, ``-3`` ...: a run
    continuing a folder records beside the earlier runs' recordings."""
    candidate, number = path, 1
    while candidate.exists():
        number += 1
        candidate = path.with_name(f"{path.stem}-{number}{path.suffix}")
    return candidate


class Record:
    """Record the run as MCAP with ROS 2 message types, for Foxglove and ``ros2 bag play``
    (``cbr run --record FILE`` adds it): the families record their world, robot and
    decisions."""

    def __init__(self, options: RecordOptions, ctx: Context) -> None:
        from cbr_recording.recorder import Recorder
        from cbrcore.run_folder import earlier_results

        if ctx.out_dir is None and options.file is None:
            raise ConfigError("observers", [
                "observers: record needs a 'file' when the engine has no output folder"])
        path = in_run_folder(options.file or DEFAULT_FILE, ctx.out_dir, ctx.config_dir)
        if not options.force and (options.file is None or not options.file.is_absolute()):
            path = _free(path)
        first = earlier_results(ctx.out_dir).next_query if ctx.out_dir is not None else 0
        self.recorder = Recorder(path, force=options.force, rate=options.rate,
                                 first_query=first)
        ctx.stash[RECORDER] = self.recorder

    @hookimpl(wrapper=True)
    def cbr_reuse(self, ctx: Context) -> Generator[None, Any, Any]:
        reused = yield
        self.recorder.note(ctx.step, reused)
        return reused

    def close(self) -> None:
        self.recorder.close()
