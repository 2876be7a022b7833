"""The ROS 2 messages the project speaks, in one place.

``DEFINITIONS`` holds the ``.msg`` text of every ROS 2 message type that the
MCAP recorder (:mod:`armando_drake.outputs.recording`), the DDS bridge and the
Foxglove server (:mod:`armando_drake.ros2.bridge`) write or read, copied from
the ROS 2 Jazzy ``.msg`` files without comments and constants (these types
have not changed since Humble). Everything else is derived from it: the
``ros2msg`` schemas of MCAP and Foxglove (:func:`message_definition`) and the
DDS types of Cyclone DDS (:mod:`armando_drake.ros2.idl`).

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

# The ROS 2 message definitions, without comments or constants, by type name (pkg/Type).
DEFINITIONS = {
    "builtin_interfaces/Time": "int32 sec\nuint32 nanosec\n",
    "builtin_interfaces/Duration": "int32 sec\nuint32 nanosec\n",
    "std_msgs/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "std_msgs/String": "string data\n",
    "std_msgs/MultiArrayDimension": "string label\nuint32 size\nuint32 stride\n",
    "std_msgs/MultiArrayLayout": "std_msgs/MultiArrayDimension[] dim\nuint32 data_offset\n",
    "std_msgs/Float64MultiArray": "std_msgs/MultiArrayLayout layout\nfloat64[] data\n",
    "rosgraph_msgs/Clock": "builtin_interfaces/Time clock\n",
    "control_msgs/SpeedScalingFactor": "float64 factor\n",
    "control_msgs/MultiDOFCommand": "string[] dof_names\nfloat64[] values\nfloat64[] values_dot\n",
    "sensor_msgs/JointState": (
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
        "float64[] effort\n"
    ),
    "trajectory_msgs/JointTrajectoryPoint": (
        "float64[] positions\nfloat64[] velocities\nfloat64[] accelerations\n"
        "float64[] effort\nbuiltin_interfaces/Duration time_from_start\n"
    ),
    "trajectory_msgs/JointTrajectory": (
        "std_msgs/Header header\nstring[] joint_names\n"
        "trajectory_msgs/JointTrajectoryPoint[] points\n"
    ),
    "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/Twist": "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n",
    "geometry_msgs/Accel": "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n",
    # Universal Robots' cartesian_control_msgs (not in ROS 2's core messages).
    "cartesian_control_msgs/CartesianPosture": (
        "string[] posture_joint_names\nfloat64[] posture_joint_values\n"
    ),
    "cartesian_control_msgs/CartesianTrajectoryPoint": (
        "builtin_interfaces/Duration time_from_start\ngeometry_msgs/Pose pose\n"
        "geometry_msgs/Twist twist\ngeometry_msgs/Accel acceleration\n"
        "geometry_msgs/Accel jerk\ncartesian_control_msgs/CartesianPosture posture\n"
    ),
    "cartesian_control_msgs/CartesianTrajectory": (
        "std_msgs/Header header\ncartesian_control_msgs/CartesianTrajectoryPoint[] points\n"
        "string controlled_frame\n"
    ),
    "geometry_msgs/Quaternion": "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
    "geometry_msgs/Transform": (
        "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n"
    ),
    "geometry_msgs/TransformStamped": (
        "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n"
    ),
    "tf2_msgs/TFMessage": "geometry_msgs/TransformStamped[] transforms\n",
    "sensor_msgs/Image": (
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n"
        "uint8 is_bigendian\nuint32 step\nuint8[] data\n"
    ),
    "sensor_msgs/RegionOfInterest": (
        "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n"
    ),
    "sensor_msgs/CameraInfo": (
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\n"
        "float64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\n"
        "uint32 binning_y\nsensor_msgs/RegionOfInterest roi\n"
    ),
    # Point clouds and cluster markers (perception), with constants, as `ros2 bag record`
    # writes them.
    "sensor_msgs/PointField": (
        "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\n"
        "uint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\n"
        "uint8 datatype\nuint32 count\n"
    ),
    "sensor_msgs/PointCloud2": (
        "std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\n"
        "bool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n"
    ),
    "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/Pose": "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n",
    "std_msgs/ColorRGBA": "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n",
    "sensor_msgs/CompressedImage": "std_msgs/Header header\nstring format\nuint8[] data\n",
    "visualization_msgs/UVCoordinate": "float32 u\nfloat32 v\n",
    "visualization_msgs/MeshFile": "string filename\nuint8[] data\n",
    "visualization_msgs/Marker": (
        "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\nint32 LINE_STRIP=4\n"
        "int32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\n"
        "int32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\nint32 TRIANGLE_LIST=11\nint32 ADD=0\n"
        "int32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\nstd_msgs/Header header\nstring ns\n"
        "int32 id\nint32 type\nint32 action\ngeometry_msgs/Pose pose\n"
        "geometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\n"
        "builtin_interfaces/Duration lifetime\nbool frame_locked\ngeometry_msgs/Point[] points\n"
        "std_msgs/ColorRGBA[] colors\nstring texture_resource\n"
        "sensor_msgs/CompressedImage texture\nvisualization_msgs/UVCoordinate[] uv_coordinates\n"
        "string text\nstring mesh_resource\nvisualization_msgs/MeshFile mesh_file\n"
        "bool mesh_use_embedded_materials\n"
    ),
    "visualization_msgs/MarkerArray": "visualization_msgs/Marker[] markers\n",
    # The ArUco detector's marker pose, /aruco_single/pose as aruco_ros.
    "geometry_msgs/PoseStamped": "std_msgs/Header header\ngeometry_msgs/Pose pose\n",
    "geometry_msgs/TwistStamped": "std_msgs/Header header\ngeometry_msgs/Twist twist\n",
    "geometry_msgs/PoseWithCovariance": "geometry_msgs/Pose pose\nfloat64[36] covariance\n",
    "geometry_msgs/TwistWithCovariance": "geometry_msgs/Twist twist\nfloat64[36] covariance\n",
    "nav_msgs/Odometry": (
        "std_msgs/Header header\nstring child_frame_id\n"
        "geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n"
    ),
    # The navigation's plan and map (nav2's planner server, map_server).
    "nav_msgs/Path": "std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses\n",
    "nav_msgs/MapMetaData": (
        "builtin_interfaces/Time map_load_time\nfloat32 resolution\nuint32 width\n"
        "uint32 height\ngeometry_msgs/Pose origin\n"
    ),
    "nav_msgs/OccupancyGrid": ("std_msgs/Header header\nnav_msgs/MapMetaData info\nint8[] data\n"),
    "sensor_msgs/LaserScan": (
        "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\n"
        "float32 angle_increment\nfloat32 time_increment\nfloat32 scan_time\n"
        "float32 range_min\nfloat32 range_max\nfloat32[] ranges\nfloat32[] intensities\n"
    ),
}
_SEPARATOR = "=" * 80 + "\n"


def short_name(type_name: str) -> str:
    """``pkg/Type`` of ``pkg/msg/Type`` (or of ``pkg/Type``)."""
    package, _, name = type_name.partition("/msg/")
    return f"{package}/{name}" if name else type_name


@functools.cache
def fields(type_name: str) -> tuple[tuple[str, str], ...]:
    """The (type, name) pairs of a message, in order; type as in the ``.msg`` file."""
    root = short_name(type_name)
    if root not in DEFINITIONS:
        raise KeyError(f"{type_name!r} is not one of the ROS 2 messages of {__name__}")
    return tuple(
        tuple(line.split()[:2])
        for line in DEFINITIONS[root].splitlines()
        if "=" not in line  # a constant (uint8 INT8=1) is no field
    )


def message_definition(type_name: str) -> str:
    """The ``ros2msg`` schema text of ``pkg/msg/Type``: the type, then each dependency once.

    Dependencies follow in depth-first order of first use, each after a line
    of 80 ``=`` and ``MSG: pkg/Type``, as ``ros2 bag record`` writes them.
    """
    root = short_name(type_name)
    order: list[str] = []

    def visit(current: str) -> None:
        for field_type, _ in fields(current):
            field_type = field_type.split("[")[0]
            if "/" in field_type and field_type not in order and field_type != root:
                order.append(field_type)
                visit(field_type)

    visit(root)
    return DEFINITIONS[root] + "".join(
        f"{_SEPARATOR}MSG: {dependency}\n{DEFINITIONS[dependency]}" for dependency in order
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
