"""Differential drives a description declares in ``<gazebo><plugin>`` blocks.

A mobile robot's URDF usually asks the simulator itself to drive its wheels: Gazebo
Sim's DiffDrive system, or Gazebo classic's ``gazebo_ros_diff_drive`` (ROS 2 tags in
snake case, ROS 1 tags in camel case). :func:`parse_drive_plugins` reads each into a
:class:`DrivePlugin` with upstream's defaults, checked against the description's
joints; the control layer runs it (:mod:`armando_drake.control.controllers.diff_drive`).

Every problem is a :class:`~armando_drake.description.packages.DescriptionError` of one
line naming the file, the plugin and the value: a wheel joint the description lacks, a
wheel radius or separation that is not positive, a number that is not one.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

from armando_drake.description.packages import DescriptionError

# Gazebo Sim's DiffDrive system: (filename fragments, names) it is known by.
GZ_SIM = "gz_sim"
GZ_SIM_NAMES = ("diff-drive-system", "diff_drive_system", "systems::DiffDrive")
# Gazebo classic's gazebo_ros plugin (ROS 1 and ROS 2 builds share the filename).
GAZEBO_ROS = "gazebo_ros"  # ROS 2 tags (left_joint, wheel_diameter, ...)
GAZEBO_ROS1 = "gazebo_ros1"  # ROS 1 tags (leftJoint, wheelDiameter, ...)
GAZEBO_ROS_NAMES = ("gazebo_ros_diff_drive",)


@dataclass(frozen=True)
class AxisLimits:
    """Limits on one axis of the commanded twist (linear x or angular z), as Gazebo Sim's
    SpeedLimiter takes them: each bound on its own, +-inf where not given."""

    min_velocity: float = -math.inf  # [m/s or rad/s]
    max_velocity: float = math.inf
    min_acceleration: float = -math.inf  # [m/s^2 or rad/s^2]
    max_acceleration: float = math.inf
    min_jerk: float = -math.inf  # [m/s^3 or rad/s^3]
    max_jerk: float = math.inf


@dataclass(frozen=True)
class DrivePlugin:
    """One differential drive of a ``<gazebo><plugin>`` block, with upstream's defaults."""

    name: str  # the plugin's name attribute
    dialect: str  # GZ_SIM, GAZEBO_ROS or GAZEBO_ROS1
    filename: str  # the plugin's filename attribute
    left_joints: tuple[str, ...]
    right_joints: tuple[str, ...]
    wheel_separation: float  # [m] between the left and right wheels' contact lines
    wheel_radius: float  # [m]
    topic: str = "cmd_vel"  # the Twist it subscribes to (relative)
    odom_topic: str = "odom"  # the Odometry it publishes (relative)
    odom_frame: str = "odom"
    base_frame: str = ""  # the odometry's child frame; "" = the robot's root link
    odom_rate: float = 50.0  # [Hz] odometry publication rate
    # [Hz] how often the plugin updates its wheel commands; 0 = every simulator step.
    update_rate: float = 0.0
    max_wheel_torque: float = math.inf  # [N m] the wheel motors' torque limit
    # [m/s^2] the largest change of a wheel's rim speed (classic); inf = none.
    max_wheel_acceleration: float = math.inf
    linear: AxisLimits = field(default_factory=AxisLimits)
    angular: AxisLimits = field(default_factory=AxisLimits)
    # Where the odometry comes from: "encoder" (wheel joints) or "world" (the model's
    # pose in the world: Gazebo classic's default).
    odometry_source: str = "encoder"
    publish_odom_tf: bool = True
    where: str = ""  # "<file>: <plugin name=...>", for messages

    @property
    def joints(self) -> tuple[str, ...]:
        return self.left_joints + self.right_joints


def _dialect(plugin: ET.Element) -> str | None:
    """The drive dialect of a ``<plugin>`` element, or None for any other plugin."""
    label = f"{plugin.get('filename', '')} {plugin.get('name', '')}"
    if any(fragment in label for fragment in GZ_SIM_NAMES):
        return GZ_SIM
    if any(fragment in label for fragment in GAZEBO_ROS_NAMES):
        camel = any(plugin.find(tag) is not None for tag in ("leftJoint", "rightJoint"))
        return GAZEBO_ROS1 if camel else GAZEBO_ROS
    return None


