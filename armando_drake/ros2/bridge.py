"""The running world as a ROS 2 robot: DDS topics in and out, Foxglove live.

:class:`Ros2Bridge` is the Drake system that does what ros2_control's
joint_state_broadcaster, robot_state_publisher and Gazebo's clock and camera
bridges do for a simulated ROS 2 robot, and subscribes the command topics of
the active controllers:

=========================================== ======================================== ===========
topic                                       type                                     QoS
=========================================== ======================================== ===========
``/clock``                                  ``rosgraph_msgs/msg/Clock``              default
``/joint_states``                           ``sensor_msgs/msg/JointState``           default
``/tf``                                     ``tf2_msgs/msg/TFMessage``               default
``/tf_static``                              ``tf2_msgs/msg/TFMessage``               latched
``/robot_description``                      ``std_msgs/msg/String``                  latched
``/camera/image_raw``                       ``sensor_msgs/msg/Image`` (rgb8)         sensor data
``/camera/camera_info``                     ``sensor_msgs/msg/CameraInfo``           default
``/<controller>/commands`` (in)             ``std_msgs/msg/Float64MultiArray``       default
``/<controller>/joint_trajectory`` (in)     ``trajectory_msgs/msg/JointTrajectory``  default
``/<controller>/speed_scaling_input`` (in)  ``control_msgs/msg/SpeedScalingFactor``  default
``/<controller>/reference`` (in)            ``control_msgs/msg/MultiDOFCommand``     default
``/odom`` (a mobile base)                   ``nav_msgs/msg/Odometry``                default
``/scan`` (a lidar's topic)                 ``sensor_msgs/msg/LaserScan``            default
``/cmd_vel`` (in; a drive's topic)          ``geometry_msgs/msg/Twist`` (plugin)     default
``/map`` (a navigation)                     ``nav_msgs/msg/OccupancyGrid``           latched
``/plan`` (a navigation)                    ``nav_msgs/msg/Path``                    default
``/goal_pose`` (in; a navigation)           ``geometry_msgs/msg/PoseStamped``        default
=========================================== ======================================== ===========

A navigation adds ``map -> <goal>`` frames to ``/tf_static`` and ``map -> odom`` to ``/tf``
(:mod:`armando_drake.outputs.navigation_topics`); a ``/goal_pose`` (RViz's 2D goal, in the
map frame) preempts its goals as NavigateToPose would.

A floating base with a drive has ``odom -> base_footprint`` on ``/tf`` from its wheel
odometry (not ``world -> base``), as the course's odometry TF node broadcasts it; the
twist sequence's ``/cmd_vel`` is published when it drives the base, else ``/cmd_vel`` is
subscribed (``geometry_msgs/msg/Twist`` for a Gazebo plugin, ``TwistStamped`` on
``/<controller>/cmd_vel`` for a diff_drive_controller).

(QoS as in :data:`armando_drake.ros2.dds.QOS`; every name but ``/tf``,
``/tf_static`` and ``/clock`` in the scenario's namespace.) The topics go to
"sinks": a :class:`~armando_drake.ros2.dds.DdsNode` (``--ros2``) and a
:class:`FoxgloveServer` (``--foxglove``), each optional.

Per-step Python is what a world pays most for, so the bridge does nothing at
the plant's step: it publishes from periodic publish events at the
controller manager's rate (and the camera's), and hands received commands
to the controllers from a periodic unrestricted update at the same rate.
DDS delivers messages on Cyclone's own thread; the bridge converts them there
and queues them, and the update empties the queue (``DidNothing`` when it is
empty). As upstream's realtime buffer, the controller sees the latest
message received since its previous tick.
"""

from __future__ import annotations

import logging
import math
import queue
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import EventStatus, LeafSystem
from pydrake.systems.sensors import ImageRgba8U

