"""One run per output folder: a run holds an exclusive lock on its folder while it
writes there, so two runs given the same ``--output`` never mix their files (the
second is refused at once, naming the first's process)."""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
from collections.abc import Iterator
from pathlib import Path

from armando_drake.tools.errors import UserInputError

LOCK_NAME = ".armando_drake.lock"


class OutputFolderBusy(UserInputError, ValueError):
    """Another run writes to the folder; the message names it and its process."""


@contextlib.contextmanager
def output_folder_lock(folder: str | os.PathLike, option: str = "--output") -> Iterator[None]:
    """Holds the folder's lock (``flock`` on a hidden file in it) for the block;
    :class:`OutputFolderBusy` if another process holds it. The lock goes with the
    process, so a killed run leaves none behind."""
    path = Path(folder) / LOCK_NAME
    descriptor = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as error:
            if error.errno not in (errno.EAGAIN, errno.EACCES):
                raise
            holder = os.read(descriptor, 32).decode(errors="replace").strip() or "?"
            raise OutputFolderBusy(
                f"{option} {folder}: another run (process {holder}) is writing there; "
                "give each run a folder of its own"
            ) from None
        os.ftruncate(descriptor, 0)
        os.write(descriptor, f"{os.getpid()}\n".encode())
        try:
            yield
        finally:
            with contextlib.suppress(OSError):
                path.unlink()
    finally:
        os.close(descriptor)
