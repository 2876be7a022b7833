"""The world builder: one function turns a :class:`Scenario` into a Drake diagram.

Every entry point (``python -m armando_drake.world``, the notebooks, the tests)
calls :func:`MakeWorld`; none wires systems by hand. The steps follow the
bring-up of the course: spawn the robot in a physics world, give it a hardware
interface (position, velocity or effort actuators), start the ros2_control
controllers of its YAML, found by type in the controller registry (all of them
in one :class:`~armando_drake.control.manager.ControllerManager` system, as
upstream's controller_manager runs them in one loop), then add
what drives and watches them (command sequencer, live jog, joint-state
logger, camera, Meshcat).

Ports of the diagram, by name:

- ``<controller>.<topic>`` (``commands``, ``joint_trajectory``, ...): command
  inputs of the active controllers that no sequencer, task or live jog drives (a
  :class:`~armando_drake.control.messages.Publication`; see
  :meth:`World.publish`);
- ``<controller>.status``: each command controller's ControllerStatus;
- ``joint_states``: the broadcaster's JointState;
- ``desired_state``: [q_d; v_d] sent to the actuators, hardware joint order;
- ``<camera>.color_image`` / ``<camera>.depth_image`` when the camera is on.
"""

from __future__ import annotations

import dataclasses
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from pydrake.geometry import Box, Meshcat, SceneGraph
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    ApplyMultibodyPlantConfig,
    CoulombFriction,
    MultibodyPlant,
)
from pydrake.systems.framework import Context, Diagram, DiagramBuilder, OutputPort, System
from pydrake.visualization import ApplyVisualizationConfig

from armando_drake.control.config import (
    ControllerConfig,
    ControllerConfigError,
    ControllerManagerConfig,
    check_update_rate,
    load_controller_config,
    parse_controller_config,
    validate_joints,
)
from armando_drake.control.controllers import ControllerJoints, lookup
from armando_drake.control.hardware import (
    AddEffortState,
    AddHardwareInterface,
    ConnectHardwareInterface,
    FinishHardwareInterface,
    HardwareInterface,
    command_interfaces,
)
from armando_drake.control.manager import (
    AddJointStateVector,
    AddStreamDesiredState,
    ControllerManager,
    ManagedController,
)
from armando_drake.control.messages import Float64MultiArray, JointTrajectory, Publication
from armando_drake.description.importer import default_controller_config
from armando_drake.description.loader import LoadedRobot, load_robot, package_of
from armando_drake.sensors.objects import AddSceneObjects, SceneObjectError
from armando_drake.simulation.scenario import Scenario, ScenarioError, sources_of
from armando_drake.simulation.validation import check_against_world, check_scenario

if TYPE_CHECKING:
    from armando_drake.outputs.logger import JointStateLogger
    from armando_drake.sensors.camera import AddedCamera

_log = logging.getLogger("armando_drake.world")


@dataclass
class TaskReference:
    """The scenario's task-space motion as the world publishes it."""

    controller: str  # the controller it is published to
    topic: str  # on its input "<controller>.<topic>"
    trajectory: Any  # the CartesianTrajectory of the end effector (in the world frame)
    arm: Any  # the ArmModel of the end effector (FK of logged joint states)
    source: Any  # the system that publishes it (output: the Publication)


@dataclass
class World:
    """The built diagram and handles to its parts."""

    diagram: Diagram
    plant: MultibodyPlant
    scene_graph: SceneGraph
    robot: LoadedRobot
    hardware: HardwareInterface
    controller_config: ControllerManagerConfig
    update_rate: int  # [Hz] the controller manager's rate
    # Active command controllers by name -> the system that runs them (the controller
    # manager), whose ports are "<name>.<topic>" and "<name>.status".
    controllers: dict[str, ControllerManager] = field(default_factory=dict)
    controller_joints: dict[str, list[str]] = field(default_factory=dict)  # by name
    # The system with the "joint_states" output (the manager), when a broadcaster is active.
    broadcaster: ControllerManager | None = None
    controller_manager: ControllerManager | None = None  # broadcaster and controllers
    sequencer: System | None = None  # the command sequencer (a LeafSystem or a Diagram)
    logger: JointStateLogger | None = None
    # The hardware's effort state interface: the torque each actuator applied over the
    # last plant step (AddEffortState), read by the broadcaster and the logger.
    effort_state: OutputPort | None = None
    # The gravity feed-forward torques [N m] on the actuation input (actuator order;
    # AddGravityFeedforward), when the scenario has it.
    gravity_feedforward: OutputPort | None = None
    sequencer_target: str = ""  # the controller the sequencer drives
    # The controller whose commands are a C++ stream (a sinusoid) that drives the
    # hardware directly, without the manager's update; "" if none.
    stream_controller: str = ""
    broadcaster_name: str = ""  # the active joint state broadcaster's name in the YAML
    cameras: dict[str, AddedCamera] = field(default_factory=dict)  # by name
    image_view_url: str | None = None  # the live camera view, when served
    perception: Any = None  # AddedPerception when the scenario has a perception block
    detectors: Any = None  # AddedDetectors when the scenario has a vision block
    image_view: Any = None  # the live camera view's server, when served
    meshcat: Meshcat | None = None
    replay_sampler: Any = None  # ReplaySampler of the plant's state, with Meshcat on
    task: TaskReference | None = None  # the scenario's task-space motion, if any
    jog: Any = None  # the MeshcatJog when the scenario has a jog block and a Meshcat
    closers: list = field(default_factory=list)  # called by close()

    def publish(self, context: Context, controller: str, message: Any) -> None:
        """Publishes ``message`` on a controller's command input, like a ROS topic."""
        port = self.command_port(controller)
        previous = port.Eval(context) if port.HasValue(context) else Publication()
        port.FixValue(context, previous.publish(message, stamp=context.get_time()))

    def command_port(self, controller: str):
        entry = self.controller_config.controllers.get(controller)
        name = f"{controller}.{entry.topic}" if entry is not None else ""
        if name and self.diagram.HasInputPort(name):
            return self.diagram.GetInputPort(name)
        raise KeyError(f"no command input for controller {controller!r}")

    def status(self, context: Context, controller: str):
        return self.diagram.GetOutputPort(f"{controller}.status").Eval(context)

    def joint_positions(self, context: Context) -> np.ndarray:
        """Measured positions of the hardware joints [rad], hardware order."""
        x = self.plant.GetPositionsAndVelocities(
            self.plant.GetMyContextFromRoot(context), self.robot.model_instance
        )
        return x[self.hardware.position_index]

    def close(self, context: Context | None = None) -> None:
        """Ends the run: with the root ``context``, first writes the joint states the
        logger has recorded since its last flush (and the sequencer's commands since
        its last batch); then closes every file and server."""
        if context is not None and self.logger is not None and self.closers:
            self.logger.flush(self.logger.GetMyContextFromRoot(context))
        if context is not None and self.sequencer is not None and self.closers:
            self.sequencer.flush(context)
        for closer in self.closers:
            closer()
        self.closers.clear()


