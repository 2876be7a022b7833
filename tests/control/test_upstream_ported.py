"""Upstream's tests, ported: ros2_controllers (Jazzy, with PR #1306) test_trajectory.cpp,
test_trajectory_controller.cpp (with its fixture's inputs: commands and state at 1.1, 2.1,
3.1, allow_nonzero_velocity_at_trajectory_end true, stopped_velocity_tolerance 0, over its
interface instantiations), test_tolerances.cpp / tolerances.hpp,
test_forward_command_controller.cpp, test_joint_group_{position,velocity,effort}_controller.cpp
and test_joint_state_broadcaster.cpp.

Each test is named after the upstream test it mirrors (``test_<upstream name>``, the
JointGroup ones ``test_joint_group_<name>``), with the same inputs and the same assertions
where our API observes them; what a port asserts differently, because we deliberately
differ (README, "Where we knowingly differ"), its docstring says. Controller tests run the
controller in a controller manager at 100 Hz (``Harness``), so "the command at the update
at t" is the sample at t + 10 ms; activation is building the manager.

Not ported, and why:

- test_tolerances.cpp's test_get_segment_tolerances, test_deactivate_tolerances,
  test_invalid_tolerances, test_invalid_joints_path_tolerance and
  test_invalid_joints_goal_tolerance: they read a FollowJointTrajectory *action goal*'s
  path_tolerance, goal_tolerance and goal_time_tolerance; trajectories reach us on the
  topic only (no action server), so a goal always has the parameters' tolerances
  (test_get_segment_tolerances_from_parameters, test_check_state_tolerance_per_joint).
  test_trajectory_actions.cpp (test_cancel_hold_position and the rest) likewise.
- Lifecycle transitions we do not model (a controller is active from the manager's first
  update until the simulation ends): configure_state_ignores_commands, activate_deactivate,
  cleanup, correct_initialization_using_parameters' deactivate/cleanup half,
  ActivateDeactivateCommandsResetSuccess, the JointGroup velocity/effort
  StopJointsOnDeactivateTest; ActivateWithWrongJointsNamesFails' second half (its fixture
  hands two joints three interfaces; a controller manager hands a controller those it
  claims).
- ROS topics and services we do not publish: state_topic_consistency,
  test_state_publish_rate, test_lower_state_publish_rate (state_publish_rate is not a Jazzy
  parameter; refused), velocity_error (the controller state message), query_state_service;
  check_interface_names(_with_command_joints) and activate's interface-configuration
  counts (the claims are checked by the manager instead).
- test_trajectory.cpp's initialize_trajectory and
  sample_velocity_only_all_segments_skipped_returns_false: an empty trajectory, or one
  whose state before has no positions, never reaches our sampler (empty trajectories are
  rejected; the state before always has the measured or commanded positions).
  fill_cubic_spline_velocities_* and sample_after_fill_is_smooth_not_staircase (rolling,
  not Jazzy), test_execute_partial_traj_in_future's body (disabled upstream: it returns
  before its assertions; our port asserts the future stamp's first segment instead).
- test_no_hold_on_startup: Humble's start_with_holding, removed in Jazzy (#839: it always
  holds at activation, test_hold_on_startup); the parameter is refused as unknown.
- test_multi_interface_forward_command_controller.cpp: ported in test_jazzy_backports.py.
"""

import logging
import math

import numpy as np
import pytest
import yaml

from armando_drake.control.config import ControllerConfigError, parse_controller_config
from armando_drake.control.controllers import ControllerJoints, check_parameters
from armando_drake.control.controllers.broadcaster import (
    JointStateBroadcaster,
    JointStateBroadcasterParameters,
)
from armando_drake.control.controllers.forward_command import (
    ForwardCommandController,
    JointGroupEffortController,
    JointGroupPositionController,
    JointGroupVelocityController,
)
from armando_drake.control.controllers.joint_trajectory import (
    JointGains,
    JointTrajectoryController,
    JointTrajectoryControllerParams,
    SampledTrajectory,
    interpolate_between_points,
    wraparound_joint,
)
from armando_drake.control.manager import ControllerManager, ManagedController
from armando_drake.messages.types import (
    Float64MultiArray,
    JointTrajectory,
    JointTrajectoryPoint,
)
from tests.control.test_controllers import NAMES, PERIOD, Harness, bare_hardware, hermite

EPS = 1e-8  # upstream's test_trajectory.cpp threshold


def message_point(time, positions=(), velocities=(), accelerations=(), effort=()):
    return JointTrajectoryPoint(
        positions=tuple(positions),
        velocities=tuple(velocities),
        accelerations=tuple(accelerations),
        effort=tuple(effort),
        time_from_start=time,
    )


def one_joint(*points, stamp=0.0):
    return JointTrajectory(stamp=stamp, joint_names=("j0",), points=tuple(points))


# ----------------------------------------------------------------------------------------------
# test_trajectory.cpp (Trajectory::sample, interpolate_between_points)

TIME_NOW = 100.0  # [s] upstream's rclcpp::Clock().now(), any time


def test_sample_trajectory_positions():
    p1, p2, p3 = (message_point(t, [float(t)]) for t in (1.0, 2.0, 3.0))
    traj = SampledTrajectory.from_message(one_joint(p1, p2, p3), time=TIME_NOW, positions=[0.0])
    velocity = (1.0 - 0.0) / 1.0
    sample = traj.sample(TIME_NOW)  # at trajectory starting time
    assert sample.segment == (0, 0)
    assert sample.positions[0] == pytest.approx(0.0, abs=EPS)
    assert sample.velocities[0] == pytest.approx(velocity, abs=EPS)
    assert sample.accelerations[0] == pytest.approx(0.0, abs=EPS)
    assert traj.sample(TIME_NOW - 0.5) is None  # before time_now
    sample = traj.sample(TIME_NOW + 0.5)
    assert sample.segment == (0, 0)
    assert sample.positions[0] == pytest.approx(0.5, abs=EPS)
    assert sample.velocities[0] == pytest.approx(velocity, abs=EPS)
    sample = traj.sample(TIME_NOW + 1.0)
    assert sample.segment == (0, 1)
    assert sample.positions[0] == pytest.approx(1.0, abs=EPS)
    assert sample.velocities[0] == pytest.approx(velocity, abs=EPS)
    assert traj.sample(TIME_NOW + 1.5).segment == (0, 1)
    assert traj.sample(TIME_NOW + 1.5).positions[0] == pytest.approx(1.5, abs=EPS)
    assert traj.sample(TIME_NOW + 2.5).positions[0] == pytest.approx(2.5, abs=EPS)
    assert traj.sample(TIME_NOW + 3.0).positions[0] == pytest.approx(3.0, abs=EPS)
    sample = traj.sample(TIME_NOW + 3.125)  # past the given points
    assert sample.segment == (2, 3)
    assert sample.positions[0] == pytest.approx(3.0, abs=EPS)
    # Long past them (upstream: 30 s, the same end point).
    sample = traj.sample(TIME_NOW + 30.0)
    assert sample.segment == (2, 3)
    assert sample.positions[0] == pytest.approx(3.0, abs=EPS)


def test_interpolation_pos_vel():
    """From x^3 - 2x: cubic, the end's acceleration ignored (the start has none)."""
    start = message_point(1.0, [0.0], [-2.0])
    end = message_point(3.0, [4.0], [10.0], [0.0])
    q, v, a = interpolate_between_points(1.0, start, 3.0, end, 1.0)
    assert (q[0], v[0], a[0]) == pytest.approx((0.0, -2.0, 0.0), abs=EPS)
    q, v, a = interpolate_between_points(1.0, start, 3.0, end, 1.0 + math.sqrt(2.0))
    assert (q[0], v[0], a[0]) == pytest.approx((0.0, 4.0, 6.0 * math.sqrt(2.0)), abs=EPS)
    q, v, a = interpolate_between_points(1.0, start, 3.0, end, 3.0)
    assert (q[0], v[0], a[0]) == pytest.approx((4.0, 10.0, 12.0), abs=EPS)


def test_interpolation_pos_vel_accel():
    """From x(x-1)(x-2)(x-3)(x-4): quintic."""
    start = message_point(1.0, [0.0], [24.0], [-100.0])
    end = message_point(3.0, [0.0], [4.0], [0.0])
    q, v, a = interpolate_between_points(1.0, start, 3.0, end, 1.0)
    assert (q[0], v[0], a[0]) == pytest.approx((0.0, 24.0, -100.0), abs=EPS)
    q, v, a = interpolate_between_points(1.0, start, 3.0, end, 2.0)
    assert (q[0], v[0], a[0]) == pytest.approx((0.0, -6.0, 10.0), abs=EPS)
    q, v, a = interpolate_between_points(1.0, start, 3.0, end, 3.0)
    assert (q[0], v[0], a[0]) == pytest.approx((0.0, 4.0, 0.0), abs=EPS)


@pytest.mark.parametrize("before_velocity", [[0.0], None], ids=["", "strange_without_vel"])
def test_sample_trajectory_velocity_with_interpolation(before_velocity):
    """Also upstream's ..._strange_without_vel: a state without velocity gets zero."""
    v1, v2, v3 = 1.0, 2.0, 1.0
    message = one_joint(
        message_point(1.0, velocities=[v1]),
        message_point(2.0, velocities=[v2]),
        message_point(3.0, velocities=[v3]),
    )
    traj = SampledTrajectory.from_message(
        message, time=TIME_NOW, positions=[0.0], velocities=before_velocity
    )
    sample = traj.sample(TIME_NOW)
    assert sample.segment == (0, 0)
    assert (sample.positions[0], sample.velocities[0]) == pytest.approx((0.0, 0.0), abs=EPS)
    assert sample.accelerations[0] == pytest.approx(v1 / 1.0, abs=EPS)
    assert traj.sample(TIME_NOW - 0.5) is None
    sample = traj.sample(TIME_NOW + 0.5)
    assert sample.positions[0] == pytest.approx(0.0 + (0.0 + ((0.0 + v1) / 2) / 2) * 0.5, abs=EPS)
    assert sample.velocities[0] == pytest.approx(v1 / 2, abs=EPS)
    first = 0.0 + (0.0 + v1) / 2 * 1.0
    sample = traj.sample(TIME_NOW + 1.0)
    assert sample.segment == (0, 1)
    assert (sample.positions[0], sample.velocities[0]) == pytest.approx((first, v1), abs=EPS)
    if before_velocity is None:
        return  # upstream's strange_without_vel case ends here
    assert sample.accelerations[0] == pytest.approx(v2 - v1 / 1.0, abs=EPS)
    sample = traj.sample(TIME_NOW + 1.5)
    assert sample.positions[0] == pytest.approx(first + (v1 + ((v1 + v2) / 2 - v1) / 2) * 0.5)
    assert sample.velocities[0] == pytest.approx((v1 + v2) / 2, abs=EPS)
    second = first + (v1 + v2) / 2 * 1.0
    sample = traj.sample(TIME_NOW + 2.0)
    assert sample.segment == (1, 2)
    assert (sample.positions[0], sample.velocities[0]) == pytest.approx((second, v2), abs=EPS)
    assert sample.accelerations[0] == pytest.approx(v3 - v2 / 1.0, abs=EPS)
    third = second + (v2 + v3) / 2 * 1.0
    for time in (3.0, 3.125):  # the goal is reached: no acceleration any more
        sample = traj.sample(TIME_NOW + time)
        assert sample.segment == (2, 3)
        assert (sample.positions[0], sample.velocities[0]) == pytest.approx((third, v3), abs=EPS)
        assert sample.accelerations[0] == pytest.approx(0.0, abs=EPS)


