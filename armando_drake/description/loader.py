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
import os
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex

from armando_drake import DEFAULT_DESCRIPTION
from armando_drake.description.camera_sensors import parse_camera_sensors
from armando_drake.description.candidates import choose_description
from armando_drake.description.config import RobotConfig
from armando_drake.description.drive import DrivePlugin, link_friction, parse_drive_plugins
from armando_drake.description.importer import PreparedUrdf, actuation, prepare_urdf
from armando_drake.description.inertia import DEFAULT_DENSITY
from armando_drake.description.packages import (
    LOGGER,
    MISSING_PACKAGE_DIR,
    DescriptionError,
    PackageSearch,
    find_packages,
)
from armando_drake.description.ros2_control import HardwareInfo, parse_ros2_control
from armando_drake.description.sdf_robot import is_sdf_model, sdf_model_file, sdf_to_urdf
from armando_drake.description.urdf import (
    BaseWeld,
    JointInfo,
    SensorBlock,
    Transmission,
    controller_files,
    detach_world,
    parse_joints,
    parse_sensor_blocks,
    parse_transmissions,
    parse_urdf,
    repair_joints,
    strip_unused,
)

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
    """The URDF text of a ``.urdf`` or ``.xacro`` file, xacro expanded (of an SDFormat
    ``.sdf`` model: :func:`~armando_drake.description.sdf_robot.sdf_to_urdf`).

    ``mappings`` are the ``xacro:arg`` values (as on the command line,
    ``name:=value``). Errors name the file and, where xacro knows it, the line.
    """
    path = Path(path)
    if not path.is_file():
        raise DescriptionError(f"{path}: description file not found")
    if search is None:
        search = find_packages(near=path)
    if path.suffix == ".sdf":
        return sdf_to_urdf(path, search)
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
    # Every <gazebo reference=...><sensor> block (cameras too), for the sensor types
    # of armando_drake.sensors.registry.
    sensors: list[SensorBlock] = field(default_factory=list)
    # The differential drives of its <gazebo><plugin> blocks (Gazebo Sim's DiffDrive,
    # gazebo_ros_diff_drive), in URDF order.
    drives: list[DrivePlugin] = field(default_factory=list)
    # Whether the URDF fixes the robot to a `world` link (an arm); without one a mobile
    # robot's root link is free.
    world_link: bool = False
    # Per link, the friction coefficient its <gazebo reference><mu1> gives.
    friction: dict[str, float] = field(default_factory=dict)
    # Whether its base is welded to Drake's world (see weld_robot).
    welded: bool = False

    def joint(self, name: str) -> JointInfo:
        for joint in self.joints:
            if joint.name == name:
                return joint
        raise KeyError(f"joint {name!r} is not a moving joint of {self.name!r}")

    @property
    def mimic_joints(self) -> list[JointInfo]:
        """Joints that follow another one (``<mimic>``): Drake couples them, none is actuated."""
        return [joint for joint in self.joints if joint.mimic]


def is_builtin_armando(robot: LoadedRobot) -> bool:
    """Whether ``robot`` is the project's own Armando description."""
    try:
        return Path(robot.source).resolve() == DEFAULT_DESCRIPTION.resolve()
    except OSError:
        return False


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
    three folders down (``robots/fr3/fr3.urdf.xacro``); of the ``.urdf.xacro`` and
    ``.urdf`` files among them, the one the package's launch files name, else the one
    with the most links (:func:`choose_description`), the others named in one log line.
    A Gazebo model folder (``model.config`` or ``model.sdf``) is its SDFormat file.
    """

    if description is None or str(description) == "":
        return DEFAULT_DESCRIPTION
    text = str(description)
    if text.startswith("package://"):
        package, _, rest = text[len("package://") :].partition("/")
        path = search.resolve(package) / rest
    else:
        path = Path(text).expanduser()
    if path.is_dir() and is_sdf_model(path):
        return sdf_model_file(path)
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
        chosen, reason = choose_description(path, candidates)
        others = [c for c in tops if c != chosen]
        if others:
            LOGGER.info(
                "%s holds %d descriptions: using %s (others: %s); chosen as %s; "
                "name a file to choose",
                path,
                len(others) + 1,
                chosen.relative_to(path),
                ", ".join(str(c.relative_to(path)) for c in others),
                reason,
            )
        return chosen
    if not path.exists():
        raise DescriptionError(f"{path}: description file not found")
    return path


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


def _find_description(
    description: str | os.PathLike | None, package_paths: Iterable[str | os.PathLike]
) -> tuple[PackageSearch, Path]:
    """(package search, description file): the packages found near the description."""
    near = None if description is None else description
    if near is not None and str(near).startswith("package://"):
        near = None
    search = find_packages(package_paths, near=near)
    source = resolve_description(description, search)
    if near is None:
        search = find_packages(package_paths, near=source)
    search.report_shadowed()
    return search, source


def _prepare(
    urdf: str,
    search: PackageSearch,
    *,
    collision: str,
    source: Path,
    joints: list[JointInfo],
    warnings: list[str],
    density: float = DEFAULT_DENSITY,
) -> tuple[PreparedUrdf, list[BaseWeld]]:
    """(the URDF Drake loads, the links to weld): repairs, the ``world`` link taken out and
    what Drake must not see stripped; the repairs' warnings go to ``warnings``."""
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

    prepared = prepare_urdf(
        urdf, search, collision=collision, source=source, edit=edit, density=density
    )
    warnings.extend(prepared.warnings)
    return prepared, welds


