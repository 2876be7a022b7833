"""A task-space motion from YAML: the trajectory it makes, and its one-line errors."""

import numpy as np
import pytest
from pydrake.common.yaml import yaml_load_typed
from pydrake.math import RigidTransform, RotationMatrix

from armando_drake.kinematics.motion import TaskSpaceMotion, make_cartesian_trajectory
from armando_drake.kinematics.paths import PathError
from armando_drake.kinematics.time_laws import TimeLawError

X_START = RigidTransform(RotationMatrix.MakeYRotation(np.pi), [0.55, 0.0, 0.5])


def test_linear_motion_with_rotation_from_yaml():
    motion = yaml_load_typed(
        schema=TaskSpaceMotion,
        data="""
path: linear
offset: [-0.1, 0.25, 0.15]
rotation: [0.0, 0.0, 0.6]
profile: trapezoidal
duration: 2.0
acceleration_time: 0.5
""",
    )
    trajectory = make_cartesian_trajectory(motion, X_START)
    end = trajectory(2.0)
    np.testing.assert_allclose(end.pose.translation(), [0.45, 0.25, 0.65], atol=1e-12)
    expected = RotationMatrix.MakeZRotation(0.6).multiply(X_START.rotation())
    np.testing.assert_allclose(end.pose.rotation().matrix(), expected.matrix(), atol=1e-12)
    middle = trajectory(1.0)
    np.testing.assert_allclose(middle.twist[:3], [0, 0, 0.6 / 1.5], atol=1e-12)  # 0.6 / (T - t_c)


def test_circular_motion_defaults_to_the_seeds_plane():
    motion = yaml_load_typed(
        schema=TaskSpaceMotion, data="{path: circular, radius: 0.1, profile: cubic}"
    )
    trajectory = make_cartesian_trajectory(motion, X_START)
    reference = trajectory.reference(np.linspace(0, motion.duration, 40))
    np.testing.assert_allclose(reference[:, 4], 0.55, atol=1e-9)  # the y-z plane
    np.testing.assert_allclose(
        np.linalg.norm(reference[:, 4:7] - [0.55, 0.0, 0.4], axis=1), 0.1, atol=1e-9
    )


@pytest.mark.parametrize(
    "data, error, text",
    [
        ("path: spiral", PathError, "path='spiral' must be one of linear, circular"),
        ("profile: bang", PathError, "profile='bang' must be one of"),
        ("{duration: 1.0, acceleration_time: 0.8}", TimeLawError, "acceleration_time=0.8"),
        ("{path: circular, radius: -0.1}", PathError, "radius=-0.1"),
        ("rotation: [0.1, 0.2]", PathError, "rotation=[0.1, 0.2]"),
    ],
)
def test_bad_motions_are_one_line_errors(data, error, text):
    motion = yaml_load_typed(schema=TaskSpaceMotion, data=data)
    with pytest.raises(error) as raised:
        make_cartesian_trajectory(motion, X_START)
    assert text in str(raised.value) and "\n" not in str(raised.value)


def test_unknown_key_is_an_error():
    with pytest.raises(RuntimeError, match="no_such_key"):
        yaml_load_typed(schema=TaskSpaceMotion, data="no_such_key: 1")