def test_sample_trajectory_acceleration_with_interpolation():
    a1, a2, a3 = 1.0, 2.0, 1.0
    message = one_joint(
        message_point(1.0, accelerations=[a1]),
        message_point(2.0, accelerations=[a2]),
        message_point(3.0, accelerations=[a3]),
    )
    traj = SampledTrajectory.from_message(message, time=TIME_NOW, positions=[0.0], velocities=[0.0])
    sample = traj.sample(TIME_NOW)
    assert sample.segment == (0, 0)
    assert (sample.positions[0], sample.velocities[0], sample.accelerations[0]) == pytest.approx(
        (0.0, 0.0, 0.0), abs=EPS
    )
    assert traj.sample(TIME_NOW - 0.5) is None
    velocity, position = 0.0, 0.0
    for k, (time, (a_prev, a_next)) in enumerate(
        zip((1.0, 2.0, 3.0), ((0.0, a1), (a1, a2), (a2, a3)), strict=True)
    ):
        new_velocity = velocity + (a_prev + a_next) / 2 * 1.0
        position += (velocity + new_velocity) / 2 * 1.0
        velocity = new_velocity
        sample = traj.sample(TIME_NOW + time)
        assert sample.segment == ((k, k + 1) if k < 2 else (2, 3))
        assert (sample.positions[0], sample.velocities[0]) == pytest.approx(
            (position, velocity), abs=EPS
        )
        assert sample.accelerations[0] == pytest.approx(a_next, abs=EPS)
    sample = traj.sample(TIME_NOW + 3.125)  # past the points: the last point
    assert (sample.positions[0], sample.velocities[0], sample.accelerations[0]) == pytest.approx(
        (position, velocity, a3), abs=EPS
    )


def test_skip_interpolation():
    """interpolation_method none: the state before until the first point, then the next
    point. Upstream's empty velocities and accelerations are zeros in our samples (our
    desired state always has velocities)."""
    p1, p2, p3 = (message_point(t, [float(t)]) for t in (1.0, 2.0, 3.0))
    traj = SampledTrajectory.from_message(
        one_joint(p1, p2, p3), time=TIME_NOW, positions=[0.0], interpolation_method="none"
    )
    expected = {0.0: 0.0, 0.5: 0.0, 1.0: 2.0, 1.5: 2.0, 2.5: 3.0, 3.0: 3.0, 3.125: 3.0}
    for time, position in expected.items():
        sample = traj.sample(TIME_NOW + time)
        assert sample.positions[0] == pytest.approx(position, abs=EPS), time
        assert (sample.velocities[0], sample.accelerations[0]) == (0.0, 0.0)
    assert traj.sample(TIME_NOW - 0.5) is None
    assert traj.sample(TIME_NOW + 0.5).segment == (0, 0)
    assert traj.sample(TIME_NOW + 1.0).segment == (0, 1)


def test_fill_point_before_with_same_degree_as_traj():
    """Points with positions, velocities and accelerations, the state before with a
    position alone: quintic, so at the start velocity and acceleration are 0."""
    message = one_joint(
        message_point(1.0, [1.0], [0.0], [0.0]), message_point(2.0, [2.0], [0.0], [0.0])
    )
    traj = SampledTrajectory.from_message(message, time=TIME_NOW, positions=[0.0])
    sample = traj.sample(TIME_NOW)
    assert sample.segment == (0, 0)
    assert (sample.positions[0], sample.velocities[0], sample.accelerations[0]) == pytest.approx(
        (0.0, 0.0, 0.0), abs=EPS
    )


def test_update_trajectory():
    """Upstream's Trajectory::update replaces the message of a trajectory object and keeps
    its state before; ours are immutable, and a new message makes a new SampledTrajectory
    from the same state before: sampled as upstream's updated one."""
    p1, p2, p3 = (message_point(t, [float(t)]) for t in (1.0, 2.0, 3.0))
    first = SampledTrajectory.from_message(one_joint(p1, p2, p3), time=TIME_NOW, positions=[0.0])
    first.sample(TIME_NOW)
    assert first.sample(TIME_NOW + 2.5).segment == (1, 2)
    traj = SampledTrajectory.from_message(one_joint(p1, p2, p3), time=TIME_NOW, positions=[0.0])
    sample = traj.sample(TIME_NOW)
    assert sample.segment == (0, 0)
    assert sample.positions[0] == pytest.approx(0.0, abs=EPS)
    assert sample.velocities[0] == pytest.approx(1.0 - 0.0, abs=EPS)
    assert sample.accelerations[0] == pytest.approx(0.0, abs=EPS)
    sample = traj.sample(TIME_NOW + 1.5)
    assert sample.segment == (0, 1)
    assert sample.positions[0] == pytest.approx((1.0 + 2.0) / 2, abs=EPS)


def test_sample_velocity_only_skipped_last_segment_deduces_positions():
    """Regression test of upstream's #2282: p1 (position 0, velocity 1, also the state
    before), then velocity-only points at 2 s and 2.001 s; sampled at 1.5 s and then past
    the end, the sample has a position (here 0 + 1 * 1 + 1 * 0.001: the velocities
    integrated, deduce_from_derivatives)."""
    p1 = message_point(1.0, [0.0], [1.0])
    p2 = message_point(2.0, velocities=[1.0])
    p3 = message_point(2.001, velocities=[1.0])
    traj = SampledTrajectory.from_message(
        one_joint(p1, p2, p3), time=TIME_NOW, positions=[0.0], velocities=[1.0]
    )
    traj.sample(TIME_NOW)
    assert len(traj.sample(TIME_NOW + 1.5).positions) == 1
    sample = traj.sample(TIME_NOW + 3.0)
    assert sample is not None
    assert len(sample.positions) == 1
    assert sample.positions[0] == pytest.approx(1.0 + 0.001, abs=EPS)


# TestWrapAroundJoint (test_trajectory.cpp): wraparound_joint moves the state before the
# trajectory of each continuous joint to within pi of the first point.

WRAP_INITIAL = [0.0, 0.0, 0.0]
WRAP_NEXT = [math.pi * 3.0 / 2.0] * 3


def test_no_wraparound():
    current = wraparound_joint(WRAP_INITIAL, WRAP_NEXT, [False, False, False])
    assert current.tolist() == WRAP_INITIAL


def test_wraparound_single_joint():
    current = wraparound_joint(WRAP_INITIAL, WRAP_NEXT, [True, False, False])
    assert current.tolist() == [WRAP_INITIAL[0] + 2 * math.pi, WRAP_INITIAL[1], WRAP_INITIAL[2]]


def test_wraparound_all_joints():
    current = wraparound_joint(WRAP_INITIAL, WRAP_NEXT, [True, True, True])
    assert current.tolist() == [q + 2 * math.pi for q in WRAP_INITIAL]


def test_wraparound_all_joints_no_offset():
    current = wraparound_joint(WRAP_NEXT, WRAP_NEXT, [True, True, True])
    assert current.tolist() == WRAP_NEXT


# ----------------------------------------------------------------------------------------------
# test_trajectory_controller.cpp, through the controller manager


def harness(initial=(0.0, 0.0, 0.0), names=NAMES, **params) -> Harness:
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(names, initial_positions=initial),
        params=JointTrajectoryControllerParams(joints=list(names), **params),
    )
    return Harness(controller)


def trajectory(*points, names=NAMES, stamp=0.0):
    return JointTrajectory(stamp=stamp, joint_names=tuple(names), points=tuple(points))


def test_sample_at_t_plus_dt():
    """PR #1306 ("Sample at t + dT instead of the beginning of the control cycle"): halfway
    along a 1 s move at 100 Hz upstream writes 1.61, not 1.60."""
    h = harness(initial=(1.0, 1.0, 1.0))
    h.set_measured(np.array([1.0, 1.0, 1.0]))
    start = h.publish(trajectory(message_point(1.0, [2.2, 2.2, 2.2])))
    h.advance(start + 0.5)
    np.testing.assert_allclose(h.desired[:3], [1.0 + 1.2 * 0.51] * 3, atol=1e-12)
    # The update that accepts the goal already commands the sample at + dt.
    h2 = harness()
    first = h2.publish(trajectory(message_point(1.0, [1.0, 1.0, 1.0])))
    h2.advance(first)
    np.testing.assert_allclose(h2.desired[:3], [0.01] * 3, atol=1e-12)


def test_interpolation_method_none_commands_the_next_point():
    """test_trajectory.cpp's skip_interpolation, through the controller: points at 1, 2,
    3 s, commands written at the updates at 0.99, 1.49, 2.49 s (samples at 1.0, 1.5,
    2.5 s) are 2, 2, 3."""
    h = harness(interpolation_method="none")
    start = h.publish(trajectory(*(message_point(t, [t, t, t]) for t in (1.0, 2.0, 3.0))))
    for time, value in ((0.5, 0.0), (0.99, 2.0), (1.49, 2.0), (2.49, 3.0), (3.5, 3.0)):
        h.advance(start + time)
        np.testing.assert_allclose(h.desired[:3], [value] * 3, atol=1e-12, err_msg=str(time))


QUINTIC_AT_QUARTER = 10 * 0.25**3 - 15 * 0.25**4 + 6 * 0.25**5  # 0.1035: rest to rest
CUBIC_AT_QUARTER = 3 * 0.25**2 - 2 * 0.25**3  # 0.15625


@pytest.mark.parametrize(
    "state_interfaces",
    [["position"], ["position", "velocity"], ["position", "velocity", "acceleration"]],
)
def test_first_segment_has_the_trajectory_degree(state_interfaces):
    """set_point_before_trajectory_msg: the state before the trajectory gets zero velocities
    and accelerations where the first point has them, so a point with positions,
    velocities and accelerations makes a quintic first segment whatever the state
    interfaces (0.104 at a quarter, where a cubic gives 0.156)."""
    h = harness(state_interfaces=state_interfaces)
    start = h.publish(trajectory(message_point(1.0, [1.0] * 3, [0.0] * 3, [0.0] * 3)))
    h.advance(start + 0.25 - PERIOD)  # the command sampled at 0.25 s
    np.testing.assert_allclose(h.desired[:3], [QUINTIC_AT_QUARTER] * 3, atol=1e-12)
    assert abs(QUINTIC_AT_QUARTER - CUBIC_AT_QUARTER) > 0.05
    # And the first command's velocity starts from zero, not (p1 - p0) / T = 1.0.
    h2 = harness(state_interfaces=state_interfaces)
    first = h2.publish(trajectory(message_point(1.0, [1.0] * 3, [0.0] * 3)))
    h2.advance(first)
    np.testing.assert_allclose(h2.desired[3:], [6 * 0.01 - 6 * 0.01**2] * 3, atol=1e-12)


