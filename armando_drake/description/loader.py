"""Robot descriptions: finding ROS packages, expanding xacro, loading into Drake.

Every entry point turns a description into Drake through :func:`load_robot`:

1. :func:`find_packages` builds the package search path (explicit entries,
   ``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH``, the project's ``models/``, the
   tree around the description) into a Drake ``PackageMap``;
2. :func:`expand_description` runs the real ``xacro`` processor with
   ``$(find pkg)`` resolved through that map;
3. :func:`load_robot` adds the URDF to a ``MultibodyPlant`` with ``package://``
   resolution, welds the base to the world and returns a :class:`LoadedRobot`
   summary with the ``<ros2_control>`` block and the camera sensors.
"""

from __future__ import annotations

import contextlib
import os
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import PackageMap, Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex

from armando_drake import MODELS_DIR
from armando_drake.description.ros2_control import HardwareInfo, parse_ros2_control


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


def _package_name(package_xml: Path) -> str | None:
    try:
        root = ET.parse(package_xml).getroot()
    except (ET.ParseError, OSError):
        return None
    name = root.findtext("name")
    return name.strip() if name else None


def _scan(root: Path, found: dict[str, Path], max_depth: int = 4) -> None:
    """Adds every package below ``root`` (up to ``max_depth``) not found before."""
    if not root.is_dir():
        return
    stack = [(root, 0)]
    while stack:
        folder, depth = stack.pop()
        package_xml = folder / "package.xml"
        if package_xml.is_file():
            name = _package_name(package_xml)
            if name and name not in found:
                found[name] = folder.resolve()
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


def find_packages(
    package_paths: Iterable[str | os.PathLike] = (), near: str | os.PathLike | None = None
) -> PackageSearch:
    """Finds ROS packages, earlier sources winning over later ones.

    Order: ``package_paths``; ``ROS_PACKAGE_PATH``; ``AMENT_PREFIX_PATH``
    (``share/<pkg>``); the project's ``models/``; the folders around ``near``
    (the package holding it and its parent's siblings).
    """
    search = PackageSearch()
    found = search.packages

    def scan(label: str, root: Path, depth: int = 4) -> None:
        search.searched.append(f"{label}: {root}")
        _scan(root, found, depth)

    for entry in package_paths:
        scan("--package-path", Path(entry).expanduser())
    for entry in filter(None, os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep)):
        scan("ROS_PACKAGE_PATH", Path(entry))
    for entry in filter(None, os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep)):
        scan("AMENT_PREFIX_PATH", Path(entry) / "share", depth=1)
    scan("project models", MODELS_DIR)
    if near is not None:
        here = Path(near).resolve()
        folder = here if here.is_dir() else here.parent
        # The package that holds the file, then its siblings.
        for candidate in [folder, *folder.parents][:4]:
            if (candidate / "package.xml").is_file():
                scan("package of the description", candidate, depth=0)
                scan("next to that package", candidate.parent, depth=2)
                break
        else:
            scan("folder of the description", folder, depth=2)
    return search


# --------------------------------------------------------------------------
# Xacro
# --------------------------------------------------------------------------


@contextlib.contextmanager
def _xacro_find(search: PackageSearch):
    """Lets the PyPI ``xacro`` resolve ``$(find pkg)`` through our search."""
    from xacro import substitution_args

    def eval_find(pkg: str) -> str:
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
        text = path.read_text()
        if "xmlns:xacro" not in text and not mappings:
            return text
    import xacro

    args = {str(k): str(v) for k, v in (mappings or {}).items()}
    try:
        with _xacro_find(search):
            doc = xacro.process_file(str(path), mappings=args)
    except DescriptionError as error:
        raise _xacro_error(path, error) from None
    except Exception as error:  # xacro raises XacroException, ExpatError, NameError...
        raise _xacro_error(path, error) from None
    finally:
        xacro.init_stacks(None)
    return doc.toprettyxml(indent="  ")


# --------------------------------------------------------------------------
# Loading into Drake
# --------------------------------------------------------------------------


@dataclass
class JointInfo:
    """A non-fixed joint of the description, with its URDF limits."""

    name: str
    type: str  # revolute | continuous | prismatic
    lower: float  # [rad] or [m], -inf if unlimited
    upper: float  # [rad] or [m], +inf if unlimited
    effort: float  # [N m] or [N], inf if not given
    velocity: float  # [rad/s] or [m/s], inf if not given


