"""Every pattern of published ROS arm descriptions, one fixture package each
(``tests/description/fixtures``): loaded with the expected joints, actuators and
interfaces, displayed, and simulated for 1 s."""

import json
import logging
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh
from fixture_packages import DAE_RED, OBJ_GREEN, TEXTURE_BLUE, make_workspace
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import DiscreteContactApproximation, MultibodyPlant
from pydrake.systems.analysis import Simulator

from armando_drake import MODELS_DIR
from armando_drake.description.loader import DescriptionError, find_packages, load_robot
from armando_drake.simulation.builder import MakeWorld
from armando_drake.simulation.scenario import load_scenario, merge_overrides


@pytest.fixture(scope="module", autouse=True)
def mesh_cache(tmp_path_factory):
    """Converted meshes go to a cache of this module's own (subprocesses inherit it)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("XDG_CACHE_HOME", str(tmp_path_factory.mktemp("xdg-cache")))
        yield


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    """All fixture packages side by side in one ``src`` folder, meshes written."""
    return make_workspace(tmp_path_factory.mktemp("workspace"))


def load(package: Path, *, time_step=0.001, approximation="lagged", **kwargs):
    plant = MultibodyPlant(time_step=time_step)
    if time_step > 0:
        plant.set_discrete_contact_approximation(
            {"lagged": DiscreteContactApproximation.kLagged,
             "tamsi": DiscreteContactApproximation.kTamsi}[approximation]
        )  # fmt: skip
    robot = load_robot(plant, package, **kwargs)
    plant.Finalize()
    return plant, robot


def simulate(description: Path, overrides: str = "", seconds: float = 1.0):
    """The world of ``description`` (no sequencer unless ``overrides`` has one), run ``seconds``."""
    scenario = merge_overrides(
        load_scenario("world"),
        [f"robot: {{description: '{description}'}}\nlogging: {{console_rate: 0}}", overrides],
    )
    world = MakeWorld(scenario, quiet=True)
    simulator = Simulator(world.diagram)
    simulator.Initialize()
    simulator.AdvanceTo(seconds)
    context = simulator.get_context()
    plant_context = world.plant.GetMyContextFromRoot(context)
    return world, plant_context


def mtl_diffuse(mtl: Path) -> list[list[float]]:
    """The ``Kd`` colour of every material of an MTL file, in file order."""
    return [
        [float(v) for v in line.split()[1:4]]
        for line in mtl.read_text().splitlines()
        if line.startswith("Kd ")
    ]


# --------------------------------------------------------------------------
# 1. A `world` link
# --------------------------------------------------------------------------


def test_world_link_chain_is_welded_at_the_joint_pose_times_the_base_pose(workspace):
    X_WB = RigidTransform(RollPitchYaw(0, 0, 0.3), [1.0, 2.0, 0.0])
    plant, robot = load(workspace / "world_arm_description", X_WB=X_WB)
    assert [j.name for j in robot.joints] == ["shoulder", "elbow"]
    assert [(w.link, w.joint) for w in robot.welds] == [("base_footprint", "world_joint")]
    assert plant.num_positions() == 2  # welded, not floating
    context = plant.CreateDefaultContext()
    X_WF = X_WB @ RigidTransform(RollPitchYaw(0, 0, np.pi / 2), [0.1, 0.0, 0.2])
    X_WL = X_WF @ RigidTransform([0.0, 0.0, 0.05])
    actual = plant.GetFrameByName("base_link").CalcPoseInWorld(context)
    np.testing.assert_allclose(actual.GetAsMatrix4(), X_WL.GetAsMatrix4(), atol=1e-12)


@pytest.mark.parametrize(
    "argument, interface",
    [
        ("PositionJointInterface", "position"),
        ("VelocityJointInterface", "velocity"),
        ("EffortJointInterface", "effort"),
    ],
)
def test_ros1_transmissions_give_each_joint_its_hardware_interface(workspace, argument, interface):
    _, robot = load(
        workspace / "world_arm_description", xacro_args={"hardware_interface": argument}
    )
    assert robot.actuation_source == "transmission"
    assert robot.command_interfaces == {"shoulder": [interface], "elbow": [interface]}
    (first, second) = robot.transmissions
    assert first.name == "shoulder_transmission"
    assert first.type == "transmission_interface/SimpleTransmission"
    assert first.hardware_interfaces == {"shoulder": [f"hardware_interface/{argument}"]}


def test_a_moving_joint_from_the_world_link_hangs_on_a_welded_anchor(tmp_path):
    """A linear rail from `world`: the rail stays a joint, its parent welded at the base pose."""
    path = tmp_path / "rail.urdf"
    path.write_text(
        '<robot name="rail"><link name="world"/>'
        '<link name="carriage"><inertial><mass value="1"/>'
        '<inertia ixx="1e-2" iyy="1e-2" izz="1e-2" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        '<joint name="rail" type="prismatic"><parent link="world"/><child link="carriage"/>'
        '<origin xyz="0 0 0.5"/><axis xyz="1 0 0"/>'
        '<limit lower="-1" upper="1" effort="100" velocity="1"/></joint></robot>'
    )
    plant, robot = load(path, X_WB=RigidTransform([0.0, 2.0, 0.0]))
    assert [w.link for w in robot.welds] == ["world_anchor"]
    assert plant.num_positions() == 1
    context = plant.CreateDefaultContext()
    X = plant.GetFrameByName("carriage").CalcPoseInWorld(context)
    np.testing.assert_allclose(X.translation(), [0.0, 2.0, 0.5])


def test_gazebo_style_transmissions_one_per_interface_and_non_joint_ones(tmp_path, caplog):
    """As franka_description writes them for Gazebo: a position, a velocity and an effort
    transmission on each joint, and franka_hw state transmissions that command nothing."""

    def transmission(name, joint, interface):
        return (
            f'<transmission name="{name}"><type>transmission_interface/SimpleTransmission</type>'
            f'<joint name="{joint}"><hardwareInterface>{interface}</hardwareInterface></joint>'
            f'<actuator name="{name}_motor"/></transmission>'
        )

    blocks = [
        transmission(f"j_{kind}", "j", f"hardware_interface/{kind}JointInterface")
        for kind in ("Position", "Velocity", "Effort")
    ] + [transmission("state", "j", "franka_hw/FrankaStateInterface")]
    path = tmp_path / "arm.urdf"
    path.write_text(
        '<robot name="arm"><link name="a"/><link name="b"><inertial><mass value="1"/>'
        '<inertia ixx="1e-2" iyy="1e-2" izz="1e-2" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        '<joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="10" velocity="1"/></joint>'
        + "".join(blocks)
        + "</robot>"
    )
    caplog.set_level(logging.INFO)
    _, robot = load(path)
    assert robot.command_interfaces == {"j": ["position", "velocity", "effort"]}
    assert "franka_hw/FrankaStateInterface of joint 'j' is not a joint command interface" in (
        caplog.text
    )


WORLD_ONLY = """<robot name="r"><link name="world"/>
<link name="a"><inertial><mass value="1"/>
  <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
