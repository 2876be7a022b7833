"""Geometric paths of the end effector in the robot's base frame, and their timing.

A path maps the normalised coordinate s in [0, 1] to a position p(s); with a time
law (:mod:`armando_drake.kinematics.time_laws`) giving s, s', s'' it gives position,
velocity p' = p_s s' and acceleration p'' = p_s s'' + p_ss s'^2. Orientation is held
or interpolated between two orientations by Drake's ``PiecewiseQuaternionSlerp``
(a constant-axis rotation, so its angular velocity along s is constant).

:class:`CartesianTrajectory` composes a time law, a position path and an
orientation path into the Cartesian reference (pose, twist, acceleration) of the
task-space controllers; :meth:`CartesianTrajectory.as_reference_trajectory`
samples it at the controller's ticks into a Drake ``PiecewisePolynomial`` of the
reference vector (layout: :data:`CARTESIAN_REFERENCE_LAYOUT`) that a
``TrajectorySource`` plays in C++.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.trajectories import PiecewisePolynomial, PiecewiseQuaternionSlerp

from armando_drake.kinematics.time_laws import TimeLaw

#: The Cartesian reference vector (19 numbers), Drake's spatial order (rotation first):
#: quaternion of R_BE (w, x, y, z), position p_BE [m], angular velocity w_BE [rad/s],
#: linear velocity v_BE [m/s], angular acceleration [rad/s^2], linear acceleration
#: [m/s^2], all in the base frame B.
CARTESIAN_REFERENCE_LAYOUT = (
    ("quaternion", 4),
    ("position", 3),
    ("angular_velocity", 3),
    ("linear_velocity", 3),
    ("angular_acceleration", 3),
    ("linear_acceleration", 3),
)
CARTESIAN_REFERENCE_SIZE = sum(size for _, size in CARTESIAN_REFERENCE_LAYOUT)


class PathError(ValueError):
    """Path parameters that describe no valid path."""


def _vector3(name: str, value) -> np.ndarray:
    array = np.asarray(value, dtype=float).reshape(-1)
    if array.shape != (3,) or not np.all(np.isfinite(array)):
        raise PathError(f"{name}={value!r} must be three finite numbers")
    return array


@dataclass(frozen=True)
class PathSample:
    """Position, velocity and acceleration along a path (rows: samples)."""

    position: np.ndarray  # [m] (N, 3)
    velocity: np.ndarray  # [m/s] (N, 3)
    acceleration: np.ndarray  # [m/s^2] (N, 3)


class LinearPath:
    """The segment from ``start`` to ``goal`` [m, base frame]: p(s) = start + s (goal - start)."""

    def __init__(self, *, start, goal):
        self.start = _vector3("start", start)
        self.goal = _vector3("goal", goal)

    @property
    def length(self) -> float:
        """[m] the path's length."""
        return float(np.linalg.norm(self.goal - self.start))

    def __call__(self, s, s_dot, s_ddot) -> PathSample:
        s, s_dot, s_ddot = (np.atleast_1d(np.asarray(x, dtype=float))[:, None] for x in
                            (s, s_dot, s_ddot))  # fmt: skip
        delta = self.goal - self.start
        return PathSample(self.start + s * delta, s_dot * delta, s_ddot * delta)


class CircularPath:
    """An arc of a circle through ``start``, in the plane with normal ``normal``.

    The centre is ``start + radius * d``, with ``d`` the unit ``center_direction``
    projected into the plane; the arc turns by ``angle`` [rad] (2 pi: the whole
    circle, back to the start) about ``normal`` (right hand). The default is the
    course seed's: the y-z plane through the start point (normal x), centre below
    the start.

        p(s) = c + r (-cos(theta) d + sin(theta) e),  theta = angle s,  e = n x d.
    """

    def __init__(
        self,
        *,
        start,
        radius: float,
        normal=(1.0, 0.0, 0.0),
        center_direction=(0.0, 0.0, -1.0),
        angle: float = 2.0 * np.pi,
    ):
        self.start = _vector3("start", start)
        if not np.isfinite(radius) or radius <= 0.0:
            raise PathError(f"radius={radius!r} m must be positive and finite")
        if not np.isfinite(angle) or angle == 0.0:
            raise PathError(f"angle={angle!r} rad must be finite and non-zero")
        normal = _vector3("normal", normal)
        if np.linalg.norm(normal) < 1e-12:
            raise PathError(f"normal={normal.tolist()!r} must not be zero")
        n = normal / np.linalg.norm(normal)
        direction = _vector3("center_direction", center_direction)
        d = direction - n * (n @ direction)
        if np.linalg.norm(d) < 1e-9 * max(1.0, np.linalg.norm(direction)):
            raise PathError(
                f"center_direction={direction.tolist()!r} is parallel to "
                f"normal={normal.tolist()!r}: it must have a component in the plane"
            )
        self.radius = float(radius)
        self.angle = float(angle)
        self.normal = n
        self.d = d / np.linalg.norm(d)
        self.e = np.cross(n, self.d)
        self.center = self.start + self.radius * self.d

    @property
    def length(self) -> float:
        """[m] the arc's length."""
        return abs(self.angle) * self.radius

    def __call__(self, s, s_dot, s_ddot) -> PathSample:
        s, s_dot, s_ddot = (np.atleast_1d(np.asarray(x, dtype=float))[:, None] for x in
                            (s, s_dot, s_ddot))  # fmt: skip
        theta = self.angle * s
        theta_dot = self.angle * s_dot
        theta_ddot = self.angle * s_ddot
        cos, sin = np.cos(theta), np.sin(theta)
        radial = -cos * self.d + sin * self.e  # (p - c) / r
        tangent = sin * self.d + cos * self.e  # d(radial)/dtheta
        position = self.center + self.radius * radial
        velocity = self.radius * theta_dot * tangent
        acceleration = self.radius * (theta_ddot * tangent - theta_dot**2 * radial)
        return PathSample(position, velocity, acceleration)


