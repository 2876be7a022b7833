"""The world builder: one function turns a :class:`Scenario` into a Drake diagram.

Every entry point (``python -m armando_drake.world``, the notebooks, the tests)
calls :func:`MakeWorld`; none wires systems by hand. :func:`MakeWorld` is a
straight sequence of subsystems that add themselves, as Drake's
``hardware_sim`` applies its configs: each ``AddX(builder, config, ...)`` lives
in its own package, takes its section of the scenario and the few plant parts
and ports it needs, and returns what the next ones connect to. The order
follows the bring-up of the course: spawn the robot in a physics world, give
it a hardware interface, start the ros2_control controllers of its YAML (all
in one controller manager, as upstream's controller_manager runs them in one
loop), then add what drives and watches them.

Ports of the diagram, by name:

- ``<controller>.<topic>`` (``commands``, ``joint_trajectory``, ...): command
  inputs of the active controllers that no sequencer, task or live jog drives (a
  :class:`~armando_drake.messages.types.Publication`; see :meth:`World.publish`);
- ``<controller>.status``: each command controller's ControllerStatus;
- ``joint_states``: the broadcaster's JointState;
- ``desired_state``: [q_d; v_d] sent to the actuators, hardware joint order;
- ``<camera>.color_image`` / ``<camera>.depth_image`` when the camera is on.
"""

from __future__ import annotations

import os
from pathlib import Path

from pydrake.geometry import Meshcat
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import AddMultibodyPlant, ApplyMultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

