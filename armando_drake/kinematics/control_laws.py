"""Torque control laws of the task-space controllers, as plain classes.

Each law turns the arm's measured state and a reference vector into joint torques,
one call per controller tick (:class:`armando_drake.kinematics.controller.TorqueController`
runs it as a discrete update). M, C v, g, J and J-dot v come from the plant through
:class:`~armando_drake.kinematics.arm.ArmModel`.

- :class:`JointSpaceInverseDynamics` (computed torque), reference [q_d; v_d; a_d]:
  tau = M(q) (a_d + Kd (v_d - v) + Kp (q_d - q)) + C(q, v) v + g(q) + D v.
- :class:`OperationalSpaceInverseDynamics`, reference the Cartesian vector of
  :data:`armando_drake.kinematics.paths.CARTESIAN_REFERENCE_LAYOUT` (pose, twist,
  acceleration of E in B): a = J#_M (x''_d + Kd e' + Kp e - J-dot v) + N a_0,
  tau = M a + C v + g + D v, with J#_M the M-weighted damped pseudo-inverse, N its
  null space and a_0 the null-space damping, posture and joint-limit term. Arms with
  fewer than 6 joints put the position first and orientation in its null space.

D v compensates the URDF's joint damping. Torques are clamped to the actuators'
effort limits; a non-finite state or reference never reaches the output: the law
holds the last good reference and says so once in the log. The parameter
dataclasses are what a controller registry loads with ``yaml_load_typed``.
"""

import logging
from dataclasses import dataclass

import numpy as np

from armando_drake.kinematics.arm import (
    ArmModel,
    TaskSpaceError,
    posture_acceleration,
    resolve_tasks,
    rotation_matrix_from_quaternion,
    rotation_vector_error,
)
from armando_drake.kinematics.paths import CARTESIAN_REFERENCE_SIZE

_log = logging.getLogger(__name__)


def _positive(name: str, value: float, zero_ok: bool = False) -> None:
    if not np.isfinite(value) or value < 0.0 or (value == 0.0 and not zero_ok):
        bound = ">= 0" if zero_ok else "> 0"
        raise TaskSpaceError(f"{name}={value!r} must be finite and {bound}")


@dataclass
class JointSpaceInverseDynamicsParams:
    """Parameters of the joint-space inverse-dynamics (computed-torque) law."""

    proportional_gain: float = 400.0  # [1/s^2] Kp: joint position error -> acceleration
    derivative_gain: float = 40.0  # [1/s] Kd: joint velocity error -> acceleration

    def validate(self) -> None:
        _positive("proportional_gain", self.proportional_gain)
        _positive("derivative_gain", self.derivative_gain, zero_ok=True)


@dataclass
class OperationalSpaceInverseDynamicsParams:
    """Parameters of the operational-space inverse-dynamics law."""

    position_gain: float = 400.0  # [1/s^2] Kpp: position error -> linear acceleration
    orientation_gain: float = 400.0  # [1/s^2] Kpo: rotation-vector error -> angular accel.
    linear_velocity_gain: float = 40.0  # [1/s] Kdp: velocity error -> linear acceleration
    angular_velocity_gain: float = 40.0  # [1/s] Kdo: angular velocity error -> ang. accel.
    null_space_damping: float = 10.0  # [1/s] null space: joint velocity damping
    posture_gain: float = 0.0  # [1/s^2] null space: towards the rest posture
    limit_gain: float = 10.0  # [rad/s^2] null space: away from the joint limits
    singular_threshold: float = 0.02  # [-] singular values (M-weighted J) damped below this
    max_damping: float = 0.05  # [-] damping at a singular value of zero

    def validate(self) -> None:
        for name in ("position_gain", "orientation_gain", "singular_threshold"):
            _positive(name, getattr(self, name))
        for name in (
            "linear_velocity_gain",
            "angular_velocity_gain",
            "null_space_damping",
            "posture_gain",
            "limit_gain",
            "max_damping",
        ):
            _positive(name, getattr(self, name), zero_ok=True)


