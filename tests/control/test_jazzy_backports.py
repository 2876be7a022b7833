"""Upstream's tests of what the current ``jazzy`` branches changed, re-expressed.

ros2_controllers ``jazzy`` (commit in the README) and control_toolbox ``jazzy`` (4.x) for the
ROS 2 controllers, control_toolbox ``noetic-devel`` for ROS 1's PID. Each test is named after
the upstream test it re-expresses, with the upstream file and test name in a comment; the
controller tests run the controller in a controller manager at 100 Hz (``Harness``), as
tests/control/test_upstream_ported.py does.
"""

import math

import numpy as np
import pytest
import yaml

from armando_drake.control.config import ControllerConfigError, parse_controller_config
from armando_drake.control.controllers import ControllerJoints, load_parameters, lookup
from armando_drake.control.controllers.joint_trajectory import (
    JointGains,
    JointTrajectoryController,
    JointTrajectoryControllerParams,
    SpeedScaling,
)
from armando_drake.control.controllers.multi_interface_forward_command import (
    MultiInterfaceForwardCommandParameters,
)
from armando_drake.control.controllers.pid_controller import PidControllerParameters, PidDofGains
from armando_drake.control.controllers.ros1 import JointPositionPidController, pid_command
from armando_drake.control.controllers.ros1 import PidGains as Ros1PidGains
from armando_drake.control.pid import Pid, PidGains
from armando_drake.messages.types import (
    Float64MultiArray,
    MultiDOFCommand,
    Publication,
    SpeedScalingFactor,
)
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import ScenarioError, load_scenario
from tests.control.test_controllers import NAMES, Harness
from tests.control.test_upstream_ported import message_point, trajectory

EPS = 1e-9  # control_toolbox's pid_tests.cpp threshold


def legacy(p, i, d, i_max, i_min, antiwindup=False) -> Pid:
    """control_toolbox's ``Pid(p, i, d, i_max, i_min, antiwindup)``: the legacy strategy."""
    if i_min > i_max:
        raise ValueError("received i_min > i_max")
    return Pid(
        PidGains(
            p=p, i=i, d=d, i_max=i_max, i_min=i_min, legacy_antiwindup=antiwindup,
            antiwindup_strategy="legacy",
        )
    )  # fmt: skip


def strategy(p, i, d, u_max, u_min, name, tracking_time_constant=0.0) -> Pid:
    """control_toolbox's ``Pid(p, i, d, u_max, u_min, AntiWindupStrategy)``."""
    return Pid(
        PidGains(
            p=p, i=i, d=d, u_max=u_max, u_min=u_min, antiwindup_strategy=name,
            tracking_time_constant=tracking_time_constant,
        )
    )  # fmt: skip


# ----------------------------------------------------------------------------------------------
# control_toolbox (jazzy) control_toolbox/test/pid_tests.cpp


def test_integrationClampTest():  # noqa: N802 (upstream's name)
    # pid_tests.cpp, ParameterTest.integrationClampTest
    pid = legacy(0.0, 1.0, 0.0, 1.0, -1.0)
    assert pid.compute_command(-10.03, 1.0) == -1.0
    assert pid.compute_command(30.0, 1.0) == 1.0


def test_integrationAntiwindupTest():  # noqa: N802 (upstream's name)
    # pid_tests.cpp, ParameterTest.integrationAntiwindupTest
    pid = legacy(0.0, 2.0, 0.0, 1.0, -1.0, True)
    for error, expected in ((-1.0, -1.0), (-1.0, -1.0), (0.5, 0.0), (-1.0, -1.0)):
        assert pid.compute_command(error, 1.0) == pytest.approx(expected, abs=EPS)


def test_negativeIntegrationAntiwindupTest():  # noqa: N802 (upstream's name)
    # pid_tests.cpp, ParameterTest.negativeIntegrationAntiwindupTest: a negative integral
    # gain is accepted.
    pid = legacy(0.0, -2.5, 0.0, 0.5, -0.2, True)
    for error, expected in ((0.1, -0.2), (0.1, -0.2), (-0.05, -0.075), (0.1, -0.2)):
        assert pid.compute_command(error, 1.0) == pytest.approx(expected, abs=EPS)


def test_ITermBadIBoundsTestConstructor():  # noqa: N802 (upstream's name)
    # pid_tests.cpp, ParameterTest.ITermBadIBoundsTestConstructor
    with pytest.raises(ValueError):
        legacy(1.0, 1.0, 1.0, -1.0, 1.0)


def test_integralOnlyTest():  # noqa: N802 (upstream's name)
    # pid_tests.cpp, CommandTest.integralOnlyTest
    pid = legacy(0.0, 1.0, 0.0, 5.0, -5.0)
    for error, expected in ((-0.5, -0.5), (-0.5, -1.0), (0.0, -1.0), (0.0, -1.0), (1.0, 0.0)):
        assert pid.compute_command(error, 1.0) == expected
    assert pid.compute_command(-0.5, 1.0) == -0.5
    pid.reset()
    assert pid.compute_command(0.0, 1.0) == 0.0
    assert pid.compute_command(-0.5, 1.0) == -0.5
    pid.reset(True)
    assert pid.compute_command(0.0, 1.0) == -0.5