from armando_drake.messages.definitions import (
    clock_message,
    float64_multi_array_of,
    image_message,
    joint_state_message,
    joint_trajectory_of,
    message_definition,
    multi_dof_command_of,
    resolve_topic,
    speed_scaling_factor_of,
    string_message,
    transform_stamped,
    twist_stamped_of,
)
from armando_drake.messages.types import JointState, Publication
from armando_drake.navigation.config import NavigationGoal
from armando_drake.outputs.mobile_topics import AddMobileTopics
from armando_drake.outputs.navigation_topics import AddNavigationTopics
from armando_drake.outputs.recording import camera_stream
from armando_drake.outputs.topics import WorldTopics
from armando_drake.ros2.dds import DdsNode, Ros2Error, reachability
from armando_drake.sensors.image_view import PUBLISH_OFFSET_FRACTION
from armando_drake.tools.cli import warn_if_open
from armando_drake.tools.errors import ScenarioError
from armando_drake.tools.extras import require_extra

_log = logging.getLogger("armando_drake.ros2")


def goal_pose_of(message: Any) -> NavigationGoal:
    """The navigation goal of a received geometry_msgs/PoseStamped (RViz's 2D goal)."""
    pose = message["pose"]
    p, q = pose["position"], pose["orientation"]
    yaw = math.atan2(
        2.0 * (q["w"] * q["z"] + q["x"] * q["y"]), 1.0 - 2.0 * (q["y"] ** 2 + q["z"] ** 2)
    )
    return NavigationGoal(name="goal_pose", x=float(p["x"]), y=float(p["y"]), yaw=yaw)


# Command inputs of the controllers by port suffix: ROS type and conversion to ours.
COMMAND_TYPES: dict[str, tuple[str, Callable[[dict], Any]]] = {
    "commands": ("std_msgs/msg/Float64MultiArray", float64_multi_array_of),
    "joint_trajectory": ("trajectory_msgs/msg/JointTrajectory", joint_trajectory_of),
    "speed_scaling_input": ("control_msgs/msg/SpeedScalingFactor", speed_scaling_factor_of),
    "reference": ("control_msgs/msg/MultiDOFCommand", multi_dof_command_of),
    "cmd_vel": ("geometry_msgs/msg/TwistStamped", twist_stamped_of),
    "goal_pose": ("geometry_msgs/msg/PoseStamped", goal_pose_of),  # the navigator's
}
# The topics the bridge publishes: ROS type and QoS profile.
TOPICS = {
    "/clock": ("rosgraph_msgs/msg/Clock", "default"),
    "joint_states": ("sensor_msgs/msg/JointState", "default"),
    "/tf": ("tf2_msgs/msg/TFMessage", "default"),
    "/tf_static": ("tf2_msgs/msg/TFMessage", "latched"),
    "robot_description": ("std_msgs/msg/String", "latched"),
}
LATCHED = ("/tf_static", "robot_description")


@dataclass(frozen=True)
class CommandTopic:
    """One controller command input fed from a topic."""

    controller: str  # the controller's name, e.g. "position_controller"
    suffix: str  # its port suffix and topic leaf: "commands" or "joint_trajectory"
    ros_topic: str = ""  # the topic when not <controller>/<suffix> (a drive plugin's /cmd_vel)
    ros_type: str = ""  # the type when not COMMAND_TYPES' (a plugin's geometry_msgs/Twist)

    @property
    def topic(self) -> str:
        """The ROS 2 topic, relative to the namespace: ``<controller>/<suffix>``."""
        return self.ros_topic or f"{self.controller}/{self.suffix}"

    @property
    def port(self) -> str:
        return f"{self.controller}.{self.suffix}"

    @property
    def type_name(self) -> str:
        return self.ros_type or COMMAND_TYPES[self.suffix][0]


@dataclass(frozen=True)
class _Link:
    """A URDF joint as robot_state_publisher broadcasts it: parent -> child link."""

    parent: int  # body index of the parent link in the plant
    child: int  # body index of the child link
    parent_frame: str
    child_frame: str


