"""Dynamic look-at-point controllers (vision, the seed's 2.c): the camera's position
follows a linear path while its optical axis points at the marker, through the
inverse-dynamics torque laws of the task-space controllers.

Both read the marker's pose in the camera frame, ``/<controller>/marker_pose`` (a
:class:`~armando_drake.vision.detectors.MarkerPose` from the ArUco detector, which
names the camera's link and mount ``X_LC``), command the effort interface of every
moving joint and run at every controller tick (1 kHz in ``vision_dynamic.yaml``):

- at the first marker pose, the camera's linear path starts where the camera is:
  ``p_d(t)`` from the camera's position to that plus ``offset`` [m, world], on the
  parameters' time law (:mod:`armando_drake.kinematics.time_laws`); before it, the arm
  holds its measured state (as the task-space controllers do before a message);
- each marker pose updates the marker's position in the world, ``p_WM = X_WC p_CM``
  (the camera's pose from the measured joints); between poses (30 Hz) and without
  one (marker lost) the last estimate holds: the marker is still;
- the look-at orientation error: the rotation vector ``e_o = theta u`` of the
  smallest rotation taking the optical axis z_C onto ``d = (p_WM - p_WC) / |...|``
  (``u`` along ``z_C x d``): the desired orientation ``R_d = R(theta u) R_WC``
  leaves the roll about the optical axis free. The desired angular velocity
  ``w_d = d x d_dot``, ``d_dot = -(I - d d^T) v_d / |p_WM - p_WC|``, keeps the axis
  on the marker as the camera moves along the path.

``vision_controllers/OperationalSpaceLookAtController`` feeds ``[R_d, p_d, w_d,
v_d, 0, a_d]`` of the camera frame to the operational-space inverse-dynamics law
(:class:`~armando_drake.kinematics.control_laws.OperationalSpaceInverseDynamics`, the same
gains and null space).
``vision_controllers/JointSpaceLookAtController`` turns the same task into a joint
reference by closed-loop inverse kinematics at each tick, on the reference joints
``q_r``: ``v_r = J^+ [w_d + k_o e_o; v_d + k_p (p_d - p_C(q_r))] + N k_0 (q_rest -
q_r)``, ``q_r += v_r dt``, ``a_r = J^+ ([0; a_d] - J-dot v_r)``, and the
joint-space inverse-dynamics law (computed torque) tracks ``[q_r; v_r; a_r]``.
"""

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydrake.common.eigen_geometry import AngleAxis
from pydrake.math import RigidTransform, RotationMatrix

from armando_drake.control.controllers import register
from armando_drake.control.controllers.look_at import damped_pinv
from armando_drake.control.controllers.task_space import (
    JointSpaceInverseDynamicsController,
    JointSpaceInverseDynamicsParameters,
    OperationalSpaceInverseDynamicsController,
    OperationalSpaceInverseDynamicsParameters,
    TorqueMemory,
    _check,
    _InverseDynamicsController,
    _law_params,
)
from armando_drake.kinematics.arm import ArmModel, TaskSpaceError
from armando_drake.kinematics.control_laws import TORQUE_LAWS
from armando_drake.kinematics.motion import TaskSpaceMotion, make_time_law
from armando_drake.kinematics.paths import LinearPath, PathError
from armando_drake.kinematics.time_laws import TimeLawError
from armando_drake.messages.types import MarkerPose
from armando_drake.tools.schema import Refusal, param


class CameraArmModel(ArmModel):
    """An :class:`ArmModel` whose end effector is the camera frame C, fixed at ``X_EC``
    in the link frame E: pose, Jacobian and J-dot v are C's (the same angular rows)."""

    def __init__(self, *, X_EC: RigidTransform, **kwargs):
        super().__init__(**kwargs)
        self.X_EC = X_EC
        self._p_EC = X_EC.translation().copy()

    def pose(self) -> RigidTransform:
        return super().pose() @ self.X_EC

    def jacobian(self) -> np.ndarray:
        from pydrake.multibody.tree import JacobianWrtVariable

        J = self.plant.CalcJacobianSpatialVelocity(
            self.context, JacobianWrtVariable.kV, self.frame_E, self._p_EC, self.frame_B,
            self.frame_B,
        )  # fmt: skip
        return J[:, self._columns]

    def bias_acceleration(self) -> np.ndarray:
        from pydrake.multibody.tree import JacobianWrtVariable

        bias = self.plant.CalcBiasSpatialAcceleration(
            self.context, JacobianWrtVariable.kV, self.frame_E, self._p_EC, self.frame_B,
            self.frame_B,
        )  # fmt: skip
        return np.concatenate([bias.rotational(), bias.translational()])


