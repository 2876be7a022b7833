"""The torque laws alone: against Drake's InverseDynamicsController, task accelerations
through the plant's forward dynamics, parameters as YAML."""

import numpy as np
import pytest
from pydrake.common.yaml import yaml_load_typed
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.controllers import InverseDynamicsController
from task_robots import IIWA_END_EFFECTOR, add_iiwa

from armando_drake.kinematics.arm import ArmModel, TaskSpaceError, orientation_error
from armando_drake.kinematics.control_laws import (
    TORQUE_LAWS,
    JointSpaceInverseDynamics,
    JointSpaceInverseDynamicsParams,
    OperationalSpaceInverseDynamics,
    OperationalSpaceInverseDynamicsParams,
)
from armando_drake.kinematics.paths import CARTESIAN_REFERENCE_SIZE


@pytest.fixture(scope="module")
def iiwa() -> ArmModel:
    plant = MultibodyPlant(0.0)
    add_iiwa(plant)
    plant.Finalize()
    return ArmModel(plant=plant, end_effector_frame=IIWA_END_EFFECTOR)


def test_joint_space_law_equals_drakes_inverse_dynamics_controller(iiwa):
    params = JointSpaceInverseDynamicsParams(proportional_gain=100.0, derivative_gain=20.0)
    law = JointSpaceInverseDynamics(arm=iiwa, params=params)
    drake = InverseDynamicsController(
        iiwa.plant, kp=np.full(7, 100.0), ki=np.zeros(7), kd=np.full(7, 20.0),
        has_reference_acceleration=True,
    )  # fmt: skip
    context = drake.CreateDefaultContext()
    rng = np.random.default_rng(11)
    for _ in range(5):
        state = np.concatenate([rng.uniform(-1.5, 1.5, 7), rng.uniform(-1, 1, 7)])
        reference = rng.uniform(-1, 1, 21)
        drake.get_input_port_estimated_state().FixValue(context, state)
        drake.get_input_port_desired_state().FixValue(context, reference[:14])
        drake.get_input_port_desired_acceleration().FixValue(context, reference[14:])
        expected = drake.get_output_port_control().Eval(context)
        got = law.CalcActuation(state, reference)
        if np.all(np.abs(expected) <= 300.0):
            np.testing.assert_allclose(got, expected, atol=1e-9)
        else:
            np.testing.assert_allclose(got, np.clip(expected, -300, 300), atol=1e-9)


def test_operational_space_law_produces_the_commanded_task_acceleration(iiwa):
    """Forward dynamics with the law's torques gives J v' + J-dot v = x''_d + Kd e' + Kp e."""
    params = OperationalSpaceInverseDynamicsParams(limit_gain=0.0, null_space_damping=0.0)
    law = OperationalSpaceInverseDynamics(arm=iiwa, params=params)
    plant, context = iiwa.plant, iiwa.plant.CreateDefaultContext()
    rng = np.random.default_rng(5)
    q = np.array([0.1, 0.6, -0.2, -1.3, 0.3, 0.8, 0.2])
    v = rng.uniform(-0.5, 0.5, 7)
    iiwa.set_state(q, v)
    X = iiwa.pose()
    # A reference 5 mm / 0.02 rad away, with a twist and an acceleration.

    X_d = RigidTransform(
        X.rotation().multiply(RotationMatrix.MakeXRotation(0.02)), X.translation() + [0.005, 0, 0]
    )
    twist_d = rng.uniform(-0.2, 0.2, 6)
    acceleration_d = rng.uniform(-1, 1, 6)
    quaternion = X_d.rotation().ToQuaternion().wxyz()
    reference = np.concatenate([quaternion, X_d.translation(), twist_d, acceleration_d])
    tau = law.CalcActuation(np.concatenate([q, v]), reference)
    assert law.saturated_ticks == 0
    plant.SetPositions(context, q)
    plant.SetVelocities(context, v)
    plant.get_actuation_input_port().FixValue(context, tau)
    v_dot = plant.EvalTimeDerivatives(context).get_vector().CopyToVector()[7:]
    iiwa.set_state(q, v)
    J = iiwa.jacobian()
    achieved = J @ v_dot + iiwa.bias_acceleration()
    error = np.concatenate(
        [orientation_error(X_d.rotation(), X.rotation()), X_d.translation() - X.translation()]
    )
    commanded = acceleration_d + 40.0 * (twist_d - J @ v) + 400.0 * error
    np.testing.assert_allclose(achieved, commanded, atol=1e-6)


def test_parameters_load_from_yaml_and_are_checked():
    params = yaml_load_typed(
        schema=OperationalSpaceInverseDynamicsParams,
        data="position_gain: 900.0\nlinear_velocity_gain: 60.0\n",
    )
    assert params.position_gain == 900.0 and params.orientation_gain == 400.0
    with pytest.raises(RuntimeError, match="no_such_gain"):
        yaml_load_typed(schema=OperationalSpaceInverseDynamicsParams, data="no_such_gain: 1.0")
    with pytest.raises(TaskSpaceError, match="proportional_gain=-1.0 must be finite and > 0"):
        JointSpaceInverseDynamicsParams(proportional_gain=-1.0).validate()
    with pytest.raises(TaskSpaceError, match="null_space_damping=nan"):
        OperationalSpaceInverseDynamicsParams(null_space_damping=float("nan")).validate()


def test_unactuated_arm_is_refused():
    from armando_drake.description.loader import load_robot

    plant = MultibodyPlant(0.0)
    load_robot(plant)  # Armando without actuators (the loader adds none)
    plant.Finalize()
    arm = ArmModel(plant=plant, end_effector_frame="crawer_base")
    with pytest.raises(TaskSpaceError, match=r"joints \['j0', 'j1', 'j2', 'j3'\] .* no actuator"):
        JointSpaceInverseDynamics(arm=arm)


@pytest.mark.parametrize("type_name", sorted(TORQUE_LAWS))
def test_registry_entries_build_their_law_from_yaml(iiwa, type_name):
    entry = TORQUE_LAWS[type_name]
    params = yaml_load_typed(schema=entry.params, data="{}")
    law = entry.law(arm=iiwa, params=params)
    expected = {"joint": 21, "cartesian": CARTESIAN_REFERENCE_SIZE}[entry.reference]
    assert law.reference_size == expected
    assert entry.command_interfaces == ("effort",)
