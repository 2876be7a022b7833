"""Which robot description a package folder means, when it holds several.

``--description <package folder>`` (and ``robot.description``) may name a folder with
several ``.urdf``/``.xacro`` files: robots, and files of macros or materials only. The
choice, in order:

1. the file the package's launch files (``launch/``) or ``package.xml`` name;
2. else the file with the most links: ``<link>`` elements outside ``<xacro:macro>``
   bodies, plus the links of the files it ``xacro:include``s (a robot made of macros);
3. ties keep the folder order (``urdf/*.urdf.xacro`` first).
"""

from __future__ import annotations

import re
from pathlib import Path

LAUNCH_SUFFIXES = (".py", ".xml", ".launch", ".yaml", ".yml")
MACRO = re.compile(r"<xacro:macro\b.*?</xacro:macro>", re.S)
LINK = re.compile(r"<link\b")
INCLUDE = re.compile(r"<xacro:include\s+filename\s*=\s*\"([^\"]+)\"")


def _read(path: Path) -> str:
    try:
        return path.read_text(errors="replace")
    except OSError:
        return ""


def _launch_text(package: Path) -> str:
    """The text of the package's ``package.xml`` and launch files."""
    texts = [_read(package / "package.xml")]
    for folder in (package / "launch", package / "launch" / "include"):
        if folder.is_dir():
            for path in sorted(folder.iterdir()):
                if path.is_file() and path.suffix in LAUNCH_SUFFIXES:
                    texts.append(_read(path))
    return "\n".join(texts)


def _included(include: str, here: Path, package: Path) -> Path | None:
    """The file an ``xacro:include`` names, when it is in this package."""
    include = re.sub(r"\$\(find\s+[^)]+\)/?", "", include)
    include = re.sub(r"^package://[^/]+/", "", include)
    for base in (here.parent, package):
        if (base / include).is_file():
            return base / include
    return None


def link_count(path: Path, package: Path, depth: int = 3) -> int:
    """Links a description file makes (see the module docstring); 0 for a file of
    materials or macros only."""
    text = _read(path)
    count = len(LINK.findall(MACRO.sub("", text)))
    if depth > 0 and path.name.endswith(".xacro"):
        for include in INCLUDE.findall(text):
            found = _included(include, path, package)
            if found is not None and found != path:
                count += len(LINK.findall(_read(found))) + link_count(found, package, depth - 1)
    return count


def choose_description(package: Path, candidates: list[Path]) -> tuple[Path, str]:
    """The description ``package`` means among ``candidates`` (in folder order), and
    why (words for the log line)."""
    launch = _launch_text(package)
    named = [c for c in candidates if re.search(rf"(?<![\w.-]){re.escape(c.name)}\b", launch)]
    pool = named or candidates
    counts = {c: link_count(c, package) for c in pool}
    chosen = max(pool, key=lambda c: counts[c])  # the first of the most links
    if named:
        return chosen, "named by the package's launch files or package.xml"
    return chosen, f"the most links: {counts[chosen]}"
