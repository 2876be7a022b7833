"""The built-in Armando description: joints, limits, inertias, kinematics, collision boxes,
camera, ros2_control block and controller configuration."""

import math
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import yaml
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import RevoluteJoint, WeldJoint

from armando_drake import MODELS_DIR
from armando_drake.description.loader import load_robot

PACKAGE = MODELS_DIR / "armando_description"
JOINTS = ["j0", "j1", "j2", "j3"]
# [rad] position limits: the course's numbers.
LIMITS = {"j0": 2.57, "j1": 3.14, "j2": 3.14, "j3": 3.14}
STALL_TORQUE = 1.5  # [N m] AX-12A at 12 V
NO_LOAD_SPEED = 59 * 2 * math.pi / 60  # [rad/s] AX-12A, 59 rpm at 12 V
SERVO = 0.0546  # [kg] AX-12A
# [kg] the masses the README states.
MASSES = {
    "base_link": 0.080 + SERVO,
    "base_turn": 0.020,
    "base_turn_rot": 0.015,
    "dyn2": SERVO,
    "dyn2_r": 0.0,
    "f4": 0.008,
    "dyn3": SERVO,
    "dyn3_r": 0.0,
    "f5": 0.008,
    "dyn4": SERVO,
    "dyn4_r": 0.0,
    "wrist": 0.006,
    "dyn5": SERVO,
    "dyn5_r": 0.0,
    "crawer_base": 0.008,
    "crawer_left": 0.005,
    "crawer_right": 0.005,
    "camera_link": 0.020,
}
LINKS_WITHOUT_GEOMETRY = {"dyn2_r", "dyn3_r", "dyn4_r", "dyn5_r"}
TABLE_Z = -0.0313  # [m] the bottom of the base in base_link


def load(**xacro_args):
    """The finalized plant, its default context and the LoadedRobot."""
    plant = MultibodyPlant(time_step=0.001)
    robot = load_robot(plant, None, xacro_args={k: str(v) for k, v in xacro_args.items()})
    plant.Finalize()
    return plant, plant.CreateDefaultContext(), robot


@pytest.fixture(scope="module")
def armando():
    return load()


def robot_bodies(plant, robot):
    return [plant.get_body(index) for index in plant.GetBodyIndices(robot.model_instance)]


def robot_joints(plant, robot):
    """The URDF's joints (not the loader's weld of base_link to the world)."""
    joints = [plant.get_joint(index) for index in plant.GetJointIndices(robot.model_instance)]
    return [joint for joint in joints if joint.parent_body().index() != plant.world_body().index()]


# --------------------------------------------------------------------------
# Joints and arguments
# --------------------------------------------------------------------------


def test_four_revolute_joints_with_servo_limits(armando):
    plant, _, robot = armando
    joints = robot_joints(plant, robot)
    revolute = [joint for joint in joints if joint.num_velocities() > 0]
    assert [joint.name() for joint in revolute] == JOINTS
    assert all(isinstance(joint, RevoluteJoint) for joint in revolute)
    assert all(isinstance(joint, WeldJoint) for joint in joints if joint not in revolute)
    for joint in revolute:
        limit = LIMITS[joint.name()]
        np.testing.assert_allclose(joint.position_lower_limits(), [-limit])
        np.testing.assert_allclose(joint.position_upper_limits(), [limit])
        np.testing.assert_allclose(joint.velocity_upper_limits(), [NO_LOAD_SPEED], rtol=1e-12)
    assert NO_LOAD_SPEED == pytest.approx(6.178, abs=1e-3)
    for info in robot.joints:
        assert (info.type, info.effort) == ("revolute", STALL_TORQUE)
        assert info.velocity == pytest.approx(NO_LOAD_SPEED, rel=1e-12)
    assert (robot.name, robot.base_link) == ("armando", "base_link")


def test_prefix_goes_in_front_of_every_name():
    plant, _, robot = load(prefix="left_")
    bodies = [body.name() for body in robot_bodies(plant, robot)]
    joints = [joint.name() for joint in robot_joints(plant, robot)]
    assert len(bodies) == len(MASSES)
    assert sorted(bodies) == sorted("left_" + name for name in MASSES)
    assert all(name.startswith("left_") for name in joints), joints
    assert [joint.name for joint in robot.joints] == ["left_" + name for name in JOINTS]
    (block,) = robot.ros2_control
    assert block.name == "left_ArmandoSystem"
    assert [joint.name for joint in block.joints] == ["left_" + name for name in JOINTS]
    root = ET.fromstring(robot.urdf)
    assert [g.get("reference") for g in root.findall("gazebo")] == ["left_camera_link"]


