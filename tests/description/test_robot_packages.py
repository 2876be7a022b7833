"""Robot packages in the layouts and controller files public ROS packages use: each one
displays, and the world's default run (no --controller) drives the package's own arm
controller to the seed-style targets, exit 0."""

import json
import subprocess
import sys

import pytest
from fixture_packages import (
    ARM_JOINTS,
    ROS1_TRANSMISSIONS,
    arm_xacro,
    ros2_control_xacro,
    write_package,
)

JSB = "joint_state_broadcaster/JointStateBroadcaster"
JTC = "joint_trajectory_controller/JointTrajectoryController"
FCC = "forward_command_controller/ForwardCommandController"


def run(module: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", module, *args], capture_output=True, text=True, timeout=300
    )


def arm_package(root, name: str, controllers: dict[str, str], **files: str):
    """A light arm ``name`` with a ros2_control block and the controller files
    ``controllers`` (path -> text)."""
    include = f"$(find {name})/urdf/arm.ros2_control.xacro"
    return write_package(
        root,
        name,
        {
            f"urdf/{name}.urdf.xacro": arm_xacro(name, include=include),
            "urdf/arm.ros2_control.xacro": ros2_control_xacro(),
            **controllers,
            **files,
        },
    )


# --------------------------------------------------------------------------------------
# One package per pattern


def repeated_node_keys(root):
    # `/**:` three times in one file: ROS 2 merges them into one node key.
    return (
        arm_package(
            root,
            "repeated_description",
            {
                "config/repeated_controllers.yaml": f"""\
                /**:
                  controller_manager:
                    ros__parameters:
                      update_rate: 200
                /**:
                  controller_manager:
                    ros__parameters:
                      joint_state_broadcaster:
                        type: {JSB}
                      arm_controller:
                        type: {JTC}
                /**:
                  arm_controller:
                    ros__parameters:
                      joints: [j1, j2, j3]
                      command_interfaces: [position]
                      state_interfaces: [position, velocity]
                """
            },
        ),
        [],
        ["'arm_controller'", "at 200 Hz"],
    )


def undeclared_parameters(root):
    # Humble's state_publish_rate, the forward controller's interface_name, gains and
    # constraints of names that are not joints, old PID keys: Jazzy declares none of them.
    return (
        arm_package(
            root,
            "legacy_description",
            {
                "config/legacy_controllers.yaml": f"""\
                controller_manager:
                  ros__parameters:
                    update_rate: 100
                    joint_state_broadcaster:
                      type: {JSB}
                    arm_controller:
                      type: {JTC}
                joint_state_broadcaster:
                  ros__parameters:
                    publish_rate: 50
                arm_controller:
                  ros__parameters:
                    joints: [j1, j2, j3]
                    interface_name: position
                    command_interfaces: [position]
                    state_interfaces: [position, velocity]
                    state_publish_rate: 100.0
                    action_monitor_rate: 20.0
                    constraints:
                      stopped_velocity_tolerance: 0.0
                      goal_time: 0.0
                      tool0: {{goal: 0.1}}
                      j1: {{trajectory: 0.0, goal: 0.0, path: 1.0}}
                    gains:
                      j1: {{p: 100.0, normalize_error: true}}
                """
            },
        ),
        [],
        ["arm_controller.ros__parameters.state_publish_rate: " + JTC],
    )


def type_in_own_parameters(root):
    # No controller_manager node: each controller's type in its own ros__parameters (the
    # current ros2_control demos, spawner --param-file), joints named through a launch
    # argument the package's launch file declares.
    return (
        arm_package(
            root,
            "own_type_description",
            {
                "config/arm_controllers.yaml": f"""\
                joint_state_broadcaster:
                  ros__parameters:
                    type: {JSB}
                    update_rate: 50
                forward_position_controller:
                  ros__parameters:
                    type: {FCC}
                    joints:
                      - $(var joint_prefix)1
                      - $(var joint_prefix)2
                      - $(var joint_prefix)3
                    interface_name: position
                """,
                "launch/arm.launch.py": """\
                from launch.actions import DeclareLaunchArgument
                ARGUMENTS = [
                    DeclareLaunchArgument(
                        "joint_prefix", default_value="j", description="joint names' prefix"
                    ),
                ]
                """,
            },
        ),
        [],
        ["'forward_position_controller'"],
    )