class _Reader:
    """The tags of one ``<plugin>`` element, read with its location in messages."""

    def __init__(self, plugin: ET.Element, where: str):
        self.plugin = plugin
        self.where = where

    def texts(self, tag: str) -> list[str]:
        return [(e.text or "").strip() for e in self.plugin.findall(tag)]

    def text(self, tag: str, default: str) -> str:
        values = self.texts(tag)
        return values[0] if values and values[0] else default

    def number(self, tag: str, default: float) -> float:
        values = self.texts(tag)
        if not values:
            return default
        try:
            value = float(values[0])
        except ValueError:
            raise DescriptionError(
                f"{self.where}: <{tag}>{values[0]}</{tag}> is not a number"
            ) from None
        if math.isnan(value):
            raise DescriptionError(f"{self.where}: <{tag}>{values[0]}</{tag}> is not a number")
        return value

    def flag(self, tag: str, default: bool) -> bool:
        value = self.text(tag, "").lower()
        if not value:
            return default
        if value in ("1", "true"):
            return True
        if value in ("0", "false"):
            return False
        raise DescriptionError(f"{self.where}: <{tag}>{value}</{tag}> is not true or false")

    def positive(self, tag: str, value: float) -> float:
        if not (value > 0 and math.isfinite(value)):
            raise DescriptionError(f"{self.where}: <{tag}>{value:g}</{tag}> must be > 0")
        return value


def _gz_limits(reader: _Reader, axis: str) -> AxisLimits:
    """Gazebo Sim's limits of ``axis`` (linear | angular): the axis's own tags, else the
    tags without an axis (which set both, as the system reads them)."""
    values = {}
    for kind in ("velocity", "acceleration", "jerk"):
        for bound, default in (("min", -math.inf), ("max", math.inf)):
            value = reader.number(f"{bound}_{kind}", default)
            value = reader.number(f"{bound}_{axis}_{kind}", value)
            values[f"{bound}_{kind}"] = value
    return AxisLimits(**values)


def _gz_sim(reader: _Reader, name: str, filename: str) -> DrivePlugin:
    """Gazebo Sim's DiffDrive system (gz-sim's DiffDrive.cc defaults)."""
    return DrivePlugin(
        name=name,
        dialect=GZ_SIM,
        filename=filename,
        left_joints=tuple(reader.texts("left_joint")),
        right_joints=tuple(reader.texts("right_joint")),
        wheel_separation=reader.positive(
            "wheel_separation", reader.number("wheel_separation", 1.0)
        ),
        wheel_radius=reader.positive("wheel_radius", reader.number("wheel_radius", 0.2)),
        topic=reader.text("topic", "cmd_vel"),
        odom_topic=reader.text("odom_topic", "odometry"),
        odom_frame=reader.text("frame_id", "odom"),
        base_frame=reader.text("child_frame_id", ""),
        odom_rate=reader.number("odom_publish_frequency", 50.0),
        linear=_gz_limits(reader, "linear"),
        angular=_gz_limits(reader, "angular"),
        where=reader.where,
    )


