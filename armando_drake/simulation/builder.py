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
  inputs of the active controllers that no sequencer, task, learned IK or live jog
  drives (a :class:`~armando_drake.messages.types.Publication`; see
  :meth:`World.publish`);
- ``<controller>.status``: each command controller's ControllerStatus;
- ``joint_states``: the broadcaster's JointState;
- ``desired_state``: [q_d; v_d] sent to the actuators, hardware joint order;
- ``<camera>.color_image`` / ``<camera>.depth_image`` when the camera is on.
"""

from __future__ import annotations

import dataclasses as dc
import os
from functools import partial

from pydrake.geometry import Meshcat
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import AddMultibodyPlant, ApplyMultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

from armando_drake.control.stack import ExportFreeControllerPorts
from armando_drake.description.worlds import AddWorld
from armando_drake.messages.publications import PublicationRegistry
from armando_drake.navigation.building import AddNavigation, ConnectLocalization
from armando_drake.outputs.navigation_view import AddNavigationView
from armando_drake.outputs.recording import AddRosbagRecorder
from armando_drake.outputs.replay import AddVisualization
from armando_drake.outputs.scan_view import AddScanViews
from armando_drake.perception.add import AddPerception
from armando_drake.ros2.bridge import AddRos2Bridge, BridgeRobot
from armando_drake.sensors import lidar  # noqa: F401  (registers the lidar sensor types)
from armando_drake.sensors.cameras import AddCameras
from armando_drake.sensors.objects import AddFloor, AddGround, AddSceneObjects, SceneObjectError
from armando_drake.simulation.robots import (
    AddRobotBodies,
    AddRobotDrivers,
    AddRobotSensors,
    AddRobotStacks,
    ConnectRobots,
    FinishRobots,
    RegisterDriverCommands,
    RobotStack,
    output_folder,
    robot_scope,
)
from armando_drake.simulation.scenario import Scenario, ScenarioError, sources_of
from armando_drake.simulation.validation import check_scenario
from armando_drake.simulation.world import World
from armando_drake.task.learned_ik import AddLearnedIk
from armando_drake.task.reference import AddTask
from armando_drake.teleop.add import AddTeleop
from armando_drake.vision.add import AddDetectors


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
    closers = []
    # What the world publishes and subscribes: each subsystem registers its topics.
    publications = PublicationRegistry()
    # Every value of the scenario checked before Drake sees it; its robots as a map.
    scenario = check_scenario(scenario, source)
    builder = DiagramBuilder()
    # The physics, each robot at its spawn pose (welded, mounted or free), the ground and
    # the objects.
    plant, scene_graph, bodies = _add_physics(builder, scenario, where)
    # Each robot's hardware interface and controller manager of its controller YAML.
    stacks = AddRobotStacks(builder, plant, scene_graph, scenario, bodies, publications)
    # What drives the controllers: the command sequencers, the task, the live jog (each on
    # the robot it names), and the commands they send, recorded.
    commands_dir = output_dir if write_commands else None
    drivers = _add_drivers(builder, scenario, stacks, commands_dir, meshcat, publications, closers)
    # The commands to the plant (desired state, efforts, gravity feed-forward) and the
    # joint-state and base loggers.
    wiring = ConnectRobots(builder, scenario, stacks, drivers, output_dir, closers, quiet=quiet)
    # What watches them: the cameras, each robot's sensors, the detectors, perception.
    clusters_dir = output_dir if write_commands else None
    places = (source, clusters_dir, host)
    image_view, seen = _add_sensing(
        builder, scenario, stacks, drivers, scene_graph, meshcat, places, publications
    )
    closers += [image_view.close] if image_view is not None else []
    closers += [close for watching in seen.values() for close in watching.pop("closers")]
    # Each robot as the world keeps it, made once; its base's and navigation's topics.
    robots = FinishRobots(stacks, drivers, wiring, seen, publications)
    # The ROS 2 bag recorder, the live DDS / Foxglove bridge, Meshcat.
    table = publications.table()
    replay_sampler, bridge = _add_outputs(
        builder, scenario, robots, table, scene_graph, meshcat, record, closers
    )
    # Export what no system drives (command inputs, statuses), for notebooks and tests.
    for robot in robots.values():
        ExportFreeControllerPorts(builder, robot.stack)
    diagram = builder.Build()
    diagram.set_name("armando_world")
    return World(
        diagram=diagram,
        plant=plant,
        scene_graph=scene_graph,
        robots=robots,
        publications=table,
        meshcat=meshcat,
        image_view=image_view,
        replay_sampler=replay_sampler,
        ros2_bridge=bridge,
        closers=closers,
    )


def _origin(scenario: Scenario, key: str) -> str:
    """``"<origin>: "``: the file, ``--set`` or option the scenario's ``key`` came from."""
    return f"{sources_of(scenario).of(key)}: "


