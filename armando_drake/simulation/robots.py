"""The robots of a world: each one's description, hardware, controllers and drivers.

A scenario's robots are a map, ``robots: {name: entry}`` (the one robot of its
top-level ``robot:``, ``actuators:``, ``controllers:``, ``sequencer:``, ``twist:`` is
its only entry, :func:`~armando_drake.simulation.scenario.expand_robots`). The world
builder (:func:`~armando_drake.simulation.builder.MakeWorld`) assembles each the same
way, in phases, as one plant holds them all; each phase returns a typed handle per
robot that the next one takes: every robot's description goes into the plant
(:func:`AddRobotBodies`, a :class:`RobotBody`: standing in the world, free on its
wheels or mounted on another's link), the plant is finalized once between the hardware
interfaces' two halves (:func:`AddRobotStacks`, a :class:`RobotStack` with its
controller manager, its joint states and command inputs registered in the world's
publication table), then each robot's sequencer and twist sequence
(:func:`AddRobotDrivers`, a :class:`RobotDrivers` the builder adds the navigation, task
and jogs to), its wiring to the plant and its logs (:func:`ConnectRobot`, a
:class:`RobotWiring`) and its sensors; at the end, the frozen :class:`AddedRobot` the world
keeps is made once of them (:func:`FinishRobots`).

A robot with a namespace (``/left``) has its diagram ports ``left/joint_states``,
``left/<controller>.<topic>``, ..., its systems' names beginning with ``left/``, its logs
in ``<output>/left/``. The robot in the root namespace (the one of the top-level keys)
keeps the plain names.
"""

from __future__ import annotations

import contextlib
import dataclasses as dc
from pathlib import Path
from typing import Any

from pydrake.geometry import CollisionFilterDeclaration

from armando_drake.control.hardware import command_interfaces
from armando_drake.control.mobile import AddMobileBase, MobileBase
from armando_drake.control.sequencer import AddSequencer
from armando_drake.control.stack import (
    AddControllerManager,
    BeginHardware,
    ConnectControlStack,
    ControllerChoice,
    ControlStack,
    FinishHardware,
    LoadControllerConfig,
    choose_controllers,
    controller_update_rate,
)
from armando_drake.control.topics import RegisterSentCommands
from armando_drake.control.twist import AddTwistSequence
from armando_drake.description.loader import AddRobot, LoadedRobot
from armando_drake.messages.publications import PublicationRegistry
from armando_drake.outputs.base import BASE_CSV, AddBaseLogger
from armando_drake.outputs.logger import AddJointStateLogger, CommandsCsv
from armando_drake.outputs.mobile_topics import MobileSource
from armando_drake.sensors.registry import AddSensors
from armando_drake.simulation.scenario import (
    Scenario,
    ScenarioError,
    ScenarioRobot,
    scenario_robots,
    start_positions,
)
from armando_drake.simulation.validation import check_against_world


def output_folder(output_dir, folder: str) -> Path | None:
    """The robot's ``folder`` of ``output_dir`` (made), where its logs go; None without
    one."""
    if output_dir is None:
        return None
    path = Path(output_dir) / folder
    path.mkdir(parents=True, exist_ok=True)
    return path


@contextlib.contextmanager
def robot_scope(builder, folder: str):
    """The systems added inside get the robot's namespace ``folder`` ("left") before their
    names ("" in the root namespace: as they are)."""
    before = len(builder.GetSystems())
    yield
    if folder:
        for system in builder.GetSystems()[before:]:
            system.set_name(f"{folder}/{system.get_name()}")


@dc.dataclass(frozen=True)
class RobotBody:
    """A robot in the plant (:func:`AddRobotBodies`): its scenario entry, description,
    controller YAML and base."""

    spec: ScenarioRobot  # its entry, sections and origins
    robot: LoadedRobot
    controller_config: Any  # its controller YAML (ControllerManagerConfig)
    mobile: MobileBase  # how its base is held, its drives
    parent: RobotBody | None = None  # the robot it is mounted on, if any


@dc.dataclass(frozen=True)
class RobotStack:
    """A robot with its hardware interface and controller manager (:func:`AddRobotStacks`)."""

    body: RobotBody
    choice: ControllerChoice  # the controllers activated, the sequencer that drives them
    update_rate: int  # [Hz] its controller manager's
    stack: ControlStack  # its control stack, which the drivers and sensors add to


