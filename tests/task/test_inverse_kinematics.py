"""Inverse kinematics on the iiwa (from ../shared) and Armando; path plans and rejections."""

import logging

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from task_robots import (
    ARMANDO_END_EFFECTOR,
    IIWA_END_EFFECTOR,
    add_armando,
    add_iiwa,
)

from armando_drake.kinematics.arm import ArmModel, TaskSpaceError, orientation_error
from armando_drake.kinematics.inverse_kinematics import plan_joint_reference, solve_ik
from armando_drake.kinematics.paths import CartesianTrajectory, LinearPath, OrientationPath
from armando_drake.kinematics.time_laws import CubicTimeLaw, TrapezoidalTimeLaw


@pytest.fixture(scope="module")
def iiwa() -> ArmModel:
    plant = MultibodyPlant(0.0)
    add_iiwa(plant)
    plant.Finalize()
    return ArmModel(plant=plant, end_effector_frame=IIWA_END_EFFECTOR)


@pytest.fixture(scope="module")
def armando() -> ArmModel:
    plant = MultibodyPlant(0.0)
    add_armando(plant)
    plant.Finalize()
    return ArmModel(plant=plant, end_effector_frame=ARMANDO_END_EFFECTOR)


def test_iiwa_limits_as_the_urdf_gives_them(iiwa):
    degrees = np.array([170, 120, 170, 120, 170, 120, 175])
    np.testing.assert_allclose(iiwa.upper, np.radians(degrees), atol=1e-12)
    np.testing.assert_allclose(iiwa.lower, -np.radians(degrees), atol=1e-12)
    np.testing.assert_array_equal(iiwa.effort_limit, 300.0)
    np.testing.assert_array_equal(iiwa.velocity_limit, 10.0)
    assert iiwa.follows_full_orientation and iiwa.num_joints == 7


def test_random_reachable_iiwa_poses_are_solved(iiwa):
    rng = np.random.default_rng(2026)
    seed_posture = np.array([0.0, 0.5, 0.0, -1.2, 0.0, 0.9, 0.0])
    errors = []
    for _ in range(12):
        q_true = rng.uniform(0.9 * iiwa.lower, 0.9 * iiwa.upper)
        iiwa.set_state(q_true)
        X_target = iiwa.pose()
        result = solve_ik(iiwa, X_target, q_seed=seed_posture)
        assert result.success, result.message
        # Checked again here by forward kinematics, not from the result's own numbers.
        iiwa.set_state(result.q)
        X = iiwa.pose()
        position = np.linalg.norm(X.translation() - X_target.translation())
        rotation = np.linalg.norm(orientation_error(X_target.rotation(), X.rotation()))
        assert position <= 1e-6 and rotation <= 1e-5, result.message
        assert np.all(result.q >= iiwa.lower - 1e-9) and np.all(result.q <= iiwa.upper + 1e-9)
        errors.append((position, rotation))
    print("iiwa IK worst position / orientation error:", np.max(errors, axis=0))


@pytest.mark.parametrize(
    "X_target",
    [
        RigidTransform([1.6, 0.0, 0.4]),  # beyond the arm's reach (about 1.3 m from the base)
        RigidTransform(RotationMatrix.MakeXRotation(np.pi), [0.0, 0.0, -0.3]),  # under the base
    ],
)
def test_unreachable_iiwa_pose_is_reported(iiwa, X_target):
    result = solve_ik(iiwa, X_target, attempts=3)
    assert not result.success
    assert "unreachable" in result.message and "\n" not in result.message
    assert result.position_error > 1e-3


def test_armando_ik_reaches_positions_and_keeps_orientation_as_a_cost(armando):
    rng = np.random.default_rng(4)
    for _ in range(6):
        q_true = rng.uniform(0.8 * armando.lower, 0.8 * armando.upper)
        armando.set_state(q_true)
        X_target = armando.pose()
        result = solve_ik(armando, X_target, q_seed=np.zeros(4))
        assert result.success, result.message
        assert result.position_error <= 1e-6
        assert "(cost)" in result.message


def iiwa_start(iiwa):
    X0 = RigidTransform(RotationMatrix.MakeYRotation(np.pi), [0.55, 0.0, 0.5])
    start = solve_ik(iiwa, X0, q_seed=np.array([0.0, 0.6, 0.0, -1.4, 0.0, 0.9, 0.0]))
    assert start.success, start.message
    return X0, start.q


