"""The robot's ros2_control stack in a world: what ``controller_manager`` and
``gz_ros2_control`` set up in a ROS 2 launch.

:func:`LoadControllerConfig` finds the controller YAML (the scenario's, the
description's ``<gazebo><plugin>``'s, the package's, or a generated default);
:func:`AddHardware` gives the robot its actuators and finalizes the plant;
:func:`AddControllerManager` loads and activates the scenario's controllers
in one :class:`~armando_drake.control.manager.ControllerManager` and returns a
:class:`ControlStack`, the handle every subsystem above connects to (command
inputs by controller name, the controllers' joints, the effort state);
:func:`ConnectControlStack` wires the commands to the plant.
"""

import dataclasses as dc
import logging
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from pydrake.geometry import CollisionFilterDeclaration, SceneGraph
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder, InputPort, OutputPort

from armando_drake.control.config import (
    ControllerConfig,
    ControllerConfigError,
    ControllerManagerConfig,
    check_update_rate,
    file_generation,
    load_controller_config,
    parse_controller_config,
    validate_joints,
)
from armando_drake.control.controllers import (
    DEFAULT_CONTROLLERS,
    ControllerJoints,
    controller_type_for,
    default_controller_config,
    find_controller,
    lookup,
)
from armando_drake.control.gains import (
    DAMPING_RATIO,
    MAX_DAMPING,
    MAX_GAIN,
    NATURAL_FREQUENCY,
    GainRule,
    JointGains,
    derive_gains,
    gains_table,
)
from armando_drake.control.hardware import (
    AddEffortState,
    AddHardwareInterface,
    ConnectHardwareInterface,
    FinishHardwareInterface,
    HardwareInterface,
    HardwareJoint,
    command_interfaces,
)
from armando_drake.control.manager import (
    AddStreamDesiredState,
    ControllerManager,
    ManagedController,
)
from armando_drake.control.sequencer import (
    JointTrajectoryTargets,
    PositionTargets,
    Sinusoid,
    stream_controller,
)
from armando_drake.control.topics import RegisterControllerTopics
from armando_drake.description.loader import LoadedRobot, is_builtin_armando
from armando_drake.description.packages import installed_view, package_of
from armando_drake.messages.publications import PublicationRegistry
from armando_drake.messages.types import Float64MultiArray, JointTrajectory
from armando_drake.tools.errors import ScenarioError
from armando_drake.tools.schema import Refusal, param

_log = logging.getLogger("armando_drake.world")


# No `from __future__ import annotations` here: yaml_load_typed reads the
# dataclass field types at run time and does not resolve string annotations.


_TOO_STIFF = "stiffer than any real servo, it throws the joint against its limits"


@dc.dataclass
class ActuatorConfig:
    """The simulated position interface: Drake PD-controlled joint actuators."""

    # Proportional gain of every position joint [N m/rad]; null (the default): each
    # joint's own, derived from the robot's inertia, gravity and effort limits
    # (control/gains.py, docs/physics.md); the built-in Armando's servos: 8.
    kp: float | None = param(None, unit="N m/rad", gt=0, over=(MAX_GAIN, _TOO_STIFF))
    # Derivative gain of every position joint [N m s/rad]; null (the default): each
    # joint's own, the damping ratio below at its inertia; the built-in Armando's: 0.4.
    kd: float | None = param(None, unit="N m s/rad", ge=0, over=(MAX_DAMPING, _TOO_STIFF))
    # Velocity gain of every joint with a velocity command interface [N m s/rad]: the
    # torque per rad/s of velocity error of its damping-only servo (kp = 0).
    kv: float = param(1.0, unit="N m s/rad", ge=0, over=(MAX_DAMPING, _TOO_STIFF))
    # Per-joint gains overriding kp and kd, as joint: [kp, kd] (a velocity joint:
    # [0, kv]) [N m/rad, N m s/rad]; each pair checked by check().
    gains: dict[str, list[float]] = param({}, unit="N m/rad, N m s/rad")
    # Natural frequency of the derived gains [rad/s]: kp >= M wn^2 at the joint's
    # largest inertia M.
    natural_frequency: float = param(
        NATURAL_FREQUENCY, unit="rad/s", gt=0, over=(1e4, "no servo loop is that fast")
    )
    # Damping ratio of the derived gains [-]: kd = 2 zeta sqrt(kp M) (less the URDF damping).
    damping_ratio: float = param(DAMPING_RATIO, unit="-", gt=0, over=(100.0, "all damping"))
    # Adds the torque that holds the arm against gravity at the commanded
    # position, through the actuation input, so the steady-state error does not
    # depend on how stiff the gains are.
    gravity_feedforward: bool = True
    # Caps each joint at its URDF <limit velocity> on every command interface, as
    # Gazebo's physics does (docs/physics.md); false lifts the cap.
    velocity_limits: bool = True

    def check(self) -> None:
        """Each per-joint pair [kp, kd]: two gains, zero or positive, no stiffer than a
        servo (whether the joint exists is checked against the robot)."""
        for joint, gains in self.gains.items():
            key = f"gains.{joint}"
            if len(gains) != 2:
                raise Refusal(key, f"={gains!r} must be two numbers [kp, kd]")
            kp, kd = gains
            if kp < 0 or kd < 0:
                raise Refusal(key, f"={gains!r}: gains must be zero or positive")
            if kp > MAX_GAIN or kd > MAX_DAMPING:
                raise Refusal(
                    key,
                    f"={gains!r}: {max(kp, kd)!r} is above {MAX_GAIN:g}: {_TOO_STIFF}",
                )


