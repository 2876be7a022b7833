"""A mobile base's topics: what the course's fra2mo publishes through ros_gz_bridge.

==================== ================================= =====================================
topic                type                              from
==================== ================================= =====================================
``/odom``            ``nav_msgs/msg/Odometry``         the drive's wheel odometry
``/tf``              ``tf2_msgs/msg/TFMessage``        odom -> base_footprint, of the odometry
``/cmd_vel``         ``geometry_msgs/msg/Twist``       the twist sequence (the drive's topic)
==================== ================================= =====================================

:class:`MobileTopics` reads them at the controller manager's rate and hands each new
message (a new odometry stamp, a new publication of a twist) to ``send(topic,
type_name, message, stamp)``: the MCAP recorder's ``write`` or the live bridge's
publish. Nothing at the plant's steps. (A lidar's ``/scan`` is its own row of the table,
registered by the sensor: :mod:`armando_drake.sensors.lidar`.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem

from armando_drake.messages.definitions import (
    odometry_message,
    odometry_transform,
    twist_message,
)
from armando_drake.messages.publications import Send, Topic
from armando_drake.messages.types import Odometry, PublicationValue

ODOM_TOPIC = "/odom"


@dataclass(frozen=True)
class MobileTopicNames:
    """Where each of a base's messages goes (``""``: not published)."""

    odom: str = ODOM_TOPIC
    tf: str = "/tf"
    cmd_vel: str = ""
    # Before each frame id (odom, base_footprint): "<namespace>/" for a
    # robot of several, as its links are named on /tf; "" = the frames as they are.
    frames: str = ""


class MobileTopics(LeafSystem):
    """Sends a mobile base's odometry, its /tf and its cmd_vel.

    Ports:
      - input ``odom`` (Odometry): sent on ``odom`` and ``tf`` at each new stamp;
      - input ``cmd_vel`` (Publication of TwistStamped, optional): each new one as a Twist.
    """

    def __init__(self, names: MobileTopicNames, *, send: Send, rate: float):
        super().__init__()
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError(f"rate={rate!r} must be positive [Hz]")
        self.names = names
        self._send = send
        self._odom = self.DeclareAbstractInputPort("odom", AbstractValue.Make(Odometry()))
        self._cmd_vel = self.DeclareAbstractInputPort("cmd_vel", PublicationValue())
        self._last_odom: float | None = None
        self._counts: dict[str, int] = {}
        self.DeclarePeriodicPublishEvent(1.0 / rate, 0.0, self._Publish)

    def _new(self, key: str, port, context):
        """The latest message of a Publication input if it is new since the last call."""
        if not port.HasValue(context):
            return None
        publication = port.Eval(context)
        if publication.count <= self._counts.get(key, 0):
            return None
        self._counts[key] = publication.count
        return publication

    def _framed(self, message: dict) -> dict:
        """``message`` with its header's frame id (and child frame id) after
        ``names.frames``."""
        before = self.names.frames
        if before:
            message["header"]["frame_id"] = before + message["header"]["frame_id"]
            if "child_frame_id" in message:
                message["child_frame_id"] = before + message["child_frame_id"]
        return message

    def _Publish(self, context) -> None:
        names = self.names
        if self._odom.HasValue(context):
            odom = self._odom.Eval(context)
            if odom.stamp > 0 and odom.stamp != self._last_odom:
                self._last_odom = odom.stamp
                if names.odom:
                    message = self._framed(odometry_message(odom))
                    self._send(names.odom, "nav_msgs/msg/Odometry", message, odom.stamp)
                if names.tf:
                    tf = {"transforms": [self._framed(odometry_transform(odom))]}
                    self._send(names.tf, "tf2_msgs/msg/TFMessage", tf, odom.stamp)
        twist = self._new("cmd_vel", self._cmd_vel, context) if names.cmd_vel else None
        if twist is not None:
            message = twist_message(twist.message)
            self._send(names.cmd_vel, "geometry_msgs/msg/Twist", message, twist.stamp)


@dataclass(frozen=True, eq=False)
class MobileSource:
    """The :class:`MobileTopics` of a robot: its base's odometry (``base_log``, the
    BaseLogger of a floating base with a drive) and the twist sequence publishing cmd_vel
    (``twist``, on the drive ``twist_target``), on the controllers of ``stack`` (a
    ControlStack): a :class:`~armando_drake.messages.publications.TopicSource`."""

    stack: Any
    base_log: Any = None
    twist: Any = None
    twist_target: str = ""

    def topic(self, name: str) -> str:
        """The absolute ROS topic of ``name`` for this robot: under its namespace in a
        world of several (``/left/odom``), else ``/<name>``."""
        return f"{self.stack.namespace.rstrip('/')}/{name.lstrip('/')}"

    def names(self, *, cmd_vel: bool = True) -> MobileTopicNames:
        """The topics of the base (``cmd_vel``: the twist sequence's too), under the
        robot's namespace in a world of several (``/tf`` is shared; the frames are then
        ``<namespace>/odom``, ``<namespace>/base_footprint``, ...)."""
        odom = self.topic(ODOM_TOPIC) if self.base_log is not None else ""
        twist = ""
        if cmd_vel and self.twist is not None:
            twist = self.topic(self.stack.entry(self.twist_target).ros_topic or "/cmd_vel")
        space = self.stack.namespace.strip("/")
        return MobileTopicNames(
            odom=odom,
            tf="/tf" if odom else "",
            cmd_vel=twist,
            frames=f"{space}/" if space else "",
        )

    def table(self) -> list[Topic]:
        """Its topics (recorded and live), their names under the robot's namespace."""
        names, rate = self.names(), self.stack.update_rate
        found = []
        if names.odom:
            found += [
                Topic(names.odom, "nav_msgs/msg/Odometry", source=self, rate=rate,
                      frame_id=f"{names.frames}odom"),
                Topic(names.tf, "tf2_msgs/msg/TFMessage", source=self, rate=rate),
            ]  # fmt: skip
        if names.cmd_vel:
            found.append(Topic(names.cmd_vel, "geometry_msgs/msg/Twist", source=self, rate=rate))
        return found

    def attach(self, builder, send: Send, consumer: str) -> MobileTopics | None:
        space = self.stack.namespace.strip("/")
        name = f"{space}/mobile_{consumer}" if space else f"mobile_{consumer}"
        return AddMobileTopics(builder, self, send, name=name)


def AddMobileTopics(
    builder, source: MobileSource, send: Send, *, cmd_vel: bool = True, name: str = "mobile_topics"
) -> MobileTopics | None:
    """A :class:`MobileTopics` on the base's odometry (a floating base with a drive) and
    the twist sequence's cmd_vel (with ``cmd_vel``) of ``source``; None when there is
    neither."""
    names = source.names(cmd_vel=cmd_vel)
    if not (names.odom or names.cmd_vel):
        return None
    stack = source.stack
    system = builder.AddNamedSystem(name, MobileTopics(names, send=send, rate=stack.update_rate))
    if names.odom:
        drive = source.base_log.drive
        builder.Connect(stack.manager.GetOutputPort(f"{drive}.odom"), system.GetInputPort("odom"))
    if names.cmd_vel:
        builder.Connect(source.twist.GetOutputPort("cmd_vel"), system.GetInputPort("cmd_vel"))
    return system