@dc.dataclass(frozen=True)
class RobotDrivers:
    """What drives a robot's controllers (:func:`AddRobotDrivers`, then the builder's
    navigation, task, learned IK and live jogs), each None when the scenario has none."""

    sequencer: Any = None  # the command sequencer
    sequencer_target: str = ""  # the controller it drives
    twist: Any = None  # the TwistSequencer, the Navigator or the TwistJog publishing cmd_vel
    twist_target: str = ""  # the drive it commands
    navigation: Any = None  # the Navigation (navigation.building)
    task: Any = None  # the TaskReference
    learned_ik: Any = None  # the LearnedIk
    jog: Any = None  # the arm's MeshcatJog


@dc.dataclass(frozen=True)
class RobotWiring:
    """A robot's commands to the plant and its loggers (:func:`ConnectRobot`)."""

    logger: Any = None  # its JointStateLogger, if a broadcaster is active
    gravity_feedforward: Any = None  # the gravity feed-forward's output, if any
    base_log: Any = None  # the BaseLogger of a floating base with a drive


@dc.dataclass(frozen=True)
class AddedRobot:
    """A robot of the built world: its name, namespace, control stack, what drives it,
    its sensors and loggers, the cameras on its links and the detectors and perception
    that act on it, made once at the end of its build (:func:`FinishRobot`)."""

    name: str  # its name in the robots map
    namespace: str  # "/left" ("" in the root namespace)
    robot: LoadedRobot
    stack: ControlStack  # hardware interface, controller manager, controllers
    mobile: MobileBase  # how its base is held, its drives
    choice: ControllerChoice  # the controllers activated, its sequencer
    sequencer: Any = None  # the command sequencer, if any
    sequencer_target: str = ""  # the controller it drives
    twist: Any = None  # the TwistSequencer (or Navigator, or TwistJog) publishing cmd_vel
    twist_target: str = ""  # the drive it commands
    navigation: Any = None  # the Navigation, if the scenario has one
    task: Any = None  # the TaskReference, if the scenario has a task
    learned_ik: Any = None  # the LearnedIk, if the scenario has learned_ik
    jog: Any = None  # the MeshcatJog, if the scenario has a jog and a Meshcat
    logger: Any = None  # its JointStateLogger, if a broadcaster is active
    gravity_feedforward: Any = None  # the gravity feed-forward's output, if any
    base_log: Any = None  # the BaseLogger of a floating base with a drive
    # The outputs of the description's other sensors (sensors.registry), by sensor name.
    sensors: dict = dc.field(default_factory=dict)
    cameras: dict = dc.field(default_factory=dict)  # AddedCamera on its links, by name
    detectors: Any = None  # AddedDetectors, if the scenario's vision acts on it
    perception: Any = None  # AddedPerception, if the scenario's perception acts on it

    @property
    def folder(self) -> str:
        """Its output subfolder ("" in the root namespace)."""
        return self.namespace.strip("/")

    @property
    def plant(self):
        """The world's MultibodyPlant, which holds it."""
        return self.stack.plant


def FinishRobot(
    robot: RobotStack, drivers: RobotDrivers, wiring: RobotWiring, **watching
) -> AddedRobot:
    """The robot as the built world keeps it, of what its build added: its stack,
    ``drivers``, ``wiring``; ``watching``: its sensors, the cameras on its links, the
    detectors and perception that act on it."""
    spec = robot.body.spec
    return AddedRobot(
        name=spec.name,
        namespace=spec.namespace,
        robot=robot.body.robot,
        stack=robot.stack,
        mobile=robot.body.mobile,
        choice=robot.choice,
        **_fields(drivers),
        **_fields(wiring),
        **watching,
    )


def _fields(handle) -> dict:
    """The fields of a dataclass ``handle``, by name (their values as they are)."""
    return {field.name: getattr(handle, field.name) for field in dc.fields(handle)}


def _parent_frame(plant, bodies: dict[str, RobotBody], spec: ScenarioRobot):
    """(the robot ``spec`` is mounted on, the frame of its link), or (None, None)."""
    if not spec.entry.parent:
        return None, None
    other, link = spec.entry.parent.split("::")
    parent = bodies[other]
    instance = parent.robot.model_instance
    if not plant.HasFrameNamed(link, instance):
        links = sorted(plant.get_body(i).name() for i in plant.GetBodyIndices(instance))
        file = spec.sources.file.rsplit(": robots.", 1)[0]
        raise ScenarioError(
            f"{file}: robots.{spec.name}.parent={spec.entry.parent!r}: robot "
            f"{other!r} has no link {link!r} (links: {', '.join(links)})"
        )
    return parent, plant.GetFrameByName(link, instance)