</robot>"""
TWO_TREES_ON_WORLD = WORLD_ONLY.replace(
    "</robot>",
    '<joint name="w" type="fixed"><parent link="world"/><child link="a"/></joint>'
    '<link name="loose"/><link name="loose_child"/>'
    '<joint name="l" type="revolute"><parent link="loose"/><child link="loose_child"/>'
    '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>',
)
TWO_ROOTS = '<robot name="r"><link name="a"/><link name="b"/></robot>'
LOOP = """<robot name="r"><link name="a"/><link name="b"/>
<joint name="ab" type="fixed"><parent link="a"/><child link="b"/></joint>
<joint name="ba" type="fixed"><parent link="b"/><child link="a"/></joint></robot>"""


@pytest.mark.parametrize(
    "urdf, message",
    [
        (WORLD_ONLY, "the `world` link holds no joint"),
        (TWO_TREES_ON_WORLD, r"link\(s\) loose are attached neither to the `world` link"),
        (TWO_ROOTS, r"2 root links \(a, b\): two disconnected trees"),
        (LOOP, r"no root link: every link \(a, b\) is the child of a joint"),
    ],
)
def test_trees_that_cannot_be_welded_are_errors_naming_the_links(tmp_path, urdf, message):
    path = tmp_path / "robot.urdf"
    path.write_text(urdf)
    with pytest.raises(DescriptionError, match=message):
        load(path)


def test_world_link_arm_is_placed_by_the_scenario_base_pose_and_falls(workspace):
    world, plant_context = simulate(
        workspace / "world_arm_description",
        "robot: {base_xyz: [0.3, 0.0, 0.1]}\nground: false\n"
        "controllers: {activate: [joint_state_broadcaster]}",
        seconds=1.0,
    )
    X = world.plant.GetFrameByName("base_footprint").CalcPoseInWorld(plant_context)
    np.testing.assert_allclose(X.translation(), [0.4, 0.0, 0.3], atol=1e-12)
    # Upright and unactuated, it topples: the elbow has moved within 1 s.
    assert abs(world.plant.GetJointByName("elbow").get_angle(plant_context)) > 0.01


# --------------------------------------------------------------------------
# 2. Grippers and other joints
# --------------------------------------------------------------------------


def test_gripper_joints_mimic_damping_and_unlimited_joints(workspace, caplog):
    caplog.set_level(logging.INFO)
    plant, robot = load(workspace / "gripper_description")
    names = ["base_pan", "shoulder", "wrist", "left_finger_joint", "right_finger_joint"]
    assert [j.name for j in robot.joints] == names
    pan, wrist = robot.joint("base_pan"), robot.joint("wrist")
    assert (pan.lower, pan.upper, pan.effort) == (-np.inf, np.inf, np.inf)  # no <limit>
    assert (wrist.type, wrist.lower, wrist.upper, wrist.effort) == (
        "continuous",
        -np.inf,
        np.inf,
        5,
    )
    assert robot.joint("left_finger_joint").type == "prismatic"
    # The mimic joint is coupled by Drake and never actuated.
    assert [j.name for j in robot.mimic_joints] == ["right_finger_joint"]
    assert plant.num_constraints() == 1
    assert list(robot.command_interfaces) == ["shoulder", "wrist", "base_pan", "left_finger_joint"]
    assert "joint 'right_finger_joint' mimics 'left_finger_joint': not actuated" in caplog.text
    # Damping is simulated; friction is reported as not simulated.
    assert plant.GetJointByName("shoulder").default_damping() == pytest.approx(0.7)
    assert plant.GetJointByName("wrist").default_damping() == pytest.approx(0.02)
    (friction,) = [w for w in robot.warnings if "friction" in w]
    assert "joint 'shoulder': <dynamics friction=0.05> is not simulated" in friction


def test_mimic_joints_are_reported_when_the_solver_cannot_couple_them(workspace):
    plant, robot = load(workspace / "gripper_description", approximation="tamsi")
    assert plant.num_constraints() == 0
    (warning,) = [w for w in robot.warnings if "mimic" in w]
    assert "right_finger_joint (follows left_finger_joint) are NOT coupled" in warning


def test_gripper_on_its_own_controller_and_the_finger_follows(workspace):
    world, plant_context = simulate(
        workspace / "gripper_description",
        "controllers: {activate: [joint_state_broadcaster, position_controller, "
        "gripper_controller]}\nactuators: {kp: 50.0, kd: 2.0}",
        seconds=1.0,
    )
    assert world.robot().stack.controller_joints["gripper_controller"] == ["left_finger_joint"]
    assert world.robot().stack.controller_joints["position_controller"] == [
        "shoulder",
        "wrist",
        "base_pan",
    ]
    plant = world.plant
    left = plant.GetJointByName("left_finger_joint").get_translation(plant_context)
    right = plant.GetJointByName("right_finger_joint").get_translation(plant_context)
    assert left == pytest.approx(0.01, abs=1e-3)  # held at its initial_value
    assert right == pytest.approx(left, abs=1e-4)  # the coupler constraint
    shoulder = plant.GetJointByName("shoulder").get_angle(plant_context)
    assert shoulder == pytest.approx(0.2, abs=0.01)  # held at its initial_value


# --------------------------------------------------------------------------
# 3. Control blocks in every published form
# --------------------------------------------------------------------------


def test_control_blocks_plugins_params_transmissions(workspace, caplog):
    caplog.set_level(logging.INFO)
    _, robot = load(workspace / "control_forms_description")
    assert [b.name for b in robot.ros2_control] == ["ArmHardware", "ToolHardware", "WristSensor"]
    assert robot.command_interfaces == {
        "joint1": ["position"],
        "joint2": ["position"],
        "tool_joint": ["position"],
    }
    for block, plugin in (
        ("ArmHardware", "gz_ros2_control/GazeboSimSystem"),
        ("ToolHardware", "my_tool_driver/ToolHardwareInterface"),
    ):
        assert f"<ros2_control name='{block}'>: hardware plugin '{plugin}' is not run" in (
            caplog.text
        )
    assert "its sensors/GPIOs (tool_ft) give no readings" in caplog.text
    (transmission,) = robot.transmissions
    assert (transmission.name, transmission.ros2_control) == ("joint1_transmission", "ArmHardware")
    assert transmission.type == "transmission_interface/SimpleTransmission"
    assert transmission.mechanical_reduction == 50.0
    assert robot.controller_files == [
        workspace / "control_forms_description" / "config" / "gz_controllers.yaml"
    ]


def test_io_pseudo_joints_of_a_ros2_control_block_are_taken_as_gpios(tmp_path, caplog):
    """Older ur_description lists its I/O as <joint>s that are not in the URDF."""
    path = tmp_path / "arm.urdf"
    path.write_text(
        '<robot name="arm"><link name="a"/><link name="b"><inertial><mass value="1"/>'
        '<inertia ixx="1e-2" iyy="1e-2" izz="1e-2" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        '<joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="10" velocity="1"/></joint>'
        '<ros2_control name="Ur" type="system"><hardware><plugin>ur/Driver</plugin></hardware>'
        '<joint name="j"><command_interface name="position"/></joint>'
        '<joint name="speed_scaling"><state_interface name="speed_scaling_factor"/>'
        '<command_interface name="target_speed_fraction_cmd"/></joint>'
        "</ros2_control></robot>"
    )
    caplog.set_level(logging.INFO)
    _, robot = load(path)
    (block,) = robot.ros2_control
    assert [j.name for j in block.joints] == ["j"]
    assert [g.name for g in block.gpios] == ["speed_scaling"]
    assert robot.command_interfaces == {"j": ["position"]}
    assert "joint 'speed_scaling' is not in the URDF and has no acceleration, effort" in (
        caplog.text
    )


def test_gazebo_plugin_yaml_is_the_controller_configuration(workspace):
    world, plant_context = simulate(
        workspace / "control_forms_description",
        "controllers: {activate: [joint_state_broadcaster, forward_position_controller]}",
        seconds=1.0,
    )
    assert world.robot().stack.config.update_rate == 250  # not the decoy's 50
    hardware = {joint.name: joint for joint in world.robot().stack.hardware.joints}
    assert (hardware["joint1"].lower, hardware["joint1"].upper) == (-1.0, 1.0)  # min/max params
    assert hardware["joint1"].initial_position == 0.4
    assert hardware["tool_joint"].initial_position == 0.5
    # {-pi/2} and {pi/2}, tighter than the URDF's +-3 rad.
    assert (hardware["tool_joint"].lower, hardware["tool_joint"].upper) == pytest.approx(
        (-np.pi / 2, np.pi / 2)
    )
    for name, q0 in (("joint1", 0.4), ("joint2", -0.3), ("tool_joint", 0.5)):
        assert world.plant.GetJointByName(name).get_angle(plant_context) == pytest.approx(
            q0, abs=0.01
        )


def test_gazebo_plugin_yaml_of_a_package_we_do_not_have_is_reported(tmp_path, caplog):
    """A description naming its bringup package's YAML still loads without that package."""
    urdf = tmp_path / "robot.urdf.xacro"
    urdf.write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="a"/>'
        '<gazebo><plugin filename="gz_ros2_control-system" name="x">'
        "<parameters>$(find my_robot_bringup)/config/controllers.yaml</parameters>"
        "</plugin></gazebo></robot>"
    )
    caplog.set_level(logging.INFO)
    _, robot = load(urdf)
    assert robot.controller_files == [
        Path("/nonexistent-ros-package/my_robot_bringup/config/controllers.yaml")
    ]
    assert "$(find my_robot_bringup): unknown package (searched " in caplog.text