def test_derivativeOnlyTest():  # noqa: N802 (upstream's name)
    # pid_tests.cpp, CommandTest.derivativeOnlyTest
    pid = legacy(0.0, 0.0, 1.0, math.inf, -math.inf)
    steps = ((-0.5, 1.0, -0.5), (-0.5, 1.0, 0.0), (-0.5, 0.1, 0.0), (-1.0, 1.0, -0.5))
    for error, dt, expected in (*steps, (-0.5, 1.0, 0.5)):
        assert pid.compute_command(error, dt) == expected


def test_completePIDTest():  # noqa: N802 (upstream's name)
    # pid_tests.cpp, CommandTest.completePIDTest
    pid = legacy(1.0, 1.0, 1.0, 5.0, -5.0)
    assert pid.compute_command(-0.5, 1.0) == -1.5
    assert pid.compute_command(-0.5, 1.0) == -1.5
    assert pid.compute_command(-1.0, 1.0) == -3.5


def test_outputClampTest():  # noqa: N802 (upstream's name)
    # pid_tests.cpp, ParameterTest.outputClampTest
    pid = strategy(1.0, 0.0, 0.0, 1.0, -1.0, "back_calculation")
    for error, expected in ((0.5, 0.5), (1.0, 1.0), (2.0, 1.0), (100.0, 1.0), (-0.5, -0.5)):
        assert pid.compute_command(error, 1.0) == expected
    for error in (-1.0, -2.0, -10.0, -100.0):
        assert pid.compute_command(error, 1.0) == -1.0


def test_backCalculationPIDTest():  # noqa: N802 (upstream's name)
    # pid_tests.cpp, CommandTest.backCalculationPIDTest
    pid = strategy(0.0, 1.0, 0.0, 5.0, -5.0, "back_calculation", 1.0)
    steps = [(1.0, 1.0, 0.0), (2.0, 3.0, 1.0), (3.0, 6.0, 3.0), (1.0, 6.0, 5.0)]
    steps += [(2.0, 7.0, 5.0), (-1.0, 4.0, 5.0), (1.0, 5.0, 4.0)]
    for error, i_term, command in steps:
        assert pid.compute_command(error, 1.0) == command
        assert pid.get_current_pid_errors()[1] == i_term


def test_conditionalIntegrationPIDTest():  # noqa: N802 (upstream's name)
    # pid_tests.cpp, CommandTest.conditionalIntegrationPIDTest
    pid = strategy(0.0, 1.0, 0.0, 5.0, -5.0, "conditional_integration", 1.0)
    steps = [(1.0, 1.0, 0.0), (2.0, 3.0, 1.0), (3.0, 6.0, 3.0), (1.0, 6.0, 5.0)]
    steps += [(2.0, 6.0, 5.0), (-1.0, 5.0, 5.0), (0.0, 5.0, 5.0)]
    for error, i_term, command in steps:
        assert pid.compute_command(error, 1.0) == command
        assert pid.get_current_pid_errors()[1] == i_term


# ----------------------------------------------------------------------------------------------
# control_toolbox (noetic-devel) test/pid_tests.cpp: ROS 1's PID (pid_command)


def test_ros1_negativeIntegrationAntiwindupTest():  # noqa: N802 (upstream's name)
    # control_toolbox noetic-devel, pid_tests.cpp, ParameterTest.negativeIntegrationAntiwindupTest:
    # the integrated error is bounded to minmax(i_min / i, i_max / i).
    gains = Ros1PidGains(p=0.0, i=-2.5, d=0.0, i_clamp_min=-0.2, i_clamp_max=0.5, antiwindup=True)
    integral = 0.0
    for error, expected in ((0.1, -0.2), (0.1, -0.2), (-0.05, -0.075), (0.1, -0.2)):
        command, integral = pid_command(gains, error, 0.0, integral, 1.0)
        assert command == pytest.approx(expected, abs=1e-12)


def test_ros1_integrationAntiwindupTest():  # noqa: N802 (upstream's name)
    # control_toolbox noetic-devel, pid_tests.cpp, ParameterTest.integrationAntiwindupTest
    gains = Ros1PidGains(p=0.0, i=2.0, d=0.0, i_clamp=1.0, antiwindup=True)
    integral = 0.0
    for error, expected in ((-1.0, -1.0), (-1.0, -1.0), (0.5, 0.0), (-1.0, -1.0)):
        command, integral = pid_command(gains, error, 0.0, integral, 1.0)
        assert command == pytest.approx(expected, abs=1e-12)


def test_ros1_negative_gains_accepted():
    # control_toolbox noetic-devel, pid.cpp Pid::init: p, i and d are read as given, negative
    # ones too (negativeIntegrationAntiwindupTest's i = -2.5).
    params = load_parameters(
        JointPositionPidController, {"joint": "j0", "pid": {"p": 1.0, "i": -2.5, "d": -0.5}}
    )
    assert (params.pid.p, params.pid.i, params.pid.d) == (1.0, -2.5, -0.5)


# ----------------------------------------------------------------------------------------------
# ros2_controllers (jazzy) joint_trajectory_controller: the gains' schema and update_pids


CONFIG = """
controller_manager:
  ros__parameters:
    update_rate: 100
    arm_controller: {type: joint_trajectory_controller/JointTrajectoryController}
arm_controller:
  ros__parameters:
    joints: [j0]
    command_interfaces: [effort]
    state_interfaces: [position, velocity]
"""