def _check_tool_link(plant, robot: LoadedRobot, spec: ScenarioRobot) -> None:
    """Refuses a ``tool_link`` that is not a link of the robot, naming its links."""
    link = spec.entry.tool_link
    if link and not plant.HasFrameNamed(link, robot.model_instance):
        links = sorted(plant.get_body(i).name() for i in plant.GetBodyIndices(robot.model_instance))
        file = spec.sources.file.rsplit(": robots.", 1)[0]
        raise ScenarioError(
            f"{file}: robots.{spec.name}.tool_link={link!r} is not a link of the robot "
            f"(links: {', '.join(links)})"
        )


def AddRobotBodies(plant, scene_graph, scenario: Scenario) -> dict[str, RobotBody]:
    """Each robot's description in ``plant`` (its own model instance), its controller
    YAML read, its base welded in the world or to its parent's link, or free."""
    bodies: dict[str, RobotBody] = {}
    for name, spec in scenario_robots(scenario).items():
        robot_config, controllers = spec.robot, spec.entry.controllers
        robot = AddRobot(plant, robot_config, weld=False, model_name=spec.model_name)
        # The controller YAML before the base is placed: a drive controller frees the base.
        config = LoadControllerConfig(
            controllers, robot, arguments=robot_config.xacro_args, prefix=spec.entry.prefix
        )
        parent, frame = _parent_frame(plant, bodies, spec)
        _check_tool_link(plant, robot, spec)
        mobile = AddMobileBase(
            plant,
            scene_graph,
            robot,
            robot_config,
            config,
            activate=controllers.activate,
            where=spec.where("robot.base"),
            parent=frame,
        )
        bodies[name] = RobotBody(spec, robot, config, mobile, parent)
    return bodies


def _begin(plant, scenario: Scenario, body: RobotBody):
    """(the controllers chosen, the update rate, the hardware's pending half): the rates
    checked, the hardware's actuators added."""
    spec, config = body.spec, body.controller_config
    entry = spec.entry
    # The scenario's default controllers stand for the file's own (one line each).
    choice = choose_controllers(entry.controllers.activate, config, entry.sequencer)
    update_rate = controller_update_rate(
        config, entry.controllers, spec.where("controllers.update_rate")
    )
    # Rates, gains and periods checked against the robot and the controller YAML.
    check_against_world(
        scenario,
        spec,
        sequencer=choice.sequencer,
        update_rate=update_rate,
        update_rate_source=config.source,
        joints=command_interfaces(body.robot, warn=False)[2],
    )
    gains = {**body.mobile.gains, **entry.actuators.gains}
    pending = BeginHardware(plant, body.robot, dc.replace(entry.actuators, gains=gains), config)
    return choice, update_rate, pending


def AddRobotStacks(
    builder,
    plant,
    scene_graph,
    scenario: Scenario,
    bodies: dict[str, RobotBody],
    publications: PublicationRegistry,
) -> dict[str, RobotStack]:
    """Each robot's hardware interface (the plant finalized once, in between) and its
    controller manager running the activated controllers (and a mobile base's drive
    plugins) of its controller YAML; its joint states and command inputs registered in
    ``publications``."""
    begun = {name: _begin(plant, scenario, body) for name, body in bodies.items()}
    plant.Finalize()
    stacks = {}
    for name, body in bodies.items():
        spec, (choice, update_rate, pending) = body.spec, begun[name]
        hardware = FinishHardware(
            plant,
            scene_graph,
            pending,
            self_collision=spec.entry.robot.self_collision,
            start_positions=start_positions(spec),
        )
        if body.parent is not None:  # a mounted robot does not collide with its carrier
            geometries = [
                plant.CollectRegisteredGeometries(
                    [plant.get_body(i) for i in plant.GetBodyIndices(b.robot.model_instance)]
                )
                for b in (body, body.parent)
            ]
            scene_graph.collision_filter_manager().Apply(
                CollisionFilterDeclaration().ExcludeBetween(*geometries)
            )
        controllers = spec.entry.controllers
        with robot_scope(builder, spec.folder):
            stack = AddControllerManager(
                builder,
                dc.replace(controllers, activate=body.mobile.activation(choice.activate)),
                plant=plant,
                robot=body.robot,
                hardware=hardware,
                controller_config=body.controller_config,
                update_rate=update_rate,
                sequencer=choice.sequencer,
                where=spec.where("controllers"),
                scene_graph=scene_graph,
                hold=choice.hold,
                namespace=spec.namespace,
                publications=publications,
                drive_plugins=body.mobile.plugins,
            )
        stacks[name] = RobotStack(body, choice, update_rate, stack)
    return stacks