# --------------------------------------------------------------------------
# 5. xacro as ROS runs it
# --------------------------------------------------------------------------


def test_xacro_features(workspace, monkeypatch):
    monkeypatch.delenv("XACRO_FIXTURE_REACH", raising=False)
    plant, robot = load(workspace / "xacro_features_description")
    assert robot.name == "features"  # $(arg robot_name)'s default, used in <robot name>
    limits = {j.name: (j.lower, j.upper, j.effort) for j in robot.joints}
    assert limits == {  # from config/joint_limits.yaml through xacro.load_yaml
        "joint_a": (-1.2, 1.3, 12.0),
        "joint_b": (-0.7, 0.9, 8.0),
        "tool_joint": (-3.0, 3.0, 1.0),
    }
    context = plant.CreateDefaultContext()
    tool = plant.GetFrameByName("tool").CalcPoseInWorld(context).translation()
    np.testing.assert_allclose(tool, [0, 0, 0.05 + 2 * 0.25])  # $(optenv ..) default


def test_xacro_args_optenv_conditionals_and_other_packages(workspace, monkeypatch, tmp_path):
    monkeypatch.setenv("XACRO_FIXTURE_REACH", "0.4")
    limits = tmp_path / "limits.yaml"
    limits.write_text("joint_a: {lower: -0.5, upper: 0.5, effort: 3, velocity: 1}\n"
                      "joint_b: {lower: -0.6, upper: 0.6, effort: 3, velocity: 1}\n")  # fmt: skip
    plant, robot = load(
        workspace / "xacro_features_description",
        xacro_args={
            "robot_name": "renamed",
            "parts_file": "parts_v2.xacro",  # $(arg) in an include path
            "with_tool": "false",
            "limits_file": str(limits),
        },
    )
    assert robot.name == "renamed"
    assert [j.name for j in robot.joints] == ["joint_a", "joint_b"]  # xacro:unless took flange
    assert (robot.joint("joint_b").lower, robot.joint("joint_b").upper) == (-0.6, 0.6)
    context = plant.CreateDefaultContext()
    flange = plant.GetFrameByName("flange").CalcPoseInWorld(context).translation()
    np.testing.assert_allclose(flange, [0, 0, 0.05 + 2 * 0.4])  # $(optenv) from the environment
    # parts_v2.xacro's 3 cm radius, from the other package: a cylinder's izz = m r^2 / 2.
    body = plant.GetBodyByName("link_a")
    izz = body.default_rotational_inertia().get_moments()[2]
    assert izz == pytest.approx(body.default_mass() * 0.03**2 / 2)