def test_first_segment_uses_the_measured_velocity_only_with_a_velocity_state_interface():
    measured_velocity = np.array([0.5, -0.5, 0.2])
    for interfaces, v0 in ((["position"], np.zeros(3)), (["position", "velocity"], None)):
        h = harness(state_interfaces=interfaces)
        h.set_measured(np.zeros(3), measured_velocity)
        start = h.publish(trajectory(message_point(1.0, [1.0] * 3, [0.0] * 3)))
        h.advance(start + 0.3)
        v0 = measured_velocity if v0 is None else v0
        expected = hermite(np.zeros(3), v0, np.ones(3), np.zeros(3), 1.0, 0.31)
        np.testing.assert_allclose(h.desired[:3], expected, atol=1e-12)


def test_partial_joint_list_first_segment_from_the_measured_state():
    """Joints left out of a partial goal: from the measured position (state before the
    trajectory) to the last command (fill_partial_goal)."""
    h = harness(
        initial=(0.1, 0.2, 0.3), allow_partial_joints_goal=True, state_interfaces=["position"]
    )
    measured = np.array([0.0, 0.5, 0.0])
    h.set_measured(measured)
    start = h.publish(trajectory(message_point(1.0, [2.0]), names=("j1",)))
    h.advance(start + 0.49)
    goal = np.array([0.1, 2.0, 0.3])
    np.testing.assert_allclose(h.desired[:3], measured + (goal - measured) * 0.5, atol=1e-12)


def test_ignore_old_trajectory():
    """Points [2, 3, 4] and [4, 5, 6] 0.5 s apart; at the first point a trajectory whose
    stamp makes it end 0.1 s in the past is rejected and the old one ends at [4, 5, 6]."""
    h = harness()
    start = h.publish(
        trajectory(message_point(0.5, [2.0, 3.0, 4.0]), message_point(1.0, [4, 5, 6]))
    )
    h.advance(start + 0.49)  # the command sampled at the first point
    np.testing.assert_allclose(h.desired[:3], [2.0, 3.0, 4.0], atol=1e-12)
    h.publish(trajectory(message_point(0.5, [-1.0, -2.0, -3.0]), stamp=h.time - 0.5 - 0.1))
    h.advance(start + 1.0)
    assert h.status.rejected == 1
    assert h.status.last_error.startswith("Received trajectory with non-zero start time")
    np.testing.assert_allclose(h.desired[:3], [4.0, 5.0, 6.0], atol=1e-12)


def test_ignore_partial_old_trajectory():
    """A trajectory whose first point is in the past and second in the future. Upstream's
    test expects it ignored, but only because its stamps are steady-clock times while the
    controller's now() is the system clock (so it ends "in the past" for the controller);
    upstream's code (validate_trajectory_msg rejects only a trajectory that *ends* in the
    past) accepts it and samples it from its current segment, and so do we: here the
    command jumps onto the segment from [-1, -2, -3] to [-2, -4, -6] and ends there."""
    h = harness()
    start = h.publish(
        trajectory(message_point(0.5, [2.0, 3.0, 4.0]), message_point(1.0, [4, 5, 6]))
    )
    h.advance(start + 0.49)
    np.testing.assert_allclose(h.desired[:3], [2.0, 3.0, 4.0], atol=1e-12)
    p0, p1 = np.array([-1.0, -2.0, -3.0]), np.array([-2.0, -4.0, -6.0])
    stamp = h.time - 0.5 - 0.1
    second = h.publish(trajectory(message_point(0.5, p0), message_point(1.0, p1), stamp=stamp))
    h.advance(second)
    assert h.status.accepted == 2
    fraction = (second + PERIOD - (stamp + 0.5)) / 0.5
    np.testing.assert_allclose(h.desired[:3], p0 + (p1 - p0) * fraction, atol=1e-12)
    h.advance(second + 0.5)
    np.testing.assert_allclose(h.desired[:3], p1, atol=1e-12)


THREE_POINTS = ([3.3, 4.4, 6.6], [7.7, 8.8, 9.9], [10.10, 11.11, 12.12])
THREE_VELOCITIES = ([0.01] * 3, [0.05] * 3, [0.06] * 3)


def test_no_timeout():
    """cmd_timeout 0: a second after three points 0.25 s apart (nonzero end velocity
    allowed) the last point is still commanded, with its velocity. Upstream keeps the
    trajectory active on the topic path; we report it succeeded and hold the last point,
    velocity included (README: a goal reached on the topic is reported succeeded)."""
    h = harness(cmd_timeout=0.0, allow_nonzero_velocity_at_trajectory_end=True)
    start = h.publish(
        trajectory(
            *(
                message_point(0.25 * (k + 1), p, v)
                for k, (p, v) in enumerate(zip(THREE_POINTS, THREE_VELOCITIES, strict=True))
            )
        )
    )
    h.advance(start + 1.0)
    np.testing.assert_allclose(h.desired[:3], THREE_POINTS[2], atol=1e-2)
    assert (h.desired[3:] > 0.0).all()
    assert h.status.state == "succeeded"


def test_jump_when_state_tracking_error_updated():
    """Closed loop (open_loop_control false): a new trajectory starts from the measured
    state, so with the arm 0.3 rad behind the command the first commands jump back
    towards it."""
    h = harness(allow_nonzero_velocity_at_trajectory_end=True)
    first, second = np.array([3.3, 4.4, 5.5]), np.array([6.6, 8.8, 11.0])
    start = h.publish(trajectory(message_point(1.0, first, first / 10)))
    h.advance(start + 1.1)
    np.testing.assert_allclose(h.desired[0], first[0], atol=1e-3)
    measured = first - 0.3
    h.set_measured(measured)
    start = h.publish(trajectory(message_point(1.0, second, second / 10)))
    h.advance(start)
    q = h.desired[0]
    assert abs(q - (measured[0] + (second[0] - measured[0]) * 0.01)) < 0.1
    for _ in range(2):
        assert measured[0] < h.desired[0] < first[0]
        h.step()
    assert measured[0] < h.desired[0] < first[0]
    h.advance(start + 1.1)
    np.testing.assert_allclose(h.desired[0], second[0], atol=1e-3)
    measured = second - 0.3
    h.set_measured(measured)
    start = h.publish(trajectory(message_point(1.0, first)))
    h.advance(start)
    np.testing.assert_allclose(
        h.desired[0], measured[0] + (first[0] - measured[0]) * 0.01, atol=1e-3
    )
    for _ in range(3):
        assert first[0] < h.desired[0] < measured[0]
        h.step()
    h.advance(start + 1.1)
    np.testing.assert_allclose(h.desired[0], first[0], atol=1e-3)


def test_execute_partial_traj_in_future():
    """A stamp in the future: the first segment runs from the state at acceptance to the
    first point at stamp + time_from_start."""
    h = harness()
    accepted = h.publish(trajectory(message_point(0.5, [1.0] * 3), stamp=1.0))
    h.advance(1.0)
    np.testing.assert_allclose(h.desired[:3], [(1.01 - accepted) / (1.5 - accepted)] * 3)


def test_state_tolerances_fail_then_hold_the_measured_position():
    """A path tolerance violated: aborted, then holding the measured position."""
    h = harness(trajectory_tolerance={"j0": 0.1, "j1": 0.1, "j2": 0.1})
    measured = np.array([0.0, 0.0, 0.0])
    start = h.publish(trajectory(message_point(0.2, [1.0, 1.0, 1.0])))
    h.advance(start + 0.2)
    assert h.status.state == "aborted"
    assert h.status.last_error.startswith("path tolerance violated")
    h.step()
    np.testing.assert_array_equal(h.desired, [*measured, 0.0, 0.0, 0.0])


def test_goal_tolerances_fail_then_hold_the_measured_position():
    """Outside the goal tolerance goal_time after the end: aborted, holding the measured
    position."""
    h = harness(goal_time=0.1, goal_tolerance={"j0": 0.1, "j1": 0.1, "j2": 0.1})
    measured = np.array([0.5, 0.5, 0.5])
    h.set_measured(measured)
    start = h.publish(trajectory(message_point(0.2, [1.0, 1.0, 1.0])))
    h.advance(start + 0.3)
    assert h.status.state == "executing"
    h.step()
    assert h.status.state == "aborted"
    assert h.status.last_error.startswith("goal tolerance violated")
    h.step()
    np.testing.assert_array_equal(h.desired, [*measured, 0.0, 0.0, 0.0])


def test_hold_on_startup():
    h = harness(initial=(0.1, 0.2, 0.3), state_interfaces=["position"])
    h.advance(0.25)
    np.testing.assert_array_equal(h.desired, [0.1, 0.2, 0.3, 0.0, 0.0, 0.0])


# (command_interfaces, state_interfaces) -> whether upstream's on_activate reads the positions
# from the command interfaces (update_state_from_command_interfaces, PR #2356: whenever the
# position command interface holds values)
OFFSET_CASES = [
    (["position"], ["position"], True),
    (["position"], ["position", "velocity"], True),
    (["position"], ["position", "velocity", "acceleration"], True),
    (["position", "velocity"], ["position"], True),
    (["position", "velocity"], ["position", "velocity"], True),
    (["position", "velocity"], ["position", "velocity", "acceleration"], True),
    (["position", "velocity", "acceleration"], ["position", "velocity", "acceleration"], True),
    (["velocity"], ["position", "velocity"], False),
    (["effort"], ["position", "velocity"], False),
]


@pytest.mark.parametrize("commands, states, from_commands", OFFSET_CASES)
def test_hw_states_has_offset_later_controller_start(commands, states, from_commands):
    """open_loop_control, the command interfaces holding values (3.1, 4.1, 5.1) that differ
    from the measured state: the positions at activation are the position command
    interface's whenever there is one; else the state interfaces'. Observed through the
    first trajectory's start (open loop: from that state) and the hold at activation."""
    initial = (3.1, 4.1, 5.1)
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(NAMES, initial_positions=initial),
        params=JointTrajectoryControllerParams(
            joints=list(NAMES),
            command_interfaces=commands,
            state_interfaces=states,
            open_loop_control=True,
            gains={joint: JointGains() for joint in NAMES},
        ),
    )
    h = Harness(controller)  # measured zeros at activation
    measured_at_activation = np.zeros(3)
    h.step()
    expected = np.array(initial) if from_commands else measured_at_activation
    np.testing.assert_allclose(h.desired[:3], expected, atol=1e-12)
    start = h.publish(trajectory(message_point(1.0, [10.0] * 3)))
    h.advance(start + 0.49)
    np.testing.assert_allclose(h.desired[:3], expected + (10.0 - expected) * 0.5, atol=1e-12)


def test_hw_states_has_offset_first_controller_start():
    """Command interfaces without values at the first start (upstream: NaN; here
    set_last_command_interface_value_as_state_on_activation: false makes activation ignore
    them): the state is read from the state interfaces."""
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(NAMES, initial_positions=(3.1, 4.1, 5.1)),
        params=JointTrajectoryControllerParams(
            joints=list(NAMES),
            state_interfaces=["position"],
            open_loop_control=True,
            set_last_command_interface_value_as_state_on_activation=False,
        ),
    )
    h = Harness(controller)
    h.step()
    np.testing.assert_array_equal(h.desired, [0.0] * 6)


def test_hold_on_startup_without_command_interface_values():
    """set_last_command_interface_value_as_state_on_activation: false -- the measured
    position at activation is held."""
    h = harness(
        initial=(0.1, 0.2, 0.3), set_last_command_interface_value_as_state_on_activation=False
    )
    h.set_measured(np.array([0.5, 0.4, 0.3]))
    h.advance(0.25)  # the harness was built with measured zeros: the t = 0 update read them
    np.testing.assert_array_equal(h.desired, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0])


