"""The registered controllers, run by the controller manager, against upstream's bad-input
cases, with numbers and reason texts."""

import logging
import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from armando_drake.control.controllers import ControllerJoints
from armando_drake.control.controllers.forward_command import JointGroupPositionController
from armando_drake.control.controllers.joint_trajectory import (
    JointTrajectoryController,
    JointTrajectoryControllerParams,
)
from armando_drake.control.hardware import HardwareInterface, HardwareJoint
from armando_drake.control.manager import ControllerManager, ManagedController
from armando_drake.messages.types import (
    Float64MultiArray,
    JointTrajectory,
    JointTrajectoryPoint,
    Publication,
)

RATE = 100  # [Hz]
PERIOD = 1.0 / RATE  # [s]
NAMES = ("j0", "j1", "j2")
LOWER = (-3.0, -2.0, -3.0)  # [rad]
UPPER = (3.0, 2.0, 3.0)  # [rad]
NAME = "ctl"  # the controller's name: ports ctl.<topic>, ctl.status; log lines "ctl: ..."


def bare_hardware(names=NAMES, interface="position") -> HardwareInterface:
    """A hardware interface without a plant: the manager's ``state`` input is [q; v] of
    ``names`` in that order."""
    n = len(names)
    joints = [
        HardwareJoint(name, -np.inf, np.inf, np.inf, 0.0, command_interface=interface)
        for name in names
    ]
    return HardwareInterface("bare", "test", joints, list(range(n)), list(range(n, 2 * n)), 2 * n)


class Harness:
    """Runs one controller in a controller manager alone, with its topic and measured
    state as fixed inputs."""

    def __init__(self, logic, update_rate=RATE, measured=None):
        self.system = ControllerManager(
            hardware=bare_hardware(logic.joint_names, logic.interface),
            update_rate=update_rate,
            controllers=[ManagedController(NAME, logic)],
        )
        self.topic = f"{NAME}.{logic.topic}"
        self.simulator = Simulator(self.system)
        self.context = self.simulator.get_mutable_context()
        self.publication = Publication()
        self.system.GetInputPort(self.topic).FixValue(self.context, self.publication)
        self.set_measured(np.zeros(len(logic.joint_names)) if measured is None else measured)
        self.time = 0.0  # [s] time of the latest update
        self.simulator.AdvanceTo(PERIOD / 2)

    def set_measured(self, q, v=None) -> None:
        v = np.zeros(len(q)) if v is None else v
        self.system.GetInputPort("state").FixValue(self.context, np.concatenate([q, v]))

    def publish(self, message) -> float:
        """Publishes ``message``; returns the time of the update that handles it."""
        self.publication = self.publication.publish(message, self.time)
        self.system.GetInputPort(self.topic).FixValue(self.context, self.publication)
        return self.time + PERIOD

    def advance(self, time: float) -> None:
        """Runs until just after the update at ``time`` (a multiple of PERIOD)."""
        self.simulator.AdvanceTo(time + PERIOD / 2)
        self.time = time

    def step(self, count: int = 1) -> None:
        self.advance(self.time + count * PERIOD)

    @property
    def desired(self) -> np.ndarray:
        return np.array(self.system.GetOutputPort("desired_state").Eval(self.context))

    @property
    def status(self):
        return self.system.GetOutputPort(f"{NAME}.status").Eval(self.context)


# ----------------------------------------------------------------------------------------------
# Position controller


def position_harness(initial=(0.1, -0.2, 0.3)) -> Harness:
    controller = JointGroupPositionController(
        name=NAME,
        joints=ControllerJoints.make(NAMES, lower=LOWER, upper=UPPER, initial_positions=initial),
    )
    return Harness(controller)


def test_position_controller_holds_on_start_up():
    harness = position_harness()
    harness.advance(0.3)
    np.testing.assert_array_equal(harness.desired, [0.1, -0.2, 0.3, 0.0, 0.0, 0.0])
    status = harness.status
    assert (status.state, status.accepted, status.rejected) == ("holding", 0, 0)