def _controller_config(scenario: Scenario, robot: LoadedRobot) -> ControllerManagerConfig:
    """The controller YAML of the scenario, of the description's ``<gazebo><plugin>``
    ``<parameters>``, of the description package, or a default on the joints the
    hardware interface will actuate."""
    path = scenario.controllers.config
    if path:
        return load_controller_config(Path(path))
    for named in robot.controller_files:
        if named.is_file():
            _log.info("controller configuration from the description's <gazebo> plugin: %s", named)
            return load_controller_config(named)
        _log.warning("the description's <gazebo> plugin names %s, which does not exist", named)
    package_dir = package_of(robot.source)
    candidates = sorted((package_dir / "config").glob("*controllers*.yaml")) if package_dir else []
    if candidates:
        return load_controller_config(candidates[0])
    actuated = list(command_interfaces(robot, warn=False)[2])
    if not actuated:
        raise ScenarioError(
            f"{robot.source}: the description actuates no joint (read from "
            f"{robot.actuation_source}): nothing for a controller to command"
        )
    data = default_controller_config(actuated)
    return parse_controller_config(data, source=f"<default controllers of {robot.name}>")


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


def _add_ground(plant: MultibodyPlant) -> None:
    """A 2 m x 2 m slab whose top face is the plane z = 0.

    Cameras see it (perception role); Meshcat does not (no illustration role):
    :class:`~armando_drake.outputs.view.ViewFramer` draws a ground there that
    fits the scene.
    """
    from pydrake.geometry import GeometryInstance, PerceptionProperties, Rgba

    from armando_drake.outputs.view import GROUND_COLOR

    X_WG = RigidTransform([0.0, 0.0, -0.025])
    ground = Box(2.0, 2.0, 0.05)
    plant.RegisterCollisionGeometry(
        plant.world_body(), X_WG, ground, "ground", CoulombFriction(0.8, 0.8)
    )
    instance = GeometryInstance(X_WG, ground, "ground")
    perception = PerceptionProperties()
    perception.AddProperty("phong", "diffuse", Rgba(*GROUND_COLOR))
    instance.set_perception_properties(perception)
    plant.RegisterVisualGeometry(plant.world_body(), instance)


def _exclude_self_collision(plant: MultibodyPlant, scene_graph, robot: LoadedRobot) -> None:
    """The robot's links no longer collide with each other (Gazebo's default)."""
    from pydrake.geometry import CollisionFilterDeclaration

    bodies = [plant.get_body(i) for i in plant.GetBodyIndices(robot.model_instance)]
    geometries = plant.CollectRegisteredGeometries(bodies)
    scene_graph.collision_filter_manager().Apply(
        CollisionFilterDeclaration().ExcludeWithin(geometries)
    )