def test_trajectory_replace_from_the_measured_state():
    h = harness()
    start = h.publish(trajectory(message_point(1.0, [1.0] * 3)))
    h.advance(start + 0.3)
    h.set_measured(np.array([0.3, 0.3, 0.3]))
    second = h.publish(trajectory(message_point(1.0, [-1.0] * 3)))
    h.advance(second + 0.49)
    np.testing.assert_allclose(h.desired[:3], [0.3 - 1.3 * 0.5] * 3, atol=1e-12)


def test_allow_nonzero_velocity_at_trajectory_end_true():
    """After the last point upstream keeps commanding it, its velocity included."""
    h = harness(allow_nonzero_velocity_at_trajectory_end=True)
    start = h.publish(trajectory(message_point(0.5, [1.0] * 3, [0.2, 0.3, 0.4])))
    h.set_measured(np.ones(3))
    h.advance(start + 1.0)
    np.testing.assert_allclose(h.desired, [1.0, 1.0, 1.0, 0.2, 0.3, 0.4], atol=1e-12)
    assert h.status.state == "succeeded"


def test_allow_nonzero_velocity_at_trajectory_end_false(caplog):
    h = harness()
    with caplog.at_level(logging.ERROR, logger="armando_drake.control.controllers"):
        h.publish(trajectory(message_point(0.5, [1.0] * 3, [0.2, 0.0, 0.0])))
        h.step()
    assert h.status.last_error == (
        "Velocity of last trajectory point of joint j0 is not zero: 0.200000000000000"
    )


def test_timeout_not_at_the_goal():
    """cmd_timeout: not at the goal cmd_timeout after the end -> hold the measured position."""
    h = harness(cmd_timeout=0.3, goal_tolerance={"j0": 0.01})
    measured = np.array([0.5, 0.0, 0.0])
    h.set_measured(measured)
    start = h.publish(trajectory(message_point(0.2, [1.0, 0.0, 0.0])))
    h.advance(start + 0.5)
    assert h.status.state == "executing"
    h.step(2)
    assert h.status.state == "aborted"
    assert h.status.last_error.startswith("Aborted due to command timeout")
    np.testing.assert_array_equal(h.desired, [*measured, 0.0, 0.0, 0.0])


@pytest.mark.parametrize("allowed", [False, True])
def test_allow_integration_in_goal_trajectories(allowed):
    """Velocity-only points: rejected without allow_integration_in_goal_trajectories,
    integrated with it (deduce_from_derivatives)."""
    h = harness(allow_integration_in_goal_trajectories=allowed)
    start = h.publish(
        trajectory(
            message_point(1.0, velocities=[1.0] * 3), message_point(2.0, velocities=[0.0] * 3)
        )
    )
    h.advance(start + 0.49)
    if not allowed:
        assert h.status.last_error == (
            "Mismatch between joint_names size (3) and positions (0) at point #0."
        )
        return
    # From rest at 0 the first point is at (0 + 1) / 2 * 1 s = 0.5 rad, reached with
    # 1 rad/s on a cubic: 0.125 rad at 0.5 s; the second at 0.5 + (1 + 0) / 2 = 1 rad.
    assert h.status.accepted == 1
    np.testing.assert_allclose(h.desired[:3], [0.125] * 3, atol=1e-12)
    h.advance(start + 2.5)
    np.testing.assert_allclose(h.desired, [1.0, 1.0, 1.0, 0.0, 0.0, 0.0], atol=1e-12)


def test_interpolate_from_desired_state():
    """interpolate_from_desired_state (open_loop_control): the next trajectory starts from
    the last command, not from the measured state."""
    for name in ("interpolate_from_desired_state", "open_loop_control"):
        h = harness(**{name: True})
        h.set_measured(np.array([-1.0, -1.0, -1.0]))  # the arm lags far behind
        start = h.publish(trajectory(message_point(1.0, [1.0] * 3)))
        h.advance(start + 0.49)
        np.testing.assert_allclose(h.desired[:3], [0.5] * 3, atol=1e-12)


def pid_harness(interface, gains, initial=(0.0, 0.0, 0.0)) -> Harness:
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(NAMES, initial_positions=initial),
        params=JointTrajectoryControllerParams(
            joints=list(NAMES),
            command_interfaces=[interface],
            state_interfaces=["position", "velocity"],
            gains={joint: JointGains(**gains) for joint in NAMES},
        ),
    )
    assert controller.interface == interface
    return Harness(controller)


def test_velocity_command_interface_is_the_pid_on_the_tracking_error():
    """command_interfaces [velocity]: u = ff_velocity_scale v_d(t + dt) + p (q_d(t) - q)
    + d (v_d(t) - v) (upstream's closed-loop adapter, use_closed_loop_pid_adapter)."""
    h = pid_harness("velocity", {"p": 2.0, "d": 0.1, "ff_velocity_scale": 1.0})
    measured_q, measured_v = np.array([0.1, -0.1, 0.0]), np.array([0.2, 0.0, -0.2])
    h.set_measured(measured_q, measured_v)
    # Holding the start (0) before any goal: the PID already runs.
    h.step()
    np.testing.assert_allclose(h.desired[3:], 2.0 * (0.0 - measured_q) + 0.1 * (0.0 - measured_v))
    start = h.publish(trajectory(message_point(1.0, [1.0] * 3)))
    h.advance(start + 0.5)
    # Linear from the measured position: q_d(t) and v_d.
    q_d = measured_q + (1.0 - measured_q) * 0.5
    v_d = 1.0 - measured_q
    np.testing.assert_allclose(
        h.desired[3:], 1.0 * v_d + 2.0 * (q_d - measured_q) + 0.1 * (v_d - measured_v), atol=1e-12
    )


def test_use_closed_loop_pid():
    """use_closed_loop_pid_adapter_: velocity alone (unless open_loop_control) or effort.
    Velocity alone with open_loop_control writes the desired velocity, no PID."""
    h = pid_harness("velocity", {"p": 2.0})
    h.set_measured(np.array([0.1, 0.1, 0.1]))
    h.step(2)
    np.testing.assert_allclose(h.desired[3:], [-0.2] * 3)  # the PID holding
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(NAMES),
        params=JointTrajectoryControllerParams(
            joints=list(NAMES),
            command_interfaces=["velocity"],
            state_interfaces=["position", "velocity"],
            open_loop_control=True,
            gains={joint: JointGains(p=2.0) for joint in NAMES},
        ),
    )
    h = Harness(controller)
    h.set_measured(np.array([0.1, 0.1, 0.1]))
    h.step(2)
    np.testing.assert_allclose(h.desired[3:], [0.0] * 3)  # no PID
    start = h.publish(trajectory(message_point(1.0, [1.1] * 3)))
    h.advance(start + 0.5)
    # v_d alone, open loop from the state held since activation (measured 0 then).
    np.testing.assert_allclose(h.desired[3:], [1.1] * 3, atol=1e-12)


def test_effort_command_interface_is_the_pid_and_checks_the_stopped_velocity():
    """command_interfaces [effort]: u = p e + d e_dot; with an effort command interface the
    stopped velocity tolerance is checked (upstream computes the velocity error then)."""
    h = pid_harness("effort", {"p": 10.0, "d": 1.0})
    h.set_measured(np.array([0.5, 0.5, 0.5]), np.array([0.0, 0.0, 0.3]))
    start = h.publish(trajectory(message_point(0.2, [0.5] * 3)))
    h.advance(start + 0.1)
    effort = h.system.GetOutputPort("effort_command").Eval(h.context)
    expected_q = 0.5  # from the measured position to the same: q_d = 0.5, v_d = 0
    np.testing.assert_allclose(
        effort, 10.0 * (expected_q - 0.5) + 1.0 * (0.0 - np.array([0, 0, 0.3]))
    )
    h.advance(start + 1.0)
    assert h.status.state == "executing"  # j2 still moves at 0.3 rad/s > 0.01
    h.set_measured(np.array([0.5, 0.5, 0.5]))
    h.step()
    assert h.status.state == "succeeded"


def effort_command(h: Harness) -> np.ndarray:
    return np.array(h.system.GetOutputPort("effort_command").Eval(h.context))


def test_effort_fields_feed_forward_with_the_effort_command_interface():
    """validate_trajectory_msg accepts efforts with the effort command interface; update()
    writes ff_velocity_scale v(t + dt) + effort(t + dt) + pid(error), the effort linear
    between points (interpolate_between_points' has_effort), the last point's effort held
    after the end and after success (set_success_trajectory_point)."""
    h = pid_harness("effort", {})  # no gains: the command is the feed-forward alone
    start = h.publish(
        trajectory(
            message_point(1.0, [0.0] * 3, effort=[2.0, 4.0, 6.0]),
            message_point(2.0, [0.0] * 3, effort=[4.0, 4.0, 4.0]),
        )
    )
    h.advance(start)
    assert h.status.state == "executing"
    # The state before the trajectory has the effort command interface's value (0 here).
    np.testing.assert_allclose(effort_command(h), [0.02, 0.04, 0.06], atol=1e-12)
    h.advance(start + 0.49)  # sampled at 0.5 s
    np.testing.assert_allclose(effort_command(h), [1.0, 2.0, 3.0], atol=1e-12)
    h.advance(start + 1.49)  # sampled at 1.5 s
    np.testing.assert_allclose(effort_command(h), [3.0, 4.0, 5.0], atol=1e-12)
    h.advance(start + 2.5)
    assert h.status.state == "succeeded"
    np.testing.assert_allclose(effort_command(h), [4.0, 4.0, 4.0], atol=1e-12)


def test_effort_first_segment_starts_from_the_effort_command():
    """Upstream reads the state's effort from the effort command interface
    (read_state_from_state_interfaces), so the first segment's effort runs from the last
    effort command (here the PID holding against an offset: 10 * 0.1 = 1) to the first
    point's; the PID adds nothing along a trajectory that stays at the measured position."""
    h = pid_harness("effort", {"p": 10.0})
    measured = np.array([-0.1, -0.1, -0.1])
    h.set_measured(measured)
    h.step()
    np.testing.assert_allclose(effort_command(h), [1.0] * 3, atol=1e-12)
    start = h.publish(trajectory(message_point(1.0, measured, effort=[2.0] * 3)))
    h.advance(start)
    np.testing.assert_allclose(effort_command(h), [1.0 + 1.0 * 0.01] * 3, atol=1e-12)
    h.advance(start + 0.49)
    np.testing.assert_allclose(effort_command(h), [1.5] * 3, atol=1e-12)


@pytest.mark.parametrize("interface", ["position", "velocity"])
def test_invalid_message_effort_without_the_effort_command_interface(interface):
    """invalid_message's "Effort is not supported in trajectory message" case: rejected
    unless the command interface is effort (has_effort_command_interface_)."""
    h = harness() if interface == "position" else pid_harness("velocity", {"p": 1.0})
    h.publish(trajectory(message_point(0.25, [1.0, 2.0, 3.0], effort=[1.0, 2.0, 3.0])))
    h.step()
    assert h.status.rejected == 1
    assert h.status.last_error == (
        "Trajectories with effort fields are only supported for controllers using the "
        "'effort' command interface."
    )