def arm_params(extra: str = ""):
    text = CONFIG + "".join(f"    {line}\n" for line in extra.splitlines())
    config = parse_controller_config(yaml.safe_load(text), "c.yaml")
    return config.controllers["arm_controller"].params


def pid_trajectory_controller(interface="effort", **gains) -> Harness:
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(NAMES),
        params=JointTrajectoryControllerParams(
            joints=list(NAMES),
            command_interfaces=[interface],
            state_interfaces=["position", "velocity"],
            gains={joint: JointGains(**gains) for joint in NAMES},
        ),
    )
    return Harness(controller)


def test_gains_defaults_update_pids():
    # joint_trajectory_controller_parameters.yaml (gains.__map_joints: i_clamp .inf,
    # antiwindup_strategy legacy) and joint_trajectory_controller.cpp update_pids(): with the
    # defaults the integral term is not bounded, so an i gain alone acts.
    params = arm_params("gains: {j0: {p: 0.0, i: 2.0, antiwindup_strategy: legacy}}")
    gains = params.gains["j0"]
    assert gains.i_clamp == math.inf and gains.antiwindup_strategy == "legacy"
    pid = gains.pid_gains()
    assert (pid.i_max, pid.i_min) == (math.inf, -math.inf)
    h = pid_trajectory_controller(i=2.0)
    h.set_measured(np.array([-0.5, -0.5, -0.5]))
    h.step(10)
    # i dt e per update, e = 0.5, dt = 10 ms: ten updates integrate 10 * 2 * 0.01 * 0.5.
    np.testing.assert_allclose(
        h.system.GetOutputPort("effort_command").Eval(h.context), [0.1] * 3, atol=1e-12
    )


def test_gains_i_clamp_update_pids():
    # joint_trajectory_controller.cpp update_pids(): i_clamp_max / i_clamp_min have
    # precedence over the deprecated i_clamp where finite.
    pid = JointGains(i_clamp=2.0, i_clamp_max=1.0).pid_gains()
    assert (pid.i_max, pid.i_min) == (1.0, -2.0)


@pytest.mark.parametrize("name", ["legacy", "none", "back_calculation", "conditional_integration"])
def test_gains_antiwindup_strategy_one_of(name):
    # joint_trajectory_controller_parameters.yaml, gains.<joint>.antiwindup_strategy one_of<>
    assert (
        arm_params(f"gains: {{j0: {{p: 1.0, antiwindup_strategy: {name}}}}}")
        .gains["j0"]
        .antiwindup_strategy
        == name
    )
    with pytest.raises(ControllerConfigError, match="antiwindup_strategy"):
        arm_params("gains: {j0: {p: 1.0, antiwindup_strategy: clamp}}")


def test_use_closed_loop_pid_negative_gain():
    # control_toolbox accepts negative gains (pid_tests.cpp negativeIntegrationAntiwindupTest);
    # the trajectory controller's gains too.
    assert arm_params("gains: {j0: {p: 1.0, i: -2.5}}").gains["j0"].i == -2.5


def test_trajectory_controller_u_clamp():
    # control_toolbox pid.cpp compute_command: the output clamped to [u_clamp_min, u_clamp_max]
    h = pid_trajectory_controller(p=10.0, u_clamp_max=1.0, u_clamp_min=-2.0)
    h.set_measured(np.array([-1.0, 0.05, 1.0]))
    h.step()
    np.testing.assert_allclose(
        h.system.GetOutputPort("effort_command").Eval(h.context), [1.0, -0.5, -2.0], atol=1e-12
    )


def test_trajectory_message_pid_keeps_tracking():
    # sanity: the trajectory tracked through the PID (test_trajectory_controller.cpp
    # use_closed_loop_pid) with the new gains.
    h = pid_trajectory_controller("velocity", p=1.0)
    start = h.publish(trajectory(message_point(1.0, [1.0] * 3)))
    h.advance(start + 0.5)
    assert h.status.state == "executing"


# ----------------------------------------------------------------------------------------------
# ros2_controllers (jazzy) test_trajectory_controller.cpp: the start-up hold (PR #2356)

# Upstream's position instantiations whose state interfaces are not all commanded: the
# older rule read the state interfaces there, PR #2356 the position command interface.
HOLD_CASES = [
    (["position"], ["position", "velocity"]),
    (["position"], ["position", "velocity", "acceleration"]),
    (["position", "velocity"], ["position", "velocity", "acceleration"]),
]
INITIAL_POS_CMD = (3.1, 4.1, 5.1)  # upstream's initial_pos_cmd: 3.1 + i


@pytest.mark.parametrize("commands, states", HOLD_CASES)
def test_hw_states_has_offset_later_controller_start(commands, states):
    # test_trajectory_controller.cpp, test_hw_states_has_offset_later_controller_start:
    # interpolate_from_desired_state, the command interfaces holding 3.1 + i, the state
    # interfaces elsewhere: with a position command interface the state at activation has
    # the commanded positions, whatever the state interfaces.
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(NAMES, initial_positions=INITIAL_POS_CMD),
        params=JointTrajectoryControllerParams(
            joints=list(NAMES),
            command_interfaces=commands,
            state_interfaces=states,
            interpolate_from_desired_state=True,
        ),
    )
    h = Harness(controller)  # the state interfaces read 0
    h.step()
    np.testing.assert_allclose(h.desired[:3], INITIAL_POS_CMD, atol=1e-12)
    start = h.publish(trajectory(message_point(1.0, [10.0] * 3)))
    h.advance(start + 0.49)
    expected = np.array(INITIAL_POS_CMD) + (10.0 - np.array(INITIAL_POS_CMD)) * 0.5
    np.testing.assert_allclose(h.desired[:3], expected, atol=1e-12)