@dc.dataclass
class ControllersConfig:
    """The ros2_control controller manager."""

    # The controller parameter file(s), a path or a list read in order (later values
    # win, as ``--param-file`` takes them); empty: the description's <gazebo> plugin's,
    # else the description package's config/*controller*.yaml, else a generated default.
    config: list[str] = dc.field(default_factory=list)
    # The launch arguments ``$(var name)`` stands for in the parameter files (default:
    # robot.xacro_args, then the defaults the launch files of the file's package declare).
    arguments: dict[str, str] = dc.field(default_factory=dict)
    # Controllers to activate, by name, in order. Empty: none (the arm falls).
    activate: list[str] = dc.field(default_factory=list)
    # Rate of the controller manager [Hz], overriding the YAML's update_rate; 0 = the
    # YAML's.
    update_rate: int = param(0, unit="Hz")
    # [-] Per trajectory controller (by name), the speed scaling factor it starts with,
    # overriding its YAML's speed_scaling.initial_scaling_factor (>= 0; 1.0 = full speed).
    speed_scaling: dict[str, float] = param({}, unit="-")

    def check(self) -> None:
        """Each speed scaling factor is finite and >= 0."""
        for name, factor in self.speed_scaling.items():
            if not (math.isfinite(factor) and factor >= 0):
                raise Refusal(f"speed_scaling.{name}", f"={factor!r} must be >= 0")


@dc.dataclass
class ControlStack:
    """The robot's hardware interface and controllers in a diagram being built: what
    the subsystems above (sequencer, task, jog, logger, bridges) connect to."""

    plant: MultibodyPlant
    robot: LoadedRobot
    hardware: HardwareInterface
    config: ControllerManagerConfig  # the controller YAML
    update_rate: int  # [Hz] the controller manager's rate
    manager: ControllerManager | None = None  # broadcaster and command controllers
    # Active command controllers by name -> the system whose ports are
    # "<name>.<topic>" and "<name>.status" (the manager).
    controllers: dict[str, ControllerManager] = dc.field(default_factory=dict)
    controller_joints: dict[str, list[str]] = dc.field(default_factory=dict)  # by name
    broadcaster_name: str = ""  # the active joint state broadcaster's name in the YAML
    # The hardware's effort state interface: the torque each actuator applied over the
    # last plant step (AddEffortState), read by the broadcaster and the logger.
    effort_state: OutputPort | None = None
    # The controller whose commands are a C++ stream (a sinusoid) that drives the
    # hardware directly, without the manager's update; "" if none.
    stream_controller: str = ""
    # The plant's scene graph, for the collision checks of the seed targets (None: none).
    scene_graph: SceneGraph | None = None
    # Whether, with no command controller active, the hardware holds every joint at its
    # start position (the robot's own controllers cannot run); else nothing drives it.
    hold: bool = False
    # The robot's namespace in a world of several robots ("/left"); "" for the only one.
    namespace: str = ""

    def port_name(self, name: str) -> str:
        """``name`` as a port of the world's diagram: under the robot's namespace
        (``left/joint_states``) when it has one."""
        space = self.namespace.strip("/")
        return f"{space}/{name}" if space else name

    @property
    def broadcaster(self) -> ControllerManager | None:
        """The system with the ``joint_states`` output, when a broadcaster is active."""
        return self.manager if self.broadcaster_name else None

    @property
    def joint_states_topic(self) -> str:
        """The broadcaster's JointState topic, relative to the namespace: ``joint_states``,
        or ``<broadcaster>/joint_states`` with its ``use_local_topics`` (``~/joint_states``)."""
        logic = self.manager.broadcaster if self.manager is not None else None
        if logic is not None and getattr(logic.params, "use_local_topics", False):
            return f"{self.broadcaster_name}/joint_states"
        return "joint_states"

    def entry(self, name: str) -> ControllerConfig:
        """The YAML entry of controller ``name``."""
        return self.config.controllers[name]

    def command_input(self, name: str) -> InputPort:
        """The command input ``<name>.<topic>`` of active controller ``name``."""
        return self.controllers[name].GetInputPort(f"{name}.{self.entry(name).topic}")

    def taking(self, message: type, *, position_targets: bool = False) -> list[str]:
        """The active command controllers that read ``message`` (and, with
        ``position_targets``, take positions as targets), in activation order."""
        return [
            name
            for name in self.controllers
            if self.entry(name).controller_class.message is message
            and (not position_targets or self.entry(name).position_targets)
        ]

    def joints_of(self, joints: Sequence[str]) -> list[HardwareJoint]:
        """The hardware joints named ``joints``, in that order."""
        return [self.hardware.joints[i] for i in self.hardware.find(joints)]


