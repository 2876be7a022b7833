"""The version of armando-drake, and the commit of the checkout it runs from.

One source: the ``version`` field of ``pyproject.toml``. An installed package carries it in
its metadata (:func:`importlib.metadata.version`); a source tree (a checkout, an unpacked
source distribution, an editable install) reads the ``pyproject.toml`` beside the package,
whose version the metadata of an editable install only copies, and may copy stale.

:func:`git_commit` names the commit of the git checkout the package sits in (``git
rev-parse --short HEAD``, ``-dirty`` when tracked files have changed), and nothing for an
installed package or without git. :func:`provenance` is what a run records of the code that
produced it (``summary.json``, the MCAP file's metadata); :func:`version_text` is what
``--version`` prints.

This module imports nothing of the package: ``armando_drake/__init__.py`` derives
``__version__`` from it.
"""

from __future__ import annotations

import functools
import importlib.metadata
import re
import subprocess
from pathlib import Path

DISTRIBUTION = "armando-drake"  # the name the package is installed under

_PACKAGE_DIR = Path(__file__).resolve().parents[1]
# The project's root when the package runs from a source tree (else the folder it is installed in).
_ROOT = _PACKAGE_DIR.parent
_GIT_TIMEOUT = 10.0  # [s] a git command that takes longer names no commit


def pyproject_field(text: str, field: str) -> str | None:
    """A string ``field`` of the ``[project]`` table of a ``pyproject.toml``'s ``text``
    (``name = "..."``, ``version = "..."``); None where the table or the field is missing."""
    table = re.search(r"^\[project\][ \t]*$(.*?)(?=^\[|\Z)", text, re.MULTILINE | re.DOTALL)
    if table is None:
        return None
    value = re.search(rf"^{field}\s*=\s*[\"']([^\"']+)[\"']", table.group(1), re.MULTILINE)
    return None if value is None else value.group(1)


def _source_tree_version(root: Path) -> str | None:
    """The version in ``root/pyproject.toml`` when that file is armando-drake's."""
    try:
        text = (root / "pyproject.toml").read_text(encoding="utf-8")
    except OSError:
        return None
    if pyproject_field(text, "name") != DISTRIBUTION:
        return None
    return pyproject_field(text, "version")


@functools.cache
def package_version() -> str:
    """The version of this copy of the package: its source tree's ``pyproject.toml``, else
    the installed metadata, else ``"unknown"`` (a copy of the folder without either)."""
    version = _source_tree_version(_ROOT)
    if version is not None:
        return version
    try:
        return importlib.metadata.version(DISTRIBUTION)
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def _git(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        ["git", "-C", str(_ROOT), *args],
        capture_output=True,
        text=True,
        timeout=_GIT_TIMEOUT,
        check=False,
    )


@functools.cache
def git_commit() -> str | None:
    """``git rev-parse --short HEAD`` of the checkout the package is tracked in, with
    ``-dirty`` when a tracked file differs from that commit; None when the package is not
    tracked by git where it sits (an installed wheel, even in a virtual environment inside
    a checkout), git is missing, or git fails."""
    try:
        tracked = _git("ls-files", "--error-unmatch", f"{_PACKAGE_DIR.name}/__init__.py")
        if tracked.returncode != 0:
            return None
        head = _git("rev-parse", "--short", "HEAD")
        if head.returncode != 0 or not head.stdout.strip():
            return None
        changes = _git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return None
    commit = head.stdout.strip()
    return f"{commit}-dirty" if changes.returncode == 0 and changes.stdout.strip() else commit


def provenance() -> dict[str, str]:
    """The code that produced a run: ``{"version": ..., "commit": ...}``, the commit only
    when the package runs from a git checkout (:func:`git_commit`)."""
    result = {"version": package_version()}
    commit = git_commit()
    if commit is not None:
        result["commit"] = commit
    return result


def version_text() -> str:
    """What ``--version`` prints: ``armando-drake 0.1.0``, with ``(commit 1a2b3c4)`` from a
    git checkout."""
    text = f"{DISTRIBUTION} {package_version()}"
    commit = git_commit()
    return f"{text} (commit {commit})" if commit is not None else text