class OrientationPath:
    """R_BE(s): held at ``start`` or slerped to ``goal`` (Drake's PiecewiseQuaternionSlerp)."""

    def __init__(self, *, start: RotationMatrix, goal: RotationMatrix | None = None):
        self.start = RotationMatrix(start)
        self.goal = RotationMatrix(goal) if goal is not None else RotationMatrix(start)
        self._slerp = PiecewiseQuaternionSlerp(
            [0.0, 1.0], [self.start.ToQuaternion(), self.goal.ToQuaternion()]
        )
        # Constant along the path: angle * axis per unit s [rad].
        self._rate = np.asarray(self._slerp.angular_velocity(0.5)).reshape(3)

    @property
    def angle(self) -> float:
        """[rad] the rotation from start to goal."""
        return float(np.linalg.norm(self._rate))

    def quaternions(self, s) -> np.ndarray:
        """(N, 4) quaternions (w, x, y, z) of R_BE(s)."""
        s = np.clip(np.atleast_1d(np.asarray(s, dtype=float)), 0.0, 1.0)
        return np.array(
            [np.asarray(self._slerp.orientation(float(si)).wxyz()) for si in s]
        ).reshape(-1, 4)

    def __call__(self, s, s_dot, s_ddot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(quaternions (N, 4), angular velocity (N, 3), angular acceleration (N, 3))."""
        s_dot = np.atleast_1d(np.asarray(s_dot, dtype=float))[:, None]
        s_ddot = np.atleast_1d(np.asarray(s_ddot, dtype=float))[:, None]
        return self.quaternions(s), s_dot * self._rate, s_ddot * self._rate


@dataclass(frozen=True)
class CartesianSample:
    """The Cartesian reference at one time, in the base frame."""

    pose: RigidTransform  # X_BE
    twist: np.ndarray  # [rad/s, m/s] (6,) [w; v]
    acceleration: np.ndarray  # [rad/s^2, m/s^2] (6,) [alpha; a]


class CartesianTrajectory:
    """A time law composed with a position path and an orientation path."""

    def __init__(self, *, time_law: TimeLaw, path, orientation: OrientationPath):
        self.time_law = time_law
        self.path = path
        self.orientation = orientation

    @property
    def duration(self) -> float:
        """[s] the motion's duration."""
        return self.time_law.duration

    def reference(self, times) -> np.ndarray:
        """(N, 19) reference vectors at ``times`` [s], see :data:`CARTESIAN_REFERENCE_LAYOUT`."""
        law = self.time_law(np.atleast_1d(np.asarray(times, dtype=float)))
        linear = self.path(law.s, law.s_dot, law.s_ddot)
        quaternions, w, alpha = self.orientation(law.s, law.s_dot, law.s_ddot)
        return np.hstack(
            [quaternions, linear.position, w, linear.velocity, alpha, linear.acceleration]
        )

    def __call__(self, t: float) -> CartesianSample:
        return unpack_cartesian_reference(self.reference([t])[0])

    def as_reference_trajectory(self, period: float) -> PiecewisePolynomial:
        """The reference sampled every ``period`` [s] from 0 to the end (one sample past it).

        A first-order hold through the samples: a controller ticking at multiples
        of ``period`` reads exact samples; after the end the value holds the goal.
        """
        if not np.isfinite(period) or period <= 0.0:
            raise PathError(f"period={period!r} s must be positive")
        count = int(np.ceil(self.duration / period - 1e-9)) + 2
        times = np.arange(count) * period
        return PiecewisePolynomial.FirstOrderHold(times, self.reference(times).T)


def unpack_cartesian_reference(vector) -> CartesianSample:
    """The pose, twist and acceleration in one reference vector (19 numbers)."""
    vector = np.asarray(vector, dtype=float).reshape(-1)
    quaternion = vector[0:4] / np.linalg.norm(vector[0:4])
    pose = RigidTransform(Quaternion(quaternion), vector[4:7])
    return CartesianSample(pose=pose, twist=vector[7:13], acceleration=vector[13:19])
