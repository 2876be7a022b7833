"""An arm in a finalized MultibodyPlant, seen from its base: kinematics and dynamics.

Everything comes from the plant (``CalcRelativeTransform``,
``CalcJacobianSpatialVelocity``, ``CalcBiasSpatialAcceleration``, ``CalcMassMatrix``,
``CalcBiasTerm``, ``CalcGravityGeneralizedForces``); nothing is hand-derived. Spatial
vectors follow Drake: rotation first, ``[w; v]``, expressed in the base frame B.

Also the linear algebra the task-space code shares: the damped (and optionally
mass-weighted) pseudo-inverse, the prioritised task resolution with a null-space
term, the orientation error and the null-space posture / joint-limit term.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Frame, JacobianWrtVariable, ModelInstanceIndex


class TaskSpaceError(ValueError):
    """A task-space request the arm cannot carry out (bad frame, unreachable, singular...)."""


class ArmModel:
    """The joints of one model instance, an end-effector frame E and a base frame B.

    The arm's joints must each have one position and one velocity (revolute or
    prismatic). Its own plant context is used for every computation, so an
    ``ArmModel`` may share the plant of a running diagram.
    """

    def __init__(
        self,
        *,
        plant: MultibodyPlant,
        end_effector_frame: str | Frame,
        base_frame: str | Frame | None = None,
        model_instance: ModelInstanceIndex | None = None,
    ):
        if not plant.is_finalized():
            raise TaskSpaceError("the plant must be finalized before building an ArmModel")
        self.plant = plant
        self.frame_E = self._frame(end_effector_frame, model_instance)
        instance = model_instance if model_instance is not None else self.frame_E.model_instance()
        self.model_instance = instance
        self.frame_B = (
            self._frame(base_frame, instance) if base_frame is not None else plant.world_frame()
        )
        joints = [plant.get_joint(i) for i in plant.GetJointIndices(instance)]
        joints = [j for j in joints if j.num_velocities() > 0]
        odd = [j.name() for j in joints if j.num_positions() != 1 or j.num_velocities() != 1]
        if odd:
            raise TaskSpaceError(f"joints {odd} are not 1-dof joints: not an arm ArmModel handles")
        if not joints:
            raise TaskSpaceError(f"model instance {plant.GetModelInstanceName(instance)!r} "
                                 "has no moving joints")  # fmt: skip
        self.joint_names = [j.name() for j in joints]
        self.position_indices = np.array([j.position_start() for j in joints])
        self.velocity_indices = np.array([j.velocity_start() for j in joints])
        self.lower = np.array([j.position_lower_limits()[0] for j in joints])
        self.upper = np.array([j.position_upper_limits()[0] for j in joints])
        self.velocity_limit = np.array([j.velocity_upper_limits()[0] for j in joints])
        self.damping = np.array([j.default_damping_vector()[0] for j in joints])
        # Actuators, in the order of the instance's actuation input port.
        actuators = [plant.get_joint_actuator(i) for i in plant.GetJointActuatorIndices(instance)]
        by_velocity = {a.joint().velocity_start(): a for a in actuators}
        unactuated = [j.name() for j in joints if j.velocity_start() not in by_velocity]
        self.actuated = not unactuated and len(actuators) == len(joints)
        # actuation u (port order) = tau[self.actuation_order] (joint order)
        index_of = {v: k for k, v in enumerate(self.velocity_indices)}
        self.actuation_order = np.array([index_of[a.joint().velocity_start()] for a in actuators])
        self.effort_limit = np.full(len(joints), np.inf)
        for actuator in actuators:
            self.effort_limit[index_of[actuator.joint().velocity_start()]] = actuator.effort_limit()
        self.unactuated_joints = unactuated
        self.context = plant.CreateDefaultContext()
        # Where the arm's q and v sit in the instance's state vector [q_instance; v_instance].
        global_q = plant.GetPositionsFromArray(
            instance, np.arange(plant.num_positions(), dtype=float)
        )
        global_v = plant.GetVelocitiesFromArray(
            instance, np.arange(plant.num_velocities(), dtype=float)
        )
        slot_q = {int(g): k for k, g in enumerate(global_q)}
        slot_v = {int(g): k for k, g in enumerate(global_v)}
        self.state_position_slots = np.array([slot_q[i] for i in self.position_indices])
        self.state_velocity_slots = len(global_q) + np.array(
            [slot_v[i] for i in self.velocity_indices]
        )
        self.num_instance_states = len(global_q) + len(global_v)
        # The arm is the whole plant (the usual case): no slicing per tick.
        self._whole = np.array_equal(self.velocity_indices, np.arange(plant.num_velocities()))
        self._columns = slice(None) if self._whole else self.velocity_indices
        span = self.upper - self.lower
        self._limited = np.isfinite(span) & (span > 0)
        self._middle = np.where(self._limited, 0.5 * (self.upper + self.lower), 0.0)
        self._inverse_span2 = np.where(
            self._limited, 1.0 / np.where(self._limited, span, 1) ** 2, 0
        )

    def _frame(self, frame: str | Frame, instance) -> Frame:
        if not isinstance(frame, str):
            return frame
        try:
            if instance is None:
                return self.plant.GetFrameByName(frame)
            return self.plant.GetFrameByName(frame, instance)
        except RuntimeError as error:
            raise TaskSpaceError(f"frame {frame!r} is not in the plant: {error}") from None

    # ------------------------------------------------------------------ sizes
    @property
    def num_joints(self) -> int:
        return len(self.joint_names)

    @property
    def follows_full_orientation(self) -> bool:
        """True when the arm has the 6 joints a full pose (position + 3 rotations) needs."""
        return self.num_joints >= 6

    # ------------------------------------------------------------------ state
    def set_state(self, q, v=None) -> None:
        """Sets the arm's joint positions [rad] (and velocities [rad/s]) in its context."""
        positions = self.plant.GetPositions(self.context)
        positions[self.position_indices] = q
        self.plant.SetPositions(self.context, positions)
        velocities = self.plant.GetVelocities(self.context)
        velocities[self.velocity_indices] = 0.0 if v is None else v
        self.plant.SetVelocities(self.context, velocities)

    def split_instance_state(self, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) of the arm's joints from the instance's state vector (the plant's port)."""
        state = np.asarray(state)
        return state[self.state_position_slots], state[self.state_velocity_slots]

    def set_instance_state(self, state: np.ndarray) -> None:
        """Sets the model instance's state [q; v] (as its state output port gives it)."""
        self.plant.SetPositionsAndVelocities(self.context, self.model_instance, state)

    def default_positions(self) -> np.ndarray:
        return self.plant.GetDefaultPositions()[self.position_indices]

    # ------------------------------------------------------------------ kinematics
    def pose(self) -> RigidTransform:
        """X_BE at the context's state."""
        return self.plant.CalcRelativeTransform(self.context, self.frame_B, self.frame_E)

    def jacobian(self) -> np.ndarray:
        """(6, n) J with V_BE = J v, rows [w; v], expressed in B."""
        J = self.plant.CalcJacobianSpatialVelocity(
            self.context,
            JacobianWrtVariable.kV,
            self.frame_E,
            np.zeros(3),
            self.frame_B,
            self.frame_B,
        )
        return J[:, self._columns]

    def bias_acceleration(self) -> np.ndarray:
        """(6,) J-dot v of E in B, rows [alpha; a] (the spatial acceleration at zero v-dot)."""
        bias = self.plant.CalcBiasSpatialAcceleration(
            self.context,
            JacobianWrtVariable.kV,
            self.frame_E,
            np.zeros(3),
            self.frame_B,
            self.frame_B,
        )
        return np.concatenate([bias.rotational(), bias.translational()])

    # ------------------------------------------------------------------ dynamics
    def mass_matrix(self) -> np.ndarray:
        """(n, n) M(q) of the arm's joints."""
        M = self.plant.CalcMassMatrix(self.context)
        return M if self._whole else M[np.ix_(self.velocity_indices, self.velocity_indices)]

    def coriolis(self) -> np.ndarray:
        """(n,) C(q, v) v, from CalcBiasTerm."""
        return self.plant.CalcBiasTerm(self.context)[self._columns]

    def gravity(self) -> np.ndarray:
        """(n,) g(q): the joint torques that hold the arm against gravity (= -tau_g)."""
        return -self.plant.CalcGravityGeneralizedForces(self.context)[self._columns]

    def actuation(self, tau: np.ndarray) -> np.ndarray:
        """Joint torques (joint order) as the actuation input port's vector."""
        return np.asarray(tau)[self.actuation_order]


# ---------------------------------------------------------------------- algebra


def orientation_error(R_desired: RotationMatrix, R: RotationMatrix) -> np.ndarray:
    """(3,) the rotation vector (axis * angle) [rad] taking R to R_desired, in the base frame."""
    angle_axis = R_desired.multiply(R.inverse()).ToAngleAxis()
    return angle_axis.axis() * angle_axis.angle()


def rotation_matrix_from_quaternion(wxyz: np.ndarray) -> np.ndarray:
    """The 3x3 rotation matrix of a (normalised here) quaternion (w, x, y, z), in numpy."""
    w, x, y, z = wxyz / np.sqrt(wxyz @ wxyz)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def rotation_vector_error(R_desired: np.ndarray, R: np.ndarray) -> np.ndarray:
    """:func:`orientation_error` on 3x3 arrays (numpy only, for the per-tick laws)."""
    E = R_desired @ R.T
    cosine = min(1.0, max(-1.0, 0.5 * (E[0, 0] + E[1, 1] + E[2, 2] - 1.0)))
    angle = np.arccos(cosine)
    vee = np.array([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], E[1, 0] - E[0, 1]])
    if angle < 1e-6:
        return 0.5 * vee  # sin(angle) ~ angle
    if np.pi - angle > 1e-6:
        return vee * (angle / (2.0 * np.sin(angle)))
    return orientation_error(RotationMatrix(E), RotationMatrix())  # near pi: Drake's