def LoadControllerConfig(
    config: ControllersConfig,
    robot: LoadedRobot,
    *,
    arguments: dict[str, str] | None = None,
    prefix: str = "",
) -> ControllerManagerConfig:
    """The controller parameter files of ``config``, of the description's
    ``<gazebo><plugin>`` ``<parameters>``, of the description package
    (:func:`package_controller_files`), or a default on the joints the hardware
    interface will actuate. ``arguments``: the launch arguments of ``$(var name)``
    (``config.arguments`` win). Read leniently: a controller whose parameters cannot
    be used fails only when activated. ``prefix``: the description's ``prefix`` xacro
    argument; a file naming its joints without it is read with it
    (:func:`~armando_drake.control.config.load_controller_config`)."""
    arguments = {**(arguments or {}), **config.arguments}
    joint_names = [joint.name for joint in robot.joints]

    def load(files):
        return load_controller_config(
            files, strict=False, arguments=arguments, prefix=prefix, joint_names=joint_names
        )

    if config.config:
        return load([Path(path).expanduser() for path in config.config])
    named = [path for path in robot.controller_files if path.is_file()]
    for missing in robot.controller_files:
        if not missing.is_file():
            _log.warning(
                "the description's <gazebo> plugin names %s, which does not exist", missing
            )
    if named:
        _log.info(
            "controller configuration from the description's <gazebo> plugin: %s",
            ", ".join(map(str, named)),
        )
        return load(named)
    candidates = package_controller_files(robot)
    if candidates:
        _log.info("controller configuration of the package: %s", ", ".join(map(str, candidates)))
        return load(candidates)
    actuated = list(command_interfaces(robot, warn=False)[2])
    if not actuated:
        raise ScenarioError(
            f"{robot.source}: the description actuates no joint (read from "
            f"{robot.actuation_source}): nothing for a controller to command"
        )
    data = default_controller_config(actuated)
    return parse_controller_config(data, source=f"<default controllers of {robot.name}>")


# Parameter files of a package that hold no ros2_control controllers: MoveIt's, and the
# demos' command publishers.
_NOT_CONTROLLER_FILES = ("moveit", "fake_controller", "publisher", "simple_controller")


def package_controller_files(robot: LoadedRobot) -> list[Path]:
    """The controller files of the description's package, as an install lays it out
    (:func:`~armando_drake.description.packages.installed_view`): its
    ``config/*controller*.yaml``, those naming the robot first. ROS 2: the first, as
    a launch file names one; ROS 1: every one, as a launch file loads a file per
    controller (a joint_state_controller file and an arm's), merged."""
    package_dir = package_of(robot.source)
    if package_dir is None:
        return []
    folder = installed_view(package_dir, note=False) / "config"
    files = sorted(
        path.resolve()  # the package's own file, named in messages
        for path in folder.glob("*.y*ml")
        if "controller" in path.stem and not any(s in path.stem for s in _NOT_CONTROLLER_FILES)
    )
    files.sort(key=lambda path: robot.name.lower() not in path.stem.lower())
    if not files:
        return []
    try:
        generations = {path: file_generation(path) for path in files}
    except ControllerConfigError:
        return files[:1]  # its error is reported when it is read
    ros1 = [path for path in files if generations[path] == 1]
    ros2 = [path for path in files if generations[path] == 2]
    return ros2[:1] if ros2 else ros1 or files[:1]


# --------------------------------------------------------------------------------------
# The controllers a run activates


@dc.dataclass
class ControllerChoice:
    """What :func:`choose_controllers` decided: the controllers to activate, the
    sequencer that drives them, and whether the hardware holds the arm instead."""

    activate: list[str]
    sequencer: object
    hold: bool = False


def arm_controllers(config: ControllerManagerConfig) -> list[ControllerConfig]:
    """The supported controllers of ``config`` that a sequence of position targets can
    drive, in the order a run prefers them: joint trajectory controllers, then
    forward position groups, each with the most joints first (the arm before a
    gripper), in the file's order."""
    found = []
    for controller in config.controllers.values():
        if not controller.supported or controller.controller_class.broadcaster:
            continue
        message = controller.controller_class.message
        if controller.position_targets and message in (JointTrajectory, Float64MultiArray):
            found.append(controller)
    return sorted(
        found,
        key=lambda c: (c.controller_class.message is not JointTrajectory, -len(c.joints)),
    )


