"""A mobile base in a world: what spawning a wheeled robot in Gazebo sets up.

:func:`AddMobileBase` decides how the robot's base is held once its description and
controller YAML are read (before the plant is finalized):

- **fixed** (an arm): welded to the world at the scenario's ``base_xyz``/``base_rpy``,
  as the loader always did;
- **floating** (a mobile robot): the root link is a free body spawned there, as
  ``ros_gz_sim create -x -y -z -Y`` spawns it; it falls onto its wheels and rests there.
  ``robot.base: auto`` floats a description without a ``world`` link that drives wheels:
  a differential drive in its ``<gazebo><plugin>`` blocks or a drive controller
  (the diff drive controller of ros2_controllers) in its controller YAML.

On a floating base with a drive:

- the drive's wheels are velocity joints (Drake's PD actuator with kp = 0: the velocity
  servo that Gazebo's ``JointVelocityCmd`` and ros2_control's velocity interface are), at
  a gain that makes the URDF's joint damping negligible (:data:`WHEEL_SERVO_GAIN`, at
  least 1000 times the damping), within the joint's effort limit (and a classic plugin's
  wheel torque);
- contact friction: a link's ``<gazebo reference><mu1>`` where the description gives one;
  the wheels 1.0 otherwise; a sphere on a link that is not a wheel (a caster) slides with
  :data:`CASTER_FRICTION`, as a caster's free swivel lets it;
- each ``<gazebo><plugin>`` drive becomes a controller of the controller manager (named
  ``diff_drive``, ``diff_drive_2``, ...; its command topic is the plugin's, ``/cmd_vel``),
  activated with the robot as Gazebo loads it, unless an activated controller of the
  scenario already claims its wheels.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Sequence

import numpy as np
from pydrake.geometry import Cylinder, ProximityProperties, RoleAssign, SceneGraph, Sphere
from pydrake.multibody.plant import CoulombFriction, MultibodyPlant

from armando_drake.control.config import (
    ControllerConfig,
    ControllerManagerConfig,
    validate_joints,
)
from armando_drake.control.controllers import ControllerJoints, find_controller
from armando_drake.control.controllers.diff_drive import PluginDiffDrive, _Drive
from armando_drake.description.config import RobotConfig
from armando_drake.description.drive import DrivePlugin
from armando_drake.description.loader import LoadedRobot, base_pose, weld_robot
from armando_drake.tools.errors import ScenarioError

_log = logging.getLogger("armando_drake.world")

# [N m s/rad] the wheels' velocity servo gain (at least 1000 times the joint's damping):
# Gazebo sets a commanded wheel velocity outright; a stiff implicit servo does the same
# within the motor's torque.
WHEEL_SERVO_GAIN = 100.0
# [-] the friction of a caster sphere: it swivels and rolls, so it hardly resists.
CASTER_FRICTION = 0.01
# [-] the wheels' friction where the description gives none (Gazebo's default mu).
WHEEL_FRICTION = 1.0


@dataclasses.dataclass
class DrivePluginEntry(ControllerConfig):
    """A ``<gazebo><plugin>`` drive as an entry of the controller YAML."""

    drive: DrivePlugin | None = None

    @property
    def controller_class(self) -> type:
        return PluginDiffDrive

    @property
    def ros_topic(self) -> str:
        topic = self.drive.topic
        return topic if topic.startswith("/") else f"/{topic}"


@dataclasses.dataclass
class MobileBase:
    """How the robot's base is held, and its drives."""

    floating: bool
    base_link: str = ""  # the free body (floating) or the welded link
    drives: list[str] = dataclasses.field(default_factory=list)  # drive controllers by name
    plugins: list[str] = dataclasses.field(default_factory=list)  # those from <gazebo><plugin>
    wheels: list[str] = dataclasses.field(default_factory=list)  # every drive's wheel joints
    gains: dict[str, list[float]] = dataclasses.field(default_factory=dict)  # wheel servos

    def activation(self, activate: Sequence[str]) -> list[str]:
        """``activate`` with the plugin drives that run added; with neither a plugin nor
        one of the controller file's drives among them, the file's first drive too (as
        its bring-up spawns it), said in one line."""
        active = list(activate) + [name for name in self.plugins if name not in activate]
        own = [name for name in self.drives if name not in self.plugins]
        if own and not self.plugins and not set(own) & set(active):
            _log.info("drive: the controller file's own %r takes cmd_vel", own[0])
            active.append(own[0])
        return active


