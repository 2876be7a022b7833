"""The ROS 2 messages the project speaks, in one place.

Their definitions come from the ``rosbags`` type store of ROS 2 Humble
(:func:`typestore`; these messages have not changed since, but for a constant
Jazzy added to ``visualization_msgs/Marker``): the ``ros2msg`` schemas of MCAP and
Foxglove (:func:`message_definition`), the field lists (:func:`fields`) and from
them the DDS types of Cyclone DDS (:mod:`armando_drake.ros2.idl`). The few types
the store lacks (:data:`EXTRA_DEFINITIONS`: ros2_control's ``control_msgs`` of
Jazzy, Universal Robots' ``cartesian_control_msgs``) are written here once as
``.msg`` text and registered into that store.

Messages cross this module as plain dictionaries, field by field as in the
``.msg`` files (nested messages are dictionaries, arrays are lists, ``uint8[]``
is ``bytes``); the functions below turn the project's message dataclasses
(:mod:`armando_drake.messages.types`) into them and back. This module
imports neither Cyclone DDS nor Foxglove.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from typing import Any

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from armando_drake.messages.scans import LaserScan
from armando_drake.messages.types import (
    CartesianTrajectory,
    Float64MultiArray,
    JointState,
    JointTrajectory,
    JointTrajectoryPoint,
    MultiDOFCommand,
    Odometry,
    SpeedScalingFactor,
    Twist,
    TwistStamped,
)

# The ROS 2 distribution whose message definitions the project writes and reads.
STORE = Stores.ROS2_HUMBLE

# The message types the store lacks, as .msg text without comments (pkg/msg/Type).
EXTRA_DEFINITIONS = {
    # ros2_control's control_msgs of Jazzy (the speed scaling and the PID references).
    "control_msgs/msg/SpeedScalingFactor": "float64 factor\n",
    "control_msgs/msg/MultiDOFCommand": (
        "string[] dof_names\nfloat64[] values\nfloat64[] values_dot\n"
    ),
    # Universal Robots' cartesian_control_msgs (not in ROS 2's core messages).
    "cartesian_control_msgs/msg/CartesianPosture": (
        "string[] posture_joint_names\nfloat64[] posture_joint_values\n"
    ),
    "cartesian_control_msgs/msg/CartesianTrajectoryPoint": (
        "builtin_interfaces/Duration time_from_start\ngeometry_msgs/Pose pose\n"
        "geometry_msgs/Twist twist\ngeometry_msgs/Accel acceleration\n"
        "geometry_msgs/Accel jerk\ncartesian_control_msgs/CartesianPosture posture\n"
    ),
    "cartesian_control_msgs/msg/CartesianTrajectory": (
        "std_msgs/Header header\ncartesian_control_msgs/CartesianTrajectoryPoint[] points\n"
        "string controlled_frame\n"
    ),
}


# The message types the project writes or reads, with the ones they contain.
MESSAGE_TYPES = (
    "builtin_interfaces/msg/Time",
    "builtin_interfaces/msg/Duration",
    "std_msgs/msg/Header",
    "std_msgs/msg/String",
    "std_msgs/msg/MultiArrayDimension",
    "std_msgs/msg/MultiArrayLayout",
    "std_msgs/msg/Float64MultiArray",
    "rosgraph_msgs/msg/Clock",
    "control_msgs/msg/SpeedScalingFactor",
    "control_msgs/msg/MultiDOFCommand",
    "sensor_msgs/msg/JointState",
    "trajectory_msgs/msg/JointTrajectoryPoint",
    "trajectory_msgs/msg/JointTrajectory",
    "geometry_msgs/msg/Vector3",
    "geometry_msgs/msg/Twist",
    "geometry_msgs/msg/Accel",
    "cartesian_control_msgs/msg/CartesianPosture",
    "cartesian_control_msgs/msg/CartesianTrajectoryPoint",
    "cartesian_control_msgs/msg/CartesianTrajectory",
    "geometry_msgs/msg/Quaternion",
    "geometry_msgs/msg/Transform",
    "geometry_msgs/msg/TransformStamped",
    "tf2_msgs/msg/TFMessage",
    "sensor_msgs/msg/Image",
    "sensor_msgs/msg/RegionOfInterest",
    "sensor_msgs/msg/CameraInfo",
    "sensor_msgs/msg/PointField",
    "sensor_msgs/msg/PointCloud2",
    "geometry_msgs/msg/Point",
    "geometry_msgs/msg/Pose",
    "std_msgs/msg/ColorRGBA",
    "sensor_msgs/msg/CompressedImage",
    "visualization_msgs/msg/UVCoordinate",
    "visualization_msgs/msg/MeshFile",
    "visualization_msgs/msg/Marker",
    "visualization_msgs/msg/MarkerArray",
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/TwistStamped",
    "geometry_msgs/msg/PoseWithCovariance",
    "geometry_msgs/msg/TwistWithCovariance",
    "nav_msgs/msg/Odometry",
    "nav_msgs/msg/Path",
    "nav_msgs/msg/MapMetaData",
    "nav_msgs/msg/OccupancyGrid",
    "sensor_msgs/msg/LaserScan",
)


@functools.cache
def typestore():
    """The ``rosbags`` type store of :data:`STORE`, with :data:`EXTRA_DEFINITIONS`
    registered (made once)."""
    store = get_typestore(STORE)
    for type_name, text in EXTRA_DEFINITIONS.items():
        store.register(get_types_from_msg(text, type_name))
    return store


def full_name(type_name: str) -> str:
    """``pkg/msg/Type`` of ``pkg/Type`` (or of ``pkg/msg/Type``)."""
    package, _, name = type_name.partition("/")
    return type_name if name.startswith("msg/") else f"{package}/msg/{name}"


def short_name(type_name: str) -> str:
    """``pkg/Type`` of ``pkg/msg/Type`` (or of ``pkg/Type``)."""
    package, _, name = type_name.partition("/msg/")
    return f"{package}/{name}" if name else type_name


@functools.cache
def message_definition(type_name: str) -> str:
    """The ``ros2msg`` schema text of ``pkg/msg/Type``: the type, then each dependency once.

    Dependencies follow in depth-first order of first use, each after a line
    of 80 ``=`` and ``MSG: pkg/Type``, as ``ros2 bag record`` writes them.
    """
    name = full_name(type_name)
    store = typestore()
    if name not in store.fielddefs:
        raise KeyError(f"{type_name!r} is not a ROS 2 message of the {STORE.value} type store")
    return store.generate_msgdef(name, ros_version=2)[0]


@functools.cache
def fields(type_name: str) -> tuple[tuple[str, str], ...]:
    """The (type, name) pairs of a message, in order; type as in the ``.msg`` file."""
    own = message_definition(type_name).split("=" * 80 + "\n")[0]
    return tuple(
        tuple(line.split()[:2])
        for line in own.splitlines()
        if line and "=" not in line  # a constant (uint8 INT8=1) is no field
    )


def dds_type_name(type_name: str) -> str:
    """The DDS type name ROS 2 gives ``pkg/msg/Type``: ``pkg::msg::dds_::Type_``."""
    package, _, name = short_name(type_name).partition("/")
    return f"{package}::msg::dds_::{name}_"


def resolve_topic(topic: str, namespace: str = "") -> str:
    """The full ROS 2 name of a topic: absolute names (``/tf``) as they are, relative ones
    (``joint_states``) in ``namespace``."""
    if not topic.startswith("/"):
        topic = "/".join(part for part in (namespace.strip("/"), topic) if part)
    return "/" + topic.strip("/")


def ros_time(seconds: float) -> dict[str, int]:
    """builtin_interfaces/Time (or Duration) of a time in seconds."""
    sec, nanosec = divmod(round(seconds * 1e9), 1_000_000_000)
    return {"sec": int(sec), "nanosec": int(nanosec)}


def seconds(time: Any) -> float:
    """Seconds of a builtin_interfaces/Time or Duration (a dictionary or a message)."""
    if isinstance(time, Mapping):
        return time["sec"] + time["nanosec"] * 1e-9
    return time.sec + time.nanosec * 1e-9


def header(stamp: float, frame_id: str = "") -> dict[str, Any]:
    """std_msgs/Header at ``stamp`` [s]."""
    return {"stamp": ros_time(stamp), "frame_id": frame_id}


def joint_state_message(message: JointState) -> dict[str, Any]:
    """sensor_msgs/JointState of ours."""
    return {
        "header": header(message.stamp),
        "name": list(message.name),
        "position": list(message.position),
        "velocity": list(message.velocity),
        "effort": list(message.effort),
    }


def float64_multi_array_message(message: Float64MultiArray) -> dict[str, Any]:
    """std_msgs/Float64MultiArray of ours (no layout, as ``ros2 topic pub`` sends it)."""
    return {"layout": {"dim": [], "data_offset": 0}, "data": [float(v) for v in message.data]}


def joint_trajectory_message(message: JointTrajectory) -> dict[str, Any]:
    """trajectory_msgs/JointTrajectory of ours."""
    return {
        "header": header(message.stamp),
        "joint_names": list(message.joint_names),
        "points": [
            {
                "positions": list(point.positions),
                "velocities": list(point.velocities),
                "accelerations": list(point.accelerations),
                "effort": list(point.effort),
                "time_from_start": ros_time(point.time_from_start),
            }
            for point in message.points
        ],
    }


def _vector3(values: Sequence[float]) -> dict[str, float]:
    x, y, z = (float(v) for v in values)
    return {"x": x, "y": y, "z": z}


def _spatial(values: Sequence[float]) -> dict[str, Any]:
    """geometry_msgs/Twist or Accel of a Drake spatial vector (rotation first)."""
    values = tuple(values) if len(values) == 6 else (0.0,) * 6
    return {"linear": _vector3(values[3:]), "angular": _vector3(values[:3])}


def cartesian_trajectory_message(message: CartesianTrajectory) -> dict[str, Any]:
    """cartesian_control_msgs/CartesianTrajectory of ours (jerk zero: not planned; no
    posture)."""
    return {
        "header": header(message.stamp, message.frame_id),
        "controlled_frame": message.controlled_frame,
        "points": [
            {
                "time_from_start": ros_time(point.time_from_start),
                "pose": {
                    "position": _vector3(point.position),
                    "orientation": dict(
                        zip("wxyz", (float(v) for v in point.orientation), strict=True)
                    ),
                },
                "twist": _spatial(point.twist),
                "acceleration": _spatial(point.acceleration),
                "jerk": _spatial(()),
                "posture": {"posture_joint_names": [], "posture_joint_values": []},
            }
            for point in message.points
        ],
    }


def _get(message: Any, name: str) -> Any:
    return message[name] if isinstance(message, Mapping) else getattr(message, name)


def _floats(values: Sequence[float]) -> tuple[float, ...]:
    return tuple(float(v) for v in values)


def float64_multi_array_of(message: Any) -> Float64MultiArray:
    """Ours of a received std_msgs/Float64MultiArray (dictionary or DDS message)."""
    return Float64MultiArray(data=_floats(_get(message, "data")))


def speed_scaling_factor_of(message: Any) -> SpeedScalingFactor:
    """Ours of a received control_msgs/SpeedScalingFactor (dictionary or DDS message)."""
    return SpeedScalingFactor(factor=float(_get(message, "factor")))


def multi_dof_command_of(message: Any) -> MultiDOFCommand:
    """Ours of a received control_msgs/MultiDOFCommand (dictionary or DDS message)."""
    return MultiDOFCommand(
        dof_names=tuple(str(name) for name in _get(message, "dof_names")),
        values=_floats(_get(message, "values")),
        values_dot=_floats(_get(message, "values_dot")),
    )


def joint_trajectory_of(message: Any) -> JointTrajectory:
    """Ours of a received trajectory_msgs/JointTrajectory (dictionary or DDS message).

    A zero header stamp stays 0 ("start when received"), as the controller reads it.
    """
    return JointTrajectory(
        stamp=seconds(_get(_get(message, "header"), "stamp")),
        joint_names=tuple(str(name) for name in _get(message, "joint_names")),
        points=tuple(
            JointTrajectoryPoint(
                positions=_floats(_get(point, "positions")),
                velocities=_floats(_get(point, "velocities")),
                accelerations=_floats(_get(point, "accelerations")),
                effort=_floats(_get(point, "effort")),
                time_from_start=seconds(_get(point, "time_from_start")),
            )
            for point in _get(message, "points")
        ),
    )


def clock_message(stamp: float) -> dict[str, Any]:
    """rosgraph_msgs/Clock at ``stamp`` [s]."""
    return {"clock": ros_time(stamp)}


def string_message(text: str) -> dict[str, Any]:
    """std_msgs/String."""
    return {"data": text}


def transform_stamped(stamp: float, parent: str, child: str, X_PC) -> dict[str, Any]:
    """geometry_msgs/TransformStamped: the pose ``X_PC`` (a Drake RigidTransform) of
    frame ``child`` in frame ``parent``."""
    p = X_PC.translation()
    q = X_PC.rotation().ToQuaternion()
    return {
        "header": header(stamp, parent),
        "child_frame_id": child,
        "transform": {
            "translation": {"x": float(p[0]), "y": float(p[1]), "z": float(p[2])},
            "rotation": {"x": q.x(), "y": q.y(), "z": q.z(), "w": q.w()},
        },
    }


def pose_stamped_message(stamp: float, frame_id: str, X_FM) -> dict[str, Any]:
    """geometry_msgs/PoseStamped: the pose ``X_FM`` (a Drake RigidTransform) in ``frame_id``."""
    p = X_FM.translation()
    q = X_FM.rotation().ToQuaternion()
    return {
        "header": header(stamp, frame_id),
        "pose": {
            "position": {"x": float(p[0]), "y": float(p[1]), "z": float(p[2])},
            "orientation": {"x": q.x(), "y": q.y(), "z": q.z(), "w": q.w()},
        },
    }


def image_message(stamp: float, frame_id: str, rgb) -> dict[str, Any]:
    """sensor_msgs/Image (``rgb8``) of an height x width x 3 uint8 array."""
    height, width = rgb.shape[:2]
    return {
        "header": header(stamp, frame_id),
        "height": int(height),
        "width": int(width),
        "encoding": "rgb8",
        "is_bigendian": 0,
        "step": 3 * int(width),
        "data": rgb.tobytes(),
    }


def _covariance(diagonal: Sequence[float]) -> list[float]:
    """The 6 x 6 covariance (row-major) of its diagonal."""
    matrix = [0.0] * 36
    for k, value in enumerate(tuple(diagonal)[:6]):
        matrix[7 * k] = float(value)
    return matrix


def odometry_message(message: Odometry) -> dict[str, Any]:
    """nav_msgs/Odometry of ours."""
    w, x, y, z = (float(v) for v in message.orientation)
    return {
        "header": header(message.stamp, message.frame_id),
        "child_frame_id": message.child_frame_id,
        "pose": {
            "pose": {
                "position": _vector3(message.position),
                "orientation": {"x": x, "y": y, "z": z, "w": w},
            },
            "covariance": _covariance(message.pose_covariance),
        },
        "twist": {
            "twist": {"linear": _vector3(message.linear), "angular": _vector3(message.angular)},
            "covariance": _covariance(message.twist_covariance),
        },
    }


def odometry_transform(message: Odometry) -> dict[str, Any]:
    """geometry_msgs/TransformStamped ``frame_id -> child_frame_id`` of an odometry, as a
    drive's odometry broadcasts it on /tf."""
    w, x, y, z = (float(v) for v in message.orientation)
    return {
        "header": header(message.stamp, message.frame_id),
        "child_frame_id": message.child_frame_id,
        "transform": {
            "translation": _vector3(message.position),
            "rotation": {"x": x, "y": y, "z": z, "w": w},
        },
    }