def _sequencer_for(controller: ControllerConfig, current):
    """The sequencer that drives ``controller``: ``current`` turned into the kind it
    takes, keeping its targets, period, cyclic and start delay (a sinusoid as it is on
    a position group; on a trajectory controller, the seed targets)."""
    kind = (
        JointTrajectoryTargets
        if controller.controller_class.message is JointTrajectory
        else PositionTargets
    )
    if isinstance(current, kind) or (kind is PositionTargets and isinstance(current, Sinusoid)):
        return current
    if isinstance(current, (PositionTargets, JointTrajectoryTargets)):
        return kind(
            targets=current.targets,
            period=current.period,
            cyclic=current.cyclic,
            start_delay=current.start_delay,
        )
    return kind()


def _add_default_broadcaster(config: ControllerManagerConfig) -> str:
    """Adds the registry's joint state broadcaster (on every joint) to ``config``, for a
    file that has none; its name."""
    name = "joint_state_broadcaster"
    type_name = controller_type_for("broadcaster", ros=config.ros)
    cls = lookup(type_name, ros=config.ros)
    config.controllers[name] = ControllerConfig(
        name, type_name, [], cls.default_parameters(None), {}, "<added>", ros=config.ros
    )
    return name


def choose_controllers(
    activate: Sequence[str], config: ControllerManagerConfig, sequencer, where: str = ""
) -> ControllerChoice:
    """The controllers a run activates for the scenario's ``activate``, given the robot's
    controller file ``config``: each name the file defines, and ``type:<plugin>`` as it
    is. A default name the file lacks (:data:`DEFAULT_CONTROLLERS`:
    ``joint_state_broadcaster``, ``position_controller``, ``trajectory_controller``)
    stands for the file's controller of that role: its broadcaster (the registry's,
    added, if it has none), its arm controller (:func:`arm_controllers`), driven by
    ``sequencer`` turned into the kind it takes; a file without one the simulation
    supports leaves the arm held at its start position. Each such choice is one line
    of the log."""
    chosen, hold = [], False
    broadcasters = [
        name
        for name, c in config.controllers.items()
        if c.supported and c.controller_class.broadcaster
    ]
    for entry in activate:
        kind = DEFAULT_CONTROLLERS.get(entry)
        wants_broadcaster = kind == "broadcaster" or (
            entry.startswith("type:") and _names_broadcaster(entry)
        )
        if entry in config.controllers or (kind is None and not wants_broadcaster):
            chosen.append(entry)
        elif wants_broadcaster:
            if not broadcasters:
                broadcasters.append(_add_default_broadcaster(config))
                _log.info(
                    "%s defines no joint state broadcaster: %r added on every joint",
                    config.source,
                    broadcasters[0],
                )
            elif not entry.startswith("type:"):
                _log.info(
                    "%s: %r runs as the joint state broadcaster", config.source, broadcasters[0]
                )
            chosen.append(broadcasters[0] if not entry.startswith("type:") else entry)
        else:
            arms = arm_controllers(config)
            if not arms:
                hold, sequencer = True, None
                unsupported = [
                    f"{name} ({c.type or 'unusable'})"
                    for name, c in config.controllers.items()
                    if not c.supported
                ]
                _log.warning(
                    "%s defines no arm controller the simulation supports%s: the arm holds "
                    "its start position",
                    config.source,
                    f" (not supported: {', '.join(unsupported)})" if unsupported else "",
                )
                continue
            arm = arms[0]
            sequencer = _sequencer_for(arm, sequencer)
            chosen.append(arm.name)
            _log.info(
                "%s has no %r: driving its %r (%s on %s) with the scenario's targets",
                config.source,
                entry,
                arm.name,
                arm.type,
                ", ".join(arm.joints),
            )
    return ControllerChoice(chosen, sequencer, hold)


def _names_broadcaster(entry: str) -> bool:
    try:
        return lookup(entry[len("type:") :]).broadcaster
    except KeyError:
        return False


def controller_update_rate(
    yaml_config: ControllerManagerConfig, config: ControllersConfig, where: str
) -> int:
    """The controller manager's rate [Hz]: the YAML's, or ``config``'s override."""
    if not config.update_rate:
        return yaml_config.update_rate
    try:
        return check_update_rate(config.update_rate, f"{where}controllers")
    except ControllerConfigError as error:
        raise ScenarioError(str(error)) from None