def _running(plugins: list[str], activate: Sequence[str], config: ControllerManagerConfig):
    """The plugin drives Gazebo would run: those whose wheels no activated controller
    claims (that one drives them then)."""
    claimed = set()
    for entry in activate:
        try:
            name = find_controller(entry, config)
        except LookupError:
            continue  # reported by the controller manager
        controller = config.controllers.get(name)
        if controller is not None and controller.supported and name not in plugins:
            claimed |= set(controller.joints)
    running = []
    for name in plugins:
        if set(config.controllers[name].joints) & claimed:
            _log.info("%s is not run: an activated controller drives its wheels", name)
        else:
            running.append(name)
    return running


def _drive_controllers(config: ControllerManagerConfig) -> list[ControllerConfig]:
    return [
        c
        for c in config.controllers.values()
        if c.supported and issubclass(c.controller_class, _Drive)
    ]


def _decide(config: RobotConfig, robot: LoadedRobot, drives: bool, where: str) -> bool:
    if config.base == "fixed":
        return False
    if config.base == "floating":
        return True
    if robot.world_link and drives:
        _log.info(
            "%s: the description fixes the robot to a `world` link: its base is welded (set "
            "robot.base: floating to free it)",
            robot.source,
        )
    return drives and not robot.world_link


def _set_friction(plant, scene_graph, robot: LoadedRobot, wheels: set[str]) -> None:
    """Each collision geometry's friction: the link's <mu1>, else a wheel's default, a
    caster sphere's, or as loaded."""
    inspector = scene_graph.model_inspector()
    wheel_links = {robot.joint(name).child for name in wheels}
    source = plant.get_source_id()
    for index in plant.GetBodyIndices(robot.model_instance):
        body = plant.get_body(index)
        link = body.name()
        for geometry in plant.GetCollisionGeometriesForBody(body):
            if link in robot.friction:
                mu = robot.friction[link]
            elif link in wheel_links:
                mu = WHEEL_FRICTION
            elif isinstance(inspector.GetShape(geometry), Sphere):
                mu = CASTER_FRICTION
                _log.info("%s: link %r: a caster sphere, friction %g", robot.source, link, mu)
            else:
                continue
            properties = ProximityProperties(inspector.GetProximityProperties(geometry))
            friction = CoulombFriction(mu, mu)
            if properties.HasProperty("material", "coulomb_friction"):
                properties.UpdateProperty("material", "coulomb_friction", friction)
            else:
                properties.AddProperty("material", "coulomb_friction", friction)
            scene_graph.AssignRole(source, geometry, properties, RoleAssign.kReplace)


def _wheel_geometry(plant, scene_graph, robot: LoadedRobot, left, right):
    """(separation, radius) [m] of the wheels' collision geometry: the distance along the
    axle between the left and right wheels' centres, and their mean cylinder or sphere
    radius; None where the geometry does not tell (wheels on different parents, no
    cylinder or sphere)."""
    inspector = scene_graph.model_inspector()
    centres, axes, radii, parents = {}, [], [], set()
    for side, joints in (("left", left), ("right", right)):
        points = []
        for name in joints:
            joint = plant.GetJointByName(name, robot.model_instance)
            if not hasattr(joint, "revolute_axis"):
                return None
            X_PJ = joint.frame_on_parent().GetFixedPoseInBodyFrame()
            parents.add(joint.parent_body().index())
            axes.append(X_PJ.rotation() @ joint.revolute_axis())
            for geometry in plant.GetCollisionGeometriesForBody(joint.child_body()):
                shape = inspector.GetShape(geometry)
                if isinstance(shape, (Cylinder, Sphere)):
                    radii.append(shape.radius())
                points.append((X_PJ @ inspector.GetPoseInFrame(geometry)).translation())
        if not points:
            return None
        centres[side] = sum(points) / len(points)
    if len(parents) != 1:
        return None
    axis = axes[0] / max(1e-12, float(abs(axes[0] @ axes[0])) ** 0.5)
    separation = abs(float((centres["left"] - centres["right"]) @ axis))
    return separation, (sum(radii) / len(radii) if radii else None)