def AddRobotDrivers(
    builder, robot: RobotStack, commands_csv: Path | None, closers: list
) -> RobotDrivers:
    """The robot's command sequencer (its commands in ``commands_csv``) and twist
    sequence, on its controllers."""
    spec, stack, sequencer = robot.body.spec, robot.stack, robot.choice.sequencer
    added, target, twist, twist_target = None, "", None, ""
    with robot_scope(builder, spec.folder):
        if sequencer is not None:

            def commands_log(joints):  # commands.csv, for the joints the sequencer drives
                log = CommandsCsv(commands_csv, joints)
                closers.append(log.close)
                return log

            added, target = AddSequencer(
                builder,
                sequencer,
                stack,
                commands_log=commands_log if commands_csv is not None else None,
                where=spec.where("sequencer"),
                velocity_limits=spec.entry.actuators.velocity_limits,
            )
        if spec.entry.twist is not None:
            twist, twist_target = AddTwistSequence(
                builder, spec.entry.twist, stack, where=spec.where("twist")
            )
    return RobotDrivers(added, target, twist, twist_target)


def ConnectRobot(
    builder,
    scenario: Scenario,
    robot: RobotStack,
    drivers: RobotDrivers,
    output_dir,
    closers: list,
    *,
    quiet: bool,
) -> RobotWiring:
    """The robot's commands to the plant (desired state, efforts, gravity feed-forward),
    its joint-state logger (``joint_states.csv`` in ``output_dir``) and its base's logger
    (``base.csv``)."""
    spec, stack = robot.body.spec, robot.stack
    with robot_scope(builder, spec.folder):
        sequencer = drivers.sequencer
        tick = sequencer.GetOutputPort("tick_command") if stack.stream_controller else None
        gravity_feedforward = ConnectControlStack(
            builder,
            stack,
            gravity_feedforward=spec.entry.actuators.gravity_feedforward,
            tick_command=tick,
            velocity_limits=spec.entry.actuators.velocity_limits,
        )
        logger = AddJointStateLogger(
            builder, scenario.logging, stack, output_dir=output_dir, quiet=quiet
        )
        if logger is not None:
            closers.append(logger.close)
        twist = drivers.twist
        command = twist.GetOutputPort("command") if twist is not None else None
        csv_path = None if output_dir is None else Path(output_dir) / BASE_CSV
        log = AddBaseLogger(builder, stack, robot.body.mobile, command=command, csv_path=csv_path)
        if log is not None:
            closers.append(log.close)
    return RobotWiring(logger, gravity_feedforward, log)


def AddRobotSensors(builder, plant, robot: RobotStack, publications: PublicationRegistry) -> dict:
    """The sensors of the robot's description (a lidar; cameras are
    :func:`~armando_drake.sensors.cameras.AddCameras`'), on its links, their outputs
    ``<namespace>/<sensor>.<output>``, by sensor name; their topics registered in
    ``publications``."""
    spec = robot.body.spec
    with robot_scope(builder, spec.folder):
        return AddSensors(
            builder, robot.body.robot.sensors, plant=plant, robot=robot.body.robot,
            namespace=spec.namespace, publications=publications,
        )  # fmt: skip


def ConnectRobots(
    builder, scenario: Scenario, stacks: dict, drivers: dict, output_dir, closers, *, quiet
) -> dict[str, RobotWiring]:
    """:func:`ConnectRobot` of each robot (its logs in its folder of ``output_dir``), by
    name."""
    return {
        name: ConnectRobot(
            builder,
            scenario,
            stack,
            drivers[name],
            output_folder(output_dir, stack.body.spec.folder),
            closers,
            quiet=quiet,
        )
        for name, stack in stacks.items()
    }


def RegisterDriverCommands(
    publications: PublicationRegistry, robot: RobotStack, drivers: RobotDrivers
) -> None:
    """The commands the robot's sequencer, live jog or task sends, registered on the topic
    of the controller it drives (a jog or task is on the robot it names only)."""
    RegisterSentCommands(
        publications,
        robot.stack,
        sequencer=drivers.sequencer,
        target=drivers.sequencer_target,
        jog=drivers.jog,
        task=drivers.task,
    )


def FinishRobots(
    stacks: dict, drivers: dict, wiring: dict, watching: dict, publications
) -> dict[str, AddedRobot]:
    """Each robot as the world keeps it, made once of what its build added
    (``watching``: by robot name, its sensors, cameras, detectors and perception), its
    base's topics (odometry, /tf, cmd_vel) registered in ``publications``; by name."""
    robots = {}
    for name, stack in stacks.items():
        robot = FinishRobot(stack, drivers[name], wiring[name], **watching[name])
        publications.add(
            *MobileSource(robot.stack, robot.base_log, robot.twist, robot.twist_target).table()
        )
        robots[name] = robot
    return robots