def test_position_controller_writes_command():
    harness = position_harness()
    harness.advance(0.1)
    harness.publish(Float64MultiArray(data=(1.0, -1.5, 2.5)))
    harness.step()
    np.testing.assert_array_equal(harness.desired, [1.0, -1.5, 2.5, 0.0, 0.0, 0.0])
    status = harness.status
    assert (status.state, status.accepted, status.rejected, status.detail) == ("active", 1, 0, {})


@pytest.mark.parametrize(
    "data, reason",
    [
        ((1.0, 2.0), "command size (2) does not match number of interfaces (3)"),
        ((1.0, 1.0, 1.0, 1.0), "command size (4) does not match number of interfaces (3)"),
        ((), "command size (0) does not match number of interfaces (3)"),
        ((1.0, math.inf, 0.0), "Non-finite value received. Dropping message"),
        ((-math.inf, 0.0, 0.0), "Non-finite value received. Dropping message"),
        ((0.0, 0.0, math.nan), "Non-finite value received. Dropping message"),
        ((math.nan, 0.0), "Non-finite value received. Dropping message"),
    ],
    ids=["too-few", "too-many", "empty", "inf", "minus-inf", "nan", "nan-and-wrong-size"],
)
def test_position_controller_rejects_bad_command(caplog, data, reason):
    harness = position_harness()
    harness.publish(Float64MultiArray(data=(0.5, 0.6, 0.7)))
    harness.step()
    with caplog.at_level(logging.ERROR, logger="armando_drake.control.controllers"):
        harness.publish(Float64MultiArray(data=data))
        harness.step(5)
    np.testing.assert_array_equal(harness.desired, [0.5, 0.6, 0.7, 0.0, 0.0, 0.0])
    status = harness.status
    assert (status.state, status.accepted, status.rejected, status.last_error) == (
        "active",
        1,
        1,
        reason,
    )
    assert [record.getMessage().split(": ", 1)[1] for record in caplog.records] == [reason]
    # The controller stays active: the next good command is written.
    harness.publish(Float64MultiArray(data=(-0.5, -0.6, -0.7)))
    harness.step()
    np.testing.assert_array_equal(harness.desired[:3], [-0.5, -0.6, -0.7])
    assert (harness.status.accepted, harness.status.rejected) == (2, 1)


def test_position_controller_rejects_bad_command_before_the_first():
    harness = position_harness()
    harness.publish(Float64MultiArray(data=(1.0,)))
    harness.step()
    np.testing.assert_array_equal(harness.desired[:3], [0.1, -0.2, 0.3])
    assert (harness.status.state, harness.status.rejected) == ("holding", 1)


def test_position_controller_rejects_wrong_message_type():
    harness = position_harness()
    harness.publish(JointTrajectory(joint_names=NAMES))
    harness.step()
    assert harness.status.last_error == "expected a Float64MultiArray message, got JointTrajectory"
    np.testing.assert_array_equal(harness.desired[:3], [0.1, -0.2, 0.3])


def test_position_controller_clamps_into_limits_with_warning():
    harness = position_harness()
    harness.publish(Float64MultiArray(data=(1.0, 2.5, -3.5)))
    harness.step()
    np.testing.assert_array_equal(harness.desired[:3], [1.0, 2.0, -3.0])
    status = harness.status
    assert (status.state, status.accepted, status.rejected) == ("active", 1, 0)
    assert status.detail["warning"] == (
        "command 2.5 for joint 'j1' is outside its limits [-2.0, 2.0]; clamped to 2.0; "
        "command -3.5 for joint 'j2' is outside its limits [-3.0, 3.0]; clamped to -3.0"
    )


