"""Continuous joints in the trajectory controller, as upstream's (Jazzy) has them: their
position errors are wrapped into (-pi, pi] (compute_error_for_joint: tolerances and the
PID) and a trajectory starts from the representation of the state before it nearest its
first point (set_point_before_trajectory_msg's wraparound_joint)."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from test_interfaces import SPINNER

from armando_drake.control.controllers import ControllerJoints
from armando_drake.control.controllers.joint_trajectory import (
    JointGains,
    JointTrajectoryController,
    JointTrajectoryControllerParams,
    SampledTrajectory,
    shortest_angular_distance,
)
from armando_drake.messages.types import JointTrajectory, JointTrajectoryPoint
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario
from tests.control.test_controllers import Harness

JOINTS = ("wrap", "plain")  # a continuous joint and a revolute one without limits


def point(time, positions):
    return JointTrajectoryPoint(
        positions=tuple(positions),
        velocities=(),
        accelerations=(),
        effort=(),
        time_from_start=time,
    )


def message(*points, names=JOINTS):
    return JointTrajectory(stamp=0.0, joint_names=tuple(names), points=tuple(points))


def test_shortest_angular_distance():
    assert shortest_angular_distance(3.0, -3.0) == pytest.approx(2 * math.pi - 6.0)
    assert shortest_angular_distance(-3.0, 3.0) == pytest.approx(6.0 - 2 * math.pi)
    assert shortest_angular_distance(0.0, 7.0) == pytest.approx(7.0 - 2 * math.pi)
    assert shortest_angular_distance(0.0, math.pi) == math.pi  # (-pi, pi]
    assert shortest_angular_distance(0.0, -math.pi) == math.pi


def test_trajectory_starts_from_the_nearest_representation_of_the_state_before():
    """The state before (0, 0) becomes (2 pi, 0): the continuous joint's first segment
    runs 2 pi -> 3 pi / 2, the other's 0 -> 3 pi / 2."""
    traj = SampledTrajectory.from_message(
        message(point(1.0, [math.pi * 1.5] * 2)),
        time=100.0,
        positions=[0.0, 0.0],
        wraparound=[True, False],
    )
    np.testing.assert_allclose(traj.sample(100.0).positions, [2 * math.pi, 0.0], atol=1e-12)
    np.testing.assert_allclose(
        traj.sample(100.5).positions, [math.pi * 1.75, math.pi * 0.75], atol=1e-12
    )


def test_controller_joints_continuous():
    assert ControllerJoints.make(JOINTS).wraparound.tolist() == [False, False]
    joints = ControllerJoints.make(JOINTS, continuous=[True, False])
    assert joints.wraparound.tolist() == [True, False]
    with pytest.raises(ValueError, match="continuous"):
        ControllerJoints.make(JOINTS, continuous=[True])


def harness(**params) -> Harness:
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(JOINTS, continuous=[True, False]),
        params=JointTrajectoryControllerParams(joints=list(JOINTS), **params),
    )
    return Harness(controller, measured=np.array([3.0, 3.0]))


def test_position_commands_take_the_short_way_and_tolerances_use_the_wrapped_error():
    h = harness(trajectory_tolerance={"wrap": 0.05}, goal_tolerance={"wrap": 0.01})
    h.step()
    start = h.publish(message(point(1.0, [-3.0, -3.0])))
    h.advance(start)
    # From 3 - 2 pi (= 3.0 as an angle) up to -3.0 through -pi; the plain joint from 3.0.
    shifted = 3.0 - 2 * math.pi
    np.testing.assert_allclose(
        h.desired[:2], [shifted + (-3.0 - shifted) * 0.01, 3.0 - 6.0 * 0.01], atol=1e-12
    )
    assert h.status.state == "executing"
    # Measured 2 pi away from the desired position (the last command): no path error.
    while h.time < start + 0.9:
        h.set_measured(np.array([h.desired[0] + 2 * math.pi, 3.0]))
        h.step()
        assert h.status.state == "executing"
    # At the goal, as 2 pi - 3.0: succeeded (the plain joint has no goal tolerance).
    h.set_measured(np.array([2 * math.pi - 3.0, 3.0]))
    h.advance(start + 1.1)
    assert h.status.state == "succeeded"