def test_invalid_message_too_few_efforts():
    """invalid_message's "too few efforts" case, with the effort command interface (upstream
    does not check the size; we reject it as the other fields' sizes, our stricter rule)."""
    h = pid_harness("effort", {})
    h.publish(trajectory(message_point(0.25, [1.0, 2.0, 3.0], effort=[1.0, 2.0])))
    h.step()
    assert h.status.last_error == (
        "Mismatch between joint_names size (3) and effort (2) at point #0."
    )


# ----------------------------------------------------------------------------------------------
# test_trajectory_controller.cpp with its fixture's inputs: the command interfaces start at
# INITIAL_POS_JOINTS (1.1, 2.1, 3.1), the state reads them (or, with separate command and
# state values, stays there), the fixture sets allow_nonzero_velocity_at_trajectory_end true
# and constraints.stopped_velocity_tolerance 0.

INITIAL_POS_JOINTS = (1.1, 2.1, 3.1)
COMMON_THRESHOLD = 0.0011
FIXTURE = {"allow_nonzero_velocity_at_trajectory_end": True, "stopped_velocity_tolerance": 0.0}
# (command_interfaces, state_interfaces) of upstream's position instantiations
POSITION_CASES = [
    (["position"], ["position"]),
    (["position"], ["position", "velocity"]),
    (["position"], ["position", "velocity", "acceleration"]),
    (["position", "velocity"], ["position"]),
    (["position", "velocity"], ["position", "velocity"]),
    (["position", "velocity"], ["position", "velocity", "acceleration"]),
    (["position", "velocity", "acceleration"], ["position"]),
    (["position", "velocity", "acceleration"], ["position", "velocity"]),
    (["position", "velocity", "acceleration"], ["position", "velocity", "acceleration"]),
]
# upstream's OnlyVelocity and OnlyEffort instantiations (the fixture's PID: p 0, ff 1)
PID_CASES = [
    (["velocity"], ["position", "velocity"]),
    (["velocity"], ["position", "velocity", "acceleration"]),
    (["effort"], ["position", "velocity"]),
    (["effort"], ["position", "velocity", "acceleration"]),
]
ALL_CASES = POSITION_CASES + PID_CASES


def case_id(case):
    return "-".join("".join(word[0] for word in side) for side in case)


def upstream_harness(commands=("position",), states=("position", "velocity"), p=0.0, **params):
    """Upstream's SetUpAndActivateTrajectoryController: measured = commanded = 1.1, 2.1,
    3.1 at activation."""
    gains = {}
    if commands in (["velocity"], ["effort"], ("velocity",), ("effort",)):
        gains = {name: JointGains(p=p, ff_velocity_scale=1.0) for name in NAMES}
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(NAMES, initial_positions=INITIAL_POS_JOINTS),
        params=JointTrajectoryControllerParams(
            joints=list(NAMES),
            command_interfaces=list(commands),
            state_interfaces=list(states),
            gains=gains,
            **{**FIXTURE, **params},
        ),
    )
    h = Harness(controller, measured=np.array(INITIAL_POS_JOINTS))
    h.step()
    return h


def commanded(h: Harness, interface: str) -> np.ndarray:
    """joint_pos_, joint_vel_ or joint_eff_: what the controller writes."""
    if interface == "position":
        return h.desired[:3]
    if interface == "velocity":
        return h.desired[3:]
    return np.array(h.system.GetOutputPort("effort_command").Eval(h.context))


def points_message(delay, positions, velocities=(), stamp=0.0, names=NAMES):
    """Upstream's publish(): point k at (k + 1) * delay."""
    return trajectory(
        *(
            message_point(delay * (k + 1), p, velocities[k] if velocities else (), ())
            for k, p in enumerate(positions)
        ),
        names=names,
        stamp=stamp,
    )


def accepted(h: Harness, message) -> bool:
    """validate_trajectory_msg, through the topic: whether the next update accepts it."""
    before = h.status.accepted
    h.publish(message)
    h.step()
    return h.status.accepted == before + 1


GOOD_POINT = message_point(0.25, [1.0, 2.0, 3.0], [-1.0, -2.0, -3.0])
INVALID_MESSAGES = {
    "incompatible joint names": trajectory(GOOD_POINT, names=("bad_name",)),
    "empty message": trajectory(),
    "no position data": trajectory(message_point(0.25, [], [-1.0, -2.0, -3.0])),
    "too few positions": trajectory(message_point(0.25, [1.0, 2.0], [-1.0, -2.0, -3.0])),
    "too many positions": trajectory(message_point(0.25, [1.0, 2.0, 3.0, 4.0], [-1, -2, -3])),
    "too few velocities": trajectory(message_point(0.25, [1.0, 2.0, 3.0], [1.0, 2.0])),
    "too few accelerations": trajectory(
        message_point(0.25, [1.0, 2.0, 3.0], [-1.0, -2.0, -3.0], [1.0, 2.0])
    ),
    "effort is not supported": trajectory(
        message_point(0.25, [1.0, 2.0, 3.0], [-1.0, -2.0, -3.0], effort=[1.0, 2.0, 3.0])
    ),
    "non-strictly increasing waypoint times": trajectory(GOOD_POINT, GOOD_POINT),
}


@pytest.mark.parametrize("case", list(INVALID_MESSAGES))
def test_invalid_message(case):
    """allow_partial_joints_goal and allow_integration_in_goal_trajectories false: the good
    message is accepted, each broken copy of it rejected."""
    h = upstream_harness(allow_partial_joints_goal=False)
    assert not accepted(h, INVALID_MESSAGES[case])
    assert h.status.rejected == 1
    assert accepted(h, trajectory(GOOD_POINT))


def test_invalid_message_end_time():
    """invalid_message's last two cases: a stamp of 1 ns ("End time in the past", the
    controller's clock long past it) is rejected; stamped now with the point at 10 s ("End
    time in the future") accepted."""
    h = upstream_harness()
    h.advance(1.0)
    assert not accepted(h, trajectory(GOOD_POINT, stamp=1e-9))
    assert h.status.last_error.startswith("Received trajectory with non-zero start time")
    assert accepted(h, trajectory(message_point(10.0, [1.0, 2.0, 3.0], [-1, -2, -3]), stamp=h.time))


def test_expect_invalid_when_message_with_nonzero_end_velocity_and_when_param_false():
    h = upstream_harness(allow_nonzero_velocity_at_trajectory_end=False)
    assert not accepted(h, trajectory())  # empty message: rejected, no exception
    assert not accepted(h, trajectory(GOOD_POINT))
    assert h.status.last_error.startswith("Velocity of last trajectory point of joint j0")


MISSING_POSITIONS = {
    "good": (message_point(0.25, [1.0, 2.0, 3.0], [-1.0, -2.0, -3.0], [1.0, 2.0, 3.0]), True),
    "no position data": (message_point(0.25, [], [-1.0, -2.0, -3.0], [1.0, 2.0, 3.0]), True),
    "no position and velocity data": (message_point(0.25, [], [], [1.0, 2.0, 3.0]), True),
    "all empty": (message_point(0.25), False),
    "too few positions": (message_point(0.25, [1.0, 2.0], [-1, -2, -3], [1, 2, 3]), False),
    "too many positions": (message_point(0.25, [1, 2, 3, 4], [-1, -2, -3], [1, 2, 3]), False),
    "too few velocities": (message_point(0.25, [1, 2, 3], [1.0], [1, 2, 3]), False),
    "too few accelerations": (message_point(0.25, [1, 2, 3], [-1, -2, -3], [2.0]), False),
}


@pytest.mark.parametrize("case", list(MISSING_POSITIONS))
def test_missing_positions_message_accepted(case):
    """allow_integration_in_goal_trajectories true: points without positions (or without
    positions and velocities) are accepted, all-empty points and wrong sizes are not."""
    point, valid = MISSING_POSITIONS[case]
    h = upstream_harness(allow_integration_in_goal_trajectories=True)
    assert accepted(h, trajectory(point)) == valid


@pytest.mark.parametrize("case", ALL_CASES, ids=case_id)
def test_jumbled_joint_order(case):
    """Joints [j1, j2, j0], positions [2, 3, 1], velocities (p - joint_pos) / dt and
    accelerations v / dt, dt 0.25 s: after 0.25 s the joints are at 1, 2, 3; the
    velocity, acceleration and effort commands are negative (all velocities are)."""
    commands, states = case
    h = upstream_harness(commands, states)
    dt = 0.25
    jumble = [1, 2, 0]
    positions = [[1.0, 2.0, 3.0][j] for j in jumble]
    velocities = [(p - INITIAL_POS_JOINTS[j]) / dt for p, j in zip(positions, jumble, strict=True)]
    accelerations = [v / dt for v in velocities]
    start = h.publish(
        trajectory(
            message_point(dt, positions, velocities, accelerations),
            names=tuple(NAMES[j] for j in jumble),
        )
    )
    h.advance(start + dt - PERIOD)  # the update whose command is the sample at dt
    if "position" in commands:
        np.testing.assert_allclose(commanded(h, "position"), [1.0, 2.0, 3.0], atol=COMMON_THRESHOLD)
    if "velocity" in commands:
        assert (commanded(h, "velocity") < 0.0).all()
    if "effort" in commands:
        assert (commanded(h, "effort") < 0.0).all()


def same_sign_or_zero(a, b):
    return a * b > 0.0 or (a == 0.0 and b == 0.0)


@pytest.mark.parametrize("case", ALL_CASES, ids=case_id)
def test_partial_joint_list(case):
    """allow_partial_joints_goal: joints [j1, j0] to [2, 1] with velocities (p - joint_pos)
    / dt and accelerations v / dt in 0.25 s; j2, not in the goal, stays at its command
    with zero velocity (and effort)."""
    commands, states = case
    h = upstream_harness(commands, states, allow_partial_joints_goal=True)
    dt = 0.25
    jumble = [1, 0]
    positions = [2.0, 1.0]
    velocities = [(p - INITIAL_POS_JOINTS[j]) / dt for p, j in zip(positions, jumble, strict=True)]
    accelerations = [v / dt for v in velocities]
    start = h.publish(
        trajectory(message_point(dt, positions, velocities, accelerations), names=("j1", "j0"))
    )
    h.advance(start + dt - PERIOD)
    if "position" in commands:
        np.testing.assert_allclose(
            commanded(h, "position"), [1.0, 2.0, INITIAL_POS_JOINTS[2]], atol=COMMON_THRESHOLD
        )
    for interface in ("velocity", "effort"):
        if interface in commands:
            command = commanded(h, interface)
            assert same_sign_or_zero(positions[0] - INITIAL_POS_JOINTS[1], command[0])
            assert same_sign_or_zero(positions[1] - INITIAL_POS_JOINTS[0], command[1])
            assert command[2] == pytest.approx(0.0, abs=COMMON_THRESHOLD)


