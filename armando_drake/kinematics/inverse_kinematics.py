"""Inverse kinematics: single poses with Drake's InverseKinematics, paths by the Jacobian.

- :func:`solve_ik`: one pose (the start configuration, a goal) with Drake's
  ``InverseKinematics`` (joint limits on), checked by forward kinematics; several
  seeded starts; an unreachable pose comes back with ``success = False`` and the
  best errors found.
- :func:`plan_joint_reference`: the joint reference (q_d, v_d, a_d) along a
  :class:`~armando_drake.kinematics.paths.CartesianTrajectory`, by second-order
  closed-loop inverse kinematics at the controller period:
  a = J#(x''_d + Kd (x'_d - J v) + Kp e - J-dot v) + N a_0, with J# the damped
  pseudo-inverse, N its null-space projector and a_0 the posture / joint-limit
  term. Arms with fewer than 6 joints follow the position first and orientation
  in its null space (the log line says which components). The plan is rejected,
  with the time and the numbers, when the path leaves the workspace or passes a
  singularity (tracking error above tolerance), reaches a joint limit, a velocity
  limit or needs more than the effort limit (inverse dynamics along the plan).
"""

import logging
from dataclasses import dataclass

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.solvers import Solve
from pydrake.trajectories import PiecewisePolynomial

from armando_drake.kinematics.arm import (
    ArmModel,
    Resolution,
    TaskSpaceError,
    describe_task,
    orientation_error,
    posture_acceleration,
    resolve_tasks,
)
from armando_drake.kinematics.paths import CartesianTrajectory, unpack_cartesian_reference

_log = logging.getLogger(__name__)


@dataclass(frozen=True)
class IkResult:
    """The outcome of :func:`solve_ik`."""

    success: bool  # both errors within tolerance
    q: np.ndarray  # [rad] the best joint positions found (arm joint order)
    position_error: float  # [m] |p_BE(q) - p_target|
    orientation_error: float  # [rad] angle between R_BE(q) and the target
    message: str  # one line: what was solved, or why it failed


def _pose_errors(arm: ArmModel, q: np.ndarray, X_target: RigidTransform) -> tuple[float, float]:
    arm.set_state(q)
    X = arm.pose()
    position = float(np.linalg.norm(X.translation() - X_target.translation()))
    rotation = float(np.linalg.norm(orientation_error(X_target.rotation(), X.rotation())))
    return position, rotation


def _polish(arm: ArmModel, q: np.ndarray, X_target: RigidTransform, full: bool) -> np.ndarray:
    """A few Gauss-Newton steps on the pose error, inside the joint limits.

    The solvers stop at their feasibility tolerance (about 1e-6 on the constraint
    values, so about 1e-3 rad on an orientation); from there Newton converges in
    two or three steps to round-off.
    """
    for _ in range(8):
        arm.set_state(q)
        X = arm.pose()
        error = np.concatenate(
            [
                orientation_error(X_target.rotation(), X.rotation()),
                X_target.translation() - X.translation(),
            ]
        )
        J = arm.jacobian()
        if not full:
            error, J = error[3:], J[3:]
        if np.linalg.norm(error) < 1e-13:
            break
        q = np.clip(q + np.linalg.lstsq(J, error, rcond=1e-10)[0], arm.lower, arm.upper)
    return q


def _ik_program(
    arm: ArmModel,
    X_target: RigidTransform,
    orientation: str,
    position_tolerance: float,
    orientation_tolerance: float,
) -> InverseKinematics:
    """Drake's IK for ``X_target``: the position within tolerance, the orientation by
    ``orientation`` (constraint, cost or none)."""
    ik = InverseKinematics(arm.plant, with_joint_limits=True)
    # A tenth of the tolerance, so the solver's own slack stays inside it.
    p = X_target.translation()
    ik.AddPositionConstraint(
        frameB=arm.frame_E,
        p_BQ=np.zeros(3),
        frameA=arm.frame_B,
        p_AQ_lower=p - position_tolerance / 10,
        p_AQ_upper=p + position_tolerance / 10,
    )
    if orientation == "constraint":
        ik.AddOrientationConstraint(
            frameAbar=arm.frame_B,
            R_AbarA=X_target.rotation(),
            frameBbar=arm.frame_E,
            R_BbarB=type(X_target.rotation())(),
            theta_bound=orientation_tolerance / 10,
        )
    elif orientation == "cost":
        ik.AddOrientationCost(
            frameAbar=arm.frame_B,
            R_AbarA=X_target.rotation(),
            frameBbar=arm.frame_E,
            R_BbarB=type(X_target.rotation())(),
            c=1.0,
        )
    return ik