def _yaml_gains(
    config: ControllerManagerConfig, interfaces: dict[str, str]
) -> dict[str, list[float]]:
    """Per-joint actuator gains from a ROS 1 file's ``gazebo_ros_control/pid_gains``:
    [kp, kd] = [p, d] on a position joint, [0, kv] = [0, p] on a velocity joint (Drake's
    implicit PD, so no integral: ``i`` is noted and dropped); effort joints take none,
    as in Gazebo."""
    gains = {}
    for joint, (p, i, d) in config.pid_gains.items():
        interface = interfaces.get(joint)
        if interface == "position":
            gains[joint] = [p, d]
        elif interface == "velocity":
            gains[joint] = [0.0, p]
        else:
            _log.warning(
                "%s: gazebo_ros_control/pid_gains/%s: %s; ignored",
                config.source,
                joint,
                "an effort joint (Gazebo closes no loop on it)"
                if interface
                else "not an actuated joint of the robot",
            )
            continue
        if i:
            _log.info(
                "%s: gazebo_ros_control/pid_gains/%s: i=%g not simulated (Drake's PD actuator)",
                config.source,
                joint,
                i,
            )
    if gains:
        _log.info(
            "actuator gains from %s: %s",
            config.source,
            ", ".join(f"{joint} {values}" for joint, values in gains.items()),
        )
    return gains


def AddHardware(
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    robot: LoadedRobot,
    actuators: ActuatorConfig,
    config: ControllerManagerConfig,
    *,
    self_collision: bool = False,
    start_positions: Sequence[tuple[Sequence[float], str, str]] = (),
) -> HardwareInterface:
    """The actuators of the hardware interface; finalizes the plant. A position joint's
    gains: the scenario's ``actuators.gains`` for it, else the controller YAML's
    ``gazebo_ros_control`` ones, else ``actuators.kp``/``kd``, each one that is null
    derived from the robot (:mod:`armando_drake.control.gains`; the built-in Armando's
    servos: :data:`ARMANDO_GAINS`). Each of ``start_positions`` is (positions [rad] in
    hardware order, their origin, their key): the joints start there. Several robots in
    one plant: :func:`BeginHardware` for each, ``plant.Finalize()``, then
    :func:`FinishHardware` for each."""
    pending = BeginHardware(plant, robot, actuators, config)
    plant.Finalize()
    return FinishHardware(
        plant,
        scene_graph,
        pending,
        self_collision=self_collision,
        start_positions=start_positions,
    )


@dc.dataclass
class PendingHardware:
    """A hardware interface whose plant is not final yet (:func:`BeginHardware`)."""

    robot: LoadedRobot
    actuators: ActuatorConfig
    hardware: HardwareInterface
    explicit: dict  # joint -> [kp, kd] the scenario or the controller YAML gives
    from_yaml: dict  # joint -> [kp, kd] of the controller YAML
    chosen: tuple  # (kp, kd, the robot's own (kp, kd))


def BeginHardware(
    plant: MultibodyPlant,
    robot: LoadedRobot,
    actuators: ActuatorConfig,
    config: ControllerManagerConfig,
) -> PendingHardware:
    """The actuators of ``robot``'s hardware interface, before ``plant.Finalize()``."""
    interfaces = command_interfaces(robot, warn=False)[2]  # warned by AddHardwareInterface
    from_yaml = _yaml_gains(config, interfaces)
    explicit = {**from_yaml, **actuators.gains}  # the scenario's win
    own = ARMANDO_GAINS if is_builtin_armando(robot) else (None, None)
    kp = actuators.kp if actuators.kp is not None else own[0]
    kd = actuators.kd if actuators.kd is not None else own[1]
    hardware = AddHardwareInterface(
        plant,
        robot,
        kp=1.0 if kp is None else kp,  # placeholders until the plant is final
        kd=0.0 if kd is None else kd,
        kv=actuators.kv,
        gains=explicit,
    )
    return PendingHardware(robot, actuators, hardware, explicit, from_yaml, (kp, kd, own))


def FinishHardware(
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    pending: PendingHardware,
    *,
    self_collision: bool = False,
    start_positions: Sequence[tuple[Sequence[float], str, str]] = (),
) -> HardwareInterface:
    """The hardware interface of :func:`BeginHardware`, once the plant is final: the
    collision filter of the robot's own links, the start positions, the gains."""
    robot, hardware = pending.robot, pending.hardware
    if not self_collision:  # the robot's links do not collide with each other (Gazebo's default)
        bodies = [plant.get_body(i) for i in plant.GetBodyIndices(robot.model_instance)]
        scene_graph.collision_filter_manager().Apply(
            CollisionFilterDeclaration().ExcludeWithin(plant.CollectRegisteredGeometries(bodies))
        )
    FinishHardwareInterface(plant, robot, hardware)
    for positions, where, key in start_positions:
        set_start_positions(plant, robot, hardware, positions, where, key)
    _log.info(
        "hardware interface %r (%s): %s",
        hardware.name,
        hardware.source,
        ", ".join(
            f"{j.name} {j.command_interface} [{j.lower:.2f}, {j.upper:.2f}]"
            for j in hardware.joints
        ),
    )
    _settle_gains(
        plant,
        robot,
        hardware,
        pending.actuators,
        pending.explicit,
        pending.from_yaml,
        pending.chosen,
    )
    return hardware