@pytest.mark.parametrize("case", ALL_CASES, ids=case_id)
def test_partial_joint_list_not_allowed(case):
    """Without allow_partial_joints_goal the same partial goal is rejected: the commands
    stay at their initial values (velocities and efforts zero)."""
    commands, states = case
    h = upstream_harness(commands, states, allow_partial_joints_goal=False)
    start = h.publish(trajectory(message_point(0.25, [2.0, 1.0], [2.0, 1.0]), names=("j1", "j0")))
    h.advance(start + 0.25)
    assert h.status.last_error == "Joints on incoming trajectory don't match the controller joints."
    if "position" in commands:
        np.testing.assert_allclose(
            commanded(h, "position"), INITIAL_POS_JOINTS, atol=COMMON_THRESHOLD
        )
    for interface in ("velocity", "effort"):
        if interface in commands:
            np.testing.assert_allclose(commanded(h, interface), 0.0, atol=COMMON_THRESHOLD)


def test_trajectory_replace():
    """allow_partial_joints_goal: [2, 3, 4] with velocities [0.2, 0.3, 0.4] at 0.5 s is
    reached; then a partial goal for j0 alone, 1.5 with velocity copysign(0.15, 1.5 -
    q0): the result mixes the new goal and the old one, [1.5, 3, 4] with velocities
    [-0.15, 0, 0] (the measured state follows the commands, as upstream's fixture)."""
    h = upstream_harness(allow_partial_joints_goal=True)
    old, old_velocities = [2.0, 3.0, 4.0], [0.2, 0.3, 0.4]
    start = h.publish(points_message(0.5, [old], [old_velocities]))
    h.advance(start + 0.5)
    np.testing.assert_allclose(h.desired, old + old_velocities, atol=0.1)
    h.set_measured(h.desired[:3], h.desired[3:])
    velocity = math.copysign(0.15, 1.5 - h.desired[0])
    second = h.publish(points_message(0.5, [[1.5]], [[velocity]], names=("j0",)))
    h.advance(second + 0.5)
    np.testing.assert_allclose(h.desired, [1.5, 3.0, 4.0, -0.15, 0.0, 0.0], atol=0.1)


THREE = ([3.3, 4.4, 5.5], [7.7, 8.8, 9.9], [10.10, 11.11, 12.12])


@pytest.mark.parametrize("case", ALL_CASES, ids=case_id)
def test_state_tolerances_fail(case):
    """constraints.<joint>.trajectory 0.0001, the state stays at 1.1, 2.1, 3.1 (separate
    command and state values), kp 1: three points 0.1 s apart; after 0.1 s the path
    tolerance has aborted the goal and the command holds the measured position (zero
    velocity)."""
    commands, states = case
    tolerance = {name: 0.0001 for name in NAMES}
    h = upstream_harness(commands, states, p=1.0, trajectory_tolerance=tolerance)
    start = h.publish(points_message(0.1, THREE, THREE_VELOCITIES))
    h.advance(start + 0.1)
    assert h.status.state == "aborted"
    assert h.status.last_error.startswith("path tolerance violated")
    expect_command_point(h, commands, INITIAL_POS_JOINTS)


def expect_command_point(h: Harness, commands, positions, measured=INITIAL_POS_JOINTS):
    """Upstream's expectCommandPoint: without the PID, the position commands at
    ``positions`` and velocity commands zero; with it (velocity alone or effort), each
    command of the sign of ``positions - measured``, or zero where that is zero."""
    if list(commands) in (["velocity"], ["effort"]):
        command = commanded(h, commands[0])
        for j in range(3):
            assert same_sign_or_zero(positions[j] - measured[j], command[j]), (j, command)
        return
    if "position" in commands:
        np.testing.assert_allclose(commanded(h, "position"), positions, atol=COMMON_THRESHOLD)
    if "velocity" in commands:
        np.testing.assert_array_equal(commanded(h, "velocity"), [0.0, 0.0, 0.0])


@pytest.mark.parametrize("case", ALL_CASES, ids=case_id)
def test_goal_tolerances_fail(case):
    """constraints.<joint>.goal 0.1 and goal_time 1e-6, the state stays at 1.1, 2.1, 3.1:
    after the three points (0.4 s) the goal is aborted and the measured position held;
    the measured j0 then jumping to -3.3 does not move the hold."""
    commands, states = case
    tolerance = {name: 0.1 for name in NAMES}
    h = upstream_harness(commands, states, p=1.0, goal_tolerance=tolerance, goal_time=0.000001)
    start = h.publish(points_message(0.1, THREE, THREE_VELOCITIES))
    h.advance(start + 0.4)
    assert h.status.state == "aborted"
    assert h.status.last_error.startswith("goal tolerance violated")
    expect_command_point(h, commands, INITIAL_POS_JOINTS)
    measured = (-3.3, INITIAL_POS_JOINTS[1], INITIAL_POS_JOINTS[2])
    h.set_measured(np.array(measured))
    h.advance(start + 0.5)
    expect_command_point(h, commands, INITIAL_POS_JOINTS, measured)


def test_decline_false_cmd_timeout(caplog):
    """cmd_timeout 1.0 with constraints.goal_time 2.0: the timeout is off (get_cmd_timeout
    0), with upstream's warning."""
    with caplog.at_level(logging.WARNING, logger="armando_drake.control.controllers"):
        h = upstream_harness(cmd_timeout=1.0, goal_time=2.0)
    assert "Command timeout must be higher than goal_time tolerance (1.000000 vs. 2.000000)" in (
        caplog.text
    )
    # Off: far from the goal (goal tolerance 0.01) 1.5 s after the end nothing times out,
    # and goal_time aborts it after 2 s.
    h2 = upstream_harness(cmd_timeout=1.0, goal_time=2.0, goal_tolerance={"j0": 0.01})
    start = h2.publish(points_message(0.25, [[5.0, 2.1, 3.1]]))
    h2.advance(start + 0.25 + 1.5)
    assert h2.status.state == "executing"
    h2.advance(start + 0.25 + 2.1)
    assert h2.status.last_error.startswith("goal tolerance violated")
    assert h.status.state == "idle"


def test_accept_correct_cmd_timeout():
    """cmd_timeout 3.0 with goal_time 2.0 is kept; here it never fires first, goal_time
    does (so it is observed only through the absence of the warning)."""
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(NAMES),
        params=JointTrajectoryControllerParams(joints=list(NAMES), cmd_timeout=3.0, goal_time=2.0),
    )
    assert controller._cmd_timeout == 3.0  # upstream's get_cmd_timeout()


@pytest.mark.parametrize("case", ALL_CASES, ids=case_id)
def test_timeout(case):
    """cmd_timeout 0.1, kp 1, three points 0.25 s apart with velocities. After 0.75 s the
    trajectory is still running. Upstream's topic path then, 0.1 s after the end, replaces
    it with a hold of the measured position (zero velocity) whether or not the goal is
    reached. Ours (README: a goal reached on the topic is reported succeeded and the last
    point held, as for an action goal, whose success upstream holds too): with no goal
    tolerance and constraints.stopped_velocity_tolerance 0 (the fixture's) the goal is
    reached at the end and the last point held, so cmd_timeout, which only fires on a
    goal not reached (test_timeout_not_at_the_goal), does not follow. With position
    commands the commanded positions are upstream's (the last point); upstream's zero
    velocity command and, with the PID, its hold at 1.1, 2.1, 3.1 are not."""
    commands, states = case
    h = upstream_harness(commands, states, p=1.0, cmd_timeout=0.1)
    start = h.publish(points_message(0.25, THREE_POINTS, THREE_VELOCITIES))
    h.advance(start + 0.75 - 2 * PERIOD)
    assert h.status.state == "executing"
    h.advance(start + 1.0)
    assert h.status.state == "succeeded"
    np.testing.assert_allclose(h.desired[:3], THREE_POINTS[2], atol=COMMON_THRESHOLD)
    if "position" in commands:
        np.testing.assert_allclose(h.desired[3:], THREE_VELOCITIES[2], atol=1e-12)


@pytest.mark.parametrize("case", PID_CASES, ids=case_id)
def test_timeout_with_the_pid_not_at_the_goal(case):
    """test_timeout's PID instantiations with a goal tolerance (0.1) the arm, left at 1.1,
    2.1, 3.1, does not reach: 0.1 s after the end the measured position is held, every
    command 0 (upstream's expectCommandPoint(INITIAL_POS_JOINTS))."""
    commands, states = case
    tolerance = {name: 0.1 for name in NAMES}
    h = upstream_harness(commands, states, p=1.0, cmd_timeout=0.1, goal_tolerance=tolerance)
    start = h.publish(points_message(0.25, THREE_POINTS, THREE_VELOCITIES))
    h.advance(start + 0.75 - 2 * PERIOD)
    assert h.status.state == "executing"
    h.advance(start + 1.0)
    assert h.status.state == "aborted"
    assert h.status.last_error.startswith("Aborted due to command timeout")
    expect_command_point(h, commands, INITIAL_POS_JOINTS)


def test_no_jump_when_state_tracking_error_not_updated():
    """open_loop_control: with the measured position 0.3 behind the command, the next
    trajectory starts from the last command (no jump back), on to 6.6, then back to 3.3."""
    h = upstream_harness(open_loop_control=True)
    first, second = [3.3, 4.4, 5.5], [6.6, 8.8, 11.0]
    trajectory_frac = 0.01 / 1.0
    start = h.publish(points_message(1.0, [first]))
    h.advance(start + 1.1)
    np.testing.assert_allclose(h.desired[0], first[0], atol=COMMON_THRESHOLD)
    h.set_measured(np.array([first[0] - 0.3, *INITIAL_POS_JOINTS[1:]]))
    for goal, previous in ((second, first), (first, second)):
        start = h.publish(points_message(1.0, [goal]))
        h.advance(start)
        low, high = sorted((previous[0], goal[0]))
        np.testing.assert_allclose(
            h.desired[0],
            previous[0] + (goal[0] - previous[0]) * trajectory_frac,
            atol=COMMON_THRESHOLD,
        )
        for _ in range(3):
            assert low < h.desired[0] < high
            h.step()
        h.advance(start + 1.1)
        np.testing.assert_allclose(h.desired[0], goal[0], atol=COMMON_THRESHOLD)
        h.set_measured(np.array([goal[0] - 0.3, *INITIAL_POS_JOINTS[1:]]))


@pytest.mark.parametrize("case", POSITION_CASES, ids=case_id)
def test_correct_initialization_using_parameters(case):
    """After activation the commands are 1.1, 2.1, 3.1; three points 0.25 s apart (with
    velocities): at 0.25 s the command is within 0.05 of the first point. (Deactivation
    and cleanup are not modelled.)"""
    commands, states = case
    h = upstream_harness(commands, states)
    np.testing.assert_array_equal(h.desired[:3], INITIAL_POS_JOINTS)
    start = h.publish(points_message(0.25, THREE, THREE_VELOCITIES))
    h.advance(start + 0.25 - PERIOD)
    np.testing.assert_allclose(h.desired[:3], THREE[0], atol=0.05)