def MakeWorld(
    scenario: Scenario,
    *,
    meshcat: Meshcat | None = None,
    output_dir: str | os.PathLike | None = None,
    quiet: bool = False,
    source: str = "",
    write_commands: bool = False,
    record: str | os.PathLike | None = None,
    host: str = "127.0.0.1",
) -> World:
    """Builds the world diagram of ``scenario``.

    ``meshcat``: draw the world there (when the scenario's visualization is on).
    ``output_dir``: where the logger writes ``joint_states.csv`` (none: no CSV)
    and, with ``write_commands``, the sequencer's ``commands.csv``.
    ``source``: the scenario file, named in error messages.
    ``record``: an ``.mcap`` file where the run's topics are recorded as a ROS 2 bag
    (:func:`~armando_drake.outputs.recording.AddRosbagRecorder`).
    ``host``: the address the camera's live view listens on (``--host``, as Meshcat).
    """
    where = f"{source}: " if source else ""
    # Every value of the scenario checked before Drake sees it.
    check_scenario(scenario, source)
    builder = DiagramBuilder()
    # The physics: a MultibodyPlant and its SceneGraph, as the scenario configures them.
    plant, scene_graph = _add_plant(builder, scenario, where)
    # Spawn the robot (its base welded at the spawn pose), the ground and the objects.
    robot = _add_robot_and_scene(plant, scenario, where)
    # The controller YAML (before the actuators: a ROS 1 file's gazebo_ros_control gains
    # are theirs); its update rate, which the scenario may override, below.
    config = _controller_config(scenario, robot)
    # Rates, gains and periods checked against the robot and the controller YAML.
    check_against_world(
        scenario,
        update_rate=_update_rate(config, scenario, _origin(scenario, "controllers.update_rate")),
        update_rate_source=config.source,
        joints=command_interfaces(robot, warn=False)[2],
    )
    # The hardware interface: an actuator per commanded joint; then the plant is final.
    hardware = _add_hardware(plant, scene_graph, robot, scenario, config)
    world = World(
        diagram=None,  # set by Build() below
        plant=plant,
        scene_graph=scene_graph,
        robot=robot,
        hardware=hardware,
        controller_config=config,
        update_rate=_update_rate(config, scenario, _origin(scenario, "controllers.update_rate")),
        meshcat=meshcat,
    )
    # The controller manager: the activated controllers of the YAML, in one system.
    _add_controller_manager(builder, world, scenario, _origin(scenario, "controllers"))
    # What drives and watches them: sequencer, logger, cameras, recorder, bridges.
    commands_csv = Path(output_dir) / "commands.csv" if output_dir and write_commands else None
    _add_sequencer(builder, world, scenario, _origin(scenario, "sequencer"), commands_csv)
    _add_task(builder, world, scenario, _origin(scenario, "task"))
    _add_jog(builder, world, scenario, _origin(scenario, "jog"))
    # The commands to the plant: desired state, efforts, gravity feed-forward.
    _connect_hardware(builder, world, scenario)
    _add_logger(builder, world, scenario, output_dir, quiet)
    _add_cameras(builder, world, scenario, meshcat, where, sources_of(scenario).of("cameras"), host)
    _add_detectors(builder, world, scenario, _origin(scenario, "vision"))
    _add_perception(
        builder, world, scenario, meshcat, output_dir if write_commands else None, source
    )
    _add_recorder_and_bridges(builder, world, scenario, record)
    # Meshcat draws the world.
    _apply_visualization(builder, world, scenario, meshcat)
    # Export what no system drives (command inputs, statuses), for notebooks and tests.
    _export_free_ports(builder, world)
    world.diagram = builder.Build()
    world.diagram.set_name("armando_world")
    return world


def _origin(scenario: Scenario, key: str) -> str:
    """``"<origin>: "``: the file, ``--set`` or option the scenario's ``key`` came from."""
    return f"{sources_of(scenario).of(key)}: "


def _add_plant(builder: DiagramBuilder, scenario: Scenario, where: str):
    """The plant and scene graph of ``scenario.plant_config``."""
    plant_config = scenario.plant_config
    if plant_config.time_step > 0 and plant_config.discrete_contact_approximation == "tamsi":
        raise ScenarioError(
            f"{where}plant_config.discrete_contact_approximation='tamsi' ignores PD actuator "
            "gains; use 'lagged', 'sap' or 'similar'"
        )
    plant, scene_graph = AddMultibodyPlant(plant_config, builder)
    ApplyMultibodyPlantConfig(plant_config, plant)
    return plant, scene_graph


def _add_robot_and_scene(plant: MultibodyPlant, scenario: Scenario, where: str) -> LoadedRobot:
    """The robot's description welded at its spawn pose, the ground and the objects."""
    robot_config = scenario.robot
    X_WB = RigidTransform(RollPitchYaw(robot_config.base_rpy), robot_config.base_xyz)
    robot = load_robot(
        plant,
        robot_config.description or None,
        xacro_args=robot_config.xacro_args,
        package_paths=robot_config.package_paths,
        X_WB=X_WB,
        collision=robot_config.collision,
    )
    if scenario.ground:
        _add_ground(plant)
    try:
        AddSceneObjects(plant, scenario.objects)
    except SceneObjectError as error:
        raise ScenarioError(f"{where}objects: {error}") from None
    return robot


