"""Where a recording may be written."""

from __future__ import annotations

import os
from pathlib import Path

from cbrcore.errors import CbrError


def check_path(path: Path, *, force: bool = False, what: str = "--record") -> None:
    """A CbrError unless ``path`` can take a new recording: not a folder, not an existing file
    unless ``force``, in a folder that exists or can be made. Checked before a run starts, so
    that a refused recording leaves the run's other outputs as they were."""
    if path.is_dir():
        raise CbrError(f"{what} {path}: is a folder; name the .mcap file to write")
    if path.exists() and not force:
        raise CbrError(f"{what} {path}: exists; name a new file, or give --force (force: true "
                       "in the configuration) to replace it")
    folder = path.parent
    while not folder.exists():
        folder = folder.parent
    if not folder.is_dir() or not os.access(folder, os.W_OK | os.X_OK):
        raise CbrError(f"{what} {path}: cannot be written (the folder {folder} is not a "
                       "writable folder)")
