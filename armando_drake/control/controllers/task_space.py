"""Inverse-dynamics torque controllers: ``task_space_controllers/JointSpaceInverseDynamics``
and ``task_space_controllers/OperationalSpaceInverseDynamics``.

Both command the effort interface of every moving joint of the robot and run a torque
law of :mod:`armando_drake.kinematics.control_laws` at each controller tick, with M, C v, g,
J and J-dot v from the world's MultibodyPlant (:class:`~armando_drake.kinematics.arm.ArmModel`
on its own context, so nothing is hand-derived):

- ``JointSpaceInverseDynamics`` (computed torque) reads a
  ``trajectory_msgs/JointTrajectory`` on ``/<controller>/joint_trajectory``: every
  point needs positions; velocities and accelerations may be empty (zero). Its
  joint names must be the controller's joints (any order); a first point after
  ``time_from_start`` 0 is reached from the measured state at the start;
- ``OperationalSpaceInverseDynamics`` reads a
  ``cartesian_control_msgs/CartesianTrajectory`` on
  ``/<controller>/cartesian_trajectory``: the pose, twist and acceleration of
  ``controlled_frame`` (a frame of the plant; "" is the last link) in
  ``header.frame_id`` ("" or ``world``: the world frame).

The points become a first-order hold (a Drake ``PiecewisePolynomial``, evaluated in
C++ at each tick); after the last point the controller holds its pose with zero
velocity and acceleration (state ``succeeded``). Before any message it holds the
measured state of its first tick.

Bad input is rejected, naming the point, its time and the value, and the controller
keeps its previous reference: non-finite numbers, times not increasing, a joint
position outside its limits, a point farther from the arm's first joint than the arm
can reach (the sum of its link lengths), an unknown frame. A reference that passes
near a singularity is followed with the law's damped pseudo-inverse and its torques
clamped to the effort limits; ``status.detail`` counts the ticks that were clamped
(``saturated_ticks``) and those whose state or reference was not finite
(``rejected_ticks``; the output is then finite all the same).
"""

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from pydrake.trajectories import PiecewisePolynomial

from armando_drake.control.controllers import (
    Controller,
    ControllerMemory,
    Rejected,
    register,
)
from armando_drake.kinematics.arm import ArmModel, TaskSpaceError
from armando_drake.kinematics.control_laws import (
    TORQUE_LAWS,
    JointSpaceInverseDynamicsParams,
    OperationalSpaceInverseDynamicsParams,
)
from armando_drake.messages.types import CartesianTrajectory, JointTrajectory
from armando_drake.tools.schema import Refusal, param


@dataclass
class JointSpaceInverseDynamicsParameters(JointSpaceInverseDynamicsParams):
    """``ros__parameters`` of the joint-space inverse-dynamics controller."""

    # The joints commanded: every moving joint of the robot, in any order.
    joints: list[str] = param([], required=True, nonempty=True, unique=True)

    def check(self) -> None:
        _check(self)


@dataclass
class OperationalSpaceInverseDynamicsParameters(OperationalSpaceInverseDynamicsParams):
    """``ros__parameters`` of the operational-space inverse-dynamics controller."""

    # The joints commanded: every moving joint of the robot, in any order.
    joints: list[str] = param([], required=True, nonempty=True, unique=True)

    def check(self) -> None:
        _check(self)


def _check(params) -> None:
    """The control law's own rules (its ``validate()``), as the parameters' refusal."""
    try:
        params.validate()
    except TaskSpaceError as error:  # "<name>=<value> must be ..."
        name, _, problem = str(error).partition("=")
        raise Refusal(name, f"={problem}") from None


@dataclass(frozen=True)
class TorqueMemory(ControllerMemory):
    """A torque controller's memory: it has work at every tick (the torque follows the
    measured state), so it is always busy."""

    def __post_init__(self):
        object.__setattr__(self, "busy", True)


@dataclass(frozen=True)
class _Reference:
    """A reference being followed: the law, its curve from ``start`` [s], the end."""

    law: Any  # the torque law (of the frames the message names)
    curve: PiecewisePolynomial | None  # reference vector against time since start
    start: float  # [s] simulation time of the curve's t = 0
    end: float  # [s] simulation time of its last point
    final: np.ndarray  # the reference after the end (last point, derivatives zero)

    def at(self, now: float) -> np.ndarray:
        if self.curve is None or now >= self.end:
            return self.final
        return self.curve.value(max(now - self.start, 0.0)).reshape(-1)