def robot_links(plant, model_instance) -> tuple[list[_Link], list[_Link]]:
    """(moving, fixed) joints of a model instance, as parent/child link pairs.

    Moving joints go on ``/tf``, fixed ones (welds, including the weld of the
    base to the world) on ``/tf_static``, as robot_state_publisher does.
    """
    moving, fixed = [], []
    for index in plant.GetJointIndices(model_instance):
        joint = plant.get_joint(index)
        parent, child = joint.parent_body(), joint.child_body()
        link = _Link(int(parent.index()), int(child.index()), parent.name(), child.name())
        (fixed if joint.num_velocities() == 0 else moving).append(link)
    return moving, fixed


def referenced_files(urdf: str) -> list[str]:
    """The ``filename`` URIs of a URDF's meshes and textures, as the URDF writes them."""
    try:
        root = ElementTree.fromstring(urdf)
    except ElementTree.ParseError:
        return []
    return sorted(
        {
            element.get("filename", "")
            for element in root.iter()
            if element.tag in ("mesh", "texture") and element.get("filename")
        }
    )


class FoxgloveServer:
    """The topics over Foxglove's WebSocket protocol (``foxglove-sdk``), CDR-encoded.

    Each topic is a channel with its ``ros2msg`` schema, so Foxglove decodes
    it as it would a ROS 2 topic; the server time is the simulation time.
    Latched topics (``/tf_static``, ``/robot_description``) are sent again to
    every client that subscribes to them.
    """

    def __init__(
        self,
        *,
        host: str = "127.0.0.1",
        port: int = 8765,
        namespace: str = "",
        packages: dict[str, Any] | None = None,
        assets: Sequence[str] = (),
        name: str = "armando_drake",
    ):
        import foxglove
        from foxglove.websocket import Capability

        if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
            raise ValueError(f"ros2.foxglove_port={port!r} must be an integer in [0, 65535]")
        self._foxglove = foxglove
        self._context = foxglove.Context()
        self._channels: dict[str, Any] = {}
        self._encoders: dict[str, Callable[[dict], bytes]] = {}
        self._latched: dict[str, tuple[bytes, int]] = {}
        self._namespace = namespace
        self._packages = {name: Path(path).resolve() for name, path in (packages or {}).items()}
        self._assets = frozenset(assets)
        self._server = foxglove.start_server(
            name=name,
            host=host,
            port=port,
            capabilities=[Capability.Time],
            server_listener=self,
            asset_handler=self._asset,
            context=self._context,
        )
        self.host = host

    @property
    def port(self) -> int:
        return self._server.port

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    def advertise(self, topic: str, type_name: str, qos: str = "default") -> None:
        if topic in self._channels:
            return
        from mcap_ros2._dynamic import serialize_dynamic  # the recorder's CDR encoder

        definition = message_definition(type_name)
        self._encoders[topic] = serialize_dynamic(type_name, definition)[type_name]
        self._channels[topic] = self._foxglove.Channel(
            resolve_topic(topic, self._namespace),
            message_encoding="cdr",
            schema=self._foxglove.Schema(
                name=type_name, encoding="ros2msg", data=definition.encode()
            ),
            context=self._context,
        )
        if qos == "latched":
            self._latched[topic] = (b"", 0)

    def publish(self, topic: str, type_name: str, message: dict[str, Any], stamp: float) -> None:
        self.advertise(topic, type_name)
        data = self._encoders[topic](message)
        log_time = max(0, round(stamp * 1e9))
        if topic in self._latched:
            self._latched[topic] = (data, log_time)
        self._channels[topic].log(data, log_time=log_time)

    def _asset(self, uri: str) -> bytes | None:
        """A file the robot's URDF references (its meshes and textures, by the URI the
        URDF gives), for Foxglove's 3-D panel; any other URI is refused (None), even one
        naming another file of the same package."""
        if uri not in self._assets:
            return None
        if uri.startswith("file://"):
            path = Path(uri[len("file://") :])
        elif uri.startswith("package://"):
            package, _, relative = uri[len("package://") :].partition("/")
            root = self._packages.get(package)
            if root is None:
                return None
            path = (root / relative).resolve()
            if not path.is_relative_to(root):
                return None
        else:
            return None
        return path.read_bytes() if path.is_file() else None

    def set_time(self, stamp: float) -> None:
        self._server.broadcast_time(max(0, round(stamp * 1e9)))

    def on_subscribe(self, client, channel) -> None:  # ServerListener, on the server's thread
        for topic, (data, log_time) in list(self._latched.items()):
            if data and resolve_topic(topic, self._namespace) == channel.topic:
                self._channels[topic].log(data, log_time=log_time)

    def close(self) -> None:
        if self._server is not None:
            self._server.stop()
            self._server = None