def _add_model(
    plant: MultibodyPlant,
    prepared: PreparedUrdf,
    search: PackageSearch,
    *,
    model_name: str | None,
    source: Path,
) -> ModelInstanceIndex:
    """Parses the prepared URDF into ``plant``; returns its model instance."""
    parser = Parser(plant, model_name) if model_name else Parser(plant)
    parser.package_map().AddMap(search.package_map())
    try:
        (model_instance,) = parser.AddModelsFromString(prepared.urdf, "urdf")
    except Exception as error:  # Drake's parser raises RuntimeError with its diagnostic
        text = " ".join(str(error).split())  # Drake's diagnostic spans lines
        raise DescriptionError(f"{source}: Drake could not load the URDF: {text}") from None
    return model_instance


def _weld_bases(
    plant: MultibodyPlant,
    model_instance: ModelInstanceIndex,
    welds: list[BaseWeld],
    X_WB: RigidTransform | None,
    parent=None,
) -> None:
    """Welds each base link to Drake's world (or the ``parent`` frame) at ``X_WB`` times
    its joint's origin."""
    X_WD = X_WB if X_WB is not None else RigidTransform()
    for base in welds:
        plant.WeldFrames(
            plant.world_frame() if parent is None else parent,
            plant.GetFrameByName(base.link, model_instance),
            X_WD @ base.X_DL,
        )


def weld_robot(
    plant: MultibodyPlant, robot: LoadedRobot, X_WB: RigidTransform | None, parent=None
) -> None:
    """Welds the base link(s) of a robot loaded with ``weld=False`` to Drake's world (or
    the ``parent`` frame: a robot mounted on another's link) at ``X_WB`` (times each
    weld's own pose), as :func:`load_robot` does by default."""
    _weld_bases(plant, robot.model_instance, robot.welds, X_WB, parent)
    robot.welded = True


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
    density: float = DEFAULT_DENSITY,
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
    ``collision`` mode, mass and inertia repairs, links without mass at ``density``
    [kg/m^3]). Every repair is a warning,
    logged and kept in ``LoadedRobot.warnings``.
    """

    search, source = _find_description(description, package_paths)
    urdf = expand_description(source, xacro_args, search)
    root = parse_urdf(urdf, source)
    joints = parse_joints(root, source)
    hardware = parse_ros2_control(root, source=str(source))
    cameras = parse_camera_sensors(root, source=str(source))
    sensor_blocks = parse_sensor_blocks(root, source)
    warnings: list[str] = []
    interfaces, actuation_source, notes = actuation(root, hardware, joints)
    for message in notes:  # a Warning among them is one
        (LOGGER.warning if isinstance(message, Warning) else LOGGER.info)("%s: %s", source, message)
    transmissions = parse_transmissions(root)
    drives = parse_drive_plugins(root, source)
    world_link = any(link.get("name") == "world" for link in root.findall("link"))
    prepared, welds = _prepare(
        urdf,
        search,
        collision=collision,
        source=source,
        joints=joints,
        warnings=warnings,
        density=density,
    )
    model_instance = _add_model(plant, prepared, search, model_name=model_name, source=source)
    if weld:
        _weld_bases(plant, model_instance, welds, X_WB)
    robot = LoadedRobot(
        model_instance=model_instance,
        name=plant.GetModelInstanceName(model_instance),
        source=source,
        urdf=urdf,
        base_link=welds[0].link,
        joints=joints,
        ros2_control=hardware,
        cameras=cameras,
        sensors=sensor_blocks,
        packages=search,
        welds=welds,
        transmissions=transmissions,
        command_interfaces=interfaces,
        actuation_source=actuation_source,
        controller_files=controller_files(root, source),
        warnings=warnings,
        drives=drives,
        world_link=world_link,
        friction=link_friction(root),
        welded=weld,
    )
    _check_mimic_support(plant, robot)
    return robot


def base_pose(config: RobotConfig) -> RigidTransform:
    """X_WB: the pose ``base_xyz``/``base_rpy`` of the scenario's ``robot:`` section."""
    return RigidTransform(RollPitchYaw(config.base_rpy), config.base_xyz)


def AddRobot(
    plant: MultibodyPlant,
    config: RobotConfig,
    *,
    weld: bool = True,
    model_name: str | None = None,
    xacro_args: Mapping[str, str] | None = None,
) -> LoadedRobot:
    """The description of the scenario's ``robot:`` section, its base welded at
    ``base_xyz``/``base_rpy`` (:func:`load_robot`); with ``weld`` False nothing is welded
    yet (:func:`weld_robot` does, or the base stays free). ``model_name``: its model
    instance's name scope (two robots of one description need two); ``xacro_args``:
    given instead of ``config.xacro_args``."""
    return load_robot(
        plant,
        config.description or None,
        xacro_args=config.xacro_args if xacro_args is None else xacro_args,
        package_paths=config.package_paths,
        X_WB=base_pose(config),
        weld=weld,
        model_name=model_name,
        collision=config.collision,
        density=config.density,
    )