@pytest.mark.parametrize(
    "commands, states",
    [
        ([], ["position"]),
        (["bad_name"], ["position"]),
        (["effort", "position"], ["position"]),
        (["velocity", "acceleration"], ["position"]),
        (["acceleration"], ["position"]),
        (["position"], []),
        (["position"], ["effort"]),
        (["position"], ["bad_name"]),
        (["position"], ["velocity"]),
        (["position"], ["velocity", "acceleration"]),
        (["position"], ["acceleration"]),
        (["velocity"], ["position"]),
        (["velocity"], ["velocity"]),
        (["effort"], ["position"]),
        (["effort"], ["velocity"]),
    ],
)
def test_incorrect_initialization_using_interface_parameters(commands, states):
    """Each combination upstream refuses at init or configure is refused at loading, with
    an error naming the parameter. (Upstream's state cases keep the command interfaces of
    its previous case; here the other side is a valid [position].)"""
    text = CONFIG.replace(
        "    command_interfaces: [position]\n    state_interfaces: [position, velocity]\n",
        f"    command_interfaces: {json_list(commands)}\n"
        f"    state_interfaces: {json_list(states)}\n",
    )
    with pytest.raises(ControllerConfigError) as error:
        parse_controller_config(yaml.safe_load(text), "c.yaml")
    assert "_interfaces" in str(error.value)


def json_list(values):
    return "[" + ", ".join(values) + "]"


# ----------------------------------------------------------------------------------------------
# Parameters: implemented or refused


CONFIG = """
controller_manager:
  ros__parameters:
    update_rate: 100
    arm_controller: {type: joint_trajectory_controller/JointTrajectoryController}
arm_controller:
  ros__parameters:
    joints: [j0]
    command_interfaces: [position]
    state_interfaces: [position, velocity]
"""


@pytest.mark.parametrize(
    "extra, message",
    [
        ("is_async: true", "is_async: is_async=True is not simulated"),
        ("update_rate: 50", "update_rate: update_rate=50 differs from controller_manager's 100"),
        (
            "command_interfaces: [velocity]\nstate_interfaces: [position]",
            "'velocity' command interface can only be used alone if 'velocity' and 'position' "
            "state interfaces are present",
        ),
        (
            "command_interfaces: [effort]\nstate_interfaces: [position]",
            "'effort' command interface can only be used alone or with 'position' command "
            "interface if 'velocity' and 'position' state interfaces are present",
        ),
        ("command_interfaces: [acceleration]", "'acceleration' command interface can only be"),
        (
            "command_interfaces: [position, velocity, effort]",
            "'effort' command interface has to be used alone or with a 'position' interface",
        ),
        ("state_interfaces: [velocity]", "has no 'position' state interface"),
        ("interpolation_method: cubic", "interpolation_method='cubic' is not one of"),
        ("action_monitor_rate: 0.01", "action_monitor_rate=0.01 must be >= 0.1"),
    ],
)
def test_trajectory_parameters_refused_name_the_parameter(extra, message):
    text = CONFIG + "".join(f"    {line}\n" for line in extra.splitlines())
    with pytest.raises(ControllerConfigError) as error:
        parse_controller_config(yaml.safe_load(text), "c.yaml")
    assert message in str(error.value)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize(
    "extra, ignored",
    [
        ("bogus: 1", "bogus"),
        ("state_publish_rate: 100.0", "state_publish_rate"),  # Humble's, removed in Jazzy
        ("interface_name: position", "interface_name"),  # the forward controller's
        ("speed_scaling_interface_name: speed_scaling/factor", "speed_scaling_interface_name"),
        ("gains: {j9: {p: 1.0}}", "gains.j9"),  # not one of the joints (Jazzy's __map_joints)
        ("gains: {j0: {p: 1.0, normalize_error: true}}", "gains.j0.normalize_error"),
        ("constraints: {j7: {goal: 0.1}}", "constraints.j7"),
        ("constraints: {j0: {goal: 0.1, path: 0.2}}", "constraints.j0.path"),
    ],
)
def test_parameters_jazzy_does_not_declare_are_ignored_with_one_warning(extra, ignored, caplog):
    # As ROS: the controller's node takes undeclared parameters and never reads them.
    text = CONFIG + "".join(f"    {line}\n" for line in extra.splitlines())
    with caplog.at_level("WARNING", logger="armando_drake.control.config"):
        params = arm_controller_params(text)
    assert params.joints == ["j0"]
    assert [r.getMessage() for r in caplog.records] == [
        f"c.yaml: arm_controller.ros__parameters.{ignored}: "
        "joint_trajectory_controller/JointTrajectoryController (ROS 2 Jazzy) does not declare "
        "it; ignored, as ROS ignores it"
    ]


def arm_controller_params(text: str):
    """The typed parameters of ``arm_controller`` in the controller YAML ``text``."""
    return (
        parse_controller_config(yaml.safe_load(text), "c.yaml").controllers["arm_controller"].params
    )


def test_trajectory_parameters_accepted():
    text = CONFIG + (
        "    allow_integration_in_goal_trajectories: true\n"
        "    interpolate_from_desired_state: true\n"
        "    cmd_timeout: 2.0\n"
        "    speed_scaling: {initial_scaling_factor: 0.5}\n"
        "    gains: {j0: {p: 10.0, i: 0.1, d: 0.5, i_clamp: 1.0, ff_velocity_scale: 1.0}}\n"
        "    update_rate: 100\n"
    )
    params = arm_controller_params(text)
    assert params.allow_integration_in_goal_trajectories and params.from_desired_state
    assert params.cmd_timeout == 2.0 and params.gains["j0"].p == 10.0


# ----------------------------------------------------------------------------------------------
# test_tolerances.cpp / tolerances.hpp


def test_get_segment_tolerances_from_parameters():
    """tolerances.hpp's get_segment_tolerances(params), the defaults every goal on the
    topic gets: goal_time_tolerance = constraints.goal_time, per joint the state (path)
    position tolerance = constraints.<joint>.trajectory, the goal position tolerance =
    constraints.<joint>.goal and the goal velocity tolerance =
    constraints.stopped_velocity_tolerance."""
    text = CONFIG.replace("joints: [j0]", "joints: [j0, j1]") + (
        "    constraints:\n"
        "      goal_time: 2.0\n"
        "      stopped_velocity_tolerance: 0.02\n"
        "      j0: {trajectory: 0.2, goal: 1.1}\n"
        "      j1: {goal: 1.2}\n"
    )
    params = arm_controller_params(text)
    assert params.goal_time == 2.0
    assert params.stopped_velocity_tolerance == 0.02
    assert params.trajectory_tolerance == {"j0": 0.2}
    assert params.goal_tolerance == {"j0": 1.1, "j1": 1.2}


def test_check_state_tolerance_per_joint():
    """check_state_tolerance_per_joint: a tolerance is checked only when greater than 0,
    and violated only when |error| > tolerance. Open loop (the trajectory stays at the
    commanded 0): j0 exactly 0.5 from it with tolerance 0.5 is within, j1 5 rad away with
    tolerance 0 is unchecked; j0 a little further than 0.5 aborts."""
    h = harness(open_loop_control=True, trajectory_tolerance={"j0": 0.5, "j1": 0.0, "j2": 0.1})
    h.set_measured(np.array([0.5, 5.0, 0.0]))
    start = h.publish(trajectory(message_point(1.0, [0.0, 0.0, 0.0])))
    h.advance(start + 0.5)
    assert h.status.state == "executing"
    h.set_measured(np.array([0.5 + 1e-9, 5.0, 0.0]))
    h.step()
    assert h.status.state == "aborted"
    assert h.status.last_error.startswith("path tolerance violated: joint 'j0'")


# ----------------------------------------------------------------------------------------------
# test_forward_command_controller.cpp


def forward(**params):
    return ForwardCommandController(
        name="fwd",
        joints=ControllerJoints.make(("joint1", "joint2", "joint3")),
        params=ForwardCommandController.parameters(joints=["joint1", "joint2", "joint3"], **params),
    )


def test_CommandSuccessTest():  # noqa: N802 (upstream's name)
    """An update before any command keeps the defaults (1.1, 2.1, 3.1); then the command
    is written."""
    h = Harness(forward_with_initial("position"))
    h.step()
    np.testing.assert_array_equal(h.desired[:3], FWD_INITIAL)
    h.publish(Float64MultiArray(data=(10.0, 20.0, 30.0)))
    h.step()
    np.testing.assert_array_equal(h.desired[:3], [10.0, 20.0, 30.0])


def test_WrongCommandCheckTest():  # noqa: N802 (upstream's name)
    """Two values for three joints: nothing written, the defaults stay. Upstream's update
    returns ERROR (Jazzy then deactivates the controller); ours stays active with the
    previous command (README, stricter)."""
    h = Harness(forward_with_initial("position"))
    h.publish(Float64MultiArray(data=(10.0, 20.0)))
    h.step()
    np.testing.assert_array_equal(h.desired[:3], FWD_INITIAL)
    assert h.status.state == "holding"
    assert h.status.last_error == "command size (2) does not match number of interfaces (3)"


def test_DropInfiniteCommandCallbackTest():  # noqa: N802 (upstream's name)
    h = Harness(forward(interface_name="position"))
    h.publish(Float64MultiArray(data=(10.0, math.inf, 30.0)))
    h.step()
    np.testing.assert_array_equal(h.desired[:3], [0.0, 0.0, 0.0])
    assert h.status.last_error == "Non-finite value received. Dropping message"


@pytest.mark.parametrize(
    "params, message",
    [
        ("interface_name: position", "'joints' parameter is missing"),
        ("joints: []\n    interface_name: position", "joints=[] must not be empty"),
        ("joints: [j0]", "'interface_name' parameter is missing"),
        ("joints: [j0]\n    interface_name: ''", "interface_name='' is not one of"),
    ],
    ids=[
        "JointsParameterNotSet",
        "JointsParameterIsEmpty",
        "InterfaceParameterNotSet",
        "InterfaceParameterEmpty",
    ],
)
def test_forward_command_parameters(params, message):
    text = (
        "controller_manager:\n  ros__parameters:\n"
        "    fwd: {type: forward_command_controller/ForwardCommandController}\n"
        f"fwd:\n  ros__parameters:\n    {params}\n"
    )
    with pytest.raises(ControllerConfigError) as error:
        parse_controller_config(yaml.safe_load(text), "c.yaml")
    assert message in str(error.value)


FWD_JOINTS = ("joint1", "joint2", "joint3")
FWD_INITIAL = (1.1, 2.1, 3.1)  # upstream's command interfaces' initial values


def forward_config(params: str, type_name="forward_command_controller/ForwardCommandController"):
    text = (
        "controller_manager:\n  ros__parameters:\n"
        f"    fwd: {{type: {type_name}}}\n"
        f"fwd:\n  ros__parameters:\n{params}"
    )
    return parse_controller_config(yaml.safe_load(text), "c.yaml")


def configure_fails(params: str, type_name="forward_command_controller/ForwardCommandController"):
    with pytest.raises(ControllerConfigError) as error:
        forward_config(params, type_name)
    assert "\n" not in str(error.value)
    return str(error.value)


def test_JointsParameterNotSet():  # noqa: N802 (upstream's name)
    """test_forward_command_controller.cpp: interface_name 'dummy', no joints -> configure
    fails."""
    assert "'joints' parameter is missing" in configure_fails("    interface_name: dummy\n")


def test_InterfaceParameterNotSet():  # noqa: N802 (upstream's name)
    """joints [] and no interface_name -> configure fails (on the empty joints first, as
    upstream's on_configure checks joints before interface_name)."""
    assert "joints" in configure_fails("    joints: []\n")


def test_JointsParameterIsEmpty():  # noqa: N802 (upstream's name)
    message = configure_fails("    joints: []\n    interface_name: ''\n")
    assert "joints=[] must not be empty" in message