class Ros2Bridge(LeafSystem):
    """Publishes the world's topics and feeds received commands to its controllers.

    .. pydrake_system::

        name: Ros2Bridge
        input_ports:
        - joint_states
        - body_poses
        - <camera>.color_image (one per camera)
        output_ports:
        - <controller>.commands / <controller>.joint_trajectory (one per command topic)

    - ``joint_states``: the broadcaster's
      :class:`~armando_drake.messages.types.JointState`, published on
      ``joint_states`` at ``update_rate`` [Hz] from t = 0 (when connected);
    - ``body_poses``: the plant's body poses in the world
      (``get_body_poses_output_port``); ``/tf`` carries every moving joint of
      ``model_instance`` as parent link -> child link at ``update_rate``,
      ``/tf_static`` every fixed one once at initialization;
    - ``<camera>.color_image``: ``<camera topic>/image_raw`` and
      ``camera_info`` at the camera's rate, as the recorder writes them;
    - ``<controller>.<suffix>``: a
      :class:`~armando_drake.messages.types.Publication` holding the latest
      command received on ``<controller>/<suffix>`` (abstract state, updated at
      ``update_rate``).

    ``/clock`` is published at ``clock_rate`` [Hz] (simulation time), and
    ``robot_description`` (the URDF text) once at initialization. ``sinks``
    are objects with ``advertise(topic, type_name, qos)`` and ``publish(topic,
    type_name, message, stamp)``; ``subscriber``, if given, has
    ``subscribe(topic, type_name, callback)`` and delivers the commands.
    """

    def __init__(
        self,
        *,
        plant,
        model_instance,
        urdf: str,
        update_rate: float,
        sinks: Sequence[Any],
        subscriber: Any = None,
        commands: Sequence[CommandTopic] = (),
        cameras: Sequence[Any] = (),
        clock_rate: float = 0.0,
        joint_states_topic: str = "joint_states",
        exclude_children: Sequence[str] = (),
        prefix: str = "",
        clock: bool = True,
    ):
        super().__init__()
        # A robot of several: its topics and tf frames under its namespace ``prefix``.
        self._prefix = prefix.strip("/")
        if not (math.isfinite(update_rate) and update_rate > 0):
            raise ValueError(f"update_rate={update_rate!r} must be positive [Hz]")
        if not (math.isfinite(clock_rate) and clock_rate >= 0):
            raise ValueError(f"ros2.clock_rate={clock_rate!r} must be positive, or 0 [Hz]")
        if commands and subscriber is None:
            raise ValueError("commands need a subscriber")
        self._sinks = list(sinks)
        self._urdf = urdf
        self._moving, self._fixed = robot_links(plant, model_instance)
        # Links whose pose another broadcaster gives (the odometry's base frame).
        self._moving = [link for link in self._moving if link.child_frame not in exclude_children]
        self._last_stamp: float | None = None
        self._static: dict[str, dict] = {}  # /tf_static's frames so far, by child
        self._commands = tuple(commands)
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._received = [0] * len(self._commands)  # messages received per command topic

        # The broadcaster's topic: joint_states, or <broadcaster>/joint_states
        # (use_local_topics).
        self._joint_states_topic = self.topic_name(joint_states_topic)
        self._clock = clock
        for topic, (type_name, qos) in TOPICS.items():
            if topic == "/clock" and not clock:
                continue
            topic = joint_states_topic if topic == "joint_states" else topic
            for sink in self._sinks:
                sink.advertise(self.topic_name(topic), type_name, qos)
        self._joint_states = self.DeclareAbstractInputPort(
            "joint_states", AbstractValue.Make(JointState())
        )
        self._body_poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self.DeclareInitializationPublishEvent(self._PublishLatched)
        period = 1.0 / update_rate
        clock_period = 1.0 / clock_rate if clock_rate > 0 else period
        if not clock:
            self.DeclarePeriodicPublishEvent(period, 0.0, self._PublishState)
        elif math.isclose(clock_period, period):
            self.DeclarePeriodicPublishEvent(period, 0.0, self._PublishClockAndState)
        else:
            self.DeclarePeriodicPublishEvent(period, 0.0, self._PublishState)
            self.DeclarePeriodicPublishEvent(clock_period, 0.0, self._PublishClock)

        self._DeclareCameras(cameras)
        self._DeclareCommands(subscriber, period)

    def topic_name(self, topic: str) -> str:
        """``topic`` under the robot's namespace (a robot of several); /tf, /tf_static
        and /clock are shared."""
        if not self._prefix or topic in ("/tf", "/tf_static", "/clock"):
            return topic
        return f"{self._prefix}/{topic.lstrip('/')}"

    def _frame(self, frame: str) -> str:
        """A link's tf frame: ``<namespace>/<link>`` for a robot of several."""
        return f"{self._prefix}/{frame}" if self._prefix and frame != "world" else frame

    def _DeclareCameras(self, cameras) -> None:
        """image_raw and camera_info, a thousandth of a period after each frame."""
        self._cameras = list(cameras)
        for camera in self._cameras:
            base = camera.topic.strip("/")
            for sink in self._sinks:
                sink.advertise(f"{base}/image_raw", "sensor_msgs/msg/Image", "sensor_data")
                sink.advertise(f"{base}/camera_info", "sensor_msgs/msg/CameraInfo", "default")
            port = self.DeclareAbstractInputPort(
                f"{camera.name}.color_image", AbstractValue.Make(ImageRgba8U())
            )
            camera_period = 1.0 / camera.rate
            self.DeclarePeriodicPublishEvent(
                camera_period,
                PUBLISH_OFFSET_FRACTION * camera_period,
                lambda context, camera=camera, port=port: self._PublishFrame(context, camera, port),
            )

    def _DeclareCommands(self, subscriber, period: float) -> None:
        """Commands: DDS thread -> queue -> abstract state at the controllers' rate."""
        if self._commands:
            self._publications = self.DeclareAbstractState(
                AbstractValue.Make(tuple(Publication() for _ in self._commands))
            )
            for k, command in enumerate(self._commands):
                if command.suffix not in COMMAND_TYPES:
                    raise ValueError(
                        f"{command.port}: no ROS 2 message type known for {command.suffix!r} "
                        f"(known: {', '.join(COMMAND_TYPES)})"
                    )
                self.DeclareAbstractOutputPort(
                    command.port,
                    lambda: AbstractValue.Make(Publication()),
                    lambda context, output, k=k: output.set_value(
                        context.get_abstract_state(self._publications).get_value()[k]
                    ),
                    {self.abstract_state_ticket(self._publications)},
                )
                convert = COMMAND_TYPES[command.suffix][1]
                subscriber.subscribe(
                    self.topic_name(command.topic),
                    command.type_name,
                    lambda message, k=k, convert=convert: self._Receive(k, convert(message)),
                )
            self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._Deliver)

    def close(self) -> None:
        """Closes the DDS participant and the Foxglove server."""
        for sink in self._sinks:
            sink.close()

    @property
    def sinks(self) -> list[Any]:
        """Where the topics go: the DDS node and/or the Foxglove server."""
        return list(self._sinks)

    @property
    def commands(self) -> tuple[CommandTopic, ...]:
        return self._commands

    @property
    def received(self) -> dict[str, int]:
        """Messages received so far, by command topic (relative name)."""
        return {command.topic: n for command, n in zip(self._commands, self._received, strict=True)}

    # -- receiving (Cyclone's thread) -------------------------------------------------------
    def _Receive(self, k: int, message: Any) -> None:
        self._received[k] += 1
        self._queue.put((k, message))

    # -- delivering (the simulator's thread) ------------------------------------------------
    def _Deliver(self, context, state) -> EventStatus:
        if self._queue.empty():
            return EventStatus.DidNothing()
        latest: dict[int, Any] = {}
        while True:
            try:
                k, message = self._queue.get_nowait()
            except queue.Empty:
                break
            latest[k] = message  # as upstream's realtime buffer: the newest wins
        publications = list(context.get_abstract_state(self._publications).get_value())
        for k, message in latest.items():
            publications[k] = publications[k].publish(message, stamp=context.get_time())
        state.get_mutable_abstract_state(self._publications).set_value(tuple(publications))
        return EventStatus.Succeeded()

    # -- publishing ---------------------------------------------------------------------------
    def publish(self, topic: str, type_name: str, message: dict, stamp: float) -> None:
        """Sends one message to every sink (for the mobile base's topics)."""
        self._Publish(topic, type_name, message, stamp)

    def _Publish(self, topic: str, type_name: str, message: dict, stamp: float) -> None:
        if topic == "/tf_static":  # one static broadcaster: every frame in each message
            self._static.update({t["child_frame_id"]: t for t in message["transforms"]})
            message = {"transforms": list(self._static.values())}
        for sink in self._sinks:
            sink.publish(topic, type_name, message, stamp)

    def _Transforms(self, context, links: Sequence[_Link], stamp: float) -> dict:
        poses = self._body_poses.Eval(context)
        return {
            "transforms": [
                transform_stamped(
                    stamp,
                    self._frame(link.parent_frame),
                    self._frame(link.child_frame),
                    poses[link.parent].inverse() @ poses[link.child],
                )
                for link in links
            ]
        }

    def _PublishLatched(self, context, event=None) -> None:
        stamp = context.get_time()
        description = self.topic_name("robot_description")
        self._Publish(description, "std_msgs/msg/String", string_message(self._urdf), stamp)
        if self._fixed:
            static = self._Transforms(context, self._fixed, stamp)
            self._Publish("/tf_static", "tf2_msgs/msg/TFMessage", static, stamp)

    def _PublishClock(self, context) -> None:
        stamp = context.get_time()
        self._Publish("/clock", "rosgraph_msgs/msg/Clock", clock_message(stamp), stamp)
        for sink in self._sinks:
            if hasattr(sink, "set_time"):
                sink.set_time(stamp)

    def _PublishState(self, context) -> None:
        stamp = context.get_time()
        if self._joint_states.HasValue(context):
            sample = self._joint_states.Eval(context)
            if sample.name and sample.stamp != self._last_stamp:
                self._last_stamp = sample.stamp
                message = joint_state_message(sample)
                self._Publish(
                    self._joint_states_topic, "sensor_msgs/msg/JointState", message, stamp
                )
        if self._moving:
            tf = self._Transforms(context, self._moving, stamp)
            self._Publish("/tf", "tf2_msgs/msg/TFMessage", tf, stamp)

    def _PublishClockAndState(self, context) -> None:
        self._PublishClock(context)
        self._PublishState(context)

    def _PublishFrame(self, context, camera, port) -> None:
        image = port.Eval(context)
        if image.width() != camera.width or image.height() != camera.height:
            return  # nothing rendered yet
        period = 1.0 / camera.rate
        stamp = math.floor(context.get_time() / period + 1e-6) * period
        rgb = np.ascontiguousarray(image.data[:, :, :3])
        base = camera.topic.strip("/")
        self._Publish(
            f"{base}/image_raw",
            "sensor_msgs/msg/Image",
            image_message(stamp, camera.frame_id, rgb),
            stamp,
        )
        self._Publish(
            f"{base}/camera_info", "sensor_msgs/msg/CameraInfo", camera.camera_info(stamp), stamp
        )