from armando_drake.control.hardware import command_interfaces
from armando_drake.control.sequencer import AddSequencer
from armando_drake.control.stack import (
    AddControllerManager,
    AddHardware,
    ConnectControlStack,
    ExportFreeControllerPorts,
    LoadControllerConfig,
    controller_update_rate,
)
from armando_drake.description.loader import load_robot
from armando_drake.outputs.logger import AddJointStateLogger, CommandsCsv
from armando_drake.outputs.recording import AddRosbagRecorder
from armando_drake.outputs.replay import AddVisualization
from armando_drake.outputs.topics import WorldTopics
from armando_drake.perception.systems import AddPerception
from armando_drake.ros2.bridge import AddRos2Bridge
from armando_drake.sensors.cameras import AddCameras
from armando_drake.sensors.objects import AddGround, AddSceneObjects, SceneObjectError
from armando_drake.simulation.scenario import Scenario, ScenarioError, sources_of
from armando_drake.simulation.validation import check_against_world, check_scenario
from armando_drake.simulation.world import World
from armando_drake.task.reference import AddTask
from armando_drake.teleop.jog import AddJog
from armando_drake.vision.detectors import AddDetectors


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
    and, with ``write_commands``, the sequencer's ``commands.csv`` and the
    perception's ``clusters.json``.
    ``source``: the scenario file, named in error messages.
    ``record``: an ``.mcap`` file where the run's topics are recorded as a ROS 2 bag
    (:func:`~armando_drake.outputs.recording.AddRosbagRecorder`).
    ``host``: the address the camera's live view listens on (``--host``, as Meshcat).
    """
    where = f"{source}: " if source else ""
    origin = lambda key: f"{sources_of(scenario).of(key)}: "  # noqa: E731 (one line)
    closers = []
    # Every value of the scenario checked before Drake sees it.
    check_scenario(scenario, source)
    builder = DiagramBuilder()
    # The physics: a MultibodyPlant and its SceneGraph, as the scenario configures them.
    plant, scene_graph = AddMultibodyPlant(scenario.plant_config, builder)
    ApplyMultibodyPlantConfig(scenario.plant_config, plant)
    # Spawn the robot (its base welded at the spawn pose), the ground and the objects.
    robot = load_robot(
        plant,
        scenario.robot.description or None,
        xacro_args=scenario.robot.xacro_args,
        package_paths=scenario.robot.package_paths,
        X_WB=RigidTransform(RollPitchYaw(scenario.robot.base_rpy), scenario.robot.base_xyz),
        collision=scenario.robot.collision,
    )
    if scenario.ground:
        AddGround(plant)
    try:
        AddSceneObjects(plant, scenario.objects)
    except SceneObjectError as error:
        raise ScenarioError(f"{where}objects: {error}") from None
    # The controller YAML (before the actuators: a ROS 1 file's gazebo_ros_control gains
    # are theirs) and its update rate, which the scenario may override.
    controller_config = LoadControllerConfig(scenario.controllers, robot)
    update_rate = controller_update_rate(
        controller_config, scenario.controllers, origin("controllers.update_rate")
    )
    # Rates, gains and periods checked against the robot and the controller YAML.
    check_against_world(
        scenario,
        update_rate=update_rate,
        update_rate_source=controller_config.source,
        joints=command_interfaces(robot, warn=False)[2],
    )
    # The hardware interface: an actuator per commanded joint; then the plant is final.
    hardware = AddHardware(
        plant,
        scene_graph,
        robot,
        scenario.actuators,
        controller_config,
        self_collision=scenario.robot.self_collision,
        start_positions=_start_positions(scenario, origin),
    )
    # The controller manager: the activated controllers of the YAML, in one system.
    stack = AddControllerManager(
        builder,
        scenario.controllers,
        plant=plant,
        robot=robot,
        hardware=hardware,
        controller_config=controller_config,
        update_rate=update_rate,
        sequencer=scenario.sequencer,
        where=origin("controllers"),
    )
    topics = WorldTopics(stack=stack)
    # What drives the controllers: the command sequencer, the task, the live jog.
    if scenario.sequencer is not None:

        def commands_log(joints):  # commands.csv, for the joints the sequencer drives
            log = CommandsCsv(Path(output_dir) / "commands.csv", joints)
            closers.append(log.close)
            return log

        topics.sequencer, topics.sequencer_target = AddSequencer(
            builder,
            scenario.sequencer,
            stack,
            commands_log=commands_log if output_dir and write_commands else None,
            where=origin("sequencer"),
        )
    if scenario.task is not None:
        topics.task = AddTask(builder, scenario.task, stack, meshcat=meshcat, where=origin("task"))
    if scenario.jog is not None:
        topics.jog = AddJog(builder, scenario.jog, stack, meshcat=meshcat, where=origin("jog"))
        if topics.jog is not None:
            closers.append(topics.jog.delete_controls)
    # The commands to the plant: desired state, efforts, gravity feed-forward.
    gravity_feedforward = ConnectControlStack(
        builder,
        stack,
        gravity_feedforward=scenario.actuators.gravity_feedforward,
        tick_command=(
            topics.sequencer.GetOutputPort("tick_command") if stack.stream_controller else None
        ),
    )
    # What watches them: the joint-state logger, the cameras, the detectors, perception.
    logger = AddJointStateLogger(
        builder,
        stack,
        console_rate=scenario.logging.console_rate,
        output_dir=output_dir,
        quiet=quiet,
    )
    if logger is not None:
        closers.append(logger.close)
    topics.cameras, image_view = AddCameras(
        builder,
        scenario.camera,
        plant=plant,
        scene_graph=scene_graph,
        robot=robot,
        extra=scenario.cameras,
        meshcat=meshcat,
        host=host,
        where=where,
        source=sources_of(scenario).of("cameras"),
    )
    if image_view is not None:
        closers.append(image_view.close)
    if scenario.vision is not None:
        topics.detectors = AddDetectors(
            builder,
            scenario.vision,
            stack,
            cameras=topics.cameras,
            image_view=image_view,
            where=origin("vision"),
            console=scenario.logging.console_rate > 0,  # no console output: no keypoints
        )
    if scenario.perception is not None:
        topics.perception = AddPerception(
            builder,
            scenario.perception,
            cameras=topics.cameras,
            robot_source=str(robot.source),
            meshcat=meshcat,
            output_dir=output_dir if write_commands else None,
            source=source,
        )
        if topics.perception.log is not None:
            closers.append(topics.perception.log.close)
    # The ROS 2 bag recorder and the live DDS / Foxglove bridge.
    if record is not None:
        closers.append(AddRosbagRecorder(builder, record, topics).close)
    bridge = AddRos2Bridge(builder, scenario.ros2, topics)
    if bridge is not None:
        closers.append(bridge.close)
    # Meshcat draws the world.
    replay_sampler = None
    if meshcat is not None and scenario.visualization.enable_meshcat_creation:
        replay_sampler = AddVisualization(
            builder,
            scenario.visualization,
            plant=plant,
            scene_graph=scene_graph,
            meshcat=meshcat,
            robot_instances=[robot.model_instance],
            ground=scenario.ground,
        )
    # Export what no system drives (command inputs, statuses), for notebooks and tests.
    ExportFreeControllerPorts(builder, stack)
    diagram = builder.Build()
    diagram.set_name("armando_world")
    return World(
        diagram=diagram,
        scene_graph=scene_graph,
        topics=topics,
        meshcat=meshcat,
        gravity_feedforward=gravity_feedforward,
        logger=logger,
        image_view=image_view,
        replay_sampler=replay_sampler,
        closers=closers,
    )


def _start_positions(scenario: Scenario, origin) -> list[tuple[list[float], str, str]]:
    """The joints' start positions the task and the jog give, with their origins."""
    starts = []
    if scenario.task is not None and scenario.task.start_positions:
        key = "task.start_positions"
        starts.append((scenario.task.start_positions, origin(key), key))
    if scenario.jog is not None and scenario.jog.home_positions:
        key = "jog.home_positions"
        starts.append((scenario.jog.home_positions, origin(key), key))
    return starts