def _ik_attempt(
    arm: ArmModel,
    ik: InverseKinematics,
    start: np.ndarray,
    q_seed: np.ndarray,
    X_target: RigidTransform,
    orientation: str,
) -> np.ndarray:
    """Solves ``ik`` from ``start``, nearest ``q_seed``, and polishes the result [rad]."""
    guess = arm.plant.GetPositions(arm.context).copy()
    guess[arm.position_indices] = start
    # Among the solutions, the one nearest the seed (a redundant arm has many).
    nearest = guess.copy()
    nearest[arm.position_indices] = q_seed
    ik.prog().AddQuadraticErrorCost(np.eye(guess.size), nearest, ik.q())
    result = Solve(ik.prog(), guess)
    q = result.GetSolution(ik.q())[arm.position_indices]
    if np.all(np.isfinite(q)):
        q = _polish(arm, q, X_target, full=orientation == "constraint")
    return q


def _ik_message(
    X_target: RigidTransform,
    within: bool,
    position: float,
    rotation: float,
    *,
    attempts: int,
    orientation: str,
    position_tolerance: float,
    orientation_tolerance: float,
) -> str:
    """The one-line outcome of :func:`solve_ik`: what was reached, or why not."""
    p_text = np.array2string(X_target.translation(), precision=4)
    if within:
        return (
            f"IK reached {p_text} m: position error {position:.2e} m, "
            f"orientation error {rotation:.2e} rad ({orientation})"
        )
    return (
        f"pose at {p_text} m is unreachable: best of {attempts} IK attempts has "
        f"position error {position:.3g} m (tolerance {position_tolerance:g}) and "
        f"orientation error {rotation:.3g} rad"
        + (f" (tolerance {orientation_tolerance:g})" if orientation == "constraint" else "")
    )


def solve_ik(
    arm: ArmModel,
    X_target: RigidTransform,
    *,
    q_seed: np.ndarray | None = None,
    orientation: str = "auto",
    position_tolerance: float = 1e-6,
    orientation_tolerance: float = 1e-5,
    attempts: int = 6,
    seed: int = 0,
) -> IkResult:
    """Joint positions putting E at ``X_target`` (X_BE), within the joint limits.

    Drake's ``InverseKinematics`` (joint limits, nearest to the seed) solves it,
    a few Newton steps on the Jacobian polish the solver's result to round-off.

    ``orientation``: ``"constraint"`` (the whole pose), ``"cost"`` (position exact,
    orientation as close as the arm allows), ``"none"``, or ``"auto"``: constraint for
    arms with 6 or more joints, cost otherwise. Starts from ``q_seed`` (default: the
    plant's default positions), then from seeded random configurations.
    """
    if orientation == "auto":
        orientation = "constraint" if arm.follows_full_orientation else "cost"
    if orientation not in ("constraint", "cost", "none"):
        raise TaskSpaceError(f"orientation={orientation!r} must be constraint, cost, none or auto")
    q_seed = arm.default_positions() if q_seed is None else np.asarray(q_seed, dtype=float)
    rng = np.random.default_rng(seed)
    lower = np.where(np.isfinite(arm.lower), arm.lower, -np.pi)
    upper = np.where(np.isfinite(arm.upper), arm.upper, np.pi)
    check_rotation = orientation == "constraint"
    best = None
    for attempt in range(max(1, attempts)):
        ik = _ik_program(arm, X_target, orientation, position_tolerance, orientation_tolerance)
        start = q_seed if attempt == 0 else rng.uniform(lower, upper)
        q = _ik_attempt(arm, ik, start, q_seed, X_target, orientation)
        position, rotation = _pose_errors(arm, q, X_target)
        within = position <= position_tolerance and (
            not check_rotation or rotation <= orientation_tolerance
        )
        score = position + (rotation if check_rotation else 0.0)
        if best is None or score < best[0]:
            best = (score, q, position, rotation, within)
        if within:
            break
    _, q, position, rotation, within = best
    message = _ik_message(
        X_target,
        within,
        position,
        rotation,
        attempts=attempts,
        orientation=orientation,
        position_tolerance=position_tolerance,
        orientation_tolerance=orientation_tolerance,
    )
    return IkResult(
        success=within,
        q=q,
        position_error=position,
        orientation_error=rotation,
        message=message,
    )