def test_camera_and_ros2_control_can_be_left_out():
    plant, _, robot = load(use_camera="false", use_ros2_control="false")
    bodies = {body.name() for body in robot_bodies(plant, robot)}
    assert bodies == set(MASSES) - {"camera_link"}
    assert robot.ros2_control == []
    root = ET.fromstring(robot.urdf)
    assert root.findall("ros2_control") == [] and root.findall("gazebo") == []
    assert root.find("joint[@name='camera_joint']") is None


# --------------------------------------------------------------------------
# Mass properties
# --------------------------------------------------------------------------


def test_inertias_are_valid_and_masses_as_stated(armando):
    plant, context, robot = armando
    masses = {}
    for body in robot_bodies(plant, robot):
        inertia = body.CalcSpatialInertiaInBodyFrame(context)
        assert inertia.IsPhysicallyValid(), body.name()
        masses[body.name()] = inertia.get_mass()
    assert masses.keys() == MASSES.keys()
    for name, mass in MASSES.items():
        assert masses[name] == pytest.approx(mass, abs=1e-12), name
    total = sum(MASSES.values()) - MASSES["camera_link"]
    assert total == pytest.approx(0.428, abs=1e-9)
    # Every moving joint carries mass on its child side, though the horn frames are massless.
    carried = {}
    for joint in robot_joints(plant, robot):
        if joint.num_velocities() > 0:
            outboard = plant.GetBodiesKinematicallyAffectedBy([joint.index()])
            carried[joint.name()] = sum(masses[plant.get_body(i).name()] for i in outboard)
    expected = {"j0": 0.2734, "j1": 0.2038, "j2": 0.1412, "j3": 0.0786}
    assert carried == pytest.approx(expected, abs=1e-9)


def _visual_bounds(link: ET.Element) -> tuple[np.ndarray, np.ndarray] | None:
    """The bounding box, in the link frame, of a link's primitive visuals."""
    points = []
    for visual in link.findall("visual"):
        geometry = visual.find("geometry")
        box, cylinder = geometry.find("box"), geometry.find("cylinder")
        if box is not None:
            half = np.array([float(v) for v in box.get("size").split()]) / 2
        else:
            assert cylinder is not None, f"{link.get('name')}: only boxes and cylinders"
            radius, length = float(cylinder.get("radius")), float(cylinder.get("length"))
            half = np.array([radius, radius, length / 2])
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        X = _origin(visual)
        points.extend(X.multiply((corners * half).T).T)
    if not points:
        return None
    points = np.array(points)
    return points.min(axis=0), points.max(axis=0)


def _origin(element: ET.Element) -> RigidTransform:
    origin = element.find("origin")
    xyz = [float(v) for v in origin.get("xyz", "0 0 0").split()]
    rpy = [float(v) for v in origin.get("rpy", "0 0 0").split()]
    return RigidTransform(RollPitchYaw(rpy), xyz)


def collision_margins(urdf: str) -> dict[str, np.ndarray]:
    """Per link with visuals: how far its collision box reaches past its visual bounding
    box on each side (-x, -y, -z, +x, +y, +z) [m]."""
    margins = {}
    for link in ET.fromstring(urdf).findall("link"):
        name = link.get("name")
        bounds = _visual_bounds(link)
        collisions = link.findall("collision")
        if bounds is None:
            assert collisions == [], f"{name} has collisions but no visuals"
            continue
        assert len(collisions) == 1, f"{name} has {len(collisions)} collision elements"
        box = collisions[0].find("geometry/box")
        assert box is not None, f"{name}: the collision is not a box"
        X = _origin(collisions[0])
        assert np.allclose(X.rotation().matrix(), np.eye(3)), f"{name}: rotated collision box"
        half = np.array([float(v) for v in box.get("size").split()]) / 2
        low, high = X.translation() - half, X.translation() + half
        margins[name] = np.concatenate([bounds[0] - low, high - bounds[1]])
    return margins


