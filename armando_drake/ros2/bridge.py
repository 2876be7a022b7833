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
(:mod:`armando_drake.navigation.topics`); a ``/goal_pose`` (RViz's 2D goal, in the
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

Which topics go: every ``live`` topic of the world's publication table
(:mod:`armando_drake.outputs.publications`), and every subscription of it whose input
nothing else drives; a topic added to the table is on DDS and in Foxglove with no edit
here. Each robot's :class:`Ros2Bridge` adds what robot_state_publisher and Gazebo's clock
bridge give (``/tf`` and ``/tf_static`` of its links, ``robot_description``, ``/clock``)
and feeds its subscriptions to its controllers.

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

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import EventStatus, LeafSystem

from armando_drake.messages.definitions import (
    clock_message,
    message_definition,
    resolve_topic,
    string_message,
    transform_stamped,
)
from armando_drake.messages.publications import SHARED_TOPICS, Publications, Topic
from armando_drake.messages.types import Publication
from armando_drake.outputs.publications import AttachTopics, TopicPublisher
from armando_drake.ros2.dds import DdsNode, Ros2Error, reachability
from armando_drake.tools.cli import warn_if_open
from armando_drake.tools.errors import ScenarioError
from armando_drake.tools.extras import require_extra
from armando_drake.tools.rejections import Rejections

_log = logging.getLogger("armando_drake.ros2")

# The topics each robot's bridge publishes itself: ROS type and QoS profile.
TOPICS = {
    "/clock": ("rosgraph_msgs/msg/Clock", "default"),
    "/tf": ("tf2_msgs/msg/TFMessage", "default"),
    "/tf_static": ("tf2_msgs/msg/TFMessage", "latched"),
    "robot_description": ("std_msgs/msg/String", "latched"),
}


@dataclass(frozen=True)
class CommandTopic:
    """One subscription of the table, fed to an input of the world."""

    topic: str  # the ROS 2 topic, relative to the robot's namespace
    type_name: str  # pkg/msg/Type
    port: str  # the bridge's output port, e.g. "position_controller.commands"
    receive: Callable[[Any], Any]  # a received message -> the input's value

    @classmethod
    def of(cls, topic: Topic) -> CommandTopic:
        return cls(topic.topic, topic.type_name, topic.key, topic.receive)


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


class LiveSinks:
    """The sinks of a world's topics (DDS, Foxglove), shared by its bridges: each message
    goes to every sink; ``/tf_static`` is one static broadcaster, each message carrying
    every frame sent so far (as tf2's StaticTransformBroadcaster latches them)."""

    def __init__(self, sinks: Sequence[Any]):
        self.sinks = list(sinks)
        self._static: dict[str, dict] = {}  # /tf_static's frames so far, by child

    def advertise(self, topic: str, type_name: str, qos: str = "default") -> None:
        for sink in self.sinks:
            sink.advertise(topic, type_name, qos)

    def publish(self, topic: str, type_name: str, message: dict, stamp: float) -> None:
        if topic == "/tf_static":
            self._static.update({t["child_frame_id"]: t for t in message["transforms"]})
            message = {"transforms": list(self._static.values())}
        for sink in self.sinks:
            sink.publish(topic, type_name, message, stamp)

    def set_time(self, stamp: float) -> None:
        for sink in self.sinks:
            if hasattr(sink, "set_time"):
                sink.set_time(stamp)

    def close(self) -> None:
        for sink in self.sinks:
            sink.close()


class Ros2Bridge(LeafSystem):
    """One robot on DDS and Foxglove: its links on /tf, its description, and the
    commands received for it.

    .. pydrake_system::

        name: Ros2Bridge
        input_ports:
        - body_poses
        output_ports:
        - <controller>.<suffix> (one per subscribed command topic)

    - ``body_poses``: the plant's body poses in the world
      (``get_body_poses_output_port``); ``/tf`` carries every moving joint of
      ``model_instance`` as parent link -> child link at ``update_rate``,
      ``/tf_static`` every fixed one once at initialization;
    - ``<controller>.<suffix>``: a
      :class:`~armando_drake.messages.types.Publication` holding the latest
      command received on its topic (abstract state, updated at ``update_rate``).

    ``/clock`` is published at ``clock_rate`` [Hz] (simulation time) when ``clock``, and
    ``robot_description`` (the URDF text) once at initialization. ``sinks`` (a
    :class:`LiveSinks`) has ``advertise(topic, type_name, qos)``, ``publish(topic,
    type_name, message, stamp)`` and ``set_time(stamp)``; ``subscriber``, if given, has
    ``subscribe(topic, type_name, callback)`` and delivers the commands.
    """

    def __init__(
        self,
        *,
        plant,
        model_instance,
        urdf: str,
        update_rate: float,
        sinks: LiveSinks,
        subscriber: Any = None,
        commands: Sequence[CommandTopic] = (),
        clock_rate: float = 0.0,
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
        self._sinks = sinks
        self._urdf = urdf
        self._moving, self._fixed = robot_links(plant, model_instance)
        # Links whose pose another broadcaster gives (the odometry's base frame).
        self._moving = [link for link in self._moving if link.child_frame not in exclude_children]
        self._commands = tuple(commands)
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._received = [0] * len(self._commands)  # messages received per command topic
        self._rejections = Rejections("ros2")  # messages dropped per command topic
        for topic, (type_name, qos) in TOPICS.items():
            if topic != "/clock" or clock:
                sinks.advertise(self.topic_name(topic), type_name, qos)
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
        self._DeclareCommands(subscriber, period)

    def topic_name(self, topic: str) -> str:
        """``topic`` under the robot's namespace (a robot of several); /tf, /tf_static
        and /clock are shared."""
        if not self._prefix or topic in SHARED_TOPICS:
            return topic
        return f"{self._prefix}/{topic.lstrip('/')}"

    def _frame(self, frame: str) -> str:
        """A link's tf frame: ``<namespace>/<link>`` for a robot of several."""
        return f"{self._prefix}/{frame}" if self._prefix and frame != "world" else frame

    def _DeclareCommands(self, subscriber, period: float) -> None:
        """Commands: DDS thread -> queue -> abstract state at the controllers' rate."""
        if not self._commands:
            return
        self._publications = self.DeclareAbstractState(
            AbstractValue.Make(tuple(Publication() for _ in self._commands))
        )
        for k, command in enumerate(self._commands):
            self.DeclareAbstractOutputPort(
                command.port,
                lambda: AbstractValue.Make(Publication()),
                lambda context, output, k=k: output.set_value(
                    context.get_abstract_state(self._publications).get_value()[k]
                ),
                {self.abstract_state_ticket(self._publications)},
            )
            subscriber.subscribe(
                self.topic_name(command.topic),
                command.type_name,
                lambda message, k=k, receive=command.receive: self._Receive(k, message, receive),
            )
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._Deliver)

    def close(self) -> None:
        """Closes the DDS participant and the Foxglove server."""
        self._sinks.close()

    @property
    def sinks(self) -> list[Any]:
        """Where the topics go: the DDS node and/or the Foxglove server."""
        return list(self._sinks.sinks)

    @property
    def commands(self) -> tuple[CommandTopic, ...]:
        return self._commands

    @property
    def received(self) -> dict[str, int]:
        """Messages received so far, by command topic (relative name)."""
        return {command.topic: n for command, n in zip(self._commands, self._received, strict=True)}

    @property
    def rejections(self) -> Rejections:
        """Messages dropped so far (not finite, out of range, malformed), by topic."""
        return self._rejections

    # -- receiving (Cyclone's thread) -------------------------------------------------------
    def _Receive(self, k: int, message: Any, receive: Callable[[Any], Any] | None = None) -> None:
        """Converts (with ``receive``; None: ``message`` is converted already) and queues a
        message; one that cannot be used is dropped with a logged reason (counted in
        :attr:`rejections`), the last good command kept."""
        self._received[k] += 1
        try:
            value = message if receive is None else receive(message)
        except (ValueError, TypeError, KeyError, OverflowError, AttributeError) as error:
            self._rejections.reject(self.topic_name(self._commands[k].topic), str(error))
            return
        self._queue.put((k, value))

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
        """Sends one message to every sink."""
        self._sinks.publish(topic, type_name, message, stamp)

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
        self.publish(description, "std_msgs/msg/String", string_message(self._urdf), stamp)
        if self._fixed:
            static = self._Transforms(context, self._fixed, stamp)
            self.publish("/tf_static", "tf2_msgs/msg/TFMessage", static, stamp)

    def _PublishClock(self, context) -> None:
        stamp = context.get_time()
        self.publish("/clock", "rosgraph_msgs/msg/Clock", clock_message(stamp), stamp)
        self._sinks.set_time(stamp)

    def _PublishState(self, context) -> None:
        if self._moving:
            stamp = context.get_time()
            tf = self._Transforms(context, self._moving, stamp)
            self.publish("/tf", "tf2_msgs/msg/TFMessage", tf, stamp)

    def _PublishClockAndState(self, context) -> None:
        self._PublishClock(context)
        self._PublishState(context)


@dataclass(frozen=True)
class BridgeRobot:
    """A robot whose ``/tf``, ``/tf_static`` and ``robot_description`` a bridge
    publishes: its control stack (a ControlStack: plant, description, namespace, update
    rate) and, for a base with odometry, the base link the odometry places on ``/tf``
    (``odom -> base``, not ``world -> base``; "" otherwise)."""

    stack: Any
    odometry_link: str = ""


def AddRos2Bridge(
    builder, config, table: Publications, robots: Sequence[BridgeRobot]
) -> Ros2Bridge | None:
    """Adds the world's topics on DDS and Foxglove for the ``ros2:`` scenario section
    ``config`` (:class:`~armando_drake.ros2.config.Ros2Config`) to a world being built.

    ``table``: the world's publication table; ``robots``: its robots, the first one's
    bridge with ``/clock``. With ``config.enabled`` the table's ``live`` topics go on DDS
    and its subscriptions whose input nothing else drives yet (no sequencer) are
    subscribed; with ``config.foxglove`` the topics are served to Foxglove. The log says
    where the world is reachable; the bridge's ``close`` closes the participant and the
    server. Call it before the world's free command inputs are exported (the bridge
    drives them instead). Returns None when both are off.

    Each robot gets a :class:`Ros2Bridge` (the first one's is returned, with ``/clock``)
    on the same participant and server, its topics under its namespace
    (``left/joint_states``, ``left/position_controller/commands``,
    ``left/robot_description``) and its tf frames named ``left/<link>``.
    """
    if not (config.enabled or config.foxglove):
        return None
    first, *others = robots
    sinks, node = _sinks(config, first.stack.robot)
    live = LiveSinks(sinks)
    for label, port in table.untyped:
        if not builder.IsConnectedOrExported(port):
            _log.warning("%s not subscribed: no ROS 2 type known for it", label)
    bridge = _add_bridge(builder, config, first, table, live, node, first=True)
    for other in others:
        _add_bridge(builder, config, other, table, live, node, first=False)
    published = table.published(live=True)
    for topic in published:
        live.advertise(topic.name, topic.type_name, topic.qos)
    system = builder.AddNamedSystem(
        "ros2_topics", TopicPublisher(published, live.publish, name=lambda topic: topic.name)
    )
    AttachTopics(builder, system, published, live.publish, consumer="bridge")
    return bridge


def _add_bridge(
    builder, config, robot: BridgeRobot, table: Publications, live: LiveSinks, node, *, first
) -> Ros2Bridge:
    """One robot's :class:`Ros2Bridge` on ``live`` (``first``: with the clock), with the
    subscriptions of ``table`` under its namespace that nothing drives yet."""
    stack = robot.stack
    prefix = stack.namespace.strip("/")
    subscribed = []  # (the bridge's view, the table's topic)
    for topic in table.subscribed(namespace=prefix):
        if builder.IsConnectedOrExported(topic.port):
            _log.info("%s not subscribed: another system drives it", topic.key.replace(".", "/"))
        elif node is not None:
            subscribed.append((CommandTopic.of(topic), topic))
    plant = stack.plant
    bridge = builder.AddSystem(
        Ros2Bridge(
            plant=plant,
            model_instance=stack.robot.model_instance,
            urdf=stack.robot.urdf,
            update_rate=stack.update_rate,
            sinks=live,
            subscriber=node,
            commands=[command for command, _ in subscribed],
            clock_rate=config.clock_rate,
            exclude_children=[robot.odometry_link] if robot.odometry_link else [],
            prefix=prefix,
            clock=first,
        )
    )
    bridge.set_name(f"{prefix}/ros2_bridge" if prefix else "ros2_bridge")
    builder.Connect(plant.get_body_poses_output_port(), bridge.GetInputPort("body_poses"))
    for command, topic in subscribed:
        builder.Connect(bridge.GetOutputPort(command.port), topic.port)
        _log.info(
            "subscribed %s (%s)", node.resolve(bridge.topic_name(command.topic)), command.type_name
        )
    return bridge


def _sinks(config, robot) -> tuple[list[Any], DdsNode | None]:
    """Where the topics go: the DDS node (``config.enabled``; also returned) and the
    Foxglove server (``config.foxglove``, serving the files of ``robot``, the first
    robot's LoadedRobot)."""
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
                packages=robot.packages.packages,
                assets=referenced_files(robot.urdf),
            )
        except Exception as error:  # a bad port, or one in use
            raise ScenarioError(
                f"ros2.foxglove_port={config.foxglove_port!r} on {config.foxglove_host}: "
                f"cannot serve Foxglove there: {error}"
            ) from None
        sinks.append(server)
        _log.info("Foxglove: %s (Foxglove > Open connection > Foxglove WebSocket)", server.url)

    return sinks, node
