"""ROS message layouts carried on Drake abstract-valued ports.

The field names follow the ROS 2 messages users already know
(``sensor_msgs/JointState``, ``std_msgs/Float64MultiArray``,
``trajectory_msgs/JointTrajectory``, ``cartesian_control_msgs/CartesianTrajectory``),
with times as float seconds of simulation time instead of ``builtin_interfaces/Time``.

A topic is a port whose value is a :class:`Publication`: the number of
messages published on it so far and the latest one. A subscriber (a
controller) remembers the count it has handled and treats a larger count as a
new message, so each message is validated and acted on exactly once, as with
a ROS subscription of queue depth 1.

Messages are immutable, so copying one returns it: Drake deep-copies every
abstract state and port value at each update, and a field-by-field deep copy
of a message would cost more than the controller's own work.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from typing import Any

from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform


@dataclass(frozen=True)
class JointState:
    """sensor_msgs/JointState: one sample of named joints."""

    stamp: float = 0.0  # [s] simulation time of the sample (header.stamp)
    name: tuple[str, ...] = ()
    position: tuple[float, ...] = ()  # [rad] or [m]
    velocity: tuple[float, ...] = ()  # [rad/s] or [m/s]
    effort: tuple[float, ...] = ()  # [N m] or [N]

    def __deepcopy__(self, memo):
        return self  # immutable: see the module docstring


@dataclass(frozen=True)
class Float64MultiArray:
    """std_msgs/Float64MultiArray as the forward-command controllers read it."""

    data: tuple[float, ...] = ()

    def __deepcopy__(self, memo):
        return self  # immutable: see the module docstring


@dataclass(frozen=True)
class Float64:
    """std_msgs/Float64: one value, as ROS 1's single-joint controllers read it."""

    data: float = 0.0

    def __deepcopy__(self, memo):
        return self  # immutable: see the module docstring


@dataclass(frozen=True)
class SpeedScalingFactor:
    """control_msgs/SpeedScalingFactor: the trajectory controller's speed scaling input."""

    factor: float = 1.0  # [-] >= 0; 1.0 = full speed

    def __deepcopy__(self, memo):
        return self  # immutable: see the module docstring


@dataclass(frozen=True)
class MultiDOFCommand:
    """control_msgs/MultiDOFCommand: a reference per degree of freedom, as upstream's PID
    controller reads it."""

    dof_names: tuple[str, ...] = ()
    values: tuple[float, ...] = ()  # the references (a position [rad], a velocity, ...)
    values_dot: tuple[float, ...] = ()  # their rates (the second reference interface)

    def __deepcopy__(self, memo):
        return self  # immutable: see the module docstring


@dataclass(frozen=True)
class JointTrajectoryPoint:
    """trajectory_msgs/JointTrajectoryPoint."""

    positions: tuple[float, ...] = ()
    velocities: tuple[float, ...] = ()
    accelerations: tuple[float, ...] = ()
    effort: tuple[float, ...] = ()
    time_from_start: float = 0.0  # [s] since the trajectory's start

    def __deepcopy__(self, memo):
        return self  # immutable: see the module docstring


@dataclass(frozen=True)
class JointTrajectory:
    """trajectory_msgs/JointTrajectory.

    ``stamp`` is header.stamp: 0 means "start when received"; a non-zero
    stamp is the simulation time at which the trajectory starts.
    """

    stamp: float = 0.0  # [s]
    joint_names: tuple[str, ...] = ()
    points: tuple[JointTrajectoryPoint, ...] = ()

    def __deepcopy__(self, memo):
        return self  # immutable: see the module docstring


@dataclass(frozen=True)
class CartesianTrajectoryPoint:
    """cartesian_control_msgs/CartesianTrajectoryPoint: the pose, twist and acceleration
    of the controlled frame E in the trajectory's frame B (``header.frame_id``)."""

    time_from_start: float = 0.0  # [s] since the trajectory's start
    position: tuple[float, ...] = ()  # [m] p_BE (x, y, z)
    orientation: tuple[float, ...] = ()  # [-] R_BE as a unit quaternion (w, x, y, z)
    twist: tuple[float, ...] = ()  # [rad/s, m/s] (w; v) of E in B, expressed in B (6)
    acceleration: tuple[float, ...] = ()  # [rad/s^2, m/s^2] (alpha; a) of E in B (6)

    def __deepcopy__(self, memo):
        return self  # immutable: see the module docstring