@pytest.mark.parametrize("commands, states", HOLD_CASES)
def test_hold_on_startup(commands, states):
    # test_trajectory_controller.cpp, hold_on_startup (activation holds the position read
    # by update_state_from_command_interfaces): the commanded positions, not the measured.
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(NAMES, initial_positions=(0.1, 0.2, 0.3)),
        params=JointTrajectoryControllerParams(
            joints=list(NAMES), command_interfaces=commands, state_interfaces=states
        ),
    )
    h = Harness(controller)
    h.set_measured(np.array([0.5, 0.4, 0.3]))
    h.advance(0.25)
    np.testing.assert_allclose(h.desired[:3], [0.1, 0.2, 0.3], atol=1e-12)


# ----------------------------------------------------------------------------------------------
# ros2_controllers (jazzy) command_interfaces [position, effort] (PR #1200)

CONFIG_INTERFACES = CONFIG.replace("    command_interfaces: [effort]\n", "")


def interfaces_config(commands, states):
    text = CONFIG_INTERFACES.replace(
        "    state_interfaces: [position, velocity]\n",
        f"    command_interfaces: [{', '.join(commands)}]\n"
        f"    state_interfaces: [{', '.join(states)}]\n",
    )
    return parse_controller_config(yaml.safe_load(text), "c.yaml")


@pytest.mark.parametrize(
    "commands, states",
    [
        (["effort", "velocity"], ["position", "velocity"]),
        (["effort", "acceleration"], ["position", "velocity"]),
        (["effort", "velocity", "acceleration"], ["position", "velocity"]),
        (["effort", "position"], ["position"]),
        (["effort", "position"], ["velocity"]),
    ],
)
def test_incorrect_initialization_using_interface_parameters(commands, states):
    # test_trajectory_controller.cpp, incorrect_initialization_using_interface_parameters:
    # effort has to be alone or with position, and then needs position and velocity states.
    with pytest.raises(ControllerConfigError, match="_interfaces"):
        interfaces_config(commands, states)


@pytest.mark.parametrize(
    "commands, states",
    [
        (["position", "effort"], ["position", "velocity"]),
        (["position", "effort"], ["position", "velocity", "acceleration"]),
        (["effort", "position"], ["position", "velocity"]),
        (["position", "acceleration"], ["position"]),
    ],
)
def test_correct_initialization_using_parameters(commands, states):
    # test_trajectory_controller.cpp, correct_initialization_using_parameters, with the
    # PositionEffortTrajectoryControllers instantiation; validate_jtc_parameters.hpp allows
    # acceleration with position alone too.
    config = interfaces_config(commands, states)
    assert config.controllers["arm_controller"].params.command_interfaces == commands


def position_effort_harness(states=("position", "velocity")) -> Harness:
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(NAMES, initial_positions=(1.1, 2.1, 3.1)),
        params=JointTrajectoryControllerParams(
            joints=list(NAMES),
            command_interfaces=["position", "effort"],
            state_interfaces=list(states),
            allow_nonzero_velocity_at_trajectory_end=True,
            stopped_velocity_tolerance=0.0,
        ),
    )
    assert controller.interface == "position" and controller.effort_output
    h = Harness(controller, measured=np.array([1.1, 2.1, 3.1]))
    h.step()
    return h


POINTS = [[3.3, 4.4, 6.6], [7.7, 8.8, 9.9], [10.10, 11.11, 12.12]]
EFFORT = [[0.3, 0.4, 0.6], [1.7, 1.8, 1.9], [2.10, 2.11, 2.12]]


@pytest.mark.parametrize(
    "states", [("position", "velocity"), ("position", "velocity", "acceleration")]
)
def test_position_error_not_angle_wraparound(states):
    # test_trajectory_controller.cpp, position_error_not_angle_wraparound, the
    # PositionEffortTrajectoryControllers instantiation: the positions go to the position
    # command interface (one step before the first point, the point), the effort command is
    # the reference's effort, no PID ("u = ff for feed forward effort").
    h = position_effort_harness(states)
    start = h.publish(
        trajectory(*(message_point(0.3 * (k + 1), POINTS[k], effort=EFFORT[k]) for k in range(3)))
    )
    h.advance(start + 0.3 - 0.01)
    np.testing.assert_allclose(h.desired[:3], POINTS[0], atol=0.0011)
    h.advance(start + 0.3)
    effort = h.system.GetOutputPort("effort_command").Eval(h.context)
    np.testing.assert_allclose(effort, EFFORT[0], atol=0.0011)


def test_invalid_message_effort_with_position_effort():
    # test_trajectory_controller.cpp, invalid_message: efforts are allowed whenever there is
    # an effort command interface (has_effort_command_interface_), [position, effort] too.
    h = position_effort_harness()
    h.publish(trajectory(message_point(0.25, [1.0, 2.0, 3.0], effort=[1.0, 2.0, 3.0])))
    h.step()
    assert (h.status.rejected, h.status.state) == (0, "executing")