class _InverseDynamicsController(Controller):
    """What the two inverse-dynamics controllers share."""

    fixed_interface = "effort"
    initial_state = "holding"
    law_type: ClassVar[str]  # the name of its law: its key in TORQUE_LAWS

    def __init__(self, *, name, joints, params=None):
        super().__init__(name=name, joints=joints, params=params)
        self._initial = TorqueMemory(
            desired=self._initial.desired, status=self._initial.status, effort=np.zeros(self.n)
        )
        self._plant = None
        self._instance = None
        self._laws: dict[tuple[str, str], Any] = {}  # by (controlled frame, base frame)

    def connect_plant(self, plant, model_instance) -> None:
        self._plant, self._instance = plant, model_instance
        self._law("", "")  # checks the joints now, at build time

    def _law(self, frame: str, base: str):
        """The law (and its arm) of end-effector ``frame`` in ``base`` ("" = defaults)."""
        key = (frame, base)
        law = self._laws.get(key)
        if law is not None:
            return law
        if self._plant is None:
            raise RuntimeError(f"{self.name}: connect_plant() was not called before the run")
        plant, instance = self._plant, self._instance
        moving = [plant.get_joint(i) for i in plant.GetJointIndices(instance)]
        moving = [j for j in moving if j.num_velocities() > 0]
        if sorted(j.name() for j in moving) != sorted(self.joint_names):
            raise ValueError(
                f"controller {self.name!r} claims {list(self.joint_names)}; an inverse-dynamics "
                f"controller needs every moving joint of the robot: "
                f"{[j.name() for j in moving]}"
            )
        last = max(moving, key=lambda j: j.velocity_start())
        arm = ArmModel(
            plant=plant,
            end_effector_frame=frame or last.child_body().body_frame(),
            base_frame=base if base not in ("", "world") else None,
            model_instance=instance,
        )
        entry = TORQUE_LAWS[self.law_type]
        law = entry.law(arm=arm, params=_law_params(entry.params, self.params))
        # Controller joint i is the arm's joint order[i].
        order = np.array([arm.joint_names.index(name) for name in self.joint_names])
        law.controller_order = order
        law.q_slots = arm.state_position_slots[order]
        law.v_slots = arm.state_velocity_slots[order]
        law.reach = _reach(arm)
        self._laws[key] = law
        return law

    def _hold(self, law, q: np.ndarray, v: np.ndarray, now: float) -> _Reference:
        raise NotImplementedError

    def _accept(self, message, q, v, now) -> _Reference:
        raise NotImplementedError

    def update(self, now, message, memory, measure):
        q, v = measure(memory.desired)
        reference, status = memory.trajectory, memory.status
        if message is not None:
            try:
                reference = self._accept(message, q, v, now)
                status = self.accept(status, "executing", {})
            except Rejected as rejection:
                status = self.reject(status, str(rejection))
        if reference is None:
            reference = self._hold(self._law("", ""), q, v, now)
        law = reference.law
        state = np.zeros(law.arm.num_instance_states)
        state[law.q_slots] = q
        state[law.v_slots] = v
        saturated, rejected = law.saturated_ticks, law.rejected_ticks
        u = law.CalcActuation(state, reference.at(now))
        tau = np.empty(law.arm.num_joints)
        tau[law.arm.actuation_order] = u
        effort = tau[law.controller_order]
        if status.state == "executing" and now >= reference.end:
            status = dataclasses.replace(status, state="succeeded", detail=dict(status.detail))
        if law.saturated_ticks != saturated or law.rejected_ticks != rejected:
            if law.saturated_ticks != saturated and not status.detail.get("saturated_ticks"):
                self.log_warning(self.name, _saturation_warning(law, now, q))
            detail = dict(status.detail)
            detail["saturated_ticks"] = detail.get("saturated_ticks", 0) + (
                law.saturated_ticks - saturated
            )
            detail["rejected_ticks"] = detail.get("rejected_ticks", 0) + (
                law.rejected_ticks - rejected
            )
            status = dataclasses.replace(status, detail=detail)
        return TorqueMemory(memory.desired, status, trajectory=reference, effort=effort)


def _saturation_warning(law, now: float, q: np.ndarray) -> str:
    """The first clamped torque of a reference, said once: when, and how near a
    singularity the arm is."""
    text = f"torques clamped to the effort limits at t={now:.3f} s (q={np.round(q, 3).tolist()})"
    sigma = getattr(law, "smallest_singular_value", None)
    if sigma is not None and np.isfinite(sigma) and sigma < law.params.singular_threshold:
        return text + (
            f"; smallest singular value of the weighted Jacobian {sigma:.3g} (damped below "
            f"{law.params.singular_threshold:g}): near a singularity or the workspace boundary"
        )
    return text + ": the reference asks for more than the actuators give"