def _add_physics(builder: DiagramBuilder, scenario: Scenario, where: str):
    """The plant and scene graph of ``scenario.plant_config``; each robot at its spawn
    pose (welded, mounted, or free on its wheels), the ground and the objects; (plant,
    scene graph, the robots' bodies by name)."""
    plant, scene_graph = AddMultibodyPlant(scenario.plant_config, builder)
    ApplyMultibodyPlantConfig(scenario.plant_config, plant)
    bodies = AddRobotBodies(plant, scene_graph, scenario)
    if scenario.world_file:
        where = _origin(scenario, "world_file")
        paths = scenario.world_resource_paths
        packages = [p for entry in scenario.robots.values() for p in entry.robot.package_paths]
        AddWorld(
            plant, scenario.world_file, resource_paths=paths, package_paths=packages, where=where
        )
    elif scenario.ground:
        floating = any(body.mobile.floating for body in bodies.values())
        (AddFloor if floating else AddGround)(plant, scene_graph)
    try:
        AddSceneObjects(plant, scenario.objects)
    except SceneObjectError as error:
        raise ScenarioError(f"{where}objects: {error}") from None
    return plant, scene_graph, bodies


def _add_drivers(builder, scenario, stacks, commands_dir, meshcat, publications, closers):
    """Each robot's drivers (:func:`_add_robot_drivers`), its sequencer's commands in
    ``commands.csv`` of ``commands_dir`` (None: none), the commands they send
    registered; by robot name."""
    drivers = {}
    for name, stack in stacks.items():
        folder = output_folder(commands_dir, stack.body.spec.folder)
        csv = folder / "commands.csv" if folder else None
        added = AddRobotDrivers(builder, stack, csv, closers)
        with robot_scope(builder, stack.body.spec.folder):
            drivers[name] = _add_robot_drivers(
                builder, scenario, stack, added, meshcat, closers, publications
            )
        RegisterDriverCommands(publications, stack, drivers[name])
    return drivers


def _add_robot_drivers(builder, scenario: Scenario, robot: RobotStack, drivers, meshcat, closers,
                       publications):  # fmt: skip
    """The scenario's navigation, task, learned IK and live jogs (the arm's, the base's)
    that act on ``robot``, on its controllers; ``drivers`` (its sequencers) with them.
    ``publications``: where the navigation registers its topics."""
    spec, stack, where = robot.body.spec, robot.stack, partial(_origin, scenario)
    config = spec.entry.robot
    navigation, task = spec.section("navigation"), spec.section("task")
    learned_ik = spec.section("learned_ik")
    found = {}
    if navigation is not None:
        nav = AddNavigation(
            builder, navigation, stack, where=where("navigation"), publications=publications
        )
        found.update(navigation=nav, twist=nav.navigator, twist_target=nav.drive)
    if task is not None:
        found["task"] = AddTask(builder, task, stack, meshcat=meshcat, where=where("task"))
    if learned_ik is not None:
        base = RigidTransform(RollPitchYaw(config.base_rpy), config.base_xyz)
        found["learned_ik"] = AddLearnedIk(
            builder, learned_ik, stack, base_pose=base, where=where("learned_ik")
        )
    jogs = (spec.section("jog"), spec.section("twist_jog"))
    jog, base_jog = AddTeleop(builder, *jogs, stack, meshcat=meshcat, where=where, closers=closers)
    found["jog"] = jog
    if base_jog is not None:
        found.update(twist=base_jog, twist_target=base_jog.controller)
    return dc.replace(drivers, **found)