# --------------------------------------------------------------------------
# 5b. Package resolution order
# --------------------------------------------------------------------------


def test_the_named_description_package_wins_and_the_shadowed_one_is_reported(tmp_path, caplog):
    """An edited copy of models/armando_description given as the description: its
    $(find armando_description) includes come from the copy, so the edit is applied."""
    copy = tmp_path / "copy" / "armando_description"
    shutil.copytree(MODELS_DIR / "armando_description", copy)
    arm = copy / "urdf" / "armando.xacro"  # included with $(find armando_description)
    original = '<xacro:property name="j123_limit" value="3.14"/>'
    assert original in arm.read_text()
    arm.write_text(arm.read_text().replace(original, original.replace("3.14", "1.234")))
    caplog.set_level(logging.INFO)
    robot = load_robot(MultibodyPlant(0.001), copy)
    assert [robot.joint(j).upper for j in ("j1", "j2", "j3")] == [1.234] * 3
    assert robot.packages.resolve("armando_description") == copy.resolve()
    (shadow,) = [r.getMessage() for r in caplog.records if "shadows" in r.getMessage()]
    assert f"package 'armando_description': using {copy.resolve()}" in shadow
    assert str((MODELS_DIR / "armando_description").resolve()) in shadow
    # Reported once per process, not at every load.
    caplog.clear()
    load_robot(MultibodyPlant(0.001), copy)
    assert "shadows" not in caplog.text
    # The built-in model is unchanged.
    assert load_robot(MultibodyPlant(0.001), None).joint("j1").upper == 3.14