# [N m/rad], [N m s/rad]: the gains of the built-in Armando's Dynamixel servos, its
# position joints' gains when the scenario gives none.
ARMANDO_GAINS = (8.0, 0.4)


def _settle_gains(plant, robot, hardware, actuators, explicit, from_yaml, chosen) -> None:
    """Derives the gains left null (``chosen``: kp, kd, the robot's own), records every
    joint's gains and origin in ``hardware`` and logs them in one line."""
    kp, kd, own = chosen
    position = [j for j in hardware.joints if j.command_interface == "position"]
    wanted = {
        j.name: (kp, kd) for j in position if j.name not in explicit and (kp is None or kd is None)
    }
    rule = GainRule(actuators.natural_frequency, actuators.damping_ratio)
    derived = derive_gains(plant, robot, hardware, wanted, rule)
    unlimited = [j.name for j in hardware.joints if j.name in derived and math.isinf(j.effort)]
    if unlimited:
        _log.warning(
            "%s: no effort limit (effort missing or 0) on %s: their actuators apply any "
            "torque, and their derived kp is bounded by %g only",
            robot.source,
            ", ".join(unlimited),
            MAX_GAIN,
        )
    rows: list[JointGains] = []
    for joint in hardware.joints:
        if joint.name in derived:
            joint.kp, joint.kd = derived[joint.name].kp, derived[joint.name].kd
            joint.gains_origin = "derived"
        elif joint.name in actuators.gains:
            joint.gains_origin = "scenario"
        elif joint.name in from_yaml:
            joint.gains_origin = "controller YAML"
        elif joint.command_interface == "position" and (
            (actuators.kp is None and own[0] is not None)
            or (actuators.kd is None and own[1] is not None)
        ):
            joint.gains_origin = "Armando's servos"
        elif joint.command_interface == "velocity":
            joint.gains_origin = "actuators.kv"
        elif joint.command_interface == "position":
            joint.gains_origin = "scenario"
        else:
            continue
        rows.append(JointGains(joint.name, joint.kp, joint.kd, joint.gains_origin))
    if rows:
        _log.info("%s", gains_table(robot.name, rows, rule))


def effective_actuators(actuators: ActuatorConfig, hardware: HardwareInterface) -> ActuatorConfig:
    """``actuators`` with the gains the robot's own rules gave written out: per joint the
    derived ones, kp and kd of the built-in Armando's servos; loading the result gives
    every joint the gains it had."""
    gains = dict(actuators.gains)
    kp, kd = actuators.kp, actuators.kd
    for joint in hardware.joints:
        if joint.gains_origin == "derived":
            gains[joint.name] = [joint.kp, joint.kd]
        elif joint.gains_origin == "Armando's servos":
            kp = joint.kp if kp is None else kp
            kd = joint.kd if kd is None else kd
    return dc.replace(actuators, kp=kp, kd=kd, gains=gains)


def set_start_positions(
    plant, robot, hardware, positions, where: str, key: str = "task.start_positions"
) -> None:
    """The hardware joints start at ``positions`` [rad] (hardware order), inside their
    limits; ``key`` names them in errors, after ``where`` (their origin)."""
    if len(positions) != len(hardware.joints):
        raise ScenarioError(
            f"{where}{key}={positions!r} must have {len(hardware.joints)} values "
            f"({', '.join(hardware.joint_names)})"
        )
    for joint, value in zip(hardware.joints, positions, strict=True):
        if not joint.lower <= value <= joint.upper:
            raise ScenarioError(
                f"{where}{key}: {value!r} of joint {joint.name!r} is outside its "
                f"limits [{joint.lower:.4g}, {joint.upper:.4g}]"
            )
        plant.GetJointByName(joint.name, robot.model_instance).set_default_positions([value])
        joint.initial_position = float(value)