def AddRos2Bridge(
    builder, config, topics: WorldTopics, others: Sequence[WorldTopics] = ()
) -> Ros2Bridge | None:
    """Adds a :class:`Ros2Bridge` for the ``ros2:`` scenario section ``config``
    (:class:`~armando_drake.ros2.config.Ros2Config`) to a world being built, on the
    publishers of ``topics``.

    With ``config.enabled`` the topics go on DDS and the command input of
    every active controller that nothing else drives yet (no sequencer) is
    subscribed; with ``config.foxglove`` they are served to Foxglove. The log
    says where the world is reachable; the bridge's ``close`` closes the participant
    and the server. Call it before the world's free command inputs
    are exported (the bridge drives them instead). Returns None when both are off.

    ``others``: the other robots of a world of several; each robot gets a bridge on the
    same participant and server, its topics under its namespace (``left/joint_states``,
    ``left/position_controller/commands``, ``left/robot_description``) and its tf frames
    named ``left/<link>``; the first robot's bridge (returned) publishes ``/clock`` and
    the cameras.
    """
    if not (config.enabled or config.foxglove):
        return None
    sinks, node = _sinks(config, topics)
    bridge = _add_bridge(builder, config, topics, sinks, node, first=True)
    for other in others:
        _add_bridge(builder, config, other, sinks, node, first=False)
    return bridge