def _add_hardware(
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    robot: LoadedRobot,
    scenario: Scenario,
    config: ControllerManagerConfig,
) -> HardwareInterface:
    """The actuators of the hardware interface (gains: the scenario's, per joint the
    controller YAML's ``gazebo_ros_control`` ones unless the scenario names the joint);
    finalizes the plant; the task's start positions, if it gives them."""
    interfaces = command_interfaces(robot, warn=False)[2]  # warned by AddHardwareInterface
    actuators = scenario.actuators
    gains = {**_yaml_gains(config, interfaces), **actuators.gains}  # the scenario's win
    hardware = AddHardwareInterface(
        plant, robot, kp=actuators.kp, kd=actuators.kd, kv=actuators.kv, gains=gains
    )
    plant.Finalize()
    if not scenario.robot.self_collision:
        _exclude_self_collision(plant, scene_graph, robot)
    FinishHardwareInterface(plant, robot, hardware)
    if scenario.task is not None and scenario.task.start_positions:
        _set_start_positions(
            plant,
            robot,
            hardware,
            scenario.task.start_positions,
            _origin(scenario, "task.start_positions"),
        )
    if scenario.jog is not None and scenario.jog.home_positions:
        _set_start_positions(
            plant,
            robot,
            hardware,
            scenario.jog.home_positions,
            _origin(scenario, "jog.home_positions"),
            "jog.home_positions",
        )
    _log.info(
        "hardware interface %r (%s): %s",
        hardware.name,
        hardware.source,
        ", ".join(
            f"{j.name} {j.command_interface} [{j.lower:.2f}, {j.upper:.2f}]"
            for j in hardware.joints
        ),
    )
    return hardware


def _update_rate(config: ControllerManagerConfig, scenario: Scenario, where: str) -> int:
    """The controller manager's rate [Hz]: the YAML's, or the scenario's override."""
    if not scenario.controllers.update_rate:
        return config.update_rate
    try:
        return check_update_rate(scenario.controllers.update_rate, f"{where}controllers")
    except ControllerConfigError as error:
        raise ScenarioError(str(error)) from None


def _add_controller_manager(builder, world: World, scenario: Scenario, where: str) -> None:
    """Loads and activates the scenario's controllers (a broadcaster and command
    controllers, each joint claimed once) in one :class:`ControllerManager`, wired to
    the plant through the hardware interface."""
    config, hardware, plant = world.controller_config, world.hardware, world.plant
    validate_joints(config, hardware.joint_names, str(world.robot.source))
    claimed: dict[str, str] = {}
    broadcaster = None
    managed = []  # ManagedController, in activation order
    for name in scenario.controllers.activate:
        name = _controller_name(name, config, where)
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
            world.update_rate,
        )
        try:
            cls = controller.controller_class
        except ControllerConfigError as error:  # a type the registry does not know
            raise ScenarioError(f"{where}controllers.activate: {name!r}: {error}") from None
        if cls.broadcaster:
            if broadcaster is not None:
                raise ScenarioError(
                    f"{where}controllers.activate names two joint state broadcasters "
                    f"({world.broadcaster_name!r} and {name!r}); activate one"
                )
            broadcaster = cls(
                name=name,
                joints=ControllerJoints.make(joints),
                params=controller.params,
            )
            world.broadcaster_name = name
        else:
            for joint in joints:
                if joint in claimed:
                    raise ScenarioError(
                        f"{where}controllers {claimed[joint]!r} and {name!r} both command "
                        f"joint {joint!r}; activate only one of them"
                    )
                claimed[joint] = name
            managed.append(_managed_controller(world, controller, joints))
        world.controller_joints[name] = list(joints)
        _log.info("activated controller %r", name)
    if broadcaster is None and not managed:
        return

    # A sinusoid's controller takes it as a C++ stream when it can.
    world.stream_controller = _stream_controller(world, scenario, managed)
    if world.stream_controller:
        managed = [dataclasses.replace(managed[0], stream=True)]
    # The controller manager runs them all in one update at the update rate.
    try:
        manager = ControllerManager(
            hardware=hardware,
            update_rate=world.update_rate,
            broadcaster=broadcaster,
            controllers=managed,
        )
    except ValueError as error:
        raise ScenarioError(f"{where}{error}") from None
    builder.AddSystem(manager)
    manager.set_name("controller_manager")
    world.controller_manager = manager
    instance = world.robot.model_instance
    builder.Connect(plant.get_state_output_port(instance), manager.GetInputPort("state"))
    world.effort_state = AddEffortState(builder, plant, world.robot)
    builder.Connect(world.effort_state, manager.GetInputPort("effort"))
    if broadcaster is not None:
        builder.ExportOutput(manager.GetOutputPort("joint_states"), "joint_states")
        world.broadcaster = manager
    for controller in managed:
        world.controllers[controller.name] = manager


def _stream_controller(world: World, scenario: Scenario, managed: list) -> str:
    """The controller that takes the scenario's sinusoid as a C++ stream, or "".

    A stream needs no Python per sample: the wave is evaluated and sampled in C++
    and checked against the joint limits now, so each sample is accepted as it is,
    and it drives the hardware directly, latched at the manager's ticks (see
    :func:`_connect_hardware`). That takes a position controller commanding every
    joint alone, and samples no faster than the manager's ticks (each one handled
    at one tick); otherwise the samples go through the manager as messages."""
    from armando_drake.control.sequencer import SequencerError, Sinusoid, validate, wave_of

    config = scenario.sequencer
    if not isinstance(config, Sinusoid) or len(managed) != 1:
        return ""
    controller = managed[0]
    logic = controller.logic
    entry = world.controller_config.controllers[controller.name]
    if not (
        entry.controller_class.message is Float64MultiArray
        and entry.position_targets
        and logic.accepts_stream(logic.params)
        and sorted(logic.joint_names) == sorted(world.hardware.joint_names)
    ):
        return ""
    if config.rate is not None and not config.rate <= world.update_rate:
        return ""  # the manager would take only the latest of several samples per tick
    joints = list(logic.joint_names)
    rows = world.hardware.find(joints)
    config = _sized_seed(config, world, [world.hardware.joints[i] for i in rows])
    lower = np.array([world.hardware.joints[i].lower for i in rows])
    upper = np.array([world.hardware.joints[i].upper for i in rows])
    try:
        validate(config, joints, lower, upper)
    except SequencerError:
        return ""  # the sequencer reports it
    # Inside the limits with room for the rounding of the samples, so that the
    # controller would never clamp one.
    wave = wave_of(config, joints)
    reach = np.abs(wave.amplitude)
    room = 1e-9 * (1.0 + np.abs(wave.offset) + reach)
    if np.any(wave.offset + reach > upper - room) or np.any(wave.offset - reach < lower + room):
        return ""
    return controller.name


