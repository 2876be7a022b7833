"""Paths: geometry to 1e-9, derivatives against finite differences, the reference vector."""

import numpy as np
import pytest
from pydrake.math import RotationMatrix

from armando_drake.kinematics.paths import (
    CARTESIAN_REFERENCE_SIZE,
    CartesianTrajectory,
    CircularPath,
    LinearPath,
    OrientationPath,
    PathError,
    unpack_cartesian_reference,
)
from armando_drake.kinematics.time_laws import CubicTimeLaw, TrapezoidalTimeLaw


def finite_difference(function, t, h=1e-5):
    return (function(t + h) - function(t - h)) / (2 * h)


def timed(path, law):
    """p(t), v(t), a(t) of a path driven by a law, as (3,) arrays."""

    def at(t, which):
        sample = law(np.array([t]))
        return getattr(path(sample.s, sample.s_dot, sample.s_ddot), which)[0]

    return at


@pytest.mark.parametrize(
    "path",
    [
        LinearPath(start=[0.5, -0.1, 0.4], goal=[0.3, 0.2, 0.7]),
        CircularPath(start=[0.5, 0.0, 0.5], radius=0.1),
        CircularPath(
            start=[0.1, 0.2, 0.3],
            radius=0.07,
            normal=[1, 1, 1],
            center_direction=[1, 0, 0],
            angle=-np.pi,
        ),  # fmt: skip
    ],
)
def test_velocity_and_acceleration_are_the_time_derivatives(path):
    law = TrapezoidalTimeLaw(duration=2.0, acceleration_time=0.6)
    at = timed(path, law)
    for t in (0.3, 1.0, 1.7):
        np.testing.assert_allclose(
            at(t, "velocity"), finite_difference(lambda x: at(x, "position"), t), atol=1e-8
        )
        np.testing.assert_allclose(
            at(t, "acceleration"), finite_difference(lambda x: at(x, "velocity"), t), atol=1e-7
        )


def test_linear_path_ends():
    path = LinearPath(start=[0.5, -0.1, 0.4], goal=[0.3, 0.2, 0.7])
    sample = path([0.0, 1.0], [0.0, 0.0], [0.0, 0.0])
    np.testing.assert_allclose(sample.position, [[0.5, -0.1, 0.4], [0.3, 0.2, 0.7]], atol=1e-15)
    assert path.length == pytest.approx(np.sqrt(0.04 + 0.09 + 0.09), rel=1e-12)


def test_circle_default_is_the_seeds_y_z_plane_through_the_start():
    start = np.array([0.55, 0.05, 0.45])
    path = CircularPath(start=start, radius=0.12)
    s = np.linspace(0.0, 1.0, 50)
    sample = path(s, np.ones_like(s), np.zeros_like(s))
    np.testing.assert_allclose(np.linalg.norm(sample.position - path.center, axis=1), 0.12,
                               atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(sample.position[:, 0], start[0], atol=1e-9)  # x constant
    np.testing.assert_allclose(sample.position[0], start, atol=1e-12)
    np.testing.assert_allclose(sample.position[-1], start, atol=1e-9)  # whole circle
    assert np.ptp(sample.position[:, 1]) == pytest.approx(0.24, abs=1e-3)
    assert np.ptp(sample.position[:, 2]) == pytest.approx(0.24, abs=1e-3)


def test_circle_in_a_tilted_plane():
    normal = np.array([0.0, 1.0, 1.0]) / np.sqrt(2)
    start = np.array([0.2, -0.3, 0.6])
    path = CircularPath(start=start, radius=0.05, normal=normal, center_direction=[1, 0, 0])
    s = np.linspace(0.0, 1.0, 37)
    sample = path(s, np.ones_like(s), np.zeros_like(s))
    np.testing.assert_allclose((sample.position - start) @ normal, 0.0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(sample.position - path.center, axis=1), 0.05,
                               atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(path.center, start + [0.05, 0, 0], atol=1e-12)
    assert path.length == pytest.approx(2 * np.pi * 0.05, rel=1e-12)


def test_slerp_orientation_ends_and_angular_velocity():
    R0 = RotationMatrix.MakeXRotation(np.pi)
    R1 = R0.multiply(RotationMatrix.MakeZRotation(0.6))
    orientation = OrientationPath(start=R0, goal=R1)
    assert orientation.angle == pytest.approx(0.6, abs=1e-12)
    quaternions, w, alpha = orientation([0.0, 0.5, 1.0], [2.0, 2.0, 2.0], [1.0, 1.0, 1.0])
    for quaternion, R in ((quaternions[0], R0), (quaternions[2], R1)):
        got = unpack_cartesian_reference(np.concatenate([quaternion, np.zeros(15)]))
        np.testing.assert_allclose(got.pose.rotation().matrix(), R.matrix(), atol=1e-12)
    # Rotation about R0's z axis, in the base frame; |w| = angle * s'.
    axis = R0.matrix()[:, 2]
    np.testing.assert_allclose(w[1], 0.6 * 2.0 * axis, atol=1e-12)
    np.testing.assert_allclose(alpha[1], 0.6 * 1.0 * axis, atol=1e-12)
    held = OrientationPath(start=R0)
    assert held.angle == 0.0


def test_reference_trajectory_holds_exact_samples_at_the_ticks():
    law = CubicTimeLaw(duration=1.0)
    R0 = RotationMatrix.MakeYRotation(0.3)
    trajectory = CartesianTrajectory(
        time_law=law,
        path=CircularPath(start=[0.4, 0.0, 0.5], radius=0.05),
        orientation=OrientationPath(start=R0, goal=RotationMatrix.MakeZRotation(0.4)),
    )
    period = 0.01
    reference = trajectory.as_reference_trajectory(period)
    assert reference.rows() == CARTESIAN_REFERENCE_SIZE
    for t in (0.0, 0.37, 0.5, 1.0, 1.01):
        np.testing.assert_allclose(reference.value(t)[:, 0], trajectory.reference([t])[0],
                                   atol=1e-12)  # fmt: skip
    end = unpack_cartesian_reference(reference.value(5.0)[:, 0])  # held after the end
    np.testing.assert_allclose(end.pose.translation(), [0.4, 0.0, 0.5], atol=1e-9)
    np.testing.assert_allclose(end.twist, 0.0, atol=1e-12)
    sample = trajectory(0.5)
    np.testing.assert_allclose(sample.pose.translation(), [0.4, 0.0, 0.4], atol=1e-12)


@pytest.mark.parametrize(
    "make, text",
    [
        (lambda: CircularPath(start=[0, 0, 0], radius=0.0), "radius=0.0"),
        (lambda: CircularPath(start=[0, 0, 0], radius=-0.1), "radius=-0.1"),
        (lambda: CircularPath(start=[0, 0, 0], radius=0.1, normal=[0, 0, 0]), "normal="),
        (
            lambda: CircularPath(start=[0, 0, 0], radius=0.1, center_direction=[2, 0, 0]),
            "center_direction=[2.0, 0.0, 0.0] is parallel",
        ),
        (lambda: LinearPath(start=[0, 0], goal=[1, 1, 1]), "start=[0, 0]"),
        (lambda: LinearPath(start=[0, 0, 0], goal=[1, float("nan"), 1]), "goal="),
    ],
)
def test_bad_paths_are_one_line_errors(make, text):
    with pytest.raises(PathError) as error:
        make()
    assert text in str(error.value)
    assert "\n" not in str(error.value)