def test_position_controller_handles_each_message_once():
    harness = position_harness()
    harness.publish(Float64MultiArray(data=(1.0,)))
    harness.step(10)
    assert harness.status.rejected == 1
    harness.publish(Float64MultiArray(data=(1.0, 1.0, 1.0)))
    harness.step(10)
    assert (harness.status.accepted, harness.status.rejected) == (1, 1)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"joint_names": ()}, "joint_names=() must not be empty"),
        ({"joint_names": ("a", "b", "a")}, "joint_names=('a', 'b', 'a') repeats ['a']"),
        ({"update_rate": 0}, "update_rate=0 must be a positive integer [Hz]"),
        ({"update_rate": -5.0}, "update_rate=-5.0 must be a positive integer [Hz]"),
        ({"lower": (0.0, 0.0)}, "must each have 3 values"),
        ({"lower": (3.5, 0.0, 0.0)}, "limits [3.5, 3.0] of joint 'j0' are not an interval"),
        ({"initial_positions": (0.0, math.nan, 0.0)}, "must be 3 finite values"),
    ],
)
def test_position_controller_constructor_errors(kwargs, message):
    arguments = dict(joint_names=NAMES, lower=LOWER, upper=UPPER, update_rate=RATE)
    arguments.update(kwargs)
    update_rate = arguments.pop("update_rate")
    with pytest.raises(ValueError) as error:
        logic = JointGroupPositionController(
            name=NAME, joints=ControllerJoints.make(arguments.pop("joint_names"), **arguments)
        )
        Harness(logic, update_rate=update_rate)
    assert message in str(error.value)


# ----------------------------------------------------------------------------------------------
# Trajectory controller


def trajectory_harness(initial=(0.0, 0.0, 0.0), **params) -> Harness:
    controller = JointTrajectoryController(
        name=NAME,
        joints=ControllerJoints.make(NAMES, lower=LOWER, upper=UPPER, initial_positions=initial),
        params=JointTrajectoryControllerParams(joints=list(NAMES), **params),
    )
    return Harness(controller)


def point(positions, time, velocities=(), accelerations=(), effort=()):
    return JointTrajectoryPoint(
        positions=tuple(positions),
        velocities=tuple(velocities),
        accelerations=tuple(accelerations),
        effort=tuple(effort),
        time_from_start=time,
    )


def trajectory(*points, names=NAMES, stamp=0.0):
    return JointTrajectory(stamp=stamp, joint_names=tuple(names), points=tuple(points))


GOOD_GOAL = (0.4, -0.5, 0.6)


def run_to_good_goal(harness: Harness) -> None:
    """Accepts and finishes a trajectory to GOOD_GOAL (the last good command)."""
    harness.publish(trajectory(point(GOOD_GOAL, 0.1)))
    harness.step(20)
    assert harness.status.state == "succeeded"
    np.testing.assert_array_equal(harness.desired, [*GOOD_GOAL, 0.0, 0.0, 0.0])


