"""Our iiwa description (models/iiwa_description): the course's kinematics and dynamics
with our own shapes, loaded without ../shared; its interfaces; no file of the course's."""

import numpy as np
import pytest
from pydrake.multibody.plant import MultibodyPlant

from armando_drake import MODELS_DIR
from armando_drake.description.loader import load_robot

PACKAGE = MODELS_DIR / "iiwa_description"
TOP = "package://iiwa_description/urdf/iiwa14.urdf.xacro"
JOINTS = [f"iiwa_joint_{k}" for k in range(1, 8)]
FRAMES = [f"iiwa_link_{k}" for k in range(8)] + ["iiwa_link_ee"]
# [rad] the course's position limits, 170 / 120 / ... / 175 degrees either way.
LIMITS = np.radians([170, 120, 170, 120, 170, 120, 175])


def iiwa(description: str, **kwargs) -> tuple[MultibodyPlant, object]:
    plant = MultibodyPlant(0.001)
    robot = load_robot(plant, description, **kwargs)
    plant.Finalize()
    return plant, robot


@pytest.mark.parametrize("interface", ["position", "velocity", "effort"])
def test_every_joint_takes_the_chosen_command_interface(interface):
    plant, robot = iiwa(TOP, xacro_args={"command_interface": interface})
    assert robot.command_interfaces == {joint: [interface] for joint in JOINTS}
    assert np.allclose(plant.GetPositionUpperLimits(), LIMITS)
    assert np.allclose(plant.GetPositionLowerLimits(), -LIMITS)
    assert np.allclose(plant.GetVelocityUpperLimits(), 10.0)
    assert [plant.GetJointByName(j).default_damping() for j in JOINTS] == [0.5] * 7
    assert np.isclose(plant.CalcTotalMass(plant.CreateDefaultContext()), 22.5)  # [kg]


def test_the_package_holds_no_mesh():
    files = [p for p in PACKAGE.rglob("*") if p.is_file()]
    assert not [p for p in files if p.suffix.lower() in (".stl", ".dae", ".obj")]
    for path in PACKAGE.glob("urdf/*.xacro"):
        assert "<mesh" not in path.read_text(), path.name


def test_frames_and_dynamics_are_the_course_models(iiwa_package):
    ours, _ = iiwa(TOP, xacro_args={"command_interface": "effort"})
    course, _ = iiwa(
        str(iiwa_package / "urdf" / "iiwa14.urdf.xacro"),
        xacro_args={"hardware_interface": "EffortJointInterface"},
        package_paths=[iiwa_package.parent],
    )
    ours_context, course_context = ours.CreateDefaultContext(), course.CreateDefaultContext()
    rng = np.random.default_rng(0)
    for _ in range(30):
        q, v = rng.uniform(-LIMITS, LIMITS), rng.uniform(-1.0, 1.0, 7)
        for plant, context in ((ours, ours_context), (course, course_context)):
            plant.SetPositions(context, q)
            plant.SetVelocities(context, v)
        for name in FRAMES:
            X_ours = ours.GetFrameByName(name).CalcPoseInWorld(ours_context)
            X_course = course.GetFrameByName(name).CalcPoseInWorld(course_context)
            assert np.allclose(X_ours.GetAsMatrix4(), X_course.GetAsMatrix4(), atol=1e-12), name
        assert np.allclose(
            ours.CalcMassMatrix(ours_context), course.CalcMassMatrix(course_context), atol=1e-9
        )
        assert np.allclose(
            ours.CalcBiasTerm(ours_context), course.CalcBiasTerm(course_context), atol=1e-9
        )
        assert np.allclose(
            ours.CalcGravityGeneralizedForces(ours_context),
            course.CalcGravityGeneralizedForces(course_context),
            atol=1e-9,
        )
