"""The publication table: what a world publishes and subscribes, one record per topic.

Each :class:`Topic` names a topic, its ROS 2 message type (one of the ``rosbags`` type
store, :mod:`armando_drake.messages.definitions`) and where its messages come from or go:

- a topic published from a port: the Drake output port it is read from and ``read``, the
  function that turns the port's value into a message (or says there is nothing new), at
  ``rate`` [Hz];
- a topic published by a system of its own (a :class:`TopicSource`, e.g. a mobile base's
  odometry and ``/tf``, which reads several ports and keeps state): that source, which
  adds its system once for every topic it sends;
- a topic subscribed: the input port its messages drive and ``receive``, the function
  that turns a received message into that port's value.

The table is filled while the world is built: the builder hands one
:class:`PublicationRegistry` to each ``AddX`` that publishes or subscribes, which registers
its rows next to the system it adds. The MCAP recorder
(:mod:`armando_drake.outputs.recording`), the DDS bridge and Foxglove
(:mod:`armando_drake.ros2.bridge`) are loops over the finished :class:`Publications`
table: a topic added to it is recorded (``recorded``), sent on DDS and to Foxglove
(``live``) and, when subscribed, fed from DDS, with no edit of theirs. This module
imports no Drake system: the ports are whatever the systems that fill the table give.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

PUBLISH, SUBSCRIBE = "publish", "subscribe"
# The topics every robot of a world shares (not under a robot's namespace).
SHARED_TOPICS = ("/tf", "/tf_static", "/clock")
QOS_PROFILES = ("default", "latched", "sensor_data")

# (port value, simulation time [s]) -> (message dictionary, stamp [s], key) or None when
# there is nothing to send; a message is sent only when its key differs from the last one
# sent (None: every time).
Read = Callable[[Any, float], "tuple[dict, float, Hashable] | None"]
# (topic, type name, message dictionary, stamp [s]): the recorder's write, the bridge's
# publish.
Send = Callable[[str, str, dict, float], None]


class TopicSource(Protocol):
    """A system that sends several topics of a table (it reads its own ports)."""

    def attach(self, builder, send: Send, consumer: str) -> Any:
        """Adds the system to ``builder``, sending through ``send``; ``consumer`` (e.g.
        ``"recorder"``, ``"bridge"``) names the system apart from the other consumers'."""


@dataclass(frozen=True, eq=False)
class Topic:
    """One topic of the world: published from a port or a source, or subscribed."""

    topic: str  # as the robot's node names it: relative (joint_states) or absolute (/tf)
    type_name: str  # pkg/msg/Type
    direction: str = PUBLISH  # PUBLISH or SUBSCRIBE
    port: Any = None  # PUBLISH: the output port read; SUBSCRIBE: the input port fed
    read: Read | None = None  # PUBLISH from a port: its value -> a message
    receive: Callable[[Any], Any] | None = None  # SUBSCRIBE: a received message -> value
    source: TopicSource | None = None  # PUBLISH through a system of its own
    rate: float = 0.0  # [Hz] the port is read; 0: once, at initialization
    offset: float = 0.0  # [s] of the reads after each period's start
    frame_id: str = ""  # header.frame_id of its messages ("" where it varies)
    qos: str = "default"  # QoS profile on DDS: default, latched or sensor_data
    namespace: str = ""  # the robot's namespace in a world of several ("" otherwise)
    key: str = ""  # the name of a subscription's port on the bridge (controller.suffix)
    recorded: bool = True  # written to the MCAP recording
    live: bool = True  # published on DDS and Foxglove
    # PUBLISH from a port: called once by each consumer that connects to the port (a
    # camera renders only the frames read: it learns of its readers so)
    on_attach: Callable[[], None] | None = None

    def __post_init__(self) -> None:
        where = f"topic {self.topic!r} ({self.type_name})"
        if self.direction not in (PUBLISH, SUBSCRIBE):
            raise ValueError(f"{where}: direction={self.direction!r} is not publish/subscribe")
        if self.qos not in QOS_PROFILES:
            raise ValueError(f"{where}: qos={self.qos!r} is not one of {QOS_PROFILES}")
        if self.direction == SUBSCRIBE:
            if self.port is None or self.receive is None:
                raise ValueError(f"{where}: a subscription needs its port and receive")
        elif (self.source is None) == (self.port is None or self.read is None):
            raise ValueError(f"{where}: a publication needs a port and read, or a source")
        if self.rate < 0:
            raise ValueError(f"{where}: rate={self.rate!r} must be positive, or 0 [Hz]")

    @property
    def name(self) -> str:
        """The topic under the robot's namespace (``left/joint_states``), relative to the
        world's ROS 2 namespace; absolute names and the shared topics as they are for one
        robot."""
        if not self.namespace or self.topic in SHARED_TOPICS:
            return self.topic
        return f"{self.namespace.strip('/')}/{self.topic.lstrip('/')}"


