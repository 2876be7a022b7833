"""The built world: its diagram and the handles callers outside the builder use."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydrake.geometry import Meshcat, SceneGraph
from pydrake.systems.framework import Context, Diagram

from armando_drake.messages.types import Publication
from armando_drake.outputs.topics import WorldTopics


@dataclass
class World:
    """The built diagram and handles to its parts (the subsystems' own handles)."""

    diagram: Diagram
    scene_graph: SceneGraph
    # Each robot (simulation.robots.AddedRobot: name, namespace, topics, logger), by name,
    # in the scenario's order; the one robot of a scenario without robots: is its only
    # entry. The handles below are the first's (the scene's cameras, detectors and
    # perception report with it).
    robots: dict[str, Any]
    meshcat: Meshcat | None = None
    image_view: Any = None  # the live camera view's server, when served
    replay_sampler: Any = None  # ReplaySampler of the plant's state, with Meshcat on
    ros2_bridge: Any = None  # the Ros2Bridge, with ros2.enabled or ros2.foxglove
    closers: list = field(default_factory=list)  # called by close()

    @property
    def first(self):
        """The first robot (its AddedRobot)."""
        return next(iter(self.robots.values()))

    # The first robot's control stack and every publisher.
    topics = property(lambda self: self.first.topics)
    # Its gravity feed-forward torques [N m] on the actuation input (actuator order), when
    # the scenario has it.
    gravity_feedforward = property(lambda self: self.first.gravity_feedforward)
    logger = property(lambda self: self.first.logger)  # its JointStateLogger, if any
    # The control stack's parts, by their old names.
    stack = property(lambda self: self.topics.stack)
    plant = property(lambda self: self.stack.plant)
    robot = property(lambda self: self.stack.robot)
    hardware = property(lambda self: self.stack.hardware)
    controller_config = property(lambda self: self.stack.config)
    update_rate = property(lambda self: self.stack.update_rate)
    controllers = property(lambda self: self.stack.controllers)
    controller_joints = property(lambda self: self.stack.controller_joints)
    controller_manager = property(lambda self: self.stack.manager)
    broadcaster = property(lambda self: self.stack.broadcaster)
    broadcaster_name = property(lambda self: self.stack.broadcaster_name)
    effort_state = property(lambda self: self.stack.effort_state)
    stream_controller = property(lambda self: self.stack.stream_controller)
    cameras = property(lambda self: self.topics.cameras)
    sequencer = property(lambda self: self.topics.sequencer)
    sequencer_target = property(lambda self: self.topics.sequencer_target)
    task = property(lambda self: self.topics.task)
    jog = property(lambda self: self.topics.jog)
    perception = property(lambda self: self.topics.perception)
    detectors = property(lambda self: self.topics.detectors)
    mobile = property(lambda self: self.topics.mobile)
    twist = property(lambda self: self.topics.twist)
    base_log = property(lambda self: self.topics.base_log)
    image_view_url = property(lambda self: self.image_view.url if self.image_view else None)

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

    def joint_positions(self, context: Context, robot: str = "") -> np.ndarray:
        """Measured positions of the hardware joints [rad], hardware order; of the robot
        named ``robot`` in a world of several (default: the first)."""
        stack = self.robot_topics(robot).stack if robot else self.stack
        x = self.plant.GetPositionsAndVelocities(
            self.plant.GetMyContextFromRoot(context), stack.robot.model_instance
        )
        return x[stack.hardware.position_index]

    def robot_topics(self, name: str) -> WorldTopics:
        """The control stack and publishers of the robot named ``name``."""
        if name not in self.robots:
            raise KeyError(f"no robot {name!r} (robots: {', '.join(self.robots)})")
        return self.robots[name].topics

    def close(self, context: Context | None = None) -> None:
        """Ends the run: with the root ``context``, first writes the joint states each
        robot's logger has recorded since its last flush (and its sequencer's commands
        since its last batch); then closes every file and server."""
        if context is not None and self.closers:
            for robot in self.robots.values():
                if robot.logger is not None:
                    robot.logger.flush(robot.logger.GetMyContextFromRoot(context))
            for robot in self.robots.values():
                if robot.topics.sequencer is not None:
                    robot.topics.sequencer.flush(context)
        for closer in self.closers:
            closer()
        self.closers.clear()