def AddControllerManager(
    builder: DiagramBuilder,
    config: ControllersConfig,
    *,
    plant: MultibodyPlant,
    robot: LoadedRobot,
    hardware: HardwareInterface,
    controller_config: ControllerManagerConfig,
    update_rate: int,
    sequencer=None,
    where: str = "",
    scene_graph: SceneGraph | None = None,
    hold: bool = False,
    namespace: str = "",
    publications: PublicationRegistry | None = None,
    drive_plugins: Sequence[str] = (),
) -> ControlStack:
    """Loads and activates ``config.activate`` (a broadcaster and command controllers,
    each joint claimed once) in one :class:`ControllerManager`, wired to the plant
    through the hardware interface. ``sequencer``: the scenario's sequencer section; a
    sinusoid's controller takes it as a C++ stream when it can. ``hold``: with no
    command controller, the hardware holds the joints at their start positions.
    ``namespace``: the robot's, in a world of several (its ports' names begin with it).
    ``publications``: where its joint states and its controllers' command inputs are
    registered (:func:`~armando_drake.control.topics.RegisterControllerTopics`, with the
    base's ``drive_plugins``)."""
    stack = ControlStack(
        plant=plant,
        robot=robot,
        hardware=hardware,
        config=controller_config,
        update_rate=update_rate,
        scene_graph=scene_graph,
        hold=hold,
        namespace=namespace,
    )
    broadcaster, managed = _activate(stack, config.activate, where, config.speed_scaling)
    if broadcaster is None and not managed and not hold:
        return stack
    stack.stream_controller = stream_controller(sequencer, managed, stack)
    if stack.stream_controller:
        managed = [dc.replace(managed[0], stream=True)]
    # The controller manager runs them all in one update at the update rate.
    try:
        manager = ControllerManager(
            hardware=hardware, update_rate=update_rate, broadcaster=broadcaster, controllers=managed
        )
    except ValueError as error:
        raise ScenarioError(f"{where}{error}") from None
    builder.AddSystem(manager)
    manager.set_name("controller_manager")
    stack.manager = manager
    builder.Connect(
        plant.get_state_output_port(robot.model_instance), manager.GetInputPort("state")
    )
    stack.effort_state = AddEffortState(builder, plant, robot)
    builder.Connect(stack.effort_state, manager.GetInputPort("effort"))
    if broadcaster is not None:
        builder.ExportOutput(manager.GetOutputPort("joint_states"), stack.port_name("joint_states"))
    for controller in managed:
        stack.controllers[controller.name] = manager
    if publications is not None:
        RegisterControllerTopics(publications, stack, drive_plugins)
    return stack


def _activate(stack: ControlStack, activate: Sequence[str], where: str, speed_scaling=None):
    """(the broadcaster or None, the managed command controllers) of ``activate``;
    ``speed_scaling`` overrides the named controllers' initial speed scaling factor."""
    speed_scaling = dict(speed_scaling or {})
    config, hardware = stack.config, stack.hardware
    names = [controller_name(name, config, where) for name in activate]
    validate_joints(config, hardware.joint_names, str(stack.robot.source), names)
    claimed: dict[str, str] = {}
    broadcaster, managed = None, []
    for name in names:
        if name not in config.controllers:
            raise ScenarioError(
                f"{where}controllers.activate names {name!r}, which {config.source} does not "
                f"define (defined: {', '.join(config.controllers) or 'none'})"
            )
        controller = config.controllers[name]
        joints = controller.joints or hardware.joint_names
        _log.info(
            "loaded controller %r of type %s on %s at %g Hz",
            name,
            controller.type,
            ", ".join(joints),
            stack.update_rate,
        )
        try:
            cls = controller.controller_class
        except ControllerConfigError as error:  # a type the registry does not know
            raise ScenarioError(f"{where}controllers.activate: {name!r}: {error}") from None
        if cls.broadcaster:
            if broadcaster is not None:
                raise ScenarioError(
                    f"{where}controllers.activate names two joint state broadcasters "
                    f"({stack.broadcaster_name!r} and {name!r}); activate one"
                )
            broadcaster = cls(
                name=name, joints=ControllerJoints.make(joints), params=controller.params
            )
            stack.broadcaster_name = name
        else:
            for joint in joints:
                if joint in claimed:
                    raise ScenarioError(
                        f"{where}controllers {claimed[joint]!r} and {name!r} both command "
                        f"joint {joint!r}; activate only one of them"
                    )
                claimed[joint] = name
            check_hardware_interfaces(controller, stack.robot, where)
            factor = speed_scaling.pop(name, None)
            if factor is not None:
                controller = _with_speed_scaling(controller, factor, where)
            managed.append(_managed_controller(stack, controller, joints))
        stack.controller_joints[name] = list(joints)
        _log.info("activated controller %r", name)
    for name in speed_scaling:
        raise ScenarioError(
            f"{where}controllers.speed_scaling names {name!r}, which is not an activated "
            "command controller"
        )
    return broadcaster, managed