def _wheel_sides(plant, robot: LoadedRobot, left, right) -> list[str]:
    """What is mirrored in the wheels' placement, as sentences: "left" wheels on the
    base's right (-y), or a wheel whose positive turn rolls it backwards (-x)."""
    found = []
    lateral = {}
    for side, joints in (("left", left), ("right", right)):
        ys = []
        for name in joints:
            joint = plant.GetJointByName(name, robot.model_instance)
            if not hasattr(joint, "revolute_axis"):
                return []
            X_PJ = joint.frame_on_parent().GetFixedPoseInBodyFrame()
            ys.append(X_PJ.translation()[1])
            rolls = float(np.cross(X_PJ.rotation() @ joint.revolute_axis(), [0.0, 0.0, 1.0])[0])
            if rolls < -1e-6:
                found.append(f"a positive turn of {side} wheel {name!r} rolls it backwards")
        lateral[side] = sum(ys) / max(1, len(ys))
    if lateral["left"] < lateral["right"]:
        found.append(
            "its left wheels are on the base's right (-y): a commanded left turn turns right"
        )
    return found


def _check_kinematics(plant, scene_graph, robot, name: str, left, right, separation, radius):
    """Warns where a drive's wheel separation or radius is not its wheels' geometry: the
    robot then drives (and its odometry errs) as it would in Gazebo."""
    geometry = _wheel_geometry(plant, scene_graph, robot, left, right)
    if geometry is None:
        return
    actual_separation, actual_radius = geometry
    effects = []
    if abs(separation - actual_separation) > 0.05 * actual_separation:
        effects.append(
            f"wheel_separation={separation:g} m, but the wheels are {actual_separation:.4g} m "
            f"apart: it turns {separation / actual_separation:.3g} times the commanded yaw rate"
        )
    if actual_radius and abs(radius - actual_radius) > 0.05 * actual_radius:
        effects.append(
            f"wheel_radius={radius:g} m, but the wheels' is {actual_radius:.4g} m: it drives "
            f"{actual_radius / radius:.3g} times the commanded speed"
        )
    for effect in effects:
        _log.warning(
            "%s: %s: %s, and its odometry errs as much (as in Gazebo)", robot.source, name, effect
        )
    for mirrored in _wheel_sides(plant, robot, left, right):
        _log.warning(
            "%s: %s: %s (as in Gazebo; its odometry does not see it)", robot.source, name, mirrored
        )


def _plugin_entries(robot: LoadedRobot, config: ControllerManagerConfig) -> list[str]:
    """The description's plugin drives added to ``config`` as controllers; their names."""
    names = []
    for k, drive in enumerate(robot.drives):
        if not drive.base_frame:  # Gazebo Sim's default: the model's canonical link
            drive = dataclasses.replace(drive, base_frame=robot.base_link)
        name = "diff_drive" if k == 0 else f"diff_drive_{k + 1}"
        while name in config.controllers:
            name += "_plugin"
        config.controllers[name] = DrivePluginEntry(
            name=name,
            type=drive.filename or drive.name,
            joints=list(drive.joints),
            params=drive,
            key=drive.where,
            drive=drive,
        )
        names.append(name)
        _log.info(
            "%s: %s drives %s (wheel separation %g m, radius %g m) on /%s",
            robot.source,
            name,
            ", ".join(drive.joints),
            drive.wheel_separation,
            drive.wheel_radius,
            drive.topic.lstrip("/"),
        )
    return names