@dataclass(frozen=True)
class Resolution:
    """The joint acceleration of a prioritised task resolution, and how well-posed it was."""

    acceleration: np.ndarray  # [rad/s^2] (n,)
    smallest_singular_value: float  # of the first task's (weighted) Jacobian
    singular_value_ratio: float  # its smallest over its largest singular value (0: singular)
    null_space: np.ndarray  # (n, n) projector onto the motions that leave all tasks alone


def resolve_tasks(
    tasks: list[tuple[np.ndarray, np.ndarray]],
    posture_acceleration: np.ndarray,
    *,
    threshold: float,
    max_damping: float,
    mass_matrix: np.ndarray | None = None,
    secondary_threshold: float | None = None,
    secondary_damping: float | None = None,
) -> Resolution:
    """Joint accelerations a with J_i a = b_i by priority, plus the null-space term.

    ``tasks`` are (J_i, b_i) with b_i = desired task acceleration - J-dot_i v. Each
    lower-priority task acts in the null space of those above; the remaining null
    space gets ``posture_acceleration``. With ``mass_matrix`` the pseudo-inverses
    are weighted by M (normalised by its mean diagonal): J# = M^-1 J^T (J M^-1 J^T)^-1,
    the dynamically consistent inverse. Tasks after the first are damped with
    ``secondary_threshold`` / ``secondary_damping`` (default: as the first), so a
    lower-priority task gives way well before its own singularity.
    """
    n = posture_acceleration.shape[0]
    if mass_matrix is None:
        W_inv = None
    else:
        W_inv = np.linalg.inv(mass_matrix * (n / np.trace(mass_matrix)))
    a = np.zeros(n)
    P = np.eye(n)
    smallest, ratio = np.inf, 1.0
    for i, (J, b) in enumerate(tasks):
        JP = J @ P
        limit, damping = threshold, max_damping
        if i > 0:
            limit = secondary_threshold if secondary_threshold is not None else threshold
            damping = secondary_damping if secondary_damping is not None else max_damping
        # Damped inverse: each singular value sigma of JP W^-1/2 below ``limit`` becomes
        # sigma / (sigma^2 + lambda^2), lambda^2 = damping^2 (1 - (sigma / limit)^2), so
        # J# stays bounded at a singularity and directions at sigma = 0 are dropped.
        # J# = W^-1 (JP)^T U diag(1 / (sigma^2 + lambda^2)) U^T, with sigma^2 and U the
        # eigen-decomposition of JP W^-1 (JP)^T (no SVD of the rows x n matrix).
        JW = JP.T if W_inv is None else W_inv @ JP.T
        sigma2, U = np.linalg.eigh(JP @ JW)
        sigma2 = np.maximum(sigma2, 0.0)
        S = np.sqrt(sigma2)
        lam2 = np.where(S < limit, damping**2 * (1.0 - (S / limit) ** 2), 0.0)
        denominator = sigma2 + lam2
        scale = np.divide(1.0, denominator, out=np.zeros_like(S), where=denominator > 1e-300)
        scale[S <= 1e-9 * S[-1]] = 0.0  # numerically zero: J# maps nothing there anyway
        JP_pinv = JW @ ((U * scale) @ U.T)
        if i == 0 and S.size:
            smallest = float(S[0])  # eigh sorts ascending
            ratio = smallest / S[-1] if S[-1] > 0 else 0.0
        a = a + JP_pinv @ (b - J @ a)
        P = P - JP_pinv @ JP
    return Resolution(
        acceleration=a + P @ posture_acceleration,
        smallest_singular_value=smallest,
        singular_value_ratio=ratio,
        null_space=P,
    )