def _law_params(schema: type, params):
    """The law's parameters dataclass from the controller's (which adds ``joints``)."""
    return schema(**{f.name: getattr(params, f.name) for f in dataclasses.fields(schema)})


def _reach(arm: ArmModel) -> float:
    """[m] an upper bound of the distance from the arm's first joint to E: the sum of
    the distances between successive joint origins and from the last one to E."""
    plant, context = arm.plant, arm.plant.CreateDefaultContext()
    points = []
    for name in arm.joint_names:
        joint = plant.GetJointByName(name, arm.model_instance)
        points.append(joint.frame_on_child().CalcPoseInWorld(context).translation())
    points.append(arm.frame_E.CalcPoseInWorld(context).translation())
    return float(sum(np.linalg.norm(b - a) for a, b in zip(points[:-1], points[1:], strict=True)))


def check_within_reach(arm: ArmModel, trajectory, samples: int = 400) -> None:
    """Raises :class:`TaskSpaceError` if the position path of ``trajectory`` (a
    :class:`~armando_drake.kinematics.paths.CartesianTrajectory` in the arm's base frame) leaves
    the sphere the arm can reach (:func:`_reach` around its first joint): the check the
    controller makes of every point it is sent, made of a scenario's task when the world
    is built."""

    reach = _reach(arm)
    joint = arm.plant.GetJointByName(arm.joint_names[0], arm.model_instance)
    base = joint.frame_on_child().CalcPose(arm.context, arm.frame_B).translation()
    times = np.linspace(0.0, trajectory.duration, samples)
    distance = np.linalg.norm(trajectory.reference(times)[:, 4:7] - base, axis=1)
    k = int(np.argmax(distance))
    if distance[k] > reach:
        raise TaskSpaceError(
            f"the path at {times[k]:.3g} s is {distance[k]:.3f} m from the arm's first joint, "
            f"beyond its reach of {reach:.3f} m (outside the workspace)"
        )


def _base_joint_position(law) -> np.ndarray:
    """[m] the arm's first joint origin in its base frame B, now."""
    arm = law.arm
    joint = arm.plant.GetJointByName(arm.joint_names[0], arm.model_instance)
    return joint.frame_on_child().CalcPose(arm.context, arm.frame_B).translation()


