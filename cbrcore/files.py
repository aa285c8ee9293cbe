"""Files the program writes appear whole or not at all.

A file is written to a temporary file in the same folder, flushed to the disk and renamed over
its target: a crash, a kill or a full disk leaves either the earlier file or the new one, never
a truncated mix, and a failed write leaves no temporary file behind.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO


@contextlib.contextmanager
def replacing(path: Path, mode: str = "w") -> Iterator[IO[str]]:
    """A file object whose content replaces ``path`` when the block ends without an error.

    ``mode`` is ``"w"`` (text, UTF-8, newlines as written) or ``"wb"``.
    """
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.",
                                         suffix=".partial")
    try:
        # mkstemp makes the file private; the target gets the permissions of any new file
        os.chmod(temporary, 0o666 & ~_umask())
        with os.fdopen(handle, mode, **({} if "b" in mode else
                                        {"encoding": "utf-8", "newline": ""})) as file:
            yield file
            file.flush()
            os.fsync(file.fileno())
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)
        raise


def write_text(path: Path, text: str) -> None:
    """Replace ``path`` with ``text`` (UTF-8), whole or not at all."""
    with replacing(path) as file:
        file.write(text)


def _umask() -> int:
    current = os.umask(0)
    os.umask(current)
    return current
