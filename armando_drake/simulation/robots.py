"""The robots of a world: each one's description, hardware, controllers and drivers.

A scenario holds one robot (its top-level ``robot:``, ``actuators:``, ``controllers:``,
``sequencer:``, ``twist:``) or several (``robots:``, each entry with those keys). The
world builder (:func:`~armando_drake.simulation.builder.MakeWorld`) assembles each the
same way, in phases, as one plant holds them all: every robot's description goes into the
plant (:func:`AddRobotBodies`: standing in the world, free on its wheels or mounted on
another's link), the plant is finalized once between the hardware interfaces' two halves
(:func:`AddRobotStacks`, which also starts each robot's controller manager), then each
robot's sequencer and twist sequence (:func:`AddRobotDrivers`) and its wiring to the
plant and its logs (:func:`ConnectRobot`).

A robot of ``robots:`` has a namespace (``/left``): its diagram ports are
``left/joint_states``, ``left/<controller>.<topic>``, ..., its systems' names begin with
``left/``, its logs go to ``<output>/left/``. The only robot of a scenario without
``robots:`` keeps the plain names.
"""

from __future__ import annotations

import contextlib
import dataclasses as dc
from pathlib import Path
from typing import Any

from pydrake.geometry import CollisionFilterDeclaration

from armando_drake.control.hardware import command_interfaces
from armando_drake.control.mobile import AddMobileBase
from armando_drake.control.sequencer import AddSequencer
from armando_drake.control.stack import (
    AddControllerManager,
    BeginHardware,
    ConnectControlStack,
    FinishHardware,
    LoadControllerConfig,
    choose_controllers,
    controller_update_rate,
)
from armando_drake.control.twist import AddTwistSequence
from armando_drake.description.loader import AddRobot
from armando_drake.outputs.base import BASE_CSV, AddBaseLogger
from armando_drake.outputs.logger import AddJointStateLogger, CommandsCsv
from armando_drake.outputs.topics import WorldTopics
from armando_drake.sensors.registry import AddSensors
from armando_drake.simulation.scenario import (
    Scenario,
    ScenarioError,
    robot_view,
    sources_of,
    start_positions,
)
from armando_drake.simulation.validation import check_against_world


@dc.dataclass
class RobotParts:
    """One robot of the world being built, and its parts as the phases add them."""

    name: str  # its name in robots: ("" for a scenario's only robot)
    namespace: str  # "/left" ("" for a scenario's only robot)
    view: Scenario  # the scenario as this robot sees it (robot_view)
    index: int = 0  # its place in robots:
    mount: str = ""  # "OTHER::link" it is welded to ("": the world)
    robot: Any = None  # LoadedRobot
    controller_config: Any = None  # its controller YAML
    mobile: Any = None  # its MobileBase
    parent: Any = None  # the robot it is mounted on (RobotParts), if any
    pending: Any = None  # its hardware interface before the plant is final
    choice: Any = None  # the controllers chosen (ControllerChoice)
    update_rate: int = 0  # [Hz] its controller manager's
    topics: WorldTopics | None = None  # its control stack and publishers
    logger: Any = None  # its JointStateLogger, if a broadcaster is active
    gravity_feedforward: Any = None  # the gravity feed-forward's output, if any

    @property
    def folder(self) -> str:
        """Its output subfolder ("" for the only robot)."""
        return self.namespace.strip("/")

    def output_dir(self, output_dir) -> Path | None:
        """Its folder of ``output_dir`` (made), where its logs go; None without one."""
        if output_dir is None:
            return None
        folder = Path(output_dir) / self.folder
        folder.mkdir(parents=True, exist_ok=True)
        return folder


def robot_parts(scenario: Scenario) -> list[RobotParts]:
    """The robots of ``scenario``: its ``robots:``, else the one of its top-level keys."""
    if not scenario.robots:
        return [RobotParts(name="", namespace="", view=scenario)]
    return [
        RobotParts(
            name=entry.name,
            namespace=entry.space,
            view=robot_view(scenario, i),
            index=i,
            mount=entry.parent,
        )
        for i, entry in enumerate(scenario.robots)
    ]


def _origin(view: Scenario, key: str) -> str:
    return f"{sources_of(view).of(key)}: "


@contextlib.contextmanager
def robot_scope(builder, part: RobotParts):
    """The systems added inside get the robot's namespace before their names."""
    before = len(builder.GetSystems())
    yield
    if part.folder:
        for system in builder.GetSystems()[before:]:
            system.set_name(f"{part.folder}/{system.get_name()}")


def _parent_frame(plant, parts: list[RobotParts], part: RobotParts):
    """The frame of the link ``part`` is mounted on, or None (its base is in the world)."""
    parent = part.mount
    if not parent:
        return None
    other, link = parent.split("::")
    part.parent = next(p for p in parts if p.name == other)
    instance = part.parent.robot.model_instance
    if not plant.HasFrameNamed(link, instance):
        links = sorted(plant.get_body(i).name() for i in plant.GetBodyIndices(instance))
        file = sources_of(part.view).file.rsplit(": robots.", 1)[0]
        raise ScenarioError(
            f"{file}: robots.{part.index}.parent={parent!r}: robot "
            f"{other!r} has no link {link!r} (links: {', '.join(links)})"
        )
    return plant.GetFrameByName(link, instance)