def _cross(a, b) -> np.ndarray:
    """``a x b`` of two 3-vectors: numpy's cross product without its axis handling (the
    same products and differences, a tenth of the cost at 1 kHz)."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def look_at_rotation(axis: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """theta u [rad]: the smallest rotation taking the unit ``axis`` onto the unit
    ``direction`` (zero when they agree; about any normal when they are opposite)."""
    cross = _cross(axis, direction)
    sine, cosine = float(np.linalg.norm(cross)), float(axis @ direction)
    angle = math.atan2(sine, cosine)
    if sine < 1e-12:
        if cosine > 0:
            return np.zeros(3)
        normal = _cross(axis, [1.0, 0.0, 0.0])
        if np.linalg.norm(normal) < 1e-6:
            normal = _cross(axis, [0.0, 1.0, 0.0])
        return math.pi * normal / np.linalg.norm(normal)
    return angle * cross / sine


@dataclass
class _LookAtPathParameters:
    """The camera's linear path (both dynamic look-at controllers)."""

    # The joints commanded: every moving joint of the robot, in any order.
    joints: list[str] = param([], required=True, nonempty=True, unique=True)
    # [m] the camera's path: its goal minus its start (where it is at the first
    # marker pose), in the world frame.
    offset: list[float] = param([0.0, 0.0, 0.0], unit="m", length=3)
    duration: float = 2.5  # [s] the path's duration
    profile: str = "trapezoidal"  # its time law: trapezoidal | cubic | quintic
    acceleration_time: float = 0.6  # [s] trapezoidal: t_c, 0 < t_c <= duration / 2


def _check_path(params) -> None:
    """The control law's rules and the path's time law's (rules between fields)."""
    _check(params)
    try:
        make_time_law(_motion(params))
    except (PathError, TimeLawError) as error:
        name, equals, problem = str(error).partition("=")
        if not equals:
            raise Refusal("profile", f": {error}") from None
        raise Refusal(name, f"={problem}") from None


def _motion(params) -> TaskSpaceMotion:
    return TaskSpaceMotion(
        path="linear",
        offset=list(params.offset),
        profile=params.profile,
        duration=params.duration,
        acceleration_time=params.acceleration_time,
    )


@dataclass
class OperationalSpaceLookAtParameters(
    OperationalSpaceInverseDynamicsParameters, _LookAtPathParameters
):
    """``ros__parameters`` of the operational-space look-at controller: the law's gains
    and null space, and the camera's path."""

    def check(self) -> None:
        _check_path(self)


@dataclass
class JointSpaceLookAtParameters(JointSpaceInverseDynamicsParameters, _LookAtPathParameters):
    """``ros__parameters`` of the joint-space look-at controller: the law's gains, the
    camera's path and the closed-loop inverse kinematics that makes the joint reference."""

    # [1/s] k_p: camera position error -> velocity (CLIK)
    position_gain: float = param(50.0, unit="1/s", ge=0)
    # [1/s] k_o: look-at error -> angular velocity (CLIK)
    orientation_gain: float = param(10.0, unit="1/s", ge=0)
    # [1/s] k_0: towards rest_positions, in the null space
    null_space_gain: float = param(1.0, unit="1/s", ge=0)
    # [rad] q_rest, one per joint; empty = the joints' positions at the path's start.
    rest_positions: list[float] = param([], unit="rad")
    # [-] damping of the pseudo-inverse (A^T (A A^T + d^2 I)^-1)
    damping: float = param(0.01, unit="-", ge=0)

    def check(self) -> None:
        """The path's rules, and one rest position per joint."""
        _check_path(self)
        if self.rest_positions and len(self.rest_positions) != len(self.joints):
            raise Refusal(
                "rest_positions",
                f"={self.rest_positions!r} must have one value per joint ({len(self.joints)})",
            )


@dataclass(frozen=True)
class _Motion:
    """A look-at motion under way: the camera's law, its path, the marker estimate."""

    law: Any  # the torque law on the camera's CameraArmModel
    path: LinearPath  # the camera's path [m, world]
    time_law: Any  # s(t) of the path
    start: float  # [s] simulation time of the path's t = 0
    target: np.ndarray  # [m] p_WM, the marker's estimated position in the world
    # JointSpaceLookAtController: the reference joints (arm order) and their velocities.
    q_r: np.ndarray | None = None
    v_r: np.ndarray | None = None
    q_rest: np.ndarray | None = None
    last: float = 0.0  # [s] time of the previous tick