def test_path_tolerance_still_checks_the_wrapped_error():
    h = harness(trajectory_tolerance={"wrap": 0.05})
    start = h.publish(message(point(1.0, [3.0, 3.0])))
    h.advance(start)
    h.set_measured(np.array([3.0 + 2 * math.pi + 0.1, 3.0]))
    h.step()
    assert h.status.state == "aborted"
    assert "joint 'wrap' is 0.1 rad" in h.status.last_error


def test_the_pid_acts_on_the_wrapped_error():
    """command_interfaces [velocity]: u = p * shortest_angular_distance(q, q_d)."""
    controller = JointTrajectoryController(
        name="ctl",
        joints=ControllerJoints.make(JOINTS, continuous=[True, False]),
        params=JointTrajectoryControllerParams(
            joints=list(JOINTS),
            command_interfaces=["velocity"],
            state_interfaces=["position", "velocity"],
            gains={joint: JointGains(p=10.0) for joint in JOINTS},
        ),
    )
    h = Harness(controller, measured=np.array([0.0, 0.0]))
    h.step()
    # Holding 0: measured 2 pi - 0.1 is 0.1 short of 0 as an angle.
    h.set_measured(np.array([2 * math.pi - 0.1, 2 * math.pi - 0.1]))
    h.step()
    np.testing.assert_allclose(h.desired[2:], [10.0 * 0.1, 10.0 * (0.1 - 2 * math.pi)])


# ----------------------------------------------------------------------------------------------
# End to end: a continuous URDF joint through the simulation

CONTROLLERS = """\
controller_manager:
  ros__parameters:
    update_rate: 100
    joint_state_broadcaster: {type: joint_state_broadcaster/JointStateBroadcaster}
    jtc: {type: joint_trajectory_controller/JointTrajectoryController}
jtc:
  ros__parameters:
    joints: [spin]
    command_interfaces: [INTERFACE]
    state_interfaces: [position, velocity]
    gains: {spin: GAINS}
"""
GAINS = {"velocity": "{p: 20.0}", "effort": "{p: 2.0, d: 0.1}"}


def spinner_from(tmp_path, interface: str, q0: float):
    urdf = tmp_path / "spinner.urdf"
    urdf.write_text(
        SPINNER.replace("INTERFACE", interface).replace(
            '<state_interface name="position"/>',
            '<state_interface name="position">'
            f'<param name="initial_value">{q0}</param></state_interface>',
        )
    )
    controllers = tmp_path / "controllers.yaml"
    controllers.write_text(
        CONTROLLERS.replace("INTERFACE", interface).replace("GAINS", GAINS[interface])
    )
    scenario = load_scenario(
        "position",
        f"robot: {{description: {urdf}, base_xyz: [0, 0, 0]}}\nsequencer: null\n"
        "logging: {console_rate: 0}\n"
        f"controllers: {{config: {controllers}, activate: [joint_state_broadcaster, jtc]}}\n",
    )
    return MakeWorld(scenario, quiet=True)


@pytest.mark.parametrize("interface", ["velocity", "effort"])
def test_continuous_joint_moves_the_short_way_through_pi(tmp_path, interface):
    """From 3.0 to -3.0: upstream's wrapped error and shifted start turn the joint 0.28 rad
    up through pi (to 2 pi - 3.0), not 6 rad down through 0."""
    world = spinner_from(tmp_path, interface, 3.0)
    (joint,) = world.robot().stack.hardware.joints
    assert joint.continuous and joint.command_interface == interface
    simulator = Simulator(world.diagram)
    context = simulator.get_mutable_context()
    plant = world.plant

    def angle() -> float:
        positions = plant.GetPositions(plant.GetMyContextFromRoot(context))
        return float(positions[0])

    simulator.AdvanceTo(0.05)
    world.publish(context, "jtc", message(point(1.0, [-3.0]), names=("spin",)))
    path = []
    for time in np.arange(0.1, 2.0, 0.05):
        simulator.AdvanceTo(time)
        path.append(angle())
    assert min(path) > 2.9  # never down towards 0
    assert path[-1] == pytest.approx(2 * math.pi - 3.0, abs=0.01)
    assert world.status(context, "jtc").state == "succeeded"
    world.close()