BAD_TRAJECTORIES = {
    "wrong-joint-name": (
        trajectory(point((0, 0, 0), 1.0), names=("j0", "j1", "x")),
        "Incoming joint x doesn't match the controller's joints.",
        {},
    ),
    "wrong-joint-count": (
        trajectory(point((0, 0), 1.0), names=("j0", "j1")),
        "Joints on incoming trajectory don't match the controller joints.",
        {},
    ),
    "empty-joint-names": (
        trajectory(point((), 1.0), names=()),
        "Empty joint names on incoming trajectory.",
        {"allow_partial_joints_goal": True},
    ),
    "no-points": (trajectory(), "Empty trajectory received.", {}),
    "no-positions": (
        trajectory(point((), 1.0)),
        "Mismatch between joint_names size (3) and positions (0) at point #0.",
        {},
    ),
    "too-few-positions": (
        trajectory(point((0, 0, 0), 1.0), point((0, 0), 2.0)),
        "Mismatch between joint_names size (3) and positions (2) at point #1.",
        {},
    ),
    "too-many-positions": (
        trajectory(point((0, 0, 0, 0), 1.0)),
        "Mismatch between joint_names size (3) and positions (4) at point #0.",
        {},
    ),
    "too-few-velocities": (
        trajectory(point((0, 0, 0), 1.0, velocities=(0, 0))),
        "Mismatch between joint_names size (3) and velocities (2) at point #0.",
        {},
    ),
    "too-few-accelerations": (
        trajectory(point((0, 0, 0), 1.0, velocities=(0, 0, 0), accelerations=(0,))),
        "Mismatch between joint_names size (3) and accelerations (1) at point #0.",
        {},
    ),
    "effort-given": (
        trajectory(point((0, 0, 0), 1.0, effort=(1, 1, 1))),
        "Trajectories with effort fields are only supported for controllers using the "
        "'effort' command interface.",
        {},
    ),
    "time-decreasing": (
        trajectory(point((0, 0, 0), 1.0), point((1, 1, 1), 0.5)),
        "Time between points 0 and 1 is not strictly increasing, it is 1.000000 and "
        "0.500000 respectively",
        {},
    ),
    "time-repeated": (
        trajectory(point((0, 0, 0), 0.5), point((1, 1, 1), 1.0), point((1, 1, 1), 1.0)),
        "Time between points 1 and 2 is not strictly increasing, it is 1.000000 and "
        "1.000000 respectively",
        {},
    ),
    "ends-in-the-past": (
        trajectory(point((0, 0, 0), 0.1), stamp=0.05),
        "Received trajectory with non-zero start time (0.050000) that ends in the past (0.150000)",
        {},
    ),
    "nonzero-end-velocity": (
        trajectory(point((0, 0, 0), 1.0, velocities=(0, 0.5, 0))),
        "Velocity of last trajectory point of joint j1 is not zero: 0.500000000000000",
        {},
    ),
    # Stricter than upstream:
    "duplicate-joint": (
        trajectory(point((0, 0, 0), 1.0), names=("j0", "j1", "j0")),
        "Incoming joint j0 appears more than once.",
        {},
    ),
    "negative-time": (
        trajectory(point((0, 0, 0), -0.5), point((0, 0, 0), 1.0)),
        "Time from start of point #0 is negative: -0.500000",
        {},
    ),
    "nan-time": (
        trajectory(point((0, 0, 0), math.nan)),
        "Non-finite time_from_start at point #0: nan",
        {},
    ),
    "nan-position": (
        trajectory(point((0, math.nan, 0), 1.0)),
        "Non-finite value in positions at point #0.",
        {},
    ),
    "inf-velocity": (
        trajectory(point((0, 0, 0), 0.5), point((0, 0, 0), 1.0, velocities=(0, math.inf, 0))),
        "Non-finite value in velocities at point #1.",
        {"allow_nonzero_velocity_at_trajectory_end": True},
    ),
    "nan-acceleration": (
        trajectory(point((0, 0, 0), 1.0, velocities=(0, 0, 0), accelerations=(math.nan, 0, 0))),
        "Non-finite value in accelerations at point #0.",
        {},
    ),
    "nan-stamp": (
        trajectory(point((0, 0, 0), 1.0), stamp=math.nan),
        "Non-finite header stamp received: nan",
        {},
    ),
    "wrong-message-type": (
        Float64MultiArray(data=(0.0, 0.0, 0.0)),
        "expected a JointTrajectory message, got Float64MultiArray",
        {},
    ),
}


@pytest.mark.parametrize("case", list(BAD_TRAJECTORIES))
def test_trajectory_controller_rejects_bad_trajectory(caplog, case):
    message, reason, params = BAD_TRAJECTORIES[case]
    harness = trajectory_harness(**params)
    run_to_good_goal(harness)
    with caplog.at_level(logging.ERROR, logger="armando_drake.control.controllers"):
        harness.publish(message)
        harness.step(5)
    np.testing.assert_array_equal(harness.desired, [*GOOD_GOAL, 0.0, 0.0, 0.0])
    status = harness.status
    assert (status.state, status.accepted, status.rejected, status.last_error) == (
        "succeeded",
        1,
        1,
        reason,
    )
    assert [record.getMessage().split(": ", 1)[1] for record in caplog.records] == [reason]


def test_trajectory_controller_rejection_keeps_running_trajectory():
    harness = trajectory_harness()
    start = harness.publish(trajectory(point((1.0, 1.0, 1.0), 1.0)))
    harness.advance(start + 0.3)
    harness.publish(trajectory())
    harness.advance(start + 0.5)
    # The command of the update at t is the sample at t + dt (upstream PR #1306).
    np.testing.assert_allclose(harness.desired, [0.51, 0.51, 0.51, 1.0, 1.0, 1.0], atol=1e-12)
    assert (harness.status.state, harness.status.last_error) == (
        "executing",
        "Empty trajectory received.",
    )


