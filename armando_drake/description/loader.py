"""Robot descriptions: finding ROS packages, expanding xacro, loading into Drake.

Every entry point turns a description into Drake through :func:`load_robot`:

1. :func:`find_packages` builds the package search path into a Drake
   ``PackageMap``: the package of the description the user named first (an
   edited copy of a package wins over the original), then ``--package-path``,
   ``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH``, the folders around the
   description, the project's ``models/`` last; a package hidden by an earlier
   one of the same name is reported once;
2. :func:`expand_description` runs the real ``xacro`` processor with
   ``$(find pkg)`` resolved through that map;
3. :func:`load_robot` repairs meaningless joint values (:func:`repair_joints`),
   takes a ``world`` link out and welds what was fixed to it
   (:func:`detach_world`), adds the URDF to a ``MultibodyPlant`` and returns a
   :class:`LoadedRobot` summary: joints (limits, damping, mimic), the
   ``<ros2_control>`` blocks, ROS 1 and ROS 2 transmissions, the command
   interfaces of each actuated joint, the controller YAML a ``<gazebo>``
   plugin names, the camera sensors, and every warning.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import PackageMap, Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex

from armando_drake import MODELS_DIR
from armando_drake.description.ros2_control import HardwareInfo, parse_ros2_control

LOGGER = logging.getLogger("armando_drake.description")
# What $(find pkg) gives for a package that is not found: a folder that does not exist.
MISSING_PACKAGE_DIR = Path("/nonexistent-ros-package")


class DescriptionError(RuntimeError):
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


# --------------------------------------------------------------------------
# Xacro
# --------------------------------------------------------------------------


@contextlib.contextmanager
def _xacro_find(search: PackageSearch, missing: list[str]):
    """Lets the PyPI ``xacro`` resolve ``$(find pkg)`` through our search.

    An unknown package is appended to ``missing`` and stands for a folder that
    does not exist (:data:`MISSING_PACKAGE_DIR`): a ``<gazebo>`` block naming a
    bringup package's YAML must not stop the description from loading; an
    include or a mesh from it still fails, naming the package.
    """
    from xacro import substitution_args

    def eval_find(pkg: str) -> str:
        if pkg not in search.packages:
            if pkg not in missing:
                missing.append(pkg)
            return str(MISSING_PACKAGE_DIR / pkg)
        return str(search.resolve(pkg))

    saved = substitution_args._eval_find, substitution_args._eval_dict.get("find")
    substitution_args._eval_find = eval_find
    substitution_args._eval_dict["find"] = eval_find
    try:
        yield
    finally:
        substitution_args._eval_find = saved[0]
        substitution_args._eval_dict["find"] = saved[1]


def _xacro_error(path: Path, error: BaseException) -> DescriptionError:
    """A one-paragraph message naming the file (and line) of a xacro failure."""
    import xacro

    files = [str(f) for f in (xacro.filestack or []) if f]
    where = files[-1] if files else str(path)
    from xml.parsers.expat import ExpatError

    line = error.lineno if isinstance(error, ExpatError) else None
    cause = error
    while getattr(cause, "exc", None) is not None and cause.exc is not cause:
        cause = cause.exc
    if isinstance(cause, DescriptionError):
        text = str(cause)
    else:
        text = str(error)
    if line is None and isinstance(cause, ExpatError):
        line = cause.lineno
    text = "; ".join(part.strip() for part in text.strip().splitlines() if part.strip())
    location = f"{where}:{line}" if line else where
    chain = ""
    if len(files) > 1:
        chain = " (included from " + " <- ".join(reversed(files[:-1])) + ")"
    macros = [m.body.getAttribute("name") for m in (xacro.macrostack or [])]
    if macros:
        chain += " in macro " + " <- ".join(reversed(macros))
    return DescriptionError(f"{location}: xacro error{chain}: {text}")


def _root_arg_defaults(path: Path, given: Mapping[str, str]) -> dict[str, str]:
    """Defaults of the ``xacro:arg``s used in the ``<robot>`` tag's own attributes.

    xacro evaluates ``<robot name="$(arg name)">`` before it reads the
    ``<xacro:arg name="name" default=..>`` inside, so a description written
    that way (ur_description, for one) only expands when the launch file passes
    the argument. Here the declared default is used, as it would be anywhere
    else in the file (plain defaults only: one holding ``$(..)`` or ``${..}``
    is left to xacro).
    """
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError):
        return {}
    import re

    used = {
        name
        for value in root.attrib.values()
        for name in re.findall(r"\$\(arg\s+([^)\s]+)\s*\)", value)
        if name not in given
    }
    defaults = {}
    for element in root:
        if element.tag.endswith("}arg") or element.tag == "xacro:arg":
            name, default = element.get("name"), element.get("default")
            if name in used and default is not None and "$" not in default:
                defaults[name] = default
    return defaults


def expand_description(
    path: str | os.PathLike,
    mappings: Mapping[str, str] | None = None,
    search: PackageSearch | None = None,
) -> str:
    """The URDF text of a ``.urdf`` or ``.xacro`` file, xacro expanded.

    ``mappings`` are the ``xacro:arg`` values (as on the command line,
    ``name:=value``). Errors name the file and, where xacro knows it, the line.
    """
    path = Path(path)
    if not path.is_file():
        raise DescriptionError(f"{path}: description file not found")
    if search is None:
        search = find_packages(near=path)
    if path.suffix != ".xacro":
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError as error:
            raise DescriptionError(
                f"{path}: not a text (UTF-8) file: byte {error.start} is "
                f"{error.object[error.start]:#x}"
            ) from None
        if "xmlns:xacro" not in text and not mappings:
            return text
    import xacro

    args = {str(k): str(v) for k, v in (mappings or {}).items()}
    args.update(_root_arg_defaults(path, args))
    missing: list[str] = []
    try:
        with _xacro_find(search, missing):
            doc = xacro.process_file(str(path), mappings=args)
    except Exception as error:  # xacro raises XacroException, ExpatError, NameError...
        failure = _xacro_error(path, error)
        if missing:
            unknown = ", ".join(repr(name) for name in missing)
            searched = "; ".join(search.searched) or "(no search path)"
            failure = DescriptionError(
                f"{failure}; $(find) of unknown package {unknown} (searched {searched})"
            )
        raise failure from None
    finally:
        xacro.init_stacks(None)
    text = doc.toprettyxml(indent="  ")
    for name in missing:
        LOGGER.warning(
            "%s: $(find %s): unknown package (searched %s); it stands for %s, which does not "
            "exist, so whatever the description takes from it is not used",
            path,
            name,
            "; ".join(search.searched),
            MISSING_PACKAGE_DIR / name,
        )
    return text


# --------------------------------------------------------------------------
# Loading into Drake
# --------------------------------------------------------------------------


@dataclass
class JointInfo:
    """A non-fixed joint of the description, with its URDF limits (repaired, see load_robot)."""

    name: str
    type: str  # revolute | continuous | prismatic
    lower: float  # [rad] or [m], -inf if unlimited
    upper: float  # [rad] or [m], +inf if unlimited
    effort: float  # [N m] or [N], inf if not given or 0 (Gazebo's "no limit")
    velocity: float  # [rad/s] or [m/s], inf if not given or 0
    damping: float = 0.0  # [N m s/rad] or [N s/m], <dynamics damping>, simulated by Drake
    friction: float = 0.0  # [N m] or [N], <dynamics friction>, NOT simulated (Drake has none)
    mimic: str | None = None  # the joint this one follows (<mimic joint=..>), None if none
    mimic_multiplier: float = 1.0  # q = multiplier * q_mimicked + offset
    mimic_offset: float = 0.0  # [rad] or [m]
    parent: str = ""  # parent link
    child: str = ""  # child link


# ROS 1 ``hardware_interface/...JointInterface`` -> the ros2_control command interface.
HARDWARE_INTERFACES = {
    "PositionJointInterface": "position",
    "VelocityJointInterface": "velocity",
    "EffortJointInterface": "effort",
}


@dataclass
class Transmission:
    """A ``<transmission>`` block: ROS 1 (top level) or ROS 2 (inside ``<ros2_control>``)."""

    name: str
    type: str  # e.g. transmission_interface/SimpleTransmission (ROS 2: the <plugin>)
    # joint -> its command interfaces, from ROS 1 <hardwareInterface> mapped with
    # HARDWARE_INTERFACES (others, such as franka_hw/FrankaStateInterface, left out);
    # empty for ROS 2
    joints: dict[str, list[str]] = field(default_factory=dict)
    # joint -> the <hardwareInterface> texts as written (ROS 1),
    # e.g. "hardware_interface/EffortJointInterface"
    hardware_interfaces: dict[str, list[str]] = field(default_factory=dict)
    mechanical_reduction: float = 1.0  # actuator turns per joint turn, as written
    ros2_control: str = ""  # the <ros2_control name> holding it; "" for a ROS 1 block


@dataclass
class BaseWeld:
    """A link welded to Drake's world, and where, in the description's own world frame."""

    link: str
    X_DL: RigidTransform  # pose of the link in the description's world frame D
    joint: str = ""  # the fixed joint from the URDF's `world` link; "" for a plain root link


@dataclass
class LoadedRobot:
    """What :func:`load_robot` put into the plant, and what the URDF says of it."""

    model_instance: ModelInstanceIndex
    name: str  # the URDF robot name (the model instance name)
    source: Path  # the description file
    urdf: str  # the expanded URDF text (as xacro wrote it, before any repair)
    base_link: str  # the first link welded to the world
    joints: list[JointInfo]  # non-fixed joints, in URDF order
    ros2_control: list[HardwareInfo]
    cameras: list  # camera sensor blocks, see armando_drake.sensors.camera
    packages: PackageSearch
    # Every link welded to Drake's world (several when a `world` link holds several).
    welds: list[BaseWeld] = field(default_factory=list)
    # ROS 1 top-level and ROS 2 (in <ros2_control>) <transmission> blocks.
    transmissions: list[Transmission] = field(default_factory=list)
    # Actuated joint -> its command interfaces (position, velocity, effort, ...), from
    # <ros2_control>, else the transmissions' hardware_interface, else ["position"];
    # mimic joints are never actuated. Insertion order is the actuation order.
    command_interfaces: dict[str, list[str]] = field(default_factory=dict)
    # Where command_interfaces came from: "ros2_control", "transmission" or "non-fixed joints".
    actuation_source: str = ""
    # Controller YAML files named by <gazebo><plugin><parameters> (gazebo_ros2_control,
    # gz_ros2_control), in URDF order; the controller configuration when the user gives none.
    controller_files: list[Path] = field(default_factory=list)
    # What loading repaired, ignored or could not use, one line each (also logged).
    warnings: list[str] = field(default_factory=list)

    def joint(self, name: str) -> JointInfo:
        for joint in self.joints:
            if joint.name == name:
                return joint
        raise KeyError(f"joint {name!r} is not a moving joint of {self.name!r}")

    @property
    def mimic_joints(self) -> list[JointInfo]:
        """Joints that follow another one (``<mimic>``): Drake couples them, none is actuated."""
        return [joint for joint in self.joints if joint.mimic]


def _description_files(folder: Path, depth: int = 3) -> list[Path]:
    """Top-level description files (``*.urdf.xacro``, ``*.urdf``) below ``folder``."""
    found = []
    for path in sorted(folder.rglob("*")):
        relative = path.relative_to(folder)
        if len(relative.parts) > depth or any(
            part.startswith(".") or part in ("build", "install", "log", "test")
            for part in relative.parts[:-1]
        ):
            continue
        if path.is_file() and path.name.endswith((".urdf.xacro", ".urdf")):
            found.append(path)
    return found


def resolve_description(description: str | os.PathLike | None, search: PackageSearch) -> Path:
    """The description file meant by a path, a package dir or ``package://pkg/file``.

    In a package directory: ``urdf/*.urdf.xacro``, ``urdf/*.xacro``,
    ``urdf/*.urdf``, ``*.urdf*``, else any ``*.urdf.xacro`` or ``*.urdf`` up to
    three folders down (``robots/fr3/fr3.urdf.xacro``); the first in that order,
    the others named in the log.
    """
    from armando_drake import DEFAULT_DESCRIPTION

    if description is None or str(description) == "":
        return DEFAULT_DESCRIPTION
    text = str(description)
    if text.startswith("package://"):
        package, _, rest = text[len("package://") :].partition("/")
        path = search.resolve(package) / rest
    else:
        path = Path(text).expanduser()
    if path.is_dir():
        urdf_dir = path / "urdf"
        candidates = sorted(urdf_dir.glob("*.urdf.xacro")) + sorted(urdf_dir.glob("*.xacro"))
        candidates += sorted(urdf_dir.glob("*.urdf")) + sorted(path.glob("*.urdf*"))
        candidates = list(dict.fromkeys(candidates)) or _description_files(path)
        if not candidates:
            raise DescriptionError(
                f"{path}: no .urdf or .xacro file in {urdf_dir}, {path} or the folders below"
            )
        tops = [c for c in candidates if c.name.endswith((".urdf.xacro", ".urdf"))]
        others = [c for c in tops if c != candidates[0]]
        if others:
            LOGGER.info(
                "%s holds %d descriptions: using %s (others: %s); name a file to choose",
                path,
                len(others) + 1,
                candidates[0].relative_to(path),
                ", ".join(str(c.relative_to(path)) for c in others),
            )
        return candidates[0]
    if not path.exists():
        raise DescriptionError(f"{path}: description file not found")
    return path


def _float(value: str | None, default: float) -> float:
    return default if value in (None, "") else float(value)


def _link_of(joint: ET.Element, tag: str) -> str:
    element = joint.find(tag)
    return "" if element is None else element.get("link", "")


def parse_joints(root: ET.Element, source: str | os.PathLike = "") -> list[JointInfo]:
    """The non-fixed joints of a URDF, with their limits as written; errors name
    ``source``."""
    joints = []
    for element in root.findall("joint"):
        kind = element.get("type", "")
        if kind in ("fixed", "floating", "planar", ""):
            continue
        limit = element.find("limit")
        get = (lambda key: None) if limit is None else limit.get
        dynamics = element.find("dynamics")
        dyn = (lambda key: None) if dynamics is None else dynamics.get
        mimic = element.find("mimic")
        unlimited = kind == "continuous"
        name = element.get("name", "")
        try:
            joints.append(
                JointInfo(
                    name=name,
                    type=kind,
                    lower=-np.inf if unlimited else _float(get("lower"), -np.inf),
                    upper=np.inf if unlimited else _float(get("upper"), np.inf),
                    effort=_float(get("effort"), np.inf),
                    velocity=_float(get("velocity"), np.inf),
                    damping=_float(dyn("damping"), 0.0),
                    friction=_float(dyn("friction"), 0.0),
                    mimic=None if mimic is None else mimic.get("joint"),
                    mimic_multiplier=1.0 if mimic is None else _float(mimic.get("multiplier"), 1.0),
                    mimic_offset=0.0 if mimic is None else _float(mimic.get("offset"), 0.0),
                    parent=_link_of(element, "parent"),
                    child=_link_of(element, "child"),
                )
            )
        except ValueError as error:
            where = f"{source}: " if source else ""
            raise DescriptionError(f"{where}joint {name!r}: {error}") from None
    return joints


def _pose(element: ET.Element, where: str) -> RigidTransform:
    origin = element.find("origin")
    if origin is None:
        return RigidTransform()
    try:
        xyz = [float(v) for v in (origin.get("xyz") or "0 0 0").split()]
        rpy = [float(v) for v in (origin.get("rpy") or "0 0 0").split()]
        return RigidTransform(RollPitchYaw(rpy), xyz)
    except (ValueError, TypeError) as error:
        raise DescriptionError(f"{where}: bad <origin>: {error}") from None


def detach_world(root: ET.Element, source: str | os.PathLike = "<urdf>") -> list[BaseWeld]:
    """Takes the URDF's ``world`` link out of ``root``; returns the links to weld to Drake's world.

    Gazebo descriptions fix the arm to a link named ``world``. Each fixed joint
    from it is removed and its child is to be welded at that joint's origin;
    a moving joint from it is kept, hung on a massless link ``world_anchor``
    that is welded at the identity. Without a ``world`` link the one root
    link is welded at the identity. Errors name the links: no root left, or
    more than one tree.
    """
    where = str(source)
    links = [link.get("name", "") for link in root.findall("link")]
    welds: list[BaseWeld] = []
    if "world" in links:
        for joint in list(root.findall("joint")):
            if _link_of(joint, "child") == "world":
                raise DescriptionError(
                    f"{where}: joint {joint.get('name')!r} has the `world` link as its child; "
                    "`world` can only be a parent"
                )
            if _link_of(joint, "parent") != "world":
                continue
            if joint.get("type") == "fixed":
                welds.append(
                    BaseWeld(
                        _link_of(joint, "child"),
                        _pose(joint, f"{where}: joint {joint.get('name')!r}"),
                        joint.get("name", ""),
                    )
                )
                root.remove(joint)
            else:
                anchor = "world_anchor"
                while anchor in links:
                    anchor += "_"
                joint.find("parent").set("link", anchor)
                if all(w.link != anchor for w in welds):
                    welds.append(BaseWeld(anchor, RigidTransform(), ""))
                    ET.SubElement(root, "link", name=anchor)
        for link in root.findall("link"):
            if link.get("name") == "world":
                root.remove(link)
        links = [link.get("name", "") for link in root.findall("link")]
        if not welds:
            raise DescriptionError(
                f"{where}: the `world` link holds no joint: nothing of the robot is attached to it"
            )
    children = {_link_of(joint, "child") for joint in root.findall("joint")}
    roots = [name for name in links if name not in children]
    welded = {weld.link for weld in welds}
    if not links:
        raise DescriptionError(f"{where}: the URDF has no links")
    if not roots:
        raise DescriptionError(
            f"{where}: the URDF has no root link: every link ({', '.join(links)}) is the child "
            "of a joint, so the joints form a loop"
        )
    if welds:
        loose = [name for name in roots if name not in welded]
        if loose:
            raise DescriptionError(
                f"{where}: link(s) {', '.join(loose)} are attached neither to the `world` link "
                f"nor to the robot on it ({', '.join(sorted(welded))}): two disconnected trees"
            )
        return welds
    if len(roots) > 1:
        raise DescriptionError(
            f"{where}: the URDF has {len(roots)} root links ({', '.join(roots)}): two "
            "disconnected trees; join them with a joint, or fix each to a `world` link"
        )
    return [BaseWeld(roots[0], RigidTransform(), "")]


def repair_joints(
    root: ET.Element, joints: list[JointInfo], source: str | os.PathLike = "<urdf>"
) -> list[str]:
    """Repairs physically meaningless joint values in ``root`` and ``joints``; one warning each.

    - lower limit above upper: swapped (Drake refuses such a joint);
    - ``effort="0"``: Gazebo applies no effort limit; neither do we (effort = inf);
    - negative effort or velocity: its magnitude;
    - ``velocity="0"``: no velocity limit (inf);
    - ``<dynamics friction>``: reported, Drake simulates no joint friction.
    """
    warnings = []
    elements = {joint.get("name"): joint for joint in root.findall("joint")}
    for info in joints:
        where = f"{source}: joint {info.name!r}"
        limit = elements[info.name].find("limit") if info.name in elements else None
        if info.lower > info.upper:
            warnings.append(
                f"{where}: lower limit {info.lower:g} is above upper {info.upper:g}: swapped"
            )
            info.lower, info.upper = info.upper, info.lower
            if limit is not None:
                limit.set("lower", repr(info.lower))
                limit.set("upper", repr(info.upper))
        if info.effort == 0:
            warnings.append(
                f'{where}: effort="0", which Gazebo takes as no effort limit: '
                "its actuator here has no effort limit either"
            )
            info.effort = math.inf
        elif info.effort < 0:
            warnings.append(f"{where}: effort={info.effort:g} is negative: using {-info.effort:g}")
            info.effort = -info.effort
            if limit is not None:
                limit.set("effort", repr(info.effort))
        if info.velocity == 0:
            warnings.append(f'{where}: velocity="0": taken as no velocity limit')
            info.velocity = math.inf
            if limit is not None:
                del limit.attrib["velocity"]
        elif info.velocity < 0:
            warnings.append(
                f"{where}: velocity={info.velocity:g} is negative: using {-info.velocity:g}"
            )
            info.velocity = -info.velocity
            if limit is not None:
                limit.set("velocity", repr(info.velocity))
        if info.friction:
            warnings.append(
                f"{where}: <dynamics friction={info.friction:g}> is not simulated (Drake has "
                f"no joint friction); damping={info.damping:g} is"
            )
            dynamics = elements[info.name].find("dynamics") if info.name in elements else None
            if dynamics is not None:
                dynamics.attrib.pop("friction", None)  # said once, here, not again by Drake
        if info.damping < 0:
            warnings.append(f"{where}: damping={info.damping:g} is negative: using 0")
            info.damping = 0.0
            elements[info.name].find("dynamics").set("damping", "0")
    names = {info.name for info in joints}
    for info in joints:
        if info.mimic and info.mimic not in names:
            raise DescriptionError(
                f"{source}: joint {info.name!r} mimics {info.mimic!r}, which is not a moving "
                "joint of the URDF"
            )
    return warnings


def parse_transmissions(root: ET.Element) -> list[Transmission]:
    """ROS 1 top-level ``<transmission>`` blocks and ROS 2 ones inside ``<ros2_control>``."""
    result = []
    for block, holder in [(t, "") for t in root.findall("transmission")] + [
        (t, r.get("name", ""))
        for r in root.findall("ros2_control")
        for t in r.findall("transmission")
    ]:
        kind = (block.findtext("type") or block.findtext("plugin") or "").strip()
        transmission = Transmission(name=block.get("name", ""), type=kind, ros2_control=holder)
        reduction = next(
            (
                text
                for path in (
                    "actuator/mechanicalReduction",
                    "joint/mechanicalReduction",
                    "actuator/mechanical_reduction",
                    "joint/mechanical_reduction",
                )
                if (text := block.findtext(path))
            ),
            None,
        )
        with contextlib.suppress(TypeError, ValueError):
            transmission.mechanical_reduction = float(reduction)
        for joint in block.findall("joint"):
            written = [(e.text or "").strip() for e in joint.findall("hardwareInterface") if e.text]
            written += [
                (e.text or "").strip()
                for e in block.findall("actuator/hardwareInterface")
                if e.text and not written
            ]
            interfaces = []
            for text in written:
                short = text.rsplit("/", 1)[-1]
                if short in HARDWARE_INTERFACES:  # not e.g. franka_hw/FrankaStateInterface
                    interfaces.append(HARDWARE_INTERFACES[short])
            name = joint.get("name", "")
            transmission.joints[name] = list(dict.fromkeys(interfaces))
            transmission.hardware_interfaces[name] = written
        result.append(transmission)
    return result


def controller_files(root: ET.Element, source: str | os.PathLike = "<urdf>") -> list[Path]:
    """The controller YAML files named in ``<gazebo><plugin><parameters>`` blocks.

    gazebo_ros2_control and gz_ros2_control read their controller configuration
    from there; a relative path is taken relative to the description's folder.
    """
    files = []
    base = Path(source).parent
    for plugin in root.findall("gazebo/plugin"):
        for parameters in plugin.findall("parameters"):
            text = (parameters.text or "").strip()
            if not text:
                continue
            path = Path(text.removeprefix("file://")).expanduser()
            if not path.is_absolute():
                path = base / path
            if path.suffix.lower() in (".yaml", ".yml"):
                files.append(path)
    return files


# Tags of ROS tools that mean nothing to Drake: (parent tag, child tag) -> what they are.
UNUSED_TAGS = {
    ("joint", "safety_controller"): "soft limits of ROS 1's safety controller",
    ("joint", "calibration"): "encoder calibration",
    ("link", "self_collision_checking"): "MoveIt's self-collision shapes",
}


def strip_unused(root: ET.Element, source: str | os.PathLike = "<urdf>") -> list[str]:
    """Removes the tags of :data:`UNUSED_TAGS`; one note per kind, naming how many and where."""
    notes = []
    for (parent_tag, tag), meaning in UNUSED_TAGS.items():
        owners = []
        for parent in root.findall(parent_tag):
            found = parent.findall(tag)
            for element in found:
                parent.remove(element)
            if found:
                owners.append(parent.get("name", ""))
        if owners:
            notes.append(
                f"{source}: <{tag}> ({meaning}) ignored on {len(owners)} {parent_tag}(s): "
                + ", ".join(owners)
            )
    return notes


def parse_urdf(urdf: str, source: str | os.PathLike = "<string>") -> ET.Element:
    """The XML root of a URDF text; errors name the source and line."""
    try:
        root = ET.fromstring(urdf)
    except ET.ParseError as error:
        raise DescriptionError(f"{source}: not valid XML: {error}") from None
    if root.tag != "robot":
        raise DescriptionError(
            f"{source}: not a URDF: the root element is <{root.tag}>, not <robot>"
        )
    return root


def _warn(warnings: list[str], message: str) -> None:
    LOGGER.warning("%s", message)
    warnings.append(message)


def _check_mimic_support(plant: MultibodyPlant, robot: LoadedRobot) -> None:
    """Says so when the plant cannot couple the mimic joints (only SAP can)."""
    if not robot.mimic_joints:
        return
    from pydrake.multibody.plant import DiscreteContactSolver

    names = ", ".join(f"{j.name} (follows {j.mimic})" for j in robot.mimic_joints)
    if plant.time_step() > 0 and plant.get_discrete_contact_solver() != DiscreteContactSolver.kSap:
        _warn(
            robot.warnings,
            f"{robot.source}: mimic joints {names} are NOT coupled: Drake couples them only "
            "with the SAP solver; plant_config.discrete_contact_approximation="
            f"{plant.get_discrete_contact_approximation()!s} ('tamsi') cannot: they move freely",
        )
    else:
        LOGGER.info("%s: mimic joints coupled by Drake constraints: %s", robot.source, names)


def load_robot(
    plant: MultibodyPlant,
    description: str | os.PathLike | None = None,
    *,
    xacro_args: Mapping[str, str] | None = None,
    package_paths: Iterable[str | os.PathLike] = (),
    X_WB: RigidTransform | None = None,
    weld: bool = True,
    model_name: str | None = None,
    collision: str = "auto",
) -> LoadedRobot:
    """Adds a robot description to ``plant`` and returns its summary.

    ``description`` is a ``.urdf``/``.xacro`` file, a package directory or a
    ``package://pkg/file`` URL (default: the built-in Armando). Packages are
    found by :func:`find_packages`, the description's own package first. A
    ``world`` link is taken out (:func:`detach_world`): each link fixed to it
    is welded to Drake's world at ``X_WB`` times that joint's origin; without
    one, the root link is welded at ``X_WB``. Nothing is welded when ``weld``
    is False. Meaningless joint values are repaired (:func:`repair_joints`),
    then the URDF goes through
    :func:`armando_drake.description.importer.prepare_urdf` (mesh conversion,
    ``collision`` mode, mass and inertia repairs). Every repair is a warning,
    logged and kept in ``LoadedRobot.warnings``.
    """
    from armando_drake.description.importer import actuation, prepare_urdf
    from armando_drake.sensors.camera import parse_camera_sensors

    near = None if description is None else description
    if near is not None and str(near).startswith("package://"):
        near = None
    search = find_packages(package_paths, near=near)
    source = resolve_description(description, search)
    if near is None:
        search = find_packages(package_paths, near=source)
    search.report_shadowed()
    urdf = expand_description(source, xacro_args, search)
    root = parse_urdf(urdf, source)
    joints = parse_joints(root, source)
    hardware = parse_ros2_control(root, source=str(source))
    cameras = parse_camera_sensors(root, source=str(source))
    warnings: list[str] = []
    interfaces, actuation_source, notes = actuation(root, hardware, joints)
    for message in notes:  # a Warning among them is one
        (LOGGER.warning if isinstance(message, Warning) else LOGGER.info)("%s: %s", source, message)
    transmissions = parse_transmissions(root)
    welds: list[BaseWeld] = []

    def edit(tree: ET.Element) -> None:
        """Repairs, the `world` link and what Drake must not see, on the tree Drake loads."""
        for message in repair_joints(tree, joints, source):
            _warn(warnings, message)
        welds.extend(detach_world(tree, source))
        for message in strip_unused(tree, source):
            LOGGER.info("%s", message)
        # The hardware interface makes the actuators from what we parsed; Drake's own
        # transmission actuators would duplicate them.
        for element in tree.findall("transmission"):
            tree.remove(element)

    prepared = prepare_urdf(urdf, search, collision=collision, source=source, edit=edit)
    warnings += prepared.warnings
    parser = Parser(plant, model_name) if model_name else Parser(plant)
    parser.package_map().AddMap(search.package_map())
    try:
        (model_instance,) = parser.AddModelsFromString(prepared.urdf, "urdf")
    except Exception as error:  # Drake's parser raises RuntimeError with its diagnostic
        text = " ".join(str(error).split())  # Drake's diagnostic spans lines
        raise DescriptionError(f"{source}: Drake could not load the URDF: {text}") from None
    X_WD = X_WB if X_WB is not None else RigidTransform()
    if weld:
        for base in welds:
            plant.WeldFrames(
                plant.world_frame(),
                plant.GetFrameByName(base.link, model_instance),
                X_WD @ base.X_DL,
            )
    robot = LoadedRobot(
        model_instance=model_instance,
        name=plant.GetModelInstanceName(model_instance),
        source=source,
        urdf=urdf,
        base_link=welds[0].link,
        joints=joints,
        ros2_control=hardware,
        cameras=cameras,
        packages=search,
        welds=welds,
        transmissions=transmissions,
        command_interfaces=interfaces,
        actuation_source=actuation_source,
        controller_files=controller_files(root, source),
        warnings=warnings,
    )
    _check_mimic_support(plant, robot)
    return robot
