"""Look-at-point controllers (vision, #15): the camera on the arm turns towards a marker.

Both read the marker's pose in the camera frame, ``/<controller>/marker_pose`` (a
:class:`~armando_drake.vision.detectors.MarkerPose` from the ArUco detector, which
also names the camera's link and its mount ``X_LC``), and command joint velocities
[rad/s] on the velocity interface. The camera Jacobian ``J`` (6 x n, ``[w; v]`` of
the camera frame C, expressed in C) comes from the plant
(``CalcJacobianSpatialVelocity``), at the measured joint positions.

- ``vision_controllers/LookAtPointController`` (the seed's 2.a): resolved-velocity
  control towards the camera pose ``X_MCd`` offset from the marker:
  ``qdot = J^+ k [theta u; p] + N k0 (q_rest - q)``, with ``(theta u, p)`` the
  rotation vector and translation of ``X_CCd = X_CM X_MCd``;
- ``vision_controllers/ImprovedLookAtPointController`` (2.b): on the unit vector
  ``s = p / |p|`` towards the marker, whose interaction matrix is
  ``L = [[s]x, -(I - s s^T) / |p|]`` (``s_dot = L [w; v]`` for a still marker):
  ``qdot = k (L J)^+ s_d + N k0 (q_rest - q)``, ``s_d = (0, 0, 1)``.

``N = I - A^+ A`` is the null-space projector of the task matrix ``A`` (``J`` or
``L J``), ``A^+`` its damped pseudo-inverse. The velocities are scaled down
together to the joints' velocity limits. Without a new marker pose for
``timeout`` seconds (marker lost) the joints are commanded to stop.

On the position interface (``interface: position``, a robot whose servos take
positions, as Armando's) the same velocities are integrated into the position
command at every controller update (``q_d += qdot dt``, from the measured
positions at the first pose, clamped into the joint limits), with ``qdot`` as the
desired velocity; the marker lost, ``q_d`` holds.
"""

import dataclasses
import math

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.tree import JacobianWrtVariable

from armando_drake.control.controllers import (
    Controller,
    ControllerMemory,
    register,
)
from armando_drake.messages.types import MarkerPose
from armando_drake.tools.schema import Refusal, param


@dataclasses.dataclass
class LookAtPointParameters:
    """The parameters of the look-at-point controllers."""

    # The joints commanded (velocity interface), in order.
    joints: list[str] = param([], nonempty=True, unique=True)
    gain: float = param(2.0, unit="1/s", gt=0)  # [1/s] k: rate at which the task error decays
    # [1/s] k0: rate towards the rest posture, in the null space
    null_space_gain: float = param(1.0, unit="1/s", ge=0)
    # [rad] q_rest, one per joint; empty = the joints' initial positions.
    rest_positions: list[float] = param([], unit="rad")
    # [-] damping of the pseudo-inverse (A^T (A A^T + d^2 I)^-1)
    damping: float = param(0.01, unit="-", ge=0)
    timeout: float = param(0.2, unit="s", ge=0)  # [s] without a new marker pose, the joints stop
    # The command interface of the joints: velocity (commands qdot) or position
    # (commands the integral of qdot, for position servos).
    interface: str = param("velocity", choices=("velocity", "position"))
    # LookAtPointController only: the desired camera pose in the marker frame
    # (OpenCV's: z out of the face): [m] position and [rad] roll pitch yaw. The default
    # is 0.5 m in front of the face, looking at it.
    offset_xyz: list[float] = param([0.0, 0.0, 0.5], unit="m", length=3)
    offset_rpy: list[float] = param([math.pi, 0.0, 0.0], unit="rad", length=3)

    def check(self) -> None:
        """The rules between fields (the fields' own are declared beside them)."""
        if self.rest_positions and len(self.rest_positions) != len(self.joints):
            raise Refusal(
                "rest_positions",
                f"={self.rest_positions!r} must have one value per joint ({len(self.joints)})",
            )


def damped_pinv(A: np.ndarray, damping: float) -> np.ndarray:
    """``A^T (A A^T + damping^2 I)^-1``."""
    return A.T @ np.linalg.inv(A @ A.T + damping**2 * np.eye(A.shape[0]))


def skew(s: np.ndarray) -> np.ndarray:
    """[s]x: skew(s) @ w == cross(s, w)."""
    return np.array([[0.0, -s[2], s[1]], [s[2], 0.0, -s[0]], [-s[1], s[0], 0.0]])


def interaction_matrix(p: np.ndarray) -> np.ndarray:
    """L (3 x 6) of s = p / |p| for a still point p in the camera frame C: s_dot = L [w; v]
    ([w; v] the camera's spatial velocity, expressed in C)."""
    distance = float(np.linalg.norm(p))
    s = p / distance
    return np.hstack([skew(s), -(np.eye(3) - np.outer(s, s)) / distance])