def _add_bridge(builder, config, topics: WorldTopics, sinks, node, *, first: bool) -> Ros2Bridge:
    """One robot's :class:`Ros2Bridge` on ``sinks`` (``first``: with the clock and the
    cameras)."""
    commands = _free_commands(builder, topics, subscribe=node is not None)
    navigator = topics.navigation.navigator if topics.navigation is not None else None
    if (
        navigator is not None
        and node is not None
        and not builder.IsConnectedOrExported(navigator.GetInputPort("goal_pose"))
    ):  # RViz's 2D goal (unless the ArUco marker's goal is sent instead)
        commands.append(CommandTopic("navigator", "goal_pose", ros_topic="/goal_pose"))
    cameras = [camera_stream(name, camera) for name, camera in topics.cameras.items()]
    cameras = cameras if first else []
    plant = topics.plant
    odometry = topics.base_log is not None  # odom -> base on /tf, not world -> base
    prefix = topics.stack.namespace.strip("/")
    bridge = builder.AddSystem(
        Ros2Bridge(
            plant=plant,
            model_instance=topics.robot.model_instance,
            urdf=topics.robot.urdf,
            update_rate=topics.update_rate,
            sinks=sinks,
            subscriber=node,
            commands=commands,
            cameras=cameras,
            clock_rate=config.clock_rate,
            joint_states_topic=topics.joint_states_topic,
            exclude_children=[topics.mobile.base_link] if odometry else [],
            prefix=prefix,
            clock=first,
        )
    )
    space = f"{prefix}/" if prefix else ""
    bridge.set_name(f"{space}ros2_bridge")
    AddMobileTopics(builder, topics, bridge.publish, name=f"{space}mobile_bridge")
    if navigator is not None:
        for sink in sinks:
            sink.advertise("/map", "nav_msgs/msg/OccupancyGrid", "latched")
        AddNavigationTopics(builder, topics, bridge.publish, name=f"{space}navigation_bridge")
    if topics.broadcaster is not None:
        builder.Connect(
            topics.broadcaster.GetOutputPort("joint_states"), bridge.GetInputPort("joint_states")
        )
    builder.Connect(plant.get_body_poses_output_port(), bridge.GetInputPort("body_poses"))
    for stream in cameras:
        builder.Connect(
            topics.cameras[stream.name].color_image,
            bridge.GetInputPort(f"{stream.name}.color_image"),
        )
    for command in commands:
        if command.suffix == "goal_pose":
            builder.Connect(bridge.GetOutputPort(command.port), navigator.GetInputPort("goal_pose"))
        else:
            builder.Connect(
                bridge.GetOutputPort(command.port),
                topics.controllers[command.controller].GetInputPort(command.port),
            )
        _log.info(
            "subscribed %s (%s)", node.resolve(bridge.topic_name(command.topic)), command.type_name
        )
    return bridge


