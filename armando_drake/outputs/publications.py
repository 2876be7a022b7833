"""The world's publication table, and the generic system that publishes its ports.

:func:`world_publications` fills the table (:class:`~armando_drake.messages.publications.
Publications`) from what the subsystems returned (each robot's
:class:`~armando_drake.outputs.topics.WorldTopics`): joint states, the commands the
sequencer or the jog sends, the task's reference, the cameras, the perception, the
detectors, a mobile base's topics, a navigation's; and the command inputs of the
controllers, subscribed.

:func:`AttachTopics` connects a consumer to the published topics of a table: its
:class:`TopicPublisher` reads the topics that come from a port, each source adds its own
system; every message goes to ``send(topic, type_name, message, stamp)``. The MCAP
recorder and the DDS bridge are this loop with their own ``send``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from pydrake.systems.framework import LeafSystem, PortDataType

from armando_drake.messages.definitions import (
    cartesian_trajectory_message,
    float64_multi_array_message,
    float64_multi_array_of,
    joint_state_message,
    joint_trajectory_message,
    joint_trajectory_of,
    multi_dof_command_of,
    resolve_topic,
    speed_scaling_factor_of,
    twist_stamped_of,
)
from armando_drake.messages.publications import (
    SUBSCRIBE,
    Publications,
    Send,
    Topic,
    published,
    sampled,
    sources,
)
from armando_drake.outputs.camera_topics import camera_topics
from armando_drake.outputs.mobile_topics import MobileSource
from armando_drake.outputs.navigation_topics import NavigationSource
from armando_drake.outputs.perception_recording import PerceptionSource
from armando_drake.outputs.topics import WorldTopics
from armando_drake.outputs.vision_recording import VisionSource

# Command inputs of the controllers by port suffix: ROS type and conversion to ours.
COMMAND_TYPES: dict[str, tuple[str, Callable[[Any], Any]]] = {
    "commands": ("std_msgs/msg/Float64MultiArray", float64_multi_array_of),
    "joint_trajectory": ("trajectory_msgs/msg/JointTrajectory", joint_trajectory_of),
    "speed_scaling_input": ("control_msgs/msg/SpeedScalingFactor", speed_scaling_factor_of),
    "reference": ("control_msgs/msg/MultiDOFCommand", multi_dof_command_of),
    "cmd_vel": ("geometry_msgs/msg/TwistStamped", twist_stamped_of),
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


def recorded_name(topic: Topic) -> str:
    """The absolute name of a topic in a recording (``/left/joint_states``)."""
    return resolve_topic(topic.name)


class TopicPublisher(LeafSystem):
    """Reads the topics of ``topics`` that come from a port and sends their messages.

    One input port per topic (named after it, connected to the topic's port), read at the
    topic's rate and offset (rate 0: once, at initialization); each message its ``read``
    gives is sent as ``send(name(topic), type_name, message, stamp)`` when its key
    changed. Topics of one rate and offset are read in one event, in the table's order.
    """

    def __init__(self, topics: Sequence[Topic], send: Send, name: Callable[[Topic], str]):
        super().__init__()
        topics = from_ports(topics)
        self._send = send
        self._last: list[Any] = [None] * len(topics)
        events: dict[tuple[float, float], list] = {}
        self._ports = []
        for k, topic in enumerate(topics):
            port_name = f"{k}:{name(topic)}"
            if topic.port.get_data_type() == PortDataType.kVectorValued:
                port = self.DeclareVectorInputPort(port_name, topic.port.size())
            else:
                port = self.DeclareAbstractInputPort(port_name, topic.port.Allocate())
            self._ports.append(port)
            events.setdefault((topic.rate, topic.offset), []).append((k, topic, name(topic)))
        for (rate, offset), group in events.items():
            if rate > 0:
                self.DeclarePeriodicPublishEvent(
                    1.0 / rate, offset, lambda context, group=group: self._Read(context, group)
                )
            else:
                self.DeclareInitializationPublishEvent(
                    lambda context, group=group: self._Read(context, group)
                )

    def _Read(self, context, group) -> None:
        time = context.get_time()
        for k, topic, name in group:
            port = self._ports[k]
            if not port.HasValue(context):
                continue
            value = port.Eval(context)
            found = topic.read(value, time)
            if found is None:
                continue
            message, stamp, key = found
            if key is not None and key == self._last[k]:
                continue
            self._last[k] = key
            self._send(name, topic.type_name, message, stamp)


def from_ports(topics: Sequence[Topic]) -> list[Topic]:
    """The topics of ``topics`` read from a port (not sent by a source)."""
    return [topic for topic in topics if topic.source is None]


def AttachTopics(builder, system: TopicPublisher, topics: Sequence[Topic], send: Send,
                 *, consumer: str) -> None:  # fmt: skip
    """Connects a consumer to the published ``topics``: ``system`` (made on
    :func:`from_ports` of them, added to ``builder``) to their ports, and each source's
    system to ``send`` (only the topics among ``topics``; ``consumer`` names it)."""
    for index, topic in enumerate(from_ports(topics)):
        builder.Connect(topic.port, system.get_input_port(index))
    for source, names in sources(topics):
        source.attach(builder, _only(send, names), consumer)


def _only(send: Send, names: set[str]) -> Send:
    """``send`` for the topics of ``names`` only (a source may send more)."""

    def filtered(topic: str, type_name: str, message: dict, stamp: float) -> None:
        if topic in names:
            send(topic, type_name, message, stamp)

    return filtered


def world_publications(topics: WorldTopics, others: Sequence[WorldTopics] = ()) -> Publications:
    """The table of a world: its first robot's topics (with the world's cameras, the
    perception and the detectors), then each other robot's."""
    table = _robot_publications(topics, first=True)
    for other in others:
        table += _robot_publications(other, first=False)
    return table


