"""ROS packages: where ``package://`` and ``$(find pkg)`` point.

:func:`find_packages` builds the package search path into a Drake ``PackageMap``:
the package of the description the user named first (an edited copy of a package
wins over the original), then ``--package-path``, ``ROS_PACKAGE_PATH``,
``AMENT_PREFIX_PATH``, the folders around the description, the project's
``models/`` last; a package hidden by an earlier one of the same name is reported
once.
"""

from __future__ import annotations

import atexit
import hashlib
import logging
import os
import re
import shutil
import tempfile
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
        """A Drake PackageMap holding exactly these packages, each as an install lays
        it out (:func:`installed_view`)."""
        result = PackageMap.MakeEmpty()
        for name, path in self.packages.items():
            result.Add(name, str(installed_view(path, note=False)))
        return result

    def resolve(self, name: str) -> Path:
        """The directory of package ``name`` as an install lays it out
        (:func:`installed_view`: ``$(find name)``), or an error naming the search path."""
        if name not in self.packages:
            searched = "; ".join(self.searched) or "(no search path)"
            raise DescriptionError(f"unknown package {name!r} (searched {searched})")
        return installed_view(self.packages[name])

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


# --------------------------------------------------------------------------
# Source packages as an install lays them out
# --------------------------------------------------------------------------

# The CMake keywords that end the list of files or folders of an install() rule.
_INSTALL_KEYWORDS = frozenset(
    {"DESTINATION", "PATTERN", "REGEX", "FILES_MATCHING", "USE_SOURCE_PERMISSIONS",
     "PERMISSIONS", "FILE_PERMISSIONS", "DIRECTORY_PERMISSIONS", "CONFIGURATIONS",
     "COMPONENT", "OPTIONAL", "EXCLUDE_FROM_ALL", "MESSAGE_NEVER", "RENAME", "EXCLUDE"}
)  # fmt: skip
_views: dict[Path, Path] = {}
_noted: set[Path] = set()
_views_root: list[Path] = []


def _cmake_commands(text: str, command: str) -> list[list[str]]:
    """The arguments of each ``command(...)`` call in CMake ``text`` (comments removed,
    quotes stripped)."""
    text = re.sub(r"#[^\n]*", "", text)
    calls = []
    for match in re.finditer(rf"\b{command}\s*\(((?:[^()]|\([^()]*\))*)\)", text, re.I):
        calls.append([arg.strip("\"'") for arg in re.findall(r'"[^"]*"|\S+', match.group(1))])
    return calls


def install_rules(package_dir: Path) -> list[tuple[str, Path, bool]]:
    """What the package's ``CMakeLists.txt`` installs into ``share/<package>``:
    (destination folder relative to it, the source file or folder, whether only the
    folder's contents go there), in the order written. ``install(DIRECTORY|FILES ...
    DESTINATION share/${PROJECT_NAME}[/...])`` (also ``${CATKIN_PACKAGE_SHARE_DESTINATION}``)
    and ``ament_auto_package(INSTALL_TO_SHARE ...)``; a rule with another variable is
    skipped."""
    cmake = package_dir / "CMakeLists.txt"
    try:
        text = cmake.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return []
    projects = _cmake_commands(text, "project")
    project = projects[0][0] if projects and projects[0] else package_dir.name
    share = {f"share/{project}", "share/${PROJECT_NAME}", "${CATKIN_PACKAGE_SHARE_DESTINATION}"}
    rules = []
    for args in _cmake_commands(text, "install"):
        if not args or args[0].upper() not in ("DIRECTORY", "FILES") or "DESTINATION" not in args:
            continue
        destination = args[args.index("DESTINATION") + 1].rstrip("/")
        prefix = next(
            (s for s in share if destination == s or destination.startswith(s + "/")), None
        )
        if prefix is None:
            continue
        below = destination[len(prefix) :].strip("/")
        for item in args[1:]:
            if item.upper() in _INSTALL_KEYWORDS:
                break
            source = item.replace("${CMAKE_CURRENT_SOURCE_DIR}", str(package_dir))
            source = source.replace("${PROJECT_SOURCE_DIR}", str(package_dir))
            if "$" in source:
                continue
            path = Path(source) if Path(source).is_absolute() else package_dir / source
            rules.append((below, path, args[0].upper() == "DIRECTORY" and item.endswith("/")))
    for args in _cmake_commands(text, "ament_auto_package"):
        if "INSTALL_TO_SHARE" in args:
            for item in args[args.index("INSTALL_TO_SHARE") + 1 :]:
                if item.isupper():
                    break
                rules.append(("", package_dir / item, False))
    return rules


def _insert(tree: dict, parts: list[str], source: Path) -> bool:
    """Puts ``source`` at ``parts`` in ``tree`` (name -> Path or a merged folder, a
    dict) unless something is there already (folders merged); whether it added."""
    name, rest = parts[0], parts[1:]
    here = tree.get(name)
    if rest:
        if isinstance(here, Path):
            if not here.is_dir():
                return False
            here = tree[name] = {child.name: child for child in here.iterdir()}
        return _insert(tree.setdefault(name, {}), rest, source)
    if here is None:
        tree[name] = source
        return True
    if not source.is_dir() or (isinstance(here, Path) and (not here.is_dir() or here == source)):
        return False
    if isinstance(here, Path):
        here = tree[name] = {child.name: child for child in here.iterdir()}
    return any([_insert(here, [child.name], child) for child in sorted(source.iterdir())])


def _materialize(tree: dict, folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for name, node in tree.items():
        if isinstance(node, dict):
            _materialize(node, folder / name)
        else:
            (folder / name).symlink_to(node)


def installed_view(package_dir: str | os.PathLike, *, note: bool = True) -> Path:
    """The package folder as ``$(find pkg)`` sees it once installed: the source folder
    itself, unless its ``CMakeLists.txt`` installs something into ``share/<package>``
    at a path the source lacks (``install(DIRECTORY description/ros2_control
    DESTINATION share/${PROJECT_NAME})`` puts ``description/ros2_control`` at
    ``ros2_control``): then a folder of links holding the source's entries, and each
    such install at its destination (the source's own entries win). An installed
    package (no ``CMakeLists.txt``) is itself. Made once per process, removed at exit;
    with ``note``, the first use of a view is one line of the log."""
    package_dir = Path(package_dir)
    if package_dir in _views:
        view = _views[package_dir]
        if note and view != package_dir and view not in _noted:
            _noted.add(view)
            LOGGER.info(
                "package %r: its source laid out as its CMakeLists.txt installs it (%s)",
                package_dir.name,
                view,
            )
        return view
    view = package_dir
    rules = [rule for rule in install_rules(package_dir) if rule[1].exists()]
    if rules:
        tree: dict = {child.name: child for child in package_dir.iterdir()}
        added = False
        for below, source, contents in rules:
            base = [part for part in below.split("/") if part]
            items = sorted(source.iterdir()) if contents and source.is_dir() else [source]
            for item in items:
                added = _insert(tree, [*base, item.name], item) or added
        if added:
            view = _views_folder() / (
                f"{package_dir.name}-{hashlib.sha1(str(package_dir).encode()).hexdigest()[:10]}"
            )
            if view.exists():
                shutil.rmtree(view)
            _materialize(tree, view)
    _views[package_dir] = view
    return installed_view(package_dir, note=note)


def _views_folder() -> Path:
    if not _views_root:
        _views_root.append(Path(tempfile.mkdtemp(prefix="armando_drake-install-")))
        atexit.register(shutil.rmtree, _views_root[0], True)
    return _views_root[0]
