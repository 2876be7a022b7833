"""A robot's odometry and TF buffer: its base's poses sampled at the odometry's rate,
from which every consumer takes the pose at a message's stamp, as Nav2's nodes look a
transform up in TF at the stamp of the scan or goal they handle.

:class:`PoseTrack` is one transform's history (planar poses at increasing stamps),
interpolated between two samples as tf2 does: the position linearly, the heading along
the shorter arc of the circle; a stamp outside the history takes its nearest end (tf2's
"latest" for a stamp of 0). :class:`RobotPoses` holds a robot's two tracks: the ground
truth (the plant's base, for a navigation without localization) and the drive's
odometry (``odom -> base_link``; AMCL's and SLAM's map -> odom composed on it). The
odometry is the drive's message as it is: the integration of the wheel axle's midpoint,
published as the base frame's pose, as ROS's diff_drive_controller and Gazebo's DiffDrive
publish it (see :func:`body_odometry`).

:class:`PoseBuffer` is the Drake system that keeps them, one per robot: sampled at the
drive's odometry rate (its ``publish_rate``, 50 Hz by default), :data:`BUFFER_SECONDS`
kept; its output adds the current sample, so a message stamped now is placed exactly.
"""

from __future__ import annotations

import bisect
import dataclasses as dc
import math

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem

from armando_drake.control.manager import planar_base
from armando_drake.messages.types import Odometry

# [s] of poses kept: a scan or a goal's stamp may be this old (tf2 keeps 10 s).
BUFFER_SECONDS = 2.0


def _wrap(angle: float) -> float:
    """``angle`` in (-pi, pi]."""
    return math.atan2(math.sin(angle), math.cos(angle))


def compose(a, b) -> tuple[float, float, float]:
    """The planar pose ``a`` then ``b`` (b expressed in a's frame)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], _wrap(a[2] + b[2])


def inverse(a) -> tuple[float, float, float]:
    """The planar pose whose composition with ``a`` is the identity."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return -c * a[0] - s * a[1], s * a[0] - c * a[1], _wrap(-a[2])


def body_odometry(message) -> tuple[float, float, float]:
    """The odometry's pose of the base frame (``odom -> base_link``): the drive's
    integration of its wheel axle's midpoint, published as the base frame's pose, as
    ros2_controllers' diff_drive_controller and Gazebo's DiffDrive do (they know no offset
    between the axle and the base frame: turning in place is a pure rotation in odom)."""
    if message is None:
        return 0.0, 0.0, 0.0
    return float(message.position[0]), float(message.position[1]), float(message.yaw)


@dc.dataclass(frozen=True)
class PoseTrack:
    """Planar poses (x, y, yaw) at increasing stamps [s]: one transform's history."""

    stamps: tuple = ()
    poses: tuple = ()

    def add(self, stamp: float, pose, keep: float = BUFFER_SECONDS) -> PoseTrack:
        """This track with ``pose`` at ``stamp`` (replacing a sample at the same stamp,
        ignored if older than the latest), the samples older than ``keep`` [s] dropped."""
        stamp = float(stamp)
        pose = tuple(float(v) for v in pose)
        stamps, poses = list(self.stamps), list(self.poses)
        if stamps and stamp < stamps[-1]:
            return self
        if stamps and stamp == stamps[-1]:
            stamps.pop()
            poses.pop()
        stamps.append(stamp)
        poses.append(pose)
        first = bisect.bisect_left(stamps, stamp - keep)
        first = max(0, first - 1)  # one sample at or before the window's start
        return PoseTrack(tuple(stamps[first:]), tuple(poses[first:]))

    @property
    def latest(self) -> tuple:
        """The newest pose ((0, 0, 0) when empty)."""
        return self.poses[-1] if self.poses else (0.0, 0.0, 0.0)

    def at(self, stamp: float) -> tuple[float, float, float]:
        """The pose at ``stamp``: interpolated between the samples around it (position
        linearly, yaw on the circle); the nearest end outside them."""
        if not self.stamps:
            return (0.0, 0.0, 0.0)
        k = bisect.bisect_right(self.stamps, stamp)
        if k == 0:
            return self.poses[0]
        if k == len(self.stamps):
            return self.poses[-1]
        t0, t1 = self.stamps[k - 1], self.stamps[k]
        a, b = self.poses[k - 1], self.poses[k]
        s = (stamp - t0) / (t1 - t0)
        return (
            a[0] + s * (b[0] - a[0]),
            a[1] + s * (b[1] - a[1]),
            _wrap(a[2] + s * _wrap(b[2] - a[2])),
        )


@dc.dataclass(frozen=True)
class RobotPoses:
    """A robot's pose tracks: ``truth`` (the plant's base in the world) and ``odom`` (the
    drive's odometry of the base frame)."""

    truth: PoseTrack = PoseTrack()
    odom: PoseTrack = PoseTrack()

    def __deepcopy__(self, memo):
        return self

    def map_pose(self, stamp: float, map_to_odom=None) -> tuple[float, float, float]:
        """The base's pose in the map at ``stamp``: the ground truth's without a
        localization (``map_to_odom`` None), else map -> odom then the odometry's."""
        if map_to_odom is None:
            return self.truth.at(stamp)
        return compose(tuple(map_to_odom), self.odom.at(stamp))


class PoseBuffer(LeafSystem):
    """A robot's :class:`RobotPoses`, sampled at the odometry's rate.

    .. pydrake_system::

        name: PoseBuffer
        input_ports:
        - state
        - odom
        output_ports:
        - poses

    - ``state``: the robot model instance's state (its floating base's pose and twist);
    - ``odom``: the drive's latest Odometry (the wheel axle's midpoint integrated, as
      the base frame's pose: :func:`body_odometry`);
    - ``poses``: the :class:`RobotPoses` kept, with the current sample added.
    """

    def __init__(self, *, state_size: int, base_rows, rate: float):
        super().__init__()
        self._q_rows, self._v_rows = base_rows
        self._state = self.DeclareVectorInputPort("state", state_size)
        self._odom = self.DeclareAbstractInputPort("odom", AbstractValue.Make(Odometry()))
        self._poses = self.DeclareAbstractState(AbstractValue.Make(RobotPoses()))
        self.DeclareAbstractOutputPort(
            "poses", lambda: AbstractValue.Make(RobotPoses()), self._Output
        )
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / rate, 0.0, self._Update)

    def _sampled(self, context, poses: RobotPoses) -> RobotPoses:
        now = context.get_time()
        x = self._state.Eval(context)
        truth = poses.truth.add(now, planar_base(x[self._q_rows], x[self._v_rows])[:3])
        message = self._odom.Eval(context)
        odom = poses.odom.add(message.stamp, body_odometry(message))
        return RobotPoses(truth, odom)

    def _Update(self, context, state) -> None:
        poses = context.get_abstract_state(self._poses).get_value()
        state.get_mutable_abstract_state(self._poses).set_value(self._sampled(context, poses))

    def _Output(self, context, output) -> None:
        poses = context.get_abstract_state(self._poses).get_value()
        output.set_value(self._sampled(context, poses))
