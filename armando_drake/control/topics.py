"""The topics of a robot's control stack, as rows of the publication table
(:mod:`armando_drake.messages.publications`).

- :func:`RegisterControllerTopics`: the broadcaster's ``joint_states`` and the command
  inputs of every active controller (subscribed: the bridge feeds those nothing else
  drives), registered by :func:`~armando_drake.control.stack.AddControllerManager`;
- :func:`RegisterSentCommands`: the commands the sequencer, the live jog or the task
  sends, recorded on the topic of the controller they drive.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from armando_drake.messages.definitions import (
    cartesian_trajectory_message,
    float64_multi_array_message,
    float64_multi_array_of,
    joint_state_message,
    joint_trajectory_message,
    joint_trajectory_of,
    multi_dof_command_of,
    speed_scaling_factor_of,
    twist_stamped_of,
)
from armando_drake.messages.publications import (
    SUBSCRIBE,
    PublicationRegistry,
    Topic,
    published,
    sampled,
)
from armando_drake.messages.types import TwistStamped
from armando_drake.tools.rejections import require_finite

# Command inputs of the controllers by port suffix: ROS type and conversion to ours.
COMMAND_TYPES: dict[str, tuple[str, Callable[[Any], Any]]] = {
    "commands": ("std_msgs/msg/Float64MultiArray", float64_multi_array_of),
    "joint_trajectory": ("trajectory_msgs/msg/JointTrajectory", joint_trajectory_of),
    "speed_scaling_input": ("control_msgs/msg/SpeedScalingFactor", speed_scaling_factor_of),
    "reference": ("control_msgs/msg/MultiDOFCommand", multi_dof_command_of),
    "cmd_vel": ("geometry_msgs/msg/TwistStamped", lambda message: received_twist_of(message)),
}
# The commands a world's sequencer, jog or task sends, as recorded: type and conversion.
SENT_COMMANDS = {
    "commands": ("std_msgs/msg/Float64MultiArray", float64_multi_array_message),
    "joint_trajectory": ("trajectory_msgs/msg/JointTrajectory", joint_trajectory_message),
    "cartesian_trajectory": (
        "cartesian_control_msgs/msg/CartesianTrajectory",
        cartesian_trajectory_message,
    ),
}


def received_twist_of(message: Any) -> TwistStamped:
    """Ours of a received cmd_vel (Twist or TwistStamped);
    :class:`~armando_drake.tools.rejections.RejectedMessage` when a field is not finite
    (the drive keeps its last good command)."""
    twist = twist_stamped_of(message)
    require_finite(
        [(f"linear.{a}", v) for a, v in zip("xyz", twist.twist.linear, strict=True)]
        + [(f"angular.{a}", v) for a, v in zip("xyz", twist.twist.angular, strict=True)]
    )
    return twist


def RegisterControllerTopics(
    publications: PublicationRegistry, stack, drive_plugins: Sequence[str] = ()
) -> None:
    """Registers the joint states of ``stack`` (a ControlStack; with a broadcaster) and
    the command inputs of its active controllers (subscribed), and those no ROS 2 type is
    known for. ``drive_plugins``: the drives of the base's ``<gazebo>`` plugins, whose
    cmd_vel is their own topic (``/cmd_vel``, a geometry_msgs/Twist as Gazebo's bridge
    takes it)."""
    space = stack.namespace.strip("/")
    if stack.broadcaster is not None:
        publications.add(
            Topic(stack.joint_states_topic, "sensor_msgs/msg/JointState",
                  port=stack.broadcaster.GetOutputPort("joint_states"),
                  read=sampled(joint_state_message), rate=stack.update_rate, namespace=space)
        )  # fmt: skip
    for name, system in stack.controllers.items():
        for index in range(system.num_input_ports()):
            port = system.get_input_port(index)
            prefix, _, suffix = port.get_name().partition(".")
            if prefix != name or not suffix:
                continue
            if suffix not in COMMAND_TYPES:
                publications.add_untyped(f"{name}/{suffix}", port)
                continue
            type_name, receive = COMMAND_TYPES[suffix]
            topic = f"{name}/{suffix}"
            if suffix == "cmd_vel" and name in drive_plugins:
                topic = stack.entry(name).ros_topic or "/cmd_vel"
                type_name = "geometry_msgs/msg/Twist"
            publications.add(
                Topic(topic, type_name, SUBSCRIBE, port=port, receive=receive, namespace=space,
                      key=f"{name}.{suffix}", recorded=False)
            )  # fmt: skip


def RegisterSentCommands(
    publications: PublicationRegistry,
    stack,
    *,
    sequencer=None,
    target: str = "",
    jog=None,
    task=None,
) -> None:
    """Registers the commands the ``sequencer`` (driving ``target``, "" for the default
    controllers), the live ``jog`` (when no sequencer drives) or the ``task`` sends on
    ``stack``'s controllers, recorded on the topic of the controller each drives (not
    published live: the world subscribes the controllers' free inputs instead)."""
    ports: dict[str, Any] = {}
    if sequencer is not None:
        for suffix in ("commands", "joint_trajectory"):
            ports[suffix] = sequencer.GetOutputPort(suffix)
    owners = {
        "commands": target or "position_controller",
        "joint_trajectory": target or "trajectory_controller",
        "cartesian_trajectory": "operational_space_controller",
    }
    if jog is not None and sequencer is None:  # the live jog, when nothing drives
        suffix = "joint_trajectory" if jog.sends_trajectories else "commands"
        ports[suffix] = jog.GetOutputPort("commands")
        owners["commands"] = target or jog.controller
        owners["joint_trajectory"] = target or jog.controller
    if task is not None:
        ports.setdefault(task.topic, task.source.get_output_port())
        owners["cartesian_trajectory"] = task.controller
        if task.topic == "joint_trajectory" and sequencer is None:
            owners["joint_trajectory"] = task.controller
    space = stack.namespace.strip("/")
    for suffix, (type_name, convert) in SENT_COMMANDS.items():
        if suffix in ports:
            publications.add(
                Topic(f"{owners[suffix]}/{suffix}", type_name, port=ports[suffix],
                      read=published(convert), rate=stack.update_rate, namespace=space,
                      live=False)
            )  # fmt: skip