@dataclass
class LoadedRobot:
    """What :func:`load_robot` put into the plant, and what the URDF says of it."""

    model_instance: ModelInstanceIndex
    name: str  # the URDF robot name (the model instance name)
    source: Path  # the description file
    urdf: str  # the expanded URDF text
    base_link: str
    joints: list[JointInfo]  # non-fixed joints, in URDF order
    ros2_control: list[HardwareInfo]
    cameras: list  # camera sensor blocks, see armando_drake.sensors.camera
    packages: PackageSearch

    def joint(self, name: str) -> JointInfo:
        for joint in self.joints:
            if joint.name == name:
                return joint
        raise KeyError(f"joint {name!r} is not a moving joint of {self.name!r}")


def resolve_description(description: str | os.PathLike | None, search: PackageSearch) -> Path:
    """The description file meant by a path, a package dir or ``package://pkg/file``."""
    from armando_drake import DEFAULT_DESCRIPTION

    if description is None or str(description) == "":
        return DEFAULT_DESCRIPTION
    text = str(description)
    if text.startswith("package://"):
        package, _, rest = text[len("package://") :].partition("/")
        return search.resolve(package) / rest
    path = Path(text).expanduser()
    if path.is_dir():
        urdf_dir = path / "urdf"
        candidates = sorted(urdf_dir.glob("*.urdf.xacro")) + sorted(urdf_dir.glob("*.xacro"))
        candidates += sorted(urdf_dir.glob("*.urdf")) + sorted(path.glob("*.urdf*"))
        if not candidates:
            raise DescriptionError(f"{path}: no .urdf or .xacro file in {urdf_dir} or {path}")
        return candidates[0]
    if not path.exists():
        raise DescriptionError(f"{path}: description file not found")
    return path


def _float(value: str | None, default: float) -> float:
    return default if value in (None, "") else float(value)


def parse_joints(root: ET.Element) -> list[JointInfo]:
    """The non-fixed joints of a URDF, with their limits."""
    joints = []
    for element in root.findall("joint"):
        kind = element.get("type", "")
        if kind in ("fixed", "floating", "planar", ""):
            continue
        limit = element.find("limit")
        get = (lambda key: None) if limit is None else limit.get
        unlimited = kind == "continuous"
        joints.append(
            JointInfo(
                name=element.get("name", ""),
                type=kind,
                lower=-np.inf if unlimited else _float(get("lower"), -np.inf),
                upper=np.inf if unlimited else _float(get("upper"), np.inf),
                effort=_float(get("effort"), np.inf),
                velocity=_float(get("velocity"), np.inf),
            )
        )
    return joints


def _root_link(root: ET.Element) -> str:
    links = [link.get("name") for link in root.findall("link")]
    children = {j.findtext("child") or (j.find("child").get("link")) for j in root.findall("joint")}
    roots = [name for name in links if name not in children and name != "world"]
    if not roots:
        raise DescriptionError("the URDF has no root link")
    return roots[0]


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
    ``package://pkg/file`` URL (default: the built-in Armando). The root link is
    welded to the world at ``X_WB`` unless ``weld`` is False. Before Drake parses
    it, the URDF goes through :func:`armando_drake.description.importer.prepare_urdf` (mesh
    conversion, ``collision`` mode, inertia repairs).
    """
    from armando_drake.sensors.camera import parse_camera_sensors

    near = None if description is None else description
    if near is not None and str(near).startswith("package://"):
        near = None
    search = find_packages(package_paths, near=near)
    source = resolve_description(description, search)
    if near is None:
        search = find_packages(package_paths, near=source)
    urdf = expand_description(source, xacro_args, search)
    root = parse_urdf(urdf, source)
    joints = parse_joints(root)
    hardware = parse_ros2_control(root, source=str(source))
    cameras = parse_camera_sensors(root, source=str(source))
    base_link = _root_link(root)

    from armando_drake.description.importer import prepare_urdf

    prepared = prepare_urdf(urdf, search, collision=collision, source=source)
    parser = Parser(plant, model_name) if model_name else Parser(plant)
    parser.package_map().AddMap(search.package_map())
    try:
        (model_instance,) = parser.AddModelsFromString(prepared.urdf, "urdf")
    except Exception as error:  # Drake's parser raises RuntimeError with its diagnostic
        raise DescriptionError(f"{source}: Drake could not load the URDF: {error}") from None
    if weld:
        plant.WeldFrames(
            plant.world_frame(),
            plant.GetFrameByName(base_link, model_instance),
            X_WB if X_WB is not None else RigidTransform(),
        )
    return LoadedRobot(
        model_instance=model_instance,
        name=plant.GetModelInstanceName(model_instance),
        source=source,
        urdf=urdf,
        base_link=base_link,
        joints=joints,
        ros2_control=hardware,
        cameras=cameras,
        packages=search,
    )