def posture_acceleration(
    arm: ArmModel,
    q: np.ndarray,
    v: np.ndarray,
    *,
    rest: np.ndarray,
    posture_gain: float,
    limit_gain: float,
    damping_gain: float,
) -> np.ndarray:
    """The null-space joint acceleration: to ``rest``, away from the limits, damped.

    posture_gain (rest - q) + limit_gain * (-grad H) - damping_gain v, where
    H = sum(((q - mid) / (upper - lower))^2) / 2 grows towards the limits (joints
    without finite limits contribute nothing).
    """
    limit_term = -(q - arm._middle) * arm._inverse_span2
    return posture_gain * (rest - q) + limit_gain * limit_term - damping_gain * v


def describe_task(arm: ArmModel, q: np.ndarray) -> str:
    """One line naming what the task controls for this arm (logged by the planners)."""
    if arm.follows_full_orientation:
        extra = arm.num_joints - 6
        return (
            f"{arm.num_joints} joints: task = position (3) + orientation (3) of "
            f"{arm.frame_E.name()!r}; {extra} redundant joint(s) go to the null-space posture"
        )
    arm.set_state(q)
    J = arm.jacobian()
    _, S_p, Vt_p = np.linalg.svd(J[3:], full_matrices=True)
    rank = int(np.sum(S_p > 1e-9))
    null = Vt_p[rank:].T  # joint motions that keep the position
    Jo_null = J[:3] @ null
    U, S, _ = np.linalg.svd(Jo_null, full_matrices=False)
    axes = [U[:, k] for k in range(len(S)) if S[k] > 1e-6]
    axes_text = ", ".join(np.array2string(axis, precision=3, suppress_small=True) for axis in axes)
    return (
        f"{arm.num_joints} joints: task = position (3) of {arm.frame_E.name()!r}, first; then "
        f"orientation in its null space: {len(axes)} component(s) the arm can follow "
        f"(rotation about {axes_text or 'no axis'} in the base frame at the start), "
        "the others are not controlled"
    )


def last_link_frame(plant, instance):
    """The body frame of the child link of the robot's last moving joint (the end
    effector when the scenario names none)."""
    moving = [plant.get_joint(i) for i in plant.GetJointIndices(instance)]
    moving = [j for j in moving if j.num_velocities() > 0]
    return max(moving, key=lambda j: j.velocity_start()).child_body().body_frame()


def tool_frame(plant, instance):
    """The robot's tool link: from the child of its last moving joint along the links
    welded to it, as long as the chain does not branch (a gripper's palm, before its
    fingers); that child itself when it branches at once or has none."""
    body = last_link_frame(plant, instance).body()
    while True:
        welded = [
            plant.get_joint(i).child_body()
            for i in plant.GetJointIndices(instance)
            if plant.get_joint(i).parent_body().index() == body.index()
            and plant.get_joint(i).num_velocities() == 0
        ]
        if len(welded) != 1:
            return body.body_frame()
        body = welded[0]
