"""The simulated world with ros2_control controllers (the Gazebo + controller_manager step)."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from armando_drake.messages.types import Float64MultiArray, JointTrajectory, JointTrajectoryPoint
from armando_drake.outputs.logger import read_joint_states
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import ScenarioError, load_scenario

SEED_TARGETS = [
    [0.0, 0.0, 0.0, 0.0],
    [1.2, -1.0, 1.2, 0.6],
    [-1.2, 1.0, -1.2, -0.6],
    [0.6, 0.0, -0.6, 1.0],
]
JOINTS = ("j0", "j1", "j2", "j3")


def world_of(name: str, overrides: str = "", **kwargs):
    scenario = load_scenario(name, "logging: {console_rate: 0}\n" + overrides)
    world = MakeWorld(scenario, quiet=True, **kwargs)
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    return world, simulator


def test_without_controllers_the_arm_falls():
    world, simulator = world_of("world")
    context = simulator.get_mutable_context()
    q0 = world.joint_positions(context).copy()
    simulator.AdvanceTo(2.0)
    moved = np.abs(world.joint_positions(context) - q0)
    assert moved.max() > 0.3, f"joints moved only {moved} rad in 2 s"


def test_position_control_reaches_the_seed_targets_without_overshoot(tmp_path):
    world, simulator = world_of(
        "position",
        "sequencer: {targets: " + str(SEED_TARGETS) + ", period: 3.0}",
        output_dir=tmp_path,
    )
    simulator.AdvanceTo(12.0)
    world.close()
    states = read_joint_states(tmp_path / "joint_states.csv", list(JOINTS))
    times, q = states.times, states.position
    previous = np.zeros(4)
    for k, target in enumerate(SEED_TARGETS):
        start, end = 3.0 * k, 3.0 * (k + 1)
        window = (times >= start) & (times < end - 1e-9)
        reached = q[window][-1]
        assert np.abs(reached - target).max() <= 0.01, (k, reached, target)
        step = np.asarray(target) - previous
        for j in range(4):
            if abs(step[j]) < 1e-6:
                continue
            beyond = (q[window][:, j] - target[j]) * np.sign(step[j])
            overshoot = max(0.0, beyond.max()) / abs(step[j])
            assert overshoot < 0.10, f"step {k} joint {JOINTS[j]} overshoots {overshoot:.1%}"
        previous = np.asarray(target)


def trajectory(points, names=JOINTS):
    return JointTrajectory(
        joint_names=tuple(names),
        points=tuple(
            JointTrajectoryPoint(positions=tuple(p), velocities=tuple(v), time_from_start=t)
            for p, v, t in points
        ),
    )


def test_trajectory_with_velocities_is_followed_and_succeeds():
    world, simulator = world_of("trajectory", "sequencer: null")
    context = simulator.get_mutable_context()
    points = [
        ([0.4, -0.3, 0.5, 0.2], [0.2, -0.1, 0.2, 0.1], 1.5),
        ([0.8, -0.6, 0.9, 0.4], [0.1, -0.1, 0.1, 0.05], 3.0),
        ([1.0, -0.8, 1.0, 0.5], [0.0, 0.0, 0.0, 0.0], 4.5),
    ]
    world.publish(context, "trajectory_controller", trajectory(points))
    start = context.get_time()
    errors = []
    for positions, _, t in points:
        simulator.AdvanceTo(start + t)
        errors.append(np.abs(world.joint_positions(context) - positions).max())
    assert max(errors) <= 0.02, errors
    simulator.AdvanceTo(start + 5.5)
    final = np.abs(world.joint_positions(context) - points[-1][0]).max()
    assert final <= 0.01
    assert world.status(context, "trajectory_controller").state == "succeeded"


GOOD = (0.5, -0.4, 0.6, 0.3)

BAD_COMMANDS = [
    (
        Float64MultiArray(data=(0.1, 0.2)),
        "command size (2) does not match number of interfaces (4)",
    ),
    (Float64MultiArray(data=()), "command size (0) does not match number of interfaces (4)"),
    (Float64MultiArray(data=(0.1, math.nan, 0.0, 0.0)), "Non-finite value received"),
    (Float64MultiArray(data=(0.1, math.inf, 0.0, 0.0)), "Non-finite value received"),
]


def test_the_sinusoid_drives_its_position_controller_as_a_stream():
    world, simulator = world_of("sinusoid")
    assert world.robot().stack.stream_controller == "position_controller"
    context = simulator.get_mutable_context()
    simulator.AdvanceTo(1.0)
    status = world.status(context, "position_controller")
    # One sample applied at each tick from 0.01 s to 0.99 s (the tick at 0 s precedes the
    # first sample; the one at 1 s runs when the simulation goes on).
    assert (status.state, status.accepted, status.rejected) == ("active", 99, 0)


@pytest.mark.parametrize("message, reason", BAD_COMMANDS, ids=["short", "empty", "nan", "inf"])
def test_bad_position_command_keeps_the_last_good_one(message, reason):
    world, simulator = world_of("position", "sequencer: null")
    context = simulator.get_mutable_context()
    world.publish(context, "position_controller", Float64MultiArray(data=GOOD))
    simulator.AdvanceTo(2.5)
    world.publish(context, "position_controller", message)
    simulator.AdvanceTo(4.0)
    status = world.status(context, "position_controller")
    assert reason in status.last_error
    assert status.rejected == 1 and status.accepted == 1
    assert np.abs(world.joint_positions(context) - GOOD).max() <= 0.01


def test_position_command_outside_limits_is_clamped():
    world, simulator = world_of("position", "sequencer: null")
    context = simulator.get_mutable_context()
    world.publish(context, "position_controller", Float64MultiArray(data=(3.0, 0.0, 0.0, 0.0)))
    simulator.AdvanceTo(3.0)
    assert abs(world.joint_positions(context)[0] - 2.57) <= 0.01


def _point(p, t, **kw):
    return JointTrajectoryPoint(positions=tuple(p), time_from_start=t, **kw)


BAD_TRAJECTORIES = [
    (JointTrajectory(joint_names=("j0", "j1"), points=(_point([0, 0], 1),)), "don't match"),
    (JointTrajectory(joint_names=JOINTS, points=()), "Empty trajectory"),
    (
        JointTrajectory(joint_names=("j0", "j1", "j2", "j9"), points=(_point([0] * 4, 1),)),
        "j9",
    ),
    (
        JointTrajectory(joint_names=("j0", "j1", "j2", "j2"), points=(_point([0] * 4, 1),)),
        "j2",
    ),
    (
        JointTrajectory(
            joint_names=JOINTS, points=(_point([0] * 4, 1, velocities=(0.1, 0, 0, 0)),)
        ),
        "not zero",
    ),
    (
        JointTrajectory(joint_names=JOINTS, points=(_point([0] * 4, 1), _point([0] * 4, 1))),
        "strictly increasing",
    ),
    (JointTrajectory(joint_names=JOINTS, points=(_point([0] * 3, 1),)), "positions"),
    (
        JointTrajectory(joint_names=JOINTS, points=(_point([0, math.nan, 0, 0], 1),)),
        "finite",
    ),
    (JointTrajectory(joint_names=JOINTS, points=(_point([0] * 4, -1),)), "negative"),
]


@pytest.mark.parametrize(
    "message, reason",
    BAD_TRAJECTORIES,
    ids=["partial", "empty", "unknown", "duplicate", "velocity", "time", "size", "nan", "neg"],
)
def test_bad_trajectory_keeps_the_last_good_goal(message, reason):
    world, simulator = world_of("trajectory", "sequencer: null")
    context = simulator.get_mutable_context()
    world.publish(context, "trajectory_controller", trajectory([(GOOD, [0.0] * 4, 1.0)]))
    simulator.AdvanceTo(3.0)
    world.publish(context, "trajectory_controller", message)
    simulator.AdvanceTo(4.0)
    status = world.status(context, "trajectory_controller")
    assert reason in status.last_error, status
    assert status.rejected == 1
    assert np.abs(world.joint_positions(context) - GOOD).max() <= 0.01


def test_both_command_controllers_on_the_same_joints_is_an_error():
    scenario = load_scenario(
        "position",
        "controllers: {activate: [joint_state_broadcaster, position_controller, "
        "trajectory_controller]}",
    )
    with pytest.raises(ScenarioError, match="both command joint 'j0'"):
        MakeWorld(scenario, quiet=True, source="position.yaml")


def test_unknown_controller_to_activate_is_named():
    scenario = load_scenario("position", "controllers: {activate: [arm_controller]}")
    with pytest.raises(ScenarioError, match="activate names 'arm_controller'.*defined: "):
        MakeWorld(scenario, quiet=True)


def test_tamsi_is_refused_because_it_ignores_pd_gains():
    scenario = load_scenario("position", "plant_config: {discrete_contact_approximation: tamsi}")
    with pytest.raises(ScenarioError, match="tamsi"):
        MakeWorld(scenario, quiet=True)


def test_initial_value_and_min_max_from_ros2_control():
    world, simulator = world_of(
        "position", "sequencer: null\nrobot: {xacro_args: {initial_j1: '0.4'}}"
    )
    context = simulator.get_mutable_context()
    assert world.joint_positions(context)[1] == pytest.approx(0.4)
    simulator.AdvanceTo(1.0)
    # Before any command the controller holds the initial position.
    assert abs(world.joint_positions(context)[1] - 0.4) <= 0.01
