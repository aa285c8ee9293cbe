"""Where a run's recorder is found: the stash key the ``record`` observer fills.

A family that has something to record asks ``ctx.stash.get(RECORDER, None)`` and records only
when the run is recorded. This module imports no ROS or MCAP library, so families import it
at no cost when nothing is recorded.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cbrcore.stash import StashKey

if TYPE_CHECKING:
    pass

RECORDER = StashKey["Recorder"]()
"""The run's :class:`~cbr_recording.recorder.Recorder`, present while the run is recorded."""