class _TorqueLaw:
    """What the two laws share: the arm, effort clamping, bad-input handling, counters."""

    reference_size: int

    def __init__(self, *, arm: ArmModel):
        if not arm.actuated:
            model = arm.plant.GetModelInstanceName(arm.model_instance)
            raise TaskSpaceError(
                f"joints {arm.unactuated_joints} of {model!r} have no actuator: "
                "a torque law needs one per joint"
            )
        self.arm = arm
        self.saturated_ticks = 0  # ticks where some torque was clamped to its effort limit
        self.rejected_ticks = 0  # ticks with a non-finite state or reference
        self._last_reference = None
        self._warned = False

    def _good_reference(self, reference: np.ndarray, q: np.ndarray) -> np.ndarray:
        if np.isfinite(reference.sum()):  # a NaN or inf anywhere makes the sum non-finite
            self._last_reference = reference.copy()
            return reference
        self.rejected_ticks += 1
        if not self._warned:
            _log.warning("%s: non-finite reference %s; holding the last good one",
                         type(self).__name__, reference)  # fmt: skip
            self._warned = True
        return self._last_reference if self._last_reference is not None else self._hold(q)

    def _hold(self, q: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _finish(self, tau: np.ndarray) -> np.ndarray:
        if not np.isfinite(tau.sum()):
            self.rejected_ticks += 1
            tau = np.where(np.isfinite(tau), tau, 0.0)
        limit = self.arm.effort_limit
        if (np.abs(tau) > limit).any():
            self.saturated_ticks += 1
            tau = np.clip(tau, -limit, limit)
        return self.arm.actuation(tau)

    def CalcActuation(self, state: np.ndarray, reference: np.ndarray) -> np.ndarray:
        """The actuation vector (actuation input port order) for the instance's state."""
        arm = self.arm
        q, v = arm.split_instance_state(state)
        if not np.isfinite(q.sum() + v.sum()):
            self.rejected_ticks += 1
            return np.zeros(arm.num_joints)
        arm.set_instance_state(state)
        reference = self._good_reference(np.asarray(reference, dtype=float), q)
        return self._finish(self._torque(q, v, reference))

    def _torque(self, q, v, reference) -> np.ndarray:
        raise NotImplementedError


class JointSpaceInverseDynamics(_TorqueLaw):
    """Computed torque on a joint reference [q_d; v_d; a_d] (3 n numbers)."""

    def __init__(self, *, arm: ArmModel, params: JointSpaceInverseDynamicsParams | None = None):
        super().__init__(arm=arm)
        self.params = params or JointSpaceInverseDynamicsParams()
        self.params.validate()
        self.reference_size = 3 * arm.num_joints

    def _hold(self, q):
        return np.concatenate([q, np.zeros(2 * q.size)])

    def _torque(self, q, v, reference):
        n = self.arm.num_joints
        q_d, v_d, a_d = reference[:n], reference[n : 2 * n], reference[2 * n :]
        p = self.params
        a = a_d + p.derivative_gain * (v_d - v) + p.proportional_gain * (q_d - q)
        arm = self.arm
        return arm.mass_matrix() @ a + arm.coriolis() + arm.gravity() + arm.damping * v


class OperationalSpaceInverseDynamics(_TorqueLaw):
    """Operational-space inverse dynamics on a Cartesian reference (19 numbers)."""

    def __init__(
        self,
        *,
        arm: ArmModel,
        params: OperationalSpaceInverseDynamicsParams | None = None,
        rest: np.ndarray | None = None,
    ):
        super().__init__(arm=arm)
        self.params = params or OperationalSpaceInverseDynamicsParams()
        self.params.validate()
        self.reference_size = CARTESIAN_REFERENCE_SIZE
        self.rest = None if rest is None else np.asarray(rest, dtype=float)
        self.smallest_singular_value = np.inf  # of the M-weighted task Jacobian, over the run
        p = self.params
        self._kp = np.array([p.orientation_gain] * 3 + [p.position_gain] * 3)
        self._kd = np.array([p.angular_velocity_gain] * 3 + [p.linear_velocity_gain] * 3)

    def _hold(self, q):
        X = self.arm.pose()
        return np.concatenate([X.rotation().ToQuaternion().wxyz(), X.translation(), np.zeros(12)])

    def _torque(self, q, v, reference):
        arm, p = self.arm, self.params
        if self.rest is None:
            self.rest = q.copy()
        X = arm.pose()
        J = arm.jacobian()
        R_desired = rotation_matrix_from_quaternion(reference[0:4])
        error = np.empty(6)
        error[:3] = rotation_vector_error(R_desired, X.rotation().matrix())
        error[3:] = reference[4:7] - X.translation()
        commanded = (
            reference[13:19]
            + self._kd * (reference[7:13] - J @ v)
            + self._kp * error
            - arm.bias_acceleration()
        )
        if arm.follows_full_orientation:
            tasks = [(J, commanded)]
        else:
            tasks = [(J[3:], commanded[3:]), (J[:3], commanded[:3])]
        a0 = posture_acceleration(
            arm,
            q,
            v,
            rest=self.rest,
            posture_gain=p.posture_gain,
            limit_gain=p.limit_gain,
            damping_gain=p.null_space_damping,
        )
        M = arm.mass_matrix()
        resolution = resolve_tasks(
            tasks,
            a0,
            threshold=p.singular_threshold,
            max_damping=p.max_damping,
            mass_matrix=M,
        )
        self.smallest_singular_value = min(
            self.smallest_singular_value, resolution.smallest_singular_value
        )
        return M @ resolution.acceleration + arm.coriolis() + arm.gravity() + arm.damping * v


@dataclass(frozen=True)
class TorqueLawType:
    """What a controller registry needs to register a torque law (registered, under
    the type strings it owns, by :mod:`armando_drake.control.controllers.task_space`)."""

    name: str  # the law's name: its class's
    params: type  # the parameters dataclass, the yaml_load_typed schema of ros__parameters
    law: type  # the law class, built as law(arm=ArmModel, params=params)
    reference: str  # "joint": [q_d; v_d; a_d] (3 n); "cartesian": CARTESIAN_REFERENCE_LAYOUT
    command_interfaces: tuple[str, ...]  # claimed per joint
    state_interfaces: tuple[str, ...]  # read per joint


#: The two laws, keyed by their name, for the controller registry to register.
TORQUE_LAWS = {
    entry.name: entry
    for entry in (
        TorqueLawType(
            name=JointSpaceInverseDynamics.__name__,
            params=JointSpaceInverseDynamicsParams,
            law=JointSpaceInverseDynamics,
            reference="joint",
            command_interfaces=("effort",),
            state_interfaces=("position", "velocity"),
        ),
        TorqueLawType(
            name=OperationalSpaceInverseDynamics.__name__,
            params=OperationalSpaceInverseDynamicsParams,
            law=OperationalSpaceInverseDynamics,
            reference="cartesian",
            command_interfaces=("effort",),
            state_interfaces=("position", "velocity"),
        ),
    )
}