def test_trajectory_controller_holds_on_start_up():
    """The position command interface's values, whatever the state interfaces (upstream's
    PR #2356); without set_last_command_interface_value_as_state_on_activation, the
    measured position read at activation."""
    harness = trajectory_harness(initial=(0.3, -0.3, 1.0), state_interfaces=["position"])
    harness.set_measured(np.array([0.1, 0.1, 0.1]))
    harness.advance(0.5)
    np.testing.assert_array_equal(harness.desired, [0.3, -0.3, 1.0, 0.0, 0.0, 0.0])
    assert (harness.status.state, harness.status.accepted) == ("idle", 0)
    commanded = trajectory_harness(initial=(0.3, -0.3, 1.0))  # with a velocity state
    commanded.advance(0.5)
    np.testing.assert_array_equal(commanded.desired, [0.3, -0.3, 1.0, 0.0, 0.0, 0.0])
    measured = trajectory_harness(  # measured zeros at activation
        initial=(0.3, -0.3, 1.0), set_last_command_interface_value_as_state_on_activation=False
    )
    measured.advance(0.5)
    np.testing.assert_array_equal(measured.desired, [0.0] * 6)


def test_linear_from_measured_state():
    """Positions only: a straight line from the measured position to each point (the
    measured velocity is kept, but the first point has none: linear)."""
    harness = trajectory_harness()
    q0 = np.array([0.2, -0.4, 0.1])
    harness.set_measured(q0, np.array([1.0, 1.0, 1.0]))
    harness.advance(0.2)
    p1, p2 = np.array([1.0, 0.6, -1.1]), np.array([2.0, -0.4, 0.9])
    start = harness.publish(trajectory(point(p1, 0.4), point(p2, 1.0)))
    harness.advance(start + 0.2)
    np.testing.assert_allclose(harness.desired[:3], q0 + (p1 - q0) * 0.21 / 0.4, atol=1e-12)
    np.testing.assert_allclose(harness.desired[3:], (p1 - q0) / 0.4, atol=1e-12)
    harness.advance(start + 0.7)
    np.testing.assert_allclose(harness.desired[:3], p1 + (p2 - p1) * 0.31 / 0.6, atol=1e-12)
    np.testing.assert_allclose(harness.desired[3:], (p2 - p1) / 0.6, atol=1e-12)
    harness.set_measured(p2)  # stopped at the goal
    harness.advance(start + 1.5)
    np.testing.assert_array_equal(harness.desired, [*p2, 0.0, 0.0, 0.0])
    assert harness.status.state == "succeeded"
    assert harness.status.detail == pytest.approx({"start_time": start, "end_time": start + 1.0})


def hermite(p0, v0, p1, v1, duration, s):
    """Cubic Hermite value at ``s`` into a segment of ``duration``."""
    u = s / duration
    h00 = 2 * u**3 - 3 * u**2 + 1
    h10 = u**3 - 2 * u**2 + u
    h01 = -2 * u**3 + 3 * u**2
    h11 = u**3 - u**2
    return h00 * p0 + h10 * duration * v0 + h01 * p1 + h11 * duration * v1


def test_cubic_hermite_with_velocities():
    harness = trajectory_harness()
    q0, v0 = np.array([0.1, 0.2, -0.3]), np.array([0.5, -0.5, 0.0])
    harness.set_measured(q0, v0)
    harness.advance(0.1)
    p1, v1 = np.array([1.0, -1.0, 0.5]), np.array([0.8, 0.3, -0.2])
    p2 = np.array([0.0, 0.5, 1.5])
    start = harness.publish(
        trajectory(point(p1, 0.5, velocities=v1), point(p2, 1.5, velocities=(0, 0, 0)))
    )
    # The first segment starts from the measured position and velocity.
    harness.advance(start + 0.2)
    np.testing.assert_allclose(harness.desired[:3], hermite(q0, v0, p1, v1, 0.5, 0.21), atol=1e-9)
    harness.advance(start + 0.9)
    np.testing.assert_allclose(
        harness.desired[:3], hermite(p1, v1, p2, np.zeros(3), 1.0, 0.41), atol=1e-9
    )