# ----------------------------------------------------------------------------------------------
# ros2_controllers (jazzy) constraints.decelerate_on_cancel (backport #2222)

INITIAL = np.array([1.1, 2.1, 3.1])  # upstream's INITIAL_POS_JOINTS
MAX_DECEL = 10.0  # [rad/s^2]


def decelerating(
    initial_vel, commands=("position",), states=("position", "velocity"), run=True, **params
):
    """Upstream's decelerate_to_hold_position fixture: cmd_timeout 0.1 s, decelerate_on_cancel
    with every joint's max_deceleration_on_cancel 10, the URDF's velocity limit 0.2 rad/s;
    the state stays at INITIAL_POS_JOINTS with ``initial_vel``. A trajectory to a point
    0.5 rad away with a goal tolerance: the goal is not reached (ours times out only a goal
    not reached, README), so cmd_timeout aborts 0.1 s after its end."""
    settings = {
        "cmd_timeout": 0.1,
        "decelerate_on_cancel": True,
        "max_deceleration_on_cancel": {name: MAX_DECEL for name in NAMES},
        "goal_tolerance": {name: 0.01 for name in NAMES},
        **params,
    }
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(NAMES, velocity=[0.2] * 3, initial_positions=INITIAL),
        params=JointTrajectoryControllerParams(
            joints=list(NAMES),
            command_interfaces=list(commands),
            state_interfaces=list(states),
            **settings,
        ),
    )
    h = Harness(controller, measured=INITIAL)
    h.set_measured(INITIAL, np.array(initial_vel, dtype=float))
    start = h.publish(trajectory(message_point(0.25, INITIAL + 0.5)))
    if not run:
        return h
    h.advance(start + 0.25 + 0.1 + 0.05)
    assert h.status.state == "aborted"
    assert h.status.last_error.startswith("Aborted due to command timeout")
    return h


def stopped_at(initial_vel) -> np.ndarray:
    v = np.array(initial_vel, dtype=float)
    return INITIAL + np.where(v >= 0.0, 1.0, -1.0) * v * v / (2.0 * MAX_DECEL)


@pytest.mark.parametrize(
    "initial_vel",
    [[0.2, 0.2, 0.2], [-0.2, -0.2, -0.2], [0.2, -0.1, 0.0]],
    ids=["positive_velocity", "negative_velocity", "per_joint_calculation"],
)
def test_decelerate_to_hold_position(initial_vel):
    # test_trajectory_controller.cpp, decelerate_to_hold_position_positive_velocity,
    # _negative_velocity and _per_joint_calculation: after the ramp (0.2 / 10 = 0.02 s) the
    # command is p0 + sign(v0) v0^2 / (2 max_decel), zero velocity.
    h = decelerating(initial_vel)
    h.step(10)
    np.testing.assert_allclose(h.desired[:3], stopped_at(initial_vel), atol=1e-12)
    np.testing.assert_allclose(h.desired[3:], 0.0, atol=1e-12)


def test_decelerate_to_hold_position_ramp():
    # joint_trajectory_controller.cpp decelerate_to_hold_position: the stop trajectory's
    # points, one per update period from the update after the abort: p0 + v0 t - a t^2 / 2,
    # v0 - a t; the command at an update is the sample one period ahead.
    h = decelerating([1.0, 1.0, 1.0], commands=("position", "velocity"), run=False)
    while h.status.state != "aborted":
        h.step()
    h.step()  # the stop trajectory's first update: the point at t = dt
    dt = 0.01
    np.testing.assert_allclose(h.desired[:3], INITIAL + dt - 0.5 * MAX_DECEL * dt**2, atol=1e-12)
    np.testing.assert_allclose(h.desired[3:], 1.0 - MAX_DECEL * dt, atol=1e-12)
    h.step(20)  # 1 m/s lasts 0.1 s; the hold is p0 + 1 / 20
    np.testing.assert_allclose(h.desired[:3], INITIAL + 0.05, atol=1e-12)


def test_decelerate_to_hold_position_velocity_command_ramps_to_zero():
    # test_trajectory_controller.cpp, decelerate_to_hold_position_velocity_command_ramps_to_zero
    h = decelerating([0.2, 0.2, 0.2], commands=("position", "velocity"))
    h.step(10)
    np.testing.assert_allclose(h.desired[3:], 0.0, atol=0.0011)
    np.testing.assert_allclose(h.desired[:3], stopped_at([0.2] * 3), atol=1e-12)


@pytest.mark.parametrize(
    "states, params",
    [
        (("position",), {}),
        (("position", "velocity"), {"max_deceleration_on_cancel": {}}),
    ],
    ids=["no_velocity_state", "zero_max_decel"],
)
def test_decelerate_to_hold_position_fallback(states, params):
    # test_trajectory_controller.cpp, decelerate_to_hold_position_fallback_no_velocity_state
    # and _fallback_zero_max_decel: the measured position is held.
    h = decelerating([0.2, 0.2, 0.2], states=states, **params)
    h.step(10)
    np.testing.assert_allclose(h.desired[:3], INITIAL, atol=1e-12)