def test_inertias_are_those_of_the_link_geometry(armando):
    """Each inertia is that of a solid box (a cylinder for the turntable) filling the link's
    visual bounding box at the link's mass, centred on it."""
    _, _, robot = armando
    for link in ET.fromstring(robot.urdf).findall("link"):
        name = link.get("name")
        inertial = link.find("inertial")
        if name in LINKS_WITHOUT_GEOMETRY:
            assert inertial is None
            continue
        low, high = _visual_bounds(link)
        size, centre = high - low, (high + low) / 2
        mass = float(inertial.find("mass").get("value"))
        inertia = inertial.find("inertia")
        moments = np.array([float(inertia.get(k)) for k in ("ixx", "iyy", "izz")])
        products = [float(inertia.get(k)) for k in ("ixy", "ixz", "iyz")]
        if name == "base_turn_rot":
            radius, length = size[0] / 2, size[2]
            side = mass * (3 * radius**2 + length**2) / 12
            expected = np.array([side, side, mass * radius**2 / 2])
        else:
            a, b, c = size
            expected = mass * np.array([b * b + c * c, a * a + c * c, a * a + b * b]) / 12
        np.testing.assert_allclose(moments, expected, rtol=1e-9, err_msg=name)
        assert products == [0.0, 0.0, 0.0]
        np.testing.assert_allclose(_origin(inertial).translation(), centre, atol=1e-12)


# --------------------------------------------------------------------------
# Kinematics against the course's model
# --------------------------------------------------------------------------


def course_plant(package):
    """The course's arm.urdf without its geometry (STL meshes), welded at the origin, and
    its model instance."""
    text = (package / "urdf" / "arm.urdf").read_text()
    text = re.sub(r"<(collision|visual)>.*?</\1>", "", text, flags=re.S)
    plant = MultibodyPlant(time_step=0.001)
    (instance,) = Parser(plant, "course").AddModelsFromString(text, "urdf")
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("base_link", instance))
    plant.Finalize()
    return plant, instance


def test_forward_kinematics_equals_the_course_model(armando, course_package):
    plant, context, robot = armando
    course, instance = course_plant(course_package)
    course_context = course.CreateDefaultContext()
    names = [course.get_body(index).name() for index in course.GetBodyIndices(instance)]
    assert len(names) == 17 and set(names) <= set(MASSES)
    lower, upper = plant.GetPositionLowerLimits(), plant.GetPositionUpperLimits()
    np.testing.assert_allclose(course.GetPositionLowerLimits(), lower)
    np.testing.assert_allclose(course.GetPositionUpperLimits(), upper)
    rng = np.random.default_rng(20240)
    worst_position, worst_angle = 0.0, 0.0
    for _ in range(50):
        q = rng.uniform(lower, upper)
        plant.SetPositions(context, q)
        course.SetPositions(course_context, q)
        for name in names:
            X_ours = plant.GetBodyByName(name).EvalPoseInWorld(context)
            X_course = course.GetBodyByName(name).EvalPoseInWorld(course_context)
            error = X_course.InvertAndCompose(X_ours)
            worst_position = max(worst_position, np.linalg.norm(error.translation()))
            worst_angle = max(worst_angle, error.rotation().ToAngleAxis().angle())
    # 1.57 for pi/2 (and 3.14 for pi) in the course's rpy: 0.8 mrad per use, accumulated.
    assert worst_position < 1e-3
    assert worst_angle < 6e-3
    assert worst_position > 1e-5  # the rounding shows: the two models are not the same file


def test_arm_is_straight_up_at_zero(armando):
    plant, context, _ = armando
    plant.SetPositions(context, np.zeros(4))
    p_tip = plant.GetBodyByName("crawer_base").EvalPoseInWorld(context).translation()
    np.testing.assert_allclose(p_tip, [0.0007, -0.0102, 0.3875], atol=5e-4)


# --------------------------------------------------------------------------
# Collision geometry
# --------------------------------------------------------------------------


def test_one_collision_box_per_link_covers_its_visuals(armando):
    _, _, robot = armando
    margins = collision_margins(robot.urdf)
    assert set(margins) == set(MASSES) - LINKS_WITHOUT_GEOMETRY
    worst = max(margins.items(), key=lambda item: item[1].max())
    least = min(margins.items(), key=lambda item: item[1].min())
    assert least[1].min() >= -1e-9, f"{least[0]}: visual sticks out by {-least[1].min()} m"
    assert worst[1].max() <= 0.005, f"{worst[0]}: collision box {worst[1].max()} m too big"
    # The boxes are the visual extents grown by the 1 mm clearance.
    np.testing.assert_allclose(np.concatenate(list(margins.values())), 0.001, atol=1e-9)