class _DynamicLookAt(_InverseDynamicsController):
    """What both dynamic look-at controllers share: the camera's law, path and target."""

    message = MarkerPose
    topic = "marker_pose"

    def _camera_law(self, link: str, X_LC: RigidTransform):
        key = ("camera", link, X_LC.GetAsMatrix34().tobytes())
        law = self._laws.get(key)
        if law is not None:
            return law
        reference = self._law("", "")  # checks the joints; its orders are the camera's too
        plant, instance = self._plant, self._instance
        try:
            frame = plant.GetBodyByName(link, instance).body_frame()
        except RuntimeError:
            raise TaskSpaceError(f"link {link!r} is not a body of the robot") from None
        arm = CameraArmModel(
            plant=plant, end_effector_frame=frame, model_instance=instance, X_EC=X_LC
        )
        entry = TORQUE_LAWS[self.law_type]
        law = entry.law(arm=arm, params=_law_params(entry.params, self.params))
        for name in ("controller_order", "q_slots", "v_slots", "reach"):
            setattr(law, name, getattr(reference, name))
        self._laws[key] = law
        return law

    def _arm_state(self, law, q, v) -> tuple[np.ndarray, np.ndarray]:
        n = law.arm.num_joints
        q_arm, v_arm = np.empty(n), np.empty(n)
        q_arm[law.controller_order] = q
        v_arm[law.controller_order] = v
        return q_arm, v_arm

    def _start(self, message: MarkerPose, q, v, now) -> _Motion:
        law = self._camera_law(message.link, message.X_LC)
        q_arm, v_arm = self._arm_state(law, q, v)
        law.arm.set_state(q_arm, v_arm)
        p_start = law.arm.pose().translation()
        goal = p_start + np.asarray(self.params.offset, dtype=float)
        time_law = make_time_law(_motion(self.params))
        rest = getattr(self.params, "rest_positions", None)
        q_rest = q_arm.copy()
        if rest:
            q_rest[law.controller_order] = np.asarray(rest, dtype=float)
        return _Motion(
            law=law,
            path=LinearPath(start=p_start, goal=goal),
            time_law=time_law,
            start=now,
            target=np.zeros(3),
            q_r=q_arm.copy(),
            v_r=v_arm.copy(),
            q_rest=q_rest,
            last=now,
        )

    def _path(self, motion: _Motion, now: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(p_d, v_d, a_d) [m, m/s, m/s^2] of the camera at ``now``."""
        t = max(now - motion.start, 0.0)
        if t >= motion.time_law.duration:  # the end: held (the law's s'' at T is not zero)
            return motion.path.goal, np.zeros(3), np.zeros(3)
        law = motion.time_law(np.array([t]))
        sample = motion.path(law.s, law.s_dot, law.s_ddot)
        return sample.position[0], sample.velocity[0], sample.acceleration[0]

    @staticmethod
    def _look_at(X_WC: RigidTransform, target: np.ndarray, v_d: np.ndarray):
        """(e_o, w_d): the look-at error and the angular velocity that keeps it at zero."""
        offset = target - X_WC.translation()
        distance = float(np.linalg.norm(offset))
        if distance < 1e-6:  # [m] at the marker: no direction to look in
            return np.zeros(3), np.zeros(3)
        d = offset / distance
        e_o = look_at_rotation(X_WC.rotation().matrix()[:, 2], d)
        d_dot = -(v_d - d * (d @ v_d)) / distance
        return e_o, _cross(d, d_dot)

    def _torque(self, motion: _Motion, q, v, now) -> tuple[np.ndarray, _Motion, float]:
        """The torques (controller order), the motion after this tick and the camera's
        distance from its path [m], at the measured (q, v)."""
        raise NotImplementedError

    def update(self, now, message, memory, measure):
        motion = memory.internal
        if message is None and motion is None:
            return super().update(now, None, memory, measure)  # hold until the marker is seen
        q, v = measure(memory.desired)
        q, v = np.asarray(q, dtype=float), np.asarray(v, dtype=float)
        status = memory.status
        if message is not None:
            if not isinstance(message, MarkerPose):
                status = self.reject(status, f"expected a MarkerPose, got {type(message).__name__}")
                if motion is None:  # still holding
                    return super().update(now, None, dataclasses.replace(memory, status=status),
                                          measure)  # fmt: skip
            else:
                try:
                    # The marker in the world through the camera that saw it (the path
                    # and the pointing are those of the camera of the first pose).
                    law = self._camera_law(message.link, message.X_LC)
                    if motion is None:
                        motion = self._start(message, q, v, now)
                    law.arm.set_state(*self._arm_state(law, q, v))
                    target = law.arm.pose() @ message.pose.translation()
                    motion = dataclasses.replace(motion, target=target)
                    detail = {
                        "target": target.tolist(),  # [m] p_WM, the marker's estimate
                        "path_start": motion.path.start.tolist(),  # [m] the camera's path
                        "path_goal": motion.path.goal.tolist(),
                        "path_start_time": motion.start,  # [s]
                    }
                    if "max_path_error" in status.detail:  # kept over the messages
                        detail["max_path_error"] = status.detail["max_path_error"]
                    status = self.accept(status, "executing", detail)
                except TaskSpaceError as error:
                    status = self.reject(status, str(error))
                    if motion is None:  # still holding
                        return super().update(
                            now, None, dataclasses.replace(memory, status=status), measure
                        )
        effort, motion, error = self._torque(motion, q, v, now)
        if error > status.detail.get("max_path_error", 0.0):
            # [m] the largest distance so far of the camera from its path (measured joints)
            status = dataclasses.replace(status, detail={**status.detail, "max_path_error": error})
        return TorqueMemory(memory.desired, status, trajectory=None, effort=effort, internal=motion)


def _effort(law, q, v, reference) -> np.ndarray:
    """The controller-order torques of ``law`` at (q, v) for ``reference``."""
    state = np.zeros(law.arm.num_instance_states)
    state[law.q_slots] = q
    state[law.v_slots] = v
    u = law.CalcActuation(state, reference)
    tau = np.empty(law.arm.num_joints)
    tau[law.arm.actuation_order] = u
    return tau[law.controller_order]


@register("vision_controllers/JointSpaceLookAtController")
class JointSpaceLookAtController(_DynamicLookAt):
    """The camera's linear path and the look-at orientation by closed-loop inverse
    kinematics, tracked by joint-space inverse dynamics (computed torque)."""

    parameters = JointSpaceLookAtParameters
    law_type = "JointSpaceInverseDynamics"
    _hold = JointSpaceInverseDynamicsController._hold  # before the marker is seen

    def _torque(self, motion, q, v, now):
        law, p = motion.law, self.params
        arm = law.arm
        dt = max(now - motion.last, 0.0)
        q_r = np.clip(motion.q_r + motion.v_r * dt, arm.lower, arm.upper)
        arm.set_state(q_r, motion.v_r)
        X_WC = arm.pose()
        J = arm.jacobian()
        p_d, v_d, a_d = self._path(motion, now)
        e_o, w_d = self._look_at(X_WC, motion.target, v_d)
        twist = np.concatenate(
            [w_d + p.orientation_gain * e_o, v_d + p.position_gain * (p_d - X_WC.translation())]
        )
        J_pinv = damped_pinv(J, p.damping)
        null = np.eye(arm.num_joints) - J_pinv @ J
        v_r = J_pinv @ twist + null @ (p.null_space_gain * (motion.q_rest - q_r))
        arm.set_state(q_r, v_r)
        a_r = J_pinv @ (np.concatenate([np.zeros(3), a_d]) - arm.bias_acceleration())
        reference = np.concatenate([q_r, v_r, a_r])
        motion = dataclasses.replace(motion, q_r=q_r, v_r=v_r, last=now)
        effort = _effort(law, q, v, reference)  # (leaves the measured state in the arm)
        error = float(np.linalg.norm(arm.pose().translation() - p_d))
        return effort, motion, error


@register("vision_controllers/OperationalSpaceLookAtController")
class OperationalSpaceLookAtController(_DynamicLookAt):
    """The camera's linear path and the look-at orientation through operational-space
    inverse dynamics."""

    parameters = OperationalSpaceLookAtParameters
    law_type = "OperationalSpaceInverseDynamics"
    _hold = OperationalSpaceInverseDynamicsController._hold  # before the marker is seen

    def _torque(self, motion, q, v, now):
        law = motion.law
        law.arm.set_state(*self._arm_state(law, q, v))
        X_WC = law.arm.pose()
        p_d, v_d, a_d = self._path(motion, now)
        e_o, w_d = self._look_at(X_WC, motion.target, v_d)
        angle = float(np.linalg.norm(e_o))
        turn = RotationMatrix(AngleAxis(angle, e_o / angle)) if angle > 0 else RotationMatrix()
        R_d = turn.multiply(X_WC.rotation())
        reference = np.concatenate([R_d.ToQuaternion().wxyz(), p_d, w_d, v_d, np.zeros(3), a_d])
        error = float(np.linalg.norm(X_WC.translation() - p_d))
        return _effort(law, q, v, reference), motion, error


__all__ = [
    "CameraArmModel",
    "JointSpaceLookAtController",
    "OperationalSpaceLookAtController",
    "look_at_rotation",
]
