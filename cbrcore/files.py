"""Files the program reads are regular files; files it writes appear whole or not at all.

Every file a user names as input is opened through :func:`open_regular`, which refuses a folder,
a named pipe, a device or a socket without waiting on it: reading a named pipe that nobody
writes to would hang for ever, and a device such as ``/dev/zero`` never ends.

A file is written to a temporary file in the same folder, flushed to the disk and renamed over
its target: a crash, a kill or a full disk leaves either the earlier file or the new one, never
a truncated mix, and a failed write leaves no temporary file behind. A read-only file is never
replaced.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, BinaryIO


class NotRegularFile(OSError):
    """An input path that names something other than a regular file.

    An :class:`OSError`, so that every reader's handling of unreadable files reports it; its
    ``strerror`` (and text) says what the path is, e.g. ``a named pipe, not a regular file``.
    """

    def __init__(self, path: str | os.PathLike[str], kind: str) -> None:
        super().__init__(errno.EINVAL, f"{kind}, not a regular file", os.fspath(path))

    def __str__(self) -> str:
        return str(self.strerror)


class FolderNotFile(NotRegularFile, IsADirectoryError):
    """A folder where a file was expected; an :class:`IsADirectoryError` too, as :func:`open`
    raises."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        super().__init__(path, "a folder")
        self.errno = errno.EISDIR


_KINDS = (
    (stat.S_ISFIFO, "a named pipe"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def open_regular(path: str | os.PathLike[str]) -> BinaryIO:
    """``path`` opened for reading in binary, refused with :class:`NotRegularFile` unless it
    is a regular file (a symbolic link is followed).

    The file is opened without blocking and checked by the descriptor it was opened as, so
    neither a named pipe with no writer nor a file swapped for one after a check can make the
    read wait; a regular file is then read as usual. Other errors (no such file, no
    permission) are raised as :func:`open` raises them.
    """
    # Windows has no named pipes in the file system, and no flag
    nonblocking = getattr(os, "O_NONBLOCK", 0)
    descriptor = os.open(path, os.O_RDONLY | nonblocking | getattr(os, "O_BINARY", 0))
    try:
        mode = os.fstat(descriptor).st_mode
        if stat.S_ISDIR(mode):
            raise FolderNotFile(path)
        if not stat.S_ISREG(mode):
            raise NotRegularFile(path, next((kind for test, kind in _KINDS if test(mode)),
                                            "something else"))
        if nonblocking:  # the flag was for the open; a regular file is read as any other
            os.set_blocking(descriptor, True)
        return os.fdopen(descriptor, "rb")
    except BaseException:
        os.close(descriptor)
        raise


@contextlib.contextmanager
def replacing(path: Path, mode: str = "w") -> Iterator[IO[str]]:
    """A file object whose content replaces ``path`` when the block ends without an error.

    ``mode`` is ``"w"`` (text, UTF-8, newlines as written) or ``"wb"``. A symbolic link is
    followed: the file it names is replaced, and the link stays. A replaced file keeps its
    permissions. Something that is not a regular file (a terminal, a pipe, ``/dev/stdout``)
    cannot be replaced and is written directly. A read-only file (:func:`read_only`) is
    refused with a PermissionError and left as it is.
    """
    options: dict[str, str] = {} if "b" in mode else {"encoding": "utf-8", "newline": ""}
    try:
        existing = path.stat()  # through any link
    except FileNotFoundError:
        existing = None
    if existing is not None and not stat.S_ISREG(existing.st_mode):
        with path.open(mode, **options) as file:
            yield file
        return
    if existing is not None and read_only(path, existing):
        # renaming over it would succeed, since that needs only the folder's permission
        raise PermissionError(errno.EACCES, "the file is read-only; it is not replaced",
                              str(path))
    target = Path(os.path.realpath(path))
    handle, temporary = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.",
                                         suffix=".partial")
    try:
        # mkstemp makes the file private; the result keeps the permissions the file had, or
        # gets those of any new file
        permissions = (stat.S_IMODE(existing.st_mode) if existing is not None
                       else 0o666 & ~_umask())
        os.chmod(temporary, permissions)
        with os.fdopen(handle, mode, **options) as file:
            yield file
            file.flush()
            os.fsync(file.fileno())
        os.replace(temporary, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)
        raise


def read_only(path: Path, found: os.stat_result) -> bool:
    """Whether the file ``path``, of status ``found``, is read-only: nobody has permission to
    write it, or this process may not (a superuser may write any file, but a file without any
    write permission was made read-only on purpose)."""
    return not found.st_mode & 0o222 or not os.access(path, os.W_OK)


def write_text(path: Path, text: str) -> None:
    """Replace ``path`` with ``text`` (UTF-8), whole or not at all."""
    with replacing(path) as file:
        file.write(text)


def _umask() -> int:
    current = os.umask(0)
    os.umask(current)
    return current