def test_decelerate_on_cancel_parameters():
    # joint_trajectory_controller_parameters.yaml: constraints.decelerate_on_cancel and
    # constraints.<joint>.max_deceleration_on_cancel (gt_eq 0).
    params = arm_params(
        "constraints: {decelerate_on_cancel: true, j0: {max_deceleration_on_cancel: 2.0}}"
    )
    assert params.decelerate_on_cancel and params.max_deceleration_on_cancel == {"j0": 2.0}
    with pytest.raises(ControllerConfigError, match="max_deceleration_on_cancel"):
        arm_params("constraints: {j0: {max_deceleration_on_cancel: -1.0}}")


# ----------------------------------------------------------------------------------------------
# ros2_controllers (jazzy) speed_scaling.* (backport #2105)


def scaled_harness(factor, commands=("position",)) -> Harness:
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(NAMES),
        params=JointTrajectoryControllerParams(
            joints=list(NAMES),
            command_interfaces=list(commands),
            speed_scaling=SpeedScaling(initial_scaling_factor=factor),
            goal_tolerance={name: 0.01 for name in NAMES},
            goal_time=0.2,
        ),
    )
    return Harness(controller)


def test_scaling_factor_from_param():
    # test_trajectory_controller.cpp, scaling_factor_from_param (the factor read from
    # speed_scaling.initial_scaling_factor is in effect), observed as update() uses it:
    # traj_time_ += period * scaling_factor_, the command sampled at traj_time_ + period.
    assert arm_params(
        "command_interfaces: [position]\nspeed_scaling: {initial_scaling_factor: 0.123}"
    ).speed_scaling.initial_scaling_factor == pytest.approx(0.123)
    h = scaled_harness(0.5)
    start = h.publish(trajectory(message_point(1.0, [1.0] * 3)))
    h.advance(start + 0.5)  # 50 updates: the trajectory's time is 0.25 s
    np.testing.assert_allclose(h.desired[:3], [0.25 + 0.01] * 3, atol=1e-9)
    h.advance(start + 1.5)  # 0.75 s
    np.testing.assert_allclose(h.desired[:3], [0.75 + 0.01] * 3, atol=1e-9)
    assert h.status.state == "executing"


def test_scaling_factor_zero_stops_the_trajectory():
    # joint_trajectory_controller.cpp set_scaling_factor: 0.0 is allowed ("0.0 should work
    # as an edge case", setting_scaling_factor_works_correctly): the trajectory's time stands.
    h = scaled_harness(0.0)
    start = h.publish(trajectory(message_point(1.0, [1.0] * 3)))
    h.advance(start + 2.0)
    np.testing.assert_allclose(h.desired[:3], [0.01] * 3, atol=1e-9)
    assert h.status.state == "executing"


def test_scaling_factor_only_for_position_interfaces():
    # joint_trajectory_controller.cpp on_configure: "Speed scaling is currently only supported
    # for position interfaces": with another command interface the factor is 1.0.
    h = scaled_harness(0.5, commands=("position", "velocity"))
    start = h.publish(trajectory(message_point(1.0, [1.0] * 3)))
    h.advance(start + 0.5)
    np.testing.assert_allclose(h.desired[:3], [0.51] * 3, atol=1e-9)


def _robot_with_ros2_control(gpio: str = ""):
    """What check_hardware_interfaces reads of a robot: its <ros2_control> blocks."""
    import xml.etree.ElementTree as ET
    from types import SimpleNamespace

    from armando_drake.description.ros2_control import parse_ros2_control

    xml = (
        '<robot name="r"><link name="a"/><link name="b"/><joint name="j0" type="revolute">'
        '<parent link="a"/><child link="b"/><limit lower="-1" upper="1" effort="1" '
        'velocity="1"/></joint><ros2_control name="hw" type="system"><hardware><plugin>p'
        '</plugin></hardware><joint name="j0"><command_interface name="position"/></joint>'
        f"{gpio}</ros2_control></robot>"
    )
    return SimpleNamespace(ros2_control=parse_ros2_control(ET.fromstring(xml)))


def test_wrong_scaling_state_interface_parameter_controller_fails_activation():
    # test_trajectory_controller.cpp, wrong_scaling_state_interface_parameter_controller_fails_
    # activation (and the command interface's): an interface the hardware does not declare
    # fails the activation; one its <ros2_control> declares (a GPIO) is held at its value.
    from armando_drake.control.stack import check_hardware_interfaces
    from armando_drake.tools.errors import ScenarioError

    scaling = '<gpio name="speed_scaling"><state_interface name="factor"/></gpio>'
    for name in ("state_interface", "command_interface"):
        text = CONFIG + f"    command_interfaces: [position]\n    speed_scaling: {{{name}: x/y}}\n"
        controller = parse_controller_config(yaml.safe_load(text), "c.yaml").controllers[
            "arm_controller"
        ]
        with pytest.raises(ScenarioError, match=f"speed_scaling.{name}: 'x/y' is not an interface"):
            check_hardware_interfaces(controller, _robot_with_ros2_control(scaling), "")
    text = CONFIG + "    speed_scaling: {state_interface: speed_scaling/factor}\n"
    controller = parse_controller_config(yaml.safe_load(text), "c.yaml").controllers[
        "arm_controller"
    ]
    check_hardware_interfaces(controller, _robot_with_ros2_control(scaling), "")
    with pytest.raises(ControllerConfigError, match="initial_scaling_factor"):
        arm_params("command_interfaces: [position]\nspeed_scaling: {initial_scaling_factor: -1}")