def split_ros1_files(root):
    # ROS 1: a joint_state_controller file and the arm's, loaded one after the other.
    gazebo = (
        '  <gazebo><plugin name="gazebo_ros_control" filename="libgazebo_ros_control.so">'
        "<robotNamespace>/arm</robotNamespace></plugin></gazebo>\n"
    )
    package = write_package(
        root,
        "split_description",
        {
            "urdf/split.urdf.xacro": arm_xacro("split", extra=ROS1_TRANSMISSIONS + gazebo),
            "config/joint_state_controller.yaml": """\
                arm:
                  joint_state_controller:
                    type: joint_state_controller/JointStateController
                    publish_rate: 50
                """,
            "config/arm_controller.yaml": """\
                arm:
                  arm_controller:
                    type: position_controllers/JointTrajectoryController
                    joints: [j1, j2, j3]
                    constraints: {goal_time: 0.6, stopped_velocity_tolerance: 0.05}
                    state_publish_rate: 25
                    action_monitor_rate: 10
                """,
        },
    )
    return package, [], ["'arm_controller'", "'joint_state_controller'"]


def install_rule_paths(root):
    # The source keeps description/ and bringup/; $(find) names the installed layout.
    name = "install_demo"
    include = f"$(find {name})/ros2_control/arm.ros2_control.xacro"
    inc = f'  <xacro:include filename="$(find {name})/urdf/inc/limits.xacro"/>\n'
    package = write_package(
        root,
        name,
        {
            "CMakeLists.txt": """\
                cmake_minimum_required(VERSION 3.16)
                project(install_demo LANGUAGES CXX)
                install(
                  DIRECTORY description/urdf description/ros2_control
                  DESTINATION share/${PROJECT_NAME}
                )
                install(DIRECTORY bringup/config DESTINATION share/${PROJECT_NAME})
                install(FILES bringup/extra/limits.xacro
                  DESTINATION share/${PROJECT_NAME}/urdf/inc)  # a file into a folder
                """,
            "description/urdf/arm.urdf.xacro": arm_xacro(name, include=include, extra=inc),
            "description/ros2_control/arm.ros2_control.xacro": ros2_control_xacro(),
            "bringup/extra/limits.xacro": (
                '<?xml version="1.0"?>\n<robot xmlns:xacro="http://www.ros.org/wiki/xacro"/>\n'
            ),
            "bringup/config/arm_controllers.yaml": f"""\
                controller_manager:
                  ros__parameters:
                    joint_state_broadcaster: {{type: {JSB}}}
                    joint_trajectory_controller: {{type: {JTC}}}
                joint_trajectory_controller:
                  ros__parameters:
                    joints: [j1, j2, j3]
                    command_interfaces: [position]
                    state_interfaces: [position, velocity]
                """,
        },
    )
    return package, [], ["'joint_trajectory_controller'"]


def several_files(root):
    # Two files given in order, the later winning: it adds a joint and sets the rate.
    package = arm_package(
        root,
        "layered_description",
        {
            "config/layered_controllers.yaml": f"""\
                controller_manager:
                  ros__parameters:
                    update_rate: 100
                    joint_state_broadcaster: {{type: {JSB}}}
                    arm_controller: {{type: {JTC}}}
                arm_controller:
                  ros__parameters:
                    joints: [j1, j2]
                    command_interfaces: [position]
                    state_interfaces: [position, velocity]
                """,
            "config/site/overrides.yaml": """\
                controller_manager:
                  ros__parameters:
                    update_rate: 250
                arm_controller:
                  ros__parameters:
                    joints: [j1, j2, j3]
                """,
        },
    )
    files = [
        package / "config" / "layered_controllers.yaml",
        package / "config/site/overrides.yaml",
    ]
    args = [arg for path in files for arg in ("--param-file", str(path))]
    return package, args, ["at 250 Hz", "'arm_controller'"]


def wildcard_and_qualified_names(root):
    # Fully qualified node names in a namespace, the type from a wildcard key, the
    # joints from the qualified one; another namespace's node is not this manager's.
    return (
        arm_package(
            root,
            "namespaced_description",
            {
                "config/namespaced_controllers.yaml": f"""\
                /robot/controller_manager:
                  ros__parameters:
                    update_rate: 100
                    joint_state_broadcaster:
                      type: {JSB}
                /**/arm_controller:
                  ros__parameters:
                    type: {JTC}
                    command_interfaces: [position]
                    state_interfaces: [position, velocity]
                /robot/arm_controller:
                  ros__parameters:
                    joints: [j1, j2, j3]
                /other/arm_controller:
                  ros__parameters:
                    joints: [x1, x2]
                /*:
                  ros__parameters:
                    use_sim_time: true
                """
            },
        ),
        [],
        ["'arm_controller'"],
    )