def quintic(p0, v0, a0, p1, v1, a1, duration, s):
    """The quintic through both ends' position, velocity, acceleration, solved numerically."""
    T = duration
    matrix = np.array(
        [
            [1, 0, 0, 0, 0, 0],
            [0, 1, 0, 0, 0, 0],
            [0, 0, 2, 0, 0, 0],
            [1, T, T**2, T**3, T**4, T**5],
            [0, 1, 2 * T, 3 * T**2, 4 * T**3, 5 * T**4],
            [0, 0, 2, 6 * T, 12 * T**2, 20 * T**3],
        ]
    )
    coefficients = np.linalg.solve(matrix, np.stack([p0, v0, a0, p1, v1, a1]))
    return np.array([s**k for k in range(6)]) @ coefficients


def test_quintic_with_accelerations():
    harness = trajectory_harness()
    harness.advance(0.1)
    p1, v1, a1 = np.array([0.5, -0.2, 1.0]), np.array([0.4, 0.1, -0.3]), np.array([1.0, -2, 0.5])
    p2, v2, a2 = np.array([1.2, 0.3, 0.2]), np.zeros(3), np.array([-0.5, 0.7, 0.0])
    start = harness.publish(
        trajectory(
            point(p1, 0.5, velocities=v1, accelerations=a1),
            point(p2, 1.3, velocities=v2, accelerations=a2),
        )
    )
    # The first segment is quintic too: from the measured state (at rest, no
    # acceleration measured: zero) to the first point.
    harness.advance(start + 0.2)
    zeros = np.zeros(3)
    np.testing.assert_allclose(
        harness.desired[:3], quintic(zeros, zeros, zeros, p1, v1, a1, 0.5, 0.21), atol=1e-9
    )
    harness.advance(start + 0.9)
    expected = quintic(p1, v1, a1, p2, v2, a2, 0.8, 0.41)
    np.testing.assert_allclose(harness.desired[:3], expected, atol=1e-9)
    # A quintic, not the cubic through the same ends.
    assert np.max(np.abs(expected - hermite(p1, v1, p2, v2, 0.8, 0.41))) > 1e-3


def test_interpolation_none_commands_the_next_point():
    """Upstream's ``interpolation_method: none``: the state before the trajectory until
    the first point, then from each point on the *next* point's values."""
    harness = trajectory_harness(interpolation_method="none")
    q0 = np.array([0.1, 0.2, 0.3])
    harness.set_measured(q0)
    harness.advance(0.1)
    p1, p2 = np.array([1.0, 1.0, 1.0]), np.array([-1.0, -1.0, -1.0])
    start = harness.publish(trajectory(point(p1, 0.3, velocities=(0.5, 0.5, 0.5)), point(p2, 0.6)))
    harness.advance(start + 0.2)  # samples 0.21 s: before the first point
    np.testing.assert_array_equal(harness.desired, [*q0, 0.0, 0.0, 0.0])
    harness.advance(start + 0.28)  # samples 0.29 s: still before it
    np.testing.assert_array_equal(harness.desired, [*q0, 0.0, 0.0, 0.0])
    harness.advance(start + 0.29)  # samples 0.30 s: between point 1 and 2 -> point 2
    np.testing.assert_array_equal(harness.desired, [*p2, 0.0, 0.0, 0.0])
    harness.advance(start + 0.7)
    np.testing.assert_array_equal(harness.desired, [*p2, 0.0, 0.0, 0.0])


def test_stamped_trajectory_starts_at_its_stamp():
    harness = trajectory_harness()
    harness.advance(0.2)
    start = harness.publish(trajectory(point((1.0, 1.0, 1.0), 0.5), stamp=0.5))
    assert start == pytest.approx(0.21)
    # The first segment runs from the state at acceptance (0.21 s) to the point (1.0 s).
    harness.advance(0.61)
    np.testing.assert_allclose(harness.desired[:3], [0.41 / 0.79] * 3, atol=1e-12)
    np.testing.assert_allclose(harness.desired[3:], [1.0 / 0.79] * 3, atol=1e-12)
    assert harness.status.detail["end_time"] == 1.0


