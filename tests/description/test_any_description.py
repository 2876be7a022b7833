"""Descriptions other than our own: the course's STL package and a xacro arm with a gripper."""

import json
import subprocess
import sys
import textwrap

import pytest
from conftest import make_mini_package


def run(module: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", module, *args], capture_output=True, text=True, timeout=300
    )


def test_display_loads_the_course_package(course_package):
    result = run("armando_drake.display", "--description", str(course_package), "--loop-once")
    assert result.returncode == 0, result.stderr
    assert "Joints: j0 [-2.57, 2.57], j1 [-3.14, 3.14], j2 [-3.14, 3.14], j3 [-3.14, 3.14]" in (
        result.stdout
    )


def test_world_drives_the_course_package_to_the_seed_targets(course_package, tmp_path):
    result = run(
        "armando_drake.world",
        "--no-meshcat",
        "--realtime-rate",
        "0",
        "--description",
        str(course_package),
        "--output",
        str(tmp_path),
        "--quiet",
    )
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert len(summary["steps"]) == 5
    assert max(step["final_error"] for step in summary["steps"]) <= 0.01
    # The importer said what it repaired.
    assert "link 'base_link': inertia" in result.stderr + result.stdout


GRIPPER = """
<link name="finger">
  <visual><geometry><box size="0.01 0.02 0.04"/></geometry></visual>
  <collision><geometry><box size="0.01 0.02 0.04"/></geometry></collision>
  <inertial><mass value="0.02"/>
    <inertia ixx="1e-6" iyy="1e-6" izz="1e-6" ixy="0" ixz="0" iyz="0"/></inertial>
</link>
<joint name="finger_joint" type="prismatic">
  <parent link="lower"/><child link="finger"/><origin xyz="0 0 0.12"/><axis xyz="1 0 0"/>
  <limit lower="0" upper="0.03" effort="20" velocity="0.1"/>
</joint>
<xacro:include filename="$(find mini_description)/urdf/mini.ros2_control.xacro"/>
<xacro:mini_ros2_control name="MiniArm" initial_q1="$(arg initial_q1)"/>
"""

ROS2_CONTROL_MACRO = """<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:macro name="mini_ros2_control" params="name initial_q1">
    <ros2_control name="${name}" type="system">
      <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
      <xacro:macro name="joint_interfaces" params="joint initial">
        <joint name="${joint}">
          <command_interface name="position"/>
          <state_interface name="position"><param name="initial_value">${initial}</param>
          </state_interface>
          <state_interface name="velocity"/>
        </joint>
      </xacro:macro>
      <xacro:joint_interfaces joint="q1" initial="${initial_q1}"/>
      <xacro:joint_interfaces joint="q2" initial="0.0"/>
      <xacro:joint_interfaces joint="finger_joint" initial="0.0"/>
    </ros2_control>
  </xacro:macro>
</robot>
"""

CONTROLLERS = """
/**:
  controller_manager:
    ros__parameters:
      update_rate: 200
      joint_state_broadcaster:
        type: joint_state_broadcaster/JointStateBroadcaster
      arm_controller:
        type: forward_command_controller/ForwardCommandController
/**/arm_controller:
  ros__parameters:
    joints: [q1, q2, finger_joint]
    interface_name: position
"""


def test_xacro_arm_with_gripper_ros2_control_macro_and_namespaced_yaml(tmp_path):
    package = make_mini_package(tmp_path, GRIPPER)
    top = package / "urdf" / "mini.urdf.xacro"
    top.write_text(
        top.read_text().replace(
            '<xacro:arg name="prefix" default=""/>',
            '<xacro:arg name="prefix" default=""/>\n  <xacro:arg name="initial_q1" default="0.2"/>',
        )
    )
    (package / "urdf" / "mini.ros2_control.xacro").write_text(ROS2_CONTROL_MACRO)
    (package / "config").mkdir()
    (package / "config" / "mini_controllers.yaml").write_text(textwrap.dedent(CONTROLLERS))
    scenario = tmp_path / "mini.yaml"
    scenario.write_text(
        textwrap.dedent(
            f"""
            robot:
              description: package://mini_description/urdf/mini.urdf.xacro
              package_paths: [{tmp_path}]
              xacro_args: {{initial_q1: "0.3"}}
            controllers:
              activate: [joint_state_broadcaster, arm_controller]
            sequencer: !PositionTargets
              targets: [[0.3, 0.0, 0.0], [0.8, -0.6, 0.02], [-0.5, 0.9, 0.01]]
              period: 2.0
            """
        )
    )
    out = tmp_path / "out"
    result = run(
        "armando_drake.world",
        "--scenario",
        str(scenario),
        "--no-meshcat",
        "--realtime-rate",
        "0",
        "--output",
        str(out),
    )
    assert result.returncode == 0, result.stderr
    assert "loaded controller 'arm_controller' of type " in result.stdout
    assert "at 200 Hz" in result.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["joint_names"] == ["q1", "q2", "finger_joint"]
    errors = [step["final_error"] for step in summary["steps"]]
    assert len(errors) == 3 and max(errors) <= 0.01, errors
    rows = (out / "joint_states.csv").read_text().splitlines()
    assert rows[0].startswith("time,q1_position,q1_velocity,q1_effort,q2_position")
    assert abs(len(rows) - 1 - 6.0 * 200) <= 1
    first = [float(v) for v in rows[1].split(",")]
    assert first[1] == pytest.approx(0.3)  # initial_value from the xacro:arg
