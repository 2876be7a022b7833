"""One run per output folder: a run holds an exclusive lock on its folder while it
writes there, so two runs given the same ``--output`` never mix their files (the
second is refused at once, naming the first's process)."""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import time
from collections.abc import Iterator
from pathlib import Path

from armando_drake.tools.errors import UserInputError

LOCK_NAME = ".armando_drake.lock"


class OutputFolderBusy(UserInputError, ValueError):
    """Another run writes to the folder; the message names it and its process."""


def _holder(descriptor: int) -> str:
    """The process id the lock file names; the holder writes it just after it takes the
    lock, so an empty file is read again for a moment."""
    deadline = time.monotonic() + 1.0
    while True:
        holder = os.pread(descriptor, 32, 0).decode(errors="replace").strip()
        if holder or time.monotonic() > deadline:
            return holder or "?"
        time.sleep(0.01)


def _locked_descriptor(path: Path, folder, option: str) -> int:
    """A descriptor of the lock file at ``path`` holding its exclusive lock. A lock
    taken on a file its last holder has just removed is let go and taken again on the
    file now at ``path``, so two runs never hold two different files."""
    while True:
        descriptor = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as error:
            if error.errno not in (errno.EAGAIN, errno.EACCES):
                os.close(descriptor)
                raise
            holder = _holder(descriptor)
            os.close(descriptor)
            raise OutputFolderBusy(
                f"{option} {folder}: another run (process {holder}) is writing there; "
                "give each run a folder of its own"
            ) from None
        try:
            current = os.stat(path).st_ino
        except FileNotFoundError:
            current = None
        if current == os.fstat(descriptor).st_ino:
            return descriptor
        os.close(descriptor)  # removed by the run that held it: take the new one


@contextlib.contextmanager
def output_folder_lock(folder: str | os.PathLike, option: str = "--output") -> Iterator[None]:
    """Holds the folder's lock (``flock`` on a hidden file in it) for the block;
    :class:`OutputFolderBusy` if another process holds it. The lock goes with the
    process, so a killed run leaves none behind."""
    path = Path(folder) / LOCK_NAME
    descriptor = _locked_descriptor(path, folder, option)
    try:
        os.ftruncate(descriptor, 0)
        os.pwrite(descriptor, f"{os.getpid()}\n".encode(), 0)
        try:
            yield
        finally:
            with contextlib.suppress(OSError):
                path.unlink()
    finally:
        os.close(descriptor)
