"""The generic system that publishes the ports of the world's publication table
(:class:`~armando_drake.messages.publications.Publications`, filled by the subsystems as
the world is built).

:func:`AttachTopics` connects a consumer to the published topics of a table: its
:class:`TopicPublisher` reads the topics that come from a port, each source adds its own
system; every message goes to ``send(topic, type_name, message, stamp)``. The MCAP
recorder and the DDS bridge are this loop with their own ``send``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from pydrake.systems.framework import LeafSystem, PortDataType

from armando_drake.messages.definitions import resolve_topic
from armando_drake.messages.publications import Send, Topic, sources


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
    :func:`from_ports` of them, added to ``builder``) to their ports (telling each topic,
    :attr:`Topic.on_attach`), and each source's system to ``send`` (only the topics
    among ``topics``; ``consumer`` names it)."""
    for index, topic in enumerate(from_ports(topics)):
        builder.Connect(topic.port, system.get_input_port(index))
        if topic.on_attach is not None:
            topic.on_attach()
    for source, names in sources(topics):
        source.attach(builder, _only(send, names), consumer)


def _only(send: Send, names: set[str]) -> Send:
    """``send`` for the topics of ``names`` only (a source may send more)."""

    def filtered(topic: str, type_name: str, message: dict, stamp: float) -> None:
        if topic in names:
            send(topic, type_name, message, stamp)

    return filtered