def test_replacement_starts_from_current_state():
    harness = trajectory_harness()
    first = harness.publish(trajectory(point((2.0, 2.0, 2.0), 2.0)))
    harness.advance(first + 0.5)
    np.testing.assert_allclose(harness.desired[:3], [0.51, 0.51, 0.51], atol=1e-12)
    harness.set_measured(harness.desired[:3])  # perfect tracking
    target = np.array([-1.0, 0.0, 1.5])
    second = harness.publish(trajectory(point(target, 1.0)))
    harness.advance(second + 0.5)
    np.testing.assert_allclose(harness.desired[:3], 0.51 + (target - 0.51) * 0.51, atol=1e-12)
    harness.advance(second + 2.5)  # past the first trajectory's end too
    np.testing.assert_array_equal(harness.desired, [*target, 0.0, 0.0, 0.0])
    status = harness.status
    assert (status.state, status.accepted, status.rejected) == ("succeeded", 2, 0)


def test_partial_goal_allowed_starts_from_measured_state():
    """The joints a partial goal leaves out go from their measured position to their
    last command over the first segment (upstream's fill_partial_goal and
    set_point_before_trajectory_msg)."""
    harness = trajectory_harness(
        initial=(0.1, 0.2, 0.3), allow_partial_joints_goal=True, state_interfaces=["position"]
    )
    measured = np.array([-0.5, -0.5, -0.5])
    harness.set_measured(measured)
    harness.advance(0.1)
    start = harness.publish(trajectory(point((1.0,), 1.0), names=("j1",)))
    harness.advance(start + 0.5)
    goal = np.array([0.1, 1.0, 0.3])
    np.testing.assert_allclose(
        harness.desired, [*(measured + (goal - measured) * 0.51), *(goal - measured)], atol=1e-12
    )
    harness.set_measured(goal)
    harness.advance(start + 1.5)
    np.testing.assert_array_equal(harness.desired, [0.1, 1.0, 0.3, 0.0, 0.0, 0.0])
    assert harness.status.state == "succeeded"


def test_partial_goal_forbidden():
    harness = trajectory_harness(initial=(0.1, 0.2, 0.3), state_interfaces=["position"])
    harness.publish(trajectory(point((1.0,), 1.0), names=("j1",)))
    harness.step(50)
    np.testing.assert_array_equal(harness.desired, [0.1, 0.2, 0.3, 0.0, 0.0, 0.0])
    status = harness.status
    assert (status.state, status.rejected, status.last_error) == (
        "idle",
        1,
        "Joints on incoming trajectory don't match the controller joints.",
    )


def test_jumbled_joint_order_is_mapped():
    harness = trajectory_harness()
    start = harness.publish(
        trajectory(
            point((0.3, 0.1, 0.2), 0.5, velocities=(0.0, 0.0, 0.0)), names=("j2", "j0", "j1")
        )
    )
    harness.advance(start + 0.25)  # samples 0.26 s of a cubic from rest to rest
    expected = hermite(np.zeros(3), np.zeros(3), np.array([0.1, 0.2, 0.3]), np.zeros(3), 0.5, 0.26)
    np.testing.assert_allclose(harness.desired[:3], expected, atol=1e-12)
    harness.advance(start + 0.6)
    np.testing.assert_array_equal(harness.desired, [0.1, 0.2, 0.3, 0.0, 0.0, 0.0])


def test_trajectory_positions_outside_limits_are_clamped():
    harness = trajectory_harness()
    start = harness.publish(trajectory(point((0.0, 2.5, 0.0), 0.5)))
    harness.advance(start + 0.45)
    assert harness.desired[1] == 2.0
    assert harness.status.detail["warning"] == (
        "point positions of joint 'j1' leave its limits [-2.0, 2.0]; "
        "the desired position is clamped"
    )


GOAL = (0.5, -0.5, 1.0)


@pytest.mark.parametrize(
    "offset, velocity",
    [((0.04, -0.04, 0.0), (0.0, 0.005, 0.0)), ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))],
    ids=["within-tolerance", "exact"],
)
def test_goal_tolerance_met_succeeds(offset, velocity):
    harness = trajectory_harness(goal_time=0.5, goal_tolerance={"j0": 0.05, "j1": 0.05})
    start = harness.publish(trajectory(point(GOAL, 0.5)))
    harness.set_measured(np.add(GOAL, offset), np.array(velocity))
    harness.advance(start + 0.5)
    assert harness.status.state == "succeeded"
    np.testing.assert_array_equal(harness.desired, [*GOAL, 0.0, 0.0, 0.0])