def _times(points, label: str) -> np.ndarray:
    if not points:
        raise Rejected(f"empty {label}: no points")
    times = np.array([point.time_from_start for point in points], dtype=float)
    if not np.all(np.isfinite(times)) or times[0] < 0:
        raise Rejected(f"time_from_start {times.tolist()[:3]}... must be finite and >= 0")
    bad = np.flatnonzero(np.diff(times) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise Rejected(
            f"time_from_start of point {k} ({float(times[k])!r} s) is not after point {k - 1}'s "
            f"({float(times[k - 1])!r} s)"
        )
    return times


def _curve(times: np.ndarray, samples: np.ndarray) -> PiecewisePolynomial | None:
    """The first-order hold through (times, samples (N, m)), None for a single point."""
    if len(times) < 2:
        return None
    return PiecewisePolynomial.FirstOrderHold(times, samples.T)


@register("task_space_controllers/JointSpaceInverseDynamics")
class JointSpaceInverseDynamicsController(_InverseDynamicsController):
    """Computed torque on a JointTrajectory (positions, velocities, accelerations)."""

    parameters = JointSpaceInverseDynamicsParameters
    message = JointTrajectory
    topic = "joint_trajectory"
    law_type = "JointSpaceInverseDynamics"

    def _hold(self, law, q, v, now):
        n = law.arm.num_joints
        q_arm = np.empty(n)
        q_arm[law.controller_order] = q
        return _Reference(law, None, now, now, np.concatenate([q_arm, np.zeros(2 * n)]))

    def _accept(self, message, q, v, now):
        if not isinstance(message, JointTrajectory):
            raise Rejected(f"expected a JointTrajectory message, got {type(message).__name__}")
        law = self._law("", "")
        n = self.n
        names = list(message.joint_names)
        if sorted(names) != sorted(self.joint_names) or len(set(names)) != n:
            raise Rejected(
                f"joint_names {names} must be the controller's joints {list(self.joint_names)}"
            )
        times = _times(message.points, "trajectory")
        to_arm = np.array([law.arm.joint_names.index(name) for name in names])
        samples = np.zeros((len(times), 3 * n))
        lower, upper = law.arm.lower, law.arm.upper
        for k, point in enumerate(message.points):
            for block, (label, values) in enumerate(
                (
                    ("positions", point.positions),
                    ("velocities", point.velocities),
                    ("accelerations", point.accelerations),
                )
            ):
                if block > 0 and len(values) == 0:
                    continue
                values = np.asarray(values, dtype=float)
                if values.shape != (n,) or not np.all(np.isfinite(values)):
                    raise Rejected(
                        f"point {k} at {float(times[k])!r} s: {label} {values.tolist()} must be "
                        f"{n} finite numbers"
                    )
                samples[k, block * n + to_arm] = values
            outside = np.flatnonzero(
                (samples[k, :n] < lower - 1e-9) | (samples[k, :n] > upper + 1e-9)
            )
            if outside.size:
                i = int(outside[0])
                low, high, value = float(lower[i]), float(upper[i]), float(samples[k, i])
                raise Rejected(
                    f"point {k} at {float(times[k])!r} s: position {value!r} of joint "
                    f"'{law.arm.joint_names[i]}' is outside its limits [{low!r}, {high!r}]"
                )
        if times[0] > 0:  # reach the first point from where the arm is
            start = np.zeros(3 * n)
            start[law.controller_order] = q
            start[n + law.controller_order] = v
            times, samples = np.concatenate([[0.0], times]), np.vstack([start, samples])
        final = samples[-1].copy()
        final[n:] = 0.0
        begin = message.stamp if message.stamp > 0 else now
        return _Reference(law, _curve(times, samples), begin, begin + times[-1], final)


@register("task_space_controllers/OperationalSpaceInverseDynamics")
class OperationalSpaceInverseDynamicsController(_InverseDynamicsController):
    """Operational-space inverse dynamics on a CartesianTrajectory (pose, twist, accel.)."""

    parameters = OperationalSpaceInverseDynamicsParameters
    message = CartesianTrajectory
    topic = "cartesian_trajectory"
    law_type = "OperationalSpaceInverseDynamics"

    def _hold(self, law, q, v, now):
        arm = law.arm
        q_arm = np.empty(arm.num_joints)
        q_arm[law.controller_order] = q
        arm.set_state(q_arm)
        X = arm.pose()
        final = np.concatenate([X.rotation().ToQuaternion().wxyz(), X.translation(), np.zeros(12)])
        return _Reference(law, None, now, now, final)

    def _accept(self, message, q, v, now):
        if not isinstance(message, CartesianTrajectory):
            raise Rejected(f"expected a CartesianTrajectory message, got {type(message).__name__}")
        try:
            law = self._law(message.controlled_frame, message.frame_id)
        except TaskSpaceError as error:
            raise Rejected(
                f"controlled_frame {message.controlled_frame!r} in frame_id "
                f"{message.frame_id!r}: {error}"
            ) from None
        times = _times(message.points, "Cartesian trajectory")
        samples = np.zeros((len(times), 19))
        q_arm = np.empty(law.arm.num_joints)
        q_arm[law.controller_order] = q
        law.arm.set_state(q_arm)
        base = _base_joint_position(law)
        for k, point in enumerate(message.points):
            for start, size, label, values in (
                (4, 3, "position", point.position),
                (0, 4, "orientation", point.orientation),
                (7, 6, "twist", point.twist),
                (13, 6, "acceleration", point.acceleration),
            ):
                if size == 6 and len(values) == 0:
                    continue
                values = np.asarray(values, dtype=float)
                if values.shape != (size,) or not np.all(np.isfinite(values)):
                    raise Rejected(
                        f"point {k} at {float(times[k])!r} s: {label} {values.tolist()} must be "
                        f"{size} finite numbers"
                    )
                samples[k, start : start + size] = values
            norm = np.linalg.norm(samples[k, :4])
            if not 0.9 < norm < 1.1:
                raise Rejected(
                    f"point {k} at {float(times[k])!r} s: orientation {samples[k, :4].tolist()} is "
                    "not a unit quaternion (w, x, y, z)"
                )
            samples[k, :4] /= norm
            if k and samples[k, :4] @ samples[k - 1, :4] < 0:  # the same rotation, nearer
                samples[k, :4] *= -1.0
            distance = float(np.linalg.norm(samples[k, 4:7] - base))
            if distance > law.reach:
                raise Rejected(
                    f"point {k} at {float(times[k])!r} s: position {samples[k, 4:7].tolist()} is "
                    f"{distance:.3f} m from the arm's first joint, beyond its reach of "
                    f"{law.reach:.3f} m (outside the workspace)"
                )
        if times[0] > 0:  # reach the first point from where the arm is
            hold = self._hold(law, q, v, now).final
            times, samples = np.concatenate([[0.0], times]), np.vstack([hold, samples])
        final = samples[-1].copy()
        final[7:] = 0.0
        begin = message.stamp if message.stamp > 0 else now
        return _Reference(law, _curve(times, samples), begin, begin + times[-1], final)