def test_InterfaceParameterEmpty():  # noqa: N802 (upstream's name)
    message = configure_fails("    joints: [joint1, joint2]\n    interface_name: ''\n")
    assert "interface_name='' is not one of 'position', 'velocity', 'effort'" in message


def test_ConfigureParamsSuccess():  # noqa: N802 (upstream's name)
    config = forward_config("    joints: [joint1, joint2]\n    interface_name: position\n")
    params = config.controllers["fwd"].params
    assert (params.joints, params.interface_name) == (["joint1", "joint2"], "position")


def forward_on(joints, interface_name, hardware_names=FWD_JOINTS, hardware_interface="position"):
    """A forward-command controller on ``joints`` activated in a controller manager whose
    hardware has ``hardware_names`` with ``hardware_interface``: activation is building
    the manager (it claims the joints' command interfaces)."""
    logic = ForwardCommandController(
        name="fwd",
        joints=ControllerJoints.make(joints),
        params=ForwardCommandController.parameters(
            joints=list(joints), interface_name=interface_name
        ),
    )
    return ControllerManager(
        hardware=bare_hardware(hardware_names, hardware_interface),
        update_rate=100,
        controllers=[ManagedController("fwd", logic)],
    )


def test_ActivateWithWrongJointsNamesFails():  # noqa: N802 (upstream's name)
    """'joint4' is not a joint of the hardware: activation fails. (Upstream's second half,
    joints [joint1, joint2] failing too, fails only because its fixture hands the
    controller three interfaces for two joints; a controller manager hands it those it
    claims, as ours does, so that half is not ported.)"""
    with pytest.raises(ValueError, match=r"claims \['joint4'\]"):
        forward_on(("joint1", "joint4"), "position")


def test_ActivateWithWrongInterfaceNameFails():  # noqa: N802 (upstream's name)
    """interface_name 'acceleration' on position joints: activation fails. Upstream
    configures it and fails at activation; our YAML loading refuses it already at
    configuration (no acceleration command interface is simulated; README, stricter)."""
    with pytest.raises(ValueError, match="commands the acceleration interface"):
        forward_on(FWD_JOINTS, "acceleration")
    message = configure_fails(
        "    joints: [joint1, joint2, joint3]\n    interface_name: acceleration\n"
    )
    assert "interface_name='acceleration' is not one of 'position', 'velocity'" in message


def test_ActivateSuccess():  # noqa: N802 (upstream's name)
    forward_on(FWD_JOINTS, "position")
    h = Harness(forward_with_initial("position"))
    assert h.status.state == "holding"


def forward_with_initial(interface_name, initial=FWD_INITIAL):
    return ForwardCommandController(
        name="fwd",
        joints=ControllerJoints.make(FWD_JOINTS, initial_positions=initial),
        params=ForwardCommandController.parameters(
            joints=list(FWD_JOINTS), interface_name=interface_name
        ),
    )


def test_NoCommandCheckTest():  # noqa: N802 (upstream's name)
    """An update with no command received: the command interfaces keep their values."""
    h = Harness(forward_with_initial("position"))
    h.step()
    np.testing.assert_array_equal(h.desired[:3], FWD_INITIAL)
    assert h.status.rejected == 0


def test_CommandCallbackTest():  # noqa: N802 (upstream's name)
    """A command published on the topic is written at the next update."""
    h = Harness(forward_with_initial("position"))
    np.testing.assert_array_equal(h.desired[:3], FWD_INITIAL)
    h.publish(Float64MultiArray(data=(10.0, 20.0, 30.0)))
    h.step()
    np.testing.assert_array_equal(h.desired[:3], [10.0, 20.0, 30.0])


# ----------------------------------------------------------------------------------------------
# position_controllers / velocity_controllers / effort_controllers test_joint_group_*.cpp

GROUP_TYPES = {
    "position": JointGroupPositionController,
    "velocity": JointGroupVelocityController,
    "effort": JointGroupEffortController,
}


def group_harness(interface) -> Harness:
    """Upstream's fixture gives the command interfaces 1.1, 2.1, 3.1; our position joints
    start at their initial positions (1.1, 2.1, 3.1 here), our velocity and effort command
    interfaces at 0 (the simulated hardware has no other initial velocity or effort
    command), so for those the "default values" are zeros."""
    logic = GROUP_TYPES[interface](
        name="fwd",
        joints=ControllerJoints.make(FWD_JOINTS, initial_positions=FWD_INITIAL),
        params=GROUP_TYPES[interface].parameters(joints=list(FWD_JOINTS)),
    )
    return Harness(logic)


def group_command(h: Harness, interface) -> np.ndarray:
    if interface == "position":
        return h.desired[:3]
    if interface == "velocity":
        return h.desired[3:]
    return np.array(h.system.GetOutputPort("effort_command").Eval(h.context))


def group_default(interface):
    return np.array(FWD_INITIAL) if interface == "position" else np.zeros(3)


@pytest.mark.parametrize("interface", list(GROUP_TYPES))
def test_joint_group_JointsParameterNotSet(interface):  # noqa: N802 (upstream's name)
    """test_joint_group_{position,velocity,effort}_controller.cpp JointsParameterNotSet."""
    message = configure_fails("    {}\n", GROUP_TYPES[interface].type_name())
    assert "'joints' parameter is missing" in message


@pytest.mark.parametrize("interface", list(GROUP_TYPES))
def test_joint_group_JointsParameterIsEmpty(interface):  # noqa: N802 (upstream's name)
    message = configure_fails("    joints: []\n", GROUP_TYPES[interface].type_name())
    assert "joints=[] must not be empty" in message


@pytest.mark.parametrize("interface", list(GROUP_TYPES))
def test_joint_group_ConfigureParamsSuccess(interface):  # noqa: N802 (upstream's name)
    config = forward_config(
        "    joints: [joint1, joint2, joint3]\n", GROUP_TYPES[interface].type_name()
    )
    assert config.controllers["fwd"].params.joints == list(FWD_JOINTS)


@pytest.mark.parametrize("interface", list(GROUP_TYPES))
def test_joint_group_ActivateWithWrongJointsNamesFails(interface):  # noqa: N802
    """joints [joint1, joint4]: 'joint4' is not a hardware joint, activation fails."""
    logic = GROUP_TYPES[interface](
        name="fwd",
        joints=ControllerJoints.make(("joint1", "joint4")),
        params=GROUP_TYPES[interface].parameters(joints=["joint1", "joint4"]),
    )
    with pytest.raises(ValueError, match=r"claims \['joint4'\]"):
        ControllerManager(
            hardware=bare_hardware(FWD_JOINTS, interface),
            update_rate=100,
            controllers=[ManagedController("fwd", logic)],
        )


@pytest.mark.parametrize("interface", list(GROUP_TYPES))
def test_joint_group_ActivateSuccess(interface):  # noqa: N802 (upstream's name)
    assert group_harness(interface).status.state == "holding"


@pytest.mark.parametrize("interface", list(GROUP_TYPES))
def test_joint_group_CommandSuccessTest(interface):  # noqa: N802 (upstream's name)
    """No command yet: the defaults stay; then [10, 20, 30] is written. (Our position,
    velocity and effort limits are infinite on the bare hardware, so nothing clamps.)"""
    h = group_harness(interface)
    h.step()
    np.testing.assert_array_equal(group_command(h, interface), group_default(interface))
    h.publish(Float64MultiArray(data=(10.0, 20.0, 30.0)))
    h.step()
    np.testing.assert_array_equal(group_command(h, interface), [10.0, 20.0, 30.0])


@pytest.mark.parametrize("interface", list(GROUP_TYPES))
def test_joint_group_WrongCommandCheckTest(interface):  # noqa: N802 (upstream's name)
    """A command of two values for three joints: rejected, the defaults stay. Upstream's
    update returns ERROR (Jazzy then deactivates the controller); ours stays active
    (README, stricter)."""
    h = group_harness(interface)
    h.publish(Float64MultiArray(data=(10.0, 20.0)))
    h.step()
    np.testing.assert_array_equal(group_command(h, interface), group_default(interface))
    assert h.status.last_error == "command size (2) does not match number of interfaces (3)"
    assert h.status.state == "holding"


@pytest.mark.parametrize("interface", list(GROUP_TYPES))
def test_joint_group_NoCommandCheckTest(interface):  # noqa: N802 (upstream's name)
    h = group_harness(interface)
    h.step(3)
    np.testing.assert_array_equal(group_command(h, interface), group_default(interface))


@pytest.mark.parametrize("interface", list(GROUP_TYPES))
def test_joint_group_CommandCallbackTest(interface):  # noqa: N802 (upstream's name)
    h = group_harness(interface)
    h.publish(Float64MultiArray(data=(10.0, 20.0, 30.0)))
    h.step()
    np.testing.assert_array_equal(group_command(h, interface), [10.0, 20.0, 30.0])


# ----------------------------------------------------------------------------------------------
# test_joint_state_broadcaster.cpp


def broadcaster(**params) -> JointStateBroadcaster:
    parameters = JointStateBroadcasterParameters(**params)
    check_parameters(JointStateBroadcasterParameters, parameters, given=params)
    joints = JointStateBroadcaster.joints_of(parameters) or ["joint1", "joint2", "joint3"]
    return JointStateBroadcaster(
        name="jsb", joints=ControllerJoints.make(joints), params=parameters
    )


def test_ActivateTest():  # noqa: N802 (upstream's name)
    """No joints, no interfaces: every joint, every interface."""
    jsb = broadcaster()
    message = jsb.message(1.0, [1.1, 2.1, 3.1], [0.1, 0.2, 0.3], [1.0, 2.0, 3.0])
    assert message.name == ("joint1", "joint2", "joint3")
    assert message.position == (1.1, 2.1, 3.1)
    assert message.velocity == (0.1, 0.2, 0.3)
    assert message.effort == (1.0, 2.0, 3.0)


def test_ActivateTestWithoutInterfacesParameter():  # noqa: N802 (upstream's name)
    """Joints given but no interfaces: upstream publishes all joints and interfaces."""
    params = JointStateBroadcasterParameters(joints=["joint1"])
    assert JointStateBroadcaster.joints_of(params) == []


def test_ActivateTestTwoJointsOneInterface():  # noqa: N802 (upstream's name)
    jsb = broadcaster(joints=["joint1", "joint3"], interfaces=["position"])
    message = jsb.message(0.0, [1.1, 3.1], [0.1, 0.3], [1.0, 3.0])
    assert message.name == ("joint1", "joint3")
    assert message.position == (1.1, 3.1)
    assert all(math.isnan(value) for value in message.velocity + message.effort)
    assert len(message.velocity) == len(message.effort) == 2


def test_ExtraJointStatePublishTest():  # noqa: N802 (upstream's name)
    jsb = broadcaster(extra_joints=["extra1", "extra2", "extra3"])
    message = jsb.message(0.0, [1.1, 2.1, 3.1], [0.1, 0.2, 0.3], [1.0, 2.0, 3.0])
    assert message.name == ("joint1", "joint2", "joint3", "extra1", "extra2", "extra3")
    assert message.position == (1.1, 2.1, 3.1, 0.0, 0.0, 0.0)
    assert message.velocity == (0.1, 0.2, 0.3, 0.0, 0.0, 0.0)
    assert message.effort == (1.0, 2.0, 3.0, 0.0, 0.0, 0.0)