PATTERNS = [
    repeated_node_keys,
    undeclared_parameters,
    type_in_own_parameters,
    split_ros1_files,
    install_rule_paths,
    several_files,
    wildcard_and_qualified_names,
]


@pytest.mark.parametrize("pattern", PATTERNS, ids=[p.__name__ for p in PATTERNS])
def test_package_displays_and_its_default_run_reaches_the_targets(pattern, tmp_path):
    package, args, expected = pattern(tmp_path / "src")
    shown = run("armando_drake.display", "--description", str(package), "--loop-once")
    assert shown.returncode == 0, shown.stderr
    assert all(f"{joint} [-2.00, 2.00]" in shown.stdout for joint in ARM_JOINTS), shown.stdout
    out = tmp_path / "out"
    result = run(
        "armando_drake.world", "--description", str(package), *args,
        "--set", "sequencer: {period: 1.2}", "--duration", "6",
        "--no-meshcat", "--realtime-rate", "0", "--no-replay", "--output", str(out),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    log = result.stdout + result.stderr
    for text in expected:
        assert text in log, (text, log[-3000:])
    summary = json.loads((out / "summary.json").read_text())
    assert summary["joint_names"] == list(ARM_JOINTS)
    errors = [step["final_error"] for step in summary["steps"]]
    assert len(errors) == 5 and max(errors) <= 0.01, errors


@pytest.mark.parametrize("pattern", [undeclared_parameters, type_in_own_parameters])
def test_controller_none_loads_the_same_files(pattern, tmp_path):
    package, args, _ = pattern(tmp_path / "src")
    result = run(
        "armando_drake.world", "--description", str(package), *args, "--controller", "none",
        "--duration", "0.5", "--no-meshcat", "--realtime-rate", "0", "--quiet",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr


def test_controller_options_map_to_the_files_controller_of_that_kind(tmp_path):
    package, _, _ = undeclared_parameters(tmp_path / "src")
    result = run(
        "armando_drake.world", "--description", str(package), "--controller", "trajectory",
        "--duration", "0.5", "--no-meshcat", "--realtime-rate", "0",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "activated controller 'arm_controller'" in result.stdout
    result = run(
        "armando_drake.world", "--description", str(package), "--controller", "position",
        "--duration", "0.5", "--no-meshcat", "--realtime-rate", "0",
    )  # fmt: skip
    assert result.returncode == 2
    assert "asks for a position_controllers/JointGroupPositionController" in result.stderr


def test_gripper_without_a_supported_controller_says_so_and_holds(tmp_path):
    finger = """\
        <?xml version="1.0"?>
        <robot name="gripper">
          <link name="palm"><inertial><mass value="0.2"/>
            <inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>
          <link name="finger"><visual><geometry><box size="0.01 0.02 0.04"/></geometry></visual>
            <inertial><mass value="0.02"/>
            <inertia ixx="1e-6" iyy="1e-6" izz="1e-6" ixy="0" ixz="0" iyz="0"/></inertial></link>
          <joint name="finger_joint" type="prismatic">
            <parent link="palm"/><child link="finger"/><origin xyz="0 0 0.05"/>
            <axis xyz="0 0 1"/><limit lower="0" upper="0.04" effort="20" velocity="0.1"/>
          </joint>
        </robot>
        """
    package = write_package(
        tmp_path / "src",
        "gripper_description",
        {
            "urdf/gripper.urdf": finger,
            "config/gripper_controllers.yaml": f"""\
                controller_manager:
                  ros__parameters:
                    joint_state_broadcaster: {{type: {JSB}}}
                    gripper_controller:
                      type: position_controllers/GripperActionController
                gripper_controller:
                  ros__parameters:
                    joint: finger_joint
                """,
        },
    )
    out = tmp_path / "out"
    result = run(
        "armando_drake.world", "--description", str(package), "--duration", "2",
        "--no-meshcat", "--realtime-rate", "0", "--no-replay", "--output", str(out),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert (
        "defines no arm controller the simulation supports (not supported: gripper_controller "
        "(position_controllers/GripperActionController)): the arm holds its start position"
    ) in result.stdout
    from armando_drake.outputs.logger import read_joint_states

    states = read_joint_states(out / "joint_states.csv", ["finger_joint"])
    assert abs(states.position[-1][0] - states.position[0][0]) < 1e-3  # held, not fallen