# --------------------------------------------------------------------------
# Camera
# --------------------------------------------------------------------------


def test_camera_looks_at_the_workspace_in_front_of_the_arm(armando):
    plant, context, robot = armando
    X_BC = plant.GetBodyByName("camera_link").EvalPoseInWorld(context)
    p_camera, forward = X_BC.translation(), X_BC.rotation().col(0)
    assert 0.7 < np.linalg.norm(p_camera[:2]) < 0.8  # 0.75 m from the base
    assert 0.2 < p_camera[2] - TABLE_Z < 0.3  # above the table
    assert X_BC.rotation().col(2)[2] > 0.9  # upright: +z up
    assert -0.2 < forward[2] < -0.05  # pitched down a little
    # The optical axis passes through the arm's vertical axis, halfway up the arm.
    s = -(p_camera[:2] @ forward[:2]) / (forward[:2] @ forward[:2])
    p_axis = p_camera + s * forward
    np.testing.assert_allclose(p_axis[:2], [0.0, 0.0], atol=0.01)
    assert 0.12 < p_axis[2] - TABLE_Z < 0.2
    (sensor,) = ET.fromstring(robot.urdf).findall("gazebo/sensor")
    assert sensor.get("name") == "camera" and sensor.get("type") == "camera"
    values = {
        path: sensor.findtext(path)
        for path in (
            "camera/horizontal_fov",
            "camera/image/width",
            "camera/image/height",
            "camera/clip/near",
            "camera/clip/far",
            "update_rate",
            "topic",
        )
    }
    assert values == {
        "camera/horizontal_fov": "1.047",
        "camera/image/width": "640",
        "camera/image/height": "480",
        "camera/clip/near": "0.1",
        "camera/clip/far": "100",
        "update_rate": "30",
        "topic": "camera",
    }


# --------------------------------------------------------------------------
# ros2_control and controllers
# --------------------------------------------------------------------------


def test_ros2_control_block(armando):
    _, _, robot = armando
    (block,) = robot.ros2_control
    assert (block.name, block.type, block.plugin) == (
        "ArmandoSystem",
        "system",
        "gz_ros2_control/GazeboSimSystem",
    )
    assert [joint.name for joint in block.joints] == JOINTS
    for joint in block.joints:
        assert [i.name for i in joint.command_interfaces] == ["position"]
        assert (joint.command_interfaces[0].min, joint.command_interfaces[0].max) == (None, None)
        assert [i.name for i in joint.state_interfaces] == ["position", "velocity", "effort"]
        assert joint.state_interface("position").initial_value == 0.0


def test_initial_positions_and_plugin_are_arguments():
    _, _, robot = load(initial_j1="0.5", initial_j3="-1.25", ros2_control_plugin="mock/Plugin")
    (block,) = robot.ros2_control
    assert block.plugin == "mock/Plugin"
    initial = [joint.state_interface("position").initial_value for joint in block.joints]
    assert initial == [0.0, 0.5, 0.0, -1.25]


def test_controllers_yaml():
    data = yaml.safe_load((PACKAGE / "config" / "armando_controllers.yaml").read_text())
    manager = data["controller_manager"]["ros__parameters"]
    assert manager["update_rate"] == 100
    types = {name: manager[name]["type"] for name in manager if name != "update_rate"}
    assert types == {
        "joint_state_broadcaster": "joint_state_broadcaster/JointStateBroadcaster",
        "position_controller": "position_controllers/JointGroupPositionController",
        "trajectory_controller": "joint_trajectory_controller/JointTrajectoryController",
    }
    assert data["position_controller"]["ros__parameters"]["joints"] == JOINTS
    trajectory = data["trajectory_controller"]["ros__parameters"]
    assert trajectory["joints"] == JOINTS
    assert trajectory["command_interfaces"] == ["position"]
    assert trajectory["state_interfaces"] == ["position", "velocity"]
    constraints = trajectory["constraints"]
    assert constraints["goal_time"] > 0 and constraints["stopped_velocity_tolerance"] == 0.01
    for joint in JOINTS:
        assert constraints[joint] == {"trajectory": 0.2, "goal": 0.01}


def test_package_is_found_by_name():
    from armando_drake.description.loader import find_packages

    assert find_packages().resolve("armando_description") == PACKAGE.resolve()
