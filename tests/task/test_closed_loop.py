"""Closed loop in a bare diagram: plant + TorqueController at 1 kHz, both torque laws.

iiwa (../shared): linear path with slerped orientation and circular path with held
orientation, trapezoidal and cubic laws, joint-space (through the planned joint
reference) and operational-space inverse dynamics: max position error <= 1 mm,
orientation error <= 0.01 rad, joint, velocity and effort limits respected.
Armando: linear and circular position paths with the joint-space law through the
planned joint reference, within 2 mm.
"""

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput
from task_robots import ARMANDO_END_EFFECTOR, IIWA_END_EFFECTOR, add_armando, add_iiwa

from armando_drake.kinematics.arm import ArmModel, TaskSpaceError, orientation_error
from armando_drake.kinematics.control_laws import (
    JointSpaceInverseDynamics,
    OperationalSpaceInverseDynamics,
    OperationalSpaceInverseDynamicsParams,
)
from armando_drake.kinematics.controller import AddTorqueController, TorqueController
from armando_drake.kinematics.inverse_kinematics import plan_joint_reference, solve_ik
from armando_drake.kinematics.paths import (
    CartesianTrajectory,
    CircularPath,
    LinearPath,
    OrientationPath,
)
from armando_drake.kinematics.time_laws import CubicTimeLaw, TrapezoidalTimeLaw

PERIOD = 1e-3  # [s] controller and plant step
SETTLE = 0.5  # [s] simulated after the motion


def build(add_robot, end_effector):
    builder = DiagramBuilder()
    plant = builder.AddNamedSystem("plant", MultibodyPlant(PERIOD))
    add_robot(plant)
    plant.Finalize()
    return builder, plant, ArmModel(plant=plant, end_effector_frame=end_effector)


def run_closed_loop(builder, plant, arm, law, reference, q0, duration):
    controller = AddTorqueController(
        builder, plant=plant, law=law, reference=reference, period=PERIOD
    )
    state_log = LogVectorOutput(
        plant.get_state_output_port(arm.model_instance), builder, publish_period=PERIOD
    )
    torque_log = LogVectorOutput(
        controller.GetOutputPort("actuation"), builder, publish_period=PERIOD
    )
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant.SetPositions(plant.GetMyMutableContextFromRoot(context), arm.model_instance, q0)
    simulator.Initialize()
    simulator.AdvanceTo(duration)
    states = state_log.FindLog(context)
    return states.sample_times(), states.data().T, torque_log.FindLog(context).data().T


def tracking_errors(arm, trajectory, times, states):
    """(max position error [m], max orientation error [rad]) of E against the reference."""
    references = trajectory.reference(times)
    worst_position = worst_rotation = 0.0
    for k in range(len(times)):
        q, _ = arm.split_instance_state(states[k])
        arm.set_state(q)
        X = arm.pose()
        worst_position = max(worst_position, np.linalg.norm(X.translation() - references[k, 4:7]))
        R_d = RotationMatrix(Quaternion(references[k, :4]))
        worst_rotation = max(worst_rotation, np.linalg.norm(orientation_error(R_d, X.rotation())))
    return worst_position, worst_rotation


def assert_within_limits(arm, states, torques):
    q = states[:, arm.state_position_slots]
    v = states[:, arm.state_velocity_slots]
    assert np.all(q >= arm.lower) and np.all(q <= arm.upper)
    assert np.all(np.abs(v) <= arm.velocity_limit)
    assert np.all(np.isfinite(torques))
    assert np.all(np.abs(torques) <= arm.effort_limit[arm.actuation_order] + 1e-9)


IIWA_START = RigidTransform(RotationMatrix.MakeYRotation(np.pi), [0.55, 0.0, 0.5])
IIWA_SEED = np.array([0.0, 0.6, 0.0, -1.4, 0.0, 0.9, 0.0])


def iiwa_trajectory(arm, path_kind, law):
    X0 = IIWA_START
    if path_kind == "linear":
        path = LinearPath(start=X0.translation(), goal=X0.translation() + [-0.1, 0.25, 0.15])
        R1 = X0.rotation().multiply(RotationMatrix.MakeZRotation(0.6))
        orientation = OrientationPath(start=X0.rotation(), goal=R1)
    else:
        path = CircularPath(start=X0.translation(), radius=0.1)
        orientation = OrientationPath(start=X0.rotation())
    return CartesianTrajectory(time_law=law, path=path, orientation=orientation)


LAWS = {
    "trapezoidal": TrapezoidalTimeLaw(duration=2.5, acceleration_time=0.6),
    "cubic": CubicTimeLaw(duration=2.5),
}


