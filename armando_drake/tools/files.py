"""Every file a user names is read through here: regular files only, of a bounded size,
and YAML whose aliases expand to a bounded size, checked before anything walks it.

A FIFO or a device given as a controller YAML would block the run or fill the memory
(``/dev/zero``), a directory has no text, and a YAML "billion laughs" (aliases of
aliases) expands to gigabytes in a loader that follows them. Each is one line naming
the file and the limit it passed.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
from collections.abc import Iterator
from pathlib import Path

import yaml

from armando_drake.tools.errors import UserInputError

# [bytes] the largest YAML file read (scenarios, controller YAML, Nav2, sweep specs):
# the largest real one is a few kB.
MAX_YAML_BYTES = 8 * 2**20
# The most nodes a YAML document may expand to, each alias counted every time it is
# used: far above any real file, far below what fills the memory.
MAX_YAML_NODES = 200_000
# The deepest nesting of a YAML document.
MAX_YAML_DEPTH = 200

_KINDS = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


class FileInputError(UserInputError, ValueError):
    """A file that is not read: not a regular file, too large, or YAML that expands too
    far; the message names it."""


def read_text_file(path: str | os.PathLike, *, what: str, max_bytes: int = MAX_YAML_BYTES) -> str:
    """The UTF-8 text of the regular file ``path`` (``what`` names it in messages: "the
    scenario", "the controller file"), at most ``max_bytes`` long. OSError and
    UnicodeDecodeError are the caller's to word."""
    info = os.stat(path)
    for test, kind in _KINDS:
        if test(info.st_mode):
            raise FileInputError(f"{path}: {kind}, not a file: {what} must be a regular file")
    if not stat.S_ISREG(info.st_mode):
        raise FileInputError(f"{path}: not a regular file: {what} must be one")
    with open(path, "rb") as stream:
        data = stream.read(max_bytes + 1)  # a file that grows while it is read: bounded too
    if len(data) > max_bytes:
        raise FileInputError(
            f"{path}: over {max_bytes // 2**20} MiB: too large for {what} (a YAML file of a "
            "few kB is usual)"
        )
    return data.decode("utf-8")


def check_yaml_expansion(text: str, where: str) -> None:
    """Refuses YAML ``text`` whose aliases expand beyond :data:`MAX_YAML_NODES` nodes or
    that nests deeper than :data:`MAX_YAML_DEPTH` (``where``: the file or the override,
    first in the message). Counts on the composed node graph, where an alias is one
    shared node: linear in the text, whatever it expands to. Text that is not YAML
    passes (its loader reports that)."""
    try:
        documents = [node for node in yaml.compose_all(text, Loader=yaml.SafeLoader) if node]
    except yaml.YAMLError:
        return
    sizes: dict[int, int] = {}  # id(node) -> nodes it expands to
    for document in documents:
        if _expanded_size(document, sizes, where) > MAX_YAML_NODES:
            raise FileInputError(
                f"{where}: its aliases expand to over {MAX_YAML_NODES:,} nodes (a YAML "
                "alias bomb?): not loaded"
            )


def _expanded_size(root: yaml.Node, sizes: dict[int, int], where: str) -> int:
    """The number of nodes ``root`` expands to, aliases counted at each use (memoized
    in ``sizes``; iterative, so deep nesting is counted, not recursed into)."""
    stack = [(root, 0, False)]
    on_path: set[int] = set()
    while stack:
        node, depth, children_done = stack.pop()
        if id(node) in sizes:
            continue
        children = _children(node)
        if depth > MAX_YAML_DEPTH:
            raise FileInputError(f"{where}: nested deeper than {MAX_YAML_DEPTH} levels")
        if children_done:
            on_path.discard(id(node))
            total = 1 + sum(sizes[id(child)] for child in children)
            sizes[id(node)] = min(total, MAX_YAML_NODES + 1)
            continue
        if id(node) in on_path:
            raise FileInputError(f"{where}: an alias refers to a node that contains it")
        on_path.add(id(node))
        stack.append((node, depth, True))
        for child in children:
            if id(child) not in sizes:
                if id(child) in on_path:
                    raise FileInputError(f"{where}: an alias refers to a node that contains it")
                stack.append((child, depth + 1, False))
    return sizes[id(root)]


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    if isinstance(node, yaml.MappingNode):
        return [item for pair in node.value for item in pair]
    return []


def read_yaml_file(path: str | os.PathLike, *, what: str) -> str:
    """:func:`read_text_file`, then :func:`check_yaml_expansion` naming the file."""
    text = read_text_file(path, what=what)
    check_yaml_expansion(text, str(Path(path)))
    return text


# The errors of a write that the machine, not the code, causes: each names the file.
WRITE_ERRORS = {
    errno.ENOSPC: "no space left on the device (the disk is full)",
    errno.EDQUOT: "disk quota exceeded",
    errno.EFBIG: "the file is larger than this file system or the file size limit allows",
    errno.EROFS: "the file system is read-only",
    errno.EIO: "input/output error of the device",
}


class OutputFileError(UserInputError, OSError):
    """An output file that cannot be written (disk full, quota, read-only); the
    message names it."""


def _named_write_error(path: str | os.PathLike, error: OSError) -> OSError:
    if isinstance(error, OutputFileError) or error.errno not in WRITE_ERRORS:
        return error
    named = OutputFileError(f"{path}: cannot write: {WRITE_ERRORS[error.errno]}")
    named.errno = error.errno
    return named


@contextlib.contextmanager
def writing(path: str | os.PathLike) -> Iterator[None]:
    """Turns a write error of the machine (disk full, quota, read-only) inside the block
    into one line naming ``path``."""
    try:
        yield
    except OSError as error:
        named = _named_write_error(path, error)
        if named is error:
            raise
        raise named from None


class OutputFile:
    """A file open for writing whose write errors name it (:func:`writing`): the rest
    of the file object's interface is the file's own."""

    def __init__(self, path: str | os.PathLike, mode: str = "wb", **options):
        self.path = Path(path)
        with writing(path):
            self._file = open(path, mode, **options)  # noqa: SIM115 (closed by close())

    def write(self, data):
        with writing(self.path):
            return self._file.write(data)

    def writelines(self, lines) -> None:
        with writing(self.path):
            self._file.writelines(lines)

    def flush(self) -> None:
        with writing(self.path):
            self._file.flush()

    def close(self) -> None:
        with writing(self.path):
            self._file.close()

    def __getattr__(self, name: str):
        return getattr(self._file, name)

    def __enter__(self) -> OutputFile:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