@dataclass(frozen=True)
class CartesianTrajectory:
    """cartesian_control_msgs/CartesianTrajectory: a Cartesian path for one frame.

    ``stamp`` as in :class:`JointTrajectory`; ``frame_id`` is the frame B the
    points are given in ("" or "world": Drake's world frame); ``controlled_frame``
    the frame E that follows them (a frame of the robot's plant).
    """

    stamp: float = 0.0  # [s]
    frame_id: str = ""
    controlled_frame: str = ""
    points: tuple[CartesianTrajectoryPoint, ...] = ()

    def __deepcopy__(self, memo):
        return self  # immutable: see the module docstring


@dataclass(frozen=True)
class Twist:
    """geometry_msgs/Twist: a velocity command (cmd_vel), in the robot's base frame."""

    linear: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [m/s] x forward, y left, z up
    angular: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [rad/s] about x, y, z

    def __deepcopy__(self, memo):
        return self  # immutable: see the module docstring


@dataclass(frozen=True)
class TwistStamped:
    """geometry_msgs/TwistStamped: a Twist with header.stamp (0: "now", as upstream's
    diff_drive_controller takes it) and header.frame_id."""

    stamp: float = 0.0  # [s] simulation time
    frame_id: str = ""
    twist: Twist = field(default_factory=Twist)

    def __deepcopy__(self, memo):
        return self  # immutable: see the module docstring


@dataclass(frozen=True)
class Odometry:
    """nav_msgs/Odometry: the pose of ``child_frame_id`` in ``frame_id`` (odom ->
    base_footprint) and its twist in the child frame, as a drive's odometry publishes it."""

    stamp: float = 0.0  # [s] simulation time
    frame_id: str = "odom"
    child_frame_id: str = "base_link"
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [m]
    orientation: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)  # (w, x, y, z)
    linear: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [m/s] in the child frame
    angular: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [rad/s]
    pose_covariance: tuple[float, ...] = (0.0,) * 6  # the diagonal (x, y, z, roll, pitch, yaw)
    twist_covariance: tuple[float, ...] = (0.0,) * 6  # the diagonal

    @property
    def yaw(self) -> float:
        """[rad] the heading (rotation about z) of the orientation."""
        w, x, y, z = self.orientation
        return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))

    def __deepcopy__(self, memo):
        return self  # immutable: see the module docstring


@dataclass(frozen=True)
class Publication:
    """The value of a topic port: how many messages so far, and the latest.

    ``count == 0`` means nothing has been published yet (``message`` is None).
    """

    count: int = 0
    message: Any = None
    stamp: float = 0.0  # [s] simulation time at which ``message`` was published

    def __deepcopy__(self, memo):
        message = copy.deepcopy(self.message, memo)  # the message itself if it is ours
        return self if message is self.message else Publication(self.count, message, self.stamp)

    def publish(self, message: Any, stamp: float = 0.0) -> Publication:
        """The publication that follows this one with ``message`` as the latest."""
        return Publication(count=self.count + 1, message=message, stamp=stamp)


def PublicationValue(publication: Publication | None = None) -> AbstractValue:
    """A model value for declaring a topic port."""
    return AbstractValue.Make(Publication() if publication is None else publication)


@dataclass
class ControllerStatus:
    """What a controller reports about the commands it received."""

    state: str = "idle"  # idle | holding | executing | succeeded | aborted | active
    accepted: int = 0  # messages accepted so far
    rejected: int = 0  # messages rejected so far
    last_error: str = ""  # reason of the latest rejection or abort, "" if none
    detail: dict[str, Any] = field(default_factory=dict)

    def __deepcopy__(self, memo):
        detail = copy.deepcopy(self.detail, memo) if self.detail else {}
        return ControllerStatus(self.state, self.accepted, self.rejected, self.last_error, detail)


@dataclass(frozen=True)
class MarkerPose:
    """geometry_msgs/PoseStamped of a detected marker, plus the camera's mount.

    ``pose`` is the marker frame M (OpenCV's: z out of the face) in ``frame_id``
    (the camera's optical frame C: z forward, x right, y down; or ``world``).
    """

    stamp: float = 0.0  # [s] time of the frame
    frame_id: str = ""  # the camera's name, or "world"
    marker_id: int = -1  # the marker's id in its dictionary
    pose: RigidTransform = field(default_factory=RigidTransform)  # X_FM
    link: str = ""  # the link the camera is mounted on
    X_LC: RigidTransform = field(default_factory=RigidTransform)  # camera in that link

    def __deepcopy__(self, memo):
        return self
