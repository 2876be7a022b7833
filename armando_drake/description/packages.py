"""ROS packages: where ``package://`` and ``$(find pkg)`` point.

:func:`find_packages` builds the package search path into a Drake ``PackageMap``:
the package of the description the user named first (an edited copy of a package
wins over the original), then ``--package-path``, ``ROS_PACKAGE_PATH``,
``AMENT_PREFIX_PATH``, the folders around the description, the project's
``models/`` last; a package hidden by an earlier one of the same name is reported
once.
"""

from __future__ import annotations

import logging
import os
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from pydrake.multibody.parsing import PackageMap

from armando_drake import MODELS_DIR
from armando_drake.tools.errors import UserInputError

LOGGER = logging.getLogger("armando_drake.description")
# What $(find pkg) gives for a package that is not found: a folder that does not exist.
MISSING_PACKAGE_DIR = Path("/nonexistent-ros-package")


class DescriptionError(UserInputError, RuntimeError):
    """A robot description that cannot be found, expanded or loaded."""


# --------------------------------------------------------------------------
# Packages
# --------------------------------------------------------------------------


@dataclass
class PackageSearch:
    """Where packages were found, in the order they were looked for."""

    packages: dict[str, Path] = field(default_factory=dict)  # name -> package dir
    searched: list[str] = field(default_factory=list)  # human-readable search list
    # name -> [(where it was also found, that directory)], each hidden by the one in packages
    shadowed: dict[str, list[tuple[str, Path]]] = field(default_factory=dict)
    # name -> the search entry (label: root) where the winning package was found
    origin: dict[str, str] = field(default_factory=dict)

    def package_map(self) -> PackageMap:
        """A Drake PackageMap holding exactly these packages."""
        result = PackageMap.MakeEmpty()
        for name, path in self.packages.items():
            result.Add(name, str(path))
        return result

    def resolve(self, name: str) -> Path:
        """The directory of package ``name``, or an error naming the search path."""
        if name not in self.packages:
            searched = "; ".join(self.searched) or "(no search path)"
            raise DescriptionError(f"unknown package {name!r} (searched {searched})")
        return self.packages[name]

    def report_shadowed(self) -> list[str]:
        """Logs (once per process and package) each package hidden by an earlier one."""
        lines = []
        for name, hidden in self.shadowed.items():
            others = ", ".join(f"{path} ({label})" for label, path in hidden)
            line = (
                f"package {name!r}: using {self.packages[name]} ({self.origin[name]}); "
                f"it shadows {others}"
            )
            lines.append(line)
            if line not in _reported_shadows:
                _reported_shadows.add(line)
                LOGGER.info("%s", line)
        return lines


_reported_shadows: set[str] = set()


def _package_name(package_xml: Path) -> str | None:
    try:
        root = ET.parse(package_xml).getroot()
    except (ET.ParseError, OSError):
        return None
    name = root.findtext("name")
    return name.strip() if name else None


def _scan(root: Path, found: dict[str, Path], max_depth: int = 4) -> list[tuple[str, Path]]:
    """Every package below ``root`` (up to ``max_depth``), as (name, dir), in scan order."""
    result: list[tuple[str, Path]] = []
    if not root.is_dir():
        return result
    stack = [(root, 0)]
    while stack:
        folder, depth = stack.pop()
        package_xml = folder / "package.xml"
        if package_xml.is_file():
            name = _package_name(package_xml)
            if name:
                result.append((name, folder.resolve()))
            continue  # packages do not nest
        if depth >= max_depth:
            continue
        try:
            children = sorted(p for p in folder.iterdir() if p.is_dir())
        except OSError:
            continue
        for child in reversed(children):
            if not child.name.startswith(".") and child.name not in ("build", "install", "log"):
                stack.append((child, depth + 1))
    return result


def package_of(path: str | os.PathLike) -> Path | None:
    """The package folder (with ``package.xml``) holding ``path``, up to 4 levels up."""
    here = Path(path).expanduser().resolve()
    folder = here if here.is_dir() else here.parent
    for candidate in [folder, *folder.parents][:5]:
        if (candidate / "package.xml").is_file():
            return candidate
    return None


def find_packages(
    package_paths: Iterable[str | os.PathLike] = (), near: str | os.PathLike | None = None
) -> PackageSearch:
    """Finds ROS packages; a package found earlier wins over one of the same name found later.

    Order: the package holding ``near`` (the description the user named: an
    edited copy of a package wins over the original); ``package_paths``;
    ``ROS_PACKAGE_PATH``; ``AMENT_PREFIX_PATH`` (``share/<pkg>``); the folders
    around ``near`` (that package's siblings, or the folder of a description
    that is in no package); the project's ``models/`` last. Every package found
    again later is listed in ``shadowed`` (see :meth:`PackageSearch.report_shadowed`).
    """
    search = PackageSearch()
    found = search.packages

    def scan(label: str, root: Path, depth: int = 4) -> None:
        entry = f"{label}: {root}"
        search.searched.append(entry)
        for name, folder in _scan(root, found, depth):
            if name not in found:
                found[name] = folder
                search.origin[name] = entry
            elif found[name] != folder:
                hidden = search.shadowed.setdefault(name, [])
                if all(path != folder for _, path in hidden):
                    hidden.append((entry, folder))

    own = package_of(near) if near is not None else None
    if own is not None:
        scan("package of the description", own, depth=0)
    for entry in package_paths:
        scan("--package-path", Path(entry).expanduser())
    for entry in filter(None, os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep)):
        scan("ROS_PACKAGE_PATH", Path(entry))
    for entry in filter(None, os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep)):
        scan("AMENT_PREFIX_PATH", Path(entry) / "share", depth=1)
    if own is not None:
        scan("next to the description's package", own.parent, depth=2)
    elif near is not None:
        here = Path(near).expanduser().resolve()
        scan("folder of the description", here if here.is_dir() else here.parent, depth=2)
    scan("project models", MODELS_DIR)
    return search