@dataclass
class ClikGains:
    """Gains of the second-order closed-loop IK that plans the joint reference."""

    position_gain: float = 400.0  # [1/s^2] Kp on the pose error
    velocity_gain: float = 40.0  # [1/s] Kd on the twist error
    posture_gain: float = 4.0  # [1/s^2] null space: towards the rest posture
    limit_gain: float = 4.0  # [rad/s^2] null space: away from the joint limits
    null_damping: float = 4.0  # [1/s] null space: joint velocity damping
    singular_threshold: float = 0.02  # [m/rad] singular values below this are damped
    max_damping: float = 0.05  # [m/rad] damping at a singular value of zero
    secondary_threshold: float = 0.5  # [-] the same for the orientation of arms with < 6
    secondary_damping: float = 0.5  # [-] joints (a secondary task), damped much earlier
    # [-] smallest / largest singular value of the task Jacobian below which a failure
    # is blamed on a singularity or the workspace boundary
    singular_warning: float = 0.1


@dataclass(frozen=True)
class JointReference:
    """Joint positions, velocities and accelerations sampled at the controller's ticks."""

    times: np.ndarray  # [s] (N,)
    q: np.ndarray  # [rad] (N, n)
    v: np.ndarray  # [rad/s] (N, n)
    a: np.ndarray  # [rad/s^2] (N, n)
    torque: np.ndarray  # [N m] (N, n) the inverse-dynamics torque along the plan
    task: str  # what the task controls (the log line)

    def as_reference_trajectory(self) -> PiecewisePolynomial:
        """[q_d; v_d; a_d] as a first-order hold through the samples (holds the end after)."""
        return PiecewisePolynomial.FirstOrderHold(self.times, np.hstack([self.q, self.v, self.a]).T)


def plan_joint_reference(
    arm: ArmModel,
    trajectory: CartesianTrajectory,
    q_start: np.ndarray,
    *,
    period: float,
    rest: np.ndarray | None = None,
    gains: ClikGains | None = None,
    position_tolerance: float = 1e-3,
    orientation_tolerance: float = 1e-2,
    settle_time: float = 0.0,
) -> JointReference:
    """The joint reference that follows ``trajectory`` from ``q_start`` (see module doc).

    Raises :class:`TaskSpaceError` naming the time and the numbers when the path cannot
    be followed within ``position_tolerance`` [m] / ``orientation_tolerance`` [rad]
    (the latter only for arms with 6 or more joints), or a joint, velocity or effort
    limit would be passed. ``settle_time`` [s] extends the plan past the end.
    """
    gains = gains or ClikGains()
    if not np.isfinite(period) or period <= 0.0:
        raise TaskSpaceError(f"period={period!r} s must be positive")
    q = np.asarray(q_start, dtype=float).copy()
    if q.shape != (arm.num_joints,):
        raise TaskSpaceError(f"q_start has {q.size} values, the arm has {arm.num_joints} joints")
    rest = q.copy() if rest is None else np.asarray(rest, dtype=float)
    v = np.zeros_like(q)
    count = int(np.ceil((trajectory.duration + settle_time) / period - 1e-9)) + 2
    times = np.arange(count) * period
    references = trajectory.reference(times)
    task = describe_task(arm, q)
    _log.info("task-space plan: %s", task)
    Q, V, A, TAU = (np.zeros((count, arm.num_joints)) for _ in range(4))
    for k, t in enumerate(times):
        resolution = _clik_acceleration(
            arm,
            q,
            v,
            t,
            references[k],
            trajectory,
            rest=rest,
            gains=gains,
            position_tolerance=position_tolerance,
            orientation_tolerance=orientation_tolerance,
        )
        a = resolution.acceleration
        TAU[k] = arm.mass_matrix() @ a + arm.coriolis() + arm.gravity() + arm.damping * v
        Q[k], V[k], A[k] = q, v, a
        _check_limits(
            arm,
            t,
            q,
            v,
            TAU[k],
            resolution.smallest_singular_value,
            resolution.singular_value_ratio,
            gains,
        )
        v = v + a * period
        q = q + v * period
    # The last sample holds still (the law ends at rest; the plan's residual is tiny).
    A[-1] = 0.0
    return JointReference(times=times, q=Q, v=V, a=A, torque=TAU, task=task)