def _connect_hardware(builder, world: World, scenario: Scenario) -> None:
    """Wires the commands to the plant through the hardware interface: the desired
    state of the actuators (the controllers' commands, unclaimed joints held at their
    initial positions; a stream's samples as the manager's ticks apply them), and on
    the actuation input the effort commands and the gravity feed-forward of the
    position joints. Exported as ``desired_state``."""
    manager = world.controller_manager
    if manager is None or not world.controllers:
        return
    desired = manager.GetOutputPort("desired_state")
    if world.stream_controller:
        # [q_d; 0] in hardware order from the stream's command as the manager's ticks
        # apply it, in C++.
        desired = AddStreamDesiredState(
            builder,
            world.hardware,
            world.controller_joints[world.stream_controller],
            world.sequencer.GetOutputPort("tick_command"),
        )
    world.gravity_feedforward = ConnectHardwareInterface(
        builder,
        world.plant,
        world.robot,
        world.hardware,
        desired_state=desired,
        effort=(
            manager.GetOutputPort("effort_command")
            if manager.HasOutputPort("effort_command")
            else None
        ),
        gravity_feedforward=scenario.actuators.gravity_feedforward,
    )
    builder.ExportOutput(desired, "desired_state")


def _add_detectors(builder, world: World, scenario: Scenario, where: str) -> None:
    """The scenario's OpenCV detectors on its cameras (after the cameras)."""
    if scenario.vision is None:
        return
    from armando_drake.vision.detectors import AddDetectors, DetectorError

    try:
        console = scenario.logging.console_rate > 0  # no console output asked: no keypoints
        world.detectors = AddDetectors(builder, world, scenario.vision, where, console=console)
    except DetectorError as error:
        raise ScenarioError(str(error)) from None


def _add_perception(builder, world: World, scenario: Scenario, meshcat, output_dir, source) -> None:
    """Point clouds from a camera's depth and the pipeline of ``scenario.perception``
    (``clusters.json`` in ``output_dir``); before the recorder, which records them."""
    if scenario.perception is None:
        return
    from armando_drake.perception.systems import AddPerception

    world.perception = AddPerception(
        builder,
        world,
        scenario.perception,
        meshcat=meshcat,
        output_dir=output_dir,
        source=source,
    )


def _add_recorder_and_bridges(builder, world: World, scenario: Scenario, record) -> None:
    """The ROS 2 bag recorder (``record``) and the live DDS / Foxglove bridge."""
    if record is not None:
        from armando_drake.outputs.recording import AddRosbagRecorder

        AddRosbagRecorder(builder, world, record)
    if scenario.ros2.enabled or scenario.ros2.foxglove:
        from armando_drake.ros2.bridge import AddRos2Bridge  # imports DDS only when on

        AddRos2Bridge(builder, world, scenario.ros2)


def _apply_visualization(builder, world: World, scenario: Scenario, meshcat) -> None:
    """Drake's visualization of the plant in ``meshcat``, the collision layer hidden."""
    if meshcat is None or not scenario.visualization.enable_meshcat_creation:
        return
    from armando_drake.outputs.replay import AddReplaySampler, visualization_for
    from armando_drake.outputs.view import AddViewFramer

    ApplyVisualizationConfig(
        visualization_for(scenario.visualization, meshcat),
        builder,
        plant=world.plant,
        scene_graph=world.scene_graph,
        meshcat=meshcat,
    )
    meshcat.SetProperty("/drake/proximity", "visible", False)
    # The camera on the robot and the ground to the scene's size, when the run starts.
    AddViewFramer(
        builder,
        world.plant,
        world.scene_graph,
        meshcat,
        robot_instances=[world.robot.model_instance],
        ground=scenario.ground,
    )
    # The plant's state at a bounded number of instants, for the replay after the run.
    world.replay_sampler = AddReplaySampler(builder, world.plant)


def _export_free_ports(builder: DiagramBuilder, world: World) -> None:
    """Each controller's command input that no system drives, and its status."""
    for name, system in world.controllers.items():
        port_name = f"{name}.{world.controller_config.controllers[name].topic}"
        port = system.GetInputPort(port_name)
        if not builder.IsConnectedOrExported(port):
            builder.ExportInput(port, port_name)
        builder.ExportOutput(system.GetOutputPort(f"{name}.status"), f"{name}.status")