def test_plan_follows_a_line_with_slerp(iiwa, caplog):
    X0, q0 = iiwa_start(iiwa)
    R1 = X0.rotation().multiply(RotationMatrix.MakeZRotation(0.6))
    trajectory = CartesianTrajectory(
        time_law=TrapezoidalTimeLaw(duration=2.0, acceleration_time=0.5),
        path=LinearPath(start=X0.translation(), goal=X0.translation() + [-0.1, 0.25, 0.15]),
        orientation=OrientationPath(start=X0.rotation(), goal=R1),
    )
    with caplog.at_level(logging.INFO, logger="armando_drake.kinematics.inverse_kinematics"):
        plan = plan_joint_reference(iiwa, trajectory, q0, period=2e-3)
    assert "position (3) + orientation (3)" in caplog.text
    references = trajectory.reference(plan.times)
    worst_position = worst_rotation = 0.0
    for k in range(0, len(plan.times), 10):
        iiwa.set_state(plan.q[k])
        X = iiwa.pose()
        worst_position = max(worst_position, np.linalg.norm(X.translation() - references[k, 4:7]))
        R_d = RotationMatrix(Quaternion(references[k, :4]))
        worst_rotation = max(worst_rotation, np.linalg.norm(orientation_error(R_d, X.rotation())))
    assert worst_position < 1e-4 and worst_rotation < 1e-3, (worst_position, worst_rotation)
    # a_d is the derivative of v_d (semi-implicit Euler), v_d that of q_d.
    np.testing.assert_allclose(np.diff(plan.v, axis=0)[:-1] / 2e-3, plan.a[:-2], atol=1e-9)
    np.testing.assert_allclose(np.diff(plan.q, axis=0) / 2e-3, plan.v[1:], atol=1e-9)


def test_armando_plan_logs_the_orientation_it_can_follow(armando, caplog):
    q0 = np.array([0.3, 0.4, 0.9, 0.7])
    armando.set_state(q0)
    X0 = armando.pose()
    trajectory = CartesianTrajectory(
        time_law=CubicTimeLaw(duration=2.0),
        path=LinearPath(start=X0.translation(), goal=X0.translation() + [0.03, 0.05, 0.04]),
        orientation=OrientationPath(start=X0.rotation()),
    )
    with caplog.at_level(logging.INFO, logger="armando_drake.kinematics.inverse_kinematics"):
        plan = plan_joint_reference(armando, trajectory, q0, period=2e-3)
    assert "task = position (3)" in caplog.text
    assert "1 component(s) the arm can follow" in caplog.text
    armando.set_state(plan.q[-1])
    assert (
        np.linalg.norm(armando.pose().translation() - (X0.translation() + [0.03, 0.05, 0.04]))
        < 1e-4
    )


def test_path_leaving_the_workspace_is_rejected(iiwa):
    X0, q0 = iiwa_start(iiwa)
    trajectory = CartesianTrajectory(
        time_law=CubicTimeLaw(duration=3.0),
        path=LinearPath(start=X0.translation(), goal=[1.8, 0.0, 0.5]),
        orientation=OrientationPath(start=X0.rotation()),
    )
    with pytest.raises(TaskSpaceError) as error:
        plan_joint_reference(iiwa, trajectory, q0, period=2e-3)
    text = str(error.value)
    assert "leaves the workspace or passes a singularity" in text and "\n" not in text
    assert "smallest singular value" in text
    print(text)


def test_path_too_fast_for_the_plan_period_is_rejected(iiwa):
    X0, q0 = iiwa_start(iiwa)
    trajectory = CartesianTrajectory(
        time_law=CubicTimeLaw(duration=0.2),
        path=LinearPath(start=X0.translation(), goal=X0.translation() + [-0.3, 0.3, 0.0]),
        orientation=OrientationPath(start=X0.rotation()),
    )
    with pytest.raises(TaskSpaceError, match="too fast to follow at this period"):
        plan_joint_reference(iiwa, trajectory, q0, period=1e-3)


def test_armando_beyond_its_effort_limit_is_rejected(armando):
    q0 = np.array([0.3, 0.4, 0.9, 0.7])
    armando.set_state(q0)
    X0 = armando.pose()
    trajectory = CartesianTrajectory(
        time_law=CubicTimeLaw(duration=0.1),
        path=LinearPath(start=X0.translation(), goal=X0.translation() + [0.0, 0.0, 0.12]),
        orientation=OrientationPath(start=X0.rotation()),
    )
    with pytest.raises(
        TaskSpaceError,
        match=r"joint 'j1' needs effort .* outside its effort limit \[-1.5, 1.5\] N m",
    ):
        plan_joint_reference(armando, trajectory, q0, period=1e-3)


def test_armando_path_to_the_workspace_boundary_is_rejected(armando):
    q0 = np.array([0.3, 0.4, 0.9, 0.7])
    armando.set_state(q0)
    X0 = armando.pose()
    trajectory = CartesianTrajectory(
        time_law=CubicTimeLaw(duration=2.0),
        path=LinearPath(start=X0.translation(), goal=X0.translation() + [0.0, 0.0, 0.12]),
        orientation=OrientationPath(start=X0.rotation()),
    )
    with pytest.raises(TaskSpaceError, match="leaves the workspace or passes a singularity"):
        plan_joint_reference(armando, trajectory, q0, period=1e-3)


def test_bad_frame_is_reported():
    plant = MultibodyPlant(0.0)
    add_iiwa(plant)
    plant.Finalize()
    with pytest.raises(TaskSpaceError, match="frame 'no_such_link'"):
        ArmModel(plant=plant, end_effector_frame="no_such_link")