def _add_sensing(builder, scenario, stacks, drivers, scene_graph, meshcat, where, publications):
    """The cameras (their live view, returned, or None), each robot's sensors, the
    detectors and perception on the robot they act on, with their topics registered in
    ``publications``; ``where``: (the scenario file, the folder of ``clusters.json``,
    the view's host). Returns (the live view, what watches each robot by robot name:
    its sensors, the cameras on its links, its detectors and perception, the
    ``closers`` of their logs)."""
    source, output_dir, host = where
    plant = next(iter(stacks.values())).stack.plant  # the world's one plant
    cameras, image_view = AddCameras(
        builder,
        scenario.camera,
        plant=plant,
        scene_graph=scene_graph,
        robots={name: robot.body.robot for name, robot in stacks.items()},
        namespaces={name: robot.body.spec.namespace for name, robot in stacks.items()},
        extra=scenario.cameras,
        meshcat=meshcat,
        host=host,
        where=f"{source}: " if source else "",
        source=sources_of(scenario).of("cameras"),
        publications=publications,
    )
    seen = {}
    for name, robot in stacks.items():
        sensors = AddRobotSensors(builder, plant, robot, publications)  # a lidar
        ConnectLocalization(builder, drivers[name].navigation, sensors)  # AMCL reads one
        on_robot = {key: cam for key, cam in cameras.items() if cam.info.robot == name}
        seen[name] = dict(sensors=sensors, cameras=on_robot) | _add_watchers(
            builder, scenario, robot, drivers[name], cameras, image_view, meshcat,
            (source, output_dir), publications,
        )  # fmt: skip
    return image_view, seen


def _add_watchers(builder, scenario, robot, drivers, cameras, image_view, meshcat, where, pubs):
    """The detectors and perception that act on ``robot`` (its scenario sections
    ``vision:`` and ``perception:``), on the world's ``cameras``, their topics registered
    in ``pubs``; by field name, with the ``closers`` of their logs."""
    source, output_dir = where
    spec, stack = robot.body.spec, robot.stack
    vision, perception = spec.section("vision"), spec.section("perception")
    detectors = added = None
    if vision is not None:
        detectors = AddDetectors(
            builder,
            vision,
            stack,
            cameras=cameras,
            image_view=image_view,
            where=_origin(scenario, "vision"),
            console=scenario.logging.console_rate > 0,  # no console output: no keypoints
            navigation=drivers.navigation,
            publications=pubs,
        )
    if perception is not None:
        added = AddPerception(
            builder,
            perception,
            cameras=cameras,
            robot_source=str(stack.robot.source),
            meshcat=meshcat,
            output_dir=output_dir,
            source=source,
            publications=pubs,
        )
    closers = [added.log.close] if added is not None and added.log else []
    return dict(detectors=detectors, perception=added, closers=closers)


def _add_outputs(builder, scenario: Scenario, robots, table, scene_graph, meshcat, record, closers):
    """The ROS 2 bag recorder (``record``), the live bridge and Meshcat's visualization,
    of the world's publication ``table``; (its replay sampler or None, the bridge or
    None)."""
    instances = [robot.robot.model_instance for robot in robots.values()]
    if record is not None:
        closers.append(AddRosbagRecorder(builder, record, table).close)
    bridged = [
        BridgeRobot(robot.stack, robot.mobile.base_link if robot.base_log is not None else "")
        for robot in robots.values()
    ]
    bridge = AddRos2Bridge(builder, scenario.ros2, table, bridged)
    if bridge is not None:
        closers.append(bridge.close)
    # Meshcat draws the world.
    replay_sampler = None
    if meshcat is not None and scenario.visualization.enable_meshcat_creation:
        plant = next(iter(robots.values())).plant  # the world's one plant
        bases = [
            plant.GetBodyByName(robot.mobile.base_link, robot.robot.model_instance)
            for robot in robots.values()
            if robot.mobile.floating
        ]
        replay_sampler = AddVisualization(
            builder,
            scenario.visualization,
            plant=plant,
            scene_graph=scene_graph,
            meshcat=meshcat,
            robot_instances=instances,
            ground=scenario.ground and not scenario.world_file,
            mobile_bases=bases,
        )
        # The lidars' scans as points; map, costmap, plan and goals.
        AddScanViews(builder, table, plant, meshcat)
        for robot in robots.values():
            AddNavigationView(builder, robot.navigation, meshcat, space=robot.folder)
    return replay_sampler, bridge