def _controller_name(entry: str, config: ControllerManagerConfig, where: str) -> str:
    """A controller name, or for ``type:<plugin>`` the first controller of that type.

    Else, for a broadcaster, the first broadcaster (ROS 1's
    ``joint_state_controller/JointStateController`` for
    ``type:joint_state_broadcaster/JointStateBroadcaster``); for a command
    controller, one of another type that reads the same message on the same
    command interface (a ForwardCommandController on position for
    ``type:position_controllers/JointGroupPositionController``, ROS 1's
    ``position_controllers/JointTrajectoryController`` for the trajectory type)
    or, for a position type, that takes positions whatever it commands (ROS 1's
    ``effort_controllers/JointTrajectoryController``).
    """
    if not entry.startswith("type:"):
        return entry
    wanted = entry[len("type:") :]
    try:
        wanted_class = lookup(wanted)
    except KeyError as error:
        raise ScenarioError(f"{where}controllers.activate: {error.args[0]}") from None
    matches = [name for name, c in config.controllers.items() if c.supported and c.type == wanted]
    if not matches and wanted_class.broadcaster:
        matches = [
            name
            for name, c in config.controllers.items()
            if c.supported and c.controller_class.broadcaster
        ]
    if not matches and not wanted_class.broadcaster:
        matches = [
            name
            for name, c in config.controllers.items()
            if c.supported
            and c.controller_class.message is wanted_class.message
            and (
                c.interface_name == wanted_class.fixed_interface
                or (wanted_class.fixed_interface == "position" and c.position_targets)
            )
        ]
    if matches:
        return matches[0]
    raise ScenarioError(
        f"{where}controllers.activate asks for a {wanted} controller; {config.source} "
        f"defines none (defined: {', '.join(config.controllers) or 'none'})"
    )


def _managed_controller(world: World, controller: ControllerConfig, joints) -> ManagedController:
    """The logic of a command controller on ``joints`` (its registered class, built
    with the joints' hardware limits), for the manager."""
    hardware = world.hardware
    rows = [hardware.joints[i] for i in hardware.find(joints)]
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
    try:
        logic.connect_plant(world.plant, world.robot.model_instance)
    except ValueError as error:
        raise ScenarioError(f"{controller.name}: {error}") from None
    return ManagedController(name=controller.name, logic=logic)


def _set_start_positions(
    plant, robot, hardware, positions, where: str, key: str = "task.start_positions"
) -> None:
    """The hardware joints start at ``positions`` [rad] (hardware order), inside their
    limits; ``key`` names them in errors."""
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


def _add_task(builder, world: World, scenario: Scenario, where: str) -> None:
    """The scenario's task-space motion, published once at t = 0 to the controller that
    takes it (a Drake ``ConstantValueSource`` of the publication: no per-step cost)."""
    motion = scenario.task
    if motion is None:
        return
    from pydrake.common.value import AbstractValue
    from pydrake.systems.primitives import ConstantValueSource

    from armando_drake.control.controllers.task_space import check_within_reach
    from armando_drake.control.messages import CartesianTrajectory
    from armando_drake.task.arm import ArmModel, TaskSpaceError
    from armando_drake.task.motion import make_cartesian_trajectory
    from armando_drake.task.paths import PathError
    from armando_drake.task.time_laws import TimeLawError

    config = world.controller_config.controllers
    targets = [
        n for n in world.controllers if config[n].controller_class.message is CartesianTrajectory
    ]
    targets += [
        n for n in world.controllers if config[n].controller_class.message is JointTrajectory
    ]
    if not targets:
        raise ScenarioError(
            f"{where}task needs an active controller that takes a CartesianTrajectory or a "
            f"JointTrajectory; active: {', '.join(world.controllers) or 'none'}"
        )
    name = targets[0]
    plant, instance = world.plant, world.robot.model_instance
    try:
        frame = motion.end_effector or _last_link_frame(plant, instance)
        arm = ArmModel(plant=plant, end_effector_frame=frame, model_instance=instance)
        arm.set_state(arm.default_positions())
        trajectory = make_cartesian_trajectory(motion, arm.pose())
        check_within_reach(arm, trajectory)
        period = 1.0 / world.update_rate
        if config[name].controller_class.message is CartesianTrajectory:
            message = cartesian_trajectory_message(trajectory, period, arm.frame_E.name())
        else:
            from armando_drake.task.inverse_kinematics import plan_joint_reference

            plan = plan_joint_reference(arm, trajectory, arm.default_positions(), period=period)
            message = joint_trajectory_message(plan, arm.joint_names)
    except (TaskSpaceError, PathError, TimeLawError) as error:
        raise ScenarioError(f"{where}task: {error}") from None
    source = builder.AddNamedSystem(
        "task_reference",
        ConstantValueSource(AbstractValue.Make(Publication(1, message, 0.0))),
    )
    topic = config[name].controller_class.topic
    builder.Connect(
        source.get_output_port(), world.controllers[name].GetInputPort(f"{name}.{topic}")
    )
    world.task = TaskReference(
        controller=name, topic=topic, trajectory=trajectory, arm=arm, source=source
    )
    _log.info(
        "task: %s path, %s profile, %.3g s, end effector %s, to %s (%s)",
        motion.path,
        motion.profile,
        trajectory.duration,
        arm.frame_E.name(),
        name,
        type(message).__name__,
    )
    if world.meshcat is not None:
        from pydrake.geometry import Rgba

        times = np.linspace(0.0, trajectory.duration, 400)
        path = trajectory.reference(times)[:, 4:7].T
        world.meshcat.SetLine("task/desired_path", path, 3.0, Rgba(0.1, 0.4, 1.0, 1.0))


