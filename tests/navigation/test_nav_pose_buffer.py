"""The odometry/TF pose buffer: a scan's pose at its stamp, as Nav2 looks it up in TF.

A base turning at 1.8 rad/s while driving 0.2 m/s (an exact arc: the true pose is known at
any time), its drive's odometry published at 50 Hz, a 10 Hz lidar and a 5 Hz consumer (the
controller's rate): the pose the consumer takes for each scan, from the buffer at the
scan's stamp, is the true pose at that stamp within 1 mm and 1 mrad, whether the stamp
falls on an odometry sample or between two; the localized pose (map -> odom then the
odometry) is the odometry's at that stamp, the odometry being the drive's message as ROS's
diff_drive_controller publishes it: the wheel axle's midpoint integrated, as the base
frame's pose.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import BasicVector, DiagramBuilder, LeafSystem

from armando_drake.messages.types import Odometry
from armando_drake.navigation.pose_buffer import (
    BUFFER_SECONDS,
    PoseBuffer,
    PoseTrack,
    RobotPoses,
    compose,
    inverse,
)

V, W = 0.2, 1.8  # [m/s], [rad/s]
AXLE = 0.1  # [m] the wheel axle's midpoint ahead of the base frame
ODOM_RATE, LIDAR_RATE, CONTROLLER_RATE = 50.0, 10.0, 5.0
LIDAR_PHASE = 0.013  # [s] scans between odometry samples


def true_pose(t: float) -> tuple[float, float, float]:
    """The base frame's pose on the arc at ``t`` (from the origin, heading x)."""
    r = V / W
    return (r * math.sin(W * t), r * (1.0 - math.cos(W * t)), math.remainder(W * t, 2 * math.pi))


def odometry_pose(t: float) -> tuple[float, float, float]:
    """The drive's odometry at ``t``: the axle's midpoint from where it started."""
    start = (AXLE, 0.0, 0.0)
    return compose(inverse(start), compose(true_pose(t), (AXLE, 0.0, 0.0)))


class ArcPlant(LeafSystem):
    """The floating base's state (qw qx qy qz x y z, wx wy wz vx vy vz) on the arc, and the
    drive's Odometry of the axle's midpoint published at ODOM_RATE."""

    def __init__(self):
        super().__init__()
        self.DeclareVectorOutputPort("state", 13, self._state)
        self._odom = self.DeclareAbstractState(AbstractValue.Make(self._message(0.0)))
        self.DeclareStateOutputPort("odom", self._odom)
        self.DeclarePeriodicUnrestrictedUpdateEvent(1.0 / ODOM_RATE, 0.0, self._publish)

    @staticmethod
    def _message(t: float) -> Odometry:
        axle = odometry_pose(t)
        half = axle[2] / 2
        return Odometry(stamp=t, position=(axle[0], axle[1], 0.0),
                        orientation=(math.cos(half), 0.0, 0.0, math.sin(half)))  # fmt: skip

    def _publish(self, context, state):
        state.get_mutable_abstract_state(self._odom).set_value(self._message(context.get_time()))

    def _state(self, context, output: BasicVector):
        x, y, yaw = true_pose(context.get_time())
        c, s = math.cos(yaw), math.sin(yaw)
        output.SetFromVector(
            [math.cos(yaw / 2), 0, 0, math.sin(yaw / 2), x, y, 0, 0, 0, W, V * c, V * s, 0]
        )


class Lidar(LeafSystem):
    """The stamp of the latest scan (LIDAR_RATE, LIDAR_PHASE)."""

    def __init__(self):
        super().__init__()
        self._stamp = self.DeclareDiscreteState(1)
        self.DeclareStateOutputPort("stamp", self._stamp)
        self.DeclarePeriodicDiscreteUpdateEvent(1.0 / LIDAR_RATE, LIDAR_PHASE, self._scan)

    def _scan(self, context, state):
        state.get_mutable_vector().SetAtIndex(0, context.get_time())


