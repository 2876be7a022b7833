"""The built world: its diagram and the handles callers outside the builder use."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydrake.geometry import Meshcat, SceneGraph
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Context, Diagram

from armando_drake.messages.publications import Publications
from armando_drake.messages.types import Publication


@dataclass
class World:
    """The built diagram and handles to its parts (the subsystems' own handles)."""

    diagram: Diagram
    plant: MultibodyPlant  # the world's one plant, which holds every robot
    scene_graph: SceneGraph
    # Each robot (simulation.robots.AddedRobot: its stack, drivers, sensors, loggers), by
    # name, in the scenario's order; the one robot of a scenario without robots: is its
    # only entry.
    robots: dict[str, Any]
    publications: Publications = field(default_factory=Publications)  # what it publishes
    meshcat: Meshcat | None = None
    image_view: Any = None  # the live camera view's server, when served
    replay_sampler: Any = None  # ReplaySampler of the plant's state, with Meshcat on
    ros2_bridge: Any = None  # the Ros2Bridge, with ros2.enabled or ros2.foxglove
    closers: list = field(default_factory=list)  # called by close()

    @property
    def image_view_url(self) -> str | None:
        """The live camera view's address, when served."""
        return self.image_view.url if self.image_view else None

    def robot(self, name: str = ""):
        """The robot named ``name`` (its AddedRobot); without a name, the first (the one
        of a world of one robot)."""
        if not name:
            return next(iter(self.robots.values()))
        if name not in self.robots:
            raise KeyError(f"no robot {name!r} (robots: {', '.join(self.robots)})")
        return self.robots[name]

    def robot_with(self, field: str):
        """The robot whose ``field`` (``navigation``, ``task``, ``detectors``, ...) is
        set: the one the scenario's section acts on; the first if none has it."""
        having = (robot for robot in self.robots.values() if getattr(robot, field) is not None)
        return next(having, None) or self.robot()

    def publish(self, context: Context, controller: str, message: Any) -> None:
        """Publishes ``message`` on a controller's command input, like a ROS topic."""
        port = self.command_port(controller)
        previous = port.Eval(context) if port.HasValue(context) else Publication()
        port.FixValue(context, previous.publish(message, stamp=context.get_time()))

    def command_port(self, controller: str):
        """The diagram's command input of the first robot's ``controller``."""
        entry = self.robot().stack.config.controllers.get(controller)
        name = f"{controller}.{entry.topic}" if entry is not None else ""
        if name and self.diagram.HasInputPort(name):
            return self.diagram.GetInputPort(name)
        raise KeyError(f"no command input for controller {controller!r}")

    def status(self, context: Context, controller: str):
        return self.diagram.GetOutputPort(f"{controller}.status").Eval(context)

    def joint_positions(self, context: Context, robot: str = "") -> np.ndarray:
        """Measured positions of the hardware joints [rad], hardware order; of the robot
        named ``robot`` in a world of several (default: the first)."""
        stack = self.robot(robot).stack
        x = self.plant.GetPositionsAndVelocities(
            self.plant.GetMyContextFromRoot(context), stack.robot.model_instance
        )
        return x[stack.hardware.position_index]

    def close(self, context: Context | None = None) -> None:
        """Ends the run: with the root ``context``, first writes the joint states each
        robot's logger has recorded since its last flush (and its sequencer's commands
        since its last batch); then closes every file and server."""
        if context is not None and self.closers:
            for robot in self.robots.values():
                if robot.logger is not None:
                    robot.logger.flush(robot.logger.GetMyContextFromRoot(context))
            for robot in self.robots.values():
                if robot.sequencer is not None:
                    robot.sequencer.flush(context)
        for closer in self.closers:
            closer()
        self.closers.clear()