def _sinks(config, topics: WorldTopics) -> tuple[list[Any], DdsNode | None]:
    """Where the topics go: the DDS node (``config.enabled``; also returned) and the
    Foxglove server (``config.foxglove``)."""
    sinks: list[Any] = []
    node = None
    if config.enabled:
        try:
            node = DdsNode(
                domain_id=config.domain_id,
                namespace=config.namespace,
                interface=config.network_interface,
            )
        except Ros2Error as error:
            raise ScenarioError(str(error)) from None
        except Exception as error:  # Cyclone DDS: e.g. an interface it cannot use
            raise ScenarioError(
                f"ros2: cannot join DDS domain {config.domain_id} on "
                f"{config.network_interface or 'the loopback'}: {error}"
            ) from None
        sinks.append(node)
        _log.info("%s", reachability(config.domain_id, config.network_interface))
    if config.foxglove:
        require_extra("foxglove", "ros2.foxglove (--foxglove)")
        warn_if_open(config.foxglove_host, "Foxglove")
        try:
            server = FoxgloveServer(
                host=config.foxglove_host,
                port=config.foxglove_port,
                namespace=config.namespace,
                packages=topics.robot.packages.packages,
                assets=referenced_files(topics.robot.urdf),
            )
        except Exception as error:  # a bad port, or one in use
            raise ScenarioError(
                f"ros2.foxglove_port={config.foxglove_port!r} on {config.foxglove_host}: "
                f"cannot serve Foxglove there: {error}"
            ) from None
        sinks.append(server)
        _log.info("Foxglove: %s (Foxglove > Open connection > Foxglove WebSocket)", server.url)

    return sinks, node