def test_goal_tolerance_violated_after_goal_time():
    harness = trajectory_harness(goal_time=0.305, goal_tolerance={"j0": 0.05, "j1": 0.05})
    start = harness.publish(trajectory(point(GOAL, 0.5)))
    measured = np.add(GOAL, (0.0, 0.2, 0.0))
    harness.set_measured(measured)
    harness.advance(start + 0.8)  # 0.3 s after the end: still waiting
    assert harness.status.state == "executing"
    np.testing.assert_array_equal(harness.desired, [*GOAL, 0.0, 0.0, 0.0])
    harness.step()
    status = harness.status
    assert status.state == "aborted"
    assert status.last_error == (
        "goal tolerance violated: joint 'j1' is 0.2 rad from its desired position -0.5 "
        "(goal tolerance 0.05) 0.31 s after the end"
    )
    # Upstream writes nothing at the aborting update, and holds the measured position
    # from the next one on.
    np.testing.assert_array_equal(harness.desired, [*GOAL, 0.0, 0.0, 0.0])
    harness.step()
    np.testing.assert_allclose(harness.desired, [*measured, 0.0, 0.0, 0.0], atol=1e-15)


def test_stopped_velocity_is_not_checked_with_position_commands():
    """Upstream computes the velocity error only with a velocity or effort command
    interface (compute_error_for_joint), so a position-commanded joint still moving at
    the goal succeeds."""
    harness = trajectory_harness(goal_time=0.305, goal_tolerance={"j0": 0.05, "j1": 0.05})
    start = harness.publish(trajectory(point(GOAL, 0.5)))
    harness.set_measured(np.array(GOAL), np.array([0.0, 0.0, 0.1]))
    harness.advance(start + 0.5)
    assert harness.status.state == "succeeded"


def test_goal_time_zero_waits_forever():
    harness = trajectory_harness(goal_tolerance={"j0": 0.05})
    start = harness.publish(trajectory(point(GOAL, 0.5)))
    harness.set_measured(np.array([0.0, -0.5, 1.0]))
    harness.advance(start + 3.0)
    assert harness.status.state == "executing"
    harness.set_measured(np.array([0.49, -0.5, 1.0]))
    harness.step()
    assert harness.status.state == "succeeded"


def test_path_tolerance_violated_aborts_and_holds_measured():
    harness = trajectory_harness(trajectory_tolerance={"j1": 0.105})
    measured = np.array([0.02, -0.01, 0.03])
    harness.set_measured(measured)  # the arm does not move at all
    start = harness.publish(trajectory(point((0.0, 1.0, 0.0), 1.0)))
    # j1's desired position runs from -0.01 at 1.01 rad/s; 0.101 rad off after 0.1 s.
    harness.advance(start + 0.1)
    assert harness.status.state == "executing"
    command = harness.desired  # the sample at 0.11 s
    np.testing.assert_allclose(command[:3], measured + (np.array([0, 1, 0]) - measured) * 0.11)
    harness.step()
    status = harness.status
    assert status.state == "aborted"
    assert status.last_error == (
        "path tolerance violated: joint 'j1' is 0.1111 rad from its desired position 0.1011 "
        "(trajectory tolerance 0.105)"
    )
    np.testing.assert_array_equal(harness.desired, command)  # nothing written at the abort
    harness.step()
    np.testing.assert_array_equal(harness.desired, [*measured, 0.0, 0.0, 0.0])
    harness.step(50)
    np.testing.assert_array_equal(harness.desired, [*measured, 0.0, 0.0, 0.0])


def test_trajectory_controller_rejects_mismatched_params():
    with pytest.raises(ValueError, match=r"params.joints=\['j1', 'j0'\] differs"):
        JointTrajectoryController(
            name=NAME,
            joints=ControllerJoints.make(("j0", "j1")),
            params=JointTrajectoryControllerParams(joints=["j1", "j0"]),
        )