# ----------------------------------------------------------------------------------------------
# ros2_controllers (jazzy) forward_command_controller test_multi_interface_forward_command_
# controller.cpp (MultiInterfaceForwardCommandControllerTest)

MULTI = "forward_command_controller/MultiInterfaceForwardCommandController"


def multi_config(params: str):
    text = (
        "controller_manager:\n  ros__parameters:\n    update_rate: 100\n"
        f"    multi: {{type: {MULTI}}}\n"
        f"multi:\n  ros__parameters: {params}\n"
    )
    return parse_controller_config(yaml.safe_load(text), "c.yaml")


@pytest.mark.parametrize(
    "params, message",
    [
        ("{interface_names: []}", "joint='' must not be empty"),
        ("{joint: ''}", "joint='' must not be empty"),
        ("{joint: joint1, interface_names: []}", r"interface_names=\[\] must not be empty"),
        ("{joint: joint1}", r"interface_names=\[\] must not be empty"),
    ],
    ids=[
        "JointsParameterNotSet",
        "JointsParameterIsEmpty",
        "InterfaceParameterEmpty",
        "InterfaceParameterNotSet",
    ],
)
def test_multi_interface_parameters(params, message):
    # JointsParameterNotSet, InterfaceParameterNotSet, JointsParameterIsEmpty,
    # InterfaceParameterEmpty: configure fails.
    with pytest.raises(ControllerConfigError, match=message):
        multi_config(params)


def test_multi_interface_ConfigureParamsSuccess():  # noqa: N802 (upstream's name)
    config = multi_config("{joint: joint1, interface_names: [position, velocity, effort]}")
    params = config.controllers["multi"].params
    assert (params.joint, params.interface_names) == ("joint1", ["position", "velocity", "effort"])


def test_multi_interface_ActivateWithWrongInterfaceNameFails():  # noqa: N802
    # 'acceleration' is not a command interface of the simulated joint.
    with pytest.raises(ControllerConfigError, match="acceleration"):
        multi_config("{joint: joint1, interface_names: [position, velocity, acceleration]}")


def multi_harness():
    controller = lookup(MULTI)(
        name="ctl",
        joints=ControllerJoints.make(["joint1"], initial_positions=[1.1]),
        params=MultiInterfaceForwardCommandParameters(
            joint="joint1", interface_names=["position", "velocity", "effort"]
        ),
    )
    return Harness(controller)


def multi_commands(h: Harness) -> list[float]:
    effort = h.system.GetOutputPort("effort_command").Eval(h.context)
    return [float(h.desired[0]), float(h.desired[1]), float(effort[0])]


def test_multi_interface_CommandSuccessTest():  # noqa: N802 (upstream's name)
    # CommandSuccessTest / CommandCallbackTest: each value to its interface.
    h = multi_harness()
    assert multi_commands(h) == [1.1, 0.0, 0.0]  # NoCommandCheckTest: nothing written
    h.publish(Float64MultiArray(data=(10.0, 20.0, 30.0)))
    h.step()
    assert multi_commands(h) == [10.0, 20.0, 30.0]


def test_multi_interface_WrongCommandCheckTest():  # noqa: N802 (upstream's name)
    h = multi_harness()
    h.publish(Float64MultiArray(data=(10.0, 20.0)))
    h.step()
    assert multi_commands(h) == [1.1, 0.0, 0.0]
    assert h.status.last_error == "command size (2) does not match number of interfaces (3)"


# ----------------------------------------------------------------------------------------------
# ros2_controllers (jazzy) joint_state_broadcaster test_joint_state_broadcaster.cpp


def broadcaster_params(raw: dict):
    return load_parameters(lookup("joint_state_broadcaster/JointStateBroadcaster"), raw)


def test_TestCustomInterfaceMappingIgnoredWhenVelocityInterfaceIsRequested(caplog):  # noqa: N802
    # TestCustomInterfaceMappingIgnoredWhenVelocityInterfaceIsRequested: velocity is listed in
    # interfaces, so its mapping to derived_velocity is ignored (configure succeeds, warns).
    params = broadcaster_params(
        {
            "joints": ["joint1"],
            "interfaces": ["velocity"],
            "map_interface_to_joint_state": {"velocity": "derived_velocity"},
        }
    )
    broadcaster = lookup("joint_state_broadcaster/JointStateBroadcaster")(
        name="jsb", joints=ControllerJoints.make(["joint1"]), params=params
    )
    message = broadcaster.message(0.0, [1.0], [2.0], [3.0])
    assert math.isnan(message.position[0]) and message.velocity == (2.0,)
    assert "Mapping from 'derived_velocity' to interface 'velocity' will not be done" in (
        caplog.text
    )


def test_TestCustomInterfaceWithoutMapping():  # noqa: N802 (upstream's name)
    # A mapping to an interface the joints do not have maps nothing: accepted.
    params = broadcaster_params({"map_interface_to_joint_state": {"position": "custom"}})
    assert params.map_interface_to_joint_state.position == "custom"


def test_JointStatePublishTestLocalTopic():  # noqa: N802 (upstream's name)
    # JointStatePublishTestLocalTopic: use_local_topics publishes on ~/joint_states.
    assert broadcaster_params({"use_local_topics": True}).use_local_topics


# ----------------------------------------------------------------------------------------------
# ros2_controllers (jazzy) pid_controller test_pid_controller.cpp (PidControllerTest), its
# pid_controller_params.yaml (antiwindup_strategy none for every joint)