def _add_jog(builder, world: World, scenario: Scenario, where: str) -> None:
    """The live jog of the scenario's ``jog:`` block (Meshcat sliders, jog buttons,
    gamepad) on a position controller's command input."""
    if scenario.jog is None:
        return
    from armando_drake.teleop.config import JogError
    from armando_drake.teleop.jog import AddJog

    try:
        world.jog = AddJog(builder, world, scenario.jog, where=where)
    except JogError as error:
        raise ScenarioError(str(error)) from None


def _last_link_frame(plant, instance):
    """The body frame of the child link of the robot's last moving joint."""
    moving = [plant.get_joint(i) for i in plant.GetJointIndices(instance)]
    moving = [j for j in moving if j.num_velocities() > 0]
    return max(moving, key=lambda j: j.velocity_start()).child_body().body_frame()


def cartesian_trajectory_message(trajectory, period: float, frame: str):
    """The CartesianTrajectory message of ``trajectory`` sampled every ``period`` [s]."""
    from armando_drake.control.messages import CartesianTrajectory, CartesianTrajectoryPoint

    count = int(np.ceil(trajectory.duration / period - 1e-9)) + 1
    times = np.arange(count) * period
    references = trajectory.reference(times)
    points = tuple(
        CartesianTrajectoryPoint(
            time_from_start=float(t),
            position=tuple(row[4:7].tolist()),
            orientation=tuple(row[0:4].tolist()),
            twist=tuple(row[7:13].tolist()),
            acceleration=tuple(row[13:19].tolist()),
        )
        for t, row in zip(times, references, strict=True)
    )
    return CartesianTrajectory(stamp=0.0, frame_id="world", controlled_frame=frame, points=points)


def joint_trajectory_message(plan, joint_names) -> JointTrajectory:
    """The JointTrajectory message of a planned joint reference. Its last point is at
    rest (the plan's residual velocity there is tiny; a trajectory controller
    rejects a last point that is not)."""
    from armando_drake.control.messages import JointTrajectoryPoint

    last = len(plan.times) - 1
    points = tuple(
        JointTrajectoryPoint(
            positions=tuple(plan.q[k].tolist()),
            velocities=tuple(0.0 * plan.v[k] if k == last else plan.v[k]),
            accelerations=tuple(0.0 * plan.a[k] if k == last else plan.a[k]),
            time_from_start=float(t),
        )
        for k, t in enumerate(plan.times)
    )
    return JointTrajectory(stamp=0.0, joint_names=tuple(joint_names), points=points)


def _add_sequencer(builder, world: World, scenario: Scenario, where: str, commands_csv) -> None:
    """The command sequencer of the scenario, on the first active controller of the
    kind its configuration feeds (a position or a trajectory controller)."""
    config = scenario.sequencer
    if config is None:
        return
    from armando_drake.control.sequencer import CONTROLLER_KIND, MakeSequencer, validate
    from armando_drake.outputs.logger import CommandsCsv

    kind = CONTROLLER_KIND[type(config)]
    message = JointTrajectory if kind == "trajectory" else Float64MultiArray
    targets = [
        (name, system)
        for name, system in world.controllers.items()
        if world.controller_config.controllers[name].controller_class.message is message
        and world.controller_config.controllers[name].position_targets
    ]
    if not targets:
        raise ScenarioError(
            f"{where}sequencer !{type(config).__name__} needs an active {kind} controller; "
            f"active: {', '.join(world.controllers) or 'none'}"
        )
    name, controller = targets[0]
    joints = world.controller_joints[name]
    rows = world.hardware.find(joints)
    config = _sized_seed(config, world, [world.hardware.joints[i] for i in rows])
    validate(
        config,
        joints,
        [world.hardware.joints[i].lower for i in rows],
        [world.hardware.joints[i].upper for i in rows],
        source=where.rstrip(": "),
    )
    on_publish = None
    if commands_csv is not None:
        on_publish = CommandsCsv(commands_csv, joints)
        world.closers.append(on_publish.close)
    stream = name == world.stream_controller
    sequencer = builder.AddSystem(
        MakeSequencer(
            config=config,
            joint_names=joints,
            controller_rate=world.update_rate,
            initial_positions=[world.hardware.joints[i].initial_position for i in rows],
            on_publish=on_publish,
            controller_ticks=stream,  # the stream as the manager's ticks apply it
        )
    )
    sequencer.set_name("command_sequencer")
    port = "joint_trajectory" if kind == "trajectory" else "commands"
    topic = world.controller_config.controllers[name].topic  # ROS 1: "command"
    builder.Connect(sequencer.GetOutputPort(port), controller.GetInputPort(f"{name}.{topic}"))
    if stream:
        builder.Connect(
            sequencer.GetOutputPort("tick_count"), controller.GetInputPort(f"{name}.command_count")
        )
    builder.ExportOutput(sequencer.GetOutputPort("reference"), "reference")
    world.sequencer = sequencer
    world.sequencer_target = name