def AddRobotBodies(plant, scene_graph, scenario: Scenario) -> list[RobotParts]:
    """Each robot's description in ``plant`` (its own model instance), its controller
    YAML read, its base welded in the world or to its parent's link, or free."""
    parts = robot_parts(scenario)
    for part in parts:
        view = part.view
        part.robot = AddRobot(plant, view.robot, weld=False, model_name=part.name or None)
        # The controller YAML before the base is placed: a drive controller frees the base.
        part.controller_config = LoadControllerConfig(
            view.controllers,
            part.robot,
            arguments=view.robot.xacro_args,
            prefix=scenario.robots[part.index].prefix if scenario.robots else "",
        )
        part.mobile = AddMobileBase(
            plant,
            scene_graph,
            part.robot,
            view.robot,
            part.controller_config,
            activate=view.controllers.activate,
            where=_origin(view, "robot.base"),
            parent=_parent_frame(plant, parts, part),
        )
    return parts


def _begin(plant, part: RobotParts) -> None:
    """The controllers chosen, the rates checked, the hardware's actuators added."""
    view, config, mobile = part.view, part.controller_config, part.mobile
    # The scenario's default controllers stand for the file's own (one line each).
    part.choice = choose_controllers(view.controllers.activate, config, view.sequencer)
    view.controllers.activate, view.sequencer = part.choice.activate, part.choice.sequencer
    part.update_rate = controller_update_rate(
        config, view.controllers, _origin(view, "controllers.update_rate")
    )
    # Rates, gains and periods checked against the robot and the controller YAML.
    check_against_world(
        view,
        update_rate=part.update_rate,
        update_rate_source=config.source,
        joints=command_interfaces(part.robot, warn=False)[2],
    )
    actuators = dc.replace(view.actuators, gains={**mobile.gains, **view.actuators.gains})
    part.pending = BeginHardware(plant, part.robot, actuators, config)


def AddRobotStacks(builder, plant, scene_graph, parts: list[RobotParts]) -> None:
    """Each robot's hardware interface (the plant finalized once, in between) and its
    controller manager running the activated controllers (and a mobile base's drive
    plugins) of its controller YAML; sets each ``part.topics``."""
    for part in parts:
        _begin(plant, part)
    plant.Finalize()
    for part in parts:
        view = part.view
        hardware = FinishHardware(
            plant,
            scene_graph,
            part.pending,
            self_collision=view.robot.self_collision,
            start_positions=start_positions(view),
        )
        if part.parent is not None:  # a mounted robot does not collide with its carrier
            geometries = [
                plant.CollectRegisteredGeometries(
                    [plant.get_body(i) for i in plant.GetBodyIndices(p.robot.model_instance)]
                )
                for p in (part, part.parent)
            ]
            scene_graph.collision_filter_manager().Apply(
                CollisionFilterDeclaration().ExcludeBetween(*geometries)
            )
        with robot_scope(builder, part):
            stack = AddControllerManager(
                builder,
                dc.replace(
                    view.controllers, activate=part.mobile.activation(view.controllers.activate)
                ),
                plant=plant,
                robot=part.robot,
                hardware=hardware,
                controller_config=part.controller_config,
                update_rate=part.update_rate,
                sequencer=view.sequencer,
                where=_origin(view, "controllers"),
                scene_graph=scene_graph,
                hold=part.choice.hold,
                namespace=part.namespace,
            )
        part.topics = WorldTopics(stack=stack, mobile=part.mobile)


def AddRobotDrivers(builder, part: RobotParts, commands_csv: Path | None, closers: list) -> None:
    """The robot's command sequencer (its commands in ``commands_csv``) and twist
    sequence, on its controllers."""
    view, topics = part.view, part.topics
    with robot_scope(builder, part):
        if view.sequencer is not None:

            def commands_log(joints):  # commands.csv, for the joints the sequencer drives
                log = CommandsCsv(commands_csv, joints)
                closers.append(log.close)
                return log

            topics.sequencer, topics.sequencer_target = AddSequencer(
                builder,
                view.sequencer,
                topics.stack,
                commands_log=commands_log if commands_csv is not None else None,
                where=_origin(view, "sequencer"),
            )
        if view.twist is not None:
            topics.twist, topics.twist_target = AddTwistSequence(
                builder, view.twist, topics.stack, where=_origin(view, "twist")
            )


def ConnectRobot(builder, part: RobotParts, output_dir, closers: list, *, quiet: bool) -> None:
    """The robot's commands to the plant (desired state, efforts, gravity feed-forward),
    its joint-state logger (``joint_states.csv`` in ``output_dir``) and its base's logger
    (``base.csv``)."""
    view, topics = part.view, part.topics
    with robot_scope(builder, part):
        sequencer = topics.sequencer
        stack = topics.stack
        tick = sequencer.GetOutputPort("tick_command") if stack.stream_controller else None
        part.gravity_feedforward = ConnectControlStack(
            builder,
            stack,
            gravity_feedforward=view.actuators.gravity_feedforward,
            tick_command=tick,
        )
        part.logger = AddJointStateLogger(
            builder, view.logging, stack, output_dir=output_dir, quiet=quiet
        )
        if part.logger is not None:
            closers.append(part.logger.close)
        command = topics.twist.GetOutputPort("command") if topics.twist is not None else None
        topics.base_log = AddBaseLogger(builder, stack, topics.mobile, command=command)
        log = topics.base_log
        if log is not None and output_dir is not None:
            closers.append(lambda: log.write(Path(output_dir) / BASE_CSV))


def AddRobotSensors(builder, plant, part: RobotParts) -> None:
    """The sensors of the robot's description (a lidar; cameras are
    :func:`~armando_drake.sensors.cameras.AddCameras`'), on its links, their outputs
    ``<namespace>/<sensor>.<output>``; sets ``part.topics.sensors``."""
    robot = part.robot
    with robot_scope(builder, part):
        part.topics.sensors = AddSensors(
            builder, robot.sensors, plant=plant, robot=robot, namespace=part.namespace
        )