def _clik_acceleration(
    arm: ArmModel,
    q: np.ndarray,
    v: np.ndarray,
    t: float,
    reference: np.ndarray,
    trajectory: CartesianTrajectory,
    *,
    rest: np.ndarray,
    gains: ClikGains,
    position_tolerance: float,
    orientation_tolerance: float,
) -> Resolution:
    """One step of the closed-loop IK at (q, v): the task tracking law resolved with the
    posture in the null space; raises when the pose error is past tolerance."""
    full = arm.follows_full_orientation
    arm.set_state(q, v)
    X = arm.pose()
    J = arm.jacobian()
    bias = arm.bias_acceleration()
    desired = unpack_cartesian_reference(reference)
    e_p = desired.pose.translation() - X.translation()
    e_o = orientation_error(desired.pose.rotation(), X.rotation())
    error = np.concatenate([e_o, e_p])
    if np.linalg.norm(e_p) > position_tolerance or (
        full and np.linalg.norm(e_o) > orientation_tolerance
    ):
        raise TaskSpaceError(_path_failure(arm, t, trajectory, e_p, e_o, full, J, gains))
    commanded = (
        desired.acceleration
        + gains.velocity_gain * (desired.twist - J @ v)
        + gains.position_gain * error
        - bias
    )
    tasks = [(J, commanded)] if full else [(J[3:], commanded[3:]), (J[:3], commanded[:3])]
    a0 = posture_acceleration(
        arm,
        q,
        v,
        rest=rest,
        posture_gain=gains.posture_gain,
        limit_gain=gains.limit_gain,
        damping_gain=gains.null_damping,
    )
    return resolve_tasks(
        tasks,
        a0,
        threshold=gains.singular_threshold,
        max_damping=gains.max_damping,
        secondary_threshold=gains.secondary_threshold,
        secondary_damping=gains.secondary_damping,
    )


def _path_failure(arm, t, trajectory, e_p, e_o, full, J, gains) -> str:
    s = float(trajectory.time_law(np.array([t])).s[0])
    rows = J if full else J[3:]
    singular_values = np.linalg.svd(rows, compute_uv=False)
    sigma = singular_values[-1]
    what = "pose" if full else "position"
    cause = (
        "the path leaves the workspace or passes a singularity"
        if sigma < gains.singular_warning * singular_values[0]
        else "the motion is too fast to follow at this period: make it slower"
    )
    return (
        f"the path cannot be followed: at t={t:.3f} s (s={s:.3f}) the {what} error is "
        f"{np.linalg.norm(e_p):.4g} m / {np.linalg.norm(e_o):.4g} rad; the smallest singular "
        f"value of the {what} Jacobian is {sigma:.3g} "
        f"({sigma / singular_values[0]:.3g} of the largest, damped below "
        f"{gains.singular_threshold:g}): {cause}"
    )


def _check_limits(arm: ArmModel, t: float, q, v, tau, sigma, ratio, gains: ClikGains) -> None:
    for name, value, low, high, unit, what in (
        ("position", q, arm.lower, arm.upper, "rad", "joint limits"),
        ("velocity", v, -arm.velocity_limit, arm.velocity_limit, "rad/s", "velocity limit"),
        ("effort", tau, -arm.effort_limit, arm.effort_limit, "N m", "effort limit"),
    ):
        outside = np.flatnonzero((value < low) | (value > high))
        if outside.size:
            i = outside[0]
            hint = (
                f"; the smallest singular value of the task Jacobian is {sigma:.3g} "
                f"({ratio:.3g} of the largest)"
            )
            if ratio < gains.singular_warning:
                hint += ": the path leaves the workspace or passes a singularity"
            raise TaskSpaceError(
                f"the path cannot be followed: at t={t:.3f} s joint {arm.joint_names[i]!r} "
                f"needs {name} {value[i]:.4g} {unit}, outside its {what} "
                f"[{low[i]:.4g}, {high[i]:.4g}] {unit}{hint}"
            )
