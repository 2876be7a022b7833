"""What a world publishes, and which system publishes it: the handle the ROS 2 bag
recorder (:mod:`armando_drake.outputs.recording`) and the live bridge
(:mod:`armando_drake.ros2.bridge`) connect to."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from armando_drake.control.stack import ControlStack


@dataclass
class WorldTopics:
    """The publishers of a world being built, as their subsystems returned them."""

    stack: ControlStack  # joint states, controllers' command inputs and statuses
    cameras: dict = field(default_factory=dict)  # AddedCamera by name
    sequencer: Any = None  # the command sequencer, if any
    sequencer_target: str = ""  # the controller it drives
    task: Any = None  # the TaskReference, if the scenario has a task
    learned_ik: Any = None  # the LearnedIk, if the scenario has learned_ik
    jog: Any = None  # the MeshcatJog, if the scenario has a jog and a Meshcat
    perception: Any = None  # AddedPerception, if the scenario has a perception block
    detectors: Any = None  # AddedDetectors, if the scenario has a vision block
    # The outputs of the description's other sensors (sensors.registry), by sensor name.
    sensors: dict = field(default_factory=dict)
    mobile: Any = None  # the MobileBase (control.mobile): how the base is held, its drives
    twist: Any = None  # the TwistSequencer (or the Navigator) publishing cmd_vel, if any
    twist_target: str = ""  # the drive it commands
    base_log: Any = None  # the BaseLogger of a floating base with a drive
    navigation: Any = None  # the Navigation (navigation.navigator), if the scenario has one

    @property
    def plant(self):
        return self.stack.plant

    @property
    def robot(self):
        return self.stack.robot

    @property
    def update_rate(self) -> int:
        return self.stack.update_rate

    @property
    def broadcaster(self):
        return self.stack.broadcaster

    @property
    def joint_states_topic(self) -> str:
        return self.stack.joint_states_topic

    def topic(self, name: str) -> str:
        """The absolute ROS topic of ``name`` (relative or absolute) for this robot: under
        its namespace in a world of several (``/left/joint_states``), else ``/<name>``."""
        return f"{self.stack.namespace.rstrip('/')}/{name.lstrip('/')}"

    @property
    def controllers(self) -> dict:
        return self.stack.controllers