def test_package_order_description_then_package_path_then_models(workspace, tmp_path):
    other = tmp_path / "other" / "xacro_parts"
    shutil.copytree(workspace / "xacro_parts", other)
    own = workspace / "xacro_features_description"
    search = find_packages([other.parent], near=own)
    # The description's own package first; then --package-path beats its siblings.
    assert search.resolve("xacro_features_description") == own.resolve()
    assert search.resolve("xacro_parts") == other.resolve()
    assert [label for label, _ in search.shadowed["xacro_parts"]] == [
        f"next to the description's package: {workspace.resolve()}"
    ]
    assert search.searched[0].startswith("package of the description: ")
    assert search.searched[-1].startswith("project models: ")


def test_a_package_with_its_descriptions_in_subfolders(workspace, tmp_path, caplog):
    """Like franka_description's robots/<arm>/<arm>.urdf.xacro: found, the others named."""
    package = tmp_path / "nested_description"
    for arm in ("fr3", "fer"):
        (package / "robots" / arm).mkdir(parents=True)
        shutil.copy(
            workspace / "bad_values_description" / "urdf" / "bad_values.urdf",
            package / "robots" / arm / f"{arm}.urdf",
        )
    (package / "package.xml").write_text("<package><name>nested_description</name></package>")
    caplog.set_level(logging.INFO)
    _, robot = load("package://nested_description", package_paths=[tmp_path])
    assert robot.source == package.resolve() / "robots" / "fer" / "fer.urdf"
    assert "holds 2 descriptions: using robots/fer/fer.urdf (others: robots/fr3/fr3.urdf)" in (
        caplog.text
    )