@pytest.mark.parametrize("time_law", sorted(LAWS))
@pytest.mark.parametrize("path_kind", ["linear", "circular"])
@pytest.mark.parametrize("control", ["joint_space", "operational_space"])
def test_iiwa_tracks_the_path(control, path_kind, time_law):
    builder, plant, arm = build(add_iiwa, IIWA_END_EFFECTOR)
    start = solve_ik(arm, IIWA_START, q_seed=IIWA_SEED)  # the start configuration
    assert start.success, start.message
    trajectory = iiwa_trajectory(arm, path_kind, LAWS[time_law])
    if control == "joint_space":
        plan = plan_joint_reference(arm, trajectory, start.q, period=PERIOD, settle_time=SETTLE)
        law = JointSpaceInverseDynamics(arm=arm)
        reference = plan.as_reference_trajectory()
    else:
        law = OperationalSpaceInverseDynamics(arm=arm)
        reference = trajectory.as_reference_trajectory(PERIOD)
    times, states, torques = run_closed_loop(
        builder, plant, arm, law, reference, start.q, trajectory.duration + SETTLE
    )
    position, rotation = tracking_errors(arm, trajectory, times, states)
    print(f"iiwa {control} {path_kind} {time_law}: max errors {position * 1e3:.3f} mm, "
          f"{rotation:.4f} rad, max |tau| {np.abs(torques).max():.1f} N m")  # fmt: skip
    assert position <= 1e-3 and rotation <= 0.01
    assert_within_limits(arm, states, torques)
    assert law.saturated_ticks == 0 and law.rejected_ticks == 0
    # It did move: the end is the path's end (the circle's end is its start).
    goal = trajectory.reference([trajectory.duration])[0, 4:7]
    arm.set_state(arm.split_instance_state(states[-1])[0])
    assert np.linalg.norm(arm.pose().translation() - goal) < 1e-3
    moved = np.max(np.linalg.norm(states[:, :7] - states[0, :7], axis=1))
    assert moved > 0.1


@pytest.mark.parametrize("time_law", sorted(LAWS))
@pytest.mark.parametrize("path_kind", ["linear", "circular"])
def test_armando_tracks_position_paths_with_the_joint_space_law(path_kind, time_law):
    builder, plant, arm = build(add_armando, ARMANDO_END_EFFECTOR)
    q0 = np.array([0.3, 0.4, 0.9, 0.7])
    arm.set_state(q0)
    X0 = arm.pose()
    if path_kind == "linear":
        path = LinearPath(start=X0.translation(), goal=X0.translation() + [0.03, 0.05, 0.04])
    else:
        path = CircularPath(start=X0.translation(), radius=0.04)
    trajectory = CartesianTrajectory(
        time_law=LAWS[time_law], path=path, orientation=OrientationPath(start=X0.rotation())
    )
    plan = plan_joint_reference(arm, trajectory, q0, period=PERIOD, settle_time=SETTLE)
    law = JointSpaceInverseDynamics(arm=arm)
    times, states, torques = run_closed_loop(
        builder, plant, arm, law, plan.as_reference_trajectory(), q0, trajectory.duration + SETTLE
    )
    position, _ = tracking_errors(arm, trajectory, times, states)
    print(f"Armando joint_space {path_kind} {time_law}: max error {position * 1e3:.3f} mm")
    assert position <= 2e-3
    assert_within_limits(arm, states, torques)
    assert law.saturated_ticks == 0


def test_unreachable_cartesian_reference_gives_finite_clamped_torques():
    """The operational-space law on a goal 1.3 m away: bounded, finite, at most the limits."""
    builder, plant, arm = build(add_iiwa, IIWA_END_EFFECTOR)
    start = solve_ik(arm, IIWA_START, q_seed=IIWA_SEED)
    trajectory = CartesianTrajectory(
        time_law=CubicTimeLaw(duration=1.0),
        path=LinearPath(start=IIWA_START.translation(), goal=[1.8, 0.0, 0.5]),
        orientation=OrientationPath(start=IIWA_START.rotation()),
    )
    law = OperationalSpaceInverseDynamics(arm=arm)
    times, states, torques = run_closed_loop(
        builder, plant, arm, law, trajectory.as_reference_trajectory(PERIOD), start.q, 1.5
    )
    assert np.all(np.isfinite(states)) and np.all(np.isfinite(torques))
    assert np.all(np.abs(torques) <= 300.0 + 1e-9)
    print(f"unreachable: {law.saturated_ticks} saturated ticks, smallest weighted singular "
          f"value {law.smallest_singular_value:.3g}")  # fmt: skip
    assert law.smallest_singular_value < OperationalSpaceInverseDynamicsParams().singular_threshold


def test_non_finite_reference_is_held_not_passed_on(caplog):
    plant = MultibodyPlant(0.0)
    add_iiwa(plant)
    plant.Finalize()
    arm = ArmModel(plant=plant, end_effector_frame=IIWA_END_EFFECTOR)
    q = IIWA_SEED
    state = np.concatenate([q, np.zeros(7)])
    no_limit_term = OperationalSpaceInverseDynamicsParams(limit_gain=0.0)
    for law in (
        JointSpaceInverseDynamics(arm=arm),
        OperationalSpaceInverseDynamics(arm=arm, params=no_limit_term),
    ):
        reference = np.full(law.reference_size, np.nan)
        torque = law.CalcActuation(state, reference)
        assert np.all(np.isfinite(torque)) and law.rejected_ticks == 1
        # With no good reference yet the law holds the measured pose: gravity only.
        arm.set_state(q)
        np.testing.assert_allclose(torque, arm.gravity(), atol=1e-9)
    assert "non-finite reference" in caplog.text


def test_controller_ports_and_bad_arguments():
    plant = MultibodyPlant(0.0)
    add_iiwa(plant)
    plant.Finalize()
    arm = ArmModel(plant=plant, end_effector_frame=IIWA_END_EFFECTOR)
    controller = TorqueController(law=JointSpaceInverseDynamics(arm=arm), period=1e-3)
    assert controller.GetInputPort("estimated_state").size() == 14
    assert controller.GetInputPort("reference").size() == 21
    assert controller.GetOutputPort("actuation").size() == 7
    with pytest.raises(TaskSpaceError, match="period=0.0 s must be positive"):
        TorqueController(law=JointSpaceInverseDynamics(arm=arm), period=0.0)
    with pytest.raises(TypeError):
        TorqueController(JointSpaceInverseDynamics(arm=arm), 1e-3)  # keyword-only
