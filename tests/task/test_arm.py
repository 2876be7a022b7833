"""ArmModel and the shared algebra: against finite differences, explicit formulas, Drake."""

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from task_robots import ARMANDO_END_EFFECTOR, IIWA_END_EFFECTOR, add_armando, add_iiwa

from armando_drake.kinematics.arm import (
    ArmModel,
    orientation_error,
    resolve_tasks,
    rotation_matrix_from_quaternion,
    rotation_vector_error,
)


def test_bias_acceleration_is_the_derivative_of_J_v():
    plant = MultibodyPlant(0.0)
    add_iiwa(plant)
    plant.Finalize()
    arm = ArmModel(plant=plant, end_effector_frame=IIWA_END_EFFECTOR)
    rng = np.random.default_rng(3)
    q, v = rng.uniform(-1, 1, 7), rng.uniform(-1, 1, 7)
    h = 1e-6

    def twist(at):
        arm.set_state(at, v)
        return arm.jacobian() @ v

    expected = (twist(q + h * v) - twist(q - h * v)) / (2 * h)
    arm.set_state(q, v)
    np.testing.assert_allclose(arm.bias_acceleration(), expected, atol=1e-6)


def test_two_robots_in_one_plant_keep_their_own_slots():
    plant = MultibodyPlant(0.0)
    add_armando(plant)
    iiwa_instance = add_iiwa(plant)
    plant.Finalize()
    iiwa = ArmModel(plant=plant, end_effector_frame=IIWA_END_EFFECTOR)
    armando = ArmModel(plant=plant, end_effector_frame=ARMANDO_END_EFFECTOR)
    assert iiwa.model_instance == iiwa_instance and iiwa.num_joints == 7
    assert armando.num_joints == 4 and not armando.follows_full_orientation
    q = np.linspace(-0.7, 0.7, 7)
    state = np.concatenate([q, np.zeros(7)])
    iiwa.set_instance_state(state)
    np.testing.assert_array_equal(iiwa.split_instance_state(state)[0], q)
    X_instance = iiwa.pose()
    iiwa.set_state(q)
    assert X_instance.IsNearlyEqualTo(iiwa.pose(), 1e-12)
    assert iiwa.mass_matrix().shape == (7, 7) and armando.mass_matrix().shape == (4, 4)
    np.testing.assert_array_equal(iiwa.effort_limit, 300.0)
    np.testing.assert_array_equal(armando.effort_limit, 1.5)


def test_resolve_tasks_matches_the_explicit_formulas():
    rng = np.random.default_rng(8)
    M = rng.normal(size=(7, 7))
    M = M @ M.T + 7 * np.eye(7)
    J, b, a0 = rng.normal(size=(6, 7)), rng.normal(size=6), rng.normal(size=7)
    result = resolve_tasks([(J, b)], a0, threshold=1e-3, max_damping=0.05, mass_matrix=M)
    M_inv = np.linalg.inv(M)
    J_sharp = M_inv @ J.T @ np.linalg.inv(J @ M_inv @ J.T)  # weighting scale cancels
    np.testing.assert_allclose(result.acceleration, J_sharp @ b + (np.eye(7) - J_sharp @ J) @ a0,
                               atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(J @ result.acceleration, b, atol=1e-9)
    # Two priorities, unweighted: the first task exactly, the second in its null space.
    J1, J2 = rng.normal(size=(3, 4)), rng.normal(size=(3, 4))
    result = resolve_tasks([(J1, b[:3]), (J2, b[3:])], a0[:4], threshold=1e-3, max_damping=0.05)
    pinv = np.linalg.pinv
    a1 = pinv(J1) @ b[:3]
    N1 = np.eye(4) - pinv(J1) @ J1
    a2 = a1 + pinv(J2 @ N1, rcond=1e-9) @ (b[3:] - J2 @ a1)
    N2 = N1 - pinv(J2 @ N1, rcond=1e-9) @ (J2 @ N1)
    np.testing.assert_allclose(result.acceleration, a2 + N2 @ a0[:4], atol=1e-9)
    np.testing.assert_allclose(J1 @ result.acceleration, b[:3], atol=1e-9)


def test_resolve_tasks_stays_bounded_at_a_singularity():
    J = np.array([[1.0, 0.0], [1.0, 1e-12]])  # rank 1 up to round-off
    result = resolve_tasks([(J, np.array([1.0, -1.0]))], np.zeros(2), threshold=0.1,
                           max_damping=0.1)  # fmt: skip
    assert np.all(np.isfinite(result.acceleration))
    assert np.linalg.norm(result.acceleration) < 10.0
    assert result.smallest_singular_value < 1e-9 and result.singular_value_ratio < 1e-9


@pytest.mark.parametrize("seed", range(5))
def test_numpy_rotation_helpers_match_drake(seed):
    rng = np.random.default_rng(seed)
    R_a = RotationMatrix(RollPitchYaw(rng.uniform(-3, 3, 3)))
    for R_b in (
        RotationMatrix(RollPitchYaw(rng.uniform(-3, 3, 3))),
        R_a.multiply(RotationMatrix(RollPitchYaw(rng.uniform(-1e-7, 1e-7, 3)))),
        R_a.multiply(RotationMatrix.MakeZRotation(np.pi - 1e-9)),
    ):
        np.testing.assert_allclose(
            rotation_vector_error(R_a.matrix(), R_b.matrix()), orientation_error(R_a, R_b),
            atol=1e-8,
        )  # fmt: skip
    np.testing.assert_allclose(
        rotation_matrix_from_quaternion(R_a.ToQuaternion().wxyz()), R_a.matrix(), atol=1e-12
    )
    X = RigidTransform(R_a, [1, 2, 3])
    assert np.linalg.norm(orientation_error(X.rotation(), X.rotation())) == 0.0