class _LookAt(Controller):
    """What both look-at-point controllers share: the camera Jacobian and the loop."""

    parameters = LookAtPointParameters
    message = MarkerPose
    topic = "marker_pose"
    fixed_interface = None  # velocity or position, from the parameters
    initial_state = "holding"

    @classmethod
    def command_interface(cls, params) -> str:
        return params.interface

    def connect_plant(self, plant, model_instance) -> None:
        self._plant = plant
        self._instance = model_instance
        self._context = plant.CreateDefaultContext()
        joints = [plant.GetJointByName(name, model_instance) for name in self.joint_names]
        self._q_index = np.array([j.position_start() for j in joints])
        self._v_index = np.array([j.velocity_start() for j in joints])
        rest = self.params.rest_positions or self.joints.initial_positions
        self._q_rest = np.asarray(rest, dtype=float)
        self._frames = {}

    def camera_jacobian(self, q: np.ndarray, link: str, X_LC: RigidTransform) -> np.ndarray:
        """J (6 x n): [w; v] of the camera frame C in the world, expressed in C, per
        joint velocity of the controller's joints, at their positions ``q``."""
        plant, context = self._plant, self._context
        positions = plant.GetPositions(context)
        positions[self._q_index] = q
        plant.SetPositions(context, positions)
        if link not in self._frames:
            self._frames[link] = plant.GetBodyByName(link, self._instance).body_frame()
        frame_L = self._frames[link]
        world = plant.world_frame()
        J_W = plant.CalcJacobianSpatialVelocity(
            context, JacobianWrtVariable.kV, frame_L, X_LC.translation(), world, world
        )[:, self._v_index]
        R_WC = frame_L.CalcPoseInWorld(context).rotation() @ X_LC.rotation()
        R_CW = R_WC.inverse().matrix()
        return np.vstack([R_CW @ J_W[:3], R_CW @ J_W[3:]])

    def task(self, X_CM: RigidTransform, J: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
        """The task matrix A (m x n), the desired task rate (m) and status details."""
        raise NotImplementedError

    def command(self, message: MarkerPose, q: np.ndarray) -> tuple[np.ndarray, dict]:
        """The joint velocities [rad/s] for a marker pose, and status details."""
        J = self.camera_jacobian(q, message.link, message.X_LC)
        A, rate, detail = self.task(message.pose, J)
        A_pinv = damped_pinv(A, self.params.damping)
        null = np.eye(self.n) - A_pinv @ A
        qdot = A_pinv @ rate + null @ (self.params.null_space_gain * (self._q_rest - q))
        limit = self.joints.velocity
        scale = np.max(np.abs(qdot) / limit) if np.all(np.isfinite(limit)) else 0.0
        if scale > 1.0:
            qdot = qdot / scale
        return qdot, detail

    def update(self, now, message, memory, measure):
        if self.interface == "position":
            return self._update_position(now, message, memory, measure)
        n = self.n
        if message is None:
            last = memory.trajectory
            if last is None or now - last.stamp <= self.params.timeout:
                return memory
            status = dataclasses.replace(memory.status, state="holding")
            return ControllerMemory(
                np.concatenate([memory.desired[:n], np.zeros(n)]), status, trajectory=None
            )
        q, _ = measure(memory.desired)
        qdot, detail = self.command(message, np.asarray(q, dtype=float))
        status = self.accept(memory.status, "executing", detail)
        return ControllerMemory(np.concatenate([q, qdot]), status, trajectory=message)

    def _update_position(self, now, message, memory, measure):
        """Position servos: q_d integrates the commanded velocities at every update
        (``internal``: the time of the previous update [s])."""
        n = self.n
        q_d, qdot = memory.desired[:n], memory.desired[n:]
        if memory.trajectory is not None and memory.internal is not None:
            q_d = np.clip(q_d + qdot * (now - memory.internal), self.lower, self.upper)
        if message is None:
            last = memory.trajectory
            if last is None:
                return memory
            if now - last.stamp > self.params.timeout:  # lost: hold where it is
                status = dataclasses.replace(memory.status, state="holding")
                return ControllerMemory(np.concatenate([q_d, np.zeros(n)]), status)
            return dataclasses.replace(memory, desired=np.concatenate([q_d, qdot]), internal=now)
        q, _ = measure(memory.desired)
        q = np.asarray(q, dtype=float)
        if memory.trajectory is None:  # (re)starting: from where the joints are
            q_d = q
        qdot, detail = self.command(message, q)
        status = self.accept(memory.status, "executing", detail)
        return ControllerMemory(
            np.concatenate([q_d, qdot]), status, trajectory=message, internal=now
        )


@register("vision_controllers/LookAtPointController")
class LookAtPointController(_LookAt):
    """The seed's 2.a: resolved velocities towards a camera pose offset from the marker."""

    def task(self, X_CM, J):
        X_MCd = RigidTransform(RollPitchYaw(self.params.offset_rpy), self.params.offset_xyz)
        X_CCd = X_CM @ X_MCd
        angle_axis = X_CCd.rotation().ToAngleAxis()
        rotation = angle_axis.angle() * angle_axis.axis()
        twist = self.params.gain * np.concatenate([rotation, X_CCd.translation()])
        s = X_CM.translation() / np.linalg.norm(X_CM.translation())
        return J, twist, {"s": s.tolist(), "position_error": float(np.linalg.norm(twist[3:]))}


@register("vision_controllers/ImprovedLookAtPointController")
class ImprovedLookAtPointController(_LookAt):
    """The seed's 2.b: qdot = k (L J)^+ s_d + N (q_rest - q) on s = p / |p|."""

    def task(self, X_CM, J):
        p = X_CM.translation()
        s = p / np.linalg.norm(p)
        s_d = np.array([0.0, 0.0, 1.0])
        return interaction_matrix(p) @ J, self.params.gain * s_d, {"s": s.tolist()}


__all__ = [
    "ImprovedLookAtPointController",
    "LookAtPointController",
    "LookAtPointParameters",
    "interaction_matrix",
]