def _gazebo_ros(reader: _Reader, name: str, filename: str, ros1: bool) -> DrivePlugin:
    """Gazebo classic's gazebo_ros_diff_drive, ROS 2 tags or ROS 1 (camel-case) ones."""
    tags = (
        ("leftJoint", "rightJoint", "wheelSeparation", "wheelDiameter", "wheelTorque",
         "wheelAcceleration", "commandTopic", "odometryTopic", "odometryFrame",
         "robotBaseFrame", "updateRate", "odometrySource", "publishOdomTF")
        if ros1
        else ("left_joint", "right_joint", "wheel_separation", "wheel_diameter",
              "max_wheel_torque", "max_wheel_acceleration", "command_topic", "odometry_topic",
              "odometry_frame", "robot_base_frame", "update_rate", "odometry_source",
              "publish_odom_tf")
    )  # fmt: skip
    (left, right, separation, diameter, torque, acceleration, command, odom, frame, base,
     rate, source, tf) = tags  # fmt: skip
    wheel_diameter = reader.positive(diameter, reader.number(diameter, 0.15))
    wheel_acceleration = reader.number(acceleration, 0.0)
    if wheel_acceleration < 0:
        raise DescriptionError(
            f"{reader.where}: <{acceleration}>{wheel_acceleration:g} must be >= 0"
        )
    # ROS 2: <ros><namespace> and <remapping>cmd_vel:=...</remapping> rename the topics.
    remapped = {}
    for text in reader.texts("ros/remapping") + reader.texts("ros/argument"):
        source_topic, _, target = text.removeprefix("--remap").strip().partition(":=")
        if target:
            remapped[source_topic.strip().lstrip("~/")] = target.strip()
    namespace = reader.text("ros/namespace", "").strip("/")
    odometry = reader.text(source, "1").lower()
    if odometry not in ("0", "1", "encoder", "world"):
        raise DescriptionError(
            f"{reader.where}: <{source}>{odometry}</{source}> must be encoder (0) or world (1)"
        )
    return DrivePlugin(
        name=name,
        dialect=GAZEBO_ROS1 if ros1 else GAZEBO_ROS,
        filename=filename,
        left_joints=tuple(reader.texts(left)),
        right_joints=tuple(reader.texts(right)),
        wheel_separation=reader.positive(separation, reader.number(separation, 0.34)),
        wheel_radius=wheel_diameter / 2,
        topic=_in(namespace, remapped.get("cmd_vel", reader.text(command, "cmd_vel"))),
        odom_topic=_in(namespace, remapped.get("odom", reader.text(odom, "odom"))),
        odom_frame=reader.text(frame, "odom"),
        base_frame=reader.text(base, "base_footprint"),
        odom_rate=reader.number(rate, 100.0),
        update_rate=reader.number(rate, 100.0),
        max_wheel_torque=reader.positive(torque, reader.number(torque, 5.0)),
        max_wheel_acceleration=wheel_acceleration or math.inf,
        odometry_source="encoder" if odometry in ("0", "encoder") else "world",
        publish_odom_tf=reader.flag(tf, ros1),
        where=reader.where,
    )


def _in(namespace: str, topic: str) -> str:
    """``topic`` in ``namespace`` (an absolute topic stays as it is)."""
    if topic.startswith("/") or not namespace:
        return topic
    return f"{namespace}/{topic}"


def _check_joints(drive: DrivePlugin, kinds: dict[str, str]) -> None:
    """Each side names at least one joint, every one a moving joint of the description."""
    for side, joints in (("left", drive.left_joints), ("right", drive.right_joints)):
        if not joints or not all(joints):
            raise DescriptionError(f"{drive.where}: no {side} wheel joint")
        for joint in joints:
            if kinds.get(joint) in (None, "fixed"):
                moving = [n for n, kind in kinds.items() if kind in ("continuous", "revolute")]
                what = "is a fixed joint" if joint in kinds else "is not a joint of the robot"
                raise DescriptionError(
                    f"{drive.where}: {side} wheel joint {joint!r} {what} (its moving joints: "
                    f"{', '.join(moving) or 'none'})"
                )


def parse_drive_plugins(root: ET.Element, source: str | os.PathLike = "") -> list[DrivePlugin]:
    """Every differential drive of the ``<gazebo><plugin>`` blocks of an expanded URDF, in
    document order, checked against its joints."""
    kinds = {joint.get("name", ""): joint.get("type", "") for joint in root.findall("joint")}
    drives = []
    for plugin in root.findall("gazebo/plugin"):
        dialect = _dialect(plugin)
        if dialect is None:
            continue
        name = plugin.get("name", "")
        filename = plugin.get("filename", "")
        reader = _Reader(plugin, f'{source}: <plugin name="{name}" filename="{filename}">')
        if dialect == GZ_SIM:
            drive = _gz_sim(reader, name, filename)
        else:
            drive = _gazebo_ros(reader, name, filename, ros1=dialect == GAZEBO_ROS1)
        _check_joints(drive, kinds)
        drives.append(drive)
    return drives


def link_friction(root: ET.Element) -> dict[str, float]:
    """Per link, the friction coefficient its ``<gazebo reference="LINK">`` block gives
    (``<mu1>``, as ``<mu1>0.1</mu1>`` or ``<mu1 value="0.1"/>``; the smaller of mu1
    and mu2 when both are given)."""
    friction = {}
    for gazebo in root.findall("gazebo"):
        link = (gazebo.get("reference") or "").strip()
        values = []
        for tag in ("mu1", "mu2", "mu"):
            for element in gazebo.iter(tag):
                text = element.get("value", element.text or "").strip()
                try:
                    values.append(float(text))
                except ValueError:
                    continue
        if link and values:
            friction[link] = max(0.0, min(values))
    return friction