def check_hardware_interfaces(controller: ControllerConfig, robot: LoadedRobot, where: str) -> None:
    """Fails, as upstream's activation, where ``controller`` claims a hardware interface
    (:meth:`~armando_drake.control.controllers.Controller.hardware_interfaces`) that the
    robot's ``<ros2_control>`` does not declare."""
    wanted = controller.controller_class.hardware_interfaces(controller.params)
    if not wanted:
        return
    declared = {
        f"{component.name}/{interface.name}"
        for info in robot.ros2_control
        for component in (*info.joints, *info.sensors, *info.gpios)
        for interface in (*component.state_interfaces, *component.command_interfaces)
    }
    for parameter, interface in wanted.items():
        if interface not in declared:
            raise ScenarioError(
                f"{where}controllers.activate: {controller.file}: {controller.key}.{parameter}: "
                f"{interface!r} is not an interface of the robot's <ros2_control> (upstream "
                "fails the activation)"
            )
        _log.warning(
            "%s: %s.%s: %r is held at its value: the speed scaling factor is not simulated",
            controller.file,
            controller.key,
            parameter,
            interface,
        )


def controller_name(entry: str, config: ControllerManagerConfig, where: str) -> str:
    """The controller of ``config`` an activation ``entry`` names (a name, or
    ``type:<plugin>``: :func:`~armando_drake.control.controllers.find_controller`)."""
    try:
        return find_controller(entry, config, where)
    except LookupError as error:
        raise ScenarioError(str(error.args[0])) from None


def _with_speed_scaling(controller: ControllerConfig, factor: float, where: str):
    """``controller`` starting at speed scaling ``factor`` (its initial_scaling_factor)."""
    scaling = getattr(controller.params, "speed_scaling", None)
    if scaling is None:
        raise ScenarioError(
            f"{where}controllers.speed_scaling.{controller.name}: {controller.type} has no "
            "speed scaling"
        )
    params = dc.replace(
        controller.params,
        speed_scaling=dc.replace(scaling, initial_scaling_factor=float(factor)),
    )
    return dc.replace(controller, params=params)


def _managed_controller(
    stack: ControlStack, controller: ControllerConfig, joints
) -> ManagedController:
    """The logic of a command controller on ``joints`` (its registered class, built
    with the joints' hardware limits), for the manager."""
    rows = stack.joints_of(joints)
    logic = controller.controller_class(
        name=controller.name,
        joints=ControllerJoints.make(
            joints,
            lower=[joint.lower for joint in rows],
            upper=[joint.upper for joint in rows],
            velocity=[joint.velocity for joint in rows],
            effort=[joint.effort for joint in rows],
            initial_positions=[joint.initial_position for joint in rows],
            continuous=[joint.continuous for joint in rows],
        ),
        params=controller.params,
    )
    logic.set_namespace(stack.namespace)
    try:
        logic.connect_plant(stack.plant, stack.robot.model_instance)
    except ValueError as error:
        raise ScenarioError(f"{controller.name}: {error}") from None
    return ManagedController(name=controller.name, logic=logic)


def ConnectControlStack(
    builder: DiagramBuilder,
    stack: ControlStack,
    *,
    gravity_feedforward: bool,
    tick_command: OutputPort | None = None,
    velocity_limits: bool = False,
) -> OutputPort | None:
    """Wires the commands to the plant through the hardware interface: the desired
    state of the actuators (the controllers' commands, unclaimed joints held at their
    initial positions; a stream's samples, ``tick_command``, as the manager's ticks
    apply them), and on the actuation input the effort commands and the gravity
    feed-forward of the position joints. Exports ``desired_state``; returns the
    gravity feed-forward's output, or None without one."""
    manager = stack.manager
    if manager is None or not (stack.controllers or stack.hold):
        return None
    desired = manager.GetOutputPort("desired_state")
    if stack.stream_controller:
        # [q_d; 0] in hardware order from the stream's command, in C++.
        desired = AddStreamDesiredState(
            builder, stack.hardware, stack.controller_joints[stack.stream_controller], tick_command
        )
    feedforward = ConnectHardwareInterface(
        builder,
        stack.plant,
        stack.robot,
        stack.hardware,
        desired_state=desired,
        effort=(
            manager.GetOutputPort("effort_command")
            if manager.HasOutputPort("effort_command")
            else None
        ),
        gravity_feedforward=gravity_feedforward,
        velocity_limits=velocity_limits,
    )
    builder.ExportOutput(desired, stack.port_name("desired_state"))
    return feedforward


def ExportFreeControllerPorts(builder: DiagramBuilder, stack: ControlStack) -> None:
    """Each controller's command input that no system drives, and its status."""
    for name, system in stack.controllers.items():
        port = stack.command_input(name)
        if not builder.IsConnectedOrExported(port):
            builder.ExportInput(port, stack.port_name(port.get_name()))
        status = f"{name}.status"
        builder.ExportOutput(system.GetOutputPort(status), stack.port_name(status))


def joint_limits(stack: ControlStack, joints: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) limits of ``joints`` [rad or m]."""
    rows = stack.joints_of(joints)
    return np.array([j.lower for j in rows]), np.array([j.upper for j in rows])