def _robot_publications(topics: WorldTopics, *, first: bool) -> Publications:
    space = topics.stack.namespace.strip("/")
    rows: list[Topic] = []
    if topics.broadcaster is not None:
        rows.append(
            Topic(topics.joint_states_topic, "sensor_msgs/msg/JointState",
                  port=topics.broadcaster.GetOutputPort("joint_states"),
                  read=sampled(joint_state_message), rate=topics.update_rate, namespace=space)
        )  # fmt: skip
    rows += _sent_commands(topics, first=first)
    if first:
        for name, camera in topics.cameras.items():
            rows += camera_topics(name, camera)
        if topics.perception is not None:
            camera = topics.cameras[topics.perception.camera]
            rows += PerceptionSource(topics.perception, camera).table()
        if topics.detectors is not None:
            rows += VisionSource(topics.detectors, topics.cameras).table()
    rows += MobileSource(topics).table()
    if topics.navigation is not None:
        rows += NavigationSource(topics, recorded=first).table()
    subscriptions, untyped = _command_inputs(topics)
    return Publications(tuple(rows + subscriptions), tuple(untyped))


def _sent_commands(topics: WorldTopics, *, first: bool) -> list[Topic]:
    """The commands the sequencer (or, on the first robot, the live jog or the task)
    sends, recorded on the topic of the controller it drives (not published live: the
    world subscribes the controllers' free inputs instead)."""
    target = topics.sequencer_target
    ports: dict[str, Any] = {}
    if topics.sequencer is not None:
        for suffix in ("commands", "joint_trajectory"):
            ports[suffix] = topics.sequencer.GetOutputPort(suffix)
    owners = {
        "commands": target or "position_controller",
        "joint_trajectory": target or "trajectory_controller",
        "cartesian_trajectory": "operational_space_controller",
    }
    if first:
        jog, task = topics.jog, topics.task
        if jog is not None and topics.sequencer is None:  # the live jog, when nothing drives
            suffix = "joint_trajectory" if jog.sends_trajectories else "commands"
            ports[suffix] = jog.GetOutputPort("commands")
            owners["commands"] = target or jog.controller
            owners["joint_trajectory"] = target or jog.controller
        if task is not None:
            ports.setdefault(task.topic, task.source.get_output_port())
            owners["cartesian_trajectory"] = task.controller
            if task.topic == "joint_trajectory" and topics.sequencer is None:
                owners["joint_trajectory"] = task.controller
    space = topics.stack.namespace.strip("/")
    rows = []
    for suffix, (type_name, convert) in SENT_COMMANDS.items():
        if suffix in ports:
            rows.append(
                Topic(f"{owners[suffix]}/{suffix}", type_name, port=ports[suffix],
                      read=published(convert), rate=topics.update_rate, namespace=space,
                      live=False)
            )  # fmt: skip
    return rows


def _command_inputs(topics: WorldTopics) -> tuple[list[Topic], list[tuple[str, Any]]]:
    """The command inputs of every active controller, subscribed (the bridge subscribes
    those nothing else drives), and those no ROS 2 type is known for."""
    space = topics.stack.namespace.strip("/")
    rows, untyped = [], []
    plugins = topics.mobile.plugins if topics.mobile is not None else ()
    for name, system in topics.controllers.items():
        for index in range(system.num_input_ports()):
            port = system.get_input_port(index)
            prefix, _, suffix = port.get_name().partition(".")
            if prefix != name or not suffix:
                continue
            if suffix not in COMMAND_TYPES:
                untyped.append((f"{name}/{suffix}", port))
                continue
            type_name, receive = COMMAND_TYPES[suffix]
            topic = f"{name}/{suffix}"
            if suffix == "cmd_vel" and name in plugins:
                # A drive plugin's own topic (/cmd_vel), a geometry_msgs/Twist as Gazebo's
                # bridge takes it.
                topic = topics.stack.entry(name).ros_topic or "/cmd_vel"
                type_name = "geometry_msgs/msg/Twist"
            rows.append(
                Topic(topic, type_name, SUBSCRIBE, port=port, receive=receive, namespace=space,
                      key=f"{name}.{suffix}", recorded=False)
            )  # fmt: skip
    return rows, untyped