def _sized_seed(config, world: World, joints: list) -> Any:
    """``config`` with the seed targets (the default) sized to ``joints``
    (:func:`~armando_drake.control.sequencer.seed_targets_for`), or the seed's wave
    (:func:`~armando_drake.control.sequencer.seed_wave_for`); other targets and
    waves as written."""
    from armando_drake.control.sequencer import (
        SEED_AMPLITUDE,
        SEED_PHASE,
        Sinusoid,
        is_seed,
        seed_targets_for,
        seed_wave_for,
    )

    lower, upper = [j.lower for j in joints], [j.upper for j in joints]
    if isinstance(config, Sinusoid):
        if config.amplitude or config.offset or list(config.phase) != list(SEED_PHASE):
            return config
        amplitude, phase, offset = seed_wave_for(lower, upper)
        seed = [SEED_AMPLITUDE] * len(SEED_PHASE), list(SEED_PHASE), [0.0] * len(SEED_PHASE)
        if (amplitude, phase, offset) == seed:
            return config  # the seed's wave itself (Armando)
        _log.info("seed wave sized to the %d joints of %s", len(joints), world.robot.name)
        return dataclasses.replace(config, amplitude=amplitude, phase=phase, offset=offset)
    targets = getattr(config, "targets", None)
    if not targets or not is_seed(targets):
        return config
    sized = seed_targets_for(lower, upper)
    if not is_seed(sized):
        _log.info(
            "seed targets sized to the %d joints of %s: %s",
            len(joints),
            world.robot.name,
            " ".join(str([round(v, 3) for v in target]) for target in sized),
        )
    return dataclasses.replace(config, targets=sized)


def _add_logger(builder, world: World, scenario: Scenario, output_dir, quiet: bool) -> None:
    """The joint state logger on what the broadcaster publishes: its C++ vector view
    ([q; v; effort] of its joints), sampled at the controllers' rate."""
    if world.broadcaster is None:
        return
    from armando_drake.outputs.logger import JointStateLogger

    joints = world.controller_joints[world.broadcaster_name]
    view = AddJointStateVector(
        builder,
        world.plant,
        world.hardware,
        world.robot.model_instance,
        joints,
        effort=world.effort_state,
    )
    csv_path = None if output_dir is None else Path(output_dir) / "joint_states.csv"
    console_rate = scenario.logging.console_rate
    broadcaster = world.controller_manager.broadcaster
    # ROS 1's joint_state_controller publishes at its own publish_rate.
    rate = broadcaster.publish_rate(broadcaster.params) or world.update_rate
    logger = builder.AddSystem(
        JointStateLogger(
            joint_names=joints,
            update_rate=rate,
            console_rate=console_rate if console_rate > 0 else 1.0,
            csv_path=csv_path,
            quiet=quiet or console_rate <= 0,
        )
    )
    logger.set_name("joint_state_logger")
    builder.Connect(view, logger.get_input_port())
    world.logger = logger
    world.closers.append(logger.close)


def _add_cameras(
    builder,
    world: World,
    scenario: Scenario,
    meshcat,
    where: str,
    source: str = "",
    host: str = "127.0.0.1",
) -> None:
    """RgbdSensors from the URDF's camera blocks, a live view and a frame saver."""
    settings = scenario.camera
    # The scenario's cameras are added whether or not camera.enabled is on.
    sensors = list(world.robot.cameras) if settings.enabled else []
    if settings.enabled and not world.robot.cameras and not scenario.cameras:
        _log.warning("camera enabled, but %s describes no camera sensor", world.robot.source)
        return
    if not settings.enabled and not scenario.cameras:
        return
    from armando_drake.sensors.camera import (
        AddCameraSensors,
        CameraError,
        choose_renderer,
        describe,
    )
    from armando_drake.sensors.image_view import AddFrameSaver, AddImageView

    try:
        sensors += [camera.sensor_info(source) for camera in scenario.cameras]
        renderer = choose_renderer(settings.renderer)
        world.cameras = AddCameraSensors(
            builder,
            world.plant,
            world.scene_graph,
            world.robot.model_instance,
            sensors,
            renderer=renderer,
            enable_depth=settings.depth,
            export=True,
        )
    except CameraError as error:  # a scenario camera's error names its origin already
        text = str(error)
        named = source and text.startswith(f"{source}: cameras")
        raise ScenarioError(text if named else f"{where}{text}") from None
    engine = {"gl": "RenderEngineGl", "vtk": "RenderEngineVtk"}[renderer]
    for camera in world.cameras.values():
        _log.info("camera %s, rendered by %s", describe(camera.info), engine)
    # A Meshcat kept only to record a replay (recording_only) has no viewer to go with.
    watched = meshcat is not None and not getattr(meshcat, "recording_only", False)
    if settings.live_view or watched:
        from armando_drake.tools.cli import warn_if_open

        warn_if_open(host, "the camera view")
        server = AddImageView(builder, world.cameras, host=host, depth=settings.depth)
        world.image_view_url = server.url
        world.image_view = server  # the detectors' annotated images join it
        world.closers.append(server.close)
    if settings.save_frames:
        for camera in world.cameras.values():
            AddFrameSaver(
                builder,
                camera,
                settings.save_frames,
                rate=settings.save_rate or None,
                depth=settings.depth,
            )