def laser_scan_message(message: LaserScan) -> dict[str, Any]:
    """sensor_msgs/LaserScan of ours (ranges as float32; inf and -inf kept)."""
    return {
        "header": header(message.stamp, message.frame_id),
        "angle_min": float(message.angle_min),
        "angle_max": float(message.angle_max),
        "angle_increment": float(message.angle_increment),
        "time_increment": float(message.time_increment),
        "scan_time": float(message.scan_time),
        "range_min": float(message.range_min),
        "range_max": float(message.range_max),
        "ranges": [float(r) for r in message.ranges],
        "intensities": [float(i) for i in message.intensities],
    }


def twist_message(message: TwistStamped | Twist) -> dict[str, Any]:
    """geometry_msgs/Twist of ours (the twist of a TwistStamped)."""
    twist = message.twist if isinstance(message, TwistStamped) else message
    return {"linear": _vector3(twist.linear), "angular": _vector3(twist.angular)}


def twist_stamped_of(message: Any, stamp: float = 0.0) -> TwistStamped:
    """Ours of a received geometry_msgs/Twist or TwistStamped (dictionary or DDS message);
    a Twist gets ``stamp`` (0: "now", as the drives take it)."""
    inner = _get(message, "twist") if _has(message, "twist") else message
    frame_id, time = "", stamp
    if _has(message, "header"):
        head = _get(message, "header")
        frame_id, time = str(_get(head, "frame_id")), seconds(_get(head, "stamp"))

    def vector(name: str) -> tuple[float, float, float]:
        v = _get(inner, name)
        return (float(_get(v, "x")), float(_get(v, "y")), float(_get(v, "z")))

    return TwistStamped(
        stamp=time,
        frame_id=frame_id,
        twist=Twist(linear=vector("linear"), angular=vector("angular")),
    )


def _has(message: Any, name: str) -> bool:
    return name in message if isinstance(message, Mapping) else hasattr(message, name)