def _chain_urdf(name: str, links: int) -> str:
    """A URDF of ``links`` links chained by revolute joints."""
    inertial = (
        '<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" '
        'ixz="0" iyz="0"/></inertial>'
    )
    parts = [f'<link name="l{i}">{inertial}</link>' for i in range(links)]
    parts += [
        f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
        '<origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="10" velocity="1"/></joint>'
        for i in range(1, links)
    ]
    return f'<?xml version="1.0"?><robot name="{name}">{"".join(parts)}</robot>'


def test_a_package_with_a_materials_only_urdf_and_three_robots(tmp_path, caplog):
    """A materials-only common_properties.urdf (first alphabetically) and three robots:
    the one with the most links is chosen, unless a launch file names another; one log
    line names the choice, why, and the other candidates."""
    package = tmp_path / "three_robots_description"
    (package / "urdf").mkdir(parents=True)
    (package / "urdf" / "common_properties.urdf").write_text(
        '<?xml version="1.0"?><robot name="common"><material name="blue">'
        '<color rgba="0 0 1 1"/></material></robot>'
    )
    for name, links in (("robot_a", 2), ("robot_b", 4), ("robot_c", 3)):
        (package / "urdf" / f"{name}.urdf").write_text(_chain_urdf(name, links))
    (package / "package.xml").write_text("<package><name>three_robots_description</name></package>")
    caplog.set_level(logging.INFO)
    _, robot = load("package://three_robots_description", package_paths=[tmp_path])
    assert robot.source == package.resolve() / "urdf" / "robot_b.urdf"
    (line,) = [r.message for r in caplog.records if "holds 4 descriptions" in r.message]
    assert (
        "using urdf/robot_b.urdf (others: urdf/common_properties.urdf, urdf/robot_a.urdf, "
        "urdf/robot_c.urdf); chosen as the most links: 4" in line
    )
    (package / "launch").mkdir()
    (package / "launch" / "display.launch.py").write_text(
        'urdf = os.path.join(share, "urdf", "robot_c.urdf")\n'
    )
    caplog.clear()
    _, robot = load("package://three_robots_description", package_paths=[tmp_path])
    assert robot.source == package.resolve() / "urdf" / "robot_c.urdf"
    assert "chosen as named by the package's launch files or package.xml" in caplog.text


# --------------------------------------------------------------------------
# 6. Meshes
# --------------------------------------------------------------------------