@dataclass(frozen=True)
class Publications:
    """The table: every topic of a world, in the order its systems registered them."""

    topics: tuple[Topic, ...] = ()
    # Command inputs of the controllers that no ROS 2 type is known for, left
    # unsubscribed: ("<controller>/<suffix>", the input port).
    untyped: tuple[tuple[str, Any], ...] = ()

    def __add__(self, other: Publications) -> Publications:
        return Publications(self.topics + other.topics, self.untyped + other.untyped)

    def published(self, *, recorded: bool = False, live: bool = False) -> list[Topic]:
        """The published topics (those ``recorded``, or those ``live``)."""
        return [
            topic
            for topic in self.topics
            if topic.direction == PUBLISH
            and ((recorded and topic.recorded) or (live and topic.live))
        ]

    def subscribed(self, namespace: str | None = None) -> list[Topic]:
        """The subscribed topics (of the robot of ``namespace`` when given)."""
        return [
            topic
            for topic in self.topics
            if topic.direction == SUBSCRIBE and namespace in (None, topic.namespace)
        ]


class PublicationRegistry:
    """The table of a world being built: each ``AddX`` registers the topics of the systems
    it adds (:meth:`add`), in build order; :meth:`table` is the finished table."""

    def __init__(self) -> None:
        self._topics: list[Topic] = []
        self._untyped: list[tuple[str, Any]] = []

    def add(self, *topics: Topic) -> None:
        """Registers ``topics`` (published or subscribed)."""
        self._topics.extend(topics)

    def add_untyped(self, label: str, port: Any) -> None:
        """Registers a command input no ROS 2 type is known for (``<controller>/<suffix>``)."""
        self._untyped.append((label, port))

    def table(self) -> Publications:
        """The table of every topic registered so far."""
        return Publications(tuple(self._topics), tuple(self._untyped))


def register(publications: PublicationRegistry | None, *topics: Topic) -> None:
    """Registers ``topics`` in ``publications`` (None: a system added outside a world's
    build, which publishes nothing)."""
    if publications is not None:
        publications.add(*topics)


def published(convert: Callable[[Any], dict]) -> Read:
    """The ``read`` of a port holding a :class:`~armando_drake.messages.types.Publication`:
    each new publication (its count grew) as ``convert(publication.message)``, stamped
    with its publication time."""

    def read(publication: Any, time: float):
        if publication.count <= 0:
            return None
        return convert(publication.message), publication.stamp, publication.count

    return read


def sampled(convert: Callable[[Any], dict]) -> Read:
    """The ``read`` of a port holding a stamped sample (a JointState): each new stamp as
    ``convert(sample)``, stamped with it (a sample naming no joint: none)."""

    def read(sample: Any, time: float):
        if not getattr(sample, "name", True):
            return None
        return convert(sample), sample.stamp, sample.stamp

    return read


def sources(topics: Sequence[Topic]) -> list[tuple[TopicSource, set[str]]]:
    """The distinct sources of ``topics``, each with the names of its topics among them."""
    found: dict[int, tuple[TopicSource, set[str]]] = {}
    for topic in topics:
        if topic.source is not None:
            found.setdefault(id(topic.source), (topic.source, set()))[1].add(topic.name)
    return list(found.values())