def pid_controller(set_first=True, **gains) -> Harness:
    gains = {"p": 1.0, "i": 2.0, "d": 3.0, "antiwindup_strategy": "none", **gains}
    controller = lookup("pid_controller/PidController")(
        name="ctl",
        joints=ControllerJoints.make(["joint1"]),
        params=PidControllerParameters(
            dof_names=["joint1"],
            command_interface="position",
            reference_and_state_interfaces=["position"],
            set_current_state_as_first_setpoint=set_first,
            gains={"joint1": PidDofGains(**gains)},
        ),
    )
    return Harness(controller, measured=np.array([1.1]))  # dof_state_values_


def test_update_logic_feedforward_off():
    # test_update_logic_feedforward_off: ref 101.101, state 1.1, dt 0.01: p 100.001 +
    # d 3 * 10000.1 (the PID's own derivative), no integral at the first update.
    h = pid_controller()
    h.publish(MultiDOFCommand(dof_names=("joint1",), values=(101.101,), values_dot=(math.nan,)))
    h.step()
    assert h.desired[0] == pytest.approx(30100.301, abs=1e-5)


def test_update_logic_angle_wraparound_on():
    # test_update_logic_angle_wraparound_on: error wrap(10.0 - 1.1) = 8.9 - 2 pi.
    h = pid_controller(angle_wraparound=True)
    h.publish(MultiDOFCommand(values=(10.0,)))
    h.step()
    assert h.desired[0] == pytest.approx(787.6612219, abs=1e-5)


def test_activate_set_current_state_as_first_setpoint_false():
    # test_activate_set_current_state_as_first_setpoint_false: no reference, nothing written.
    h = pid_controller(set_first=False)
    h.step(3)
    assert h.desired[0] == 0.0  # the initial command, untouched
    h = pid_controller()
    h.step(3)
    assert h.desired[0] == pytest.approx(0.0)  # reference = state: zero error


def test_pid_controller_all_parameters_set_configure_success():
    # all_parameters_set_configure_success, from a YAML as pid_controller_params.yaml's.
    text = (
        "controller_manager:\n  ros__parameters:\n    update_rate: 100\n"
        "    pid: {type: pid_controller/PidController}\n"
        "pid:\n  ros__parameters:\n    dof_names: [joint1]\n    command_interface: position\n"
        "    reference_and_state_interfaces: [position]\n"
        "    gains: {joint1: {p: 1.0, i: 2.0, d: 3.0, u_clamp_max: 5.0, u_clamp_min: -5.0}}\n"
    )
    params = parse_controller_config(yaml.safe_load(text), "c.yaml").controllers["pid"].params
    assert params.gains["joint1"].u_clamp_max == 5.0 and params.set_current_state_as_first_setpoint


def publish_on(h: Harness, topic: str, message) -> None:
    """Publishes ``message`` on the controller's further input ``topic``."""
    port = h.system.GetInputPort(f"ctl.{topic}")
    count = port.Eval(h.context).count if port.HasValue(h.context) else 0
    port.FixValue(h.context, Publication(count + 1, message))


def test_setting_scaling_factor_works_correctly(caplog):
    # test_trajectory_controller.cpp, setting_scaling_factor_works_correctly: factors from
    # ~/speed_scaling_input (0.0 too) take effect; a negative one is ignored with a warning.
    h = scaled_harness(1.0)
    publish_on(h, "speed_scaling_input", SpeedScalingFactor(0.5))
    h.step()
    start = h.publish(trajectory(message_point(1.0, [1.0] * 3)))
    h.advance(start + 0.5)
    np.testing.assert_allclose(h.desired[:3], [0.25 + 0.01] * 3, atol=1e-9)
    publish_on(h, "speed_scaling_input", SpeedScalingFactor(-0.12))
    h.step(10)  # still 0.5: 0.05 s more of the trajectory's time
    np.testing.assert_allclose(h.desired[:3], [0.30 + 0.01] * 3, atol=1e-9)
    assert "Scaling factor has to be greater or equal to 0.0 - Ignoring input!" in caplog.text
    publish_on(h, "speed_scaling_input", SpeedScalingFactor(0.0))
    h.step(10)  # the trajectory's time stands from the next update on
    np.testing.assert_allclose(h.desired[:3], [0.30 + 0.01] * 3, atol=1e-9)


def scenario_world(extra: str):
    scenario = load_scenario(
        "position",
        "sequencer: null\nlogging: {console_rate: 0}\n"
        "controllers: {activate: [joint_state_broadcaster, trajectory_controller], "
        + extra
        + "}\n",
    )
    return MakeWorld(scenario, quiet=True)


def test_scaling_factor_from_scenario():
    # scaling_factor_from_param, set from the scenario: controllers.speed_scaling overrides the
    # YAML's speed_scaling.initial_scaling_factor; the world subscribes speed_scaling_input.
    world = scenario_world("speed_scaling: {trajectory_controller: 0.5}")
    (managed,) = world.robot().stack.manager.controllers
    assert managed.logic.initial_memory().speed_scaling == 0.5
    assert world.robot().stack.manager.HasInputPort("trajectory_controller.speed_scaling_input")
    world.close()
    with pytest.raises(ScenarioError, match="controllers.speed_scaling"):
        scenario_world("speed_scaling: {position_controller: 0.5}")