def _wheel_servos(robot: LoadedRobot, base: MobileBase, config: ControllerManagerConfig):
    """The wheels become velocity joints with a stiff servo within their torque limit."""
    torque: dict[str, float] = {}
    for name in base.plugins:
        drive = config.controllers[name].drive
        for joint in drive.joints:
            torque[joint] = min(torque.get(joint, math.inf), drive.max_wheel_torque)
            given = robot.command_interfaces.get(joint)
            if given != ["velocity"]:
                _log.info(
                    "%s: joint %r is driven by %s through its velocity (was: %s)",
                    robot.source,
                    joint,
                    name,
                    ", ".join(given) if given else "not actuated",
                )
            robot.command_interfaces[joint] = ["velocity"]
    if robot.actuation_source == "non-fixed joints":  # no interface declared: velocity
        for joint in base.wheels:
            robot.command_interfaces[joint] = ["velocity"]
    for index, info in enumerate(robot.joints):
        if info.name in base.wheels:
            effort = min(info.effort, torque.get(info.name, math.inf))
            robot.joints[index] = dataclasses.replace(info, effort=effort)
            gain = max(WHEEL_SERVO_GAIN, 1000.0 * info.damping)
            base.gains[info.name] = [0.0, gain]


def AddMobileBase(
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    robot: LoadedRobot,
    config: RobotConfig,
    controller_config: ControllerManagerConfig,
    *,
    activate: Sequence[str] = (),
    where: str = "",
    parent=None,
) -> MobileBase:
    """Welds the robot (loaded with ``weld=False``) at ``config``'s base pose, or spawns it
    there free (see the module docstring); returns its :class:`MobileBase`. ``activate``:
    the scenario's controllers to activate (a plugin drive whose wheels one of them claims
    does not run); ``where``: the origin of ``robot.base`` for messages; ``parent``: a
    frame of another robot the base is welded to (at ``config``'s pose in it)."""
    plugins = _plugin_entries(robot, controller_config)
    yaml_drives = [c.name for c in _drive_controllers(controller_config) if c.name not in plugins]
    # The drives' wheels are joints of the robot (the others are checked with the hardware).
    drives_only = dataclasses.replace(
        controller_config,
        controllers={name: controller_config.controllers[name] for name in yaml_drives},
    )
    validate_joints(drives_only, [joint.name for joint in robot.joints], str(robot.source))
    floating = parent is None and _decide(config, robot, bool(plugins or yaml_drives), where)
    base = MobileBase(floating=floating, base_link=robot.base_link)
    base.plugins = _running(plugins, activate, controller_config)
    base.drives = base.plugins + yaml_drives
    base.wheels = list(
        dict.fromkeys(j for name in base.drives for j in controller_config.controllers[name].joints)
    )
    _wheel_servos(robot, base, controller_config)
    for name in base.drives:
        entry = controller_config.controllers[name]
        logic = entry.controller_class(
            name=name, joints=ControllerJoints.make(entry.joints), params=entry.params
        )
        left = [j for j, is_left in zip(logic.joint_names, logic.left_rows, strict=True) if is_left]
        right = [j for j in logic.joint_names if j not in left]
        _check_kinematics(
            plant, scene_graph, robot, name, left, right, logic.separation, logic.left_radius
        )
    X_WB = base_pose(config)
    if not floating:  # an arm; or a mobile robot on a stand, its wheels turning in the air
        weld_robot(plant, robot, X_WB, parent)
        return base
    if config.base == "floating" and len(robot.welds) > 1:
        raise ScenarioError(
            f"{where}robot.base=floating: the `world` link holds {len(robot.welds)} links "
            f"({', '.join(w.link for w in robot.welds)}); only one can float"
        )
    body = plant.GetBodyByName(robot.base_link, robot.model_instance)
    plant.SetDefaultFloatingBaseBodyPose(body, X_WB @ robot.welds[0].X_DL)
    _set_friction(plant, scene_graph, robot, set(base.wheels))
    _log.info(
        "%s: floating base %r spawned at xyz %s rpy %s",
        robot.name,
        robot.base_link,
        list(config.base_xyz),
        list(config.base_rpy),
    )
    return base