class Consumer(LeafSystem):
    """At CONTROLLER_RATE: the latest scan's stamp and the buffer's pose at it (the
    ground truth's, and map -> odom then the odometry's)."""

    MAP_TO_ODOM = (1.0, -2.0, 0.7)

    def __init__(self):
        super().__init__()
        self.poses = self.DeclareAbstractInputPort("poses", AbstractValue.Make(RobotPoses()))
        self.stamp = self.DeclareVectorInputPort("stamp", 1)
        self.seen = []
        self.DeclarePeriodicPublishEvent(1.0 / CONTROLLER_RATE, 0.0, self._take)

    def _take(self, context):
        stamp = float(self.stamp.Eval(context)[0])
        if stamp <= 0.0:
            return
        poses = self.poses.Eval(context)
        localized = poses.map_pose(stamp, self.MAP_TO_ODOM)
        self.seen.append((context.get_time(), stamp, poses.map_pose(stamp), localized))


@pytest.fixture(scope="module")
def consumed():
    builder = DiagramBuilder()
    plant = builder.AddSystem(ArcPlant())
    buffer = builder.AddSystem(
        PoseBuffer(state_size=13, base_rows=(list(range(7)), list(range(7, 13))), rate=ODOM_RATE)
    )
    lidar = builder.AddSystem(Lidar())
    consumer = builder.AddSystem(Consumer())
    builder.Connect(plant.GetOutputPort("state"), buffer.GetInputPort("state"))
    builder.Connect(plant.GetOutputPort("odom"), buffer.GetInputPort("odom"))
    builder.Connect(buffer.GetOutputPort("poses"), consumer.poses)
    builder.Connect(lidar.GetOutputPort("stamp"), consumer.stamp)
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(4.0)
    return consumer.seen


def _error(pose, expected) -> tuple[float, float]:
    return (
        math.hypot(pose[0] - expected[0], pose[1] - expected[1]),
        abs(math.remainder(pose[2] - expected[2], 2 * math.pi)),
    )


def test_a_scan_is_placed_at_its_stamp_within_a_millimetre_while_turning(consumed):
    assert len(consumed) >= 18
    lags = [now - stamp for now, stamp, _, _ in consumed]
    assert max(lags) > 0.05  # the scans are up to a lidar period old when taken
    for _, stamp, truth, localized in consumed:
        position, yaw = _error(truth, true_pose(stamp))
        assert position < 1e-3 and yaw < 1e-3, stamp
        expected = compose(Consumer.MAP_TO_ODOM, odometry_pose(stamp))
        position, yaw = _error(localized, expected)
        assert position < 1e-3 and yaw < 1e-3, stamp


def test_the_odometry_is_the_axles_integration_as_the_base_frames_pose(consumed):
    """As diff_drive_controller publishes odom -> base_link (it knows no axle offset): the
    odometry track is the axle's integration, off the base frame's true pose by the offset
    turned with the base (here 0.1 m through up to 7.2 rad)."""
    worst = 0.0
    for _, stamp, truth, localized in consumed:
        odometry = compose(inverse(Consumer.MAP_TO_ODOM), localized)
        assert _error(odometry, odometry_pose(stamp))[0] < 1e-3, stamp
        worst = max(worst, _error(odometry, truth)[0])
    assert worst > AXLE  # not the base frame's true arc


def test_the_nearest_controller_pose_would_smear_the_scan(consumed):
    """What the buffer replaces: the controller's pose at its own tick, up to 0.1 s from
    the stamp, is 0.18 rad off at 1.8 rad/s."""
    worst = max(_error(true_pose(now), true_pose(stamp))[1] for now, stamp, _, _ in consumed)
    assert worst == pytest.approx(W * (1.0 / LIDAR_RATE - LIDAR_PHASE), abs=1e-6)


def test_a_track_interpolates_yaw_on_the_circle_and_keeps_its_window():
    track = PoseTrack().add(0.0, (0.0, 0.0, 3.0)).add(0.1, (1.0, 2.0, -3.0))
    x, y, yaw = track.at(0.05)
    assert (x, y) == pytest.approx((0.5, 1.0))
    assert abs(math.remainder(yaw - math.pi, 2 * math.pi)) < 1e-12  # across +-pi, not 0
    assert track.at(-1.0) == (0.0, 0.0, 3.0) and track.at(5.0) == (1.0, 2.0, -3.0)
    for k in range(2, 400):
        track = track.add(0.02 * k, (0.0, 0.0, 0.0))
    assert track.stamps[-1] - track.stamps[1] < BUFFER_SECONDS + 1e-9
    assert track.stamps[-1] - track.stamps[0] >= BUFFER_SECONDS
    assert np.all(np.diff(track.stamps) > 0)
    assert track.add(1.0, (9.0, 9.0, 0.0)) is track  # older than the latest: ignored
