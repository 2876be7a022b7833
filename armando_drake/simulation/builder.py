"""The world builder: one function turns a :class:`Scenario` into a Drake diagram.

Every entry point (``python -m armando_drake.world``, the notebooks, the tests)
calls :func:`MakeWorld`; none wires systems by hand. The steps follow the
bring-up of the course: spawn the robot in a physics world, give it a position
hardware interface, start the ros2_control controllers from their YAML (all of
them in one :class:`~armando_drake.control.manager.ControllerManager`
system, as upstream's controller_manager runs them in one loop), then add
what drives and watches them (command sequencer, joint-state logger,
camera, Meshcat).

Ports of the diagram, by name:

- ``<controller>.commands`` / ``<controller>.joint_trajectory``: command
  inputs of the active position / trajectory controllers that no sequencer
  drives (a :class:`~armando_drake.control.messages.Publication`; see
  :meth:`World.publish`);
- ``<controller>.status``: each command controller's ControllerStatus;
- ``joint_states``: the broadcaster's JointState;
- ``desired_state``: [q_d; v_d] sent to the actuators, hardware joint order;
- ``<camera>.color_image`` / ``<camera>.depth_image`` when the camera is on.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydrake.geometry import Box, Meshcat
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    CoulombFriction,
    MultibodyPlant,
)
from pydrake.systems.framework import Context, Diagram, DiagramBuilder
from pydrake.visualization import ApplyVisualizationConfig

from armando_drake.control.config import (
    ControllerConfig,
    ControllerManagerConfig,
    load_controller_config,
    parse_controller_config,
    validate_joints,
)
from armando_drake.control.controllers import (
    JointStateBroadcasterLogic,
    PositionControllerLogic,
    TrajectoryControllerLogic,
)
from armando_drake.control.hardware import (
    AddHardwareInterface,
    FinishHardwareInterface,
    GravityFeedforward,
    HardwareInterface,
)
from armando_drake.control.manager import ControllerManager, ManagedController
from armando_drake.control.messages import Publication
from armando_drake.description.importer import default_controller_config
from armando_drake.description.loader import LoadedRobot, load_robot
from armando_drake.sensors.objects import AddSceneObjects
from armando_drake.simulation.scenario import Scenario, ScenarioError

_log = logging.getLogger("armando_drake.world")

POSITION_TYPES = (
    "position_controllers/JointGroupPositionController",
    "forward_command_controller/ForwardCommandController",
)
TRAJECTORY_TYPE = "joint_trajectory_controller/JointTrajectoryController"
BROADCASTER_TYPE = "joint_state_broadcaster/JointStateBroadcaster"


@dataclass
class World:
    """The built diagram and handles to its parts."""

    diagram: Diagram
    plant: MultibodyPlant
    scene_graph: Any
    robot: LoadedRobot
    hardware: HardwareInterface
    controller_config: ControllerManagerConfig
    update_rate: float  # [Hz] the controller manager's rate
    # Active command controllers by name -> the system that runs them (the controller
    # manager), whose ports are "<name>.commands" / "<name>.joint_trajectory", "<name>.status".
    controllers: dict[str, Any] = field(default_factory=dict)
    controller_joints: dict[str, list[str]] = field(default_factory=dict)  # by name
    broadcaster: Any = None  # the system with the "joint_states" output (the manager)
    controller_manager: Any = None  # ControllerManager: broadcaster and controllers
    sequencer: Any = None
    logger: Any = None
    sequencer_target: str = ""  # the controller the sequencer drives
    broadcaster_name: str = ""  # the active joint state broadcaster's name in the YAML
    cameras: dict[str, Any] = field(default_factory=dict)  # AddedCamera by name
    image_view_url: str | None = None  # the live camera view, when served
    perception: Any = None  # AddedPerception when the scenario has a perception block
    meshcat: Meshcat | None = None
    closers: list = field(default_factory=list)  # called by close()

    def publish(self, context: Context, controller: str, message: Any) -> None:
        """Publishes ``message`` on a controller's command input, like a ROS topic."""
        port = self.command_port(controller)
        previous = port.Eval(context) if port.HasValue(context) else Publication()
        port.FixValue(context, previous.publish(message, stamp=context.get_time()))

    def command_port(self, controller: str):
        for suffix in ("commands", "joint_trajectory"):
            name = f"{controller}.{suffix}"
            if self.diagram.HasInputPort(name):
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
        logger has recorded since its last flush; then closes every file and server."""
        if context is not None and self.logger is not None and self.closers:
            self.logger.flush(self.logger.GetMyContextFromRoot(context))
        for closer in self.closers:
            closer()
        self.closers.clear()


def _controller_config(scenario: Scenario, robot: LoadedRobot, hardware) -> ControllerManagerConfig:
    """The controller YAML of the scenario, of the description package, or a default."""
    path = scenario.controllers.config
    if path:
        return load_controller_config(Path(path))
    package_dir = robot.source.parent.parent
    candidates = sorted((package_dir / "config").glob("*controllers*.yaml"))
    if candidates and (package_dir / "package.xml").is_file():
        return load_controller_config(candidates[0])
    data = default_controller_config(hardware.joint_names)
    return parse_controller_config(data, source=f"<default controllers of {robot.name}>")


def _add_ground(plant: MultibodyPlant) -> None:
    """A 2 m x 2 m slab whose top face is the plane z = 0."""
    X_WG = RigidTransform([0.0, 0.0, -0.025])
    ground = Box(2.0, 2.0, 0.05)
    plant.RegisterCollisionGeometry(
        plant.world_body(), X_WG, ground, "ground", CoulombFriction(0.8, 0.8)
    )
    plant.RegisterVisualGeometry(
        plant.world_body(), X_WG, ground, "ground", np.array([0.85, 0.85, 0.82, 1.0])
    )


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
) -> World:
    """Builds the world diagram of ``scenario``.

    ``meshcat``: draw the world there (when the scenario's visualization is on).
    ``output_dir``: where the logger writes ``joint_states.csv`` (none: no CSV)
    and, with ``write_commands``, the sequencer's ``commands.csv``.
    ``source``: the scenario file, named in error messages.
    ``record``: an ``.mcap`` file where the run's topics are recorded as a ROS 2 bag
    (:func:`~armando_drake.outputs.recording.AddRosbagRecorder`).
    """
    where = f"{source}: " if source else ""
    builder = DiagramBuilder()
    plant_config = scenario.plant_config
    if plant_config.time_step > 0 and plant_config.discrete_contact_approximation == "tamsi":
        raise ScenarioError(
            f"{where}plant_config.discrete_contact_approximation='tamsi' ignores PD actuator "
            "gains; use 'lagged', 'sap' or 'similar'"
        )
    from pydrake.multibody.plant import ApplyMultibodyPlantConfig

    plant, scene_graph = AddMultibodyPlant(plant_config, builder)
    ApplyMultibodyPlantConfig(plant_config, plant)

    # Spawn the robot: load the description and weld its base at the spawn pose.
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
    AddSceneObjects(plant, scenario.objects)

    # The hardware interface: PD actuators from <ros2_control>.
    actuators = scenario.actuators
    hardware = AddHardwareInterface(
        plant, robot, kp=actuators.kp, kd=actuators.kd, gains=actuators.gains
    )
    plant.Finalize()
    if not robot_config.self_collision:
        _exclude_self_collision(plant, scene_graph, robot)
    FinishHardwareInterface(plant, robot, hardware)
    _log.info(
        "hardware interface %r (%s): %s",
        hardware.name,
        hardware.source,
        ", ".join(f"{j.name} [{j.lower:.2f}, {j.upper:.2f}]" for j in hardware.joints),
    )

    # The controller manager: read the YAML, then load and activate controllers.
    config = _controller_config(scenario, robot, hardware)
    validate_joints(config, hardware.joint_names, config.source)
    rate = float(config.update_rate)
    world = World(
        diagram=None,  # set below
        plant=plant,
        scene_graph=scene_graph,
        robot=robot,
        hardware=hardware,
        controller_config=config,
        update_rate=rate,
        meshcat=meshcat,
    )
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
            rate,
        )
        if controller.type == BROADCASTER_TYPE:
            if broadcaster is not None:
                raise ScenarioError(
                    f"{where}controllers.activate names two joint state broadcasters "
                    f"({world.broadcaster_name!r} and {name!r}); activate one"
                )
            broadcaster = JointStateBroadcasterLogic(joint_names=joints)
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

    # The controller manager runs them all in one update at the update rate.
    if broadcaster is not None or managed:
        gravity = None
        if managed and actuators.gravity_feedforward:
            gravity = GravityFeedforward(plant, robot, hardware)
        manager = builder.AddSystem(
            ControllerManager(
                hardware=hardware,
                update_rate=rate,
                broadcaster=broadcaster,
                controllers=managed,
                gravity=gravity,
            )
        )
        manager.set_name("controller_manager")
        world.controller_manager = manager
        builder.Connect(
            plant.get_state_output_port(robot.model_instance), manager.GetInputPort("state")
        )
        builder.Connect(
            plant.get_net_actuation_output_port(robot.model_instance),
            manager.GetInputPort("effort"),
        )
        if broadcaster is not None:
            builder.ExportOutput(manager.GetOutputPort("joint_states"), "joint_states")
            world.broadcaster = manager
        for controller in managed:
            world.controllers[controller.name] = manager

    # Desired state for the actuators: the controllers' commands, unclaimed joints
    # held at their initial positions; the gravity feed-forward on the actuation input.
    if managed:
        desired = manager.GetOutputPort("desired_state")
        builder.Connect(desired, plant.get_desired_state_input_port(robot.model_instance))
        builder.ExportOutput(desired, "desired_state")
        if gravity is not None:
            builder.Connect(
                manager.GetOutputPort("feedforward"),
                plant.get_actuation_input_port(robot.model_instance),
            )

    commands_csv = Path(output_dir) / "commands.csv" if output_dir and write_commands else None
    _add_sequencer(builder, world, scenario, where, commands_csv)
    _add_logger(builder, world, scenario, output_dir, quiet)
    _add_cameras(builder, world, scenario, meshcat, where)
    # Perception (issue #19): point clouds and the pipeline of scenario.perception.
    from armando_drake.perception.systems import AddPerception

    world.perception = AddPerception(
        builder,
        world,
        scenario.perception,
        meshcat=meshcat,
        output_dir=output_dir if write_commands else None,
        source=source,
    )
    if record is not None:
        from armando_drake.outputs.recording import AddRosbagRecorder

        AddRosbagRecorder(builder, world, record)

    if meshcat is not None and scenario.visualization.enable_meshcat_creation:
        ApplyVisualizationConfig(
            scenario.visualization, builder, plant=plant, scene_graph=scene_graph, meshcat=meshcat
        )
        meshcat.SetProperty("/drake/proximity", "visible", False)

    # Export what no system drives, for notebooks and tests.
    for name, system in world.controllers.items():
        for port_name in (f"{name}.commands", f"{name}.joint_trajectory"):
            if system.HasInputPort(port_name):
                port = system.GetInputPort(port_name)
                if not _is_connected(builder, port):
                    builder.ExportInput(port, port_name)
        builder.ExportOutput(system.GetOutputPort(f"{name}.status"), f"{name}.status")
    world.diagram = builder.Build()
    world.diagram.set_name("armando_world")
    return world


def _controller_name(entry: str, config: ControllerManagerConfig, where: str) -> str:
    """A controller name, or for ``type:<plugin>`` the first controller of that type.

    A position controller may also be a ForwardCommandController on the
    position interface.
    """
    if not entry.startswith("type:"):
        return entry
    wanted = entry[len("type:") :]
    types = POSITION_TYPES if wanted in POSITION_TYPES else (wanted,)
    for name, controller in config.controllers.items():
        if controller.type in types:
            return name
    raise ScenarioError(
        f"{where}controllers.activate asks for a {wanted} controller; {config.source} "
        f"defines none (defined: {', '.join(config.controllers) or 'none'})"
    )


def _is_connected(builder: DiagramBuilder, port) -> bool:
    return builder.IsConnectedOrExported(port)


def _managed_controller(world: World, controller: ControllerConfig, joints) -> ManagedController:
    """The logic of a position or trajectory controller on ``joints``, for the manager."""
    hardware = world.hardware
    rows = hardware.find(joints)
    lower = [hardware.joints[i].lower for i in rows]
    upper = [hardware.joints[i].upper for i in rows]
    initial = [hardware.joints[i].initial_position for i in rows]
    name = controller.name
    if controller.type in POSITION_TYPES:
        logic = PositionControllerLogic(
            joint_names=joints,
            lower=lower,
            upper=upper,
            initial_positions=initial,
            log_name=lambda: name,
        )
        return ManagedController(name=name, logic=logic, topic="commands")
    if controller.type == TRAJECTORY_TYPE:
        logic = TrajectoryControllerLogic(
            joint_names=joints,
            lower=lower,
            upper=upper,
            params=controller.params,
            initial_positions=initial,
            log_name=lambda: name,
        )
        return ManagedController(name=name, logic=logic, topic="joint_trajectory")
    # The config loader only lets supported types through.
    raise ScenarioError(f"controller {name!r} has unsupported type {controller.type!r}")


def _add_sequencer(builder, world: World, scenario: Scenario, where: str, commands_csv) -> None:
    config = scenario.sequencer
    if config is None:
        return
    from armando_drake.control.sequencer import CommandSequencer, validate
    from armando_drake.outputs.logger import CommandsCsv

    wanted = TRAJECTORY_TYPE if config.mode == "trajectory" else POSITION_TYPES
    targets = [
        (name, system)
        for name, system in world.controllers.items()
        if world.controller_config.controllers[name].type in wanted
    ]
    if not targets:
        kind = "trajectory" if config.mode == "trajectory" else "position"
        raise ScenarioError(
            f"{where}sequencer.mode={config.mode!r} needs an active {kind} controller; "
            f"active: {', '.join(world.controllers) or 'none'}"
        )
    name, controller = targets[0]
    joints = world.controller_joints[name]
    rows = world.hardware.find(joints)
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
    sequencer = builder.AddSystem(
        CommandSequencer(
            config=config,
            joint_names=joints,
            controller_rate=world.update_rate,
            on_publish=on_publish,
        )
    )
    sequencer.set_name("command_sequencer")
    port = "joint_trajectory" if config.mode == "trajectory" else "commands"
    builder.Connect(sequencer.GetOutputPort(port), controller.GetInputPort(f"{name}.{port}"))
    builder.ExportOutput(sequencer.GetOutputPort("reference"), "reference")
    world.sequencer = sequencer
    world.sequencer_target = name


def _add_logger(builder, world: World, scenario: Scenario, output_dir, quiet: bool) -> None:
    """The joint state logger on what the broadcaster publishes: the plant's state and
    net actuation of the broadcaster's joints, sampled at the controllers' rate."""
    if world.broadcaster is None:
        return
    from pydrake.systems.primitives import Multiplexer

    from armando_drake.outputs.logger import JointStateLogger

    plant, instance, hardware = world.plant, world.robot.model_instance, world.hardware
    joints = world.controller_joints[world.broadcaster_name]
    rows = hardware.find(joints)
    state = plant.get_state_output_port(instance)
    effort = plant.get_net_actuation_output_port(instance)
    sample = builder.AddSystem(Multiplexer([state.size(), effort.size()]))
    sample.set_name("joint_state_sample")
    builder.Connect(state, sample.get_input_port(0))
    builder.Connect(effort, sample.get_input_port(1))

    csv_path = None if output_dir is None else Path(output_dir) / "joint_states.csv"
    console_rate = scenario.logging.console_rate
    logger = builder.AddSystem(
        JointStateLogger(
            joint_names=joints,
            update_rate=world.update_rate,
            input_size=state.size() + effort.size(),
            position_index=[hardware.position_index[i] for i in rows],
            velocity_index=[hardware.velocity_index[i] for i in rows],
            effort_index=[state.size() + i for i in rows],
            console_rate=console_rate if console_rate > 0 else 1.0,
            csv_path=csv_path,
            quiet=quiet or console_rate <= 0,
        )
    )
    logger.set_name("joint_state_logger")
    builder.Connect(sample.get_output_port(), logger.get_input_port())
    world.logger = logger
    world.closers.append(logger.close)


def _add_cameras(builder, world: World, scenario: Scenario, meshcat, where: str) -> None:
    """RgbdSensors from the URDF's camera blocks, a live view and a frame saver."""
    settings = scenario.camera
    if not settings.enabled:
        return
    if not world.robot.cameras:
        _log.warning("camera enabled, but %s describes no camera sensor", world.robot.source)
        return
    from armando_drake.sensors.camera import (
        AddCameraSensors,
        CameraError,
        choose_renderer,
        describe,
    )
    from armando_drake.sensors.image_view import AddFrameSaver, AddImageView

    try:
        renderer = choose_renderer(settings.renderer)
    except CameraError as error:
        raise ScenarioError(f"{where}{error}") from None
    world.cameras = AddCameraSensors(
        builder,
        world.plant,
        world.scene_graph,
        world.robot.model_instance,
        world.robot.cameras,
        renderer=renderer,
        enable_depth=settings.depth,
        export=True,
    )
    engine = {"gl": "RenderEngineGl", "vtk": "RenderEngineVtk"}[renderer]
    for camera in world.cameras.values():
        _log.info("camera %s, rendered by %s", describe(camera.info), engine)
    # A Meshcat kept only to record a replay (recording_only) has no viewer to go with.
    watched = meshcat is not None and not getattr(meshcat, "recording_only", False)
    if settings.live_view or watched:
        server = AddImageView(builder, world.cameras, depth=settings.depth)
        world.image_view_url = server.url
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