def test_meshes_every_format_and_path_form(workspace, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    from pydrake.geometry import Convex, Role, SceneGraph

    plant = MultibodyPlant(0.001)
    scene_graph = SceneGraph()
    plant.RegisterAsSourceForSceneGraph(scene_graph)
    robot = load_robot(plant, workspace / "mesh_description")
    plant.Finalize()
    inspector = scene_graph.model_inspector()

    def shapes(link: str, role):
        ids = inspector.GetGeometries(
            plant.GetBodyFrameIdOrThrow(plant.GetBodyByName(link).index()), role
        )
        return [inspector.GetShape(i) for i in ids]

    def extent(shape) -> np.ndarray:  # [m] the size of the box around a collision hull
        assert isinstance(shape, Convex) and shape.source().path().name.endswith(".hull.obj")
        vertices = trimesh.load(shape.source().path()).vertices * shape.scale3()
        return vertices.max(axis=0) - vertices.min(axis=0)

    # Collada in centimetres: 4 cm body + plate from x = 4 to 6 cm, 6 cm tall: its hull.
    (base_hull,) = shapes("base_link", Role.kProximity)
    np.testing.assert_allclose(extent(base_hull), [0.08, 0.04, 0.06], atol=1e-9)
    # STL in millimetres with scale 0.001, shared by two links.
    for link in ("link2", "link3"):
        (rod,) = shapes(link, Role.kProximity)
        np.testing.assert_allclose(extent(rod), [0.02, 0.02, 0.1], atol=1e-9)
    (visual,) = shapes("base_link", Role.kIllustration)
    obj = Path(visual.source().path())
    mtl = obj.with_suffix(".mtl").read_text()
    red, textured = mtl_diffuse(obj.with_suffix(".mtl"))
    np.testing.assert_allclose(red, DAE_RED, atol=1 / 255)
    np.testing.assert_allclose(textured, [1, 1, 1])  # the texture's colour is not tinted
    (texture,) = [line.split()[1] for line in mtl.splitlines() if line.startswith("map_Kd")]
    assert (obj.parent / texture).is_file()
    # The OBJ with its MTL is passed through; the file:// path is taken as it is.
    (part,) = shapes("link1", Role.kIllustration)
    assert Path(part.source().path()) == (workspace / "mesh_description" / "meshes" / "part.obj")
    assert robot.name == "meshes"


def test_obj_without_normals_is_converted_with_its_material(tmp_path, monkeypatch):
    """Drake's renderers refuse an OBJ without normals: it is rewritten, material kept."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    from fixture_packages import write_obj_with_mtl

    from armando_drake.description.meshes import convert_mesh

    source = tmp_path / "bare.obj"
    write_obj_with_mtl(source, (0.03, 0.03, 0.05), normals=False)
    mesh = convert_mesh(source)
    assert mesh.converted and mesh.path.parent == tmp_path / "cache" / "armando_drake" / "meshes"
    assert "\nvn " in mesh.path.read_text()
    (diffuse,) = mtl_diffuse(mesh.path.with_suffix(".mtl"))
    np.testing.assert_allclose(diffuse, OBJ_GREEN, atol=1 / 255)
    assert not convert_mesh(source).converted  # cached
    np.testing.assert_allclose(np.ptp(mesh.vertices(), axis=0), [0.03, 0.03, 0.05])


def test_collada_materials_and_texture_are_sent_to_meshcat(workspace, tmp_path, monkeypatch):
    """The display sends Meshcat the converted OBJ with its MTL and its texture image."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    import base64
    import re

    from pydrake.geometry import Meshcat

    from armando_drake.description.viewer import make_display

    meshcat = Meshcat()
    visualizer, _ = make_display(workspace / "mesh_description", meshcat=meshcat)
    visualizer.Run(loop_once=True)
    messages = []
    for blob in re.findall(r"[A-Za-z0-9+/]{200,}={0,2}", meshcat.StaticHtml()):
        try:
            messages.append(base64.b64decode(blob))
        except ValueError:
            continue
    (body,) = [m for m in messages if b"mtl_library" in m and b"map_Kd" in m]
    r, g, b = (f"{c:.6g}".encode() for c in (0.8, 0.101961, 0.101961))  # DAE_RED in 8 bits
    assert b"Kd " + b" ".join((r, g, b)) in body
    assert b"map_Kd body-" in body and b"-texture1.png" in body
    assert b"data:image/png;base64,iVBORw0KGgo" in body  # the PNG itself, as a resource


def test_collada_materials_and_obj_mtl_show_in_the_camera_image(workspace, tmp_path, monkeypatch):
    """A camera looking down at the robot sees the Collada red, its blue texture, the OBJ green."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    from pydrake.geometry import (
        ClippingRange,
        ColorRenderCamera,
        DepthRange,
        DepthRenderCamera,
        MakeRenderEngineVtk,
        RenderCameraCore,
        RenderEngineVtkParams,
    )
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.sensors import CameraInfo, RgbdSensor

    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    scene_graph.AddRenderer("vtk", MakeRenderEngineVtk(RenderEngineVtkParams()))
    load_robot(plant, workspace / "mesh_description", xacro_args={})
    plant.Finalize()
    core = RenderCameraCore(
        "vtk", CameraInfo(160, 160, 0.9), ClippingRange(0.01, 10), RigidTransform()
    )
    # Above the base, looking down (-z), seeing the body, the plate and link1's part.
    X_WC = RigidTransform(RollPitchYaw(np.pi, 0, 0), [0.02, 0.0, 0.6])
    camera = builder.AddSystem(
        RgbdSensor(
            scene_graph.world_frame_id(),
            X_WC,
            ColorRenderCamera(core),
            DepthRenderCamera(core, DepthRange(0.01, 10)),
        )
    )
    builder.Connect(scene_graph.get_query_output_port(), camera.query_object_input_port())
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant.SetPositions(plant.GetMyMutableContextFromRoot(context), [0.0, -np.pi / 2, 0.0])
    image = camera.color_image_output_port().Eval(camera.GetMyContextFromRoot(context)).data
    pixels = image.reshape(-1, 4)[:, :3].astype(int)

    def count(rgb) -> int:
        return int((np.abs(pixels - np.asarray(rgb)).max(axis=1) <= 60).sum())

    red = np.round(np.asarray(DAE_RED) * 255)
    green = np.round(np.asarray(OBJ_GREEN) * 255)
    assert count(red) > 20, "no Collada colour in the image"
    assert count(TEXTURE_BLUE) > 5, "no Collada texture in the image"
    assert count(green) > 20, "no OBJ material colour in the image"


# --------------------------------------------------------------------------
# 7. Physically meaningless values
# --------------------------------------------------------------------------


def test_meaningless_values_are_repaired_with_a_warning_each(workspace):
    plant, robot = load(workspace / "bad_values_description")
    warnings = "\n".join(robot.warnings)
    swapped = robot.joint("swapped_limits")
    assert (swapped.lower, swapped.upper) == (-0.8, 1.2)
    assert "joint 'swapped_limits': lower limit 1.2 is above upper -0.8: swapped" in warnings
    assert robot.joint("effort_zero").effort == np.inf
    assert "joint 'effort_zero': effort=\"0\", which Gazebo takes as no effort limit" in warnings
    assert "link 'negative_mass': mass -0.5 kg is not physically meaningful" in warnings
    # Both weigh their 3 x 3 x 20 cm visual box at 1000 kg/m^3, named in one warning.
    assert (
        "2 link(s) declare no mass: each given the mass and inertia of its collision (else "
        "visual) geometry at 1000 kg/m^3, as MuJoCo's inertiafromgeom: zero_mass 0.18 kg "
        "(visual box), negative_mass 0.18 kg (visual box); 0.36 kg in all"
    ) in warnings
    assert "link 'bad_inertia': inertia" in warnings and "is not physically valid" in warnings
    for link in ("zero_mass", "negative_mass"):
        assert plant.GetBodyByName(link).default_mass() == pytest.approx(0.18)
    inertia = plant.GetBodyByName("bad_inertia").default_rotational_inertia()
    assert inertia.CouldBePhysicallyValid()
    joint = plant.GetJointByName("swapped_limits")
    assert (joint.position_lower_limits()[0], joint.position_upper_limits()[0]) == (-0.8, 1.2)


# --------------------------------------------------------------------------
# Every fixture: display, and 1 s of the world with no controller and with one
# --------------------------------------------------------------------------

FIXTURES = [
    # package, joints of its position controller, lines the display prints
    (
        "world_arm_description",
        2,
        [
            "Joints: shoulder [-2.00, 2.00], elbow [-2.50, 2.50]",
            "Welded to the world: base_footprint (fixed to the world link by 'world_joint')",
        ],
    ),
    (
        "gripper_description",
        3,
        [
            "base_pan [-inf, inf], shoulder [-1.50, 1.50], wrist [-inf, inf]",
            "Mimic: right_finger_joint = 1 * left_finger_joint + 0",
        ],
    ),
    ("control_forms_description", 3, ["Joints: joint1 [-2.00, 2.00], joint2 [-2.00, 2.00]"]),
    ("xacro_features_description", 3, ["Joints: joint_a [-1.20, 1.30], joint_b [-0.70, 0.90]"]),
    ("mesh_description", 3, ["Joints: joint1 [-3.00, 3.00], joint2 [-2.00, 2.00]"]),
    (
        "bad_values_description",
        3,
        ["swapped_limits [-0.80, 1.20]", "Welded to the world: base_link"],
    ),
]


def run(module: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", module, *args], capture_output=True, text=True, timeout=300
    )


@pytest.mark.parametrize("package, joints, lines", FIXTURES, ids=[f[0] for f in FIXTURES])
def test_every_fixture_displays_and_simulates(workspace, tmp_path, package, joints, lines):
    description = str(workspace / package)
    common = ["--description", description, "--package-path", str(workspace)]
    shown = run("armando_drake.display", *common, "--loop-once")
    assert shown.returncode == 0, shown.stderr
    for line in lines:
        assert line in shown.stdout
    assert "Traceback" not in shown.stderr
    for controller in ("none", "position"):
        out = tmp_path / controller
        targets = [[0.1] * joints]
        result = run(
            "armando_drake.world", *common, "--controller", controller, "--duration", "1",
            "--no-meshcat", "--realtime-rate", "0", "--quiet", "--no-replay",
            "--output", str(out), "--set", f"sequencer: {{targets: {targets}, period: 1.0}}",
            "--set", "actuators: {kp: 50.0, kd: 2.0}",
        )  # fmt: skip
        assert result.returncode == 0, result.stderr
        summary = json.loads((out / "summary.json").read_text())
        assert summary["sim_time"] == pytest.approx(1.0)
        assert summary["controller"] == controller