def _free_commands(builder, topics: WorldTopics, *, subscribe: bool) -> list[CommandTopic]:
    """The command inputs no other system drives, of every active controller (logged;
    returned to be subscribed when ``subscribe``)."""
    commands = []
    for name, system in topics.controllers.items():
        for index in range(system.num_input_ports()):
            port = system.get_input_port(index)
            prefix, _, suffix = port.get_name().partition(".")
            if prefix != name or not suffix:
                continue
            if builder.IsConnectedOrExported(port):
                _log.info("%s/%s not subscribed: the %s drives it", name, suffix, "sequencer")
            elif suffix not in COMMAND_TYPES:
                _log.warning("%s/%s not subscribed: no ROS 2 type known for it", name, suffix)
            elif subscribe:
                commands.append(_command_topic(topics, name, suffix))
    return commands


def _command_topic(topics: WorldTopics, name: str, suffix: str) -> CommandTopic:
    """The topic of a controller's command input: a drive plugin's cmd_vel is its own
    topic (``/cmd_vel``), a geometry_msgs/Twist as Gazebo's bridge takes it."""
    if suffix == "cmd_vel" and topics.mobile is not None and name in topics.mobile.plugins:
        topic = topics.stack.entry(name).ros_topic or "/cmd_vel"
        return CommandTopic(name, suffix, ros_topic=topic, ros_type="geometry_msgs/msg/Twist")
    return CommandTopic(name, suffix)
